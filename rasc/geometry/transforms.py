"""Rotations and rigid transforms, batched over leading axes.

Conventions (README "Frames"): ``T_a_from_b`` is the 4×4 transform that maps coordinates
in frame b into frame a, ``q_a = T_a_from_b @ q_b``; so
``T_a_from_b @ T_b_from_c == T_a_from_c``. Rotations are 3×3 matrices; axis-angle
vectors ("rotvec", canonical coordinates of so(3)) have length equal to the angle in
radians. exp/log go through :class:`scipy.spatial.transform.Rotation`, which is robust at
angle 0 and at π (no hand-written ``φ / (2 sin φ)``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from rasc.errors import InputError

#: Default tolerance for :func:`validate_rigid_transform`: the largest element of
#: ``RᵀR − I`` and of ``det R − 1`` allowed. Measured poses printed with six
#: significant digits (Tabb's data) reach ~3e-6, so 1e-4 accepts honest data and still
#: rejects any matrix that is visibly not a rotation (a 0.01 scale error is 2e-2).
RIGID_ATOL = 1e-4


def matrix_from_rotvec(rotvec: np.ndarray) -> np.ndarray:
    """exp: axis-angle vectors (..., 3) → rotation matrices (..., 3, 3)."""
    rotvec = np.asarray(rotvec, dtype=float)
    flat = rotvec.reshape(-1, 3)
    return Rotation.from_rotvec(flat).as_matrix().reshape(*rotvec.shape[:-1], 3, 3)


def rotvec_from_matrix(R: np.ndarray) -> np.ndarray:
    """log: rotation matrices (..., 3, 3) → axis-angle vectors (..., 3), angle in [0, π].

    Inputs should be rotations to round-off; scipy projects slightly non-orthogonal
    matrices to the nearest rotation.
    """
    R = np.asarray(R, dtype=float)
    flat = R.reshape(-1, 3, 3)
    return Rotation.from_matrix(flat).as_rotvec().reshape(*R.shape[:-2], 3)


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Rotation angle in radians, (..., 3, 3) → (...), accurate near 0 and π."""
    return np.linalg.norm(rotvec_from_matrix(R), axis=-1)


def project_to_rotation(M: np.ndarray) -> np.ndarray:
    """Nearest rotation matrix (Frobenius norm) to each 3×3 in ``M`` (..., 3, 3), via SVD."""
    M = np.asarray(M, dtype=float)
    U, _, Vt = np.linalg.svd(M)
    d = np.sign(np.linalg.det(U @ Vt))
    D = np.zeros(M.shape[:-2] + (3,))
    D[..., 0] = 1.0
    D[..., 1] = 1.0
    D[..., 2] = d
    return (U * D[..., None, :]) @ Vt


