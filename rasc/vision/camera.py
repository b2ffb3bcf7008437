"""Camera pipeline: chessboard detection → intrinsics → extrinsics (docs/METHOD.md §7).

This module holds the intrinsics (Zhang, through cv2.calibrateCamera, with per-view RMS
and outlier views) and the extrinsics (IPPE + Levenberg–Marquardt); the detection is in
:mod:`rasc.vision.detect` and the image files in :mod:`rasc.vision.images`, and every
public name of both is importable from here as well (``from rasc.vision.camera import
detect_corners``). These three and :mod:`rasc.handeye.opencv` are the library modules that
import cv2.

The board's frame and its canonical corner order: :mod:`rasc.vision.detect`.
Pixels follow OpenCV's convention (pixel centres at integers, row 0 at the top).
Extrinsics are returned as ``T_cam_from_world`` (4, 4), the paper's ``T_cw``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry import lens as _lens
from rasc.geometry.transforms import make_transform, matrix_from_rotvec
from rasc.vision import images as _images
from rasc.vision.board import (  # noqa: F401  (Board, MIN_INTRINSICS_VIEWS re-exported)
    MIN_INTRINSICS_VIEWS,
    MIN_VIEW_CORNERS,
    Board,
    CharucoBoard,
    _is_integral,
    _is_number,
    seen_mask,
    spans_plane,
)
from rasc.vision.detect import (  # noqa: F401  (re-exported: the camera pipeline's names)
    CHARUCO_METHODS,
    CHARUCO_SUBPIX_FRACTION,
    DETECTORS,
    ORDER_RULES,
    SUBPIX_CRITERIA,
    _opencv_threads,
    _saddle_window,
    charuco_saddle_window,
    colour_score,
    detect_charuco,
    detect_corners,
    detect_views,
    order_corners,
    refine_saddle,
    saddle_points,
    square_means,
)
from rasc.vision.images import (  # noqa: F401  (re-exported: the camera pipeline's names)
    encode_png,
    read_image,
    to_grey,
    write_image,
)

#: re-exported too (not imported by name: parameters below are called image_size)
image_size = _images.image_size


#: Views whose board normals all lie within this angle of each other cannot fix the focal
#: length (Zhang: fronto-parallel planes leave f and depth coupled). The normals are
#: estimated with a nominal focal length (the larger image side), so this guards against
#: the clearly degenerate case only; well-spread sets differ by 30–70°.
MIN_ORIENTATION_SPREAD_DEG = 5.0


#: The distortion models (``dist_model``): name → (lens model, the coefficients estimated,
#: the stored length of ``dist``), :data:`rasc.geometry.lens.DIST_MODELS`, the one table.
DIST_MODELS = _lens.DIST_MODELS

#: OpenCV's flags for each pinhole ``dist_model`` (cv2.calibrateCamera); ``"fisheye"`` is
#: calibrated by cv2.fisheye.calibrate with :data:`FISHEYE_FLAGS`.
CALIB_FLAGS = {
    "opencv5": 0,
    "k1k2": cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST,
    "none": (cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3
             | cv2.CALIB_ZERO_TANGENT_DIST),
    "rational": cv2.CALIB_RATIONAL_MODEL,
}
#: cv2.fisheye.calibrate's flags: the per-view extrinsics re-estimated at every
#: iteration, no skew (as the pinhole models)
FISHEYE_FLAGS = cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW
FISHEYE_CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
#: the coefficients held at each stage of the fisheye calibration (:func:`_calibrate_fisheye`)
FISHEYE_STAGES = (cv2.fisheye.CALIB_FIX_K2 | cv2.fisheye.CALIB_FIX_K3 | cv2.fisheye.CALIB_FIX_K4,
                  cv2.fisheye.CALIB_FIX_K3 | cv2.fisheye.CALIB_FIX_K4, 0)

#: The model the wrong-lens check (:func:`is_wrong_lens`) fits beside the
#: chosen one: a pinhole model against the fisheye, the fisheye against OpenCV's five
#: coefficients ("none" is not checked: the user says there is no distortion).
LENS_CHECK_ALTERNATIVE = {"opencv5": "fisheye", "k1k2": "fisheye", "rational": "fisheye",
                          "fisheye": "opencv5"}


# ------------------------------------------------------------------------ intrinsics

def T_from_rvec_tvec(rvec: np.ndarray, tvec: np.ndarray) -> np.ndarray:
    """OpenCV (rvec, tvec) → ``T_cam_from_world`` (4, 4)."""
    R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3))
    return make_transform(R, np.asarray(tvec, dtype=np.float64).reshape(3))


def rvec_tvec_from_T(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``T_cam_from_world`` (4, 4) → OpenCV (rvec (3,), tvec (3,))."""
    T = np.asarray(T, dtype=np.float64)
    rvec, _ = cv2.Rodrigues(T[:3, :3])
    return rvec.reshape(3), T[:3, 3].copy()


