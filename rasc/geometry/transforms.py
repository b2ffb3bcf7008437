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
                             atol: float = RIGID_ATOL) -> np.ndarray:
    """Check that ``T`` is a 4×4 rigid transform; return it as a float array.

    Checks: shape (4, 4); finite; ``RᵀR = I`` and ``det R = +1`` within ``atol``
    (element-wise); last row ``0 0 0 1`` within ``atol``. Raises :class:`InputError`
    with a message that starts with ``name``.
    """
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not a numeric 4x4 matrix") from None
    if T.shape != (4, 4):
        raise InputError(f"{name}: expected a 4x4 matrix, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise InputError(f"{name}: contains NaN or infinity")
    if np.max(np.abs(T[3] - [0.0, 0.0, 0.0, 1.0])) > atol:
        raise InputError(f"{name}: last row is {T[3].tolist()}, expected [0, 0, 0, 1]")
    R = T[:3, :3]
    with np.errstate(over="ignore", invalid="ignore"):   # huge entries: ortho = inf, refused
        ortho = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if not ortho <= atol:
        raise InputError(
            f"{name}: rotation part is not orthonormal (max |RᵀR − I| = {ortho:.3g} > {atol:g})")
    det = float(np.linalg.det(R))
    if abs(det - 1.0) > atol:
        raise InputError(f"{name}: rotation part has determinant {det:.6g}, expected +1")
    return T


def skew(v: np.ndarray) -> np.ndarray:
    """``[v]×`` for vectors (..., 3) → (..., 3, 3), so that ``[v]× x = v × x``."""
    v = np.asarray(v, dtype=float)
    S = np.zeros(v.shape + (3,))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S
