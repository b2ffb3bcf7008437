"""Reproduce Neubert & Ferrier (ICRA 2002) end to end: one command, one report.

    python -m experiments.reproduce [--quick] [--out DIR] [--workers N] [--seed S]

Renders the default dataset from the MuJoCo head, calibrates it through the real
pipeline (detection → intrinsics → extrinsics → RASC → loop closure), runs every
experiment of docs/METHOD.md §9 (E1–E5) and the extras (E6–E12), and writes
``DIR/REPORT.md`` with each figure (PNG and SVG) and table beside the paper's values,
the protocol parameters, the seed, the software versions and the wall time of every
stage. Raw results (CSV/JSON)
are byte-identical for the same seed, whatever ``--workers``.

``--quick`` is the reduced protocol, for tests (each module's docstring says what it
keeps; E4 and E5 then save their figures as PNG only). With ``--workers N`` (N > 1) the
experiments run on rasc.study's process pool (``rasc.study.executors``): N processes
forked from a forkserver that has imported the libraries and the experiment modules once
(``experiments._warm``); the pool is built, and E7 (which needs neither the default
dataset nor its calibration) started, while this process renders and calibrates the
default dataset.

Reuse: ``DIR/data/dataset`` is reused only when its ``render_options.json`` matches this
run exactly (seed, render options, rasc version); otherwise it is rendered afresh (so
``--seed 1`` into a seed-0 folder re-renders, and says so). Every experiment writes into
``DIR/.partial-<name>`` and the folder is renamed to ``DIR/<name>`` when the experiment
has finished. An interrupt (Ctrl-C, SIGTERM) removes the unfinished experiment's folder,
keeps the finished ones, writes no REPORT.md (a report of an earlier run is removed when
a run starts), says on stderr what it kept and removed, and exits 130.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import platform
import shutil
import sys
import time
from typing import TYPE_CHECKING

# light imports only at the top: the pool's forkserver is started (start_forkserver)
# before this process imports numpy, OpenCV or matplotlib, so that its warm-up (about 2 s
# of imports, experiments._warm) runs beside this process's own instead of after them
from rasc.errors import RascError
from rasc.interrupt import exit_process, signals_as_interrupt

if TYPE_CHECKING:
    from experiments._common import Context, Section

#: one module per paper output, in report order (adding an experiment: one module with
#: ``NAME`` and ``run(ctx) -> Section``, and one line here)
EXPERIMENTS = (
    ("e1_noise", "E1 — Figures 3 and 4: hand-eye error against noise"),
    ("e2_home_view", "E2 — noise on the home view only"),
    ("e3_quality", "E3 — the quality measure (eq. 10)"),
    ("e4_triangulation", "E4 — Table 1: triangulation with the calibrated model"),
    ("e5_base_to_ptu", "E5 — base-to-ptu: loop closure against measured mounts"),
    ("e6a_pixel_noise", "E6a — beyond the paper: error against image-space noise"),
    ("e6b_shootout", "E6b — beyond the paper: hand-eye shoot-out at small motions"),
    ("e7_model_mismatch", "E7 — beyond the paper: model mismatch (real pan-tilt units)"),
    ("e8_wide", "E8 — beyond the paper: wide motions with a ChArUco board"),
    ("e9_outliers", "E9 — beyond the paper: bad positions and unknown scale"),
    ("e10_depth", "E10 — beyond the paper: depth at any gaze against the depth buffer"),
    ("e11_lenses", "E11 — beyond the paper: calibration accuracy against field of view and "
                   "lens model"),
    ("e12_continuous", "E12 — beyond the paper: continuous motion, the time offset and "
                       "the capture time"),
)


def source_revision() -> str:
    """The code this report came from: the git commit of the checkout and whether its
    tracked files differ from it ("dirty"), or why none can be named."""
    import subprocess
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]

    def git(*argv: str) -> str:
        return subprocess.run(["git", "-C", str(repo), *argv], capture_output=True,
                              text=True, timeout=30, check=True).stdout.strip()

    try:
        commit = git("rev-parse", "HEAD")
        dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    except (OSError, subprocess.SubprocessError):
        return "not a git checkout: no commit recorded"
    return f"commit `{commit}`" + (", dirty (tracked files differ from it)" if dirty
                                   else ", clean")


def versions() -> dict[str, str]:
    import cv2
    import matplotlib
    import mujoco
    import numpy
    import scipy

    import rasc
    return {"rasc": rasc.__version__, "python": platform.python_version(),
            "numpy": numpy.__version__, "scipy": scipy.__version__, "opencv": cv2.__version__,
            "mujoco": mujoco.__version__, "matplotlib": matplotlib.__version__,
            "platform": platform.platform()}


def pipeline_section(ctx: Context) -> Section:
    """The calibration every experiment starts from, against the model's ground truth."""
    from experiments._common import Section, md_table
    cal = ctx.calibration()
    e = cal.errors
    rows = []
    for eye in ("left", "right"):
        r = cal.eyes[eye]
        he = e[eye]["T_cam_from_gaze"]
        rows.append([eye, f"{r.intrinsics.rms:.4f}", f"{e[eye]['K']['fx']:+.3f}",
                     f"{he['rotation_deg']:.4f}", f"{1000 * he['translation']:.3f}",
                     f"{r.handeye.quality:.2e}"])
    lc = e.get("loop_closure", {})
    text = (
        "The default dataset (`rasc render`, seed "
        f"{ctx.seed}): 20 intrinsics views per eye and the paper's nine pan-tilt positions "
        "(±8°, 3×3 grid) for both eyes, 9×6 board of 50 mm squares 1 m ahead, 1280×960. "
        "`rasc calibrate` (saddle-point corners, k1 k2 distortion, RASC over all ordered "
        "pairs) gives:\n\n"
        + md_table(["eye", "intrinsics RMS (px)", "fx error (px)", "T_cg rotation error (°)",
                    "T_cg translation error (mm)", "quality (eq. 10)"], rows)
        + f"\nLoop closure over the nine simultaneous views: T_pLpR error "
        f"{lc.get('rotation_deg', float('nan')):.4f}° / "
        f"{1000 * lc.get('translation', float('nan')):.2f} mm. The paper reports no such "
        "figure for its real head; these are the floors every experiment below starts from "
        "(its noise set 0).\n")
    return Section("pipeline", "The calibrated head (shared by all experiments)", text,
                   summary={eye: e[eye]["T_cam_from_gaze"] for eye in ("left", "right")})


