"""The accuracy matrix: every combination a user brings, checked against the truth.

Five factors, each cell one level of each (docs/results/accuracy_matrix.md):

* **target**: the 9×6 chessboard seen whole, a ChArUco board (16×12 squares of 40 mm)
  and an AprilGrid (6×4 tags of 100 mm), the last two seen in part at wide positions;
* **head**: the ideal unit; a tilt axis 25 mm off the pan axis and skewed 0.5°; encoder
  zero offsets; encoder scale errors; cameras moved in their housings;
* **motion**: the paper's nine positions (±8°), the same scaled to ±30° pan and ±20° tilt,
  and nine positions chosen by ``rasc plan`` (pan −40…35°, tilt −30…20°);
* **options**: the defaults, ``--scales estimate``, ``--scales hold``, ``--model paper``;
* **door**: the Python API (:func:`rasc.head.pipeline.calibrate_dataset`) or the command
  line (``rasc calibrate``), which must write the same file.

The cells are a covering design (:func:`covering_cells`): every pair of levels of two
factors appears in at least one cell, except the impossible pair (a chessboard, seen
whole, at ±30°). Each cell renders its dataset with truth, calibrates it through its
door (the command-line door also calibrates through Python and compares the files),
builds the report, and scores the calibration (:func:`score`):

* **accuracy**, in the calibration's own gauge (the renderer writes its truth there):
  each quantity's error against its predicted covariance, as a Mahalanobis distance
  ``d² = eᵀ Σ⁻¹ e`` over the quantity's components, bounded by the χ² quantile of its
  dimension at :data:`BOUND_P` (one false alarm in 10⁴ quantities when Σ is right);
* **honesty**: every compared parameter's normalized error z = e / σ, the fraction
  within 3σ and the χ² per cell (over all compared parameters, with their correlations)
  against its number of components;
* **verdict**: a cell whose errors lie outside their bounds must not be judged "usable"
  (the report's verdict, :func:`rasc.report.verdict.verdict`).

A sixth factor, the **lens** (issue 32), runs beside the design on projected corners
(:data:`LENS_CELLS`, :func:`run_lens_cell`): the default pinhole lens, a rational lens and
a 170° fisheye, each with its right ``dist_model``, and the fisheye calibrated as a pinhole
(``k1k2``), which must be warned and not called usable.

**Continuous motion** (issue 33) on projected corners (:data:`CONTINUOUS_CELLS`,
:func:`run_continuous_cell`): an ideal or imperfect unit, a pinhole or fisheye lens, a
chessboard, ChArUco board or AprilGrid, δ estimated by the defaults and scored against
its truth (the quantity "time offset"); δ held at 0 on a moving head must not be called
usable. **Rendered cells beyond the design** (:data:`EXTRA_CELLS`, run as the design's
by :func:`run_cell`): a 150° fisheye (``rasc render --lens fisheye --fov 150``,
``dist_model="fisheye"``) through the Python and command-line doors, with an imperfect
unit and a ChArUco board; a continuous capture with a 20 ms clock offset through the
Python, command-line and **import** doors (:func:`import_continuous`), with an imperfect
unit and a ChArUco board, and one at 30 deg/s with rasc render's own 10 ms exposure.
Continuous motion rendered through a lens is refused in one line
(:func:`refused_combinations`).

``python -m experiments.accuracy --out DIR`` runs the whole matrix (a benchmark:
``benchmarks/bench_accuracy_matrix.py`` writes its results page); the test suite runs a
few cells (``tests/e2e/test_accuracy_matrix.py``).
"""

from __future__ import annotations

import argparse
import functools
import itertools
import json
import os
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

#: The factors and their levels, in the order the covering design takes them.
FACTORS: dict[str, tuple[str, ...]] = {
    "head": ("ideal", "offset_skew", "encoder_zeros", "encoder_scales", "cameras_moved"),
    "options": ("defaults", "scales_estimate", "scales_hold", "model_paper"),
    "target": ("chessboard", "charuco", "aprilgrid"),
    "motion": ("paper", "wide", "planned"),
    "door": ("python", "cli"),
}

TARGETS = {"chessboard": "chessboard:9x6,0.05",
           "charuco": "charuco:16x12,0.04,0.03",
           "aprilgrid": "aprilgrid:6x4,0.1,0.3"}

#: Each head's units (rasc.sim.units.UnitBuild fields), per eye.
HEADS: dict[str, dict[str, dict[str, Any]]] = {
    "ideal": {"left": {}, "right": {}},
    "offset_skew": {eye: {"tilt_axis_offset_mm": (0.0, 25.0, 0.0), "axis_skew_deg": 0.5}
                    for eye in ("left", "right")},
    "encoder_zeros": {"left": {"pan_zero_deg": 0.4, "tilt_zero_deg": -0.3},
                      "right": {"pan_zero_deg": -0.2, "tilt_zero_deg": 0.25}},
    "encoder_scales": {"left": {"pan_scale": 1.006}, "right": {"tilt_scale": 0.995}},
    # the stock cameras sit at (48, 36, 21) and (52, 31, -18) mm, euler (1.3, -2.1, 0.8)
    # and (-0.9, 1.2, -0.6) deg: moved by 4-5 mm along each axis and 0.4-0.6 deg (more
    # and the 9x6 chessboard no longer fits whole at the paper's (8, 8) at 1 m)
    "cameras_moved": {"left": {"camera_position_mm": (44.0, 40.0, 25.0),
                               "camera_euler_deg": (1.8, -1.5, 1.2)},
                      "right": {"camera_position_mm": (56.0, 27.0, -14.0),
                                "camera_euler_deg": (-0.4, 0.7, -0.2)}},
}

#: CalibrationOptions fields of each options level ("defaults": none given).
OPTIONS: dict[str, dict[str, str]] = {
    "defaults": {},
    "scales_estimate": {"scales": "estimate"},
    "scales_hold": {"scales": "hold"},
    "model_paper": {"model": "paper"},
}
#: ... and the same on the command line
FLAGS = {"scales": "--scales", "model": "--model", "dist_model": "--dist-model"}

WIDE_PAN_DEG, WIDE_TILT_DEG = 30.0, 20.0
PLAN_PAN_RANGE, PLAN_TILT_RANGE = (-40.0, 35.0), (-30.0, 20.0)
N_POSITIONS = 9
#: intrinsics views per eye: fewer than rasc render's 20 keep a cell at ~20 s of CPU; the
#: bounds come from each calibration's own covariance, which knows how many there were
INTRINSICS_VIEWS = 12
#: image noise (grey levels), a real sensor's order: it makes the corner noise mostly
#: random (about 0.04 px) rather than the renderer's own structured error (0.017 px,
#: correlated within and between a capture's views), which no calibration's σ models
#: (measured: at 1 grey level the σ of the mounts' rotation were 1.55× optimistic over
#: the matrix, and 0.8× on projected corners with Gaussian noise)
IMAGE_NOISE = 2.0
#: each cell's target distance is drawn from this range (m) by its seed: the renderer's
#: structured corner error is fixed by the placement (E8 found the same: seeds at one
#: placement share it), so one placement for every cell would make the matrix one draw
#: of it, and a cell's bias would repeat in every seed
DISTANCE_RANGE_M = (1.00, 1.06)
#: a quantity's bound: the χ² quantile of its dimension at this tail probability
BOUND_P = 1e-4