def project_board(board: Board, T_cam_from_world: np.ndarray, K: np.ndarray,
                  dist: np.ndarray, lens: str = "pinhole") -> np.ndarray:
    """Pixel positions (N, 2) of the board's corners seen from ``T_cam_from_world``
    through the lens model ``lens`` (:data:`rasc.geometry.lens.LENS_MODELS`)."""
    if lens != "pinhole":
        T = np.asarray(T_cam_from_world, float)
        p_cam = board.object_points() @ T[:3, :3].T + T[:3, 3]
        return _lens.project_points(p_cam, K, dist, model=lens)
    rvec, tvec = rvec_tvec_from_T(T_cam_from_world)
    uv, _ = cv2.projectPoints(board.object_points(), rvec, tvec, np.asarray(K, float),
                              np.asarray(dist, float))
    return uv.reshape(-1, 2)


def reprojection_rms(corners: np.ndarray, board: Board, T_cam_from_world: np.ndarray,
                     K: np.ndarray, dist: np.ndarray, lens: str = "pinhole") -> float:
    """sqrt(Σ‖uv − û‖² / N): OpenCV's calibrateCamera RMS definition, for one view (over
    the corners seen: NaN rows of a partial view are left out)."""
    d = project_board(board, T_cam_from_world, K, dist, lens) - corners
    seen = seen_mask(corners)
    if not seen.all():
        d = d[seen]
    return float(np.sqrt(np.sum(d * d) / len(d)))


@dataclass
class IntrinsicsResult:
    """Output of :func:`calibrate_intrinsics`.

    K (3, 3); dist: the coefficients of :attr:`lens` (k1 k2 p1 p2 k3 for the pinhole
    models but the rational one's k1 k2 p1 p2 k3 k4 k5 k6; the fisheye's k1 k2 k3 k4);
    rms: OpenCV's overall RMS (px) over the views used (the fisheye's: the same
    definition, computed here); per_view_rms: name → RMS (px) of each view used;
    T_cam_from_world: name → (4, 4); outliers: names flagged by the robust rule
    (threshold ``outlier_threshold`` px);
    excluded: names left out of this calibration; initial: the calibration with every view
    when outliers were excluded and re-calibrated, else None.
    """

    K: np.ndarray
    dist: np.ndarray
    rms: float
    per_view_rms: dict[str, float]
    T_cam_from_world: dict[str, np.ndarray]
    outliers: list[str]
    outlier_threshold: float
    image_size: tuple[int, int]
    dist_model: str
    excluded: list[str] = field(default_factory=list)
    initial: IntrinsicsResult | None = None
    #: the wrong-lens check (:func:`_lens_check`): the chosen model's RMS over every view
    #: against another lens model's on the same views; None when not checked
    lens_check: dict | None = None

    @property
    def lens(self) -> str:
        """The lens model of :attr:`dist_model` (``"pinhole"`` or ``"fisheye"``)."""
        return DIST_MODELS[self.dist_model][0]

    def to_dict(self) -> dict:
        """JSON-ready dict of the intrinsics, their RMS per view, the outliers and the per-view
        extrinsics."""
        d = {"K": self.K.tolist(), "dist": self.dist.tolist(), "rms": self.rms,
             "per_view_rms": dict(self.per_view_rms), "outliers": list(self.outliers),
             "outlier_threshold": self.outlier_threshold, "image_size": list(self.image_size),
             "dist_model": self.dist_model, "excluded": list(self.excluded),
             "T_cam_from_world": {k: v.tolist() for k, v in self.T_cam_from_world.items()}}
        if self.lens != "pinhole":
            d["lens"] = self.lens
        if self.lens_check is not None:
            d["lens_check"] = dict(self.lens_check)
        if self.initial is not None:
            d["initial"] = self.initial.to_dict()
        return d


