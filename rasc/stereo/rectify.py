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
   matrix ``Q`` (4×4), with OpenCV's flags and ``alpha``;
4. ``cv2.initUndistortRectifyMap`` per eye: the remap tables.

Every output means what it means in OpenCV: ``cv2.reprojectImageTo3D(disparity, Q)``
gives points in the rectified left camera frame (length unit of the calibration), and
:attr:`StereoRectification.T_base_from_rect` takes them into the head's base frame
(rotated by ``R1`` from the left camera; same origin). With OpenCV's default
``CALIB_ZERO_DISPARITY`` the disparity is ``x_left − x_right`` of rectified pixels.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from rasc.errors import DegenerateDataError, InputError
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


@dataclass(frozen=True)
class RectifyOptions:
    """How to rectify: OpenCV's ``stereoRectify`` options, and the remap tables' type.

    Attributes
    ----------
    alpha : float
        OpenCV's free scaling: -1 its default scaling, 0 only valid pixels (zoomed in),
        1 every source pixel kept (black borders), or between.
    zero_disparity : bool
        OpenCV's ``CALIB_ZERO_DISPARITY`` (its default): both principal points at the same
        rectified pixel, so disparity is ``x_left − x_right``.
    map_type : {"fixed", "float"}
        :data:`MAP_TYPES`: ``CV_16SC2`` (default) or ``CV_32FC1`` tables.
    """

    alpha: float = -1.0
    zero_disparity: bool = True
    map_type: str = "fixed"

    def __post_init__(self):
        a = self.alpha
        if isinstance(a, bool) or not isinstance(a, int | float | np.number) or not (
                a == -1 or 0.0 <= a <= 1.0):
            raise InputError(f"alpha: expected -1 (OpenCV's default scaling) or a number "
                             f"from 0 to 1, got {a!r}")
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
        Each eye's calibrated intrinsics and OpenCV distortion coefficients (what was
        rectified).
    R, T : ndarray, shapes (3, 3) and (3,)
        The right camera from the left one (``x_right = R x_left + T``).
    R1, R2 : ndarray, shape (3, 3)
        Rectified frame from each camera (OpenCV's rectification transforms).
    P1, P2 : ndarray, shape (3, 4)
        Projection matrices in the rectified frame of the left camera.
    Q : ndarray, shape (4, 4)
        Disparity-to-depth matrix: ``[X Y Z W] = Q [x y d 1]``.
    roi1, roi2 : (int, int, int, int)
        OpenCV's valid rectangles (x, y, width, height).
    vertical : bool
        The baseline runs mostly along the cameras' y axes: OpenCV rectifies to columns.
    maps : dict or None
        ``{"left": (map1, map2), "right": (map1, map2)}`` for ``cv2.remap`` (None when not
        computed).
    options : RectifyOptions
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
        """Measured (distorted) pixels (N, 2) of ``eye`` → rectified pixels (N, 2)
        (``cv2.undistortPoints`` with this eye's ``R1``/``P1`` or ``R2``/``P2``)."""
        uv = np.asarray(uv, dtype=float)
        if uv.ndim != 2 or uv.shape[1] != 2:
            raise InputError(f"uv: expected shape (N, 2), got {uv.shape}")
        if eye not in EYES:
            raise InputError(f"eye: expected left or right, got {eye!r}")
        R, P = (self.R1, self.P1) if eye == "left" else (self.R2, self.P2)
        out = cv2.undistortPoints(uv.reshape(-1, 1, 2), self.K[eye], self.dist[eye], R=R, P=P)
        return out.reshape(-1, 2)

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
                "options": {"alpha": float(self.options.alpha),
                            "zero_disparity": self.options.zero_disparity,
                            "map_type": self.options.map_type}}


def _dist(dist: np.ndarray) -> np.ndarray:
    """OpenCV's coefficients (an empty model: no distortion)."""
    return dist if dist.size else np.zeros(5)


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
        Readings not numbers or beyond a turn; eyes with different image sizes.
    DegenerateDataError
        The two optical centres coincide (no baseline).
    """
    if not isinstance(head, HeadCalibration):
        raise InputError(f"head: expected a HeadCalibration, got {type(head).__name__}")
    options = RectifyOptions() if options is None else options
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
    flags = cv2.CALIB_ZERO_DISPARITY if options.zero_disparity else 0
    K1, K2 = head.left.K, head.right.K
    d1, d2 = _dist(head.left.dist), _dist(head.right.dist)
    R1, R2, P1, P2, Q, roi1, roi2 = cv2.stereoRectify(
        K1, d1, K2, d2, size, R, T.reshape(3, 1), flags=flags, alpha=float(options.alpha))
    tables = None
    if maps:
        kind = MAP_TYPES[options.map_type]
        tables = {"left": cv2.initUndistortRectifyMap(K1, d1, R1, P1, size, kind),
                  "right": cv2.initUndistortRectifyMap(K2, d2, R2, P2, size, kind)}
    return StereoRectification(
        readings=readings, image_size=size, T_cam_from_base=T_cb, K={"left": K1, "right": K2},
        dist={"left": d1, "right": d2}, R=R, T=T, R1=R1, R2=R2,
        P1=P1, P2=P2, Q=Q, roi1=tuple(int(v) for v in roi1),
        roi2=tuple(int(v) for v in roi2), vertical=bool(abs(T[1]) > abs(T[0])),
        options=options, maps=tables)


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
