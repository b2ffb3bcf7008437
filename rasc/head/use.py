"""Using a calibration: load it, project, triangulate, and find the angles that look at a point.

Everything here goes through :class:`~rasc.head.model.EyeCalibration`'s public methods
(``T_cam_from_base``, ``projection_matrix``, ``project``, ``undistort``) and
:meth:`~rasc.head.model.HeadCalibration.triangulate`, so it holds for whatever joint model
an eye carries, not only eq. 3. Angles are radians throughout (the model refuses
|angle| > 2π, :data:`rasc.head.model.MAX_ABS_ANGLE_RAD`); lengths are in the calibration's
unit.

* :func:`load_calibration` reads the file ``rasc calibrate`` writes (``rasc-calibration/1``)
  or a bare ``rasc-head/1`` document (:meth:`HeadCalibration.to_dict`).
* :func:`project_eye` gives each point's distorted pixel and whether the point is in front
  of the camera and inside the image.
* :func:`triangulate` gives base-frame points (eq. 15–19 after undistortion) with each eye's
  reprojection residual.
* :func:`look_at` solves for the pan and tilt that put a base-frame point's image on the
  principal point (``scipy.optimize.least_squares`` on the two angles, from eq. 3's closed
  form as the first guess).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from rasc import formats
from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.frames import EYES
from rasc.geometry.transforms import invert_transform
from rasc.head.model import FORMAT as HEAD_FORMAT
from rasc.head.model import EyeCalibration, HeadCalibration
from rasc.io import finite_number
from rasc.io import read_json_document as _read_json_document

#: The document ``rasc calibrate`` writes (rasc.head.pipeline.FORMAT; a test checks).
CALIBRATION_FORMAT = formats.CALIBRATION.tag

#: :func:`look_at` succeeds when the point's ideal image is this close to the principal
#: point, pixels: far below any corner detector (0.02 px at best), far above the solver's
#: floor (Gauss–Newton on a zero-residual problem converges quadratically to ~1e-12 px).
LOOK_AT_TOL_PX = 1e-6

#: A point this close to a camera centre (relative to its distance from the base origin
#: plus one length unit) is "at the optical centre": its direction is undefined.
CENTRE_RTOL = 1e-9

#: :func:`project_eye`'s "inside the image" also requires that undistorting the pixel gives
#: back the point's ideal pixel to this many pixels: a lens model folds points far outside
#: the field of view back into the image, and those are not seen there.
ROUND_TRIP_TOL_PX = 1e-6


# --------------------------------------------------------------------------------------
# reading


@dataclass(frozen=True)
class CalibrationFile:
    """A calibration as read from a file.

    Attributes
    ----------
    head : HeadCalibration
    length_unit : str or None
        The calibration's length unit (free text), if the file says.
    joint_range : dict or None
        Per eye, ``{"pan": (lo, hi), "tilt": (lo, hi)}`` in radians: the angles the
        calibration's pose views spanned (``rasc-calibration/1`` only), else None.
    source : str
        The path as given.
    paper_fit : dict or None
        Per eye the paper model's fit check (``paper_model_fit``: ``F``, ``threshold_F``)
        when the file's head IS the paper model (``rasc-calibration/1`` without a
        whole-head refinement), else None: what :func:`reading_warnings` reads.
    corner_noise : dict or None
        The corner noise per coordinate (px) the whole-head refinement's residuals give,
        by role: ``{"pose": σₚ, "intrinsics": σᵢ}`` — each role's RMS residual scaled by
        the fit's degrees of freedom as ``sigma_px`` is (σ_role = rms_role · sigma_px /
        rms_after). None without a refinement or its residuals. What :mod:`rasc.plan`
        predicts with.
    """

    head: HeadCalibration
    length_unit: str | None
    joint_range: dict[str, dict[str, tuple[float, float]]] | None
    source: str
    paper_fit: dict[str, dict[str, float]] | None = None
    corner_noise: dict[str, float] | None = None


def read_json_document(path: str | os.PathLike, what: str = "calibration file") -> Any:
    """Parse a JSON file by the project-wide reader's rules
    (:func:`rasc.io.read_json_document`: regular files, size, UTF-8, duplicate keys,
    depth, number sizes, NaN and Infinity, each error one line starting with the path)."""
    return _read_json_document(path, what, top=None)


def _numbers_only(value: Any, name: str) -> None:
    """Nested lists of finite JSON numbers (no booleans, strings, nulls or objects)."""
    if isinstance(value, list):
        for i, v in enumerate(value):
            _numbers_only(v, f"{name}[{i}]")
    else:
        finite_number(value, name)


def _head_from_dict(d: Any, where: str) -> HeadCalibration:
    """A ``rasc-head/1`` object → HeadCalibration; errors name ``<where>.<field>``."""
    prefix = f"{where}." if where else ""
    if not isinstance(d, dict):
        raise InputError(f"{where or 'document'}: expected an object (format {HEAD_FORMAT!r})")
    for eye in EYES:
        if eye not in d:
            raise InputError(f"{prefix}{eye}: missing")
        if isinstance(d[eye], dict):
            for field in ("K", "dist", "T_cam_from_gaze", "T_ptu_from_base"):
                if field in d[eye]:
                    _numbers_only(d[eye][field], f"{prefix}{eye}.{field}")
            dist = d[eye].get("dist")
            if isinstance(dist, list) and any(isinstance(x, list) for x in dist):
                what = ("0 or 4 numbers (a fisheye lens: k1 k2 k3 k4)"
                        if d[eye].get("lens") == "fisheye" else
                        "0, 4, 5 or 8 numbers (k1 k2 p1 p2 [k3 [k4 k5 k6]])")
                raise InputError(f"{prefix}{eye}.dist: expected a flat list of {what}")
    try:
        return HeadCalibration.from_dict(d)
    except InputError as exc:
        raise InputError(f"{prefix}{exc}") from None


def _joint_range(eyes: Any) -> dict | None:
    """The pan/tilt span of each eye's pose views in a ``rasc-calibration/1`` ``eyes``."""
    if eyes is None:
        return None
    if not isinstance(eyes, dict):
        raise InputError("eyes: expected an object with 'left' and 'right'")
    out = {}
    for eye in EYES:
        views = eyes.get(eye, {}).get("pose_views") if isinstance(eyes.get(eye), dict) else None
        if views is None:
            return None
        if not isinstance(views, list) or not views:
            raise InputError(f"eyes.{eye}.pose_views: expected a non-empty list")
        pans, tilts = [], []
        for i, v in enumerate(views):
            if not isinstance(v, dict):
                raise InputError(f"eyes.{eye}.pose_views[{i}]: expected an object")
            for key, acc in (("pan_deg", pans), ("tilt_deg", tilts)):
                if key not in v:
                    raise InputError(f"eyes.{eye}.pose_views[{i}].{key}: missing")
                acc.append(finite_number(v[key], f"eyes.{eye}.pose_views[{i}].{key}"))
        out[eye] = {"pan": (math.radians(min(pans)), math.radians(max(pans))),
                    "tilt": (math.radians(min(tilts)), math.radians(max(tilts)))}
    return out