def outlier_threshold(per_view_rms: np.ndarray) -> float:
    """Robust per-view RMS threshold: max(3·median, median + 5·1.4826·MAD).

    Both parts are needed on real data: on OpenCV's stereo samples the MAD part alone
    would flag a merely mediocre view (left13, 0.46 px, median 0.19) and 3·median alone
    comes within 0.03 px of another (right05); the gross outlier (pair 02, 1.2 px) clears
    both by a wide margin.
    """
    r = np.asarray(per_view_rms, dtype=float)
    med = float(np.median(r))
    mad = float(np.median(np.abs(r - med)))
    return max(3.0 * med, med + 5.0 * 1.4826 * mad)


def _check_corners(name, corners, board: Board) -> np.ndarray:
    """Corners (N, 2) of one view; a target whose views may be partial (ChArUco) marks
    the corners not seen with NaN rows and needs 4 seen, not all on a line."""
    c = np.asarray(corners, dtype=np.float64)
    if c.ndim == 3 and c.shape[1] == 1:
        c = c.reshape(-1, 2)
    if c.shape != (board.n_corners, 2):
        raise InputError(f"view {name!r}: expected corners of shape ({board.n_corners}, 2) for a "
                         f"{board.nx}x{board.ny} board, got {c.shape}")
    if getattr(board, "partial_views", False):
        if np.any(np.isinf(c)) or np.any(np.isnan(c[:, 0]) != np.isnan(c[:, 1])):
            raise InputError(f"view {name!r}: corners contain infinity or half-NaN rows")
        seen = seen_mask(c)
        if seen.sum() < 4 or not spans_plane(board.object_points()[seen]):
            raise InputError(f"view {name!r}: {int(seen.sum())} corner(s) seen, not enough "
                             "for a pose (at least 4, not all on one line)")
        return c
    if not np.all(np.isfinite(c)):
        raise InputError(f"view {name!r}: corners contain NaN or infinity")
    return c


def orientation_spread_deg(corners: list[np.ndarray], board: Board,
                           image_size: tuple[int, int]) -> float:
    """Largest angle between two views' board normals, from homographies, degrees.

    Uses a nominal camera (focal length = larger image side, centre principal point): an
    intrinsics-free check that the views are not all parallel (see
    :data:`MIN_ORIENTATION_SPREAD_DEG`).
    """
    w, h = image_size
    f = float(max(w, h))
    K_nominal = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1.0]])
    xy_all = board.object_points()[:, :2]
    normals = []
    for c in corners:
        seen = seen_mask(c)
        xy = xy_all if seen.all() else xy_all[seen]
        H, _ = cv2.findHomography(xy, c if seen.all() else c[seen], 0)
        if H is None:
            continue
        B = np.linalg.solve(K_nominal, H)
        r1 = B[:, 0] / np.linalg.norm(B[:, 0])
        r2 = B[:, 1] / np.linalg.norm(B[:, 1])
        n = np.cross(r1, r2)
        normals.append(n / np.linalg.norm(n))
    if len(normals) < 2:
        return 0.0
    N = np.array(normals)
    return float(np.degrees(np.arccos(np.clip(N @ N.T, -1.0, 1.0))).max())


