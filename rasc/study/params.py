"""The study parameters: every key a spec may fix or sweep (:data:`PARAMS`, each with its
checker, default, kind and description; the study-parameter reference page is generated
from it), the value checkers, and the bounds on the work a spec may ask for.
:mod:`rasc.study.spec` reads a spec with them (and re-exports these names)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.geometry.lens import DIST_MODELS, LENS_MODELS
from rasc.io import finite_number
from rasc.sim import DEFAULT_SUPERSAMPLE
from rasc.sim.motion import (
    DEFAULT_EXPOSURE,
    DEFAULT_FRAME_RATE,
    DEFAULT_JOINT_RATE,
    DEFAULT_MAX_FRAMES,
    DEFAULT_SUBFRAMES,
)
from rasc.sim.urdf import DEFAULT_CAMERAS, DEFAULT_JOINTS

#: the paper's noise set k (docs/METHOD.md §8): σ_r = 0.005 k rad, σ_t = k mm
PAPER_SIGMA_R_PER_LEVEL, PAPER_SIGMA_T_MM_PER_LEVEL = 0.005, 1.0
LAYOUTS = ("grid", "cross", "ring")
NOISE_MODELS = ("literal", "exponential")
NOISE_ON = ("all", "home")
INTRINSICS_FROM = ("calibrate", "dataset")
#: the render parameters that make a pose set (what ``intrinsics_from = "dataset"`` varies)
POSE_PARAMS = ("motion_deg", "layout", "positions", "positions_file")
UNITS_EYES = ("both", *EYES)
#: |axis_skew_deg| below this (rasc.sim.units: at 90° the axes would be parallel)
MAX_SKEW_DEG = 45.0
#: bounds on the work a spec may ask for, checked before any work (each refusal names
#: the key): pan-tilt positions and intrinsics views per rendered pose set, rendered
#: views in all, bootstrap resamples, one bootstrap's draws (resamples x samples, the
#: memory of one confidence interval: 8 bytes each) and all bootstraps' draws
MAX_POSITIONS = 400
MAX_INTRINSICS_VIEWS = 400
MAX_RENDERED_VIEWS = 100_000
MAX_BOOTSTRAP = 10**6
MAX_BOOTSTRAP_DRAWS = 2 * 10**7
MAX_BOOTSTRAP_WORK = 10**10


# ----------------------------------------------------------------- value checkers
# Each returns the normalised value or raises ValueError with what was expected.

#: the largest |number| a spec value may be (no parameter comes near it)
MAX_ABS_NUMBER = 1e15


def _number(x) -> float:
    # the one number check; its InputError is a ValueError, named by the caller's key
    return finite_number(x, "", max_abs=MAX_ABS_NUMBER)


def _nonneg(x) -> float:
    x = _number(x)
    if x < 0:
        raise ValueError(f"expected a number >= 0, got {x:g}")
    return x


def _positive(x) -> float:
    x = _number(x)
    if x <= 0:
        raise ValueError(f"expected a number > 0, got {x:g}")
    return x


def _int_at_least(lo: int, hi: int = 10**9) -> Callable[[Any], int]:
    def check(x) -> int:
        if isinstance(x, bool) or not isinstance(x, int):
            raise ValueError(f"expected an integer, got {_show(x)}")
        if not lo <= x <= hi:
            top = "10^9" if hi == 10**9 else str(hi)
            raise ValueError(f"expected an integer from {lo} to {top}, got {_show(x)}")
        return int(x)
    return check


def _render_bound(name: str, unit: str) -> Callable[[Any], float]:
    """A number from 0 to the renderer's own bound ``rasc.sim.render.<name>`` (so that
    the spec, not the renderer, names the key of a value out of range)."""
    def check(x) -> float:
        from rasc.sim import render
        x, top = _nonneg(x), getattr(render, name)
        if x > top:
            raise ValueError(f"expected a number from 0 to {top:g} ({unit}), got {x:g}")
        return x
    return check


def _supersample(x) -> int:
    """An integer from 1 to the renderer's ``rasc.sim.render.MAX_SUPERSAMPLE``."""
    from rasc.sim.render import MAX_SUPERSAMPLE
    return _int_at_least(1, MAX_SUPERSAMPLE)(x)


