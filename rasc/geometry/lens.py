"""OpenCV's lens distortion model in numpy (docs/METHOD.md §6: undistort before triangulating).

Normalised image coordinates ``(x, y) = (X/Z, Y/Z)`` of a point in the camera frame are
distorted by (OpenCV's ``projectPoints``; coefficients in OpenCV's order
``k1 k2 p1 p2 [k3 [k4 k5 k6]]``, missing ones are zero)::

    r² = x² + y²
    radial = (1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶)
    x_d = x·radial + 2 p1 x y + p2 (r² + 2 x²)
    y_d = y·radial + p1 (r² + 2 y²) + 2 p2 x y

and reach pixels through ``K``: ``u = fx x_d + s y_d + cx``, ``v = fy y_d + cy`` (OpenCV
has no skew ``s``; it is kept here only so that ``K`` and ``K⁻¹`` are used consistently).
The inverse has no closed form: :func:`undistort_normalized` runs Newton's method with
the analytic Jacobian, vectorised over all points, and refuses (``InputError``) any point
where it does not converge, or lands beyond the fold of the model (Jacobian determinant
≤ 0) or flipped through the centre (radial factor ≤ 0): there the model is not
invertible. OpenCV's ``undistortPoints`` instead stops after 5 fixed-point iterations by
default, which is not converged for strong distortion (0.1–0.25 px off, measured).

:func:`distortion_remap` gives the maps that turn an ideal (distortion-free) render into
the image a distorted camera would see, for the simulation (MuJoCo renders no distortion).

Lens models
-----------
Every function takes ``model`` (:data:`LENS_MODELS`), default ``"pinhole"``:

``"pinhole"``
    The radial-tangential model above; 8 coefficients are OpenCV's rational model
    (``CALIB_RATIONAL_MODEL``: ``k1 k2 p1 p2 k3 k4 k5 k6``).
``"fisheye"``
    OpenCV's ``cv2.fisheye`` (equidistant, Kannala–Brandt) model, 0 or 4 coefficients
    ``k1 k2 k3 k4``::

        r = sqrt(x² + y²),  θ = atan(r)                       (angle from the optical axis)
        θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)
        (x_d, y_d) = (θ_d / r) (x, y)

    It works on the same normalised coordinates ``(X/Z, Y/Z)``, so a point reaches it only
    in front of the camera (θ < 90°: fields of view up to 180°, as ``cv2.fisheye``). The
    inverse solves ``θ_d(θ) = r_d`` by Newton's method in one dimension and refuses a
    point where θ_d is not increasing (beyond the model's fold) or θ reaches 90°.

:func:`distortion_jacobians` gives the distortion and its derivatives with respect to
the normalised point and to each coefficient, for any model, broadcast over arrays of
points and per-image coefficients (what a least-squares refinement needs).
"""

from __future__ import annotations

import numpy as np

from rasc.errors import InputError

#: Accepted numbers of coefficients (OpenCV's; thin-prism and tilt terms not supported).
N_COEFFS = (0, 4, 5, 8)

#: The lens models: name → the names of its coefficients, in OpenCV's order (the
#: ``dist`` vector of a camera with this lens; a pinhole camera may give fewer).
LENS_MODELS = {
    "pinhole": ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"),
    "fisheye": ("k1", "k2", "k3", "k4"),
}

#: Accepted numbers of coefficients per model.
MODEL_N_COEFFS = {"pinhole": N_COEFFS, "fisheye": (0, 4)}

