"""Render a calibration dataset from the simulated head (``rasc render``).

Writes exactly the dataset format a real user produces (docs/CONTRACTS.md,
:mod:`rasc.vision.dataset`): a folder of PNG images and ``manifest.json``, plus
``ground_truth.json`` read from the model. Two kinds of views per eye:

* ``intrinsics/<eye>_NNN.png`` — the board moved in front of the fixed camera (head at
  home), as a person waves a board: random distance, tilt 20–45° about a random in-plane
  axis, in-plane turn, position anywhere in the image with the whole board and a margin
  visible (docs/METHOD.md §7);
* ``poses/<eye>_NN.png`` — the board fixed in front of the head, both eyes at each
  pan-tilt position (the paper's nine by default); the left and right images of one
  position share a ``view`` id, so they also serve as simultaneous views for loop closure.

Every random draw comes from ``numpy.random.default_rng(seed)``; the same seed and
options give byte-identical files. The pan-tilt units may be imperfect
(:mod:`rasc.sim.units`); the pose views' angles are then encoder readings, and the
ground truth (per eye ``unit``, ``T_cam_from_gaze``, ``T_ptu_from_base`` in the canonical
gauge) is checked against MuJoCo's camera frame at every rendered pose.
"""

from __future__ import annotations

import contextlib
import json
import math
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import PAPER_POSES_DEG
from rasc.geometry.transforms import invert_transform, make_transform, matrix_from_rotvec
from rasc.io import finite_number, finite_numbers, read_text_file
from rasc.progress import progress
from rasc.sim import DEFAULT_SUPERSAMPLE
from rasc.sim.motion import (
    DEFAULT_EXPOSURE,
    DEFAULT_FRAME_RATE,
    DEFAULT_JOINT_RATE,
    DEFAULT_MAX_FRAMES,
    DEFAULT_SUBFRAMES,
)
from rasc.vision.board import MIN_VIEW_CORNERS, Board

#: intrinsics views: board distance range (m), tilt range (deg), in-plane turn (deg)
INTRINSICS_DISTANCE_M = (0.6, 1.2)
INTRINSICS_TILT_DEG = (20.0, 45.0)
INTRINSICS_TURN_DEG = 30.0
#: the printed extent (longer side, m) of the board the distance range above was set for
#: (the default 9x6 chessboard of 50 mm squares: 10 squares)
INTRINSICS_REFERENCE_EXTENT_M = 0.5
#: a target seen in part is waved at most this many times the reference distances for
#: its intrinsics views (:func:`intrinsics_board_poses`), seen in part with at least
#: PARTIAL_INTRINSICS_CORNERS corners; 3 leaves boards up to 1.5 m (a 16x12 ChArUco board
#: of 75 mm squares) whole, as before
PARTIAL_INTRINSICS_FAR = 3.0
PARTIAL_INTRINSICS_CORNERS = 40
#: the whole board with its quiet zone stays this many pixels inside the image
MARGIN_PX = 12.0
#: below this many pixels per square in a pose view, ``rasc render`` warns: measured with
#: the default board and cameras (1280x960), the classic detector found all 18 pose views
#: with squares of 13.4 px (4.3 m) and none at 12.5 px (4.6 m)
MIN_SQUARE_PX = 14.0
#: below this many pixels per square, ``rasc render`` refuses the --distance: no pose view
#: would show a board the detector finds (between the measured 12.5 px and 13.4 px)
MIN_DETECTABLE_SQUARE_PX = 13.0
#: the largest --seed (stored in ground_truth.json, read back by rasc.io's reader)
MAX_SEED = 2**63 - 1
#: the largest --noise: the whole grey range; more is noise alone
MAX_NOISE = 255.0
#: the largest --blur: a Gaussian of 50 px wipes out every corner of the board (squares
#: of 14-60 px at the default distances); more only takes minutes to compute
MAX_BLUR_PX = 50.0
#: lens distortion coefficients ``--distortion`` accepts (OpenCV order k1 k2 p1 p2 k3)
MAX_DIST_COEFFS = 5
#: the largest --supersample: 4 renders 1280x960 images at 5120x3840 (16 times the
#: pixels, measured 12.5 times slower); the corner error falls little beyond 3
#: (docs/topics/datasets.md, benchmarks/bench_supersample.py)
MAX_SUPERSAMPLE = 4
#: bounds of the camera degradations (docs/topics/degradations.md): a sensor's full well
#: (electrons at grey 255; 0 = no sensor noise), its read noise (electrons RMS), the light
#: lost at the image corners, a motion blur's length (px), the lens's f-number and focal
#: length (mm) and the focus distance (m) of depth-dependent defocus
MAX_FULL_WELL = 1e7
MAX_READ_NOISE = 1e4
MAX_VIGNETTING = 0.95
MAX_MOTION_BLUR_PX = 50.0
F_NUMBER_RANGE = (0.5, 64.0)
MAX_FOCAL_LENGTH_MM = 1000.0
MAX_FOCUS_DISTANCE = 1000.0
#: the widest --fov (degrees across the image's width): a pinhole sees less than 180°;
#: a fisheye (OpenCV's equidistant model) is rendered up to 180° (rays to 90° off its
#: axis at the image's left and right edges; docs/topics/lenses.md)
MAX_FOV_DEG = 180.0
#: bounds of continuous motion (docs/topics/continuous.md): the peak joint speed (deg/s),
#: a dwell (s), the camera's frame rate and the joint stream's rate (Hz), the sub-frames
#: an exposure averages, a rolling shutter's line time (s), the camera-to-encoder clock
#: offset (s) and the pose frames kept per eye (every k-th of those the camera takes)
MAX_MOTION_SPEED = 500.0
MAX_DWELL = 60.0
MAX_FRAME_RATE = 1000.0
MAX_JOINT_RATE = 10000.0
MAX_SUBFRAMES = 64
MAX_LINE_TIME = 1e-3
MAX_CLOCK_OFFSET = 10.0
#: the jitter of the joint stamps at most this fraction of the stream's period (beyond,
#: stamps would leave their order: rasc.sim.motion.JITTER_TRUNCATION)
MAX_JITTER_PERIODS = 0.2
MAX_FRAMES_KEPT = 1000


#: RenderOptions' fields in rasc 0.2 (the study spec's names since): old → new
_RENAMED = {"n_intrinsics": "intrinsics_views", "target_distance": "distance",
            "noise_sigma": "image_noise", "blur_sigma": "blur", "dist": "distortion"}