#: pairs of levels no cell can show: a chessboard is only used when seen whole
IMPOSSIBLE = {(("target", "chessboard"), ("motion", "wide"))}


#: Rendered cells beyond the design (issues 32, 33): a design cell's levels plus ``lens``
#: (rendered through a 150° fisheye, :data:`FISHEYE_FOV_DEG`, calibrated with
#: ``dist_model="fisheye"``) or ``capture`` "continuous" (a head that never stops,
#: :data:`CONTINUOUS_RENDER`, calibrated with the defaults: δ estimated). Their door may
#: also be ``"import"``: the continuous capture played into a bag
#: (rasc.recordings.synth.write_continuous_recording), ``rasc import --continuous``,
#: ``rasc calibrate``. Which combinations the pipeline refuses: rendering continuous
#: motion through a lens (RenderOptions refuses it in one line).
EXTRA_KEYS = ("lens", "capture")
EXTRA_CELLS: list[dict[str, str]] = [
    {"head": "ideal", "options": "defaults", "target": "chessboard", "motion": "paper",
     "door": "cli", "lens": "fisheye"},
    {"head": "offset_skew", "options": "defaults", "target": "charuco", "motion": "paper",
     "door": "python", "lens": "fisheye"},
    {"head": "encoder_zeros", "options": "defaults", "target": "chessboard",
     "motion": "paper", "door": "cli", "capture": "continuous"},
    {"head": "cameras_moved", "options": "defaults", "target": "charuco", "motion": "paper",
     "door": "python", "capture": "continuous"},
    {"head": "offset_skew", "options": "defaults", "target": "chessboard", "motion": "paper",
     "door": "import", "capture": "continuous"},
    {"head": "ideal", "options": "defaults", "target": "chessboard", "motion": "paper",
     "door": "python", "capture": "continuous_fast"},
]
FISHEYE_FOV_DEG = 150.0
#: the rendered continuous captures (RenderOptions fields): 20 deg/s, 10 frames/s, a
#: 4 ms exposure of 2 sub-frames, the encoder clock 20 ms ahead (recordings.md's capture)
CONTINUOUS_RENDER = {"motion_speed_deg_s": 20.0, "frame_rate": 10.0, "max_frames": 16,
                     "subframes": 2, "exposure": 0.004, "clock_offset": 0.02}
#: ... and ``capture`` "continuous_fast": 30 deg/s at rasc render's own exposure (10 ms of
#: 8 sub-frames), 12 frames per eye (continuous.md's rendered capture)
CONTINUOUS_FAST_RENDER = {"motion_speed_deg_s": 30.0, "max_frames": 12, "clock_offset": 0.02}
CAPTURES = {"continuous": CONTINUOUS_RENDER, "continuous_fast": CONTINUOUS_FAST_RENDER}
#: what the import door writes beside the bag (docs/topics/recordings.md's config)
IMPORT_CONFIG = """[board]
inner_corners = [9, 6]
square_size = 0.05
length_unit = "m"

[topics]
left = "/left/image_raw"
right = "/right/image_raw"

[joints]
angle_unit = "rad"
left = {topic = "/joint_states", pan = "left_pan", tilt = "left_tilt"}
right = {topic = "/joint_states", pan = "right_pan", tilt = "right_tilt"}
"""


def _valid(cell: dict[str, str]) -> bool:
    items = set(cell.items())
    return not any(set(pair) <= items for pair in IMPOSSIBLE)


def _pairs(cell: dict[str, str]) -> set[tuple]:
    return {((a, cell[a]), (b, cell[b])) for a, b in itertools.combinations(FACTORS, 2)}


def covering_cells(factors: dict[str, tuple[str, ...]] = FACTORS) -> list[dict[str, str]]:
    """A pairwise covering design: cells (factor → level) such that every pair of levels
    of two factors that some valid cell shows appears in at least one cell. Greedy and
    deterministic: each step takes the valid cell covering most pairs not yet covered
    (the first in the product's order among equals). Computed once per set of factors."""
    key = tuple((f, tuple(levels)) for f, levels in factors.items())
    return [dict(c) for c in _covering(key)]


@functools.cache
def _covering(key: tuple) -> tuple:
    factors = dict(key)
    candidates = [dict(zip(factors, combo, strict=True))
                  for combo in itertools.product(*factors.values())]
    candidates = [c for c in candidates if _valid(c)]
    needed = set().union(*(_pairs(c) for c in candidates))
    cells: list[dict[str, str]] = []
    while needed:
        best = max(candidates, key=lambda c: len(_pairs(c) & needed))
        cells.append(best)
        needed -= _pairs(best)
    return tuple(tuple(c.items()) for c in cells)


def cell_seed(cell: dict[str, str], seed: int = 0) -> int:
    """The cell's seed: ``seed`` plus its index in :func:`covering_cells` (a cell outside
    the design: plus the index of its combination among all of them, past the design)."""
    design = covering_cells()
    if cell in design:
        return seed + design.index(cell)
    if cell in EXTRA_CELLS:
        return seed + 1000 + EXTRA_CELLS.index(cell)
    combos = [dict(zip(FACTORS, c, strict=True)) for c in itertools.product(*FACTORS.values())]
    return seed + len(design) + combos.index(cell)


def cell_name(cell: dict[str, str]) -> str:
    return "-".join([cell[f] for f in FACTORS] + [cell[k] for k in EXTRA_KEYS if k in cell])


# ----------------------------------------------------------------------------- making

def distance(seed: int) -> float:
    """The cell's target distance (m), drawn from :data:`DISTANCE_RANGE_M` by its seed."""
    lo, hi = DISTANCE_RANGE_M
    return float(lo + (hi - lo) * np.random.default_rng([seed, 30]).random())


def positions(cell: dict[str, str], seed: int = 0) -> tuple[tuple[float, float], ...]:
    """The cell's pan-tilt readings (degrees)."""
    from rasc.geometry.kinematics import PAPER_POSES_DEG

    if cell["motion"] == "paper":
        return tuple(PAPER_POSES_DEG)
    if cell["motion"] == "wide":
        return tuple((p / 8.0 * WIDE_PAN_DEG, t / 8.0 * WIDE_TILT_DEG)
                     for p, t in PAPER_POSES_DEG)
    from rasc.plan import nominal_setup, plan
    from rasc.vision.board import parse_target

    board = parse_target(TARGETS[cell["target"]])
    setup = nominal_setup(board, pan_range=PLAN_PAN_RANGE, tilt_range=PLAN_TILT_RANGE,
                          distance=distance(seed))
    planned = tuple(plan(setup, N_POSITIONS, workspace_depth=None).positions)
    if getattr(board, "partial_views", False):
        return planned
    # a plan is made for the nominal head; a chessboard must be seen whole, and on the
    # cell's own head a planned position may cut it: that view is left out, as detection
    # would leave it out of a real capture (rasc render refuses to render it)
    return _shown_whole(cell, board, planned, distance(seed))