def _paper_fit(fits: Any) -> dict | None:
    """``paper_model_fit`` of a ``rasc-calibration/1`` (per eye F and its threshold)."""
    if fits is None:
        return None
    if not isinstance(fits, dict):
        raise InputError("paper_model_fit: expected an object with 'left' and 'right'")
    out = {}
    for eye in EYES:
        f = fits.get(eye)
        if f is None:
            continue
        if not isinstance(f, dict):
            raise InputError(f"paper_model_fit.{eye}: expected an object")
        out[eye] = {key: finite_number(f.get(key), f"paper_model_fit.{eye}.{key}")
                    for key in ("F", "threshold_F")}
    return out or None


def _corner_noise(ref: Any) -> dict[str, float] | None:
    """:attr:`CalibrationFile.corner_noise` from a calibration's ``refinement``."""
    if ref is None:
        return None
    if not isinstance(ref, dict):
        raise InputError("refinement: expected an object")
    by_role = ref.get("rms_by_role_px")
    if by_role is None or ref.get("sigma_px") is None or ref.get("rms_after_px") is None:
        return None
    if not isinstance(by_role, dict):
        raise InputError("refinement.rms_by_role_px: expected an object with 'pose' and "
                         "'intrinsics'")
    sigma = finite_number(ref.get("sigma_px"), "refinement.sigma_px")
    rms = finite_number(ref.get("rms_after_px"), "refinement.rms_after_px")
    out = {}
    for role in ("pose", "intrinsics"):
        v = finite_number(by_role.get(role), f"refinement.rms_by_role_px.{role}")
        if v <= 0 or sigma <= 0 or rms <= 0:
            raise InputError(f"refinement.rms_by_role_px.{role}: expected a positive RMS "
                             f"with a positive sigma_px and rms_after_px, got {v:g}")
        out[role] = v * sigma / rms
    return out


