"""Run a study: render (or reuse) each dataset it needs, draw every sample, solve with
every method, and write the tidy results.

A study folder ``DIR``::

    study.json            the normalised spec, its sha256, the cells (the manifest)
    datasets/<key>.json   one per distinct set of render parameters: the real pipeline's
                          measurements of a rendered dataset (poses, corners, intrinsics)
                          and the renderer's truth; reused by every cell that needs it,
                          and cached between runs (:func:`cache_dir`, RASC_CACHE_DIR)
    cells/cell-NNNNN.csv  one per finished cell (rows of samples.csv), written atomically
    samples.csv           one row per cell x sample x method
    summary.csv           per cell and method: n, failures, mean, median, std and a
                          bootstrap confidence interval of the mean of each error
    figures/<axis>.png    error against each axis, one curve per method (and .svg)

Determinism: sample ``s`` of cell ``c`` draws from
``default_rng(SeedSequence([seed, *c.seed_words, s]))`` (``seed_words``: the cell's
parameters hashed), the bootstrap of (cell, method) from
``SeedSequence([seed, BOOTSTRAP_KEY, *c.seed_words, method index])``; nothing depends on
the order tasks finish, the worker count or the executor. Numbers are written with
``repr`` (shortest round trip), JSON by :func:`rasc.io.dumps_json`.

Per sample, in this order: corner noise (``corner_noise_px``: an (N, 2) normal block per
view, in view order, then each view's extrinsics re-estimated with the pipeline's
intrinsics, docs/METHOD.md §7), then eq. 13-14 pose noise on every ``T_cam_from_world``
(``sigma_r``, ``sigma_t_mm``; ``noise_model`` literal or exponential; docs/METHOD.md §8),
then every method on the same noisy poses (paired samples); a solve beyond the spec's
``gross_rotation_deg`` / ``gross_translation_mm`` is a failure with status ``gross``.
``run_study(..., pose_errors=True)`` adds each sample's extrinsics error against the
rendered truth (:data:`POSE_ERROR_COLUMNS`).

``intrinsics_from = "dataset"`` (E6b): a cell's pose views are rendered in its base
dataset's scene (:func:`pose_task`) and measured with the base's intrinsics; the base
(the given dataset, or the one its render parameters give at the default pose set) is
made first, and a cell whose pose set is the base's own uses the base itself.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import shutil
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rasc.datasets.cache import CacheStore, EntryError, read_regular
from rasc.datasets.keys import CACHE_LIBRARIES, code_digest  # noqa: F401 (re-exported)
from rasc.errors import DegenerateDataError, InputError, RascError
from rasc.geometry.frames import EYES
from rasc.interrupt import Interrupted
from rasc.io import (
    cache_root,
    dumps_json,
    read_json_document,
    write_json_atomic,
    write_text_atomic,
)
from rasc.study.executors import Executor, WorkerCrashed, make_executor, worker_environment
from rasc.study.spec import (
    FORMAT,
    PARAMS,
    POSE_PARAMS,
    STATS,
    SUMMARY_TAIL,
    UNIT_PARAMS,
    Cell,
    Spec,
    check_beside_dataset,
    dataset_metres,
    pose_grid,
)

BOOTSTRAP_KEY = 0xB007
#: what a method may raise that counts as its failure on a sample (not a crash):
#: the library's errors and numerical breakdowns
FAILURES = (RascError, ArithmeticError, ValueError, np.linalg.LinAlgError)
SAMPLE_COLUMNS = ("sample", "method", "status", "translation_mm", "rotation_deg",
                  "rotation_fro", "quality")
#: what a study writes in its folder
OUTPUT_NAMES = ("study.json", "samples.csv", "summary.csv", "cells", "datasets", "figures")


# ---------------------------------------------------------------------- formatting

def fmt(x: Any) -> str:
    """A CSV field: floats in their shortest round-trip form, NaN and None as ''."""
    if x is None:
        return ""
    if isinstance(x, float | np.floating):
        x = float(x)
        return "" if not np.isfinite(x) else repr(x)
    if isinstance(x, list | tuple):
        return " ".join(fmt(v) for v in x)
    return str(x)


def csv_text(header, rows, field: Callable[[Any], str] | None = None) -> str:
    """rasc's one CSV writer: ``header``, then each row's fields formatted by ``field``
    (default :func:`fmt`), ``\\n`` line ends."""
    field = field or fmt
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in rows:
        w.writerow([field(v) for v in row])
    return buf.getvalue()


# ---------------------------------------------------------------------- datasets

def dataset_key(render: dict[str, Any], seed: int) -> str:
    """The cache key of a rendered dataset: its render parameters and seed."""
    from rasc.study.spec import _digest
    return _digest({"render": render, "seed": seed})[:20]


def unit_builds(render: dict[str, Any]) -> dict | None:
    """``{eye: rasc.sim.units.UnitBuild}`` from a cell's head-model parameters (applied
    to the unit(s) of ``units_eye``); None when every one is at its default (the stock
    head, exactly as before these parameters existed)."""
    from rasc.sim.units import UnitBuild

    v = {k: render.get(k, PARAMS[k].default) for k in UNIT_PARAMS}
    if all(v[k] == PARAMS[k].default for k in UNIT_PARAMS):
        return None
    offset = v["tilt_axis_offset_mm"]
    # the stock units' axes: pan x, tilt z at home; their common normal is y (forward)
    build = UnitBuild(tilt_axis_offset_mm=(0.0, offset, 0.0) if offset else None,
                      axis_skew_deg=v["axis_skew_deg"] or None,
                      pan_zero_deg=v["pan_zero_deg"], tilt_zero_deg=v["tilt_zero_deg"],
                      pan_scale=v["pan_scale"], tilt_scale=v["tilt_scale"])
    which = render.get("units_eye", PARAMS["units_eye"].default)
    return {eye: build for eye in EYES if which in ("both", eye)}


def dataset_document(cal, board, truth: dict | None, **extra: Any) -> dict:
    """What the cells need from a calibrated dataset (JSON-ready): per eye the pipeline's
    poses, angles, kept pose corners (``EyeResult.corners``), intrinsics, and the
    reference ``T_cam_from_gaze``.

    Parameters
    ----------
    cal : rasc.head.pipeline.Calibration
    board : rasc.vision.board.Board
    truth : dict or None
        The renderer's ``ground_truth.json``; its ``T_cam_from_gaze`` per eye is the
        reference. None (a real head's dataset): the reference is the pipeline's own RASC
        solution on the measured poses (``"reference": "measured"``), so errors are
        deviations from what the data give without added noise.
    """
    eyes = {}
    views = (truth or {}).get("views", {})
    for eye, res in cal.eyes.items():
        ref = (truth[eye]["T_cam_from_gaze"] if truth is not None
               else np.asarray(res.handeye.T_cam_from_gaze, float).tolist())
        if all(f in views for f in res.pose_files):
            extra_eye = {"T_cam_from_world_true": [views[f]["T_cam_from_world"]
                                                   for f in res.pose_files]}
        else:
            extra_eye = {}
        eyes[eye] = {
            "files": list(res.pose_files),
            "pan_tilt_rad": np.asarray(res.pan_tilt, float).tolist(),
            "T_cam_from_world": np.asarray(res.T_cam_from_world, float).tolist(),
            "corners": [np.asarray(res.corners["pose"][f], float).tolist()
                        for f in res.pose_files],
            "K": np.asarray(res.intrinsics.K, float).tolist(),
            "dist": np.asarray(res.intrinsics.dist, float).ravel().tolist(),
            "T_cam_from_gaze_true": ref, **extra_eye}
    scene = _scene_record(truth, cal.eyes[next(iter(cal.eyes))].pose_files) \
        if truth is not None else None
    return {"format": "rasc-study-dataset/1", **extra,
            **({} if truth is not None else {"reference": "measured"}),
            **({"scene": scene} if scene is not None else {}),
            "board": {"inner_corners": list(board.inner_corners),
                      "square_size": board.square_size},
            "eyes": eyes}


def _scene_record(truth: dict, pose_files) -> dict | None:
    """What re-rendering a dataset's scene needs and checks, from its ground truth: the
    render options, the board's pose (at the first pose view) and each head as built;
    None for a dataset whose ground truth does not record them (not rendered by rasc)."""
    opts = truth.get("render_options")
    views = truth.get("views", {})
    first = views.get(pose_files[0]) if pose_files else None
    if opts is None or first is None or "T_base_from_world" not in first or not all(
            "unit_as_built" in truth.get(eye, {}) for eye in EYES):
        return None
    return {"render_options": {k: opts.get(k) for k in (
                "seed", "target_distance", "noise_sigma", "blur_sigma", "dist")},
            "model_file": truth.get("model_file"),
            "generated_scene": truth.get("generated_scene", False),
            "T_base_from_world": first["T_base_from_world"],
            "heads": {eye: truth[eye]["unit_as_built"] for eye in EYES}}


def render_task(task: dict) -> dict:
    """Render one dataset in a temporary folder, calibrate it with the real pipeline
    (rasc.head.pipeline.calibrate_dataset), return what the cells need (JSON-ready).

    Runs in a worker: sets MUJOCO_GL before anything imports mujoco.
    """
    worker_environment()
    from rasc.head.pipeline import calibrate_dataset
    from rasc.sim.render import RenderOptions, render_dataset
    from rasc.vision.dataset import load_dataset

    r = task["render"]
    full = {k: r.get(k, p.default) for k, p in PARAMS.items() if p.kind == "render"}
    options = RenderOptions(
        poses_deg=pose_grid(full["layout"], full["positions"], full["motion_deg"]),
        n_intrinsics=full["intrinsics_views"], target_distance=full["distance"],
        seed=task["seed"], noise_sigma=full["image_noise"], blur_sigma=full["blur"],
        dist=tuple(full["distortion"]))
    tmp = Path(tempfile.mkdtemp(prefix="rasc-study-render-"))
    try:
        folder = tmp / "dataset"
        try:
            render_dataset(folder, options, model_path=task["model_path"], quiet=True,
                           units=unit_builds(r))
            ds = load_dataset(folder)
            cal = calibrate_dataset(ds)
        except RascError as exc:     # name the cell's render parameters, not a CLI flag
            what = ", ".join(f"{k} = {v!r}" for k, v in sorted(r.items()) if k != "model")
            raise type(exc)(f"{task.get('where', 'the spec')}: the dataset for {what}: "
                            f"{spec_words(' '.join(str(exc).split()))}") from None
        truth = json.loads((folder / "ground_truth.json").read_text())
        return dataset_document(cal, ds.board, truth, key=task["key"], render=r,
                                seed=task["seed"])
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


#: the renderer's option names (its command's flags) and the spec's keys for them
FLAG_KEYS = (("--intrinsics-views", "intrinsics_views"), ("--distance", "distance"),
             ("--noise", "image_noise"), ("--blur", "blur"), ("--distortion", "distortion"),
             ("--poses", "the positions (layout, positions, motion_deg)"),
             ("--seed", "seed"))


def spec_words(message: str) -> str:
    """A renderer's message in the spec's words: each option named by its spec key."""
    for flag, key in FLAG_KEYS:
        message = message.replace(flag, key)
    return message


def folder_task(task: dict) -> dict:
    """Calibrate an existing dataset folder (``[fixed] dataset``) with the real pipeline;
    its ``ground_truth.json``, when present, is the reference (else the measured RASC
    solution, see :func:`dataset_document`)."""
    worker_environment()
    from rasc.head.pipeline import calibrate_dataset
    from rasc.vision.dataset import load_dataset

    folder = Path(task["folder"])
    ds = load_dataset(folder)
    cal = calibrate_dataset(ds)
    gt = folder / "ground_truth.json"
    truth = json.loads(gt.read_text()) if gt.is_file() else None
    doc = dataset_document(cal, ds.board, truth, key=task["key"])
    return _in_metres(doc, dataset_metres(folder))


#: the scene re-rendered for ``intrinsics_from = "dataset"`` must be the base's: the
#: board's pose, the heads' constants within this (both come from the same model through
#: quaternion round trips: ~1e-15 seen; a different scene differs by millimetres)
SAME_SCENE_ATOL = 1e-9
#: the generator of a pose-only render's image degradation: SeedSequence([seed, this, key])
POSE_RENDER_KEY = 0x9053


def same_poses(doc: dict, poses_deg) -> bool:
    """Whether both eyes of a dataset document have exactly the pose set ``poses_deg``
    (pan, tilt in degrees, in this order; within 1e-12 rad)."""
    want = np.radians(np.asarray(poses_deg, float))
    for eye in doc["eyes"].values():
        have = np.asarray(eye["pan_tilt_rad"], float)
        if have.shape != want.shape or np.abs(have - want).max() > 1e-12:
            return False
    return True


def _differs(a, b, path: str = "") -> str | None:
    """The first place two JSON trees differ (numbers within SAME_SCENE_ATOL), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                return f"{path}.{k}".lstrip(".")
            d = _differs(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        if len(a) != len(b):
            return path.lstrip(".")
        for k, (x, y) in enumerate(zip(a, b, strict=True)):
            d = _differs(x, y, f"{path}[{k}]")
            if d:
                return d
        return None
    if isinstance(a, int | float) and isinstance(b, int | float) and \
            not isinstance(a, bool) and not isinstance(b, bool):
        return None if abs(float(a) - float(b)) <= SAME_SCENE_ATOL else path.lstrip(".")
    return None if a == b else path.lstrip(".")


def pose_task(task: dict) -> dict:
    """``intrinsics_from = "dataset"``: render only the pose views of ``task["render"]``'s
    pose set in the base dataset's scene, detect their corners (the pipeline's detector)
    and estimate each view's extrinsics with the base's intrinsics (docs/METHOD.md §7).
    Returns a dataset document like :func:`render_task`'s (JSON-ready).

    The scene: a base rendered by this study is re-rendered from its render parameters;
    a given base from its ``scene`` record (the ground truth's render options, board
    pose and heads, checked against the package model's within SAME_SCENE_ATOL).

    Raises
    ------
    rasc.errors.InputError
        The base has no scene record (not rendered by rasc), its scene is not the package
        model's, or a pose view cannot see the board.
    rasc.errors.DegenerateDataError
        The board is not found in a rendered pose view.
    """
    worker_environment()
    from rasc.head.pipeline import CalibrationOptions
    from rasc.sim.render import RenderOptions, check_pose_views, distortion_of, view_image
    from rasc.sim.scene import StereoHeadSim, T_base_from_world_facing, distortion_warp
    from rasc.vision.board import Board
    from rasc.vision.camera import detect_corners, estimate_extrinsics

    base, r = task["base"], task["render"]
    where = task["where"]
    full = {k: r.get(k, p.default) for k, p in PARAMS.items() if p.kind == "render"}
    poses = pose_grid(full["layout"], full["positions"], full["motion_deg"])
    if "render" in base:                   # rendered by this study: its own parameters
        b = {k: base["render"].get(k, p.default) for k, p in PARAMS.items()
             if p.kind == "render"}
        scene = {"seed": base["seed"], "target_distance": b["distance"],
                 "noise_sigma": b["image_noise"], "blur_sigma": b["blur"],
                 "dist": list(b["distortion"])}
        model_path, units, record = task.get("model_path"), unit_builds(base["render"]), None
    else:
        record = base.get("scene")
        if record is None:
            raise InputError(f"{where}: intrinsics_from = 'dataset' renders pose views in "
                             "the dataset's scene, but the dataset records none (its "
                             "ground_truth.json has no render_options, views and heads: "
                             "not rendered by rasc render)")
        if record.get("generated_scene"):
            raise InputError(f"{where}: intrinsics_from = 'dataset': the dataset was "
                             "rendered from a generated scene, which cannot be rendered again")
        scene = record["render_options"]
        model_path, units = None, None
    board = Board(tuple(base["board"]["inner_corners"]), base["board"]["square_size"])
    options = RenderOptions(poses_deg=poses, target_distance=scene["target_distance"],
                            seed=scene["seed"], noise_sigma=scene["noise_sigma"] or 0.0,
                            blur_sigma=scene["blur_sigma"] or 0.0,
                            dist=tuple(scene["dist"] or ()))
    dist, distorted = distortion_of(options)
    rng = np.random.default_rng(np.random.SeedSequence(
        [task["seed"], POSE_RENDER_KEY, int(task["key"], 16)]))
    detector = CalibrationOptions().detector
    images: dict[str, list] = {eye: [] for eye in EYES}
    T_true: dict[str, list] = {eye: [] for eye in EYES}
    with StereoHeadSim(model_path, units=units) as sim:
        if sim.board != board:
            raise InputError(f"{where}: intrinsics_from = 'dataset': the scene's board "
                             f"{sim.board} is not the dataset's {board}")
        sim.set_target(T_base_from_world_facing(board, distance=options.target_distance))
        if record is not None:
            gt = sim.ground_truth()
            diff = _differs(sim.T_base_from_world.tolist(), record["T_base_from_world"]) \
                and "T_base_from_world"
            for eye in EYES:
                diff = diff or _differs(gt[eye]["unit_as_built"], record["heads"][eye],
                                        f"{eye}.unit_as_built")
            if diff:
                raise InputError(f"{where}: intrinsics_from = 'dataset': the dataset's scene "
                                 f"is not the package model's ({diff} differs); only a "
                                 "dataset rendered from it can be rendered again")
        check_pose_views(sim, options, dist if distorted else None)
        warp = {eye: distortion_warp(sim.K(eye), dist, sim.image_size) for eye in EYES} \
            if distorted else {}
        for pan, tilt in poses:
            for eye in EYES:
                sim.set_angles(eye, np.radians(pan), np.radians(tilt))
            for eye in EYES:
                images[eye].append(view_image(sim, eye, warp, rng, options))
                T_true[eye].append(sim.T_cam_from_world(eye).tolist())
        X_sim = {eye: sim.T_cam_from_gaze(eye) for eye in EYES}
    pan_tilt = np.radians(np.asarray(poses, float))
    eyes = {}
    for eye, data in base["eyes"].items():
        X_true = np.asarray(data["T_cam_from_gaze_true"], float)
        if np.abs(X_sim[eye] - X_true).max() > SAME_SCENE_ATOL:
            raise InputError(f"{where}: intrinsics_from = 'dataset': the rendered {eye} "
                             "head's T_cam_from_gaze is not the dataset's truth")
        K, d = np.asarray(data["K"], float), np.asarray(data["dist"], float)
        files, corners, T_cw = [], [], []
        for k, image in enumerate(images[eye]):
            name = f"poses±{full['motion_deg']:g}/{eye}_{k:02d}"
            c = detect_corners(image, board, method=detector)
            if c is None:
                raise DegenerateDataError(f"{where}: the pose view {name} (pan, tilt = "
                                          f"{poses[k][0]:g}, {poses[k][1]:g} deg): board "
                                          "not found")
            files.append(name)
            corners.append(np.asarray(c, float).tolist())
            T_cw.append(estimate_extrinsics(c, board, K, d)[0].tolist())
        eyes[eye] = {"files": files, "pan_tilt_rad": pan_tilt.tolist(), "T_cam_from_world": T_cw,
                     "corners": corners, "K": data["K"], "dist": data["dist"],
                     "T_cam_from_gaze_true": data["T_cam_from_gaze_true"],
                     "T_cam_from_world_true": T_true[eye]}
    out = {"format": "rasc-study-dataset/1", "key": task["key"], "render": r,
           "seed": task["seed"], "intrinsics_of": task["base_key"],
           "board": base["board"], "eyes": eyes}
    if record is not None:
        out["scene"] = record
    return out


def _in_metres(doc: dict, metres: float) -> dict:
    """A dataset document's lengths (the board's square size, every translation) scaled
    by ``metres`` per unit: the cells measure errors and eq. 14 noise in metres."""
    if metres == 1.0:
        return doc
    doc["board"]["square_size"] *= metres
    if "scene" in doc:
        T = np.asarray(doc["scene"]["T_base_from_world"], float)
        T[:3, 3] *= metres
        doc["scene"]["T_base_from_world"] = T.tolist()
    for eye in doc["eyes"].values():
        for key in ("T_cam_from_world", "T_cam_from_gaze_true", "T_cam_from_world_true"):
            if key not in eye:
                continue
            T = np.asarray(eye[key], float)
            T[..., :3, 3] *= metres
            eye[key] = T.tolist()
    return doc


# ---------------------------------------------------------------------- the cache

def cache_dir() -> Path | None:
    """Where rendered study datasets are cached between runs: ``study-datasets`` under
    :func:`rasc.io.cache_root` (``RASC_CACHE_DIR=none`` turns the cache off); entries are
    the dataset service's (:class:`rasc.datasets.CacheStore`), verified when read."""
    root = cache_root()
    return None if root is None else root / "study-datasets"


def cache_key(kind: str, task: dict) -> str:
    """The cache key of a render (``kind`` "render") or pose-set (``kind`` "poses") task:
    the dataset service's key (:func:`rasc.datasets.cache_key`: the one code digest) of
    the task's dataset key, render parameters (the model as its file's sha256), seed and,
    for a pose set, its base dataset's sha256."""
    from rasc.datasets import keys
    what = {"key": task["key"], "render": task["render"], "seed": task["seed"]}
    if kind == "poses":
        what["base"] = dataset_digest_of(task["base"])
    return keys.cache_key(f"study-{kind}", what)


def _check_dataset_doc(doc: dict) -> None:
    """ValueError unless ``doc`` looks like a whole study dataset document."""
    if doc.get("format") != "rasc-study-dataset/1":
        raise ValueError(f"format {doc.get('format')!r}, not rasc-study-dataset/1")
    eyes, board = doc.get("eyes"), doc.get("board")
    if not isinstance(board, dict) or not isinstance(eyes, dict) or not eyes:
        raise ValueError("no board or no eyes")
    for name, eye in eyes.items():
        if not isinstance(eye, dict):
            raise ValueError(f"eyes.{name} is not an object")
        n = None
        for k in ("files", "pan_tilt_rad", "T_cam_from_world", "corners"):
            v = eye.get(k)
            if not isinstance(v, list) or n is not None and len(v) != n:
                raise ValueError(f"eyes.{name}.{k} is missing or of another length")
            n = len(v)
        T = np.asarray(eye["T_cam_from_world"], float)
        if T.shape != (n, 4, 4) or not np.all(np.isfinite(T)):
            raise ValueError(f"eyes.{name}.T_cam_from_world is not {n} finite 4x4 matrices")
        for k in ("K", "T_cam_from_gaze_true"):
            if not isinstance(eye.get(k), list):
                raise ValueError(f"eyes.{name}.{k} is missing")


# ---------------------------------------------------------------------- samples

def sample_rng(seed: int, cell: Cell, sample: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([seed, *cell.seed_words, sample]))


def _solve(method: str, T_cw: np.ndarray, T_gp: np.ndarray, literal: bool):
    from rasc.handeye.methods import solve
    options = {"check_rigid": False} if literal else {}
    return solve(method, T_cw, T_gp, **options)


def _scored(T: np.ndarray, quality: float, T_true: np.ndarray) -> tuple:
    from rasc.geometry.transforms import rotation_error_deg

    R, R_true = T[:3, :3], T_true[:3, :3]
    return ("ok", 1000.0 * float(np.linalg.norm(T[:3, 3] - T_true[:3, 3])),
            float(rotation_error_deg(R, R_true)), float(np.linalg.norm(R - R_true)),
            float(quality), T)


def _score_result(res: Any, T_true: np.ndarray) -> tuple:
    """A solve's result, or the exception it raised, scored against ``T_true``: a failure
    (:data:`FAILURES`) is "failed: <error class>", a non-finite result "non-finite", both
    without numbers; any other exception propagates."""
    nan = float("nan")
    if isinstance(res, Exception):
        if not isinstance(res, FAILURES):
            raise res
        return f"failed: {type(res).__name__}", nan, nan, nan, nan, None
    T = np.asarray(res.T_cam_from_gaze, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        return "non-finite", nan, nan, nan, nan, None
    return _scored(T, res.quality, T_true)


def _score(method: str, T_cw: np.ndarray, T_gp: np.ndarray, T_true: np.ndarray,
           literal: bool) -> tuple:
    try:
        res = _solve(method, T_cw, T_gp, literal)
    except FAILURES as exc:
        res = exc
    return _score_result(res, T_true)


def score(method: str, T_cw: np.ndarray, T_gp: np.ndarray, T_true: np.ndarray,
          literal: bool) -> tuple[str, float, float, float, float]:
    """(status, translation_mm, rotation_deg, rotation_fro, quality) of one solve; a
    failed or non-finite solve has status "failed: <error class>" or "non-finite" and no
    numbers (never an error value)."""
    return _score(method, T_cw, T_gp, T_true, literal)[:5]


def _score_samples(method: str, T_cw: np.ndarray, T_gp: np.ndarray, T_true: np.ndarray,
                   literal: bool, time_limit_s: float | None = None) -> list[tuple]:
    """:func:`_score` for each of S pose sets (S, n, 4, 4), all solved in one call of
    :func:`rasc.handeye.methods.solve_many` (RASC's batched solver, whose result for a
    set is, bit for bit, that set's own solve whatever the other sets: a sample's numbers
    do not depend on how many samples its cell has)."""
    from rasc.guard import DEFAULT_TIME_LIMIT_S, guarded
    from rasc.handeye.methods import get_method, solve_many

    options = {"check_rigid": False} if literal else {}
    try:
        m = get_method(method)
        if m.builtin:
            results = solve_many(m, T_cw, T_gp, **options)
        else:
            # a plugin: one guarded call per sample (what solve_many does for it), so
            # that its output, an exit or a hang is that sample's failure
            limit = DEFAULT_TIME_LIMIT_S if time_limit_s is None else time_limit_s
            results = []
            for s in range(len(T_cw)):
                try:
                    results.append(guarded(m, T_cw[s], T_gp, who=f"method {method!r}",
                                           time_limit_s=limit, **options))
                except Exception as exc:  # noqa: BLE001 -- scored as solve_many hands it
                    results.append(exc)
    except FAILURES as exc:                      # the method itself (e.g. its name) fails
        results = [exc] * len(T_cw)
    return [_score_result(res, T_true) for res in results]


#: the estimate's columns of samples.csv with ``estimates=True`` (mm; R row-major)
ESTIMATE_COLUMNS = ("t_x_mm", "t_y_mm", "t_z_mm",
                    *(f"R_{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)))
#: the sample's extrinsics error against the rendered truth, with ``pose_errors=True``:
#: RMS over the pose views, per camera axis (x right, y down, z optical axis), of the
#: rotation-error vector log(R R_true^T) (rad) and of t - t_true (mm); the eq. 13-14
#: equivalent (docs/METHOD.md §8) is the RMS of each triple
POSE_ERROR_COLUMNS = (*(f"pose_rot_{a}_rad" for a in "xyz"), *(f"pose_t_{a}_mm" for a in "xyz"))


def pose_error_rms(T_cw: np.ndarray, T_true: np.ndarray) -> list[float]:
    """:data:`POSE_ERROR_COLUMNS` of one pose set: ``T_cw``, ``T_true`` (n, 4, 4) in
    metres → [rot x, y, z (rad), t x, y, z (mm)], RMS over the n views."""
    from rasc.geometry.transforms import rotvec_from_matrix

    w = rotvec_from_matrix(T_cw[:, :3, :3] @ np.swapaxes(T_true[:, :3, :3], -1, -2))
    dt = 1000.0 * (T_cw[:, :3, 3] - T_true[:, :3, 3])
    return [*map(float, np.sqrt(np.mean(w**2, axis=0))),
            *map(float, np.sqrt(np.mean(dt**2, axis=0)))]


def classify_gross(res: tuple, gross: tuple[float | None, float | None]) -> tuple:
    """A scored solve (:func:`_score`'s tuple) with status "gross" when it is "ok" but
    farther from the truth than ``gross`` = (deg, mm) allows (None: no limit)."""
    deg, mm = gross
    if res[0] == "ok" and (deg is not None and res[2] > deg or mm is not None and res[1] > mm):
        return ("gross", *res[1:])
    return res


def home_view(pan_tilt: np.ndarray, where: str) -> int:
    """The index of the one view at pan = tilt = 0; DegenerateDataError otherwise."""
    home = np.flatnonzero(np.all(np.asarray(pan_tilt) == 0.0, axis=1))
    if home.size != 1:
        raise DegenerateDataError(f"{where}: {home.size} pose views at pan = tilt = 0; "
                                  "noise_on = 'home' needs exactly one home view")
    return int(home[0])


def cell_task(task: dict) -> list[list]:
    """Every sample of one cell: ``[sample, method, status, errors..., quality]`` rows
    (and the estimate, :data:`ESTIMATE_COLUMNS`, with ``task["estimates"]``).

    A cell without sample-level noise (σ = 0 and no corner noise) solves once and repeats
    that row for every sample: its samples are the same pose set."""
    worker_environment()
    from rasc.geometry.kinematics import T_gaze_from_ptu
    from rasc.handeye.noise import perturb_one_view, perturb_T_cam_from_world
    from rasc.vision.board import Board
    from rasc.vision.camera import estimate_extrinsics

    cell: Cell = task["cell"]
    p, data = cell.params, task["dataset"]
    eye = data["eyes"][p["eye"]]
    T_cw0 = np.asarray(eye["T_cam_from_world"], float)
    pan_tilt = np.asarray(eye["pan_tilt_rad"], float)
    T_gp = T_gaze_from_ptu(pan_tilt[:, 0], pan_tilt[:, 1])
    T_true = np.asarray(eye["T_cam_from_gaze_true"], float)
    literal = p["noise_model"] == "literal"
    pose_noise = p["sigma_r"] > 0 or p["sigma_t_mm"] > 0
    noisy = pose_noise or p["corner_noise_px"] > 0
    home = (home_view(pan_tilt, f"the {p['eye']} eye's dataset")
            if pose_noise and p.get("noise_on", "all") == "home" else None)
    if p["corner_noise_px"] > 0:
        board = Board(tuple(data["board"]["inner_corners"]), data["board"]["square_size"])
        corners = [np.asarray(c, float) for c in eye["corners"]]
        K, dist = np.asarray(eye["K"], float), np.asarray(eye["dist"], float)
    sets = []
    for s in range(task["samples"] if noisy else 1):
        rng = sample_rng(task["seed"], cell, s)
        T_cw = T_cw0
        if p["corner_noise_px"] > 0:
            T_cw = np.array([estimate_extrinsics(c + p["corner_noise_px"]
                                                 * rng.standard_normal(c.shape),
                                                 board, K, dist)[0] for c in corners])
        if pose_noise:                                                # mm -> metres
            if home is None:
                T_cw = perturb_T_cam_from_world(T_cw, p["sigma_r"], p["sigma_t_mm"] / 1000.0,
                                                rng, p["noise_model"])
            else:
                T_cw = perturb_one_view(T_cw, home, p["sigma_r"], p["sigma_t_mm"] / 1000.0,
                                        rng, p["noise_model"])
        sets.append(T_cw)
    sets = np.array(sets)
    scored = {m: _score_samples(m, sets, T_gp, T_true, literal, task.get("time_limit_s"))
              for m in task["methods"]}
    gross = task.get("gross", (None, None))
    if gross != (None, None):
        scored = {m: [classify_gross(r, gross) for r in rs] for m, rs in scored.items()}
    pose_err = None
    if task.get("pose_errors"):
        truth = eye.get("T_cam_from_world_true")
        pose_err = ([pose_error_rms(T, np.asarray(truth, float)) for T in sets]
                    if truth is not None else [[float("nan")] * 6] * len(sets))
    rows = []
    for s in range(task["samples"]):
        for method in task["methods"]:
            *res, T = scored[method][s if noisy else 0]
            row = [s, method, *res]
            if task.get("estimates"):
                row += ([*(1000.0 * T[:3, 3]), *T[:3, :3].ravel()] if T is not None
                        else [float("nan")] * len(ESTIMATE_COLUMNS))
            if pose_err is not None:
                row += pose_err[s if noisy else 0]
            rows.append(row)
    return rows


# ---------------------------------------------------------------------- summary

def bootstrap_ci(x: np.ndarray, rng: np.random.Generator, resamples: int,
                 confidence: float) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``x`` (n,); NaN for n < 2."""
    if len(x) < 2:
        return float("nan"), float("nan")
    means = x[rng.integers(0, len(x), (resamples, len(x)))].mean(axis=1)
    a = (1.0 - confidence) / 2.0
    lo, hi = np.quantile(means, [a, 1.0 - a])
    return float(lo), float(hi)


def summarise(spec: Spec, cells: list[Cell], rows_by_cell: dict[int, list[list]]
              ) -> list[list]:
    """Per cell and method: n ok, n failed, and for each error its mean, median, std
    (ddof 1) and the bootstrap CI of the mean."""
    out = []
    for cell in cells:
        rows = rows_by_cell[cell.index]
        for m_index, method in enumerate(spec.methods):
            mine = [r for r in rows if r[1] == method]
            ok = [r for r in mine if r[2] == "ok"]
            rng = np.random.default_rng(np.random.SeedSequence(
                [spec.seed, BOOTSTRAP_KEY, *cell.seed_words, m_index]))
            stats = []
            for col in (3, 4):
                x = np.array([float(r[col]) for r in ok])
                if len(x) == 0:
                    stats += [None] * len(STATS)
                    continue
                lo, hi = bootstrap_ci(x, rng, spec.bootstrap, spec.confidence)
                stats += [float(x.mean()), float(np.median(x)),
                          float(x.std(ddof=1)) if len(x) > 1 else None, lo, hi]
            out.append([cell.index, *cell.axes.values(), method, len(ok),
                        len(mine) - len(ok), *stats])
    return out


# ---------------------------------------------------------------------- the study

@dataclass
class StudyResult:
    folder: Path
    cells: int
    cells_computed: int
    datasets_rendered: int
    samples_csv: Path
    summary_csv: Path
    figures: list[Path]
    #: datasets copied from the cache (:func:`cache_dir`) instead of rendering
    datasets_cached: int = 0


def dataset_digest_of(doc: dict) -> str:
    """The key of a given dataset document: sha256 of its JSON (20 hex digits)."""
    import hashlib
    return hashlib.sha256(dumps_json(doc).encode()).hexdigest()[:20]


def _manifest(spec: Spec, cells: list[Cell], dataset: str | None = None) -> dict:
    import rasc
    out = {"format": FORMAT, "spec_sha256": spec.digest, "spec": spec.to_dict(),
           "rasc_version": rasc.__version__,
           "cells": [{"index": c.index, "key": c.key, "axes": c.axes} for c in cells]}
    if dataset is not None:
        out["dataset"] = dataset
    return out


def prepare_folder(out: Path, spec: Spec, resume: bool, dataset: str | None = None) -> None:
    """Check ``out`` before any work: new or empty (or, with ``resume``, a study of this
    very spec); never the spec itself or a folder holding it as an output name."""
    out = Path(out)
    manifest = out / "study.json"
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: --out exists and is not a folder")
    if not out.exists():
        if not out.parent.is_dir():
            raise InputError(f"{out}: parent folder {out.parent} does not exist")
        if resume:
            raise InputError(f"{out}: --resume: no study to resume (the folder does not exist)")
        return
    if resume:
        if not manifest.is_file():
            raise InputError(f"{out}: --resume: no study.json (not a study folder)")
        try:
            doc = json.loads(manifest.read_text())
            old, old_dataset = doc.get("spec_sha256"), doc.get("dataset")
        except (OSError, ValueError, AttributeError) as exc:
            raise InputError(f"{manifest}: unreadable study manifest ({exc})") from None
        if old == spec.digest and old_dataset != dataset:
            raise InputError(f"{out}: --resume: the folder holds this study on another "
                             "dataset; --resume continues only the same dataset")
        if old != spec.digest:
            raise InputError(f"{out}: --resume: the folder holds a study of a different "
                             f"spec (sha256 {str(old)[:12]}, this one {spec.digest[:12]}); "
                             "--resume continues only the same spec")
        return
    if manifest.is_file():
        raise InputError(f"{out}: holds a study already; pass --resume to continue it, "
                         "or choose another --out")
    if any(out.iterdir()):
        raise InputError(f"{out}: --out exists and is not empty")


@contextlib.contextmanager
def study_lock(out: Path):
    """An exclusive lock on the study folder ``out`` for the block (POSIX ``flock`` on the
    folder itself: nothing is written for it, and it goes with the process, however that
    ends). A second study into the same folder is refused at once (InputError)."""
    try:
        import fcntl
    except ImportError:                 # not POSIX: one study per folder is assumed
        yield
        return
    fd = os.open(out, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"{out}: another rasc study is writing into this folder; "
                             "wait for it to finish or choose another study folder") from None
        yield
    finally:
        os.close(fd)


def _make_folder(out: Path) -> bool:
    """Create the study folder ``out`` (whether this call created it); InputError, one
    line, when it cannot be made (``/proc/x``, a read-only place)."""
    try:
        out.mkdir()
        return True
    except FileExistsError:
        if not out.is_dir():
            raise InputError(f"{out}: exists and is not a folder") from None
        return False
    except OSError as exc:
        raise InputError(f"{out}: cannot create the study folder "
                         f"({exc.strerror or exc})") from None


def run_study(spec: Spec, out: str | os.PathLike, *, workers: int = 1,
              dask: str | None = None, resume: bool = False, quiet: bool = False,
              executor: Executor | None = None,
              log: Callable[[str], None] | None = None, dataset: dict | None = None,
              estimates: bool = False, figures: bool = True,
              pose_errors: bool = False) -> StudyResult:
    """Run (or, with ``resume``, continue) ``spec`` into the folder ``out``.

    Parameters
    ----------
    dataset : dict, optional
        A calibrated dataset to run every cell on instead of rendering (as
        :func:`dataset_document` makes it, e.g. from the reproduction's default dataset);
        the spec may then have no render parameter (InputError). Its sha256 is recorded in
        ``study.json`` and ``--resume`` continues only the same dataset.
    estimates : bool
        Add the estimate (:data:`ESTIMATE_COLUMNS`) to every row of ``samples.csv``.
    pose_errors : bool
        Add the sample's extrinsics error against the rendered truth
        (:data:`POSE_ERROR_COLUMNS`, empty for a dataset without one) to every row.
    figures : bool
        Draw ``figures/<axis>.png`` (callers that plot their own may skip them).

    The folder is locked for the run (:func:`study_lock`: a second study into it is
    refused). With ``resume``, every cell file and dataset file found is verified
    (:func:`verified_cell`, :func:`_check_dataset_doc`) and computed again, with a note,
    when it is incomplete or damaged: nothing found is trusted unread.

    On KeyboardInterrupt (SIGINT, or SIGTERM inside rasc.interrupt.signals_as_interrupt)
    the workers are stopped, the finished cells stay in ``out/cells`` (each file whole),
    no partial file is left, and :class:`rasc.interrupt.Interrupted` is raised, whose note
    says what was kept (the command line prints it as its one line).
    """
    log = log or (lambda s: print(s, file=sys.stderr))
    out = Path(out)
    spec_path = spec.path.resolve()
    if out.resolve() == spec_path or out.resolve() in spec_path.parents and \
            spec_path.relative_to(out.resolve()).parts[0] in OUTPUT_NAMES:
        raise InputError(f"{out}: --out would overwrite the spec {spec.path}")
    cells = spec.cells()
    given = None
    if dataset is not None:
        if spec.dataset_path() is not None:
            raise InputError(f"{spec.path}: fixed.dataset: the caller gives the dataset "
                             "already; leave it out of the spec")
        def fail(key: str, msg: str):
            raise InputError(f"{spec.path}: {key}: {msg}")
        check_beside_dataset(spec.fixed, spec.axes, fail, "the study runs on a given dataset")
        given = dataset_digest_of(dataset)
    elif spec.dataset_path() is not None:
        given = spec.cells()[0].params["dataset"].removeprefix("sha256:")[:20]
    cache_dir()          # a bad RASC_CACHE_MAX_MB is refused before anything is made
    prepare_folder(out, spec, resume, given)
    created = _make_folder(out)
    with study_lock(out):
        if not created:
            prepare_folder(out, spec, resume, given)     # again, now that it is ours
        return _run_locked(spec, out, cells, given, created, workers=workers, dask=dask,
                           resume=resume, quiet=quiet, executor=executor, log=log,
                           dataset=dataset, estimates=estimates, figures=figures,
                           pose_errors=pose_errors)


def _run_locked(spec: Spec, out: Path, cells: list[Cell], given: str | None, created: bool,
                *, workers, dask, resume, quiet, executor, log, dataset, estimates, figures,
                pose_errors) -> StudyResult:
    from rasc.progress import progress

    owned = executor is None
    try:
        executor = executor or make_executor(workers, dask)
    except BaseException:
        if created:
            shutil.rmtree(out, ignore_errors=True)
        raise
    cells_done = 0
    count = {"rendered": 0, "cached": 0}
    header = (SAMPLE_COLUMNS + (ESTIMATE_COLUMNS if estimates else ())
              + (POSE_ERROR_COLUMNS if pose_errors else ()))
    texts: dict[int, str] = {}
    cache = cache_dir()
    try:
        for sub in ("cells", "datasets"):
            (out / sub).mkdir(exist_ok=True)
        write_json_atomic(out / "study.json", _manifest(spec, cells, given))
        # 1. datasets: the one given, or one per distinct set of render parameters;
        # cells with intrinsics_from = "dataset" first need their base dataset
        def base_of(c: Cell) -> tuple[str, dict]:
            r = c.render_params()
            if given is not None:
                return given, {}
            if c.params["intrinsics_from"] != "dataset":
                return dataset_key(r, spec.seed), r
            b = {k: v for k, v in r.items() if k != "intrinsics_from"}
            b.update({k: PARAMS[k].default for k in POSE_PARAMS})
            return dataset_key(b, spec.seed), b
        bases = {c.index: base_of(c) for c in cells}
        wanted: dict[str, dict] = {}
        for k, r in bases.values():
            wanted.setdefault(k, r)
        datasets: dict[str, dict] = {}
        if dataset is not None:
            text = dumps_json(dataset)
            for k in wanted:
                path = out / "datasets" / f"{k}.json"
                try:
                    same = read_regular(path, len(text.encode()) + 1) == text.encode()
                except EntryError:
                    same = False
                if not same:
                    write_json_atomic(path, dataset)
                datasets[k] = dataset
        else:
            datasets.update(_found_datasets(out, wanted, log))
        missing = [k for k in wanted if k not in datasets]
        where = str(spec.path)
        if spec.dataset_path() is not None:
            fn, tasks = folder_task, [{"key": k, "folder": str(spec.dataset_path())}
                                      for k in missing]
        else:
            fn, tasks = render_task, [
                {"key": k, "render": wanted[k], "seed": spec.seed, "where": where,
                 "model_path": (str(spec.model_path(wanted[k]["model"]))
                                if wanted[k].get("model") else None)} for k in missing]
        datasets.update(_render(executor, fn, tasks, out, quiet, "render datasets", count,
                                cache if fn is render_task else None, "render", log))

        # 1b. pose sets in a base's scene with its intrinsics (intrinsics_from = "dataset")
        keys, poses = {}, {}
        for c in cells:
            base_key, base_r = bases[c.index]
            r = c.render_params()
            if c.params["intrinsics_from"] != "dataset":
                keys[c.index] = base_key
                continue
            grid = pose_grid(*(c.params[k] for k in ("layout", "positions", "motion_deg")))
            if same_poses(datasets[base_key], grid):
                keys[c.index] = base_key               # the base's own pose set
                continue
            k = dataset_key({**r, "intrinsics_of": base_key}, spec.seed)
            keys[c.index] = k
            poses.setdefault(k, {"key": k, "base_key": base_key, "render": r,
                                 "seed": spec.seed, "where": where,
                                 "model_path": (str(spec.model_path(base_r["model"]))
                                                if base_r.get("model") else None)})
        datasets.update(_found_datasets(out, poses, log))
        tasks = [{**poses[k], "base": datasets[poses[k]["base_key"]]}
                 for k in sorted(poses) if k not in datasets]
        datasets.update(_render(executor, pose_task, tasks, out, quiet, "render pose sets",
                                count, cache, "poses", log))

        # 2. cells: a cell file found is used only when it is whole (verified_cell)
        for c in cells:
            text, why = verified_cell(_cell_path(out, c), header, spec.samples, spec.methods)
            if text is not None:
                texts[c.index] = text
            elif why is not None:
                log(f"rasc study: note: {_cell_path(out, c)} is incomplete or damaged "
                    f"({why}); computing the cell again")
        todo = [c for c in cells if c.index not in texts]
        tasks = [{"cell": c, "dataset": datasets[keys[c.index]], "seed": spec.seed,
                  "samples": spec.samples, "methods": spec.methods,
                  "estimates": estimates, "pose_errors": pose_errors,
                  "time_limit_s": spec.time_limit_s,
                  "gross": (spec.gross_rotation_deg, spec.gross_translation_mm)}
                 for c in todo]
        with progress(total=len(cells), desc="cells", quiet=quiet, unit="cell") as bar:
            bar.update(len(cells) - len(todo))
            try:
                for i, rows in executor.map_unordered(cell_task, tasks):
                    text = csv_text(header, rows)
                    write_text_atomic(_cell_path(out, todo[i]), text)
                    texts[todo[i].index] = text
                    cells_done += 1
                    bar.update(1)
            except WorkerCrashed as exc:
                plugins = _plugins(spec.methods)
                raise WorkerCrashed(
                    f"{exc}; " + (f"the plugin method(s) {', '.join(plugins)} may have "
                                  "ended it (a crash in native code, or an exit rasc.guard "
                                  "cannot stop); run with one worker to see which"
                                  if plugins else "no plugin method was running")) from None
    except RascError:
        # bad input found only now (a dataset that cannot be rendered or calibrated, a
        # scene that cannot be rendered again): a folder this run created is removed
        # unless a cell has finished (its datasets alone are no result)
        if created and cells_done == 0:
            shutil.rmtree(out, ignore_errors=True)
        raise
    except KeyboardInterrupt:
        if owned:
            with contextlib.suppress(Exception):
                executor.abort()
        n = len(texts)
        kept = len(list((out / "datasets").glob("*.json"))) if (out / "datasets").is_dir() else 0
        raise Interrupted(
            f"kept {n} of {len(cells)} finished cells and {kept} dataset(s) in {out}; no "
            "samples.csv, summary.csv or figures written; continue with --resume") from None
    finally:
        if owned:
            with contextlib.suppress(Exception):
                executor.close()

    # 3. assemble: tidy samples, summary, figures
    rows_by_cell = {c.index: _parse_cell(texts[c.index]) for c in cells}
    axes = list(spec.axes)
    write_text_atomic(out / "samples.csv", _samples_text(cells, axes, header, texts))
    summary = summarise(spec, cells, rows_by_cell)
    write_text_atomic(out / "summary.csv", csv_text(("cell", *axes, *SUMMARY_TAIL), summary))
    files = []
    if figures:
        from rasc.study.figures import plot_study
        files = plot_study(spec, summary, out / "figures")
    if count["cached"] and not quiet:
        log(f"rasc study: {count['cached']} dataset(s) copied from the cache {cache} "
            "(same render parameters, seed and rasc; RASC_CACHE_DIR=none renders afresh)")
    return StudyResult(out, len(cells), cells_done, count["rendered"], out / "samples.csv",
                       out / "summary.csv", files, count["cached"])


def _plugins(methods) -> list[str]:
    """The names among ``methods`` that are plugins (not built in)."""
    from rasc.handeye.methods import get_method
    out = []
    for m in methods:
        with contextlib.suppress(Exception):
            if not get_method(m).builtin:
                out.append(m)
    return out


def _found_datasets(out: Path, wanted, log: Callable[[str], None]) -> dict[str, dict]:
    """The dataset files of ``wanted`` keys already in ``out/datasets`` that are whole
    (:func:`_check_dataset_doc`, their key); a damaged one is left to be computed again,
    with a note."""
    found = {}
    for k in wanted:
        path = out / "datasets" / f"{k}.json"
        if not os.path.lexists(path):
            continue
        try:
            doc = read_json_document(path, "study dataset")
            _check_dataset_doc(doc)
            if doc.get("key") != k:
                raise ValueError(f"its key is {doc.get('key')!r}, not {k!r}")
        except (InputError, ValueError) as exc:
            log(f"rasc study: note: {path} is incomplete or damaged "
                f"({' '.join(str(exc).split())[:200]}); computing it again")
            continue
        found[k] = doc
    return found


def _render(executor: Executor, fn, tasks: list[dict], out: Path, quiet: bool,
            desc: str, count: dict[str, int], cache: Path | None = None, kind: str = "",
            log: Callable[[str], None] = print) -> dict[str, dict]:
    """Run dataset tasks, writing each result to ``out/datasets/<key>.json`` as it comes
    (``count["rendered"]`` counts them); with a ``cache`` folder, a task found there
    (verified: :class:`rasc.datasets.CacheStore`) is copied instead (``count["cached"]``)
    and a rendered one stored there. Returns the documents by key (kept in memory)."""
    from rasc.progress import progress

    store = CacheStore(folder=cache, label="rasc study", log=log) if cache is not None \
        else None
    names = [cache_key(kind, t) for t in tasks] if store is not None else []
    todo, docs = [], {}
    for k, task in enumerate(tasks):
        doc = store.get_json(names[k], _check_dataset_doc) if store is not None else None
        if doc is not None and doc.get("key") == task["key"]:
            write_json_atomic(out / "datasets" / f"{task['key']}.json", doc)
            docs[task["key"]] = doc
            count["cached"] += 1
        else:
            todo.append(k)
    if not todo:
        return docs
    with progress(total=len(todo), desc=desc, quiet=quiet, unit="dataset") as bar:
        for i, doc in executor.map_unordered(fn, [tasks[k] for k in todo]):
            task = tasks[todo[i]]
            write_json_atomic(out / "datasets" / f"{task['key']}.json", doc)
            docs[task["key"]] = doc
            if store is not None:
                store.put_json(names[todo[i]], doc)
            count["rendered"] += 1
            bar.update(1)
    return docs


def _samples_text(cells: list[Cell], axes: list[str], header, texts: dict[int, str]) -> str:
    """samples.csv: each finished cell's lines (already formatted by :func:`csv_text`)
    behind the cell's index and axis values, in cell order (the same bytes as formatting
    the rows again, without doing it twice)."""
    parts = [csv_text(("cell", *axes, *header), [])]
    for c in cells:
        prefix = csv_text(("x",), [[c.index, *c.axes.values()]]).split("\n", 1)[1][:-1]
        parts += [f"{prefix},{line}\n" for line in texts[c.index].split("\n")[1:-1]]
    return "".join(parts)


def _cell_path(out: Path, cell: Cell) -> Path:
    return out / "cells" / f"cell-{cell.index:05d}.csv"


#: the largest cell file read on resume (a bigger one is damaged: a row is < 1 kB)
MAX_CELL_BYTES = 64 * 2**20


def verified_cell(path: Path, header, samples: int, methods) -> tuple[str | None, str | None]:
    """``(text, None)`` for a whole cell file: the header, then exactly one row per
    sample and method in :func:`cell_task`'s order, each with every column, a known
    status and finite numbers (the numbers an ``ok`` row needs present), ending in a
    newline; ``(None, why)`` for anything else (cut short, a garbage line, a link or FIFO
    in its place, another header); ``(None, None)`` when there is none."""
    try:
        data = read_regular(path, MAX_CELL_BYTES)
    except EntryError as exc:
        return None, str(exc)
    if data is None:
        return None, None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return None, "not UTF-8 text"
    if not text.endswith("\n"):
        return None, "cut short: no final newline"
    lines = text.split("\n")[:-1]
    if not lines or lines[0] != ",".join(header):
        return None, "not this study's header"
    want = [(str(s), m) for s in range(samples) for m in methods]
    if len(lines) - 1 != len(want):
        return None, f"{len(lines) - 1} rows, expected {len(want)}"
    for k, (row, (s, m)) in enumerate(zip(csv.reader(lines[1:]), want, strict=True),
                                      start=2):
        if len(row) != len(header) or row[0] != s or row[1] != m:
            return None, f"line {k} is not sample {s} of method {m}"
        status = row[2]
        if status not in ("ok", "gross", "non-finite") and not status.startswith("failed: "):
            return None, f"line {k}: unknown status {status[:40]!r}"
        try:
            nums = [float(v) for v in row[3:] if v != ""]
        except ValueError:
            return None, f"line {k}: a field that is not a number"
        if not all(np.isfinite(nums)) or status in ("ok", "gross") and "" in row[3:5]:
            return None, f"line {k}: missing or non-finite numbers"
    return text, None


def _parse_cell(text: str) -> list[list]:
    """A finished cell's rows, typed as :func:`cell_task` returns them."""
    reader = csv.reader(io.StringIO(text, newline=""))
    next(reader)
    rows = []
    for r in reader:
        nums = [float(v) if v != "" else float("nan") for v in r[3:]]
        rows.append([int(r[0]), r[1], r[2], *nums])
    return rows


__all__ = ["run_study", "StudyResult", "summarise", "cell_task", "render_task", "PARAMS",
           "dumps_json", "dataset_document", "unit_builds", "ESTIMATE_COLUMNS",
           "SAMPLE_COLUMNS", "POSE_ERROR_COLUMNS", "pose_task", "pose_error_rms"]
