"""Shared harness for the paper experiments: arguments, seeding, workers, progress, output.

Determinism: every Monte-Carlo task gets its own generator spawned from
``numpy.random.SeedSequence(seed)`` by task index, and tasks are fixed independent of
the number of workers (the worker count only decides which process runs a task), so
results are identical for any ``--workers``. Floats are written with ``repr`` (shortest
round-trip form), so the same numbers give the same bytes.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import os
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rasc import formats
from rasc.datasets import CacheStore
from rasc.errors import InputError
from rasc.io import (
    dumps_json,
    module_files,
    prune_cache,
    read_json_document,
    touch_cache_entry,
    tree_digest,
    write_json_atomic,
    write_text_atomic,
)
from rasc.progress import progress
from rasc.study.figures import save_figure  # noqa: F401  (the experiments' figure saver)
from rasc.vision.dataset import load_dataset

REPO = Path(__file__).resolve().parents[1]


def parse_args(doc: str, argv: Sequence[str] | None = None,
               extra: Callable[[argparse.ArgumentParser], None] | None = None
               ) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=doc.strip().splitlines()[0])
    parser.add_argument("--seed", type=int, default=0, help="master seed (default 0)")
    parser.add_argument("--quick", action="store_true",
                        help="reduced protocol for tests (fewer samples and levels)")
    parser.add_argument("--out", type=Path, default=REPO / "out",
                        help="output folder (default ./out)")
    parser.add_argument("--workers", type=int, default=default_workers(),
                        help="processes for Monte-Carlo samples (default: all cores)")
    if extra is not None:
        extra(parser)
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error("--workers must be at least 1")
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
               else (os.cpu_count() or 1))


def spawn_rngs(seed: int, n: int, *key: int) -> list[np.random.Generator]:
    """``n`` independent generators for task ``key`` under master ``seed``."""
    ss = np.random.SeedSequence([seed, *key])
    return [np.random.default_rng(child) for child in ss.spawn(n)]


def run_tasks(fn: Callable[[Any], Any], tasks: Sequence[Any], workers: int,
              label: str = "") -> list[Any]:
    """Map ``fn`` over ``tasks`` (in order), in ``workers`` processes, with progress: on
    the study engine's executors (:func:`rasc.study.executors.make_executor`; an
    interrupt stops every worker at once)."""
    from rasc.study.executors import make_executor

    results: list[Any] = [None] * len(tasks)
    with progress(total=len(tasks), desc=label, quiet=not label) as bar, \
            make_executor(workers if len(tasks) > 1 else 1) as executor:
        for k, result in executor.map_unordered(fn, tasks):
            results[k] = result
            bar.update(1)
    return results


def fmt(x: Any) -> str:
    """An experiment's CSV field: floats as ``repr`` (NaN as ``nan``), the rest as str."""
    if isinstance(x, float | np.floating):
        return repr(float(x))
    return str(x)