def _calibrate_once(names, corners, board, image_size, dist_model):
    obj_all = board.object_points().astype(np.float32)
    # per view its own corners (a partial view's subset, by id); whole views share one array
    masks = [seen_mask(c) for c in corners]
    obj = [obj_all if m.all() else obj_all[m] for m in masks]
    img = [(c if m.all() else c[m]).astype(np.float32).reshape(-1, 1, 2)
           for c, m in zip(corners, masks, strict=True)]
    lens_model, _, n_dist = DIST_MODELS[dist_model]
    if lens_model == "fisheye":
        rms, K, dist, rvecs, tvecs = _calibrate_fisheye(names, obj, img, image_size)
    elif dist_model == "rational":
        rms, K, dist, rvecs, tvecs = _calibrate_rational(obj, img, image_size)
    else:
        rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(
            obj, img, tuple(int(v) for v in image_size), None, None,
            flags=CALIB_FLAGS[dist_model])
    K = np.asarray(K, dtype=np.float64)
    dist = np.asarray(dist, dtype=np.float64).ravel()[:n_dist]
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(dist)) and np.isfinite(rms)):
        raise DegenerateDataError(
            f"calibrate_intrinsics: OpenCV returned NaN for {len(names)} views; add views of "
            "the board tilted 20–45° about different axes")
    T = {n: T_from_rvec_tvec(r, t) for n, r, t in zip(names, rvecs, tvecs, strict=True)}
    try:
        per_view = {n: reprojection_rms(c, board, T[n], K, dist, lens_model)
                    for n, c in zip(names, corners, strict=True)}
    except InputError:        # a fitted board behind the camera: the fit failed
        raise DegenerateDataError(
            f"calibrate_intrinsics: the {dist_model} calibration of {len(names)} views put a "
            "board behind the camera; check the views and the lens model") from None
    if lens_model == "fisheye":     # OpenCV's fisheye RMS is not calibrateCamera's
        n_pts = sum(len(i) for i in img)
        rms = float(np.sqrt(sum(per_view[n] ** 2 * len(i)
                                for n, i in zip(names, img, strict=True)) / n_pts))
    return float(rms), K, dist, T, per_view


def _calibrate_rational(obj, img, image_size):
    """cv2.calibrateCamera with the rational model from two starts, the better (lower
    RMS) kept: OpenCV's own start, and the ``k1k2`` calibration's K and k1 k2
    (``CALIB_USE_INTRINSIC_GUESS``). From OpenCV's start alone the fit stopped in local
    minima on a 150° fisheye (E11's, seeds 0-2, 0.05 px noise: 4 of 6 eyes at 1.0-2.3 px
    RMS; with the views 0.25-0.6 m away, 5 of 6 at 1.0-17 px), where the start from
    ``k1k2`` reached 0.068-0.070 px on all six; the refinement, which holds the
    coefficients it cannot determine at the intrinsics' value, could not always leave
    them (seed 0's right eye: hand-eye 1.09°, 108 mm; 0.021°, 0.49 mm from here)."""
    size = tuple(int(v) for v in image_size)
    best = cv2.calibrateCamera(obj, img, size, None, None, flags=CALIB_FLAGS["rational"])
    _, K0, d0, _, _ = cv2.calibrateCamera(obj, img, size, None, None,
                                          flags=CALIB_FLAGS["k1k2"])
    d0 = np.r_[np.asarray(d0, float).ravel()[:2], np.zeros(12)]
    try:
        staged = cv2.calibrateCamera(obj, img, size, np.asarray(K0, float), d0,
                                     flags=CALIB_FLAGS["rational"]
                                     | cv2.CALIB_USE_INTRINSIC_GUESS)
    except cv2.error:
        return best
    if np.isfinite(staged[0]) and not staged[0] >= best[0]:
        return staged
    return best