#: The calibration's distortion models (``dist_model``, ``rasc calibrate --dist-model``):
#: name → (the lens model of :data:`LENS_MODELS`, the coefficients the calibration
#: estimates, the length of the ``dist`` vector it stores). The one table the intrinsics
#: (:mod:`rasc.vision.camera`, which adds OpenCV's flags), the options
#: (:mod:`rasc.head.options`, its names) and the whole-head refinement
#: (:mod:`rasc.head.refine`, its parameters) read.
DIST_MODELS = {
    "opencv5": ("pinhole", ("k1", "k2", "p1", "p2", "k3"), 5),
    "k1k2": ("pinhole", ("k1", "k2"), 5),
    "none": ("pinhole", (), 5),
    # OpenCV's rational model (CALIB_RATIONAL_MODEL): k4-k6 in the radial denominator
    "rational": ("pinhole", ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"), 8),
    # OpenCV's cv2.fisheye (equidistant, Kannala-Brandt)
    "fisheye": ("fisheye", ("k1", "k2", "k3", "k4"), 4),
}


def dist_model_lens(dist_model: str) -> str:
    """The lens model (:data:`LENS_MODELS`) of a calibration's ``dist_model``."""
    if dist_model not in DIST_MODELS:
        raise InputError(f"dist_model: unknown {dist_model!r} (use one of "
                         f"{', '.join(DIST_MODELS)})")
    return DIST_MODELS[dist_model][0]


#: The fisheye model's angle from the optical axis must stay below this (radians): at
#: 90° the normalised coordinates are infinite.
FISHEYE_MAX_THETA = np.pi / 2 - 1e-9


def check_model(model, name: str = "model") -> str:
    """``model`` if it is one of :data:`LENS_MODELS`, else InputError (one line)."""
    if not isinstance(model, str) or model not in LENS_MODELS:
        raise InputError(f"{name}: unknown lens model {model!r} "
                         f"(use one of {', '.join(LENS_MODELS)})")
    return model

#: Convergence target of :func:`undistort_normalized`, in normalised image units
#: (1e-12 ≈ 1e-9 px at a focal length of 1000 px, far below any measurement).
UNDISTORT_TOL = 1e-12

#: Newton converges quadratically from ``x_d`` for realistic lenses (measured: ≤ 5
#: iterations over a 1280×960 image whose corners the lens moves by up to 40 %).
UNDISTORT_MAX_ITER = 50


def _coefficients(dist, name: str = "dist", model: str = "pinhole") -> np.ndarray:
    """``dist`` of ``model`` (pinhole: k in {0, 4, 5, 8}; fisheye: k in {0, 4}), or None →
    all the model's coefficients (8 or 4), missing ones zero."""
    model = check_model(model)
    n_all = len(LENS_MODELS[model])
    if dist is None:
        return np.zeros(n_all)
    try:
        d = np.asarray(dist, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not a numeric vector") from None
    if d.size not in MODEL_N_COEFFS[model]:
        if model == "fisheye":
            raise InputError(f"{name}: expected 0 or 4 coefficients for a fisheye lens "
                             f"(k1 k2 k3 k4), got {d.size}")
        raise InputError(
            f"{name}: expected 0, 4, 5 or 8 coefficients (OpenCV order k1 k2 p1 p2 "
            f"[k3 [k4 k5 k6]]), got {d.size}")
    if not np.all(np.isfinite(d)):
        raise InputError(f"{name}: contains NaN or infinity")
    out = np.zeros(n_all)
    out[: d.size] = d
    return out


def validate_dist(dist, name: str = "dist", model: str = "pinhole") -> np.ndarray:
    """Check distortion coefficients of ``model``; return them as given, (k,)."""
    n = _coefficients(dist, name, model)
    return n[: 0 if dist is None else np.asarray(dist).size].copy()


def as_points(a, name: str, dim: int) -> np.ndarray:
    """Check a finite (N, dim) array of points; errors name ``name`` and the row."""
    return _points(a, name, dim)


def validate_K(K, name: str = "K") -> np.ndarray:
    """Check a camera matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` and return it (3, 3)."""
    try:
        K = np.asarray(K, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not a numeric 3x3 matrix") from None
    if K.shape != (3, 3):
        raise InputError(f"{name}: expected a 3x3 matrix, got shape {K.shape}")
    if not np.all(np.isfinite(K)):
        raise InputError(f"{name}: contains NaN or infinity")
    if K[1, 0] != 0.0 or np.any(K[2] != [0.0, 0.0, 1.0]):
        raise InputError(f"{name}: not upper triangular with last row [0, 0, 1]")
    if K[0, 0] <= 0.0 or K[1, 1] <= 0.0:
        raise InputError(f"{name}: focal lengths must be positive (fx={K[0, 0]}, fy={K[1, 1]})")
    return K


def _points(a, name: str, dim: int) -> np.ndarray:
    try:
        a = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not a numeric array") from None
    if a.ndim != 2 or a.shape[1] != dim:
        raise InputError(f"{name}: expected shape (N, {dim}), got {a.shape}")
    bad = ~np.all(np.isfinite(a), axis=1)
    if np.any(bad):
        raise InputError(f"{name}[{int(np.argmax(bad))}]: contains NaN or infinity")
    return a


def _radial(r2: np.ndarray, d: np.ndarray):
    """Radial factor and its derivative with respect to r²."""
    k1, k2, _, _, k3, k4, k5, k6 = d
    num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
    dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
    dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
    return num / den, (dnum * den - num * dden) / (den * den)


def _tangential(x: np.ndarray, y: np.ndarray, r2: np.ndarray, radial: np.ndarray,
                p1: float, p2: float):
    """The distorted coordinates from the radial factor, with the tangential terms."""
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return xd, yd


def _distort(x: np.ndarray, y: np.ndarray, d: np.ndarray):
    r2 = x * x + y * y
    radial, _ = _radial(r2, d)
    return _tangential(x, y, r2, radial, d[2], d[3])


def _distort_with_jacobian(x: np.ndarray, y: np.ndarray, d: np.ndarray):
    p1, p2 = d[2], d[3]
    r2 = x * x + y * y
    radial, dradial = _radial(r2, d)
    xd, yd = _tangential(x, y, r2, radial, p1, p2)
    jxx = radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x
    jyy = radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x
    jxy = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y  # = ∂x_d/∂y = ∂y_d/∂x
    return xd, yd, jxx, jxy, jyy


# ------------------------------------------------------------------------- fisheye

def _fisheye_theta_d(theta: np.ndarray, d: np.ndarray):
    """θ_d(θ) of the equidistant model and dθ_d/dθ."""
    k1, k2, k3, k4 = d
    t2 = theta * theta
    poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))
    dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))
    return theta * poly, dpoly