def write_csv(path: Path, header: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
    """The study engine's CSV writer (:func:`rasc.study.engine.csv_text`) with the
    experiments' field format (:func:`fmt`), written atomically."""
    from rasc.study.engine import csv_text
    write_text_atomic(path, csv_text(header, rows, field=fmt))


def read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_json(path: Path, obj: Any) -> None:
    write_json_atomic(path, obj)


def stage(label: str):
    """Context manager that prints ``label`` and its wall time to stderr."""
    class _Stage:
        def __enter__(self):
            self.t0 = time.perf_counter()
            print(f"== {label}", file=sys.stderr, flush=True)
            return self

        def __exit__(self, *exc):
            self.seconds = time.perf_counter() - self.t0
            print(f"== {label}: {self.seconds:.1f} s", file=sys.stderr, flush=True)
            return False
    return _Stage()


# ----------------------------------------------------------------------- shared context

#: the paper's eq. 13–14 noise levels (docs/METHOD.md §8): (σ_r rad, σ_t mm)
PAPER_LEVELS = tuple((0.005 * k, 1.0 * k) for k in range(1, 9))


#: the modules that render a dataset (with every rasc module they import: see
#: :func:`renderer_digest`)
RENDERER_MODULES = ("rasc.sim.render", "rasc.sim.scene", "rasc.sim.synthetic", "rasc.sim.units",
                    "rasc.vision.board", "rasc.vision.camera")


def renderer_digest(root: Path | None = None) -> str:
    """sha256 over the code and models that make a rendered dataset's bytes: the modules
    of :data:`RENDERER_MODULES` and every rasc module they import, transitively
    (:func:`rasc.io.module_files`: the kinematics that pose the units, the lens model
    that distorts, the manifest's writer, ...), and the MJCF models, of the package folder
    ``root`` (default: the imported rasc's). A list of files kept by hand missed
    ``camera.py``'s PNG encoder once, and later every module outside ``rasc/sim``."""
    if root is None:
        import rasc
        root = Path(rasc.__file__).parent
    import hashlib

    from rasc.sim import models_dir
    models = models_dir(root)
    return hashlib.sha256((tree_digest(root, module_files(root, RENDERER_MODULES))
                           + tree_digest(models, models.rglob("*"))).encode()).hexdigest()


def dataset_store() -> CacheStore:
    """The dataset service's store of rendered dataset folders (``rendered`` under the
    cache root; shared with rasc.testing: the same options give the same entry)."""
    return CacheStore("rendered", label="reproduce")


#: the format of a cached calibration (bump it when the entry's layout changes)
CALIBRATION_CACHE_FORMAT = formats.REPRODUCE_CALIBRATION.tag


def calibration_key(dataset: Path) -> dict:
    """What the default options' calibration of ``dataset`` depends on: the dataset's
    content (sha256 of every file in it), the code that computes it (the dataset
    service's one code digest, :func:`rasc.datasets.code_digest`) and Python."""
    import platform

    from rasc.datasets import code_digest
    return {"format": CALIBRATION_CACHE_FORMAT,
            "dataset_sha256": tree_digest(dataset, Path(dataset).rglob("*")),
            "code_sha256": code_digest(),
            "libraries": {"python": platform.python_version(), "machine": platform.machine()}}


def calibration_cache(key: dict) -> Path | None:
    """Where the calibration with ``key`` (:func:`calibration_key`) is cached (None: the
    cache is off): the dataset service's entry (:class:`rasc.datasets.CacheStore`,
    verified by its content's sha256) in ``reproduce-calibrations``, named by the one
    cache key of ``key``."""
    from rasc.datasets import cache_key
    return CacheStore("reproduce-calibrations").path(cache_key("calibration", key))


def _check_private(path: Path) -> None:
    """Refuse (ValueError) a cache entry that someone else could have written: unpickling
    runs code, so the entry and its folder must belong to this user and be writable by
    nobody else."""
    import stat

    if not hasattr(os, "getuid"):
        return
    for where in (path, path.parent):
        st = where.stat()
        if st.st_uid != os.getuid():
            raise ValueError(f"{where} belongs to user {st.st_uid}, not to this user "
                             f"({os.getuid()}); not unpickled")
        if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            raise ValueError(f"{where} is writable by others "
                             f"(mode {stat.filemode(st.st_mode)}); not unpickled")


def load_cached_calibration(path: Path, key: dict):
    """The calibration cached in ``path`` if it was stored under exactly ``key``, else
    None (missing: silently; unreadable, corrupt or another key: with a note on stderr,
    and the caller computes it afresh)."""
    import pickle

    from rasc.datasets.cache import read_regular, unpack

    if not os.path.lexists(path):
        return None
    try:
        _check_private(path)
        entry = pickle.loads(unpack(read_regular(path, 2**30) or b""))
        if not isinstance(entry, dict) or entry.get("key") != key:
            raise ValueError("stored under another key")
        from rasc.head.pipeline import Calibration
        if not isinstance(entry.get("calibration"), Calibration):
            raise ValueError("no calibration in it")
        touch_cache_entry(path)                       # used: the last to be pruned
        return entry["calibration"]
    except Exception as exc:   # noqa: BLE001  (any unreadable entry is only a cache miss)
        print(f"reproduce: note: ignored the cached calibration {path} "
              f"({type(exc).__name__}: {' '.join(str(exc).split())[:200]}); "
              "calibrating afresh", file=sys.stderr)
        return None


def store_calibration(path: Path, key: dict, cal) -> None:
    """Cache ``cal`` under ``key`` in ``path``, atomically (best effort: a note on
    stderr if it cannot be written)."""
    import pickle

    from rasc.datasets.cache import pack
    from rasc.io import write_bytes_atomic
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(path, pack(pickle.dumps({"key": key, "calibration": cal},
                                                   protocol=pickle.HIGHEST_PROTOCOL)))
        prune_cache(path.parent, keep=path)
    except OSError as exc:
        print(f"reproduce: note: could not cache the calibration in {path} ({exc})",
              file=sys.stderr)


#: staging folders of unfinished experiments (reproduce.py removes them on an interrupt)
PARTIAL_PREFIX = ".partial-"
#: the default dataset's record of the options it was rendered with
DATASET_OPTIONS = "render_options.json"


class Context:
    """What every experiment shares: arguments, and the default dataset rendered and
    calibrated once (``out/data/``) through the real pipeline.

    ``ctx.dataset_dir()`` renders the default dataset (seeded by ``--seed``) on first
    use; ``ctx.calibration()`` runs ``rasc.head.pipeline.calibrate_dataset`` on it once
    (or reads it from the cache, :func:`calibration_cache`, keyed by the dataset's bytes
    and the calibration code) and writes ``out/data/calibration.json``; ``ctx.truth()``
    is its ``ground_truth.json``.
    Experiments write into ``ctx.dir(name)`` and return a :class:`Section` for the report.
    """

    def __init__(self, args: argparse.Namespace) -> None:
        self.seed: int = args.seed
        self.quick: bool = args.quick
        self.out: Path = Path(args.out)
        self.workers: int = args.workers
        self._calibration = None
        self._truth = None
        self._study_dataset = None
        #: reproduce.py sets this: experiments then write into ``.partial-<name>`` and
        #: :meth:`commit` renames the folder when the experiment has finished
        self.staging = False
        #: E3 may read E1's raw samples from ``out/e1`` (False: it recomputes them, the
        #: same numbers; reproduce.py's parallel run, where E1 may be writing meanwhile)
        self.reuse_e1 = True

    @classmethod
    def from_argv(cls, doc: str, argv: Sequence[str] | None = None) -> Context:
        return cls(parse_args(doc, argv))

    def dir(self, name: str) -> Path:
        """The folder experiment ``name`` writes into (its staging folder when staging)."""
        path = self.out / (f"{PARTIAL_PREFIX}{name}" if self.staging else name)
        path.mkdir(parents=True, exist_ok=True)
        return path

    def commit(self, name: str) -> None:
        """Staging: replace ``out/name`` by the finished ``out/.partial-name``."""
        import shutil
        final, partial = self.out / name, self.out / f"{PARTIAL_PREFIX}{name}"
        if partial.is_dir():
            if final.is_dir() and not final.is_symlink():
                shutil.rmtree(final)
            partial.replace(final)

    def dataset_options(self) -> dict:
        """What the default dataset depends on (recorded beside it, compared on reuse):
        the render options (seed included), the rasc version, the sha256 of the renderer's
        code and models, and the versions of the libraries that draw and encode it."""
        from dataclasses import asdict

        import cv2
        import mujoco

        import rasc
        from rasc.sim.render import RenderOptions
        return json.loads(dumps_json({"format": formats.REPRODUCE_DATASET.tag,
                                      "rasc_version": rasc.__version__,
                                      "renderer_sha256": renderer_digest(),
                                      "libraries": {"numpy": np.__version__,
                                                    "mujoco": mujoco.__version__,
                                                    "opencv": cv2.__version__},
                                      "render_options": asdict(RenderOptions(seed=self.seed))}))

    def dataset_dir(self) -> Path:
        """``out/data/dataset``, rendered unless it exists with exactly the options it
        needs (``render_options.json`` inside it: seed, render options, rasc version).
        A dataset rendered with other options (another ``--seed``, another rasc) is
        rendered afresh, with a line on stderr; rendering happens in a temporary folder
        renamed when complete, so an interrupted render leaves nothing half-made."""
        import shutil
        import tempfile

        from rasc.sim.render import RenderOptions, render_dataset

        path = self.out / "data" / "dataset"
        record = path / DATASET_OPTIONS
        want = self.dataset_options()
        if (path / "manifest.json").is_file():
            try:
                have = json.loads(record.read_text())
            except (OSError, ValueError):
                have = None
            if have == want:
                return path
            seed = (have or {}).get("render_options", {}).get("seed", "unknown")
            print(f"reproduce: {path} was rendered with other options (seed {seed}, or "
                  "another rasc version or render options); rendering it afresh",
                  file=sys.stderr)
        path.parent.mkdir(parents=True, exist_ok=True)
        from rasc.datasets.render import render_key
        store, options = dataset_store(), RenderOptions(seed=self.seed)
        key = render_key(options)
        tmp = Path(tempfile.mkdtemp(prefix=".dataset.", dir=path.parent))
        try:
            cached = store.get_tree(key)
            if cached is not None:
                shutil.copytree(cached, tmp / "dataset")
                print(f"reproduce: the default dataset copied from the cache {cached} "
                      "(same options; RASC_CACHE_DIR=none renders it afresh)", file=sys.stderr)
            else:
                with stage("render the default dataset (intrinsics views + nine poses, "
                           "both eyes)"):
                    render_dataset(tmp / "dataset", options, quiet=True)
                store.put_tree(key, tmp / "dataset")
            write_json(tmp / "dataset" / DATASET_OPTIONS, want)
            if path.is_symlink() or path.is_file():
                path.unlink()
            elif path.exists():
                shutil.rmtree(path)
            (tmp / "dataset").replace(path)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        return path

    def calibration(self):
        """The pipeline's calibration of the default dataset (rasc.head.pipeline.Calibration)."""
        if self._calibration is None:
            from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
            from rasc.vision.dataset import load_dataset

            folder = self.dataset_dir()
            key = calibration_key(folder)
            cache = calibration_cache(key)
            cal = None if cache is None else load_cached_calibration(cache, key)
            if cal is not None:
                print(f"reproduce: the default dataset's calibration read from the cache "
                      f"{cache} (same dataset bytes, same calibration code; "
                      "RASC_CACHE_DIR=none calibrates afresh)", file=sys.stderr)
            else:
                ds = load_dataset(folder)
                with stage("calibrate the default dataset (detection, intrinsics, "
                           "extrinsics, RASC, loop closure)"):
                    cal = calibrate_dataset(ds, CalibrationOptions(model="paper"))
                if cache is not None:
                    store_calibration(cache, key, cal)
            self._calibration = cal
            doc = self._calibration.to_dict()
            doc.pop("timings_s", None)  # wall times are not results: keep files identical
            write_json(self.out / "data" / "calibration.json", doc)
        return self._calibration

    def study_dataset(self) -> dict:
        """The default dataset as the study engine takes it (``rasc.study.engine
        .dataset_document``): the pipeline's poses, kept pose corners (``EyeResult.corners``)
        and intrinsics from :meth:`calibration`, the truth from :meth:`truth`. Made once."""
        if self._study_dataset is None:
            from rasc.study.engine import dataset_document
            board = load_dataset(self.dataset_dir()).board
            self._study_dataset = dataset_document(self.calibration(), board, self.truth())
        return self._study_dataset

    def truth(self) -> dict:
        if self._truth is None:
            self._truth = read_json_document(self.dataset_dir() / "ground_truth.json",
                                             "ground truth")
        return self._truth


def run_experiment(job: tuple[Context, str]) -> tuple[str, Section, float]:
    """One experiment in a worker process of reproduce.py: ``(module, section, seconds)``.

    The context arrives pickled with the default dataset's calibration, so nothing is
    computed twice; its ``workers`` is 1 (the experiments themselves run in parallel)."""
    import importlib
    ctx, name = job
    module = importlib.import_module(f"experiments.{name}")
    t0 = time.perf_counter()
    section = module.run(ctx)
    return name, section, time.perf_counter() - t0


def script_main(run: Callable[[Context], Section], doc: str,
                argv: Sequence[str] | None = None) -> int:
    """What every experiment script's ``main`` does: arguments → ``run`` → its section
    (status 0). Interrupted (Ctrl-C, or SIGTERM): one line on stderr saying what is kept
    (every file is written whole, so the files already written are complete; a study's
    finished cells are reused by the next run), status 130."""
    from rasc.interrupt import received, signals_as_interrupt

    ctx = Context.from_argv(doc, argv)
    module = getattr(run, "__module__", "experiment").rsplit(".", 1)[-1]
    if module == "__main__":                     # python -m experiments.<name>
        module = Path(sys.argv[0]).stem
    try:
        with signals_as_interrupt():
            section = run(ctx)
            if received():    # a library that was loading swallowed the KeyboardInterrupt
                raise KeyboardInterrupt
    except KeyboardInterrupt:
        print(f"{module}: interrupted: kept the files already written under {ctx.out} (each "
              "written whole: nothing half-written is left); a study's finished cells are "
              "reused by the next run; no section printed", file=sys.stderr)
        return 130
    print(section.markdown)
    return 0


class Section:
    """One experiment's part of REPORT.md: markdown text plus the files it made."""

    def __init__(self, key: str, title: str, markdown: str, files: Sequence[Path] = (),
                 summary: dict | None = None) -> None:
        self.key, self.title, self.markdown = key, title, markdown
        self.files = list(files)
        self.summary = summary or {}


def md_table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """A markdown table; floats as given (format them before)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(v) for v in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


# ===================================================== experiments as studies

#: the experiments' study specs (TOML, read by rasc.study.spec.load_spec)
SPECS = Path(__file__).resolve().parent / "specs"


def experiment_spec(ctx: Context, name: str):
    """``experiments/specs/<name>.toml`` at ``ctx.seed``, narrowed by its ``[quick]``
    table under ``--quick`` (the reduced protocol for tests)."""
    from dataclasses import replace

    from rasc.study.spec import load_spec
    return replace(load_spec(SPECS / f"{name}.toml", quick=ctx.quick), seed=ctx.seed)


def run_spec(ctx: Context, name: str, folder: Path, *, estimates: bool = False,
             pose_errors: bool = False):
    """Run spec ``name`` on the default dataset (:meth:`Context.study_dataset`, never
    rendered again) into ``folder/<name>`` with ``ctx.workers`` processes; finished cells
    of an earlier run of the same spec on the same dataset are reused (``--resume``),
    anything else there is replaced. Returns ``(spec, rows)``: the spec and the tidy
    samples (dicts of ``samples.csv``). ``estimates``, ``pose_errors``: the extra columns
    of :func:`rasc.study.run_study`."""
    import shutil

    from rasc.study import run_study

    spec = experiment_spec(ctx, name)
    out = folder / name
    data = ctx.study_dataset()
    resume = (out / "study.json").is_file()
    try:
        result = run_study(spec, out, workers=ctx.workers, resume=resume, quiet=True,
                           dataset=data, estimates=estimates, figures=False,
                           pose_errors=pose_errors)
    except InputError:
        if not resume:
            raise
        shutil.rmtree(out)                  # another spec or dataset: start afresh
        result = run_study(spec, out, workers=ctx.workers, quiet=True, dataset=data,
                           estimates=estimates, figures=False, pose_errors=pose_errors)
    # the tidy samples as the study made them (not read back from samples.csv)
    return spec, list(csv.DictReader(io.StringIO(result.samples_text)))


def noise_rows(spec, rows: list[dict], one_noise_free: bool = True,
               estimates: bool = True) -> list[list]:
    """The tidy samples of a pose-noise study in the E1 layout (:data:`HEADER`, the
    study's column names), in the study's order: eye, noise_model, noise_level (1 when σ
    is given directly), σ_r, σ_t mm, sample, method, status, errors, quality, estimate.
    With ``one_noise_free`` a cell without noise keeps only sample 0 (its samples are the
    same pose set, solved once). Without ``estimates`` (a study run without them) the
    estimate columns are empty."""
    cells = spec.cells()
    out = []
    for r in rows:
        p = cells[int(r["cell"])].params
        if one_noise_free and p["sigma_r"] == 0 and p["sigma_t_mm"] == 0 and r["sample"] != "0":
            continue
        level = p["noise_level"] if p["noise_level"] is not None else 1
        status = r["status"]
        nums = ([float(r[k]) for k in ERROR_COLS]
                + ([float(r[k]) for k in ("t_x_mm", "t_y_mm", "t_z_mm", *R_COLS)]
                   if estimates else [""] * 12)
                if status == "ok" else [""] * (len(HEADER) - 8))
        out.append([p["eye"], p["noise_model"], level, p["sigma_r"], p["sigma_t_mm"],
                    int(r["sample"]), r["method"], status, *nums])
    return out


# ===================================================== pose-level noise (E1; E2, E3 use it)

#: the variant of the main figures: the paper printed the literal form (eq. 13)
MAIN_VARIANT = "literal"
#: the paper's two methods (E1's figures, E2)
METHOD_NAMES = ("rasc", "li")

RAW_CSV = "noise_samples.csv"
R_COLS = tuple(f"R_{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
#: the errors of a sample, in the raw rows' order (the study's column names)
ERROR_COLS = ("translation_mm", "rotation_fro", "rotation_deg", "quality")
#: the raw rows of E1 and E2 (:func:`noise_rows`): one per sample and method; the
#: study's column names (rasc.study's samples.csv: its axes, SAMPLE_COLUMNS,
#: ESTIMATE_COLUMNS)
HEADER = ("eye", "noise_model", "noise_level", "sigma_r", "sigma_t_mm", "sample", "method",
          "status", *ERROR_COLS, "t_x_mm", "t_y_mm", "t_z_mm", *R_COLS)


def mean_std(values) -> tuple[float, float]:
    """Mean and sample standard deviation (ddof 1; 0 for one value; NaN for none)."""
    v = np.asarray([float(x) for x in values], dtype=float)
    if v.size == 0:
        return float("nan"), float("nan")
    return float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else 0.0
