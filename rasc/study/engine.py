"""Run a study: render (or reuse) each dataset it needs, draw every sample, solve with
every method, and write the tidy results.

In stages, each a module: the spec (:mod:`rasc.study.spec`), the task plan and the
study folder (here: :func:`run_study`), the datasets (:mod:`rasc.study.datasets`), the
cells (:mod:`rasc.study.cells`), the summary (:mod:`rasc.study.summary`) and the figures
(:mod:`rasc.study.figures`); tasks run on :mod:`rasc.study.executors`. Every name of
those stages is importable from here as before.

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
import json
import os
import shutil
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from rasc.datasets.cache import EntryError, read_regular
from rasc.datasets.keys import CACHE_LIBRARIES, code_digest  # noqa: F401 (re-exported)
from rasc.errors import InputError, RascError
from rasc.interrupt import Interrupted, forget_temporary, register_temporary
from rasc.io import (
    dumps_json,
    write_json_atomic,
    write_text_atomic,
)
from rasc.study.cells import (  # noqa: F401 (re-exported: rasc.study.engine's names)
    ESTIMATE_COLUMNS,
    FAILURES,
    MAX_CELL_BYTES,
    POSE_ERROR_COLUMNS,
    SAMPLE_COLUMNS,
    CellTask,
    _cell_path,
    _parse_cell,
    _score,
    _score_result,
    _score_samples,
    _scored,
    _solve,
    cell_task,
    classify_gross,
    home_view,
    pose_error_rms,
    sample_rng,
    score,
    verified_cell,
)
from rasc.study.datasets import (  # noqa: F401
    POSE_RENDER_KEY,
    RENDER_NAMES,
    SAME_SCENE_ATOL,
    FolderTask,
    PoseTask,
    RenderTask,
    _check_dataset_doc,
    _differs,
    _found_datasets,
    _in_metres,
    _render,
    _scene_record,
    cache_dir,
    cache_key,
    dataset_digest_of,
    dataset_document,
    dataset_name,
    folder_task,
    pose_task,
    render_task,
    same_poses,
    unit_builds,
)
from rasc.study.executors import Executor, WorkerCrashed, make_executor, option_names
from rasc.study.spec import (
    FORMAT,
    PARAMS,
    POSE_PARAMS,
    SUMMARY_TAIL,
    Cell,
    Spec,
    check_beside_dataset,
    poses_of,
)
from rasc.study.summary import (  # noqa: F401
    BOOTSTRAP_KEY,
    _samples_text,
    bootstrap_ci,
    csv_text,
    fmt,
    summarise,
)

#: what a study writes in its folder
OUTPUT_NAMES = ("study.json", "samples.csv", "summary.csv", "cells", "datasets", "figures")


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
    #: the text of samples.csv (kept in memory: callers need not read it back)
    samples_text: str = field(default="", repr=False)


def _manifest(spec: Spec, cells: list[Cell], dataset: str | None = None) -> dict:
    import rasc
    out = {"format": FORMAT, "spec_sha256": spec.digest, "spec": spec.to_dict(),
           "rasc_version": rasc.__version__,
           "cells": [{"index": c.index, "key": c.key, "axes": c.axes} for c in cells]}
    if dataset is not None:
        out["dataset"] = dataset
    return out


def prepare_folder(out: Path, spec: Spec, resume: bool, dataset: str | None = None,
                   names: dict[str, str] | None = None) -> None:
    """Check ``out`` before any work: new or empty (or, with ``resume``, a study of this
    very spec); never the spec itself or a folder holding it as an output name.
    ``names``: how messages name the options ``out`` and ``resume``
    (:func:`rasc.study.executors.option_names`)."""
    n = option_names(names)
    out = Path(out)
    manifest = out / "study.json"
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: {n['out']}: exists and is not a folder")
    if not out.exists():
        if not out.parent.is_dir():
            raise InputError(f"{out}: parent folder {out.parent} does not exist")
        if resume:
            raise InputError(f"{out}: {n['resume']}: no study to resume (the folder does "
                             "not exist)")
        return
    if resume:
        if not manifest.is_file():
            raise InputError(f"{out}: {n['resume']}: no study.json (not a study folder)")
        try:
            doc = json.loads(manifest.read_text())
            old, old_dataset = doc.get("spec_sha256"), doc.get("dataset")
        except (OSError, ValueError, AttributeError) as exc:
            raise InputError(f"{manifest}: unreadable study manifest ({exc})") from None
        if old == spec.digest and old_dataset != dataset:
            raise InputError(f"{out}: {n['resume']}: the folder holds this study on another "
                             "dataset; a study resumes only on the same dataset")
        if old != spec.digest:
            raise InputError(f"{out}: {n['resume']}: the folder holds a study of a different "
                             f"spec (sha256 {str(old)[:12]}, this one {spec.digest[:12]}); "
                             "a study resumes only the same spec")
        return
    if manifest.is_file():
        raise InputError(f"{out}: holds a study already; pass {n['resume']} to continue it, "
                         f"or choose another {n['out']}")
    if any(out.iterdir()):
        raise InputError(f"{out}: {n['out']}: exists and is not empty")


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
              pose_errors: bool = False, names: dict[str, str] | None = None
              ) -> StudyResult:
    """Run (or, with ``resume``, continue) ``spec`` into the folder ``out``.

    Parameters
    ----------
    dataset : dict, optional
        A calibrated dataset to run every cell on instead of rendering (as
        :func:`dataset_document` makes it, e.g. from the reproduction's default dataset);
        the spec may then have no render parameter (InputError). Its sha256 is recorded in
        ``study.json`` and ``resume`` continues only the same dataset.
    estimates : bool
        Add the estimate (:data:`ESTIMATE_COLUMNS`) to every row of ``samples.csv``.
    pose_errors : bool
        Add the sample's extrinsics error against the rendered truth
        (:data:`POSE_ERROR_COLUMNS`, empty for a dataset without one) to every row.
    figures : bool
        Draw ``figures/<axis>.png`` (callers that plot their own may skip them).
    names : dict, optional
        How messages name the options ``out``, ``resume``, ``workers`` and ``dask``
        (default: as here, :data:`rasc.study.executors.OPTION_NAMES`; ``rasc study``
        passes its flags).

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
        raise InputError(f"{out}: {option_names(names)['out']}: would overwrite the spec "
                         f"{spec.path}")
    cells = spec.cells()
    given = _given_dataset(spec, dataset)
    cache_dir()          # a bad RASC_CACHE_MAX_MB is refused before anything is made
    prepare_folder(out, spec, resume, given, names)
    created = _make_folder(out)
    with study_lock(out):
        if not created:
            prepare_folder(out, spec, resume, given, names)   # again, now that it is ours
        return _run_locked(spec, out, cells, given, created, workers=workers, dask=dask,
                           resume=resume, quiet=quiet, executor=executor, log=log,
                           dataset=dataset, estimates=estimates, figures=figures,
                           pose_errors=pose_errors, names=names)


def _given_dataset(spec: Spec, dataset: dict | None) -> str | None:
    """The identity of the dataset every cell runs on, when there is one: a calibrated
    dataset the caller gives (then the spec may name no dataset nor render parameter) or
    the spec's ``[fixed] dataset``; None when the study renders its own."""
    if dataset is not None:
        if spec.dataset_path() is not None:
            raise InputError(f"{spec.path}: fixed.dataset: the caller gives the dataset "
                             "already; leave it out of the spec")

        def fail(key: str, msg: str):
            raise InputError(f"{spec.path}: {key}: {msg}")
        check_beside_dataset(spec.fixed, spec.axes, fail, "the study runs on a given dataset")
        return dataset_digest_of(dataset)
    if spec.dataset_path() is not None:
        return spec.cells()[0].params["dataset"].removeprefix("sha256:")[:20]
    return None


def _model_file(spec: Spec, render: dict) -> str | None:
    """The file a render's ``model`` or ``urdf`` digest names (None: the package's head);
    :func:`rasc.study.datasets.head_of` makes a URDF's head of it in the worker."""
    digest = render.get("model") or render.get("urdf")
    return str(spec.model_path(digest)) if digest else None


def _positions_from(spec: Spec, render: dict) -> str:
    """The spec's ``positions_file`` whose positions a render's are ("" when they are the
    layout's grid), for its messages."""
    listed = render.get("positions_file")
    if not listed:
        return ""
    want = [[float(v) for v in p] for p in listed]
    return next((rel for rel, poses in spec.positions_files.items()
                 if [[float(v) for v in p] for p in poses] == want), "")


@dataclass
class _Run:
    """One locked run of a study: its stages, in order — :meth:`plan` (which dataset each
    cell needs), :meth:`datasets` (found, cached or computed), :meth:`pose_sets`
    (intrinsics_from = "dataset"), :meth:`cells`, :meth:`assemble` (samples.csv,
    summary.csv, figures). What a stage makes stays in memory for the next one."""

    spec: Spec
    out: Path
    cells_: list[Cell]
    given: str | None
    executor: Executor
    quiet: bool
    log: Callable[[str], None]
    header: tuple[str, ...]
    cache: Path | None = None
    #: the workers' temporary files (a render's images), made when a dataset is
    #: rendered, removed whatever happens
    scratch: str | None = None
    count: dict[str, int] = field(default_factory=lambda: {"rendered": 0, "cached": 0})
    #: the cell files' texts by cell index (verified or just computed)
    texts: dict[int, str] = field(default_factory=dict)
    cells_done: int = 0
    #: per cell index: (base dataset's name, its render parameters); the dataset each uses
    bases: dict[int, tuple[str, dict]] = field(default_factory=dict)
    keys: dict[int, str] = field(default_factory=dict)
    docs: dict[str, dict] = field(default_factory=dict)

    def plan(self) -> dict[str, dict]:
        """The datasets the cells need: the one given, or one per distinct set of render
        parameters (a cell with intrinsics_from = "dataset" first needs its base)."""
        spec = self.spec

        def base_of(c: Cell) -> tuple[str, dict]:
            r = c.render_params()
            if self.given is not None:
                return self.given, {}
            if c.params["intrinsics_from"] != "dataset":
                return dataset_name(r, spec.seed), r
            b = {k: v for k, v in r.items() if k != "intrinsics_from"}
            b.update({k: PARAMS[k].default for k in POSE_PARAMS})
            return dataset_name(b, spec.seed), b
        self.bases = {c.index: base_of(c) for c in self.cells_}
        wanted: dict[str, dict] = {}
        for k, r in self.bases.values():
            wanted.setdefault(k, r)
        return wanted

    def datasets(self, wanted: dict[str, dict], dataset: dict | None) -> None:
        spec, out = self.spec, self.out
        if dataset is not None:
            text = dumps_json(dataset).encode()
            for k in wanted:
                path = out / "datasets" / f"{k}.json"
                try:
                    same = read_regular(path, len(text) + 1) == text
                except EntryError:
                    same = False
                if not same:
                    write_json_atomic(path, dataset)
                self.docs[k] = dataset
        else:
            self.docs.update(_found_datasets(out, wanted, self.log,
                                             keep=spec.keep_datasets))
        missing = [k for k in wanted if k not in self.docs]
        if spec.dataset_path() is not None:
            fn, tasks = folder_task, [FolderTask(k, str(spec.dataset_path()))
                                      for k in missing]
        else:
            if missing:
                self.scratch = register_temporary(tempfile.mkdtemp(prefix="rasc-study-"))
            fn, tasks = render_task, [
                RenderTask(k, wanted[k], spec.seed, where=str(spec.path), scratch=self.scratch,
                           model_path=_model_file(spec, wanted[k]),
                           positions_from=_positions_from(spec, wanted[k]))
                for k in missing]
        self.docs.update(_render(self.executor, fn, tasks, out, self.quiet, "render datasets",
                                 self.count, self.cache if fn is render_task else None,
                                 "render", self.log,
                                 keep=spec.keep_datasets and fn is render_task))

    def pose_sets(self) -> None:
        """Pose sets rendered in a base's scene with its intrinsics."""
        spec, poses = self.spec, {}
        for c in self.cells_:
            base_key, base_r = self.bases[c.index]
            r = c.render_params()
            if c.params["intrinsics_from"] != "dataset":
                self.keys[c.index] = base_key
                continue
            grid = poses_of(c.params)
            if same_poses(self.docs[base_key], grid):
                self.keys[c.index] = base_key               # the base's own pose set
                continue
            k = dataset_name({**r, "intrinsics_of": base_key}, spec.seed)
            self.keys[c.index] = k
            poses.setdefault(k, PoseTask(k, base_key, r, spec.seed, str(spec.path),
                                         model_path=_model_file(spec, base_r)))
        self.docs.update(_found_datasets(self.out, poses, self.log))
        tasks = [replace(poses[k], base=self.docs[poses[k].base_key])
                 for k in sorted(poses) if k not in self.docs]
        self.docs.update(_render(self.executor, pose_task, tasks, self.out, self.quiet,
                                 "render pose sets", self.count, self.cache, "poses",
                                 self.log))

    def cells(self, estimates: bool, pose_errors: bool) -> None:
        """Every cell: a cell file found is used only when it is whole (verified_cell)."""
        from rasc.progress import progress

        spec, cells = self.spec, self.cells_
        for c in cells:
            text, why = verified_cell(_cell_path(self.out, c), self.header, spec.samples,
                                      spec.methods)
            if text is not None:
                self.texts[c.index] = text
            elif why is not None:
                self.log(f"rasc study: note: {_cell_path(self.out, c)} is incomplete or "
                         f"damaged ({why}); computing the cell again")
        todo = [c for c in cells if c.index not in self.texts]
        tasks = [CellTask(c, self.docs[self.keys[c.index]], spec.seed, spec.samples,
                          spec.methods, estimates=estimates, pose_errors=pose_errors,
                          time_limit_s=spec.time_limit_s,
                          gross=(spec.gross_rotation_deg, spec.gross_translation_mm))
                 for c in todo]
        with progress(total=len(cells), desc="cells", quiet=self.quiet, unit="cell") as bar:
            bar.update(len(cells) - len(todo))
            try:
                for i, rows in self.executor.map_unordered(cell_task, tasks):
                    text = csv_text(self.header, rows)
                    write_text_atomic(_cell_path(self.out, todo[i]), text)
                    self.texts[todo[i].index] = text
                    self.cells_done += 1
                    bar.update(1)
            except WorkerCrashed as exc:
                plugins = _plugins(spec.methods)
                raise WorkerCrashed(
                    f"{exc}; " + (f"the plugin method(s) {', '.join(plugins)} may have "
                                  "ended it (a crash in native code, or an exit rasc.guard "
                                  "cannot stop); run with one worker to see which"
                                  if plugins else "no plugin method was running")) from None

    def assemble(self, figures: bool) -> StudyResult:
        """The tidy samples, the summary and the figures, from the cells' texts."""
        spec, cells, out = self.spec, self.cells_, self.out
        rows_by_cell = {c.index: _parse_cell(self.texts[c.index]) for c in cells}
        axes = list(spec.axes)
        samples_text = _samples_text(cells, axes, self.header, self.texts)
        write_text_atomic(out / "samples.csv", samples_text)
        summary = summarise(spec, cells, rows_by_cell)
        write_text_atomic(out / "summary.csv",
                          csv_text(("cell", *axes, *SUMMARY_TAIL), summary))
        files = []
        if figures:
            from rasc.study.figures import plot_study
            files = plot_study(spec, summary, out / "figures")
        if self.count["cached"] and not self.quiet:
            self.log(f"rasc study: {self.count['cached']} dataset(s) copied from the cache "
                     f"{self.cache} (same render parameters, seed and rasc; "
                     "RASC_CACHE_DIR=none renders afresh)")
        return StudyResult(out, len(cells), self.cells_done, self.count["rendered"],
                           out / "samples.csv", out / "summary.csv", files,
                           self.count["cached"], samples_text)


def _run_locked(spec: Spec, out: Path, cells: list[Cell], given: str | None, created: bool,
                *, workers, dask, resume, quiet, executor, log, dataset, estimates, figures,
                pose_errors, names=None) -> StudyResult:
    """:class:`_Run`'s stages in the locked folder ``out``; the clean-up after bad input
    found late and after an interrupt."""
    owned = executor is None
    try:
        executor = executor or make_executor(workers, dask, names)
    except BaseException:
        if created:
            shutil.rmtree(out, ignore_errors=True)
        raise
    header = (SAMPLE_COLUMNS + (ESTIMATE_COLUMNS if estimates else ())
              + (POSE_ERROR_COLUMNS if pose_errors else ()))
    run = _Run(spec, out, cells, given, executor, quiet, log, header, cache_dir())
    try:
        for sub in ("cells", "datasets"):
            (out / sub).mkdir(exist_ok=True)
        write_json_atomic(out / "study.json", _manifest(spec, cells, given))
        run.datasets(run.plan(), dataset)
        run.pose_sets()
        run.cells(estimates, pose_errors)
    except RascError:
        # bad input found only now (a dataset that cannot be rendered or calibrated, a
        # scene that cannot be rendered again): a folder this run created is removed
        # unless a cell has finished (its datasets alone are no result)
        if created and run.cells_done == 0:
            shutil.rmtree(out, ignore_errors=True)
        raise
    except KeyboardInterrupt:
        if owned:
            with contextlib.suppress(Exception):
                executor.abort()
        kept = len(list((out / "datasets").glob("*.json"))) if (out / "datasets").is_dir() else 0
        raise Interrupted(
            f"kept {len(run.texts)} of {len(cells)} finished cells and {kept} dataset(s) in "
            f"{out}; no samples.csv, summary.csv or figures written; continue with "
            f"{option_names(names)['resume']}") from None
    finally:
        if owned:
            with contextlib.suppress(Exception):
                executor.close()
        if run.scratch is not None:
            forget_temporary(run.scratch)
    return run.assemble(figures)


def _plugins(methods) -> list[str]:
    """The names among ``methods`` that are plugins (not built in)."""
    from rasc.handeye.methods import get_method
    out = []
    for m in methods:
        with contextlib.suppress(Exception):
            if not get_method(m).builtin:
                out.append(m)
    return out


__all__ = ["run_study", "StudyResult", "summarise", "cell_task", "render_task", "PARAMS",
           "dumps_json", "dataset_document", "unit_builds", "ESTIMATE_COLUMNS",
           "SAMPLE_COLUMNS", "POSE_ERROR_COLUMNS", "pose_task", "pose_error_rms"]


def __getattr__(name: str):
    from rasc.study.datasets import _renamed

    return _renamed(__name__, name)