def _shown_whole(cell: dict[str, str], board, planned, at: float) -> tuple:
    """The positions of ``planned`` at which the cell's head shows the whole board to both
    eyes (rasc render's own check), from one simulator of that head."""
    from rasc.errors import InputError
    from rasc.sim.render import RenderOptions, check_pose_views
    from rasc.sim.scene import StereoHeadSim, T_base_from_world_facing

    shown = []
    with StereoHeadSim(board=board, units=_units(cell)) as sim:
        sim.set_target(T_base_from_world_facing(board, distance=at))
        for position in planned:
            try:
                check_pose_views(sim, RenderOptions(poses_deg=(position,), distance=at),
                                 None)
            except InputError:
                continue
            shown.append(position)
    return tuple(shown)


def _units(cell: dict[str, str]) -> dict:
    """The cell's head as ``{eye: rasc.sim.units.UnitBuild}``."""
    from rasc.sim.units import UnitBuild

    return {eye: UnitBuild(**kw) for eye, kw in HEADS[cell["head"]].items()}


def render(cell: dict[str, str], folder: Path, seed: int) -> Path:
    """Render the cell's dataset (with its truth) into ``folder``."""
    from rasc.sim.render import RenderOptions, render_dataset
    from rasc.vision.board import parse_target

    units = _units(cell)
    extra: dict[str, Any] = {}
    if cell.get("lens"):
        extra = {"lens": cell["lens"], "fov": FISHEYE_FOV_DEG}
    if cell.get("capture"):
        extra = dict(CAPTURES[cell["capture"]])
    options = RenderOptions(poses_deg=positions(cell, seed), intrinsics_views=INTRINSICS_VIEWS,
                            seed=seed, image_noise=IMAGE_NOISE, distance=distance(seed),
                            **extra)
    render_dataset(folder, options, units=units, board=parse_target(TARGETS[cell["target"]]),
                   quiet=True)
    return folder


def cell_options(cell: dict[str, str]) -> dict[str, str]:
    """The CalibrationOptions fields of a cell: its options level's, and a lens's
    ``dist_model``."""
    return {**OPTIONS[cell["options"]],
            **({"dist_model": cell["lens"]} if cell.get("lens") else {})}


def calibrate_python(folder: Path, options: str | dict) -> dict:
    """The Python door: what ``rasc calibrate`` writes, from the library (``options``: a
    level of :data:`OPTIONS`, or CalibrationOptions fields)."""
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.vision.dataset import load_dataset

    fields = OPTIONS[options] if isinstance(options, str) else options
    cal = calibrate_dataset(load_dataset(folder), CalibrationOptions(**fields))
    return _document(cal, folder)


def _document(cal, folder: Path) -> dict:
    """The calibration's document as ``rasc calibrate`` writes it, read back (JSON types)."""
    from rasc.io import dumps_json

    doc = cal.to_dict()
    doc["dataset"] = str(folder)
    return json.loads(dumps_json(doc))


def _rasc(*args) -> subprocess.CompletedProcess:
    """``python -m rasc ARGS``; a failure is a RuntimeError with its stderr."""
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    run = subprocess.run([sys.executable, "-m", "rasc", *map(str, args)],
                         capture_output=True, text=True, env=env, check=False)
    if run.returncode != 0:
        raise RuntimeError(f"rasc {args[0]} exited {run.returncode}: {run.stderr.strip()}")
    return run


def calibrate_cli(folder: Path, options: str | dict, out: Path) -> tuple[dict, str]:
    """The command-line door: ``rasc calibrate FOLDER --out OUT`` with the level's flags
    (``options`` as :func:`calibrate_python`'s); returns the document written and the
    command's stderr."""
    argv = ["calibrate", folder, "--out", out, "--quiet"]
    for key, value in (OPTIONS[options] if isinstance(options, str) else options).items():
        argv += [FLAGS[key], value]
    run = _rasc(*argv)
    return json.loads(out.read_text()), run.stderr


def import_continuous(folder: Path, work: Path) -> Path:
    """The import door of a continuous capture: the rendered ``folder`` played into a bag
    (pose images and joint stream) and an intrinsics bag, then ``rasc import BAG
    --continuous --intrinsics BAG2 --config import.toml``; returns the imported dataset."""
    from rasc.recordings.synth import write_continuous_recording, write_intrinsics_recording
    from rasc.vision.dataset import load_dataset

    ds = load_dataset(folder)
    write_continuous_recording(ds, work / "moving.bag", encoding="png")
    write_intrinsics_recording(ds, work / "intrinsics.bag", encoding="png")
    (work / "import.toml").write_text(IMPORT_CONFIG)
    _rasc("import", work / "moving.bag", "--continuous", "--intrinsics",
          work / "intrinsics.bag", "--config", work / "import.toml", "--out",
          work / "imported", "--quiet")
    return work / "imported"


def same_estimates(a: dict, b: dict, within_sigma: float = 0.01) -> bool:
    """Two calibrations of one capture agree: every parameter of ``a``'s refinement
    within ``within_sigma`` of its σ of ``b``'s (the import door's bag stamps are whole
    nanoseconds, so its file cannot be the rendered dataset's to the bit)."""
    pa, pb = a["refinement"]["parameters"], b["refinement"]["parameters"]
    for group, params in pa.items():
        for name, p in params.items():
            q = (pb.get(group) or {}).get(name)
            if q is None or not p.get("std") or p.get("value") is None:
                continue
            if abs(p["value"] - q["value"]) > within_sigma * p["std"]:
                return False
    return True


#: what two doors may write differently: how long each stage took, and the dataset path
#: as each was given it
DOOR_VOLATILE = ("timings_s", "dataset")


def same_document(a: dict, b: dict) -> bool:
    """The two doors' files are the same but for :data:`DOOR_VOLATILE`."""
    def strip(d):
        return {k: v for k, v in d.items() if k not in DOOR_VOLATILE}

    return json.dumps(strip(a), sort_keys=True) == json.dumps(strip(b), sort_keys=True)


# ----------------------------------------------------------------------------- scoring

def _rotvec(R: np.ndarray) -> np.ndarray:
    from rasc.geometry.transforms import rotvec_from_matrix

    return rotvec_from_matrix(np.asarray(R, float))