def main(argv: list[str] | None = None) -> int:
    """Run the reproduction; 2 on bad input, 130 when interrupted (SIGINT or SIGTERM)."""
    state: dict = {"ctx": None, "done": [], "running": []}
    try:
        with signals_as_interrupt():
            return _run(argv, state)
    except RascError as exc:
        _remove_partials(state["ctx"])
        print(f"reproduce: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        ctx = state["ctx"]
        removed = _remove_partials(ctx)
        kept = ", ".join(state["done"]) or "none"
        where = f" in {ctx.out}" if ctx is not None else ""
        print(f"reproduce: interrupted: kept the finished experiments{where}: {kept}; "
              f"stopped the unfinished: {', '.join(state['running']) or 'none'} and removed "
              f"their partial folders ({', '.join(removed) or 'none'}); no REPORT.md "
              "written", file=sys.stderr)
        return 130


def _remove_partials(ctx) -> list[str]:
    """Remove the unfinished experiments' partial folders; their names."""
    from experiments._common import PARTIAL_PREFIX
    removed = []
    if ctx is not None:
        for partial in sorted(ctx.out.glob(PARTIAL_PREFIX + "*")):
            shutil.rmtree(partial, ignore_errors=True)
            removed.append(partial.name[len(PARTIAL_PREFIX):])
    return removed


#: experiments that need neither the default dataset nor its calibration (E7 renders or
#: projects its own heads): the parallel run starts them first, while the main process
#: calibrates the default dataset, so the longest experiment (E7 in the full run) is
#: off the critical path
EARLY = ("e7_model_mismatch",)

#: the order the parallel run submits the others: longest first (longest-processing-time
#: scheduling: the last experiment to start is a short one, so no worker idles at the end
#: while another finishes a long one), by their wall times measured on the 2-core bench
#: machine (quick: E6b 3.2 s, E1 2.5, E6a 1.7, E4 1.7, E3 1.5, E5 1.3, E2 0.8; the full
#: protocol's order is nearly the same; E10, added later, about 9 s quick and 30 s full,
#: goes first; E11, about 18 s quick, and E12, about 10 CPU-seconds quick and 75 full,
#: before it). Only the order changes, never a result.
LONGEST_FIRST = ("e11_lenses", "e12_continuous", "e10_depth", "e6b_shootout", "e1_noise",
                 "e6a_pixel_noise", "e4_triangulation", "e3_quality", "e5_base_to_ptu",
                 "e2_home_view")

#: what the pool's forkserver imports once (numpy, scipy, OpenCV, mujoco, matplotlib,
#: every experiment module): each worker is forked from it warm
PRELOAD = ["experiments._warm"]


def _requested_workers(argv: list[str] | None) -> int:
    """The ``--workers`` of ``argv`` as the real parser will read it (default: the cores
    this process may use), or 1 if it cannot tell (the real parser then reports the
    error): light, so that :func:`start_forkserver` runs before the heavy imports."""
    import argparse
    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--workers", type=int, default=None)
    try:
        args, _ = ap.parse_known_args(sys.argv[1:] if argv is None else argv)
    except (SystemExit, ValueError):
        return 1
    if args.workers is not None:
        return args.workers
    return (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
            else (os.cpu_count() or 1))


def start_forkserver() -> None:
    """Start the pool's forkserver now (it imports :data:`PRELOAD` in its own process,
    on the other core, while this one imports its own libraries and reads or renders the
    default dataset); the pool built later connects to it. Best effort: on failure the
    pool starts it itself."""
    import multiprocessing
    from multiprocessing import forkserver
    with contextlib.suppress(Exception):
        multiprocessing.get_context("forkserver").set_forkserver_preload(PRELOAD)
        _ensure_forkserver(forkserver)


def _ensure_forkserver(forkserver) -> None:
    """``forkserver.ensure_running()`` with ``experiments._warm.FORKSERVER_ENV`` set in
    the environment the forkserver inherits (so that it ends without a slow teardown),
    and only there (this process's environment is restored). Started within
    :func:`rasc.interrupt.starting_helpers` (from the main thread): a Ctrl-C to the
    process group while it imports its preload modules (seconds) reaches this process
    only, never the forkserver (it printed its own KeyboardInterrupt traceback)."""
    from rasc.interrupt import starting_helpers

    key = "RASC_REPRODUCE_FORKSERVER"       # experiments._warm.FORKSERVER_ENV (not
    old = os.environ.get(key)               # imported here: it warms up on import)
    os.environ[key] = "1"
    try:
        with starting_helpers():
            forkserver.ensure_running()
    finally:
        if old is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = old


def _finish(ctx: Context, state: dict, name: str, key: str, section: Section,
            seconds: float, finished: dict) -> None:
    """An experiment has finished: rename its staging folder, record it."""
    ctx.commit(key)
    state["done"].append(key)
    state["running"] = [r for r in state["running"] if r != key]
    finished[name] = (section, seconds)


class _ParallelRun:
    """The experiments in ``ctx.workers`` processes, on rasc.study's process pool
    (:class:`rasc.study.executors.ProcessExecutor`: forkserver workers, so none inherits
    this process's EGL context; single-threaded libraries; SIGINT left to this process;
    stopped at once by an interrupt).

    :meth:`start` builds the pool in a background thread (the forkserver imports
    ``experiments._warm`` once: numpy, scipy, OpenCV, mujoco, matplotlib and its fonts,
    every experiment module; the workers are forked from it warm) and submits the
    :data:`EARLY` experiments, while the main thread renders and calibrates the default
    dataset; :meth:`finish` then submits the others, longest first
    (:data:`LONGEST_FIRST`), and collects them as they finish. Results do not depend on
    the order they finish."""

    def __init__(self, ctx: Context, state: dict) -> None:
        self.ctx, self.state = ctx, state
        self.keys = {name: importlib.import_module(f"experiments.{name}").NAME
                     for name, _ in EXPERIMENTS}
        #: the submitted experiments not yet collected: future → module name
        self.pending: dict = {}
        self.executor = None
        self.error: BaseException | None = None
        self.thread = None

    def _child(self) -> Context:
        import copy
        child = copy.copy(self.ctx)
        child.workers = 1
        child.reuse_e1 = False      # E3 does not wait for E1 (nor read its folder meanwhile)
        return child

    def _submit(self, name: str, child: Context) -> None:
        from experiments._common import run_experiment
        print(f"== {dict(EXPERIMENTS)[name]}", file=sys.stderr, flush=True)
        self.pending[self.executor.submit(run_experiment, (child, name))] = name
        self.state["running"].append(self.keys[name])

    def _build(self, early: list[str], child: Context) -> None:
        import multiprocessing

        from rasc.study.executors import ProcessExecutor
        try:
            from multiprocessing import forkserver

            multiprocessing.get_context("forkserver").set_forkserver_preload(PRELOAD)
            _ensure_forkserver(forkserver)  # (if start_forkserver did not: no-op if it did)
            self.executor = ProcessExecutor(min(self.ctx.workers, len(EXPERIMENTS)))
            for name in early:
                self._submit(name, child)
        except BaseException as exc:   # re-raised in the main thread by finish()
            self.error = exc

    def start(self) -> None:
        import threading
        early = [name for name, _ in EXPERIMENTS if name in EARLY]
        # the context as it is now: no calibration (EARLY experiments do not use it)
        self.thread = threading.Thread(target=self._build, args=(early, self._child()),
                                       daemon=True)
        self.thread.start()

    def finish(self, finished: dict) -> None:
        self.thread.join()
        if self.error is not None:
            raise self.error
        child = self._child()       # now with the default dataset's calibration
        order = [n for n in LONGEST_FIRST if n in dict(EXPERIMENTS)]
        submitted = set(self.pending.values())
        for name in order + [n for n, _ in EXPERIMENTS if n not in order]:
            if name not in submitted:
                self._submit(name, child)
        for name, (_, section, seconds) in self.executor.completed(self.pending):
            print(f"== {dict(EXPERIMENTS)[name]}: {seconds:.1f} s", file=sys.stderr,
                  flush=True)
            _finish(self.ctx, self.state, name, self.keys[name], section, seconds, finished)

    def close(self, ok: bool) -> None:
        """Let the pool's workers end (``ok``) or stop them at once (an error, an
        interrupt: :meth:`~rasc.study.executors.ProcessExecutor.abort`)."""
        if self.thread is not None:
            self.thread.join()
        if self.executor is None:
            return
        if not ok:
            self.executor.abort()
        self.executor.close()


def _run(argv: list[str] | None, state: dict) -> int:
    from rasc.io import cache_root
    cache_root()               # a bad RASC_CACHE_MAX_MB is refused before anything starts
    if _requested_workers(argv) > 1:
        start_forkserver()
    from experiments._common import REPO, Context, stage
    from rasc.io import write_text_atomic

    ctx = Context.from_argv(__doc__, argv)
    ctx.staging = True
    state["ctx"] = ctx
    report = ctx.out / "REPORT.md"
    if report.is_file():
        report.unlink()     # it describes an earlier run; rewritten at the end of this one
    t_start = time.perf_counter()
    timings: list[tuple[str, float]] = []
    sections: list[Section] = []

    finished: dict[str, tuple[Section, float]] = {}
    parallel = _ParallelRun(ctx, state) if ctx.workers > 1 else None
    ok = False
    try:
        if parallel is not None:
            parallel.start()
        t0 = time.perf_counter()
        sections.append(pipeline_section(ctx))
        timings.append(("render + calibrate the default dataset", time.perf_counter() - t0))
        rig = REPO / "sim" / "models" / "stereo_head.png"
        if rig.is_file():
            shutil.copyfile(rig, ctx.out / "rig.png")
        if parallel is not None:
            parallel.finish(finished)
        else:
            for name, title in EXPERIMENTS:
                module = importlib.import_module(f"experiments.{name}")
                state["running"] = [module.NAME]
                with stage(title) as st:
                    section = module.run(ctx)
                _finish(ctx, state, name, module.NAME, section, st.seconds, finished)
        ok = True
    finally:
        if parallel is not None:
            parallel.close(ok)
    for name, title in EXPERIMENTS:
        section, seconds = finished[name]
        section.title = title
        sections.append(section)
        timings.append((title, seconds))
    total = time.perf_counter() - t_start
    write_text_atomic(ctx.out / "REPORT.md", report_text(ctx, sections, timings, total))
    print(f"reproduce: wrote {ctx.out / 'REPORT.md'} ({total:.1f} s)", file=sys.stderr)
    return 0


def report_text(ctx: Context, sections: list[Section], timings: list[tuple[str, float]],
                total: float) -> str:
    """REPORT.md: the command, the source, the sections in order, the software versions
    and the wall time of every stage (``total`` s in all)."""
    from experiments._common import md_table

    v = versions()
    mode = "quick (reduced protocol, for tests)" if ctx.quick else "full protocol"
    parts = [
        "# RASC — reproduction of Neubert & Ferrier, *Robust Active Stereo Calibration* "
        "(ICRA 2002)\n",
        f"Command: `python -m experiments.reproduce{' --quick' if ctx.quick else ''} "
        f"--seed {ctx.seed} --workers {ctx.workers}` — {mode}; seed {ctx.seed}.\n",
        f"Source: {source_revision()}.\n",
        "Everything below was computed from images rendered by the MuJoCo model of the "
        "head (`sim/models/`) and passed through the real pipeline (OpenCV detection, "
        "camera calibration, per-pose extrinsics) into the solvers. Raw results are in "
        "the CSV/JSON files beside this report; figures are PNG"
        + (" (SVG too in the full protocol)" if ctx.quick else " and SVG") + ".\n",
        "![The simulated stereo head](rig.png)\n",
        "## Contents\n",
        "\n".join(f"{k + 1}. {s.title}" for k, s in enumerate(sections)) + "\n",
    ]
    for k, s in enumerate(sections):
        parts.append(f"## {k + 1}. {s.title}\n\n{s.markdown.strip()}\n")
    parts.append("## Software\n\n" + md_table(["package", "version"], sorted(v.items())))
    parts.append("## Wall time\n\n" + md_table(
        ["stage", "seconds"], [(n, f"{t:.1f}") for n, t in timings] +
        [("**total**", f"**{total:.1f}**")])
        + f"\nOn {ctx.workers} worker process(es); wall times vary with the machine's load "
          "and are not part of the results.\n")
    return "\n".join(parts)


if __name__ == "__main__":
    # without the interpreter's teardown: every result is already written (atomically)
    # and closed and the pool joined, and freeing the loaded libraries (numpy, scipy,
    # OpenCV, mujoco, matplotlib) one object at a time took 0.6-0.7 s after "wrote
    # REPORT.md" (measured on the 2-core bench machine; the atexit handlers 3 ms of it)
    exit_process(main(), teardown=False)