@dataclass(frozen=True)
class RenderOptions:
    """What a rendered dataset shows. Angles in degrees, lengths in metres.

    The fields have the study spec's names (``rasc.study.spec.PARAMS``): the same
    decision has one name in Python, in a study and in messages; ``rasc render`` maps them
    to its options (``distance`` is ``--distance``, ``image_noise`` ``--noise``).
    :meth:`validate` refuses values no render can use; the renderers call it.
    """

    poses_deg: tuple[tuple[float, float], ...] = PAPER_POSES_DEG
    intrinsics_views: int = 20
    distance: float = 1.0
    seed: int = 0
    image_noise: float = 0.0        # grey levels
    blur: float = 0.0               # pixels
    distortion: tuple[float, ...] = ()  # lens distortion (OpenCV k1 k2 p1 p2 k3), both eyes
    # render S times the size, averaged over S x S pixels (1: the plain render); the
    # default, 2, is chosen in docs/results/supersample.md (rasc.sim.DEFAULT_SUPERSAMPLE)
    supersample: int = DEFAULT_SUPERSAMPLE
    # the degradations real cameras show (docs/topics/degradations.md); each off at its
    # default, and a field at its default is left out of the ground truth's
    # render_options and of the cache key (DEGRADATIONS): the renders of before
    full_well: float = 0.0          # sensor electrons at grey 255 (shot noise); 0 = none
    read_noise: float = 0.0         # sensor read noise, electrons RMS (needs full_well)
    vignetting: float = 0.0         # fraction of light lost at the image corners
    motion_blur: float = 0.0        # length of a linear motion blur, pixels
    motion_angle: float = 0.0       # its direction in the image, degrees (0 = along +u)
    focus_distance: float = 0.0     # thin-lens defocus focused here, metres; 0 = none
    f_number: float = 2.8           # the lens's f-number (with focus_distance)
    focal_length_mm: float = 8.0    # the lens's focal length, mm (with focus_distance)
    jpeg_quality: int = 0           # JPEG compression quality 1-100; 0 = none
    # the lens (docs/topics/lenses.md): its model (rasc.geometry.lens.LENS_MODELS; the
    # ``distortion`` coefficients are that model's) and its horizontal field of view
    # (degrees across the image's width; 0 = the model camera's own focal length); at
    # their defaults left out of the ground truth's render_options and of the cache key
    lens: str = "pinhole"
    fov: float = 0.0
    # continuous motion (docs/topics/continuous.md): a head that never stops, filmed by
    # cameras on their own clock. motion_speed_deg_s 0 is stop-and-go (the renders of
    # before); the other fields need it > 0, and each is left out of the ground truth's
    # render_options and of the cache key at its default (CONTINUOUS)
    motion_speed_deg_s: float = 0.0  # peak joint speed between the positions, deg/s
    dwell: float = 0.0              # seconds held at each position (0: never stops)
    frame_rate: float = DEFAULT_FRAME_RATE    # the cameras' frames per second
    exposure: float = DEFAULT_EXPOSURE        # seconds, the mean of `subframes` renders
    subframes: int = DEFAULT_SUBFRAMES        # renders averaged over an exposure
    rolling_shutter: float = 0.0    # line time, seconds (0: global shutter)
    joint_rate: float = DEFAULT_JOINT_RATE    # joint readings per second
    clock_offset: float = 0.0       # δ, s: encoder clock = camera clock + δ
    clock_jitter: float = 0.0       # Gaussian jitter of the joint stamps, s (σ)
    max_frames: int = DEFAULT_MAX_FRAMES      # pose frames kept per eye (every k-th)

    def validate(self, names: dict[str, str] | None = None) -> RenderOptions:
        """Refuse options no render can use; returns ``self``.

        ``names`` maps a field to how the caller's user wrote it (``rasc render`` passes
        its options, ``{"distance": "--distance", ...}``); messages name the field
        otherwise. Raises :class:`InputError`, one line."""
        def name(field: str) -> str:
            return (names or {}).get(field, field)

        if not _integer(self.intrinsics_views) or self.intrinsics_views < 3:
            raise InputError(f"{name('intrinsics_views')}: need an integer of at least 3, got "
                             f"{self.intrinsics_views!r}")
        if len(self.poses_deg) < 3:
            raise InputError(f"{name('poses_deg')}: need at least 3 pan-tilt positions, got "
                             f"{len(self.poses_deg)}")
        for k, pose in enumerate(self.poses_deg):
            finite_numbers(pose, f"{name('poses_deg')}[{k}]", count=2,
                           what="pan, tilt in degrees")
        if finite_number(self.distance, name("distance")) <= 0:
            raise InputError(f"{name('distance')} must be a positive number of metres, got "
                             f"{self.distance}")
        if not _integer(self.seed) or not 0 <= self.seed <= MAX_SEED:
            raise InputError(f"{name('seed')} must be an integer from 0 to 2**63-1, got "
                             f"{self.seed!r}")
        for field, unit, top in (("image_noise", "grey levels", MAX_NOISE),
                                 ("blur", "pixels", MAX_BLUR_PX)):
            value = getattr(self, field)
            if not 0 <= finite_number(value, name(field)) <= top:
                raise InputError(f"{name(field)} must be a number from 0 to {top:g} ({unit}), "
                                 f"got {value:g}")
        self._validate_lens(name)
        if not _integer(self.supersample) or not 1 <= self.supersample <= MAX_SUPERSAMPLE:
            raise InputError(f"{name('supersample')} must be an integer from 1 to "
                             f"{MAX_SUPERSAMPLE}, got {self.supersample!r}")
        self._validate_degradations(name)
        self._validate_continuous(name)
        if lensed(self) and self.motion_speed_deg_s:
            raise InputError(f"{name('motion_speed_deg_s')}: continuous motion is not "
                             f"rendered through {name('lens')} {self.lens} or {name('fov')} "
                             "(only through the model camera's own pinhole); set it to 0")
        return self

    def _validate_lens(self, name) -> None:
        from rasc.geometry.lens import LENS_MODELS

        if not isinstance(self.lens, str) or self.lens not in LENS_MODELS:
            raise InputError(f"{name('lens')} must be one of {', '.join(LENS_MODELS)}, got "
                             f"{self.lens!r}")
        n = len(self.distortion)
        if self.lens == "fisheye" and n > 4:
            raise InputError(f"{name('distortion')}: a fisheye lens has at most 4 "
                             f"coefficients (k1,k2,k3,k4), got {n}")
        if self.lens == "pinhole" and n > MAX_DIST_COEFFS and n != 8:
            raise InputError(f"{name('distortion')}: at most {MAX_DIST_COEFFS} coefficients "
                             f"(k1,k2,p1,p2,k3), or 8 (the rational model's k1,k2,p1,p2,k3,"
                             f"k4,k5,k6), got {n}")
        finite_numbers(self.distortion, name("distortion"), what="k1,k2,k3,k4"
                       if self.lens == "fisheye" else "k1,k2,p1,p2,k3" if n <= 5 else
                       "k1,k2,p1,p2,k3,k4,k5,k6")
        fov = finite_number(self.fov, name("fov"))
        top = MAX_FOV_DEG
        if fov != 0 and not (0 < fov < top or (self.lens == "fisheye" and fov == top)):
            raise InputError(f"{name('fov')} must be a field of view in degrees, above 0 and "
                             f"{'at most' if self.lens == 'fisheye' else 'below'} {top:g} "
                             f"for a {self.lens} lens (0: the camera's own), got {fov:g}")
        if fov:
            from rasc.sim.lens_render import focal_for_fov

            focal_for_fov(fov, 1, distortion_of(self)[0], self.lens, name("fov"))
        if lensed(self) and self.focus_distance:
            raise InputError(f"{name('focus_distance')}: defocus is not rendered through "
                             f"{name('lens')} {self.lens} or {name('fov')} (only through the "
                             "model camera's own pinhole); set it to 0")
    def _validate_continuous(self, name) -> None:
        for field, lo, top, unit in (
                ("motion_speed_deg_s", 0.0, MAX_MOTION_SPEED, "deg/s; 0 = stop-and-go"),
                ("dwell", 0.0, MAX_DWELL, "seconds"),
                ("frame_rate", 0.0, MAX_FRAME_RATE, "frames per second"),
                ("exposure", 0.0, 1.0, "seconds"),
                ("rolling_shutter", 0.0, MAX_LINE_TIME, "seconds per line; 0 = global"),
                ("joint_rate", 0.0, MAX_JOINT_RATE, "readings per second"),
                ("clock_offset", -MAX_CLOCK_OFFSET, MAX_CLOCK_OFFSET, "seconds"),
                ("clock_jitter", 0.0, 1.0, "seconds")):
            value = getattr(self, field)
            if not lo <= finite_number(value, name(field)) <= top:
                raise InputError(f"{name(field)} must be a number from {lo:g} to {top:g} "
                                 f"({unit}), got {value:g}")
        for field, lo, top in (("subframes", 1, MAX_SUBFRAMES),
                               ("max_frames", 3, MAX_FRAMES_KEPT)):
            value = getattr(self, field)
            if not _integer(value) or not lo <= value <= top:
                raise InputError(f"{name(field)} must be an integer from {lo} to {top}, got "
                                 f"{value!r}")
        for field in ("frame_rate", "exposure", "joint_rate"):
            if getattr(self, field) <= 0:
                raise InputError(f"{name(field)} must be positive, got "
                                 f"{getattr(self, field):g}")
        if self.exposure > 1.0 / self.frame_rate:
            raise InputError(f"{name('exposure')} {self.exposure:g} s is longer than a frame "
                             f"at {name('frame_rate')} {self.frame_rate:g} "
                             f"({1.0 / self.frame_rate:.4g} s)")
        if self.clock_jitter > MAX_JITTER_PERIODS / self.joint_rate:
            raise InputError(f"{name('clock_jitter')} {self.clock_jitter:g} s is more than "
                             f"{MAX_JITTER_PERIODS:g} of the joint stream's period at "
                             f"{name('joint_rate')} {self.joint_rate:g} "
                             f"({1.0 / self.joint_rate:.4g} s): its stamps would leave "
                             "their order")
        if not self.motion_speed_deg_s:
            stray = next(iter(continuous_of(self)), None)
            if stray is not None:
                raise InputError(f"{name(stray)} is for continuous motion: give "
                                 f"{name('motion_speed_deg_s')} > 0 too (0 is stop-and-go)")

    def _validate_degradations(self, name) -> None:
        for field, lo, top, unit in (
                ("full_well", 0.0, MAX_FULL_WELL, "electrons at grey level 255; 0 = none"),
                ("read_noise", 0.0, MAX_READ_NOISE, "electrons RMS"),
                ("vignetting", 0.0, MAX_VIGNETTING, "fraction of light lost at the corners"),
                ("motion_blur", 0.0, MAX_MOTION_BLUR_PX, "pixels"),
                ("focus_distance", 0.0, MAX_FOCUS_DISTANCE, "metres; 0 = no defocus"),
                ("f_number", *F_NUMBER_RANGE, "f-number"),
                ("focal_length_mm", 0.0, MAX_FOCAL_LENGTH_MM, "millimetres")):
            value = getattr(self, field)
            if not lo <= finite_number(value, name(field)) <= top:
                raise InputError(f"{name(field)} must be a number from {lo:g} to {top:g} "
                                 f"({unit}), got {value:g}")
        finite_number(self.motion_angle, name("motion_angle"))
        if 0 < self.full_well < 1:
            raise InputError(f"{name('full_well')} must be 0 (no sensor noise) or at least 1 "
                             f"electron, got {self.full_well:g}")
        if self.read_noise and not self.full_well:
            raise InputError(f"{name('read_noise')} {self.read_noise:g} electrons needs the "
                             f"sensor's {name('full_well')} (electrons at grey level 255) to "
                             "convert electrons to grey levels")
        if self.focal_length_mm <= 0:
            raise InputError(f"{name('focal_length_mm')} must be a positive number of "
                             f"millimetres, got {self.focal_length_mm:g}")
        if self.focus_distance and self.focus_distance <= self.focal_length_mm * 1e-3:
            raise InputError(f"{name('focus_distance')} {self.focus_distance:g} m must be "
                             f"beyond the focal length ({name('focal_length_mm')} "
                             f"{self.focal_length_mm:g} mm)")
        q = self.jpeg_quality
        if not _integer(q) or not 0 <= q <= 100:
            raise InputError(f"{name('jpeg_quality')} must be an integer from 1 to 100 "
                             f"(0: no JPEG), got {q!r}")