def calibration_from_document(doc: Any, source: str = "calibration") -> CalibrationFile:
    """A parsed ``rasc-calibration/1`` or ``rasc-head/1`` document → :class:`CalibrationFile`.

    Raises :class:`InputError` ``<source>: <field>: <problem>`` for anything wrong.
    """
    try:
        if not isinstance(doc, dict):
            raise InputError(f"expected a JSON object with format {CALIBRATION_FORMAT!r} or "
                             f"{HEAD_FORMAT!r}")
        fmt = doc.get("format")
        if fmt == HEAD_FORMAT:
            return CalibrationFile(_head_from_dict(doc, ""), None, None, source)
        if fmt != CALIBRATION_FORMAT:
            raise InputError(f"format: expected {CALIBRATION_FORMAT!r} (the file rasc "
                             f"calibrate writes) or {HEAD_FORMAT!r}, got "
                             f"{json.dumps(fmt)[:40]}")
        if "head" not in doc:
            raise InputError("head: missing (the rasc-head/1 model)")
        head = _head_from_dict(doc["head"], "head")
        unit = doc.get("length_unit")
        if unit is not None and not isinstance(unit, str):
            raise InputError(f"length_unit: expected text, got {json.dumps(unit)[:40]}")
        fit = None if "refinement" in doc else _paper_fit(doc.get("paper_model_fit"))
        return CalibrationFile(head, unit, _joint_range(doc.get("eyes")), source, fit,
                               _corner_noise(doc.get("refinement")))
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None


def read_calibration(path: str | os.PathLike) -> CalibrationFile:
    """Read a calibration file with its length unit and recorded joint range."""
    return calibration_from_document(read_json_document(path), os.fspath(path))


def dataset_reference(dataset: str | os.PathLike,
                      calibration_file: str | os.PathLike | None) -> str:
    """The calibration file's ``dataset`` field for the dataset folder ``dataset``: its
    path relative to the folder of ``calibration_file`` (the file about to be written),
    so that :func:`named_dataset` finds it whichever folder the file is later read from,
    and the two can move together; absolute where there is no such file (written to
    stdout) or no relative path (another drive)."""
    folder = _in_real_folder(dataset)           # a dataset that is a link stays one
    if calibration_file is None:
        return folder
    try:
        return os.path.relpath(folder, os.path.dirname(_in_real_folder(calibration_file)))
    except ValueError:                                   # Windows: another drive
        return folder


def _in_real_folder(path: str | os.PathLike) -> str:
    """``path`` made absolute with the links of its folder resolved (so that a relative
    path's ``..`` means what the file system means), its own name kept."""
    path = os.path.abspath(path)
    return os.path.join(os.path.realpath(os.path.dirname(path)), os.path.basename(path))