def _render_int(name: str, lo: int) -> Callable[[Any], int]:
    """An integer from ``lo`` to the renderer's bound ``rasc.sim.render.<name>``."""
    def check(x) -> int:
        from rasc.sim import render
        return _int_at_least(lo, getattr(render, name))(x)
    return check


def _signed_render_bound(name: str, unit: str) -> Callable[[Any], float]:
    """A number from −bound to +bound, the renderer's ``rasc.sim.render.<name>``."""
    def check(x) -> float:
        from rasc.sim import render
        x, top = _number(x), getattr(render, name)
        if not -top <= x <= top:
            raise ValueError(f"expected a number from {-top:g} to {top:g} ({unit}), got {x:g}")
        return x
    return check


def _seconds_up_to_one(positive: bool) -> Callable[[Any], float]:
    """Seconds from 0 (excluded when ``positive``) to 1, the renderer's bound on an
    exposure and on the joint stamps' jitter."""
    def check(x) -> float:
        x = _number(x)
        if x > 1.0 or x < 0 or positive and x == 0:
            span = "above 0 and at most 1" if positive else "from 0 to 1"
            raise ValueError(f"expected a number {span} (seconds), got {x:g}")
        return x
    return check


def _jpeg_quality(x) -> int:
    """0 (no JPEG) or a quality from 1 to 100."""
    return _int_at_least(0, 100)(x)


def _render_range(name: str, lo: float, unit: str) -> Callable[[Any], float]:
    """A number from ``lo`` to the renderer's bound ``rasc.sim.render.<name>``."""
    def check(x) -> float:
        from rasc.sim import render
        x, top = _number(x), getattr(render, name)
        if not lo <= x <= top:
            raise ValueError(f"expected a number from {lo:g} to {top:g} ({unit}), got {x:g}")
        return x
    return check


def _f_number(x) -> float:
    from rasc.sim.render import F_NUMBER_RANGE
    x = _number(x)
    if not F_NUMBER_RANGE[0] <= x <= F_NUMBER_RANGE[1]:
        raise ValueError(f"expected an f-number from {F_NUMBER_RANGE[0]:g} to "
                         f"{F_NUMBER_RANGE[1]:g}, got {x:g}")
    return x


def _time_limit(x) -> float:
    x = _positive(x)
    if x > 7 * 24 * 3600:
        raise ValueError(f"expected at most a week in seconds, got {x:g}")
    return x


def _choice(options: tuple[str, ...]) -> Callable[[Any], str]:
    def check(x) -> str:
        if x not in options or not isinstance(x, str):
            raise ValueError(f"expected one of {', '.join(options)}, got {_show(x)}")
        return x
    return check


def _coefficients(x) -> tuple[float, ...]:
    if not isinstance(x, list) or len(x) > 5:
        raise ValueError(f"expected a list of at most 5 numbers (k1, k2, p1, p2, k3), got "
                         f"{_show(x)}")
    return tuple(_number(v) for v in x)


def _skew(x) -> float:
    x = _number(x)
    if abs(x) >= MAX_SKEW_DEG:
        raise ValueError(f"expected an angle within ±{MAX_SKEW_DEG:g} degrees, got {x:g}")
    return x


def _yes_no(x) -> bool:
    if not isinstance(x, bool):
        raise ValueError(f"expected true or false, got {_show(x)}")
    return x


def _text(x) -> str:
    if not isinstance(x, str):
        raise ValueError(f"expected a string, got {_show(x)}")
    return x


def _names(count: int) -> Callable[[Any], str]:
    """``count`` different comma-separated names (``rasc render --urdf-joints`` and
    ``--urdf-cameras``' form), normalised to ``a,b,...`` without spaces."""
    def check(x) -> str:
        names = [n.strip() for n in _text(x).split(",")]
        if len(names) != count or not all(names) or len(set(names)) != count:
            raise ValueError(f"expected {count} different comma-separated names, "
                             f"got {_show(x)}")
        return ",".join(names)
    return check