def _calibrate_fisheye(names, obj, img, image_size):
    """cv2.fisheye.calibrate with its input shapes ((1, N, 3) and (1, N, 2) float64 per
    view) and its failures (cv2.error on a view it cannot fit, or an ill-conditioned
    problem) as one :class:`DegenerateDataError` line.

    In stages (:data:`FISHEYE_STAGES`): k1 alone from OpenCV's own start, then k1 k2 and
    then all four from the stage before. In one go from OpenCV's start the fit diverged
    on detected corners of a 170° lens (12 views, corners within 0.23 px: RMS 144 px, a
    board behind the camera), where the stages reached 0.036 px."""
    obj_f = [np.ascontiguousarray(o, dtype=np.float64).reshape(1, -1, 3) for o in obj]
    img_f = [np.ascontiguousarray(i, dtype=np.float64).reshape(1, -1, 2) for i in img]
    size = tuple(int(v) for v in image_size)
    K, D = np.zeros((3, 3)), np.zeros(4)
    try:
        for k, fixed in enumerate(FISHEYE_STAGES):
            flags = FISHEYE_FLAGS | fixed | (cv2.fisheye.CALIB_USE_INTRINSIC_GUESS if k else 0)
            rms, K, D, rvecs, tvecs = cv2.fisheye.calibrate(
                obj_f, img_f, size, K, D, flags=flags, criteria=FISHEYE_CRITERIA)
    except cv2.error as exc:
        lines = [ln for ln in str(exc).splitlines() if ln.strip()]
        why = lines[-1].split(") ", 1)[-1].strip() if lines else "no detail"
        raise DegenerateDataError(
            f"calibrate_intrinsics: cv2.fisheye.calibrate failed on {len(names)} views "
            f"({why}); check that the lens is a fisheye (else use another --dist-model) and "
            "that the views show the board whole, tilted 20-45° about different axes") from None
    return rms, K, D, rvecs, tvecs


def _lens_check(names, corners, board, image_size, dist_model, rms):
    """The wrong-lens check's numbers (:func:`is_wrong_lens`): the chosen model's RMS
    over ``names`` against that of :data:`LENS_CHECK_ALTERNATIVE` fitted to the same
    views, with the corners and views counted for the F test (:func:`lens_check_F`);
    None for a model not checked ("none")."""
    alt = LENS_CHECK_ALTERNATIVE.get(dist_model)
    if alt is None:
        return None
    try:
        alt_rms = _calibrate_once(names, corners, board, image_size, alt)[0]
    except (DegenerateDataError, InputError):
        alt_rms = None            # the other model cannot be fitted: no evidence against
    return {"dist_model": dist_model, "rms_px": rms, "alternative": alt,
            "alternative_rms_px": alt_rms,
            "corners": int(sum(int(seen_mask(c).sum()) for c in corners)),
            "views": len(names)}