#: Below this r (normalised), the fisheye's factor θ_d/r and its derivative come from
#: their Taylor series (1 + (k1 − 1/3) r², …): the closed forms lose all digits there.
_FISHEYE_SMALL_R = 1e-6


def _fisheye_distort_with_jacobian(x, y, d):
    """The fisheye's distorted point, its 2×2 Jacobian (jxx, jxy, jyx, jyy) and the
    factor θ_d/r with θ^(2j+1)/r (the derivatives by k_j, per unit of x or y)."""
    r2 = x * x + y * y
    r = np.sqrt(r2)
    small = r < _FISHEYE_SMALL_R
    rs = np.where(small, 1.0, r)
    theta = np.arctan(rs)
    theta_d, dtheta_d = _fisheye_theta_d(theta, d)
    s = np.where(small, 1.0 + (d[0] - 1.0 / 3.0) * r2, theta_d / rs)
    # ds/dr / r: (θ_d'(θ) θ'(r) r − θ_d) / r³, with θ'(r) = 1 / (1 + r²)
    ds_r = np.where(small, 2.0 * (d[0] - 1.0 / 3.0),
                    (dtheta_d * rs / (1.0 + rs * rs) - theta_d) / (rs * rs * rs))
    xd, yd = s * x, s * y
    jxx = s + x * x * ds_r
    jyy = s + y * y * ds_r
    jxy = x * y * ds_r
    t2 = theta * theta
    powers = [np.where(small, r2 ** (j + 1), theta * t2 ** (j + 1) / rs) for j in range(4)]
    return xd, yd, jxx, jxy, jyy, powers


def _fisheye_undistort(xd, yd, d, tol, max_iter):
    """Invert the fisheye model: θ from θ_d(θ) = r_d by Newton's method, then
    r = tan θ. Returns (x, y, ok)."""
    rd = np.sqrt(xd * xd + yd * yd)
    theta = np.minimum(rd, 1.5)       # θ_d ≈ θ near the centre: a good start
    for _ in range(max_iter):
        f, df = _fisheye_theta_d(theta, d)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = (f - rd) / df
        step = np.where(np.isfinite(step), step, 0.0)
        theta = np.clip(theta - step, 0.0, FISHEYE_MAX_THETA)
        if np.all(np.abs(step) <= 1e-15 * (1.0 + theta)):
            break
    f, df = _fisheye_theta_d(theta, d)
    ok = (np.abs(f - rd) <= tol * (1.0 + rd)) & (df > 0.0) & (theta < FISHEYE_MAX_THETA)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(rd > _FISHEYE_SMALL_R, np.tan(theta) / np.where(rd > 0, rd, 1.0),
                         1.0)
    return xd * scale, yd * scale, ok