def named_dataset(doc: Any, calibration_file: str | os.PathLike) -> str | None:
    """The dataset folder a calibration document names (its ``dataset`` field), if it
    is there (holds ``manifest.json``): an absolute path as written; a relative one taken
    from the folder of ``calibration_file`` (:func:`dataset_reference`), else, for a file
    written before rasc recorded it so, from the working directory (as it was given to
    ``rasc calibrate``). None when the document names none, or none is found."""
    named = doc.get("dataset") if isinstance(doc, dict) else None
    if not isinstance(named, str) or not named:
        return None
    candidates = [named] if os.path.isabs(named) else [
        os.path.normpath(os.path.join(os.path.dirname(_in_real_folder(calibration_file)),
                                      named)), named]
    return next((c for c in candidates if os.path.isfile(os.path.join(c, "manifest.json"))),
                None)


def load_calibration(path: str | os.PathLike) -> HeadCalibration:
    """Load the head model from a calibration file.

    Parameters
    ----------
    path : str or path-like
        The ``rasc-calibration/1`` file that ``rasc calibrate`` writes (its ``head``
        member is used), or a bare ``rasc-head/1`` document
        (:meth:`HeadCalibration.to_dict`).

    Returns
    -------
    HeadCalibration
        Angles in radians; lengths in the calibration's unit.

    Raises
    ------
    InputError
        One line naming the file and the field: unreadable or malformed JSON, an unknown
        format, a missing eye or field, wrong shapes, non-numeric or non-finite numbers,
        a transform that is not rigid, a non-positive focal length.
    """
    return read_calibration(path).head


# --------------------------------------------------------------------------------------
# projecting and triangulating


def _per_point(a, n: int, name: str) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.shape not in ((), (n,)):
        raise InputError(f"{name}: expected a scalar or shape ({n},), got {a.shape}")
    return np.broadcast_to(a, (n,)).copy()


@dataclass(frozen=True)
class Projection:
    """One eye's view of N points.

    Attributes
    ----------
    uv : ndarray, shape (N, 2)
        Distorted pixels; NaN for points at or behind the camera (they have no image).
    in_front : ndarray of bool, shape (N,)
        Depth along the optical axis > 0.
    in_image : ndarray of bool, shape (N,)
        In front, the pixel inside the image (``-0.5 ≤ u ≤ width − 0.5``, same for v:
        pixel centres are integers), and the lens model maps it back to the point's ideal
        pixel (within :data:`ROUND_TRIP_TOL_PX`).
    depth : ndarray, shape (N,)
        Coordinate along the optical axis (the calibration's length unit).
    """

    uv: np.ndarray
    in_front: np.ndarray
    in_image: np.ndarray
    depth: np.ndarray


def project_eye(eye: EyeCalibration, p_base, pan, tilt) -> Projection:
    """Project base-frame points (N, 3) into one eye at angles (radians, scalars or (N,))."""
    p_base = np.asarray(p_base, dtype=float)
    if p_base.ndim != 2 or p_base.shape[1] != 3:
        raise InputError(f"p_base: expected shape (N, 3), got {p_base.shape}")
    n = p_base.shape[0]
    pan, tilt = _per_point(pan, n, "pan"), _per_point(tilt, n, "tilt")
    T = eye.T_cam_from_base(pan, tilt)
    p_cam = np.einsum("nij,nj->ni", T[:, :3, :3], p_base) + T[:, :3, 3]
    if not np.all(np.isfinite(p_cam)):
        i = int(np.argmax(~np.all(np.isfinite(p_cam), axis=1)))
        raise InputError(f"point {i}: coordinates too large to compute with")
    depth = p_cam[:, 2]
    in_front = depth > 0.0
    uv = np.full((n, 2), np.nan)
    in_image = np.zeros(n, dtype=bool)
    if np.any(in_front):
        f = np.nonzero(in_front)[0]
        uv[f] = eye.project(p_base[f], pan[f], tilt[f])
        w, h = eye.image_size
        ok = np.all(np.isfinite(uv[f]), axis=1)
        inside = ok & (uv[f, 0] >= -0.5) & (uv[f, 0] <= w - 0.5) & \
            (uv[f, 1] >= -0.5) & (uv[f, 1] <= h - 0.5)
        cand = f[inside]
        if cand.size:
            ideal = (eye.K @ (p_cam[cand] / depth[cand, None]).T).T[:, :2]
            in_image[cand] = _round_trip_ok(eye, uv[cand], ideal)
    return Projection(uv, in_front, in_image, depth)