def _target(x) -> str:
    """A target description in ``rasc render --target``'s inline form ('' = the model's
    board), checked by :func:`rasc.vision.board.parse_target`."""
    from rasc.vision.board import TARGET_TYPES, parse_target

    x = _text(x).strip()
    if not x:
        return x
    if x.partition(":")[0] not in TARGET_TYPES or ":" not in x:
        raise ValueError("expected chessboard:NXxNY,SQUARE, charuco:SXxSY,SQUARE,MARKER"
                         "[,DICTIONARY][,legacy] or aprilgrid:COLSxROWS,TAGSIZE[,SPACING]"
                         f"[,FAMILY], got {_show(x)}")
    try:
        parse_target(x)
    except InputError as exc:
        raise ValueError(str(exc).split(": ", 1)[-1]) from None
    return x


def _show(x) -> str:
    text = repr(x)
    return text if len(text) <= 60 else text[:57] + "..."


@dataclass(frozen=True)
class Param:
    """One study parameter: its checker, default, kind ("sample", "render", "dataset" or
    "study": a setting of the whole study, in [fixed] only, outside every cell's
    identity) and unit."""

    check: Callable[[Any], Any]
    default: Any
    kind: str
    help: str


#: every parameter a study may fix or sweep
PARAMS: dict[str, Param] = {
    "noise_level": Param(_int_at_least(0), None, "sample",
                         "the paper's noise set k: sigma_r = 0.005k rad, sigma_t = k mm"),
    "sigma_r": Param(_nonneg, 0.0, "sample", "eq. 13 rotation noise per axis, rad"),
    "sigma_t_mm": Param(_nonneg, 0.0, "sample", "eq. 14 translation noise per axis, mm"),
    "noise_model": Param(_choice(NOISE_MODELS), "exponential", "sample",
                         "eq. 13 as printed (literal) or projected onto SO(3)"),
    "corner_noise_px": Param(_nonneg, 0.0, "sample",
                             "Gaussian noise on every detected corner, px (extrinsics "
                             "re-estimated per sample)"),
    "eye": Param(_choice(EYES), "left", "sample", "which eye's hand-eye problem"),
    "image_noise": Param(_render_bound("MAX_NOISE", "grey levels"), 0.0, "render",
                         "Gaussian image noise, grey levels"),
    "blur": Param(_render_bound("MAX_BLUR_PX", "pixels"), 0.0, "render", "Gaussian blur, px"),
    "distortion": Param(_coefficients, (), "render", "lens distortion k1 k2 p1 p2 k3"),
    "motion_deg": Param(_positive, 8.0, "render", "largest pan/tilt of the positions, deg"),
    "layout": Param(_choice(LAYOUTS), "grid", "render",
                    "grid (k x k), cross (home + arms) or ring (home + circle)"),
    "positions": Param(_int_at_least(3, MAX_POSITIONS), 9, "render",
                       "number of pan-tilt positions"),
    "distance": Param(_positive, 1.0, "render", "board distance in front of the head, m"),
    "intrinsics_views": Param(_int_at_least(3, MAX_INTRINSICS_VIEWS), 20, "render",
                              "intrinsics views per eye"),
    "model": Param(_text, "", "render",
                   "MJCF scene (path relative to the spec; '' = the package's model)"),
    # ---- added after rasc-study/1's first specs: at their defaults they are left out of
    # a cell's identity (IDENTITY_OPTIONAL), so older specs keep their seeds and bytes
    "noise_on": Param(_choice(NOISE_ON), "all", "sample",
                      "eq. 13-14 pose noise on every view (all) or on the home view "
                      "(pan = tilt = 0) only"),
    "tilt_axis_offset_mm": Param(_number, 0.0, "render",
                                 "distance of the tilt axis from the pan axis along their "
                                 "common normal (forward, y), mm"),
    "axis_skew_deg": Param(_skew, 0.0, "render",
                           "non-orthogonality: angle between the axes = 90° - skew"),
    "pan_zero_deg": Param(_number, 0.0, "render", "pan encoder zero offset, deg"),
    "tilt_zero_deg": Param(_number, 0.0, "render", "tilt encoder zero offset, deg"),
    "pan_scale": Param(_positive, 1.0, "render", "pan encoder scale (1 = exact)"),
    "tilt_scale": Param(_positive, 1.0, "render", "tilt encoder scale (1 = exact)"),
    "units_eye": Param(_choice(UNITS_EYES), "both", "render",
                       "which pan-tilt unit(s) the head-model parameters apply to"),
    "intrinsics_from": Param(_choice(INTRINSICS_FROM), "calibrate", "render",
                             "calibrate: intrinsics from the cell's own rendered intrinsics "
                             "views; dataset: the base dataset's intrinsics, only the pose "
                             "views rendered (in the base's scene)"),
    "target": Param(_target, "", "render",
                    "the calibration target, as rasc render --target: chessboard:NXxNY,SQUARE, "
                    "charuco:SXxSY,SQUARE,MARKER[,DICTIONARY][,legacy] or "
                    "aprilgrid:COLSxROWS,TAGSIZE[,SPACING][,FAMILY] (metres; '' = the "
                    "model's board; with model, in place of its target)"),
    "positions_file": Param(_text, "", "render",
                            "a positions file (relative to the spec, as rasc plan writes and "
                            "rasc render --poses reads) replacing the layout, positions and "
                            "motion_deg grid"),
    "supersample": Param(_supersample, DEFAULT_SUPERSAMPLE, "render",
                         "render each image at S times the size, S x S pixels averaged "
                         "into one (RenderOptions.supersample, whose default this is; "
                         "1 = plain renders)"),
    # the camera degradations (rasc.sim.render.DEGRADATIONS; docs/topics/degradations.md)
    "full_well": Param(_render_bound("MAX_FULL_WELL", "electrons"), 0.0, "render",
                       "sensor shot noise: electrons at grey level 255 (0 = none)"),
    "read_noise": Param(_render_bound("MAX_READ_NOISE", "electrons"), 0.0, "render",
                        "sensor read noise, electrons RMS (needs full_well)"),
    "vignetting": Param(_render_bound("MAX_VIGNETTING", "fraction"), 0.0, "render",
                        "fraction of light lost at the image corners"),
    "motion_blur": Param(_render_bound("MAX_MOTION_BLUR_PX", "pixels"), 0.0, "render",
                         "length of a linear motion blur, px"),
    "motion_angle": Param(_number, 0.0, "render",
                          "the motion blur's direction in the image, deg (0 = along rows)"),
    "focus_distance": Param(_render_bound("MAX_FOCUS_DISTANCE", "metres"), 0.0, "render",
                            "thin-lens defocus changing with depth, focused here, m "
                            "(0 = everything sharp)"),
    "f_number": Param(_f_number, 2.8, "render", "the lens's f-number (with focus_distance)"),
    "focal_length_mm": Param(_render_range("MAX_FOCAL_LENGTH_MM", 1e-3, "mm"), 8.0, "render",
                             "the lens's focal length, mm (with focus_distance)"),
    "jpeg_quality": Param(_jpeg_quality, 0, "render",
                          "JPEG compression quality 1-100 (0 = none)"),
    # the lens (rasc.sim.render.LENS_FIELDS; docs/topics/lenses.md) and the model the
    # cell's dataset is calibrated with
    "lens": Param(_choice(tuple(LENS_MODELS)), "pinhole", "render",
                  "the cameras' lens model: pinhole or fisheye (distortion holds its "
                  "coefficients; RenderOptions.lens)"),
    "fov": Param(_render_bound("MAX_FOV_DEG", "degrees"), 0.0, "render",
                 "horizontal field of view, deg (0 = the model camera's own focal length; "
                 "RenderOptions.fov)"),
    "dist_model": Param(_choice(("", *DIST_MODELS)), "", "render",
                        "the lens model the dataset is calibrated with "
                        "(CalibrationOptions.dist_model; '' = the lens's own: k1k2 for a "
                        "pinhole, fisheye for a fisheye)"),
    # continuous motion (rasc.sim.render.CONTINUOUS; docs/topics/continuous.md): 0 is
    # stop-and-go, the others need motion_speed_deg_s > 0 (RenderOptions.validate)
    "motion_speed_deg_s": Param(_render_bound("MAX_MOTION_SPEED", "deg/s"), 0.0, "render",
                                "peak joint speed between the positions, deg/s "
                                "(0 = stop-and-go)"),
    "dwell": Param(_render_bound("MAX_DWELL", "seconds"), 0.0, "render",
                   "seconds held at each position (0 = never stops)"),
    "frame_rate": Param(_render_range("MAX_FRAME_RATE", 1e-3, "frames per second"),
                        DEFAULT_FRAME_RATE, "render", "the cameras' frames per second"),
    "exposure": Param(_seconds_up_to_one(positive=True), DEFAULT_EXPOSURE,
                      "render", "exposure time, s (the mean of subframes renders)"),
    "subframes": Param(_render_int("MAX_SUBFRAMES", 1), DEFAULT_SUBFRAMES, "render",
                       "renders averaged over an exposure"),
    "rolling_shutter": Param(_render_bound("MAX_LINE_TIME", "seconds per line"), 0.0,
                             "render", "rolling shutter line time, s (0 = global shutter)"),
    "joint_rate": Param(_render_range("MAX_JOINT_RATE", 1e-3, "readings per second"),
                        DEFAULT_JOINT_RATE, "render", "joint readings per second"),
    "clock_offset": Param(_signed_render_bound("MAX_CLOCK_OFFSET", "seconds"), 0.0, "render",
                          "δ, s: encoder clock = camera clock + δ"),
    "clock_jitter": Param(_seconds_up_to_one(positive=False), 0.0, "render",
                          "Gaussian jitter (σ) of the joint stamps, s"),
    "max_frames": Param(_render_int("MAX_FRAMES_KEPT", 3), DEFAULT_MAX_FRAMES, "render",
                        "pose frames kept per eye (every k-th of those taken)"),
    # a head described in a URDF (rasc.sim.urdf.UrdfHead; docs/topics/urdf-head.md)
    "urdf": Param(_text, "", "render",
                  "a head described in a URDF (path relative to the spec; its bytes' sha256 "
                  "identifies it), rendered in place of the package's head; not with model"),
    "urdf_joints": Param(_names(4), ",".join(DEFAULT_JOINTS), "render",
                         "the URDF's left pan, left tilt, right pan, right tilt joints "
                         "(with urdf; rasc export's names by default)"),
    "urdf_cameras": Param(_names(2), ",".join(DEFAULT_CAMERAS), "render",
                          "the URDF's left and right camera links, REP 103 optical frames "
                          "(with urdf; rasc export's names by default)"),
    "dataset": Param(_text, "", "dataset",
                     "an existing dataset folder (relative to the spec) instead of "
                     "rendering; [fixed] only, no render parameter beside it"),
    "keep_datasets": Param(_yes_no, False, "study",
                           "true: write each rendered dataset (images, manifest.json, "
                           "ground_truth.json) under the study folder, "
                           "datasets/<key>/; false: images and corners stay in memory. "
                           "[fixed] only; no cell's key, seed or result depends on it"),
}

