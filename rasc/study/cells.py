"""A study's cells stage: every sample of one cell (:func:`cell_task`: corner noise,
eq. 13-14 pose noise, every method on the same noisy poses, scored against the truth),
and the cell files' check on resume (:func:`verified_cell`)."""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rasc.datasets.cache import EntryError, read_regular
from rasc.datasets.keys import CACHE_LIBRARIES, code_digest  # noqa: F401 (re-exported)
from rasc.errors import DegenerateDataError, RascError
from rasc.study.executors import worker_environment
from rasc.study.spec import (
    Cell,
)

#: what a method may raise that counts as its failure on a sample (not a crash):
#: the library's errors and numerical breakdowns
FAILURES = (RascError, ArithmeticError, ValueError, np.linalg.LinAlgError)


SAMPLE_COLUMNS = ("sample", "method", "status", "translation_mm", "rotation_deg",
                  "rotation_fro", "quality")


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


@dataclass(frozen=True)
class CellTask:
    """Every sample of one cell on one dataset document (what :func:`cell_task` runs)."""

    cell: Cell
    dataset: dict
    seed: int
    samples: int
    methods: tuple[str, ...]
    estimates: bool = False
    pose_errors: bool = False
    #: the time limit of one plugin call, s (None: rasc.guard's default)
    time_limit_s: float | None = None
    #: (deg, mm) beyond which an ok solve is "gross"; None: no limit
    gross: tuple[float | None, float | None] = (None, None)

    @classmethod
    def of(cls, task: CellTask | dict) -> CellTask:
        """A task given as a dataclass or as the dict of its fields."""
        return task if isinstance(task, cls) else cls(**task)


def cell_task(task: CellTask | dict) -> list[list]:
    """Every sample of one cell: ``[sample, method, status, errors..., quality]`` rows
    (and the estimate, :data:`ESTIMATE_COLUMNS`, with ``task.estimates``).

    A cell without sample-level noise (σ = 0 and no corner noise) solves once and repeats
    that row for every sample: its samples are the same pose set. The stages: the
    samples' pose sets (:func:`noisy_pose_sets`), every method on them, the rows
    (:func:`_cell_rows`)."""
    worker_environment()
    from rasc.geometry.kinematics import T_gaze_from_ptu

    task = CellTask.of(task)
    p = task.cell.params
    eye = task.dataset["eyes"][p["eye"]]
    pan_tilt = np.asarray(eye["pan_tilt_rad"], float)
    T_gp = T_gaze_from_ptu(pan_tilt[:, 0], pan_tilt[:, 1])
    T_true = np.asarray(eye["T_cam_from_gaze_true"], float)
    literal = p["noise_model"] == "literal"
    sets = noisy_pose_sets(task)
    scored = {m: _score_samples(m, sets, T_gp, T_true, literal, task.time_limit_s)
              for m in task.methods}
    gross = task.gross
    if gross != (None, None):
        scored = {m: [classify_gross(r, gross) for r in rs] for m, rs in scored.items()}
    pose_err = None
    if task.pose_errors:
        truth = eye.get("T_cam_from_world_true")
        pose_err = ([pose_error_rms(T, np.asarray(truth, float)) for T in sets]
                    if truth is not None else [[float("nan")] * 6] * len(sets))
    return _cell_rows(task, scored, pose_err, noisy=_noisy(p))


def _noisy(p: dict[str, Any]) -> bool:
    """Whether a cell's samples differ (pose noise or corner noise)."""
    return p["sigma_r"] > 0 or p["sigma_t_mm"] > 0 or p["corner_noise_px"] > 0


def noisy_pose_sets(task: CellTask) -> np.ndarray:
    """The pose sets ``T_cam_from_world`` (samples, views, 4, 4) the cell's methods
    solve: per sample, the dataset's poses measured again from its corners with corner
    noise (``corner_noise_px``), then eq. 13-14 pose noise on every view or on the home
    view only (``noise_on``); one set (the dataset's) for a cell without noise. Each
    sample draws from its own generator (:func:`sample_rng`)."""
    from rasc.handeye.noise import perturb_one_view, perturb_T_cam_from_world
    from rasc.vision.board import Board
    from rasc.vision.camera import estimate_extrinsics

    cell: Cell = task.cell
    p, data = cell.params, task.dataset
    eye = data["eyes"][p["eye"]]
    T_cw0 = np.asarray(eye["T_cam_from_world"], float)
    pan_tilt = np.asarray(eye["pan_tilt_rad"], float)
    pose_noise = p["sigma_r"] > 0 or p["sigma_t_mm"] > 0
    home = (home_view(pan_tilt, f"the {p['eye']} eye's dataset")
            if pose_noise and p.get("noise_on", "all") == "home" else None)
    if p["corner_noise_px"] > 0:
        board = Board(tuple(data["board"]["inner_corners"]), data["board"]["square_size"])
        corners = [np.asarray(c, float) for c in eye["corners"]]
        K, dist = np.asarray(eye["K"], float), np.asarray(eye["dist"], float)
        lens = eye.get("lens", "pinhole")
    sets = []
    for s in range(task.samples if _noisy(p) else 1):
        rng = sample_rng(task.seed, cell, s)
        T_cw = T_cw0
        if p["corner_noise_px"] > 0:
            T_cw = np.array([estimate_extrinsics(c + p["corner_noise_px"]
                                                 * rng.standard_normal(c.shape),
                                                 board, K, dist, lens)[0] for c in corners])
        if pose_noise:                                                # mm -> metres
            if home is None:
                T_cw = perturb_T_cam_from_world(T_cw, p["sigma_r"], p["sigma_t_mm"] / 1000.0,
                                                rng, p["noise_model"])
            else:
                T_cw = perturb_one_view(T_cw, home, p["sigma_r"], p["sigma_t_mm"] / 1000.0,
                                        rng, p["noise_model"])
        sets.append(T_cw)
    return np.array(sets)


def _cell_rows(task: CellTask, scored: dict[str, list], pose_err: list | None,
               noisy: bool) -> list[list]:
    """The cell's rows, sample by sample and method by method (a cell without noise
    repeats its one solve for every sample)."""
    rows = []
    for s in range(task.samples):
        for method in task.methods:
            *res, T = scored[method][s if noisy else 0]
            row = [s, method, *res]
            if task.estimates:
                row += ([*(1000.0 * T[:3, 3]), *T[:3, :3].ravel()] if T is not None
                        else [float("nan")] * len(ESTIMATE_COLUMNS))
            if pose_err is not None:
                row += pose_err[s if noisy else 0]
            rows.append(row)
    return rows


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