def truth_values(truth: dict) -> dict[str, Any]:
    """The truth in the calibration's gauge
    (:func:`rasc.head.pipeline.truth_in_calibration_gauge`): per eye K, the canonical
    unit's refinement parameters (tilt axis (x, y, 1), tilt point, scales, offsets),
    T_cam_from_gaze; and T_ptuL_from_ptuR."""
    from rasc.head.pipeline import truth_in_calibration_gauge

    gauge = truth_in_calibration_gauge(truth)
    out: dict[str, Any] = {}
    for eye in ("left", "right"):
        t = truth[eye]
        unit, T_cg, _ = gauge[eye]
        a = np.asarray(unit.tilt_axis, float)
        q = np.asarray(unit.tilt_point, float)
        K = np.asarray(t["K"], float)
        from rasc.geometry.lens import LENS_MODELS

        out[eye] = {
            "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2],
            # the coefficients by the names of the eye's lens (pinhole k1 k2 p1 p2 k3
            # k4 k5 k6, fisheye k1-k4), missing ones 0
            **dict(zip(LENS_MODELS[t.get("lens", "pinhole")],
                       np.r_[np.asarray(t["dist"], float), np.zeros(8)], strict=False)),
            "unit.tilt_axis_x": a[0] / a[2], "unit.tilt_axis_y": a[1] / a[2],
            "unit.tilt_point_x": q[0], "unit.tilt_point_y": q[1], "unit.tilt_point_z": q[2],
            "unit.pan_scale": unit.pan_scale, "unit.tilt_scale": unit.tilt_scale,
            "unit.pan_offset": 0.0, "unit.tilt_offset": 0.0,
            "T_cam_from_gaze": T_cg,
        }
    out["T_ptuL_from_ptuR"] = gauge["T_ptuL_from_ptuR"]
    # a continuous capture's camera-to-encoder offset δ (s; rasc render's truth "clock")
    clock = truth.get("clock") or {}
    if "clock_offset" in clock:
        out["time_offset"] = float(clock["clock_offset"])
    return out


#: The quantities whose accuracy is bounded, each a block of parameters (per eye, or the
#: head's): name → (parameter names, unit the report states the error in)
QUANTITIES = {
    "intrinsics": ("fx", "fy", "cx", "cy"),
    "hand-eye rotation": ("T_cam_from_gaze.rotx", "T_cam_from_gaze.roty",
                          "T_cam_from_gaze.rotz"),
    "hand-eye translation": ("T_cam_from_gaze.tx", "T_cam_from_gaze.ty",
                             "T_cam_from_gaze.tz"),
    "unit axes": ("unit.tilt_axis_x", "unit.tilt_point_y"),
    "encoder scales": ("unit.pan_scale", "unit.tilt_scale"),
    "mounts rotation": ("T_ptuL_from_ptuR.rotx", "T_ptuL_from_ptuR.roty",
                        "T_ptuL_from_ptuR.rotz"),
    "mounts translation": ("T_ptuL_from_ptuR.tx", "T_ptuL_from_ptuR.ty",
                           "T_ptuL_from_ptuR.tz"),
    "time offset": ("time_offset",),
}


def parameter_errors(doc: dict, truth: dict) -> dict[str, float]:
    """Estimate − truth of every parameter in the calibration's covariance (natural units:
    px, rad as a small left rotation, metres, pure numbers)."""
    from rasc.head.uncertainty import covariance_of_document

    cov = covariance_of_document(doc)
    if cov is None:
        return {}
    tv = truth_values(truth)
    params = doc["refinement"]["parameters"]
    errors: dict[str, float] = {}
    # the rational model's coefficients trade with each other (the refinement holds those
    # the corners cannot determine): not compared one by one; the lens is scored through
    # the rest (intrinsics, hand-eye, mounts)
    from rasc.geometry.lens import LENS_MODELS

    skip = set(LENS_MODELS["pinhole"]) \
        if (doc.get("options") or {}).get("dist_model") == "rational" else set()
    for name in cov.names:
        group, _, rest = name.partition(".")
        if rest in skip:
            continue
        if name == "time_offset":        # δ, s: estimated only with a joint stream
            errors[name] = float(doc["refinement"]["time_offset"]["value_s"]) \
                - tv.get("time_offset", 0.0)
            continue
        if group == "T_ptuL_from_ptuR":
            T_est = np.asarray(doc["refinement"]["T_ptuL_from_ptuR"], float)
            T_true = tv["T_ptuL_from_ptuR"]
        elif rest.startswith("T_cam_from_gaze"):
            T_est = np.asarray(doc["head"][group]["T_cam_from_gaze"], float)
            T_true = tv[group]["T_cam_from_gaze"]
        else:
            errors[name] = float(params[group][rest]["value"]) - float(tv[group][rest])
            continue
        axis = "xyz".index(name[-1])
        if ".rot" in name:
            errors[name] = float(_rotvec(T_est[:3, :3] @ T_true[:3, :3].T)[axis])
        else:
            errors[name] = float(T_est[axis, 3] - T_true[axis, 3])
    return errors


@dataclass
class Score:
    """One cell's figures against the truth."""

    n_parameters: int = 0
    chi2: float | None = None                 # eᵀ Σ⁻¹ e over every compared parameter
    within_3sigma: float | None = None        # fraction of |z| ≤ 3
    max_abs_z: float | None = None
    z: dict[str, float] = field(default_factory=dict)
    #: quantity (per eye, or the head's) → (d², bound, dimension)
    quantities: dict[str, tuple[float, float, int]] = field(default_factory=dict)
    errors: dict[str, float] = field(default_factory=dict)    # readable: deg, mm
    within_bounds: bool | None = None