def distortion_jacobians(x, y, coeffs, model: str = "pinhole"):
    """The distortion of normalised points and its derivatives, broadcast.

    Parameters
    ----------
    x, y : ndarray
        Normalised coordinates (any shape, broadcast together).
    coeffs : sequence of arrays or numbers
        All of the model's coefficients (8 for pinhole, 4 for fisheye, in the order of
        :data:`LENS_MODELS`), each broadcastable to ``x`` (e.g. one per image, shape
        (n, 1) against points (n, N)).
    model : str

    Returns
    -------
    xd, yd : ndarray
        The distorted coordinates.
    jac : tuple (jxx, jxy, jyx, jyy)
        ∂x_d/∂x, ∂x_d/∂y, ∂y_d/∂x, ∂y_d/∂y.
    by_coeff : dict
        Coefficient name → (∂x_d/∂c, ∂y_d/∂c).
    """
    model = check_model(model)
    d = list(coeffs)
    if len(d) != len(LENS_MODELS[model]):
        raise InputError(f"distortion_jacobians: {model} takes "
                         f"{len(LENS_MODELS[model])} coefficients, got {len(d)}")
    x, y = np.asarray(x, float), np.asarray(y, float)
    if model == "fisheye":
        xd, yd, jxx, jxy, jyy, powers = _fisheye_distort_with_jacobian(x, y, d)
        by = {f"k{j + 1}": (x * p, y * p) for j, p in enumerate(powers)}
        return xd, yd, (jxx, jxy, jxy, jyy), by
    k1, k2, p1, p2, k3, k4, k5, k6 = d
    r2 = x * x + y * y
    num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
    xd, yd, jxx, jxy, jyy = _distort_with_jacobian(x, y, (k1, k2, p1, p2, k3, k4, k5, k6))
    xy = x * y
    by = {}
    for j, name in enumerate(("k1", "k2", "k3")):
        f = r2 ** (j + 1) / den
        by[name] = (x * f, y * f)
    for j, name in enumerate(("k4", "k5", "k6")):
        f = -num * r2 ** (j + 1) / (den * den)
        by[name] = (x * f, y * f)
    by["p1"] = (2.0 * xy, r2 + 2.0 * y * y)
    by["p2"] = (r2 + 2.0 * x * x, 2.0 * xy)
    return xd, yd, (jxx, jxy, jxy, jyy), by


def _distort_model(x, y, d, model):
    if model == "fisheye":
        return _fisheye_distort_with_jacobian(x, y, d)[:2]
    return _distort(x, y, d)


def distort_normalized(xy: np.ndarray, dist, model: str = "pinhole") -> np.ndarray:
    """Apply the distortion model to normalised coordinates.

    Parameters
    ----------
    xy : array-like, shape (N, 2)
        Ideal normalised coordinates (X/Z, Y/Z).
    dist : array-like, shape (k,), or None
        Pinhole: OpenCV coefficients ``k1 k2 p1 p2 [k3 [k4 k5 k6]]`` (k in {0, 4, 5, 8});
        fisheye: ``k1 k2 k3 k4`` (k in {0, 4}).
    model : str
        ``"pinhole"`` or ``"fisheye"`` (:data:`LENS_MODELS`).

    Returns
    -------
    xy_d : ndarray, shape (N, 2)
    """
    xy = _points(xy, "xy", 2)
    d = _coefficients(dist, model=model)
    xd, yd = _distort_model(xy[:, 0], xy[:, 1], d, model)
    return np.stack([xd, yd], axis=1)


#: Points per block of :func:`_undistort`: a block's temporaries (about 20 arrays) stay in
#: the cache. Every point is iterated on its own, so the blocks give the same bits as one
#: pass; a 1280×960 map (:func:`distortion_remap`) took 0.85 → 0.35 s of CPU.
_UNDISTORT_BLOCK = 1 << 14


def _undistort(xd: np.ndarray, yd: np.ndarray, d: np.ndarray, tol: float, max_iter: int,
               model: str = "pinhole"):
    """Newton's method; returns (x, y, ok) with ok False where it did not converge."""
    if model == "fisheye":
        return _fisheye_undistort(xd, yd, d, tol, max_iter)
    if len(xd) <= _UNDISTORT_BLOCK:
        return _undistort_block(xd, yd, d, tol, max_iter)
    x, y, ok = np.empty_like(xd), np.empty_like(yd), np.empty(len(xd), dtype=bool)
    for b in range(0, len(xd), _UNDISTORT_BLOCK):
        s = slice(b, b + _UNDISTORT_BLOCK)
        x[s], y[s], ok[s] = _undistort_block(xd[s], yd[s], d, tol, max_iter)
    return x, y, ok