def _round_trip_ok(eye: EyeCalibration, uv: np.ndarray, ideal: np.ndarray) -> np.ndarray:
    try:
        back = eye.undistort(uv)
    except InputError:  # some pixel is beyond the lens model's fold: check one by one
        back = np.full_like(uv, np.nan)
        for i in range(uv.shape[0]):
            with contextlib.suppress(InputError):
                back[i] = eye.undistort(uv[i:i + 1])[0]
    with np.errstate(invalid="ignore"):
        return np.linalg.norm(back - ideal, axis=1) <= ROUND_TRIP_TOL_PX


@dataclass(frozen=True)
class Triangulation:
    """Triangulated points and how well they fit.

    Attributes
    ----------
    p_base : ndarray, shape (N, 3)
        Base-frame points (the calibration's length unit).
    residual_px : dict
        ``{"left": (N,), "right": (N,)}``: distance from each measured pixel to the
        point's reprojection; NaN where the point lies behind that camera.
    in_front : dict
        ``{"left": (N,), "right": (N,)}`` booleans: the point lies in front of that camera.
    """

    p_base: np.ndarray
    residual_px: dict[str, np.ndarray]
    in_front: dict[str, np.ndarray]


def triangulate(head: HeadCalibration, uv_left, uv_right, pan_left, tilt_left, pan_right,
                tilt_right, method: str = "ls") -> Triangulation:
    """Triangulate matched pixels (eq. 15–19 after undistortion) and reproject the result.

    Parameters
    ----------
    head : HeadCalibration
    uv_left, uv_right : array-like, shape (N, 2)
        Measured (distorted) pixels.
    pan_left, tilt_left, pan_right, tilt_right : float or array-like, shape (N,)
        Radians.
    method : {"ls", "tls"}

    Raises
    ------
    DegenerateDataError
        A point whose rays are parallel (its depth is undetermined); names the point.
    """
    p = head.triangulate(uv_left, uv_right, pan_left, tilt_left, pan_right, tilt_right,
                         method, on_degenerate="nan")
    bad = ~np.all(np.isfinite(p), axis=1)
    if np.any(bad):
        i = int(np.argmax(bad))
        exc = DegenerateDataError(
            f"point {i} (and {int(bad.sum()) - 1} others): its two rays are (nearly) "
            f"parallel, so its depth is undetermined")
        exc.index = i  # for callers that name the point their own way (file and line)
        raise exc
    residual, front = {}, {}
    for eye, uv, pan, tilt in (("left", uv_left, pan_left, tilt_left),
                               ("right", uv_right, pan_right, tilt_right)):
        proj = project_eye(getattr(head, eye), p, pan, tilt)
        residual[eye] = np.linalg.norm(proj.uv - np.asarray(uv, dtype=float), axis=1)
        front[eye] = proj.in_front
    return Triangulation(p, residual, front)


def point_covariances(path, head: HeadCalibration, uv_left, uv_right, pan_left, tilt_left,
                      pan_right, tilt_right, *, pixel_sigma: float | None = None,
                      method: str = "ls"):
    """Each triangulated point's covariance from the pixel noise and the covariance kept
    in the calibration file ``path`` (:func:`rasc.head.uncertainty.point_uncertainty`).
    ``pixel_sigma`` None: the file's corner noise. Returns (PointUncertainty or None,
    a dict saying what was propagated); None when no pixel noise is known (a bare head
    document without ``pixel_sigma``)."""
    from rasc.head.uncertainty import point_uncertainty, read_covariance

    cov, default = read_covariance(path)
    if pixel_sigma is None and default is None:
        return None, {"pixel_sigma_px": None, "calibration_covariance": cov is not None,
                      "note": "no pixel noise known: give --pixel-sigma for sigmas"}
    sigma, source = (pixel_sigma, "--pixel-sigma") if pixel_sigma is not None else default
    unc = point_uncertainty(head, uv_left, uv_right, pan_left, tilt_left, pan_right,
                            tilt_right, pixel_sigma=sigma, covariance=cov, method=method)
    return unc, {"pixel_sigma_px": sigma, "pixel_sigma_source": source,
                 "calibration_covariance": cov is not None,
                 "method": "first-order propagation (rasc.head.uncertainty)"}