#: the degradation fields of RenderOptions (each off at its default; left out of the
#: ground truth's render_options and of the cache key at their defaults)
DEGRADATIONS = ("full_well", "read_noise", "vignetting", "motion_blur", "motion_angle",
                "focus_distance", "f_number", "focal_length_mm", "jpeg_quality")


#: the continuous-motion fields of RenderOptions (docs/topics/continuous.md; each at its
#: default left out of the ground truth's render_options and of the cache key)
CONTINUOUS = ("motion_speed_deg_s", "dwell", "frame_rate", "exposure", "subframes",
              "rolling_shutter", "joint_rate", "clock_offset", "clock_jitter", "max_frames")


def _changed(options, fields) -> dict:
    defaults = RenderOptions.__dataclass_fields__
    get = options.get if isinstance(options, dict) else \
        (lambda k, d=None: getattr(options, k, d))
    return {k: get(k) for k in fields if get(k, defaults[k].default) != defaults[k].default}


def degradations_of(options) -> dict:
    """The degradation fields of ``options`` (a RenderOptions or a dict of its fields)
    that differ from their defaults: what the ground truth records and the cache key
    holds (empty for the renders of before)."""
    return _changed(options, DEGRADATIONS)


def continuous_of(options) -> dict:
    """The continuous-motion fields of ``options`` (:data:`CONTINUOUS`) that differ from
    their defaults, as :func:`degradations_of` (empty for stop-and-go)."""
    return _changed(options, CONTINUOUS)


#: the lens fields of RenderOptions (docs/topics/lenses.md; each at its default left
#: out of the ground truth's render_options and of the cache key)
LENS_FIELDS = ("lens", "fov")


def lens_fields_of(options) -> dict:
    """The lens fields of ``options`` (:data:`LENS_FIELDS`) that differ from their
    defaults, as :func:`degradations_of` (empty for the model camera's own pinhole)."""
    return _changed(options, LENS_FIELDS)


def _renamed_init(init):
    def __init__(self, *args, **kwargs):
        for old, new in _RENAMED.items():
            if old in kwargs:
                warnings.warn(f"RenderOptions({old}=...) is now RenderOptions({new}=...) "
                              "(renamed after rasc 0.2.0); the old name goes in rasc 0.4",
                              DeprecationWarning, stacklevel=2)
                kwargs[new] = kwargs.pop(old)
        init(self, *args, **kwargs)
    __init__.__doc__ = init.__doc__
    return __init__