def score(doc: dict, truth: dict) -> Score:
    """Score a calibration document against its truth (module docstring)."""
    from scipy.stats import chi2 as chi2_dist

    from rasc.head.uncertainty import covariance_of_document

    s = Score()
    ea = doc.get("errors_against_truth") or {}
    for eye in ("left", "right"):
        he = ea.get(eye, {}).get("T_cam_from_gaze", {})
        if he:
            s.errors[f"{eye} hand-eye rotation (deg)"] = he["rotation_deg"]
            s.errors[f"{eye} hand-eye translation (mm)"] = 1e3 * he["translation"]
    mounts = ea.get("T_ptuL_from_ptuR") or {}
    if mounts:
        s.errors["mounts translation (mm)"] = 1e3 * mounts["translation"]
    errors = parameter_errors(doc, truth)
    for eye in ("left", "right"):
        # a calibration without its errors against the truth (the import door's dataset
        # has no truth file): the hand-eye errors from the parameters' own
        if f"{eye} hand-eye rotation (deg)" not in s.errors and \
                f"{eye}.T_cam_from_gaze.rotx" in errors:
            e = [errors[f"{eye}.T_cam_from_gaze.{k}"] for k in
                 ("rotx", "roty", "rotz", "tx", "ty", "tz")]
            s.errors[f"{eye} hand-eye rotation (deg)"] = float(np.degrees(np.linalg.norm(e[:3])))
            s.errors[f"{eye} hand-eye translation (mm)"] = 1e3 * float(np.linalg.norm(e[3:]))
    if "mounts translation (mm)" not in s.errors and "T_ptuL_from_ptuR.tx" in errors:
        s.errors["mounts translation (mm)"] = 1e3 * float(np.linalg.norm(
            [errors[f"T_ptuL_from_ptuR.t{k}"] for k in "xyz"]))
    if "time_offset" in errors:
        s.errors["time offset (ms)"] = 1e3 * errors["time_offset"]
    if not errors:
        _score_jackknife(s, doc)
        return s
    cov = covariance_of_document(doc)
    idx = {n: i for i, n in enumerate(cov.names)}
    names = list(errors)
    e = np.array([errors[n] for n in names])
    sig = np.sqrt(np.diag(cov.matrix)[[idx[n] for n in names]])
    z = e / sig
    s.z = dict(zip(names, map(float, z), strict=True))
    s.n_parameters = len(names)
    sub = cov.matrix[np.ix_([idx[n] for n in names], [idx[n] for n in names])]
    # correlations, not variances, set the conditioning: whiten by the σ first
    corr = sub / np.outer(sig, sig)
    s.chi2 = float(z @ np.linalg.lstsq(corr, z, rcond=1e-12)[0])
    s.within_3sigma = float(np.mean(np.abs(z) <= 3.0))
    s.max_abs_z = float(np.max(np.abs(z)))
    ok = True
    for q, members in QUANTITIES.items():
        for group in ("left", "right", "head"):
            qn = [n for n in names if n.startswith(group + ".") and n.partition(".")[2]
                  in members] if group != "head" else \
                [n for n in names if n in members]
            if not qn:
                continue
            ii = [names.index(n) for n in qn]
            zq = z[ii]
            d2 = float(zq @ np.linalg.lstsq(corr[np.ix_(ii, ii)], zq, rcond=1e-12)[0])
            bound = float(chi2_dist.isf(BOUND_P, len(ii)))
            key = q if group == "head" else f"{group} {q}"
            s.quantities[key] = (d2, bound, len(ii))
            ok &= d2 <= bound
    s.within_bounds = ok
    return s


def _score_jackknife(s: Score, doc: dict) -> None:
    """Without the refinement's covariance (``--model paper``): the hand-eye against its
    jackknife standard error (rasc.handeye.methods.jackknife_uncertainty: the RMS of the
    whole error vector, rotation as an angle, translation as a distance), taken as
    isotropic: d² = 3 ‖e‖² / σ_j². σ_j is itself estimated, from the n positions left out
    one at a time, so d² / 3 is bounded by the F(3, n − 1) quantile at :data:`BOUND_P`
    (not χ²(3), which would take σ_j as known: at n = 9 the bound is 91, not 21)."""
    from scipy.stats import f as f_dist

    ok = None
    for eye in ("left", "right"):
        e_doc = (doc.get("eyes") or {}).get(eye) or {}
        hu = e_doc.get("handeye_uncertainty") or {}
        n = len(e_doc.get("pose_views") or [])
        if n < 4:
            continue
        bound = float(3.0 * f_dist.isf(BOUND_P, 3, n - 1))
        for q, key, err in (("hand-eye rotation", "rotation_deg",
                             s.errors.get(f"{eye} hand-eye rotation (deg)")),
                            ("hand-eye translation", "translation",
                             None if f"{eye} hand-eye translation (mm)" not in s.errors
                             else s.errors[f"{eye} hand-eye translation (mm)"] / 1e3)):
            sig = hu.get(key)
            if err is None or not sig:
                continue
            d2 = 3.0 * (err / sig) ** 2
            s.quantities[f"{eye} {q} (jackknife)"] = (d2, bound, 3)
            ok = (ok is not False) and d2 <= bound
    s.within_bounds = ok


# ----------------------------------------------------------------------------- a cell

@dataclass
class CellResult:
    cell: dict[str, str]
    seed: int
    score: Score
    verdict: str
    verdict_line: str
    warnings: list[str]
    doors_agree: bool | None
    report_pages: int | None
    scales: dict | None
    seconds: float
    error: str | None = None
    report_error: str | None = None

    def to_dict(self) -> dict:
        d = asdict(self)
        d["name"] = cell_name(self.cell)
        return d


def run_cell(cell: dict[str, str], work: Path, seed: int, *, report: bool = True) -> CellResult:
    """Render, calibrate through the cell's door, build the report, score."""
    from rasc.report.pdf import write_report
    from rasc.report.verdict import verdict
    from rasc.vision.dataset import load_dataset

    t0 = time.perf_counter()
    folder = render(cell, work / "dataset", seed)
    truth = json.loads((folder / "ground_truth.json").read_text())
    options = cell_options(cell)
    doc = calibrate_python(folder, options)
    agree = None
    if cell["door"] == "cli":
        doc_cli, _ = calibrate_cli(folder, options, work / "cal.json")
        agree = same_document(doc, doc_cli)
        doc = doc_cli
    elif cell["door"] == "import":
        folder = import_continuous(folder, work)
        doc_imp, _ = calibrate_cli(folder, options, work / "cal.json")
        agree = same_estimates(doc_imp, doc)
        doc = doc_imp
    pages, report_error = None, None
    v = verdict(doc)
    if report:
        try:
            v = write_report(doc, work / "report.pdf", dataset=load_dataset(folder))
            pages = _pdf_pages(work / "report.pdf")
        except Exception as exc:     # a report that does not build is the cell's finding
            report_error = f"{type(exc).__name__}: {exc}"
    ref = doc.get("refinement") or {}
    return CellResult(cell=dict(cell), seed=seed, score=score(doc, truth), verdict=v.level,
                      verdict_line=v.line(), warnings=list(doc.get("warnings", [])),
                      doors_agree=agree, report_pages=pages, scales=ref.get("scales"),
                      seconds=time.perf_counter() - t0, report_error=report_error)


def _pdf_pages(path: Path) -> int:
    """Pages of a PDF (its page objects; no PDF library needed)."""
    data = path.read_bytes()
    return data.count(b"/Type /Page") - data.count(b"/Type /Pages")


def cell_passes(r: CellResult) -> tuple[bool, str]:
    """The matrix's rule for one cell: the report built, the doors agree, and either the
    calibration is within its bounds or its verdict is not "usable"."""
    if r.error is not None:
        return False, r.error
    if r.report_error is not None:
        return False, f"the report did not build ({r.report_error})"
    if r.report_pages is not None and r.report_pages < 1:
        return False, "the report has no page"
    if r.doors_agree is False:
        return False, "the Python and command-line doors wrote different files"
    if r.score.within_bounds is False and r.verdict == "usable":
        worst = max(r.score.quantities.items(), key=lambda kv: kv[1][0] / kv[1][1])
        return False, (f"errors outside their bounds ({worst[0]}: d² = {worst[1][0]:.3g} > "
                       f"{worst[1][1]:.3g}) but the verdict is {r.verdict_line!r}")
    return True, "ok"