@_opencv_threads(1)
def calibrate_intrinsics(views: dict[str, np.ndarray], board: Board,
                         image_size: tuple[int, int], dist_model: str = "opencv5",
                         outlier_rms: float | None = None,
                         exclude_outliers: bool = False) -> IntrinsicsResult:
    """Zhang calibration with cv2.calibrateCamera; per-view RMS and outlier views.

    Parameters
    ----------
    views : dict name → corners (N, 2) in canonical order (any consistent or per-view
        180° relabelling gives the same K, dist and RMS: each view has its own pose).
    board : Board
    image_size : (width, height) in pixels
    dist_model : "opencv5" (k1 k2 p1 p2 k3), "k1k2" (p1 = p2 = k3 = 0), "none" (all 0),
        "rational" (OpenCV's rational model, k1 k2 p1 p2 k3 k4 k5 k6) or "fisheye"
        (cv2.fisheye's equidistant model, k1 k2 k3 k4): :data:`DIST_MODELS`
    outlier_rms : per-view RMS (px) above which a view is an outlier; None → the robust
        rule :func:`outlier_threshold`.
    exclude_outliers : re-calibrate without the outliers; the result then holds the
        re-calibration, with the all-views calibration in ``initial``.

    Raises
    ------
    DegenerateDataError : fewer than :data:`MIN_INTRINSICS_VIEWS` views, or all views at
        nearly the same orientation (:data:`MIN_ORIENTATION_SPREAD_DEG`).
    """
    if dist_model not in DIST_MODELS:
        raise InputError(f"calibrate_intrinsics: unknown dist_model {dist_model!r} "
                         f"(use one of {', '.join(DIST_MODELS)})")
    try:
        w, h = (int(v) for v in image_size)
    except (TypeError, ValueError):
        raise InputError(f"calibrate_intrinsics: image_size must be (width, height), "
                         f"got {image_size!r}") from None
    if w <= 0 or h <= 0:
        raise InputError(f"calibrate_intrinsics: image_size must be positive, got {image_size!r}")
    names = [str(n) for n in views]
    corners = [_check_corners(n, c, board) for n, c in views.items()]
    if len(names) < MIN_INTRINSICS_VIEWS:
        raise DegenerateDataError(
            f"calibrate_intrinsics: {len(names)} view(s) with the board found; need at least "
            f"{MIN_INTRINSICS_VIEWS} views with the board tilted 20–45° about different axes")
    spread = orientation_spread_deg(corners, board, (w, h))
    if spread < MIN_ORIENTATION_SPREAD_DEG:
        raise DegenerateDataError(
            f"calibrate_intrinsics: all {len(names)} views show the board at nearly the same "
            f"orientation (normals within {spread:.1f}° < {MIN_ORIENTATION_SPREAD_DEG:g}°), so the "
            "focal length is undetermined; add views with the board tilted 20–45° about "
            "different axes")
    rms, K, dist, T, per_view = _calibrate_once(names, corners, board, (w, h), dist_model)
    check = _lens_check(names, corners, board, (w, h), dist_model, rms)
    threshold = float(outlier_rms) if outlier_rms is not None else \
        outlier_threshold(np.array(list(per_view.values())))
    outliers = [n for n in names if per_view[n] > threshold]
    result = IntrinsicsResult(K=K, dist=dist, rms=rms, per_view_rms=per_view,
                              T_cam_from_world=T, outliers=outliers,
                              outlier_threshold=threshold, image_size=(w, h),
                              dist_model=dist_model, lens_check=check)
    if not exclude_outliers or not outliers:
        return result
    keep = {n: c for n, c in zip(names, corners, strict=True) if n not in outliers}
    if len(keep) < MIN_INTRINSICS_VIEWS:
        raise DegenerateDataError(
            f"calibrate_intrinsics: only {len(keep)} view(s) left after excluding outliers "
            f"{outliers}; need at least {MIN_INTRINSICS_VIEWS} good views")
    rms2, K2, dist2, T2, per_view2 = _calibrate_once(list(keep), list(keep.values()), board,
                                                     (w, h), dist_model)
    return IntrinsicsResult(K=K2, dist=dist2, rms=rms2, per_view_rms=per_view2,
                            T_cam_from_world=T2, outliers=outliers,
                            outlier_threshold=threshold, image_size=(w, h),
                            dist_model=dist_model, excluded=list(outliers), initial=result,
                            lens_check=check)


# ------------------------------------------------------------------ the lens check

#: The wrong-lens check: the intrinsics views of every eye are fitted with the chosen
#: ``dist_model`` and with another lens model (:data:`LENS_CHECK_ALTERNATIVE`: a pinhole
#: model against the fisheye, the fisheye against OpenCV's five coefficients). The chosen
#: model is wrong when the other explains the views better than the corners' noise can
#: (the F test of :func:`lens_check_F` above this) AND by a practical amount
#: (:data:`WRONG_LENS_EXCESS`). Measured on projected corners (E11's heads: a pinhole of
#: 60-120° and a fisheye of 60-150°, 20 intrinsics views of 54 corners, noise 0.03, 0.05,
#: 0.1, 0.2 and 0.3 px; docs/topics/lenses.md, "Choosing a model"): fitted with the right
#: model (pinhole data by ``k1k2`` and ``opencv5``, fisheye data by ``fisheye``) F was at
#: most 3.7 (F ≤ 0 where the other model cannot follow the lens); a 60° or 90° pinhole
#: fitted as a fisheye fits to the noise (F ≤ 1.6). A 90° fisheye fitted with ``k1k2``
#: (hand-eye 13× the right model's error in E11) gave F of 1e3-3e4 on OpenCV's fit and
#: above 100 after the refinement at 0.05 px; a 60° fisheye, whose ``k1k2`` fit costs
#: nothing measurable, 37-370 at 0.03-0.05 px. 10 leaves room above the right models.
WRONG_LENS_F_WARN = 10.0
#: ... and only when the chosen model leaves at least this share of the other's RMS
#: unexplained: rms² − rms_other² > (WRONG_LENS_EXCESS · rms_other)². F alone grows with
#: the number of corners: with thousands of corners an excess of a few per cent of the
#: noise passes F = 10 and costs nothing (the right models left at most 8.5 % measured,
#: with F ≤ 3.7); the 90° fisheye fitted with ``k1k2`` left 150 % after the refinement
#: at 0.05 px.
WRONG_LENS_EXCESS = 0.1

