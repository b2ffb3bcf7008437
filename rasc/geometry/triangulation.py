"""Linear stereo triangulation, docs/METHOD.md §6 (paper section 5, eq. 15–19).

Each eye's projection ``P = K [I|0] T_cam_from_base`` (3×4, rows ``p1 p2 p3``, last
column ``p14 p24 p34``) maps base coordinates ``x`` to the image point ``(u, v)`` by
eq. 16–18, ``u = (p1·x + p14) / (p3·x + p34)``, ``v = (p2·x + p24) / (p3·x + p34)``
(**erratum**: the paper prints ``a14`` in both denominators; it is ``a34``). Multiplying
out gives two linear equations per eye (eq. 19)::

    (u p3 − p1) · x = p14 − u p34
    (v p3 − p2) · x = p24 − v p34

Stacking both eyes gives ``A x = b`` with ``A`` 4×3 for every point.

* ``method="ls"``: ordinary least squares, the normal equations ``AᵀA x = Aᵀb`` solved as
  a batch of 3×3 systems (``np.linalg.solve`` over all points at once).
* ``method="tls"``: total least squares of the homogeneous 4×4 system
  ``[A | −b] (x, 1) = 0``: the right singular vector of the smallest singular value,
  batched SVD, divided by its last component. This is the system OpenCV's
  ``triangulatePoints`` solves, so on noisy data the two agree. No coordinate
  normalisation is applied (the paper's system as written).

Both are exact on noise-free data; they differ only in how noise is weighted.

Degenerate geometry. A point is determined only if the two rays meet at an angle: the
*parallax* of a point is the angle its two camera centres subtend at it (for noise-free
data, the angle between the rays). Parallel rays (a point at infinity, or along the
baseline) and a zero baseline both give parallax 0. Points with parallax below
``min_parallax_deg`` (default :data:`MIN_PARALLAX_DEG`) are degenerate; by default
:func:`triangulate` raises :class:`DegenerateDataError` naming the first one, or, with
``on_degenerate="nan"``, returns NaN in their rows and solves the others (a per-point
flag). Points behind a camera are not rejected (cheirality is not checked).
"""

from __future__ import annotations

import numpy as np

from rasc.errors import DegenerateDataError, InputError

#: Default smallest parallax, degrees. At 1e-3° (1.7e-5 rad) a direction error of
#: 0.02 px at a 1000 px focal length (2e-5 rad, the best corner detection there is)
#: already changes the depth by more than 100 %: the depth is not determined by images.
MIN_PARALLAX_DEG = 1e-3

METHODS = ("ls", "tls")