# ----------------------------------------------------------------------------- the run

def _cell_task(task: tuple[int, dict[str, str], int]) -> CellResult:
    """One cell in a worker (a top-level function: the executors import it by name)."""
    import tempfile

    os.environ.setdefault("MUJOCO_GL", "egl")
    index, cell, seed = task
    with tempfile.TemporaryDirectory() as tmp:
        try:
            return run_cell(cell, Path(tmp), seed)
        except Exception as exc:   # a cell that fails is a finding, recorded as such
            return CellResult(cell=dict(cell), seed=seed, score=Score(), verdict="",
                              verdict_line="", warnings=[], doors_agree=None,
                              report_pages=None, scales=None, seconds=0.0,
                              error=f"{type(exc).__name__}: {exc}")


def run_matrix(out: Path | None, cells: list[dict[str, str]] | None = None, seed: int = 0,
               workers: int = 1, log=print, quiet: bool = False) -> list[CellResult]:
    """Every cell (default: :func:`covering_cells`) on ``workers`` processes
    (:func:`rasc.study.executors.make_executor`); the results in cell order, and written
    to ``out/cells.json`` (without the timings: the same seed gives the same bytes
    whatever the worker count). A cell's seed is ``seed`` plus its index in the design
    (:func:`cell_seed`), so a cell run alone is the same cell as in the whole matrix."""
    from rasc.io import write_json_atomic
    from rasc.progress import progress
    from rasc.study.executors import make_executor

    cells = covering_cells() if cells is None else cells
    tasks = [(k, cell, cell_seed(cell, seed)) for k, cell in enumerate(cells)]
    results: dict[int, CellResult] = {}
    with make_executor(workers=workers) as ex, \
            progress(total=len(tasks), desc="accuracy matrix", unit="cell",
                     quiet=quiet) as bar:
        for k, r in ex.map_unordered(_cell_task, tasks):
            results[k] = r
            ok, why = cell_passes(r)
            bar.update(1)
            log(f"[{k + 1}/{len(cells)}] {cell_name(r.cell)}: "
                f"{'ok' if ok else 'FAIL ' + why}; chi2 "
                f"{'-' if r.score.chi2 is None else f'{r.score.chi2:.1f}'}"
                f"/{r.score.n_parameters}, verdict {r.verdict}, {r.seconds:.0f} s")
    ordered = [results[k] for k in range(len(cells))]
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_json_atomic(out / "cells.json", [{k: v for k, v in r.to_dict().items()
                                                if k != "seconds"} for r in ordered])
    return ordered


# ----------------------------------------------------------------------------- lenses

#: The lens factor's cells, on projected corners (:func:`run_lens_cell`): a lens (the
#: head of :data:`LENS_HEADS`) and the ``dist_model`` it is calibrated with; ``wrong``:
#: the model does not fit the lens, so the calibration must be warned
#: (:func:`rasc.vision.camera.is_wrong_lens`) and not called usable.
LENS_CELLS: tuple[dict[str, str], ...] = (
    {"lens": "pinhole", "dist_model": "k1k2"},
    {"lens": "rational", "dist_model": "rational"},
    {"lens": "fisheye", "dist_model": "fisheye"},
    {"lens": "fisheye", "dist_model": "k1k2", "wrong": "yes"},
)
#: corner noise of the lens cells (px per coordinate)
LENS_NOISE_PX = 0.1


def lens_head(lens: str):
    """The lens cell's head (:mod:`rasc.sim.synthetic`): the default one (f = 1150 px,
    k1 k2), the wide rational one (f = 600 px, ~130°) or the 170° fisheye."""
    from rasc.sim.synthetic import default_head, fisheye_head, rational_head

    return {"pinhole": default_head, "rational": rational_head,
            "fisheye": fisheye_head}[lens]()


def synthetic_truth(head, clock_offset: float | None = None) -> dict:
    """A :class:`rasc.sim.synthetic.SyntheticHead` as a ground-truth document (``rasc
    render``'s layout, with each eye's ``lens``; with ``clock_offset``, a continuous
    capture's δ as its ``clock``), for :func:`score`."""
    from rasc.sim.synthetic import IMAGE_SIZE

    T_pLpR = head.T_ptuL_from_ptuR()
    return {**{eye: {"K": head.K[eye].tolist(), "dist": np.asarray(head.dist[eye]).tolist(),
                     "lens": head.lens_model(eye), "image_size": list(IMAGE_SIZE),
                     "T_cam_from_gaze": head.T_cam_from_gaze[eye].tolist(),
                     "T_ptu_from_base": head.T_ptu_from_base[eye].tolist(),
                     "unit": head.unit[eye].to_dict()} for eye in ("left", "right")},
            "T_ptuL_from_ptuR": T_pLpR.tolist(), "views": {},
            **({} if clock_offset is None else {"clock": {"clock_offset": clock_offset}})}


def lens_cell_name(cell: dict[str, str]) -> str:
    return f"lens {cell['lens']} as {cell['dist_model']}"


def run_lens_cell(cell: dict[str, str], seed: int = 0) -> CellResult:
    """Project the lens cell's head (seeded :data:`LENS_NOISE_PX`), calibrate it with its
    ``dist_model`` (the defaults otherwise), score it against the truth as a rendered cell
    is, with the verdict (no images, so no report)."""
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.sim.synthetic import corner_dataset

    t0 = time.perf_counter()
    head = lens_head(cell["lens"])
    truth = synthetic_truth(head)
    ds = corner_dataset(head, seed=seed, noise_px=LENS_NOISE_PX)
    cal = calibrate_dataset(ds, CalibrationOptions(dist_model=cell["dist_model"]))
    return _projected_result(cell, seed, cal, truth, "<projected corners>", t0)


def lens_warned(r: CellResult) -> bool:
    """The calibration warns that its lens model is wrong (both eyes' lens checks)."""
    return sum("--dist-model" in w and "lens model" in w for w in r.warnings) >= 2


def lens_cell_passes(r: CellResult) -> tuple[bool, str]:
    """The matrix's rule (:func:`cell_passes`), and for the lens factor: a right model
    is not warned about its lens, a wrong one is, on both eyes."""
    ok, why = cell_passes(r)
    if not ok:
        return ok, why
    if r.cell.get("wrong") and not lens_warned(r):
        return False, "the wrong lens model was not warned"
    if not r.cell.get("wrong") and any("lens model" in w for w in r.warnings):
        return False, "the right lens model was warned"
    return True, "ok"


