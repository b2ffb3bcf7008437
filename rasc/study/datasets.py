"""A study's datasets stage: one calibration of a dataset (the dataset service's
document, :mod:`rasc.datasets.calibration`) per distinct set of render parameters —
rendered into memory, detected and calibrated by the real pipeline (:func:`render_task`;
no image file unless the spec keeps the datasets, ``[fixed] keep_datasets = true``), an
existing dataset folder calibrated (:func:`folder_task`), or pose views rendered in a
base dataset's scene (:func:`pose_task`) — found in the study folder (verified), in the
dataset service's cache (:class:`rasc.datasets.CacheStore`), or computed on the study's
executor. Documents stay in memory for the cells stage."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from rasc import formats
from rasc.datasets.cache import CacheStore
from rasc.datasets.calibration import (  # noqa: F401 (the old names, re-exported)
    _scene_record,  # noqa: F401 (re-exported)
    calibration_document,
    check_calibration_document,
    in_metres,
)
from rasc.datasets.keys import (  # noqa: F401 (re-exported)
    CACHE_LIBRARIES,
    code_digest,
    content_key,
)
from rasc.errors import DegenerateDataError, InputError, RascError
from rasc.geometry.frames import EYES
from rasc.io import (
    cache_root,
    dumps_json,
    read_json_document,
    write_json_atomic,
)
from rasc.study.cells import ESTIMATE_COLUMNS, POSE_ERROR_COLUMNS  # noqa: F401
from rasc.study.executors import Executor, worker_environment
from rasc.study.spec import (
    PARAMS,
    UNIT_PARAMS,
    dataset_metres,
    poses_of,
)


def dataset_name(render: dict[str, Any], seed: int) -> str:
    """The study's name of a dataset: the content key
    (:func:`rasc.datasets.content_key`, 20 hex digits) of its render parameters and seed,
    the same whatever the code. It names the dataset's file in a study folder,
    ``datasets/<name>.json`` (the document's ``key`` field), and the tasks that make it.
    Not a cache key: the dataset's cache entry is found under :func:`cache_key`, the
    project's one cache key (:func:`rasc.datasets.cache_key`), which adds the code
    digest. (Called ``dataset_key`` until rasc 0.2.0; the old name warns and goes in
    0.4.)"""
    return content_key({"render": render, "seed": seed})


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


def head_of(render: dict[str, Any], model_path: str | None):
    """What a dataset is rendered from: with ``urdf``, a
    :class:`rasc.sim.urdf.UrdfHead` of the file ``model_path`` and the cell's
    ``urdf_joints`` and ``urdf_cameras``; else ``model_path`` (an MJCF scene or None)."""
    if not render.get("urdf") or model_path is None:
        return model_path
    from rasc.sim.urdf import UrdfHead

    names = {k: tuple(render.get(k, PARAMS[k].default).split(","))
             for k in ("urdf_joints", "urdf_cameras")}
    return UrdfHead(model_path, names["urdf_joints"], names["urdf_cameras"])


def target_of(render: dict[str, Any]):
    """The target a cell's ``target`` describes (:func:`rasc.vision.board.parse_target`),
    or None for the model's own board."""
    from rasc.vision.board import parse_target

    text = render.get("target", PARAMS["target"].default)
    return parse_target(text) if text else None


@dataclass(frozen=True)
class RenderTask:
    """Render and calibrate the dataset of ``render`` (a cell's render parameters)."""

    key: str
    render: dict
    seed: int
    model_path: str | None = None
    #: the spec file, for messages
    where: str = "the spec"
    #: the study's scratch folder for a worker's temporary files (removed by the study,
    #: also when a worker is killed); rendering itself makes none (in memory)
    scratch: str | None = None
    #: ``keep_datasets``: return the rendered dataset (images in memory) with its
    #: calibration, for the study to write under its folder (on the study's machine,
    #: whichever machine the task ran on); False: the images end with the task
    keep: bool = False
    #: the spec's ``positions_file`` the render's positions were read from ("" for the
    #: layout's grid), for messages: a position is named by its file and index
    positions_from: str = ""


@dataclass(frozen=True)
class FolderTask:
    """Calibrate the existing dataset folder ``folder`` (``[fixed] dataset``)."""

    key: str
    folder: str


@dataclass(frozen=True)
class PoseTask:
    """Render the pose views of ``render``'s pose set in the scene of ``base`` (the
    document of the dataset ``base_key``) and measure them with its intrinsics."""

    key: str
    base_key: str
    render: dict
    seed: int
    where: str
    model_path: str | None = None
    base: dict | None = None


def render_task(task: RenderTask) -> dict | tuple:
    """Render one dataset into memory (:func:`rasc.sim.render.render_in_memory`), detect
    its corners from the arrays and calibrate it with the real pipeline
    (:func:`rasc.datasets.calibration.calibrate`); return what the cells need
    (JSON-ready) — with ``task.keep``, ``(that, the dataset)`` for the study to write.

    Runs in a worker: sets MUJOCO_GL before anything imports mujoco.
    """
    worker_environment()
    from rasc.datasets.calibration import calibrate
    from rasc.sim.render import (
        CONTINUOUS,
        DEGRADATIONS,
        LENS_FIELDS,
        RenderOptions,
        render_in_memory,
    )

    r = task.render
    full = {k: r.get(k, p.default) for k, p in PARAMS.items() if p.kind == "render"}
    try:
        options = RenderOptions(
            poses_deg=poses_of(full),
            intrinsics_views=full["intrinsics_views"], distance=full["distance"],
            seed=task.seed, image_noise=full["image_noise"], blur=full["blur"],
            distortion=tuple(full["distortion"]), supersample=full["supersample"],
            **{k: full[k] for k in (*DEGRADATIONS, *CONTINUOUS, *LENS_FIELDS)})
        names = ({"poses_deg": f"positions_file {task.positions_from}"}
                 if task.positions_from else RENDER_NAMES)
        ds = render_in_memory(options, model_path=head_of(r, task.model_path), quiet=True,
                              units=unit_builds(r), board=target_of(full), names=names)
        doc = calibrate(ds, key=task.key, render=r, seed=task.seed,
                        dist_model=dist_model_of(full))
        return (doc, ds) if task.keep else doc
    except RascError as exc:     # name the cell's render parameters, not a CLI flag
        shown = r     # a positions file replaces the grid: named, the grid's keys left out
        if task.positions_from:
            shown = {k: v for k, v in r.items() if k not in ("layout", "positions",
                                                             "motion_deg")}
            shown["positions_file"] = task.positions_from
        what = ", ".join(f"{k} = {v!r}" for k, v in sorted(shown.items())
                         if k not in ("model", "urdf"))
        raise type(exc)(f"{task.where}: the dataset for {what}: "
                        f"{' '.join(str(exc).split())}") from None


def dist_model_of(full: dict) -> str | None:
    """The ``dist_model`` a cell's dataset is calibrated with: the spec's, or for ''
    the lens's own (None, ``CalibrationOptions``' default, for a pinhole; "fisheye" for
    a fisheye)."""
    if full["dist_model"]:
        return full["dist_model"]
    return "fisheye" if full["lens"] == "fisheye" else None


#: RenderOptions' fields have the spec's names; the positions are the spec's layout
RENDER_NAMES = {"poses_deg": "the positions (layout, positions, motion_deg)"}


def folder_task(task: FolderTask) -> dict:
    """Calibrate an existing dataset folder (``[fixed] dataset``) with the real pipeline;
    its ``ground_truth.json``, when present, is the reference (else the measured RASC
    solution, see :func:`rasc.datasets.calibration.calibration_document`)."""
    worker_environment()
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.vision.dataset import load_dataset

    folder = Path(task.folder)
    ds = load_dataset(folder)
    cal = calibrate_dataset(ds, CalibrationOptions(model="paper"))
    gt = folder / "ground_truth.json"
    truth = json.loads(gt.read_text()) if gt.is_file() else None
    doc = calibration_document(cal, ds.board, truth, key=task.key)
    return in_metres(doc, dataset_metres(folder))


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


def pose_task(task: PoseTask) -> dict:
    """``intrinsics_from = "dataset"``: render only the pose views of ``task.render``'s
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
    from rasc.sim.render import DEGRADATIONS, RenderOptions
    from rasc.vision.board import Board

    base, r = task.base, task.render
    full = {k: r.get(k, p.default) for k, p in PARAMS.items() if p.kind == "render"}
    poses = poses_of(full)
    scene, model_path, units, record = _pose_scene(task)
    board = Board(tuple(base["board"]["inner_corners"]), base["board"]["square_size"])
    options = RenderOptions(poses_deg=poses, distance=scene["target_distance"],
                            seed=scene["seed"], image_noise=scene["noise_sigma"] or 0.0,
                            blur=scene["blur_sigma"] or 0.0,
                            distortion=tuple(scene["dist"] or ()),
                            supersample=scene.get("supersample", 1),
                            **{k: scene[k] for k in DEGRADATIONS if k in scene}
                            ).validate(RENDER_NAMES)
    rng = np.random.default_rng(np.random.SeedSequence(
        [task.seed, POSE_RENDER_KEY, int(task.key, 16)]))
    images, T_true, X_sim = _render_pose_views(task, options, board, model_path, units,
                                               record, rng)
    eyes = {eye: _pose_eye(task, eye, data, images[eye], T_true[eye], X_sim[eye], board,
                           poses, full["motion_deg"])
            for eye, data in base["eyes"].items()}
    out = {"format": formats.DATASET_CALIBRATION.tag, "key": task.key, "render": r,
           "seed": task.seed, "intrinsics_of": task.base_key,
           "board": base["board"], "eyes": eyes}
    if record is not None:
        out["scene"] = record
    return out


def _pose_scene(task: PoseTask) -> tuple[dict, Any, Any, dict | None]:
    """:func:`pose_task`'s scene: (the render options as the ground truth records them,
    the model path, the units, the base's scene record or None)."""
    from rasc.sim.render import DEGRADATIONS

    base, where = task.base, task.where
    if "render" in base:                   # rendered by this study: its own parameters
        b = {k: base["render"].get(k, p.default) for k, p in PARAMS.items()
             if p.kind == "render"}
        scene = {"seed": base["seed"], "target_distance": b["distance"],
                 "noise_sigma": b["image_noise"], "blur_sigma": b["blur"],
                 "dist": list(b["distortion"]), "supersample": b["supersample"],
                 **{k: b[k] for k in DEGRADATIONS}}
        model_path = head_of(base["render"], task.model_path)
        units, record = unit_builds(base["render"]), None
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
        if scene.get("lens", "pinhole") != "pinhole" or scene.get("fov"):
            raise InputError(f"{where}: intrinsics_from = 'dataset': the dataset was "
                             "rendered through a lens (lens, fov), whose pose views are "
                             "not rendered again; give intrinsics_from = 'calibrate'")
        model_path, units = None, None
    return scene, model_path, units, record


def _render_pose_views(task: PoseTask, options, board, model_path, units,
                       record: dict | None, rng: np.random.Generator) -> tuple:
    """Render :func:`pose_task`'s pose views in the base's scene: per eye the images, the
    true ``T_cam_from_world`` of each, and the scene's ``T_cam_from_gaze``."""
    from rasc.sim.render import check_pose_views, distortion_of, view_image
    from rasc.sim.scene import StereoHeadSim, distortion_warp

    where = task.where
    dist, distorted = distortion_of(options)
    images: dict[str, list] = {eye: [] for eye in EYES}
    T_true: dict[str, list] = {eye: [] for eye in EYES}
    with StereoHeadSim(model_path, units=units) as sim:
        if sim.board != board:
            raise InputError(f"{where}: intrinsics_from = 'dataset': the scene's board "
                             f"{sim.board} is not the dataset's {board}")
        sim.set_target(sim.facing_target(options.distance))
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
        for pan, tilt in options.poses_deg:
            for eye in EYES:
                sim.set_angles(eye, np.radians(pan), np.radians(tilt))
            for eye in EYES:
                images[eye].append(view_image(sim, eye, warp, rng, options))
                T_true[eye].append(sim.T_cam_from_world(eye).tolist())
        X_sim = {eye: sim.T_cam_from_gaze(eye) for eye in EYES}
    return images, T_true, X_sim


def _pose_eye(task: PoseTask, eye: str, data: dict, images: list, T_true: list,
              X_sim: np.ndarray, board, poses, motion_deg: float) -> dict:
    """One eye of :func:`pose_task`'s document: its pose views detected with the
    pipeline's detector and posed with the base's intrinsics."""
    from rasc.head.pipeline import CalibrationOptions
    from rasc.vision.camera import detect_corners, estimate_extrinsics

    where = task.where
    X_true = np.asarray(data["T_cam_from_gaze_true"], float)
    if np.abs(X_sim - X_true).max() > SAME_SCENE_ATOL:
        raise InputError(f"{where}: intrinsics_from = 'dataset': the rendered {eye} "
                         "head's T_cam_from_gaze is not the dataset's truth")
    detector = CalibrationOptions().detector
    K, d = np.asarray(data["K"], float), np.asarray(data["dist"], float)
    files, corners, T_cw = [], [], []
    for k, image in enumerate(images):
        name = f"poses±{motion_deg:g}/{eye}_{k:02d}"
        c = detect_corners(image, board, method=detector)
        if c is None:
            raise DegenerateDataError(f"{where}: the pose view {name} (pan, tilt = "
                                      f"{poses[k][0]:g}, {poses[k][1]:g} deg): board "
                                      "not found")
        files.append(name)
        corners.append(np.asarray(c, float).tolist())
        T_cw.append(estimate_extrinsics(c, board, K, d)[0].tolist())
    return {"files": files, "pan_tilt_rad": np.radians(np.asarray(poses, float)).tolist(),
            "T_cam_from_world": T_cw, "corners": corners, "K": data["K"],
            "dist": data["dist"], "T_cam_from_gaze_true": data["T_cam_from_gaze_true"],
            "T_cam_from_world_true": T_true}


def cache_dir() -> Path | None:
    """Where rendered study datasets are cached between runs: ``study-datasets`` under
    :func:`rasc.io.cache_root` (``RASC_CACHE_DIR=none`` turns the cache off); entries are
    the dataset service's (:class:`rasc.datasets.CacheStore`), verified when read."""
    root = cache_root()
    return None if root is None else root / "study-datasets"


def cache_key(kind: str, task: RenderTask | PoseTask) -> str:
    """The cache key of a render (``kind`` "render") or pose-set (``kind`` "poses") task:
    the dataset service's key (:func:`rasc.datasets.cache_key`: the one code digest) of
    the task's dataset name (:func:`dataset_name`), render parameters (the model as its
    file's sha256), seed and, for a pose set, its base dataset's sha256."""
    from rasc.datasets import keys
    what = {"key": task.key, "render": task.render, "seed": task.seed}
    if kind == "poses":
        what["base"] = dataset_digest_of(task.base)
    return keys.cache_key(f"study-{kind}", what)


def dataset_digest_of(doc: dict) -> str:
    """The key of a given dataset document: sha256 of its JSON (20 hex digits)."""
    import hashlib
    return hashlib.sha256(dumps_json(doc).encode()).hexdigest()[:20]


def kept_folder(out: Path, key: str) -> Path:
    """Where a study keeps the dataset ``key`` on disk (``keep_datasets``): a dataset
    folder beside its calibration, ``datasets/<key>/``."""
    return out / "datasets" / key


def _kept(out: Path, key: str) -> bool:
    return (kept_folder(out, key) / "manifest.json").is_file()


def _found_datasets(out: Path, wanted, log: Callable[[str], None],
                    keep: bool = False) -> dict[str, dict]:
    """The dataset files of ``wanted`` keys already in ``out/datasets`` that are whole
    (:func:`check_calibration_document`, their key); a damaged one is left to be computed
    again, with a note. With ``keep`` (``keep_datasets``), one whose dataset folder is
    not there is rendered again (to be kept)."""
    found = {}
    for k in wanted:
        path = out / "datasets" / f"{k}.json"
        if not os.path.lexists(path) or keep and not _kept(out, k):
            continue
        try:
            doc = read_json_document(path, "study dataset")
            check_calibration_document(doc)
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
            log: Callable[[str], None] = print, keep: bool = False) -> dict[str, dict]:
    """Run dataset tasks, writing each result to ``out/datasets/<key>.json`` as it comes
    (``count["rendered"]`` counts them); with a ``cache`` folder, a task found there
    (verified: :class:`rasc.datasets.CacheStore`) is copied instead (``count["cached"]``)
    and a rendered one stored there. With ``keep`` (render tasks, ``keep_datasets``),
    each dataset not yet kept in the study folder (:func:`kept_folder`) is rendered, and
    written there by this process (atomically, :func:`rasc.vision.dataset.write_dataset`)
    when its task returns it. Returns the documents by key (kept in memory)."""
    from rasc.progress import progress

    store = CacheStore(folder=cache, label="rasc study", log=log) if cache is not None \
        else None
    names = [cache_key(kind, t) for t in tasks] if store is not None else []
    if keep:
        tasks = [t if _kept(out, t.key) else replace(t, keep=True) for t in tasks]
    todo, docs = [], {}
    for k, task in enumerate(tasks):
        doc = store.get_json(names[k], check_calibration_document) \
            if store is not None and not getattr(task, "keep", False) else None
        if doc is not None and doc.get("key") == task.key:
            write_json_atomic(out / "datasets" / f"{task.key}.json", doc)
            docs[task.key] = doc
            count["cached"] += 1
        else:
            todo.append(k)
    if not todo:
        return docs
    with progress(total=len(todo), desc=desc, quiet=quiet, unit="dataset") as bar:
        for i, doc in executor.map_unordered(fn, [tasks[k] for k in todo]):
            task = tasks[todo[i]]
            if isinstance(doc, tuple):           # keep_datasets: the dataset, to write
                from rasc.vision.dataset import write_dataset

                doc, dataset = doc
                (out / "datasets").mkdir(parents=True, exist_ok=True)
                write_dataset(dataset, kept_folder(out, task.key), flag="keep_datasets:")
                del dataset
            write_json_atomic(out / "datasets" / f"{task.key}.json", doc)
            docs[task.key] = doc
            if store is not None:
                store.put_json(names[todo[i]], doc)
            count["rendered"] += 1
            bar.update(1)
    return docs


#: the old names of the calibration document's functions (now the dataset service's)
dataset_document = calibration_document
_check_dataset_doc = check_calibration_document
_in_metres = in_metres


def _renamed(module: str, name: str):
    """A module's old public name (PEP 562 ``__getattr__``): the new object, with a
    DeprecationWarning at the line that used the old name."""
    if name == "dataset_key":
        import warnings

        warnings.warn(f"{module}.dataset_key is now {module}.dataset_name (the study's "
                      "name of a dataset, not a cache key: rasc.datasets.cache_key is "
                      "the one cache key); the old name goes in rasc 0.4",
                      DeprecationWarning, stacklevel=3)
        return dataset_name
    raise AttributeError(f"module {module!r} has no attribute {name!r}")


def __getattr__(name: str):
    return _renamed(__name__, name)