def make_transform(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Rigid transform(s) (..., 4, 4) from rotation(s) (..., 3, 3) and translation(s) (..., 3)."""
    R = np.asarray(R, dtype=float)
    t = np.asarray(t, dtype=float)
    shape = np.broadcast_shapes(R.shape[:-2], t.shape[:-1])
    T = np.zeros(shape + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def invert_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transform(s) (..., 4, 4): ``T_b_from_a`` from ``T_a_from_b``."""
    T = np.asarray(T, dtype=float)
    R_t = np.swapaxes(T[..., :3, :3], -1, -2)
    t = -(R_t @ T[..., :3, 3, None])[..., 0]
    return make_transform(R_t, t)


def transform_points(T_a_from_b: np.ndarray, p_b: np.ndarray) -> np.ndarray:
    """Apply ``T_a_from_b`` (4, 4) to points ``p_b`` (N, 3) → ``p_a`` (N, 3)."""
    T_a_from_b = np.asarray(T_a_from_b, dtype=float)
    p_b = np.asarray(p_b, dtype=float)
    return p_b @ T_a_from_b[:3, :3].T + T_a_from_b[:3, 3]


def transform_from_rotvec_translation(rotvec: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The 4×4 transform of a rotation vector (radians) and a translation."""
    return make_transform(matrix_from_rotvec(rotvec), t)


def rotation_error_deg(R_est: np.ndarray, R_true: np.ndarray) -> np.ndarray:
    """Angle of ``R_estᵀ R_true`` in degrees (geodesic distance), batched."""
    R_est = np.asarray(R_est, dtype=float)
    R_true = np.asarray(R_true, dtype=float)
    return np.degrees(rotation_angle(np.swapaxes(R_est, -1, -2) @ R_true))


def is_rigid_transform(T: np.ndarray, atol: float = RIGID_ATOL) -> bool:
    """True when ``T`` passes :func:`validate_rigid_transform` (a proper rotation within
    ``atol``, last row ``0 0 0 1``), else False."""
    try:
        validate_rigid_transform(T, atol=atol)
    except InputError:
        return False
    return True


def validate_rigid_transform(T: np.ndarray, *, name: str = "transform",
                             atol: float = RIGID_ATOL, stacked: int = 0, rigid: bool = True,
                             hint: str = "") -> np.ndarray:
    """The ONE check of rigid transforms: ``T`` (4, 4), or with ``stacked`` = k a stack of
    them with k leading indices ((n, 4, 4) for k = 1); return it as a float array.

    Checks, in order: numeric; shape; finite; last row ``0 0 0 1`` within ``atol``; a
    proper rotation block (det > 0); with ``rigid`` also ``RᵀR = I`` and ``det R = +1``
    within ``atol`` (element-wise). ``rigid=False`` accepts the paper's literal eq. 13
    noise (a rotation block near, not on, SO(3)). Raises :class:`InputError` with one line
    that starts with ``name`` (``name[i, j]`` for the first offending matrix of a stack);
    ``hint`` is appended to the rigidity messages. Each check is one reduction over the
    stack; the offending index is looked for only on failure.
    """
    lead = ["S", "n"][-stacked:] if 0 < stacked <= 2 else ["m"] * stacked
    want = f"shape ({', '.join(lead)}, 4, 4)" if stacked else "a 4x4 matrix"
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        what = "array of 4x4 transforms" if stacked else "4x4 matrix"
        raise InputError(f"{name}: not a numeric {what}") from None
    if T.ndim != stacked + 2 or T.shape[-2:] != (4, 4):
        raise InputError(f"{name}: expected {want}, got shape {T.shape}")

    def first(bad: np.ndarray) -> tuple[tuple[int, ...], str]:
        k = tuple(int(x) for x in np.argwhere(bad)[0]) if stacked else ()
        return k, f"{name}[{', '.join(map(str, k))}]" if stacked else name

    if not np.isfinite(T).all():
        raise InputError(f"{first(~np.isfinite(T).all(axis=(-1, -2)))[1]}: contains NaN "
                         "or infinity")
    last = np.abs(T[..., 3, :] - [0.0, 0.0, 0.0, 1.0])
    if last.size and last.max() > atol:
        k, where = first(last.max(axis=-1) > atol)
        raise InputError(f"{where}: last row is {T[k][3].tolist()}, expected [0, 0, 0, 1]")
    R = T[..., :3, :3]
    det = np.linalg.det(R)
    if not (det > 0).all():
        k, where = first(~(det > 0))
        raise InputError(f"{where}: rotation part has determinant {det[k]:.6g}; a pose "
                         "needs a rotation (det +1)")
    if rigid and R.size:
        with np.errstate(over="ignore", invalid="ignore"):  # huge entries: inf, refused
            ortho = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-1, -2))
        if not (ortho <= atol).all():
            k, where = first(~(ortho <= atol))
            raise InputError(f"{where}: rotation part is not orthonormal (max |RᵀR − I| = "
                             f"{ortho[k]:.3g} > {atol:g}){hint}")
        if not (np.abs(det - 1.0) <= atol).all():
            k, where = first(~(np.abs(det - 1.0) <= atol))
            raise InputError(f"{where}: rotation part has determinant {det[k]:.6g}, "
                             f"expected +1{hint}")
    return T


def skew(v: np.ndarray) -> np.ndarray:
    """``[v]×`` for vectors (..., 3) → (..., 3, 3), so that ``[v]× x = v × x``."""
    v = np.asarray(v, dtype=float)
    S = np.zeros(v.shape + (3,))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S