def lens_markdown_table(results: list[CellResult]) -> str:
    """The lens cells' table: lens, dist_model, the verdict, the lens warning, the
    hand-eye errors, χ²/n and the rule."""
    lines = ["| lens | dist_model | verdict | lens warned | hand-eye L / R (deg) | "
             "hand-eye L / R (mm) | χ²/n | rule |", "|" + " --- |" * 8]
    for r in results:
        s, c = r.score, r.cell
        ok, why = lens_cell_passes(r)
        rot = " / ".join(f"{s.errors.get(f'{e} hand-eye rotation (deg)', float('nan')):.3f}"
                         for e in ("left", "right"))
        mm = " / ".join(f"{s.errors.get(f'{e} hand-eye translation (mm)', float('nan')):.3f}"
                        for e in ("left", "right"))
        lines.append(f"| {c['lens']} | {c['dist_model']}{' (wrong)' if c.get('wrong') else ''}"
                     f" | {r.verdict} | {'yes' if lens_warned(r) else 'no'} | {rot} | {mm} | "
                     f"{'—' if s.chi2 is None else f'{s.chi2 / s.n_parameters:.2f}'} | "
                     f"{'ok' if ok else 'FAIL: ' + why} |")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- continuous

#: The continuous-motion cells on projected corners (:func:`run_continuous_cell`,
#: rasc.sim.synthetic.continuous_corner_dataset: the paper's nine positions joined at
#: 30 deg/s, 10 frames/s, joints at 200 Hz, :data:`CONTINUOUS_NOISE_PX`), calibrated with
#: the defaults (δ estimated) but for ``time_offset`` "hold", which holds δ at 0 and must
#: not be called usable: a head (``unit``: the ideal one, or "imperfect": a tilt axis
#: 25 mm off and 0.5° skewed and a pan scale of 1.006), a lens, a target and δ (ms).
CONTINUOUS_CELLS: tuple[dict[str, str], ...] = (
    {"unit": "ideal", "lens": "pinhole", "target": "chessboard", "delta_ms": "30"},
    {"unit": "imperfect", "lens": "pinhole", "target": "charuco", "delta_ms": "-20"},
    {"unit": "imperfect", "lens": "fisheye", "target": "chessboard", "delta_ms": "15"},
    {"unit": "ideal", "lens": "pinhole", "target": "aprilgrid", "delta_ms": "30",
     "time_offset": "hold"},
)
CONTINUOUS_NOISE_PX = 0.03
CONTINUOUS_SPEED_DEG_S = 30.0


def continuous_unit(level: str):
    """The continuous cell's pan-tilt unit (rasc.geometry.kinematics.PanTiltUnit)."""
    from rasc.geometry.kinematics import PanTiltUnit

    if level == "ideal":
        return PanTiltUnit()
    skew = np.radians(0.5)
    return PanTiltUnit(tilt_axis=(np.sin(skew), 0.0, np.cos(skew)),
                       tilt_point=(0.0, 0.025, 0.0), pan_scale=1.006)


def continuous_cell_name(cell: dict[str, str]) -> str:
    return (f"continuous {cell['unit']} {cell['lens']} {cell['target']} "
            f"δ {cell['delta_ms']} ms" + (" held" if cell.get("time_offset") else ""))


def run_continuous_cell(cell: dict[str, str], seed: int = 0) -> CellResult:
    """Project the continuous cell's capture, calibrate it with the defaults (the lens's
    ``dist_model``; ``time_offset`` when the cell holds it), score it against the truth
    (δ too) with the verdict (no images, so no report)."""
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.sim.synthetic import continuous_corner_dataset
    from rasc.vision.board import parse_target

    t0 = time.perf_counter()
    from rasc.sim.synthetic import default_head, fisheye_head

    make = fisheye_head if cell["lens"] == "fisheye" else default_head
    head = make(continuous_unit(cell["unit"]))
    delta = float(cell["delta_ms"]) / 1e3
    truth = synthetic_truth(head, delta)
    ds = continuous_corner_dataset(head, seed=seed, noise_px=CONTINUOUS_NOISE_PX,
                                   speed_deg_s=CONTINUOUS_SPEED_DEG_S, clock_offset=delta,
                                   board=parse_target(TARGETS[cell["target"]]))
    fields = {"dist_model": "fisheye"} if cell["lens"] == "fisheye" else {}
    if cell.get("time_offset"):
        fields["time_offset"] = cell["time_offset"]
    cal = calibrate_dataset(ds, CalibrationOptions(**fields))
    return _projected_result(cell, seed, cal, truth, "<projected continuous capture>", t0)


def _projected_result(cell: dict, seed: int, cal, truth, where: str,
                      t0: float) -> CellResult:
    """A cell of projected corners (no images, one door): its calibration scored against
    the truth, its document's verdict and warnings."""
    from rasc.head.pipeline import errors_against_truth
    from rasc.report.verdict import verdict

    cal.errors = errors_against_truth(cal, truth)
    doc = _document(cal, Path(where))
    v = verdict(doc)
    ref = doc.get("refinement") or {}
    return CellResult(cell=dict(cell), seed=seed, score=score(doc, truth), verdict=v.level,
                      verdict_line=v.line(), warnings=list(doc.get("warnings", [])),
                      doors_agree=None, report_pages=None, scales=ref.get("scales"),
                      seconds=time.perf_counter() - t0)


def continuous_cell_passes(r: CellResult) -> tuple[bool, str]:
    """The matrix's rule (:func:`cell_passes`); a cell that holds δ at 0 on a moving head
    must not be called usable, one that estimates it must be within its bounds, δ
    among them."""
    ok, why = cell_passes(r)
    if not ok:
        return ok, why
    if r.cell.get("time_offset") == "hold":
        return (r.verdict != "usable",
                "ok" if r.verdict != "usable" else "δ held at 0 but called usable")
    if "time offset" not in r.score.quantities:
        return False, "δ was not estimated"
    if r.score.within_bounds is not True:
        return False, f"not within its bounds (verdict {r.verdict_line!r})"
    return True, "ok"


def continuous_markdown_table(results: list[CellResult]) -> str:
    """The continuous cells' table: the cell, the verdict, δ's error against its σ, the
    hand-eye errors, χ²/n and the rule."""
    lines = ["| unit | lens | target | δ (ms) | δ | verdict | δ error (ms) / d² | "
             "hand-eye L / R (deg) | hand-eye L / R (mm) | χ²/n | rule |",
             "|" + " --- |" * 11]
    for r in results:
        s, c = r.score, r.cell
        ok, why = continuous_cell_passes(r)
        d = s.quantities.get("time offset")
        de = s.errors.get("time offset (ms)")
        rot = " / ".join(f"{s.errors.get(f'{e} hand-eye rotation (deg)', float('nan')):.4f}"
                         for e in ("left", "right"))
        mm = " / ".join(f"{s.errors.get(f'{e} hand-eye translation (mm)', float('nan')):.3f}"
                        for e in ("left", "right"))
        lines.append(
            f"| {c['unit']} | {c['lens']} | {c['target']} | {c['delta_ms']} | "
            f"{c.get('time_offset', 'estimated')} | {r.verdict} | "
            f"{'—' if de is None else f'{de:+.4f}'} / {'—' if d is None else f'{d[0]:.2f}'} | "
            f"{rot} | {mm} | "
            f"{'—' if s.chi2 is None else f'{s.chi2 / s.n_parameters:.2f}'} | "
            f"{'ok' if ok else 'FAIL: ' + why} |")
    return "\n".join(lines)