def _renamed_property(old: str, new: str) -> property:
    def get(self):
        warnings.warn(f"RenderOptions.{old} is now RenderOptions.{new} (renamed after rasc "
                      "0.2.0); the old name goes in rasc 0.4", DeprecationWarning, stacklevel=2)
        return getattr(self, new)
    return property(get, doc=f"Deprecated: :attr:`{new}`.")


RenderOptions.__init__ = _renamed_init(RenderOptions.__init__)
for _old, _new in _RENAMED.items():
    setattr(RenderOptions, _old, _renamed_property(_old, _new))


def _integer(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def parse_poses(text: str, where: str = "poses") -> tuple[tuple[float, float], ...]:
    """``"0,0;8,8;-8,0"`` → ((0, 0), (8, 8), (-8, 0)) degrees; ``"paper"`` → the nine; the
    name of a positions file (:func:`read_positions`, ``.csv`` or ``.toml``) → its
    positions. ``where`` names the value in messages (``rasc render`` passes ``--poses``)."""
    if text.strip() == "paper":
        return PAPER_POSES_DEG
    name = text.strip()
    # a path that exists (a device too: the reader names it), but never the empty text,
    # whose Path is the working folder
    if name and (name.lower().endswith((".csv", ".toml")) or Path(name).exists()):
        return read_positions(name)
    return tuple(finite_numbers(item, f"{where}[{k}]", count=2, what="pan,tilt in degrees",
                                text=True) for k, item in enumerate(text.split(";")))


POSITIONS_HEADER = "# rasc positions: pan,tilt in degrees (encoder readings), one a line"
#: the largest positions file read (a million positions of two numbers)
MAX_POSITIONS_BYTES = 64 * 2**20


def read_positions(path: str | Path) -> tuple[tuple[float, float], ...]:
    """Pan-tilt positions (degrees) from a positions file: CSV, one ``pan,tilt`` a line
    (``#`` comments, blank lines and a ``pan,tilt`` header allowed), or TOML with
    ``positions = [[pan, tilt], ...]`` (an optional ``angle_unit = "deg"`` or ``"rad"``).
    What ``rasc plan`` writes and ``rasc render --poses FILE`` reads. Raises
    :class:`InputError` naming the file, line or item."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: positions file not found")
    # the one reader of input text: a device (/dev/zero), FIFO or folder is named as
    # such before anything is read
    text = read_text_file(path, "positions file", MAX_POSITIONS_BYTES)
    poses: list[tuple[float, float]] = []
    if path.suffix.lower() == ".toml":
        import tomllib

        try:
            doc = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise InputError(f"{path}: not TOML ({exc})") from None
        unit = doc.get("angle_unit", "deg")
        if unit not in ("deg", "rad"):
            raise InputError(f"{path}: angle_unit must be 'deg' or 'rad', got {unit!r}")
        items = doc.get("positions")
        if not isinstance(items, list):
            raise InputError(f"{path}: missing field 'positions' (a list of [pan, tilt])")
        k = 180.0 / math.pi if unit == "rad" else 1.0
        for i, item in enumerate(items):
            pan, tilt = finite_numbers(item, f"{path}: positions[{i}]", count=2,
                                       what="pan, tilt")
            poses.append((pan * k, tilt * k))
    else:
        for n, line in enumerate(text.splitlines(), 1):
            line = line.split("#", 1)[0].strip()
            if not line or line.replace(" ", "").lower() == "pan,tilt":
                continue
            poses.append(finite_numbers(line, f"{path}: line {n}", count=2,
                                        what="pan,tilt in degrees", text=True))
    if not poses:
        raise InputError(f"{path}: no positions")
    return tuple(poses)


def format_positions(poses_deg, comment: str = "") -> str:
    """The CSV text of a positions file (:func:`read_positions` reads it back exactly:
    ``repr`` of each float)."""
    lines = [POSITIONS_HEADER]
    lines += [f"# {c}" for c in comment.splitlines() if c.strip()]
    lines.append("pan,tilt")
    lines += [f"{float(p)!r},{float(t)!r}" for p, t in poses_deg]
    return "\n".join(lines) + "\n"


def _outline(board: Board, per_side: int = 16) -> np.ndarray:
    """The border of the board's printed area plus one square of quiet zone, (4·per_side, 3)
    points in the board frame (points along the edges, not only the corners: lens
    distortion bends the edges)."""
    x0, y0, x1, y1 = board.quiet_box()
    corners = np.array([[x0, y0, 0], [x1, y0, 0], [x1, y1, 0], [x0, y1, 0]])
    f = np.linspace(0.0, 1.0, per_side, endpoint=False)[:, None]
    return np.concatenate([a + f * (b - a) for a, b in zip(corners, np.roll(corners, -1, 0),
                                                           strict=True)])


def _visible(T_cam_from_world: np.ndarray, board: Board, K: np.ndarray,
             size: tuple[int, int], dist=None, P_world: np.ndarray | None = None,
             model: str = "pinhole") -> bool:
    """Points ``P_world`` (N, 3) (default: the board's border with its quiet zone) at
    least MARGIN_PX inside the (distorted) image (through the lens ``model``)."""
    from rasc.geometry.lens import project_points

    P_world = _outline(board) if P_world is None else P_world
    p = P_world @ T_cam_from_world[:3, :3].T + T_cam_from_world[:3, 3]
    if np.any(p[:, 2] <= 0.05):
        return False
    uv = project_points(p, K, dist, model=model)
    w, h = size
    return bool(np.all((uv >= MARGIN_PX) & (uv <= [w - 1 - MARGIN_PX, h - 1 - MARGIN_PX])))


def _square_px(T_cam_from_world: np.ndarray, board: Board, K: np.ndarray, dist=None,
               model: str | None = None) -> float:
    """Smallest distance (px) between neighbouring corners of the board's image (of the
    ideal pinhole image; through the lens when ``model`` is given)."""
    nx, ny = board.inner_corners
    p = board.object_points() @ T_cam_from_world[:3, :3].T + T_cam_from_world[:3, 3]
    if model is None:
        uv = ((p[:, :2] / p[:, 2:]) * [K[0, 0], K[1, 1]]).reshape(ny, nx, 2)
    else:
        from rasc.geometry.lens import project_points

        uv = project_points(p, K, dist, model=model).reshape(ny, nx, 2)
    return float(min(np.linalg.norm(np.diff(uv, axis=0), axis=2).min(),
                     np.linalg.norm(np.diff(uv, axis=1), axis=2).min()))


def visible_corners(T_cam_from_world: np.ndarray, board, K: np.ndarray,
                    size: tuple[int, int], dist=None, model: str = "pinhole"
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The board's corners inside the (distorted) image, in front of the camera: their ids
    (M,) and true pixels (M, 2) (the ground truth of a partial view; through the lens
    ``model``)."""
    from rasc.geometry.lens import project_points

    P = board.object_points()
    p = P @ T_cam_from_world[:3, :3].T + T_cam_from_world[:3, 3]
    front = p[:, 2] > 0.05
    uv = np.full((len(P), 2), np.nan)
    if front.any():
        uv[front] = project_points(p[front], K, dist, model=model)
    w, h = size
    inside = front & np.all(np.isfinite(uv), axis=1) & (uv[:, 0] >= 0) & (uv[:, 1] >= 0) \
        & (uv[:, 0] <= w - 1) & (uv[:, 1] <= h - 1)
    ids = np.flatnonzero(inside)
    return ids, uv[ids]


def check_pose_views(sim, options: RenderOptions, dist: np.ndarray | None,
                     log=None, names: dict[str, str] | None = None,
                     cameras: dict[str, np.ndarray] | None = None) -> float:
    """Before rendering: every position inside both units' joint ranges and every inner
    corner of the board at least MARGIN_PX inside both images at each (the board's outer
    squares and quiet zone may be cut: at the default 1 m and (8, 8) deg they are, and the
    board is still found), and the ground truth agreeing with MuJoCo's camera frames at
    each (:meth:`rasc.sim.scene.StereoHeadSim.check_ground_truth`). Returns the smallest
    square (px). ``cameras`` ({eye: K}) are the cameras of a lens of
    :func:`lensed` options (:func:`lens_K`): the corners are then projected through
    ``options.lens`` and the squares measured in its image.

    Raises
    ------
    InputError
        Naming the ``poses_deg`` item or the ``distance`` that cannot be rendered usefully
        (as ``names`` maps them, :meth:`RenderOptions.validate`), or the eye and pose
        where the ground truth disagrees with the model.
    """
    def name(field: str) -> str:
        return (names or {}).get(field, field)

    board, size = sim.board, sim.image_size
    d = options.distance
    model = options.lens if cameras else "pinhole"

    def K_of(eye):
        return cameras[eye] if cameras else sim.K(eye)

    def square_px(T, eye):
        return _square_px(T, board, K_of(eye), dist, model) if cameras else \
            _square_px(T, board, sim.K(eye))

    smallest = math.inf
    for eye in EYES:  # the intrinsics views are taken at home
        sim.set_angles(eye, 0.0, 0.0)
    for eye in EYES:
        sim.check_ground_truth(eye, "home (the intrinsics views)")
    partial = getattr(board, "partial_views", False)
    for k, (pan, tilt) in enumerate(options.poses_deg):
        for eye in EYES:
            try:
                sim.set_angles(eye, np.radians(pan), np.radians(tilt))
            except InputError as exc:
                raise InputError(f"{name('poses_deg')}: item {k} ({pan:g},{tilt:g}): "
                                 f"{exc}") from None
        for eye in EYES:
            sim.check_ground_truth(eye, f"{name('poses_deg')} item {k}")
            T = sim.T_cam_from_world(eye)
            if partial:     # a target seen in part: any share of it may leave the image
                ids, _ = visible_corners(T, board, K_of(eye), size, dist, model)
                if len(ids) >= MIN_VIEW_CORNERS:
                    smallest = min(smallest, square_px(T, eye))
                elif log is not None:
                    log(f"{name('poses_deg')} item {k} ({pan:g}, {tilt:g}) deg: the {eye} eye sees "
                        f"{len(ids)} corner(s) of the target, fewer than {MIN_VIEW_CORNERS}: "
                        "rendered, and skipped when calibrating")
                continue
            if not _visible(T, board, K_of(eye), size, dist, board.object_points(), model):
                if dist is not None and model == "pinhole" and _visible(
                        T, board, K_of(eye), size, None, board.object_points()):
                    raise InputError(
                        f"{name('distortion')} {','.join(f'{v:g}' for v in dist)}: at pan, tilt = "
                        f"({pan:g}, {tilt:g}) deg the distortion moves corners of the board "
                        f"outside the {eye} image ({size[0]}x{size[1]}, {MARGIN_PX:g} px "
                        "margin), which fits without it; use smaller coefficients")
                raise InputError(
                    f"{name('distance')} {d:g}: at pan, tilt = ({pan:g}, {tilt:g}) deg the "
                    f"corners of the {board.nx}x{board.ny} board do not all fit inside the "
                    f"{eye} image ({size[0]}x{size[1]}, {MARGIN_PX:g} px margin); put the "
                    f"board farther away ({name('distance')}) or use smaller pan-tilt angles "
                    f"({name('poses_deg')})")
            smallest = min(smallest, square_px(T, eye))
    return smallest


def intrinsics_board_poses(rng: np.random.Generator, board: Board, K: np.ndarray,
                           size: tuple[int, int], n: int, dist=None,
                           model: str | None = None) -> list[np.ndarray]:
    """``n`` well-spread board poses ``T_cam_from_world`` fully inside the image (a target
    seen in part larger than 1.5 m: showing at least PARTIAL_INTRINSICS_CORNERS corners).

    The board faces the camera (board axes = camera axes), tilted by 20–45° about a random
    axis in its plane and turned in-plane by up to ±30°; its centre lies on the ray of a
    random pixel at a random distance. Rejection sampling keeps whole, margined boards
    (inside the distorted image when ``dist`` (k,) is given).

    ``model`` (a lens of :func:`lensed` options, :data:`rasc.geometry.lens.LENS_MODELS`)
    places them for a wide lens: the pixel over the central :data:`WIDE_PIXEL_SPAN` of
    the image, its ray through the lens, the board turned to face the camera along it
    before its tilt (a wide lens must be seen to its edges), at the distances above
    scaled by the lens's focal length against :data:`INTRINSICS_REFERENCE_FOCAL_PX`
    (at most 1: the squares keep their size in the image); the same draws.
    """
    nx, ny = board.inner_corners
    centre_w = board.centre()
    K_inv = np.linalg.inv(K)
    w, h = size
    # a board larger than the default's printed 0.5 m is waved proportionally farther
    # (the same draws, scaled: the default board's views are unchanged)
    extent = board.extent()
    far = max(1.0, extent / INTRINSICS_REFERENCE_EXTENT_M)
    # a target seen in part larger than that (a wall) is not waved whole far away, where
    # its squares shrink to ~20 px and their corners to 0.12-0.17 px RMS (measured on a
    # 3.4 m board): its views stay within PARTIAL_INTRINSICS_FAR of the reference
    # distances and show part of it (at least PARTIAL_INTRINSICS_CORNERS corners)
    partial = getattr(board, "partial_views", False) and far > PARTIAL_INTRINSICS_FAR
    if partial:
        far = PARTIAL_INTRINSICS_FAR
    span = (0.2, 0.8) if model is None else \
        ((1 - WIDE_PIXEL_SPAN) / 2, (1 + WIDE_PIXEL_SPAN) / 2)
    if model is not None:
        far *= min(1.0, K[0, 0] / INTRINSICS_REFERENCE_FOCAL_PX)
    lens = model or "pinhole"
    poses = []
    for _ in range(200 * n):
        if len(poses) == n:
            break
        d = far * rng.uniform(*INTRINSICS_DISTANCE_M)
        psi = rng.uniform(0, 2 * np.pi)
        tilt = np.radians(rng.uniform(*INTRINSICS_TILT_DEG))
        turn = np.radians(rng.uniform(-INTRINSICS_TURN_DEG, INTRINSICS_TURN_DEG))
        pixel = np.array([rng.uniform(span[0] * w, span[1] * w),
                          rng.uniform(span[0] * h, span[1] * h), 1.0])
        R = matrix_from_rotvec(tilt * np.array([np.cos(psi), np.sin(psi), 0.0])) @ \
            matrix_from_rotvec([0.0, 0.0, turn])
        if model is None:
            ray = K_inv @ pixel
        else:
            from rasc.sim.lens_render import pixel_rays

            ray = pixel_rays(K, dist, (1, 1), model, uv=pixel[:2])
            if ray is None or ray[2] < 0.2:     # no ray, or one too far off the axis
                continue
            R = _facing(ray) @ R
        T = make_transform(R, d * ray / np.linalg.norm(ray) - R @ centre_w)
        if (len(visible_corners(T, board, K, size, dist, lens)[0])
                >= PARTIAL_INTRINSICS_CORNERS
                if partial else _visible(T, board, K, size, dist, model=lens)):
            poses.append(T)
    if len(poses) < n:
        raise InputError(f"cannot place {n} whole boards of {nx}x{ny} corners, "
                         f"{board.square_size} m squares, in the {w}x{h} image: the board is "
                         f"too large for the camera; use a smaller board")
    return poses


def wide_lens(model: str) -> str | None:
    """The ``model`` argument of :func:`intrinsics_board_poses` for a camera of lens
    ``model`` (:data:`rasc.geometry.lens.LENS_MODELS`): None (the views of the model
    camera) for a pinhole, else the lens (the views reach the image's edges). The one
    choice of :mod:`rasc.sim.synthetic` and :mod:`rasc.plan`; ``rasc render`` also places
    a pinhole of another field of view (``RenderOptions.fov``) as a wide lens."""
    return None if model == "pinhole" else model


#: intrinsics views through a wide lens (:func:`intrinsics_board_poses`): the board's
#: centre on the ray of a pixel over this central fraction of the image; distances scaled
#: by the lens's focal length against the stock camera's (1152 px)
WIDE_PIXEL_SPAN = 0.9
INTRINSICS_REFERENCE_FOCAL_PX = 1152.0


def _facing(ray: np.ndarray) -> np.ndarray:
    """The rotation turning the camera's z axis onto ``ray`` (3,) by the shortest turn."""
    ray = ray / np.linalg.norm(ray)
    axis = np.cross([0.0, 0.0, 1.0], ray)
    s = np.linalg.norm(axis)
    return np.eye(3) if s < 1e-12 else matrix_from_rotvec(axis / s * np.arctan2(s, ray[2]))


def unit_summary(sim) -> list[str]:
    """One line per eye whose pan-tilt unit is not the paper's: what the images will show
    (axis distance and angle, encoder zeros and scales as built)."""
    lines = []
    for eye in EYES:
        unit, (built, _, _) = sim.unit(eye), sim.unit_as_built(eye)
        if unit.is_ideal and built.is_ideal:
            continue
        lines.append(
            f"{eye} unit: tilt axis {1e3 * unit.axis_distance:.4g} mm from the pan axis, "
            f"{unit.axis_angle_deg:.4f} deg between the axes, encoder zeros "
            f"{math.degrees(built.pan_offset):+.4g}/{math.degrees(built.tilt_offset):+.4g} deg "
            f"and scales {built.pan_scale:.6g}/{built.tilt_scale:.6g} (pan/tilt); ground truth "
            f"in the canonical gauge")
    return lines


def distortion_of(options: RenderOptions) -> tuple[np.ndarray, bool]:
    """The distortion coefficients of ``options.distortion`` for its lens (zeros beyond
    those given): five (k1 k2 p1 p2 k3) or the rational model's eight for a pinhole, four
    (k1 k2 k3 k4) for a fisheye; and whether any is non-zero."""
    lens = getattr(options, "lens", "pinhole")
    n = 4 if lens == "fisheye" else 8 if len(options.distortion) > MAX_DIST_COEFFS else 5
    dist = np.zeros(n)
    dist[:len(options.distortion)] = options.distortion
    return dist, bool(np.any(dist != 0))


def lensed(options: RenderOptions) -> bool:
    """Whether ``options`` render through :mod:`rasc.sim.lens_render` (a lens other than
    the model camera's pinhole, or another field of view) rather than by distorting the
    model camera's one render (:func:`rasc.sim.scene.distortion_warp`)."""
    return getattr(options, "lens", "pinhole") != "pinhole" or bool(getattr(options, "fov", 0))


def lens_K(K: np.ndarray, options: RenderOptions, width: int) -> np.ndarray:
    """The camera matrix of the lens of ``options`` on a camera of matrix ``K``: ``K``
    itself, or with ``options.fov`` its focal lengths fx = fy set so that rays
    ``fov / 2`` off the axis reach the image's left and right edges
    (:func:`rasc.sim.lens_render.focal_for_fov`); the principal point is ``K``'s."""
    K = np.array(K, dtype=float)
    if getattr(options, "fov", 0):
        from rasc.sim.lens_render import focal_for_fov

        K[0, 0] = K[1, 1] = focal_for_fov(options.fov, width, distortion_of(options)[0],
                                          options.lens)
    return K


def view_image(sim, eye: str, warp: dict, rng: np.random.Generator,
               options: RenderOptions, grey: np.ndarray | None = None,
               lens_views: dict | None = None) -> np.ndarray:
    """The ``eye``'s current view as ``rasc render`` writes it: rendered grey (at
    ``options.supersample`` times the size and averaged down,
    :meth:`rasc.sim.scene.StereoHeadSim.render_camera`), distorted (``warp[eye]``,
    :func:`rasc.sim.scene.distortion_warp`, when the options distort), then blurred and
    noised (:func:`rasc.sim.scene.degrade`, drawing from ``rng``).

    With the camera degradations (docs/topics/degradations.md) the order is a real
    camera's: depth-dependent defocus (from the render's depth buffer, before the lens
    distortion), distortion, motion blur, Gaussian blur, vignetting, the sensor's shot and
    read noise, Gaussian pixel noise, JPEG compression; at their defaults they draw
    nothing from ``rng`` and change no byte. ``grey``: the rendered grey image to use
    instead of rendering now (a continuous exposure, :func:`continuous_grey`); the
    defocus's depth is still rendered at the current state. ``lens_views`` ({eye:
    :class:`rasc.sim.lens_render.LensView`}, for :func:`lensed` options): the image is
    made through the lens from several pinhole views in place of the one render and its
    warp."""
    import rasc.sim.degrade as dg

    if grey is not None:
        image = grey
    elif lens_views:
        image = lens_views[eye].render(sim, eye)
    else:
        image = sim.render_grey(eye, supersample=options.supersample)
    if options.focus_distance:
        depth = sim.render_depth(eye, supersample=options.supersample)
        image = dg.defocus(image, dg.circle_of_confusion_px(
            depth, sim.K(eye)[0, 0], options.focal_length_mm, options.f_number,
            options.focus_distance))
    if eye in warp:
        image = warp[eye](image)
    if options.motion_blur:
        image = dg.motion_blur(image, options.motion_blur, options.motion_angle)
    if options.blur:
        image = dg.blur(image, options.blur)
    if options.vignetting:
        image = dg.vignette(image, options.vignetting)
    if options.full_well:
        image = dg.sensor_noise(image, options.full_well, options.read_noise, rng)
    image = dg.degrade(image, rng, noise_sigma=options.image_noise)
    if options.jpeg_quality:
        image = dg.jpeg(image, options.jpeg_quality)
    return image


def render_dataset(out: str | Path, options: RenderOptions = RenderOptions(), *,
                   model_path: str | Path | None = None, quiet: bool = False,
                   units: dict | None = None, board=None,
                   names: dict[str, str] | None = None) -> Path:
    """Render the dataset into folder ``out`` (created; must be empty or absent).

    ``units`` ({eye: :class:`rasc.sim.units.UnitBuild`}) makes the pan-tilt units
    imperfect; the pose views' ``pan``/``tilt`` are then encoder readings. At every
    rendered pose the ground truth is checked against MuJoCo's camera frame; a
    disagreement raises :class:`InputError` before ``ground_truth.json`` is written.
    Returns the manifest path. Images are written as 8-bit grey PNG, each as it is
    rendered (:func:`rasc.vision.dataset.write_dataset_image`; the same files as
    :func:`rasc.vision.dataset.write_dataset` writes of :func:`render_in_memory`'s
    dataset).

    ``board`` (a :class:`rasc.vision.board.Board`, :class:`~rasc.vision.board.CharucoBoard`
    or :class:`~rasc.vision.board.AprilGrid`): the target, drawn from its description
    (:func:`rasc.sim.scene.scene_xml`) around the stock head, or with ``model_path``
    around that model's head in place of its own target
    (:class:`rasc.sim.scene.StereoHeadSim`'s ``board``). For a target seen in part every
    view's ground truth also lists the corners inside the image, by id
    (``views.<file>.corners``: ``ids``, ``uv`` in pixels).
    ``names``: how messages name the options (:meth:`RenderOptions.validate`).
    """
    from rasc.vision.dataset import write_dataset_image, write_dataset_index

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: output folder exists as a file")
    if out.exists() and any(out.iterdir()):
        raise InputError(f"{out}: output folder exists and is not empty")
    board, images, gt, stream = _render(
        options, model_path, quiet, units, board,
        lambda name, image: write_dataset_image(out, name, image), names)
    return write_dataset_index(out, board, images, gt, angle_unit="deg", length_unit="m",
                               joint_stream=stream)


def render_in_memory(options: RenderOptions = RenderOptions(), *,
                     model_path: str | Path | None = None, quiet: bool = False,
                     units: dict | None = None, board=None,
                     names: dict[str, str] | None = None):
    """Render the dataset of ``options`` into memory: a
    :class:`rasc.vision.dataset.Dataset` holding its images as arrays and the ground
    truth as its ``truth`` (what :func:`render_dataset` writes, without a file;
    :func:`rasc.vision.dataset.write_dataset` writes it as the same folder). The
    arguments are :func:`render_dataset`'s. The images take width × height bytes each
    (1.2 MB at 1280×960)."""
    from rasc.io import dumps_json
    from rasc.vision.dataset import Dataset

    pixels: dict[str, np.ndarray] = {}
    board, images, gt, stream = _render(options, model_path, quiet, units, board,
                                        pixels.__setitem__, names)
    # the truth as ground_truth.json holds it (JSON types): what the folder's reader gives
    truth = json.loads(dumps_json(gt))
    ds = Dataset.in_memory(board, images, pixels, angle_unit="deg", length_unit="m",
                           truth=truth, joint_stream=stream)
    ds.options = options
    return ds


def _render(options: RenderOptions, model_path, quiet: bool, units, board, put,
            names: dict[str, str] | None = None) -> tuple:
    """Render every view, giving each image to ``put(file, image)``; returns (the
    board, the manifest's image entries, the ground truth document, the joint stream of
    a continuous capture or None)."""
    from rasc.sim.scene import (
        StereoHeadSim,
        distortion_warp,
    )

    options.validate(names)
    distance = (names or {}).get("distance", "distance")
    rng = np.random.default_rng(options.seed)
    with contextlib.ExitStack() as stack:
        sim = stack.enter_context(StereoHeadSim(model_path, board=board, units=units))
        if sim.board is None:
            raise InputError(f"{sim.model_file}: the model has no calibration target "
                             "(give a scene with the board, e.g. one written by "
                             "rasc.sim.scene.scene_xml, not the head model alone)")
        board = sim.board
        size = sim.image_size
        gt = sim.ground_truth()
        dist, distorted = distortion_of(options)
        wide = lensed(options)      # through rasc.sim.lens_render (a fisheye, a --fov)
        model = options.lens if wide else "pinhole"
        K_eye = {eye: lens_K(sim.K(eye), options, size[0]) for eye in EYES}
        cam_dist = dist if distorted or wide else None
        for eye in EYES:
            gt[eye]["dist"] = dist.tolist()
            if wide:
                gt[eye]["K"] = K_eye[eye].tolist()
            if model != "pinhole":          # absent: pinhole (the files of before)
                gt[eye]["lens"] = model
        # fail on bad positions or distances before rendering anything
        sim.set_target(sim.facing_target(options.distance))
        square_px = check_pose_views(
            sim, options, cam_dist,
            log=None if quiet else (lambda line: print(f"render: {line}", file=sys.stderr)),
            names=names, cameras=K_eye if wide else None)
        if square_px < MIN_DETECTABLE_SQUARE_PX:
            raise InputError(f"{distance} {options.distance:g}: board squares would be "
                             f"only {square_px:.1f} px in the pose views, where corner "
                             f"detection fails (measured: none found at 12.5 px); bring the "
                             f"board closer")
        if square_px < MIN_SQUARE_PX:     # a warning, not progress: printed even with --quiet
            print(f"rasc render: warning: board squares are only {square_px:.1f} px in the "
                  f"pose views at {distance} {options.distance:g}; corner detection "
                  f"was measured to fail below ~{MIN_SQUARE_PX - 1:g} px", file=sys.stderr)
        if not quiet:
            for line in unit_summary(sim):
                print(f"render: {line}", file=sys.stderr)
        warp = {eye: distortion_warp(sim.K(eye), dist, size) for eye in EYES} \
            if distorted and not wide else {}
        lens_views = None
        if wide:
            from rasc.sim.lens_render import LensView

            lens_views = {eye: LensView(K_eye[eye], dist, size, model, options.supersample)
                          for eye in EYES}
        views: dict[str, dict] = {}
        images: list[dict] = []
        capture = None
        if options.motion_speed_deg_s:
            capture = continuous_capture(options, size[1], names)
        n_poses = len(options.poses_deg) if capture is None else len(capture["frames"])
        total = 2 * (options.intrinsics_views + n_poses)
        bar = stack.enter_context(progress(total=total, desc="render", quiet=quiet,
                                           unit="image"))

        def shoot(eye: str, name: str, entry: dict, grey=None, truth=None) -> None:
            sim.check_ground_truth(eye, name)
            put(name, view_image(sim, eye, warp, rng, options, grey, lens_views))
            images.append({"file": name, "eye": eye, **entry})
            views[name] = {"eye": eye, "T_cam_from_world": sim.T_cam_from_world(eye).tolist(),
                           "T_base_from_world": sim.T_base_from_world.tolist(),
                           **{k: v for k, v in entry.items() if k in ("pan", "tilt")},
                           **(truth or {})}
            if getattr(board, "partial_views", False):
                ids, uv = visible_corners(sim.T_cam_from_world(eye), board, K_eye[eye], size,
                                          cam_dist, model)
                views[name]["corners"] = {"ids": ids.tolist(), "uv": uv.tolist()}
            bar.set_postfix_str(name, refresh=False)
            bar.update(1)

        for eye in EYES:
            sim.set_angles("left", 0.0, 0.0)
            sim.set_angles("right", 0.0, 0.0)
            T_base_from_cam = invert_transform(sim.T_cam_from_base(eye))
            for k, T_cw in enumerate(intrinsics_board_poses(
                    rng, board, K_eye[eye], size, options.intrinsics_views, cam_dist,
                    model if wide else None)):
                sim.set_target(T_base_from_cam @ T_cw)
                shoot(eye, f"intrinsics/{eye}_{k:03d}.png", {"role": "intrinsics"})
        sim.set_target(sim.facing_target(options.distance))
        stream = None
        if capture is not None:
            stream = _shoot_continuous(sim, options, capture, rng, shoot)
            gt["clock"], gt["trajectory"] = capture["clock"], capture["record"]
        for k, (pan, tilt) in enumerate(options.poses_deg if capture is None else ()):
            for eye in EYES:
                sim.set_angles(eye, np.radians(pan), np.radians(tilt))
            for eye in EYES:
                shoot(eye, f"poses/{eye}_{k:02d}.png",
                      {"role": "pose", "pan": float(pan), "tilt": float(tilt),
                       "view": f"{k:02d}"})
        gt["views"] = views
        gt["render_options"] = {"seed": options.seed, "n_intrinsics": options.intrinsics_views,
                                "poses_deg": [list(p) for p in options.poses_deg],
                                "target_distance": options.distance,
                                "noise_sigma": options.image_noise,
                                "blur_sigma": options.blur, "dist": dist.tolist()}
        if options.supersample != 1:    # absent: 1, the plain render (files before 2026-11-28)
            gt["render_options"]["supersample"] = options.supersample
        gt["render_options"].update(degradations_of(options))  # each absent at its default
        gt["render_options"].update(continuous_of(options))    # each absent at its default
        gt["render_options"].update(lens_fields_of(options))   # each absent at its default
        gt["model_file"] = Path(gt["model_file"]).name
    return board, images, gt, stream


def continuous_capture(options: RenderOptions, rows: int,
                       names: dict[str, str] | None = None) -> dict:
    """What a continuous capture of ``options`` takes (:mod:`rasc.sim.motion`): its
    ``trajectory`` (a :class:`rasc.sim.motion.Trajectory` through ``options.poses_deg``),
    the kept ``frames`` (mid-exposure stamps, camera clock: the camera runs at
    ``frame_rate`` over the whole motion and every k-th frame is kept, at most
    ``max_frames`` per eye), and the ground truth's ``clock`` and trajectory ``record``.
    ``rows``: the image height (a rolling shutter's readout). Raises :class:`InputError`
    naming the option when the readout outlasts a frame or fewer than three frames
    fit the motion."""
    from rasc.sim.motion import Trajectory, frame_times, kept_frames

    def name(field: str) -> str:
        return (names or {}).get(field, field)

    readout = (rows - 1) * options.rolling_shutter
    if readout > 1.0 / options.frame_rate:
        raise InputError(f"{name('rolling_shutter')} {options.rolling_shutter:g} s: reading "
                         f"{rows} rows takes {readout:.4g} s, longer than a frame at "
                         f"{name('frame_rate')} {options.frame_rate:g}")
    traj = Trajectory(np.radians(options.poses_deg), options.motion_speed_deg_s,
                      options.dwell)
    taken = frame_times(traj.duration, options.frame_rate, options.exposure, readout)
    frames = taken[kept_frames(len(taken), options.max_frames)]
    if len(frames) < 3:
        raise InputError(f"{name('motion_speed_deg_s')} {options.motion_speed_deg_s:g}: the "
                         f"motion lasts {traj.duration:.3g} s, {len(frames)} frame(s) at "
                         f"{name('frame_rate')} {options.frame_rate:g}; hand-eye needs at "
                         "least 3: move slower or film faster")
    clock = {"convention": "encoder clock = camera clock + clock_offset; an image's time "
                           "is its middle row's mid-exposure on the camera clock",
             "clock_offset": options.clock_offset, "clock_jitter": options.clock_jitter,
             "frame_rate": options.frame_rate, "exposure": options.exposure,
             "subframes": options.subframes, "rolling_shutter": options.rolling_shutter,
             "joint_rate": options.joint_rate, "frames_taken": len(taken),
             "frames_kept": len(frames)}
    record = {"speed_deg_s": options.motion_speed_deg_s, "dwell": options.dwell,
              "duration": traj.duration, "arrivals": traj.arrivals.tolist(),
              "positions_deg": [list(p) for p in options.poses_deg],
              "profile": "minimum jerk"}
    return {"trajectory": traj, "frames": frames, "clock": clock, "record": record}


def continuous_grey(sim, eye: str, traj, t_mid: float, options: RenderOptions
                    ) -> np.ndarray:
    """The grey image ``eye`` exposes around ``t_mid`` (camera clock) while the head
    follows ``traj``: the mean of ``options.subframes`` renders over the exposure, each
    row at its own time with a rolling shutter (:func:`rasc.sim.motion.exposure_plan`,
    which states the error), rounded to 8 bits. Leaves the head at the last sub-frame's
    angles."""
    from rasc.sim.motion import expose, exposure_plan

    times, start = exposure_plan(t_mid, options.exposure, options.subframes,
                                 options.rolling_shutter, sim.image_size[1])

    def render_at(t: float) -> np.ndarray:
        pan, tilt = traj.angles(t, eye)
        sim.set_angles(eye, pan, tilt)
        return sim.render_grey(eye, supersample=options.supersample)

    image = expose(render_at, times, start, options.subframes)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def _shoot_continuous(sim, options: RenderOptions, capture: dict, rng, shoot):
    """The pose frames of a continuous capture: per kept frame, both eyes exposed along
    the trajectory, each image's manifest angles the joint stream at its own stamp (no
    offset: what a user without an offset estimate has), its truth the readings at
    mid-exposure. Returns the joint stream (drawn from ``rng``)."""
    from rasc.sim.motion import sample_joint_stream

    traj = capture["trajectory"]
    stream = sample_joint_stream(traj, options.joint_rate, options.clock_offset,
                                 options.clock_jitter, rng)
    width = max(3, len(str(len(capture["frames"]) - 1)))
    for k, t in enumerate(capture["frames"]):
        t = float(t)
        for eye in EYES:
            grey = continuous_grey(sim, eye, traj, t, options)
            pan, tilt = traj.angles(t, eye)
            sim.set_angles(eye, pan, tilt)          # the truth: mid-exposure
            read = np.degrees(stream.angles(eye, t))
            shoot(eye, f"poses/{eye}_{k:0{width}d}.png",
                  {"role": "pose", "pan": float(read[0]), "tilt": float(read[1]),
                   "view": f"{k:0{width}d}", "time": t},
                  grey=grey, truth={"pan": math.degrees(pan), "tilt": math.degrees(tilt),
                                    "time": t})
    return stream