def _undistort_block(xd: np.ndarray, yd: np.ndarray, d: np.ndarray, tol: float,
                     max_iter: int):
    """:func:`_undistort` of one block."""
    x, y = xd.copy(), yd.copy()
    if not np.any(d):
        return x, y, np.ones(x.shape, dtype=bool)
    active = np.ones(x.shape, dtype=bool)
    for _ in range(max_iter):
        if not np.any(active):
            break
        idx = np.nonzero(active)[0]
        xa, ya = x[idx], y[idx]
        fx, fy, jxx, jxy, jyy = _distort_with_jacobian(xa, ya, d)
        rx, ry = fx - xd[idx], fy - yd[idx]
        det = jxx * jyy - jxy * jxy
        with np.errstate(divide="ignore", invalid="ignore"):
            dx = (jyy * rx - jxy * ry) / det
            dy = (jxx * ry - jxy * rx) / det
        x[idx] = xa - dx
        y[idx] = ya - dy
        # Stop a point once its Newton step is below round-off (quadratic convergence:
        # the step then bounds the remaining error) or it has diverged to non-finite.
        scale = 1.0 + np.abs(xa) + np.abs(ya)
        done = (np.abs(dx) + np.abs(dy) <= 1e-14 * scale) | ~np.isfinite(dx + dy)
        active[idx[done]] = False
    fx, fy, jxx, jxy, jyy = _distort_with_jacobian(x, y, d)
    with np.errstate(invalid="ignore"):
        res = np.maximum(np.abs(fx - xd), np.abs(fy - yd))
        det = jxx * jyy - jxy * jxy
        radial, _ = _radial(x * x + y * y, d)
        # Inside the invertible region (around the centre, up to the fold) the radial
        # factor and the Jacobian determinant are positive. A root beyond the fold (det ≤ 0)
        # or flipped through the centre (radial ≤ 0) is not the lens's pre-image.
        ok = (np.isfinite(res) & (res <= tol * (1.0 + np.abs(xd) + np.abs(yd)))
              & (det > 0.0) & (radial > 0.0))
    return x, y, ok


def undistort_normalized(xy_d: np.ndarray, dist, *, tol: float = UNDISTORT_TOL,
                         max_iter: int = UNDISTORT_MAX_ITER,
                         model: str = "pinhole") -> np.ndarray:
    """Invert :func:`distort_normalized` by Newton's method, all points at once.

    Parameters
    ----------
    xy_d : array-like, shape (N, 2)
        Distorted normalised coordinates.
    dist : array-like, shape (k,), or None
        The coefficients of ``model`` (:func:`distort_normalized`).
    model : str
        ``"pinhole"`` (default) or ``"fisheye"`` (:data:`LENS_MODELS`).
    tol : float
        Largest residual ``|distort(xy) − xy_d|`` accepted, relative to ``1 + |xy_d|``.

    Returns
    -------
    xy : ndarray, shape (N, 2)
        Ideal normalised coordinates with ``distort_normalized(xy) = xy_d`` to ``tol``.

    Raises
    ------
    InputError
        A point where Newton did not converge, or converged beyond the fold of the model
        (Jacobian determinant ≤ 0) or through the centre (radial factor ≤ 0): it lies
        outside the region where the lens model is invertible (typically far outside the
        image the coefficients were fitted on).
    """
    xy_d = _points(xy_d, "xy_d", 2)
    d = _coefficients(dist, model=model)
    x, y, ok = _undistort(xy_d[:, 0], xy_d[:, 1], d, tol, max_iter, model)
    if not np.all(ok):
        bad = np.nonzero(~ok)[0]
        raise InputError(
            f"undistort: point {bad[0]} {xy_d[bad[0]].tolist()} (and {bad.size - 1} others) "
            f"is outside the region where the distortion model is invertible "
            f"(Newton did not converge to {tol:g}); use points inside the calibrated image")
    return np.stack([x, y], axis=1)


def _normalize_pixels(uv: np.ndarray, K: np.ndarray):
    y = (uv[:, 1] - K[1, 2]) / K[1, 1]
    x = (uv[:, 0] - K[0, 2] - K[0, 1] * y) / K[0, 0]
    return x, y


def _pixels(x: np.ndarray, y: np.ndarray, K: np.ndarray) -> np.ndarray:
    return np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=1)