def _worst_and_hand_eye(s) -> tuple[str, str]:
    """A score's table cells: its worst quantity (the largest d² against its bound, as
    ``name (d² / bound)``) and both eyes' hand-eye translation errors (``L / R`` mm)."""
    worst = "—"
    if s.quantities:
        q, (d2, b, _) = max(s.quantities.items(), key=lambda kv: kv[1][0] / kv[1][1])
        worst = f"{q} ({d2:.3g} / {b:.3g})"
    he = " / ".join(f"{s.errors[f'{eye} hand-eye translation (mm)']:.3f}"
                    if f"{eye} hand-eye translation (mm)" in s.errors else "—"
                    for eye in ("left", "right"))
    return worst, he


def extra_markdown_table(results: list[CellResult]) -> str:
    """The rendered cells beyond the design (:data:`EXTRA_CELLS`): the cell, verdict,
    doors, report pages, δ's error, hand-eye and mounts errors, χ²/n, the worst quantity
    and the rule."""
    lines = ["| head | target | lens / capture | door | verdict | doors agree | report pages "
             "| δ error (ms) | hand-eye L / R (mm) | mounts (mm) | χ²/n | worst (d² / bound) "
             "| rule |", "|" + " --- |" * 13]
    for r in results:
        s, c = r.score, r.cell
        ok, why = cell_passes(r)
        worst, he = _worst_and_hand_eye(s)
        de = s.errors.get("time offset (ms)")
        mounts = s.errors.get("mounts translation (mm)")
        cap = CAPTURES.get(c.get("capture", ""), {})
        kind = (f"fisheye {FISHEYE_FOV_DEG:g}°" if c.get("lens")
                else f"continuous {cap['motion_speed_deg_s']:g} deg/s, "
                     f"{1e3 * cap.get('exposure', 0.01):g} ms, δ "
                     f"{1e3 * cap['clock_offset']:g} ms")
        lines.append(
            f"| {c['head']} | {c['target']} | {kind} | {c['door']} | {r.verdict or '—'} | "
            f"{'—' if r.doors_agree is None else ('yes' if r.doors_agree else 'NO')} | "
            f"{r.report_pages if r.report_pages is not None else '—'} | "
            f"{'—' if de is None else f'{de:+.4f}'} | {he} | "
            f"{'—' if mounts is None else f'{mounts:.3f}'} | "
            f"{'—' if s.chi2 is None else f'{s.chi2 / s.n_parameters:.2f}'} | {worst} | "
            f"{'ok' if ok else 'FAIL: ' + why} |")
    return "\n".join(lines)


def refused_combinations() -> dict[str, str]:
    """The combinations the pipeline refuses, each with the one line it refuses it in
    (an :class:`rasc.errors.InputError`): continuous motion rendered through a lens."""
    from rasc.errors import InputError
    from rasc.sim.render import RenderOptions

    out = {}
    try:
        RenderOptions(lens="fisheye", fov=FISHEYE_FOV_DEG, motion_speed_deg_s=20.0).validate()
    except InputError as exc:
        out["continuous motion rendered through a fisheye"] = str(exc)
    return out


# ----------------------------------------------------------------------------- tables

def pooled_z(results: list[CellResult]) -> dict[str, tuple[int, float, float]]:
    """Over the cells judged usable (the calibrations a user is told to trust): per kind
    of parameter (an eye's and the mounts' together), the count, the RMS of the
    normalized errors and the largest |z|; ``"all"`` too."""
    groups: dict[str, list[float]] = {}
    for r in results:
        if r.verdict != "usable":
            continue
        for name, z in r.score.z.items():
            group, _, rest = name.partition(".")
            kind = rest if group in ("left", "right") else name
            if kind.startswith(("T_cam_from_gaze.", "T_ptuL_from_ptuR.")):
                kind = kind[:-1] + "*"          # rotx roty rotz → rot*, tx ty tz → t*
            groups.setdefault(kind, []).append(z)
            groups.setdefault("all", []).append(z)
    return {k: (len(v), float(np.sqrt(np.mean(np.square(v)))), float(np.max(np.abs(v))))
            for k, v in sorted(groups.items())}


def markdown_tables(results: list[CellResult]) -> str:
    """The results page's tables: every cell and its verdict, every cell's figures (two
    tables, so that each fits a page's width), then the normalized errors."""
    lines = ["| # | head | options | target | motion | door | verdict | doors agree | "
             "report pages | rule |", "|" + " --- |" * 10]
    for k, r in enumerate(results):
        c = r.cell
        ok, why = cell_passes(r)
        lines.append(
            f"| {k} | {c['head']} | {c['options']} | {c['target']} | {c['motion']} | "
            f"{c['door']} | {r.verdict or '—'} | "
            f"{'—' if r.doors_agree is None else ('yes' if r.doors_agree else 'NO')} | "
            f"{r.report_pages if r.report_pages is not None else '—'} | "
            f"{'ok' if ok else 'FAIL: ' + why} |")
    lines += ["", "| # | χ²/n | within 3σ | worst quantity (d² / bound) | hand-eye L / R (mm) "
              "| mounts (mm) |", "|" + " --- |" * 6]
    for k, r in enumerate(results):
        s = r.score
        worst, he = _worst_and_hand_eye(s)
        mounts = s.errors.get("mounts translation (mm)")
        lines.append(
            f"| {k} | {'—' if s.chi2 is None else f'{s.chi2 / s.n_parameters:.2f}'} | "
            f"{'—' if s.within_3sigma is None else f'{100 * s.within_3sigma:.0f} %'} | "
            f"{worst} | {he} | {'—' if mounts is None else f'{mounts:.3f}'} |")
    usable = [r for r in results if r.verdict == "usable" and r.score.z]
    lines += ["", f"Normalized errors z = (estimate − truth) / σ of the {len(usable)} cells",
              "judged usable that have the refinement's covariance (a well-kept σ gives",
              "an RMS of 1 and |z| ≤ 3 for 99.7 %):", "",
              "| parameter | n | RMS z | largest abs z |", "| --- | --- | --- | --- |"]
    for kind, (n, rms, mx) in pooled_z(results).items():
        lines.append(f"| {kind} | {n} | {rms:.2f} | {mx:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m experiments.accuracy",
                                description="Run the accuracy matrix (module docstring).")
    p.add_argument("--out", default="accuracy", help="output folder (cells.json)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--cells", help="comma-separated cell indices (default: all)")
    args = p.parse_args(argv)
    cells = covering_cells()
    if args.cells:
        cells = [cells[int(i)] for i in args.cells.split(",")]
    results = run_matrix(Path(args.out), cells, args.seed, workers=args.workers)
    print(markdown_tables(results))
    return 0 if all(cell_passes(r)[0] for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