WRONG_LENS_REMEDY = "calibrate with --dist-model"


def lens_check_F(check: dict, rms: float | None = None) -> float | None:
    """The F statistic of a lens check: the chosen model's extra residual per coefficient
    of the other model, over the other model's residual variance ::

        F = [(RSS − RSS_other) / q] / [RSS_other / (2N − 4 − q − 6V)]

    with N corners over V views, RSS = N·rms² (OpenCV's RMS is per corner over both
    coordinates) and q the other model's coefficients. ≲ 1 when both models explain the
    views to the noise (the other's extra freedom fits at most q noise dimensions), ≫ 1
    when only the other does. ``rms``: the chosen model's RMS (default
    :func:`lens_check_rms`). None when a number is missing (a check written before it
    counted its corners)."""
    rms = lens_check_rms(check) if rms is None else rms
    alt = check.get("alternative_rms_px")
    n, v = check.get("corners"), check.get("views")
    if rms is None or not isinstance(alt, int | float) or not isinstance(n, int) \
            or not isinstance(v, int) or check.get("alternative") not in DIST_MODELS:
        return None
    q = len(DIST_MODELS[check["alternative"]][1])
    df = 2 * n - 4 - q - 6 * v
    if not (np.isfinite(rms) and np.isfinite(alt)) or df <= 0:
        return None
    if alt <= 0:
        return float("inf") if rms > 0 else 0.0
    return float((n * (rms ** 2 - alt ** 2) / q) / (n * alt ** 2 / df))


def is_wrong_lens(rms: float | None, alternative_rms: float | None,
                  F: float | None = None) -> bool:
    """The chosen lens model does not fit the intrinsics views that another one does:
    the F test (:func:`lens_check_F`) above :data:`WRONG_LENS_F_WARN` (when known) and
    the chosen model's RMS above the other's by :data:`WRONG_LENS_EXCESS` of it in
    quadrature (False when either RMS is unknown)."""
    if rms is None or alternative_rms is None or not np.isfinite(rms) \
            or not np.isfinite(alternative_rms):
        return False
    if F is not None and not F > WRONG_LENS_F_WARN:
        return False
    return bool(rms ** 2 - alternative_rms ** 2 > (WRONG_LENS_EXCESS * alternative_rms) ** 2)


def lens_check_rms(check: dict) -> float | None:
    """The chosen model's RMS of a lens check: the better of the intrinsics'
    (``rms_px``) and the whole-head refinement's (``refined_rms_px``, when refined)."""
    vals = [v for v in (check.get("rms_px"), check.get("refined_rms_px"))
            if isinstance(v, int | float) and np.isfinite(v)]
    return min(vals) if vals else None


def wrong_lens_warning(check: dict | None) -> str | None:
    """One line for the user when an eye's lens check (the intrinsics result's
    ``lens_check``) finds the chosen model wrong (:func:`is_wrong_lens` of
    :func:`lens_check_rms` against the other model's RMS, with :func:`lens_check_F`),
    else None."""
    if not check:
        return None
    rms = lens_check_rms(check)
    if not is_wrong_lens(rms, check.get("alternative_rms_px"), lens_check_F(check, rms)):
        return None
    chosen, alt = check["dist_model"], check["alternative"]
    F = lens_check_F(check, rms)
    return (f"the lens model {chosen!r} leaves the intrinsics views at "
            f"{rms:.3g} px RMS where the {alt!r} model fits them to "
            f"{check['alternative_rms_px']:.3g} px"
            + (f" (F = {F:.3g} > {WRONG_LENS_F_WARN:g})" if F is not None else "")
            + ": the lens is probably "
            f"{'a fisheye' if alt == 'fisheye' else 'not a fisheye'}; "
            f"{WRONG_LENS_REMEDY} {alt}")


# ------------------------------------------------------------------------ extrinsics