def undistort_pixels(uv: np.ndarray, K: np.ndarray, dist, model: str = "pinhole") -> np.ndarray:
    """Distorted pixels → the pixels an ideal camera with the same ``K`` would see.

    Parameters
    ----------
    uv : array-like, shape (N, 2)
    K : array-like, shape (3, 3)
    dist : array-like, shape (k,), or None
        The coefficients of ``model`` (:func:`distort_normalized`).
    model : str
        ``"pinhole"`` (default) or ``"fisheye"`` (:data:`LENS_MODELS`).

    Returns
    -------
    uv_ideal : ndarray, shape (N, 2)
        ``K · undistort_normalized(K⁻¹ · uv)``; raises as :func:`undistort_normalized`.
    """
    uv = _points(uv, "uv", 2)
    K = validate_K(K)
    x, y = _normalize_pixels(uv, K)
    xy = undistort_normalized(np.stack([x, y], axis=1), dist, model=model)
    return _pixels(xy[:, 0], xy[:, 1], K)


def project_points(p_cam: np.ndarray, K: np.ndarray, dist, model: str = "pinhole") -> np.ndarray:
    """Pinhole projection with distortion (OpenCV's ``projectPoints`` with zero pose).

    Parameters
    ----------
    p_cam : array-like, shape (N, 3)
        Points in the camera frame (OpenCV axes, +z forward).
    K : array-like, shape (3, 3)
    dist : array-like, shape (k,), or None
        The coefficients of ``model`` (:func:`distort_normalized`).
    model : str
        ``"pinhole"`` (default) or ``"fisheye"`` (:data:`LENS_MODELS`).

    Returns
    -------
    uv : ndarray, shape (N, 2)

    Raises
    ------
    InputError
        A point at or behind the camera (z ≤ 0): it has no image. (OpenCV would
        return a mirrored, meaningless pixel.)
    """
    p_cam = _points(p_cam, "p_cam", 3)
    K = validate_K(K)
    d = _coefficients(dist, model=model)
    behind = p_cam[:, 2] <= 0.0
    if np.any(behind):
        i = int(np.argmax(behind))
        raise InputError(
            f"project_points: point {i} is at or behind the camera (z = {p_cam[i, 2]:.6g}), "
            f"{int(behind.sum())} such points in all")
    x = p_cam[:, 0] / p_cam[:, 2]
    y = p_cam[:, 1] / p_cam[:, 2]
    xd, yd = _distort_model(x, y, d, model)
    return _pixels(xd, yd, K)


def distortion_remap(K: np.ndarray, dist, size: tuple[int, int], model: str = "pinhole"):
    """Maps that warp an ideal render into the image of a distorted camera.

    For every pixel ``(u, v)`` of the distorted image (pixel centres at integers, OpenCV's
    convention), ``(map_x[v, u], map_y[v, u])`` is the pixel of the ideal image (same
    ``K``, no distortion) that the same ray hits, i.e. ``undistort_pixels``. So::

        distorted = cv2.remap(ideal, map_x, map_y, cv2.INTER_LINEAR)

    puts a point whose ideal projection is ``uv_ideal`` at ``project_points`` with
    distortion. Pixels whose ray is outside the invertible region of the model (possible
    only for lenses far stronger than real ones) map to (−1, −1), which ``cv2.remap``
    fills with the border value.

    Parameters
    ----------
    K : array-like, shape (3, 3)
    dist : array-like, shape (k,), or None
        The coefficients of ``model`` (:func:`distort_normalized`).
    model : str
        ``"pinhole"`` (default) or ``"fisheye"`` (:data:`LENS_MODELS`).
    size : (width, height)

    Returns
    -------
    map_x, map_y : ndarray, float32, shape (height, width)
    """
    K = validate_K(K)
    d = _coefficients(dist, model=model)
    try:
        w, h = (int(s) for s in size)
    except (TypeError, ValueError):
        raise InputError(f"size: expected (width, height), got {size!r}") from None
    if w <= 0 or h <= 0:
        raise InputError(f"size: width and height must be positive, got {(w, h)}")
    vv, uu = np.mgrid[0:h, 0:w].astype(float)
    x, y = _normalize_pixels(np.stack([uu.ravel(), vv.ravel()], axis=1), K)
    xu, yu, ok = _undistort(x, y, d, UNDISTORT_TOL, UNDISTORT_MAX_ITER, model)
    uv = _pixels(xu, yu, K)
    uv[~ok] = -1.0
    return (uv[:, 0].reshape(h, w).astype(np.float32),
            uv[:, 1].reshape(h, w).astype(np.float32))