#: the head-model parameters: a rasc.sim.units.UnitBuild for the unit(s) of ``units_eye``
UNIT_PARAMS = ("tilt_axis_offset_mm", "axis_skew_deg", "pan_zero_deg", "tilt_zero_deg",
               "pan_scale", "tilt_scale")
#: parameters that enter a cell's identity only when they differ from their default
IDENTITY_OPTIONAL = ("noise_on", *UNIT_PARAMS, "units_eye", "dataset", "intrinsics_from",
                     "target", "positions_file", "supersample", "full_well", "read_noise",
                     "vignetting", "motion_blur", "motion_angle", "focus_distance",
                     "f_number", "focal_length_mm", "jpeg_quality", "urdf", "urdf_joints",
                     "urdf_cameras", *("motion_speed_deg_s", "dwell", "frame_rate", "exposure",
                                       "subframes", "rolling_shutter", "joint_rate",
                                       "clock_offset", "clock_jitter", "max_frames"),
                     "lens", "fov", "dist_model")
#: the URDF parameters (a head from a URDF: rasc.sim.urdf.UrdfHead)
URDF_PARAMS = ("urdf", "urdf_joints", "urdf_cameras")

TOP_KEYS = {"name": _text, "description": _text, "seed": _int_at_least(0),
            "samples": _int_at_least(1), "methods": None,
            "bootstrap": _int_at_least(100, MAX_BOOTSTRAP),
            "confidence": None, "paired": None, "fixed": None, "axes": None,
            "quick": None, "gross_rotation_deg": _positive,
            "gross_translation_mm": _positive, "time_limit_s": _time_limit}
#: what a [quick] table may narrow (load_spec(..., quick=True))
QUICK_KEYS = ("samples", "methods", "axes")
REQUIRED = ("seed", "samples", "methods")