def _projections(P, n: int, name: str) -> np.ndarray:
    try:
        P = np.asarray(P, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not a numeric array") from None
    if P.shape == (3, 4):
        P = P[None]
    elif P.shape != (n, 3, 4):
        raise InputError(f"{name}: expected shape (3, 4) or ({n}, 3, 4), got {P.shape}")
    bad = ~np.all(np.isfinite(P), axis=(1, 2))
    if np.any(bad):
        raise InputError(f"{name}[{int(np.argmax(bad))}]: contains NaN or infinity")
    M = P[:, :, :3]
    det = np.linalg.det(M)
    scale = np.prod(np.linalg.norm(M, axis=2), axis=1)
    singular = ~(np.abs(det) > 1e-12 * scale)  # rows of M (nearly) linearly dependent
    if np.any(singular):
        raise InputError(
            f"{name}[{int(np.argmax(singular))}]: left 3x3 block is singular, "
            f"not a finite camera")
    return P


def _image_points(uv, name: str) -> np.ndarray:
    try:
        uv = np.asarray(uv, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not a numeric array") from None
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise InputError(f"{name}: expected shape (N, 2), got {uv.shape}")
    bad = ~np.all(np.isfinite(uv), axis=1)
    if np.any(bad):
        raise InputError(f"{name}[{int(np.argmax(bad))}]: contains NaN or infinity")
    return uv


def _rows(P: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Eq. 19 for one eye as homogeneous rows (N, 2, 4): ``(u p3 − p1)``, ``(v p3 − p2)``."""
    u, v = uv[:, 0, None], uv[:, 1, None]
    return np.stack([u * P[:, 2] - P[:, 0], v * P[:, 2] - P[:, 1]], axis=1)


def _centres(P: np.ndarray) -> np.ndarray:
    """Camera centres ``C`` with ``P (C, 1) = 0``: ``C = −M⁻¹ p4`` (N or 1, 3)."""
    return -np.linalg.solve(P[:, :, :3], P[:, :, 3:])[..., 0]


def _sin_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|sin| of the angle between the lines along ``a`` and ``b`` (…, 3); 0 if either is 0."""
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    norms = np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = cross / norms
    return np.where(norms > 0.0, s, 0.0)


def triangulate(P_left: np.ndarray, P_right: np.ndarray, uv_left: np.ndarray,
                uv_right: np.ndarray, method: str = "ls", *,
                min_parallax_deg: float = MIN_PARALLAX_DEG,
                on_degenerate: str = "raise") -> np.ndarray:
    """Triangulate matched image points from two projections (eq. 15–19, erratum a34).

    Parameters
    ----------
    P_left, P_right : array-like, shape (3, 4) or (N, 3, 4)
        Projection from the common frame (base) to each eye's pixels; one shared
        matrix, or one per point (each point seen at its own pan/tilt).
    uv_left, uv_right : array-like, shape (N, 2)
        Ideal (undistorted) pixel coordinates, row k of both the same point.
    method : {"ls", "tls"}
        Ordinary or total least squares (module docstring).
    min_parallax_deg : float
        Points whose parallax is smaller are degenerate (module docstring).
    on_degenerate : {"raise", "nan"}
        Raise :class:`DegenerateDataError`, or return NaN rows for degenerate points.

    Returns
    -------
    p : ndarray, shape (N, 3)
        Points in the frame the projections start from.
    """
    if method not in METHODS:
        raise InputError(f"method: expected one of {METHODS}, got {method!r}")
    if on_degenerate not in ("raise", "nan"):
        raise InputError(f"on_degenerate: expected 'raise' or 'nan', got {on_degenerate!r}")
    uv_left = _image_points(uv_left, "uv_left")
    uv_right = _image_points(uv_right, "uv_right")
    n = uv_left.shape[0]
    if uv_right.shape[0] != n:
        raise InputError(f"uv_right: {uv_right.shape[0]} points, uv_left has {n}")
    P_left = _projections(P_left, n, "P_left")
    P_right = _projections(P_right, n, "P_right")

    H = np.concatenate([_rows(P_left, uv_left), _rows(P_right, uv_right)], axis=1)  # (N,4,4)
    A, b = H[:, :, :3], -H[:, :, 3]

    # Parallel rays make A rank 2 (every row is orthogonal to the common direction):
    # screen them out before solving, by the angle between the rays
    # d = M⁻¹ (u, v, 1) (the rows of A for one eye are orthogonal to its ray d).
    d_left = np.cross(A[:, 0], A[:, 1])
    d_right = np.cross(A[:, 2], A[:, 3])
    sin_min = np.sin(np.radians(min_parallax_deg))
    good = _sin_angle(d_left, d_right) >= sin_min

    p = np.full((n, 3), np.nan)
    if np.any(good):
        if method == "ls":
            Ag, bg = A[good], b[good]
            At = np.swapaxes(Ag, 1, 2)
            p[good] = np.linalg.solve(At @ Ag, (At @ bg[:, :, None]))[:, :, 0]
        else:
            _, _, Vt = np.linalg.svd(H[good])
            h = Vt[:, -1, :]
            with np.errstate(divide="ignore", invalid="ignore"):
                p[good] = h[:, :3] / h[:, 3:]
    # Parallax at the solution: the angle the two centres subtend there. Zero for a zero
    # baseline whatever the rays, and for near-parallel rays (a point far away).
    C_left, C_right = _centres(P_left), _centres(P_right)
    with np.errstate(invalid="ignore"):
        parallax_ok = _sin_angle(C_left - p, C_right - p) >= sin_min
    good &= np.all(np.isfinite(p), axis=1) & parallax_ok
    if not np.all(good):
        bad = np.nonzero(~good)[0]
        if on_degenerate == "raise":
            raise DegenerateDataError(
                f"triangulate: point {bad[0]} (and {bad.size - 1} others) has rays that "
                f"meet at less than {min_parallax_deg:g} deg (parallel rays or zero "
                f"baseline): its position is undetermined; it needs views from two "
                f"separated camera centres, or pass on_degenerate='nan' to flag it")
        p[bad] = np.nan
    return p


def point_covariance(P_left: np.ndarray, P_right: np.ndarray, uv_left: np.ndarray,
                     uv_right: np.ndarray, p: np.ndarray, sigma_px: float) -> np.ndarray:
    """First-order covariance (N, 3, 3) of :func:`triangulate`'s ``method="ls"`` points
    ``p`` for independent noise of ``sigma_px`` on each ideal pixel coordinate.

    ``p`` solves the normal equations ``Aᵀ f = 0`` of the residuals ``f = A p − b``
    (eq. 19, four rows). A pixel coordinate ``u`` of one eye enters one row,
    ``(u p3 − p1)·(p, 1)``: ``∂f_row/∂u = p3·(p, 1) = w`` (the point's projective depth
    in that eye) and ``∂A_row/∂u = p3[:3]``. Implicit differentiation gives
    ``∂p/∂u = −(AᵀA)⁻¹ (A_rowᵀ w + p3[:3] f_row)`` (the second term vanishes on
    consistent pixels), and ``Σ_p = σ² J Jᵀ`` with ``J`` the four columns. Exact to first
    order; the projections are those of :func:`triangulate` (undistorted pixels: a lens
    adds the undistortion's Jacobian, see :mod:`rasc.head.uncertainty`).
    """
    uv_left = _image_points(uv_left, "uv_left")
    uv_right = _image_points(uv_right, "uv_right")
    n = uv_left.shape[0]
    P_left = _projections(P_left, n, "P_left")
    P_right = _projections(P_right, n, "P_right")
    p = np.asarray(p, dtype=float).reshape(n, 3)
    H = np.concatenate([_rows(P_left, uv_left), _rows(P_right, uv_right)], axis=1)  # (N,4,4)
    A = H[:, :, :3]
    ph = np.concatenate([p, np.ones((n, 1))], axis=1)                             # (N, 4)
    f = np.einsum("nij,nj->ni", H, ph)                                             # (N, 4)
    G = np.linalg.inv(np.swapaxes(A, 1, 2) @ A)                                    # (N,3,3)
    J = np.zeros((n, 3, 4))
    for row, P in enumerate((P_left, P_left, P_right, P_right)):
        P3 = np.broadcast_to(P[:, 2], (n, 4))
        w = np.einsum("nj,nj->n", P3, ph)
        d = A[:, row] * w[:, None] + P3[:, :3] * f[:, row, None]
        J[:, :, row] = -np.einsum("nij,nj->ni", G, d)
    return sigma_px ** 2 * np.einsum("nik,njk->nij", J, J)
