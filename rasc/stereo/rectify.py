"""Stereo rectification of a calibrated active head at any gaze.

A fixed stereo rig is rectified once (OpenCV's ``stereoRectify``); an active head's two
cameras move with every pan-tilt reading, so its rectification is a function of the four
readings. For readings ``(pan_l, tilt_l)``, ``(pan_r, tilt_r)`` (radians):

1. each eye's pose in the base frame, eq. 1–2 through its calibrated unit
   (:meth:`rasc.head.model.EyeCalibration.T_cam_from_base`);
2. the right camera in the left one, in OpenCV's convention (``x_right = R x_left + T``,
   the ``R, T`` that ``cv2.stereoCalibrate`` returns)::

       T_camR_from_camL = T_camR_from_base @ inv(T_camL_from_base)

3. ``cv2.stereoRectify`` with the calibrated ``K`` and ``dist`` of each eye and that
   ``R, T``: the rectifying rotations ``R1``, ``R2`` (rectified from camera), the new
   projection matrices ``P1``, ``P2`` (3×4, rectified pixels) and the disparity-to-depth
   matrix ``Q`` (4×4), with OpenCV's flags and ``alpha``; for fisheye eyes
   (``EyeCalibration.lens == "fisheye"``) ``cv2.fisheye.stereoRectify`` with its
   ``balance`` and ``fov_scale`` instead of ``alpha`` (and the valid rectangles, which it
   does not return, computed as ``cv2.stereoRectify`` computes them);
4. ``cv2.initUndistortRectifyMap`` per eye (``cv2.fisheye.initUndistortRectifyMap`` for
   fisheye eyes): the remap tables.

A pinhole eye with 8 coefficients (OpenCV's rational model) goes to ``cv2.stereoRectify``
as it is. Both eyes must have one lens model. :meth:`StereoRectification.rectify_points`
undistorts through the lens model of :mod:`rasc.geometry.lens` (Newton's method to
convergence) rather than ``cv2.undistortPoints``, whose fixed 5 iterations leave 0.1–0.25 px
under strong distortion.

Every output means what it means in OpenCV: ``cv2.reprojectImageTo3D(disparity, Q)``
gives points in the rectified left camera frame (length unit of the calibration), and
:attr:`StereoRectification.T_base_from_rect` takes them into the head's base frame
(rotated by ``R1`` from the left camera; same origin). With OpenCV's default
``CALIB_ZERO_DISPARITY`` the disparity is ``x_left − x_right`` of rectified pixels.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry import lens as lens_models
from rasc.geometry.frames import EYES
from rasc.geometry.transforms import invert_transform
from rasc.head.model import HeadCalibration

#: remap table types (``--map-type``): OpenCV's fixed-point pair (``CV_16SC2``, what its
#: stereo sample uses: faster remapping, 1/32 px interpolation tables) or two float maps
#: (``CV_32FC1``: exact coordinates)
MAP_TYPES = {"fixed": cv2.CV_16SC2, "float": cv2.CV_32FC1}
#: cameras whose centres are closer than this (in the calibration's length unit) have no
#: baseline to rectify along (the same point; a calibration in metres: 1 nm)
MIN_BASELINE = 1e-9
#: largest ``fov_scale`` accepted: the rectified focal length divided by 10 already
#: squeezes a 60° field into a tenth of the image
MAX_FOV_SCALE = 10.0
#: points per source image edge that give a fisheye pair's valid rectangles
#: (:func:`_inner_rectangle`; OpenCV takes 9 for a pinhole pair, whose edges bend less)
INNER_RECT_EDGE_POINTS = 257


@dataclass(frozen=True)
class RectifyOptions:
    """How to rectify: OpenCV's ``stereoRectify`` options, and the remap tables' type.

    Attributes
    ----------
    alpha : float
        Pinhole eyes: OpenCV's free scaling, -1 its default scaling, 0 only valid pixels
        (zoomed in), 1 every source pixel kept (black borders), or between. Fisheye eyes
        refuse any but -1 (``cv2.fisheye.stereoRectify`` has no alpha: use ``balance``).
    balance : float or None
        Fisheye eyes: ``cv2.fisheye.stereoRectify``'s balance, 0 (its default: the new
        focal length keeps only valid pixels) to 1 (the whole fisheye image, the focal
        length shrunk to fit); None means 0. Pinhole eyes refuse it.
    fov_scale : float or None
        Fisheye eyes: ``cv2.fisheye.stereoRectify``'s fov_scale, the new focal length
        divided by it (> 1 widens the rectified field of view); None means 1. Pinhole eyes
        refuse it.
    zero_disparity : bool
        OpenCV's ``CALIB_ZERO_DISPARITY`` (its default): both principal points at the same
        rectified pixel, so disparity is ``x_left − x_right``.
    map_type : {"fixed", "float"}
        :data:`MAP_TYPES`: ``CV_16SC2`` (default) or ``CV_32FC1`` tables.
    """

    alpha: float = -1.0
    zero_disparity: bool = True
    map_type: str = "fixed"
    balance: float | None = None
    fov_scale: float | None = None

    def __post_init__(self):
        a = self.alpha
        if isinstance(a, bool) or not isinstance(a, int | float | np.number) or not (
                a == -1 or 0.0 <= a <= 1.0):
            raise InputError(f"alpha: expected -1 (OpenCV's default scaling) or a number "
                             f"from 0 to 1, got {a!r}")
        b = self.balance
        if b is not None and (isinstance(b, bool) or not isinstance(b, int | float | np.number)
                              or not 0.0 <= b <= 1.0):
            raise InputError(f"balance: expected a number from 0 (only valid pixels) to 1 "
                             f"(the whole fisheye image), got {b!r}")
        f = self.fov_scale
        if f is not None and (isinstance(f, bool) or not isinstance(f, int | float | np.number)
                              or not (np.isfinite(f) and 0.0 < f <= MAX_FOV_SCALE)):
            raise InputError(f"fov_scale: expected a number above 0 and at most "
                             f"{MAX_FOV_SCALE:g} (the rectified focal length divided by "
                             f"it), got {f!r}")

    def for_lens(self, model: str) -> RectifyOptions:
        """These options checked against the eyes' lens model, fisheye's two made
        explicit (OpenCV's defaults: balance 0, fov_scale 1)."""
        if model == "fisheye":
            if self.alpha != -1:
                raise InputError(f"alpha {self.alpha:g}: the eyes are fisheye, whose "
                                 "rectification (cv2.fisheye.stereoRectify) has no alpha; "
                                 "use balance (0 only valid pixels, 1 the whole image) and "
                                 "fov_scale")
            return replace(self, balance=0.0 if self.balance is None else float(self.balance),
                           fov_scale=1.0 if self.fov_scale is None else float(self.fov_scale))
        for name in ("balance", "fov_scale"):
            if getattr(self, name) is not None:
                raise InputError(f"{name}: only for fisheye eyes (cv2.fisheye.stereoRectify); "
                                 f"these eyes are {model}: use alpha")
        return self
        if self.map_type not in MAP_TYPES:
            raise InputError(f"map_type: expected one of {', '.join(MAP_TYPES)}, got "
                             f"{self.map_type!r}")


@dataclass(frozen=True, eq=False)
class StereoRectification:
    """The rectification of a head at one pair of readings (OpenCV's names and meanings).

    Attributes
    ----------
    readings : dict
        ``{"left": (pan, tilt), "right": (pan, tilt)}``, radians.
    image_size : (int, int)
        (width, height) of both eyes' images, and of the rectified ones.
    T_cam_from_base : dict
        ``{"left": (4, 4), "right": (4, 4)}``: each camera at its readings.
    K, dist : dict
        Each eye's calibrated intrinsics and distortion coefficients (what was rectified;
        ``lens`` says which model's).
    R, T : ndarray, shapes (3, 3) and (3,)
        The right camera from the left one (``x_right = R x_left + T``).
    R1, R2 : ndarray, shape (3, 3)
        Rectified frame from each camera (OpenCV's rectification transforms).
    P1, P2 : ndarray, shape (3, 4)
        Projection matrices in the rectified frame of the left camera.
    Q : ndarray, shape (4, 4)
        Disparity-to-depth matrix: ``[X Y Z W] = Q [x y d 1]``.
    roi1, roi2 : (int, int, int, int)
        OpenCV's valid rectangles (x, y, width, height): the largest rectangle of the
        rectified image whose every pixel comes from inside the source image.
    vertical : bool
        The baseline runs mostly along the cameras' y axes: OpenCV rectifies to columns.
    maps : dict or None
        ``{"left": (map1, map2), "right": (map1, map2)}`` for ``cv2.remap`` (None when not
        computed).
    options : RectifyOptions
        As used: for fisheye eyes with ``balance`` and ``fov_scale`` made explicit.
    lens : str
        Both eyes' lens model (:data:`rasc.geometry.lens.LENS_MODELS`).
    """

    readings: dict[str, tuple[float, float]]
    image_size: tuple[int, int]
    T_cam_from_base: dict[str, np.ndarray]
    K: dict[str, np.ndarray]
    dist: dict[str, np.ndarray]
    R: np.ndarray
    T: np.ndarray
    R1: np.ndarray
    R2: np.ndarray
    P1: np.ndarray
    P2: np.ndarray
    Q: np.ndarray
    roi1: tuple[int, int, int, int]
    roi2: tuple[int, int, int, int]
    vertical: bool
    options: RectifyOptions = field(default_factory=RectifyOptions)
    maps: dict[str, tuple[np.ndarray, np.ndarray]] | None = None
    lens: str = "pinhole"

    @property
    def baseline(self) -> float:
        """Distance between the two optical centres (the calibration's length unit)."""
        return float(np.linalg.norm(self.T))

    @property
    def T_rect_from_base(self) -> np.ndarray:
        """The rectified left camera frame (where ``Q``'s points are) from the base (4, 4)."""
        R_rect = np.eye(4)
        R_rect[:3, :3] = self.R1
        return R_rect @ self.T_cam_from_base["left"]

    @property
    def T_base_from_rect(self) -> np.ndarray:
        """The base from the rectified left camera frame (4, 4): ``p_base`` of
        ``cv2.reprojectImageTo3D``'s points."""
        return invert_transform(self.T_rect_from_base)

    def rectify_points(self, eye: str, uv: np.ndarray) -> np.ndarray:
        """Measured (distorted) pixels (N, 2) of ``eye`` → rectified pixels (N, 2).

        What ``cv2.undistortPoints`` (``cv2.fisheye.undistortPoints``) with this eye's
        ``R1``/``P1`` or ``R2``/``P2`` computes, but undistorted through the lens model
        (:func:`rasc.geometry.lens.undistort_normalized`) to convergence: each pixel's
        ray, turned by ``R1`` (``R2``), projected by ``P1`` (``P2``)'s left 3×3. A ray that
        turns behind the rectified camera (possible only for a fisheye pixel near 90° off
        its axis) has no rectified pixel: NaN. Raises :class:`InputError` for a pixel
        outside the region where the lens model is invertible.
        """
        uv = np.asarray(uv, dtype=float)
        if uv.ndim != 2 or uv.shape[1] != 2:
            raise InputError(f"uv: expected shape (N, 2), got {uv.shape}")
        if eye not in EYES:
            raise InputError(f"eye: expected left or right, got {eye!r}")
        R, P = (self.R1, self.P1) if eye == "left" else (self.R2, self.P2)
        rays = self._rays(eye, uv) @ R.T
        with np.errstate(divide="ignore", invalid="ignore"):
            out = rays[:, :2] / rays[:, 2:]
        out[~(rays[:, 2] > 0.0)] = np.nan
        return out @ P[:2, :2].T + P[:2, 2]

    def _rays(self, eye: str, uv: np.ndarray) -> np.ndarray:
        """Each pixel's ray (x, y, 1) in the camera frame (normalised, undistorted)."""
        K = self.K[eye]
        y = (uv[:, 1] - K[1, 2]) / K[1, 1]
        x = (uv[:, 0] - K[0, 2] - K[0, 1] * y) / K[0, 0]
        xy = lens_models.undistort_normalized(np.c_[x, y], self.dist[eye], model=self.lens)
        return np.c_[xy, np.ones(len(xy))]

    def points_from_disparity(self, uv_left_rect: np.ndarray, disparity) -> np.ndarray:
        """Rectified left pixels (N, 2) and their disparities (N,) → points in the base
        frame (N, 3), through ``Q`` and :attr:`T_base_from_rect`."""
        uv = np.asarray(uv_left_rect, dtype=float).reshape(-1, 2)
        d = np.broadcast_to(np.asarray(disparity, dtype=float), (uv.shape[0],))
        X = np.c_[uv, d, np.ones(len(d))] @ self.Q.T
        p_rect = X[:, :3] / X[:, 3:]
        T = self.T_base_from_rect
        return p_rect @ T[:3, :3].T + T[:3, 3]

    def to_dict(self) -> dict:
        """JSON-ready geometry (no maps): readings (radians), image size, the relative pose,
        R1, R2, P1, P2, Q, the valid rectangles, the baseline, the options."""
        return {"readings": {eye: {"pan": float(self.readings[eye][0]),
                                   "tilt": float(self.readings[eye][1])} for eye in EYES},
                "image_size": list(self.image_size),
                "T_cam_from_base": {eye: self.T_cam_from_base[eye].tolist() for eye in EYES},
                "K": {eye: self.K[eye].tolist() for eye in EYES},
                "dist": {eye: self.dist[eye].tolist() for eye in EYES},
                "R": self.R.tolist(), "T": self.T.tolist(),
                "R1": self.R1.tolist(), "R2": self.R2.tolist(),
                "P1": self.P1.tolist(), "P2": self.P2.tolist(), "Q": self.Q.tolist(),
                "roi1": list(self.roi1), "roi2": list(self.roi2),
                "vertical": self.vertical, "baseline": self.baseline,
                "T_rect_from_base": self.T_rect_from_base.tolist(),
                "lens": self.lens,
                "options": {"alpha": float(self.options.alpha),
                            "zero_disparity": self.options.zero_disparity,
                            "map_type": self.options.map_type,
                            "balance": self.options.balance,
                            "fov_scale": self.options.fov_scale}}


def _dist(dist: np.ndarray, model: str = "pinhole") -> np.ndarray:
    """OpenCV's coefficients (an empty model: no distortion; fisheye: 4 zeros)."""
    return dist if dist.size else np.zeros(4 if model == "fisheye" else 5)


def _lens(head: HeadCalibration) -> str:
    """The eyes' one lens model (a pair of two models is refused: OpenCV rectifies a
    pinhole pair or a fisheye pair)."""
    models = {eye: getattr(head, eye).lens for eye in EYES}
    if models["left"] != models["right"]:
        raise InputError(f"lens: the eyes' lens models differ (left {models['left']}, right "
                         f"{models['right']}); rectification takes a pair of one model "
                         "(cv2.stereoRectify or cv2.fisheye.stereoRectify)")
    return models["left"]


def _fisheye_tables(K, dist, R, P, size, kind):
    """``cv2.fisheye.initUndistortRectifyMap`` of one eye, made safe for fixed-point
    tables: OpenCV writes ±inf where a rectified pixel's ray lies behind the camera, which
    float tables remap to the border but ``CV_16SC2`` turns into source pixel 0 (measured:
    half of a rectified image at a turned gaze filled from the source's corner). Those
    entries become (−1, −1), outside the image, before the fixed-point conversion
    (``cv2.convertMaps``, OpenCV's own rounding to 1/32 px)."""
    mx, my = cv2.fisheye.initUndistortRectifyMap(K, dist, R, P, size, cv2.CV_32FC1)
    behind = ~(np.isfinite(mx) & np.isfinite(my))
    mx[behind] = -1.0
    my[behind] = -1.0
    return (mx, my) if kind == cv2.CV_32FC1 else cv2.convertMaps(mx, my, kind)


def _inner_rectangle(rect: StereoRectification, eye: str) -> tuple[int, int, int, int]:
    """The valid rectangle of ``eye``'s rectified image as ``cv2.stereoRectify`` finds it
    (its getRectangles: the inner rectangle of the source image's edges, rectified, within
    the image), for a fisheye pair, whose rectified edges bend far more than a pinhole's:
    :data:`INNER_RECT_EDGE_POINTS` points per edge where OpenCV takes 9. An edge point
    whose ray has no rectified pixel (turned behind the rectified camera: the source
    image reaches past the rectified view there) bounds nothing; (0, 0, 0, 0) when
    nothing is valid."""
    w, h = rect.image_size
    n = INNER_RECT_EDGE_POINTS
    xs, ys = np.linspace(0, w - 1, n), np.linspace(0, h - 1, n)
    edges = np.concatenate([np.c_[np.zeros(n), ys], np.c_[np.full(n, w - 1.0), ys],
                            np.c_[xs, np.zeros(n)], np.c_[xs, np.full(n, h - 1.0)]])
    try:
        out = rect.rectify_points(eye, edges)
    except InputError:                   # an edge point beyond the lens's fold: one by one
        out = np.full_like(edges, np.nan)
        for i in range(len(edges)):
            with contextlib.suppress(InputError):
                out[i] = rect.rectify_points(eye, edges[i:i + 1])[0]
    left, right, top, bottom = out.reshape(4, n, 2)

    def bound(values, pick, default):
        values = values[np.isfinite(values)]
        return pick(values) if values.size else default

    x0, x1 = bound(left[:, 0], np.max, 0.0), bound(right[:, 0], np.min, w - 1.0)
    y0, y1 = bound(top[:, 1], np.max, 0.0), bound(bottom[:, 1], np.min, h - 1.0)
    # OpenCV's rounding: Rect(ceil(x0), ceil(y0), floor(x1 − x0), floor(y1 − y0)), then
    # its intersection with the image
    x, y = int(np.ceil(x0)), int(np.ceil(y0))
    right, bottom = x + int(np.floor(x1 - x0)), y + int(np.floor(y1 - y0))
    x, y, right, bottom = max(x, 0), max(y, 0), min(right, w), min(bottom, h)
    if right <= x or bottom <= y:
        return (0, 0, 0, 0)
    return (x, y, right - x, bottom - y)


def _reading(value, where: str) -> tuple[float, float]:
    try:
        pan, tilt = value
    except (TypeError, ValueError):
        raise InputError(f"{where}: expected (pan, tilt) in radians, got {value!r}") from None
    out = []
    for name, a in (("pan", pan), ("tilt", tilt)):
        if np.ndim(a) != 0:
            raise InputError(f"{where} {name}: expected one number (radians), got shape "
                             f"{np.shape(a)}")
        out.append(a)
    return out[0], out[1]


def rectify_head(head: HeadCalibration, left, right, options: RectifyOptions | None = None,
                 *, maps: bool = True) -> StereoRectification:
    """The rectification of ``head`` at the readings ``left`` and ``right``.

    Parameters
    ----------
    head : HeadCalibration
    left, right : (pan, tilt)
        Each eye's encoder readings, radians.
    options : RectifyOptions, optional
    maps : bool
        Also compute the remap tables (``cv2.initUndistortRectifyMap``).

    Returns
    -------
    StereoRectification

    Raises
    ------
    InputError
        Readings not numbers or beyond a turn; eyes with different image sizes or lens
        models; ``alpha`` for fisheye eyes, ``balance`` or ``fov_scale`` for pinhole ones.
    DegenerateDataError
        The two optical centres coincide (no baseline).
    """
    if not isinstance(head, HeadCalibration):
        raise InputError(f"head: expected a HeadCalibration, got {type(head).__name__}")
    options = RectifyOptions() if options is None else options
    model = _lens(head)
    options = options.for_lens(model)
    eyes = {"left": head.left, "right": head.right}
    sizes = {eye: eyes[eye].image_size for eye in EYES}
    if sizes["left"] != sizes["right"]:
        raise InputError(f"image_size: the eyes differ (left {sizes['left']}, right "
                         f"{sizes['right']}); OpenCV rectifies a pair of one size")
    readings, T_cb = {}, {}
    for eye, given in (("left", left), ("right", right)):
        pan, tilt = _reading(given, f"{eye} readings")
        try:
            T_cb[eye] = eyes[eye].T_cam_from_base(pan, tilt)
        except InputError as exc:
            raise InputError(f"{eye} readings: {exc}") from None
        readings[eye] = (float(pan), float(tilt))
    T_rl = T_cb["right"] @ invert_transform(T_cb["left"])
    R, T = T_rl[:3, :3].copy(), T_rl[:3, 3].copy()
    if not np.linalg.norm(T) > MIN_BASELINE:
        raise DegenerateDataError(
            f"at these readings the two optical centres coincide (baseline "
            f"{np.linalg.norm(T):.3g} ≤ {MIN_BASELINE:g}): nothing to rectify")
    size = sizes["left"]
    K1, K2 = head.left.K, head.right.K
    d1, d2 = _dist(head.left.dist, model), _dist(head.right.dist, model)
    if model == "fisheye":
        flags = cv2.fisheye.CALIB_ZERO_DISPARITY if options.zero_disparity else 0
        R1, R2, P1, P2, Q = cv2.fisheye.stereoRectify(
            K1, d1, K2, d2, size, R, T.reshape(3, 1), flags, newImageSize=size,
            balance=options.balance, fov_scale=options.fov_scale)
        roi1 = roi2 = None                   # cv2.fisheye has none: computed below
        init_map = _fisheye_tables
    else:
        flags = cv2.CALIB_ZERO_DISPARITY if options.zero_disparity else 0
        R1, R2, P1, P2, Q, roi1, roi2 = cv2.stereoRectify(
            K1, d1, K2, d2, size, R, T.reshape(3, 1), flags=flags, alpha=float(options.alpha))
        init_map = cv2.initUndistortRectifyMap
    tables = None
    if maps:
        kind = MAP_TYPES[options.map_type]
        tables = {"left": init_map(K1, d1, R1, P1, size, kind),
                  "right": init_map(K2, d2, R2, P2, size, kind)}
    rect = StereoRectification(
        readings=readings, image_size=size, T_cam_from_base=T_cb, K={"left": K1, "right": K2},
        dist={"left": d1, "right": d2}, R=R, T=T, R1=R1, R2=R2,
        P1=P1, P2=P2, Q=Q, roi1=(0, 0, 0, 0), roi2=(0, 0, 0, 0),
        vertical=bool(abs(T[1]) > abs(T[0])), options=options, maps=tables, lens=model)
    rois = ((roi1, roi2) if roi1 is not None else
            (_inner_rectangle(rect, "left"), _inner_rectangle(rect, "right")))
    return replace(rect, roi1=tuple(int(v) for v in rois[0]),
                   roi2=tuple(int(v) for v in rois[1]))


def rectify_images(rect: StereoRectification, image_left: np.ndarray,
                   image_right: np.ndarray,
                   interpolation: int = cv2.INTER_LINEAR) -> tuple[np.ndarray, np.ndarray]:
    """Both images remapped through ``rect``'s tables (``cv2.remap``).

    Raises :class:`InputError` when ``rect`` has no maps or an image is not of the
    calibration's size (``where`` each image is named ``left`` / ``right``).
    """
    if rect.maps is None:
        raise InputError("rectify_images: the rectification has no maps (rectify_head(..., "
                         "maps=True))")
    out = []
    for eye, image in (("left", image_left), ("right", image_right)):
        image = np.asarray(image)
        if image.ndim not in (2, 3) or image.shape[1::-1] != tuple(rect.image_size):
            w, h = rect.image_size
            shape = "×".join(map(str, image.shape[1::-1])) if image.ndim >= 2 else \
                str(image.shape)
            raise InputError(f"{eye} image: {shape} pixels, the calibration's images are "
                             f"{w}×{h}")
        m1, m2 = rect.maps[eye]
        out.append(cv2.remap(image, m1, m2, interpolation))
    return out[0], out[1]