# --------------------------------------------------------------------------------------
# looking at a point


@dataclass(frozen=True)
class Fixation:
    """The angles that put a point on an eye's principal point.

    Attributes
    ----------
    pan, tilt : float
        Radians, in (−π, π].
    residual_px : float
        Distance of the point's ideal image from the principal point, pixels.
    depth : float
        The point's depth along the optical axis (the calibration's length unit).
    """

    pan: float
    tilt: float
    residual_px: float
    depth: float


def _wrap(a):
    """Angles to (−π, π]."""
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=float), 2.0 * np.pi)


def _eq3_guess(eye: EyeCalibration, p_base: np.ndarray) -> np.ndarray:
    """Eq. 3's closed form: the pan and tilt that turn the camera's home optical axis
    towards the point as seen from the unit's centre (exact for a camera at the centre)."""
    T_pb = getattr(eye, "T_ptu_from_base", None)
    if T_pb is None:
        return np.zeros(2)
    q = T_pb[:3, :3] @ p_base + T_pb[:3, 3]                       # p_ptu
    T_cam_from_ptu = eye.T_cam_from_base(0.0, 0.0) @ invert_transform(T_pb)
    d0 = T_cam_from_ptu[2, :3]                                    # optical axis in ptu, home
    # eq. 3: the gaze's line of sight (ptu +y at home) after (pan, tilt) is
    # (sin τ, cos τ cos φ, cos τ sin φ) in ptu (x up, y forward, z left)
    nq = np.linalg.norm(q)
    if nq == 0.0:
        return np.zeros(2)
    pan = math.atan2(q[2], q[1]) - math.atan2(d0[2], d0[1])
    tilt = math.asin(float(np.clip(q[0] / nq, -1, 1))) - math.asin(float(np.clip(d0[0], -1, 1)))
    return _wrap(np.array([pan, tilt]))


def _fixation_error(eye: EyeCalibration, p_base: np.ndarray, angles) -> tuple[float, float]:
    """(pixels from the principal point of the ideal image, depth) at ``angles``."""
    P = eye.projection_matrix(*_wrap(angles))
    u, v, w = P[:, :3] @ p_base + P[:, 3]
    if not w > 0.0:
        return math.inf, float(w)
    return float(math.hypot(u / w - eye.K[0, 2], v / w - eye.K[1, 2])), float(w)