@_opencv_threads(1)
def estimate_extrinsics(corners: np.ndarray, board: Board, K: np.ndarray,
                        dist: np.ndarray, lens: str = "pinhole") -> tuple[np.ndarray, float]:
    """Board pose with intrinsics fixed (docs/METHOD.md §7): IPPE, then Levenberg–Marquardt
    refinement.

    A lens other than the pinhole (``lens="fisheye"``): the corners are undistorted to
    normalised coordinates by the lens model (:func:`rasc.geometry.lens.undistort_normalized`),
    IPPE and LM run there with an identity camera and no distortion, and the pose is then
    refined on the pixels through the lens (least squares, the same RMS as below).

    Parameters
    ----------
    corners : (N, 2) canonical order; board : Board; K : (3, 3); dist : (k,) OpenCV order
    lens : the lens model of ``dist`` (:data:`rasc.geometry.lens.LENS_MODELS`)

    Returns
    -------
    T_cam_from_world : (4, 4); rms : reprojection RMS in px (same definition as OpenCV's).
    """
    c = _check_corners("extrinsics", corners, board)
    K = np.asarray(K, dtype=np.float64)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise InputError(f"estimate_extrinsics: K must be a finite 3x3 matrix, got {K.shape}")
    obj = board.object_points()
    seen = seen_mask(c)
    if not seen.all():             # a partial view: the corners it shows, by id
        obj, c = obj[seen], c[seen]
    # OpenCV's own path for the pinhole models (the rational one too), the fisheye through
    # the lens core
    own = lens != "pinhole"
    if not own:
        pts, K_pnp, d_pnp = c, K, dist
    else:
        x, y = (c[:, 0] - K[0, 2] - K[0, 1] * (c[:, 1] - K[1, 2]) / K[1, 1]) / K[0, 0], \
            (c[:, 1] - K[1, 2]) / K[1, 1]
        pts = _lens.undistort_normalized(np.stack([x, y], axis=1), dist, model=lens)
        K_pnp, d_pnp = np.eye(3), np.zeros(0)
    ok, rvec, tvec = cv2.solvePnP(obj, pts, K_pnp, d_pnp, flags=cv2.SOLVEPNP_IPPE)
    if not ok or not (np.all(np.isfinite(rvec)) and np.all(np.isfinite(tvec))):
        raise DegenerateDataError(
            "estimate_extrinsics: no pose fits these corners (collinear or coincident?); "
            "use a view where the whole board is seen")
    rvec, tvec = cv2.solvePnPRefineLM(
        obj, pts, K_pnp, d_pnp, rvec, tvec,
        criteria=(cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-12))
    T = T_from_rvec_tvec(rvec, tvec)
    if own and np.all(obj @ T[2, :3] + T[2, 3] > 0):
        T = _refine_pose_pixels(T, obj, c, K, dist, lens)
    # the corners seen must lie in front of the camera (not the board's origin: a large
    # board seen in part at a wide pan may have its corner 0 behind the image plane)
    if not np.all(obj @ T[2, :3] + T[2, 3] > 0):
        raise DegenerateDataError("estimate_extrinsics: the fitted board lies behind the camera; "
                                  "check the corners and intrinsics")
    d = project_board(board, T, K, dist, lens)[seen] - c
    return T, float(np.sqrt(np.sum(d * d) / len(d)))


def _refine_pose_pixels(T0, obj, uv, K, dist, lens):
    """The pose ``T0`` refined on the pixels ``uv`` of ``obj`` through the lens model
    (Levenberg–Marquardt on a small rotation and the translation)."""
    from scipy.optimize import least_squares

    R0 = T0[:3, :3]

    def residuals(p):
        R = matrix_from_rotvec(p[:3]) @ R0
        pc = obj @ R.T + p[3:]
        if np.any(pc[:, 2] <= 0):
            return np.full(2 * len(obj), 1e6)
        return (_lens.project_points(pc, K, dist, model=lens) - uv).ravel()

    res = least_squares(residuals, np.r_[np.zeros(3), T0[:3, 3]], method="lm",
                        xtol=1e-14, ftol=1e-14, gtol=1e-14)
    return make_transform(matrix_from_rotvec(res.x[:3]) @ R0, res.x[3:])