def look_at(eye: EyeCalibration, p_base, *, tol_px: float = LOOK_AT_TOL_PX) -> Fixation:
    """The pan and tilt at which ``eye`` fixates the base-frame point ``p_base``.

    Fixating means the point's image lies on the principal point (``K[0, 2], K[1, 2]``;
    lens distortion vanishes there), in front of the camera. Solved with
    ``scipy.optimize.least_squares`` over (pan, tilt) for the eye's full model, from eq. 3's
    closed form (:func:`_eq3_guess`), then from a few other starts if that does not reach
    ``tol_px``. The residual minimised is ``K₂ₓ₂ (x, y) / ‖p_cam‖`` (pixels, smooth
    everywhere except at the camera centre).

    Parameters
    ----------
    eye : EyeCalibration
    p_base : array-like, shape (3,)
        The point in the base frame (x up, y forward, z left).
    tol_px : float
        Largest accepted distance from the principal point, pixels.

    Raises
    ------
    InputError
        Non-finite point; a point behind the head (base ``y ≤ 0``: no forward-looking
        unit fixates it); a point at the optical centre; an unreachable point (no angles
        bring it within ``tol_px`` of the principal point, in front of the camera).
    """
    p = np.asarray(p_base, dtype=float)
    if p.shape != (3,):
        raise InputError(f"point: expected 3 coordinates (x, y, z), got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise InputError("point: contains NaN or infinity")
    if not p[1] > 0.0:
        raise InputError(f"point ({p[0]:g}, {p[1]:g}, {p[2]:g}) is behind the head "
                         f"(base y = {p[1]:g} <= 0; y points forward)")
    K2 = eye.K[:2, :2]
    scale = 1.0 + float(np.linalg.norm(p))

    def residual(angles):
        T = eye.T_cam_from_base(*_wrap(angles))
        p_cam = T[:3, :3] @ p + T[:3, 3]
        r = np.linalg.norm(p_cam)
        if r <= CENTRE_RTOL * scale:
            return np.full(2, 1e6)
        return K2 @ p_cam[:2] / r

    guess = _eq3_guess(eye, p)
    starts = [guess, np.zeros(2)] + [guess + np.array([dp, dt])
                                     for dp in (-0.5, 0.5) for dt in (-0.5, 0.5)]
    best, centre_hit = None, False
    for x0 in starts:
        T0 = eye.T_cam_from_base(*_wrap(x0))
        if np.linalg.norm(T0[:3, :3] @ p + T0[:3, 3]) <= CENTRE_RTOL * scale:
            centre_hit = True
            continue
        sol = least_squares(residual, x0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15,
                            max_nfev=200)
        err, depth = _fixation_error(eye, p, sol.x)
        if best is None or err < best[1]:
            best = (_wrap(sol.x), err, depth)
        if err <= tol_px:
            break
    if best is None or best[1] > tol_px:
        where = f"({p[0]:g}, {p[1]:g}, {p[2]:g})"
        if centre_hit or (best is not None and abs(best[2]) <= CENTRE_RTOL * scale):
            raise InputError(f"point {where} is at the camera's optical centre: it has no "
                             f"direction to look in")
        got = "" if best is None or not math.isfinite(best[1]) else \
            f" (closest: {best[1]:.3g} px from the principal point)"
        raise InputError(f"point {where} is unreachable: no pan and tilt put it on the "
                         f"principal point in front of the camera{got}")
    (pan, tilt), err, depth = best
    return Fixation(float(pan), float(tilt), float(err), float(depth))


def outside_range(angle: float, span: tuple[float, float], margin: float = 1e-9) -> bool:
    """Whether ``angle`` lies outside the closed interval ``span`` (radians)."""
    return angle < span[0] - margin or angle > span[1] + margin


# --------------------------------------------------------------------------------------
# what a user of a calibration is told (rasc triangulate, project and look-at alike)


def _angle_text(radians: float, unit: str) -> float:
    return math.degrees(radians) if unit == "deg" else float(radians)


def reading_warnings(cal: CalibrationFile, readings: dict[str, tuple[Any, Any]],
                     unit: str = "deg", where=None) -> list[str]:
    """Warnings for answers computed at these pan-tilt readings, one sentence each.

    * per eye, readings outside the pan/tilt range the calibration's pose views spanned
      (``cal.joint_range``; the model is extrapolated there: on a unit the paper model
      does not fit, 10 mm errors with 0.02 px residuals);
    * a calibration whose head is the paper model and whose pose views that model does
      not fit (``cal.paper_fit``: F above its threshold): every answer carries the misfit.

    Parameters
    ----------
    cal : CalibrationFile
    readings : ``{eye: (pan, tilt)}``, radians, scalars or (N,) arrays (the eyes used)
    unit : "deg" or "rad", how angles are written in the messages
    where : ``where(i)`` names reading i (a file and line); default ``reading i``
    """
    where = where or (lambda i: f"reading {i}")
    out = []
    if cal.joint_range is not None:
        for eye in EYES:
            if eye not in readings:
                continue
            pan, tilt = (np.atleast_1d(np.asarray(a, dtype=float)) for a in readings[eye])
            pan, tilt = np.broadcast_arrays(pan, tilt)
            span = cal.joint_range[eye]
            bad = np.array([outside_range(p, span["pan"]) or outside_range(t, span["tilt"])
                            for p, t in zip(pan, tilt, strict=True)], dtype=bool)
            if not bad.any():
                continue
            first = int(np.argmax(bad))
            n = int(bad.sum())
            more = f" ({n} points; first {where(first)})" if n > 1 else f" ({where(first)})"
            rng = ", ".join(f"{j} {_angle_text(span[j][0], unit):g} to "
                            f"{_angle_text(span[j][1], unit):g}" for j in ("pan", "tilt"))
            out.append(f"{eye} eye: pan {_angle_text(pan[first], unit):.4g}, tilt "
                       f"{_angle_text(tilt[first], unit):.4g} {unit}{more} lies outside the "
                       f"range the calibration was measured over ({rng} {unit}); the model "
                       "is extrapolated there")
    if cal.paper_fit:
        bad = {eye: f for eye, f in cal.paper_fit.items() if f["F"] > f["threshold_F"]}
        if bad:
            from rasc.head.fit import REMEDY

            fs = ", ".join(f"{eye} F = {f['F']:.3g}" for eye, f in bad.items())
            out.append(f"the calibration {cal.source} uses the paper's pan-tilt model, which "
                       f"does not fit its pose views ({fs}, above "
                       f"{next(iter(bad.values()))['threshold_F']:g}): its answers may be off "
                       f"by millimetres; recalibrate ({REMEDY})")
    return out + calibration_warnings(cal)


#: the two units' distances from the base origin differ by more than this factor: a
#: length in another unit (mm among metres is 1000). ``rasc calibrate`` puts the base
#: midway between the units (the cyclopean base, eq. 13-14): the ratio is 1 there; a
#: hand-made base off the middle by a third of the baseline stays within 2.
BASE_DISTANCE_RATIO_WARN = 3.0


def calibration_warnings(cal: CalibrationFile) -> list[str]:
    """What the numbers of a calibration contradict, one sentence each: in a file that
    ``rasc calibrate`` wrote (``rasc-calibration/1``, whose base is cyclopean), the units'
    distances from the base (``T_ptu_from_base`` translations) differing by more than
    :data:`BASE_DISTANCE_RATIO_WARN` times (a translation in another length unit). A bare
    ``rasc-head/1`` may put its base anywhere (at one unit, say): not checked."""
    if cal.joint_range is None:
        return []
    d = {eye: float(np.linalg.norm(getattr(cal.head, eye).T_ptu_from_base[:3, 3]))
         for eye in EYES}
    lo, hi = sorted(d.values())
    if hi > 0 and (lo == 0 or hi / lo > BASE_DISTANCE_RATIO_WARN):
        far = max(d, key=d.get)
        unit = cal.length_unit or "the calibration's unit"
        return [f"{cal.source}: the {far} unit is {d[far]:.4g} from the base origin, the "
                f"other {lo:.4g} ({unit}): {far}.T_ptu_from_base's translation looks like "
                "another length unit (millimetres among metres?); answers are wrong until "
                "it is fixed"]
    return []


def intrinsics_from_calibration(path: str | os.PathLike
                                ) -> tuple[dict[str, np.ndarray], tuple[int, int]]:
    """K per eye and the image size of a calibration file (what ``rasc calibrate`` or
    ``rasc intrinsics`` writes; :func:`load_calibration`): the cameras ``rasc render
    --urdf-intrinsics`` gives a URDF head (:class:`rasc.sim.urdf.UrdfHead`'s ``K``,
    ``image_size``)."""
    head = load_calibration(path)
    K = {eye: np.asarray(getattr(head, eye).K, dtype=float) for eye in EYES}
    sizes = {tuple(int(v) for v in getattr(head, eye).image_size) for eye in EYES}
    if len(sizes) != 1:
        raise InputError(f"{path}: the two eyes' image sizes differ ({sorted(sizes)}); the "
                         "bench renders both eyes at one size")
    return K, sizes.pop()
