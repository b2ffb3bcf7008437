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
import os
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from rasc.io import read_json_document, write_json_atomic, write_text_atomic

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


def _init_worker() -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")


def run_tasks(fn: Callable[[Any], Any], tasks: Sequence[Any], workers: int,
              label: str = "") -> list[Any]:
    """Map ``fn`` over ``tasks`` (in order), in ``workers`` processes, with progress."""
    progress = Progress(label, len(tasks))
    if workers <= 1 or len(tasks) <= 1:
        out = []
        for task in tasks:
            out.append(fn(task))
            progress.step()
        return out
    results: list[Any] = [None] * len(tasks)
    with ProcessPoolExecutor(max_workers=workers, initializer=_init_worker) as pool:
        futures = {pool.submit(fn, task): k for k, task in enumerate(tasks)}
        from concurrent.futures import as_completed
        for fut in as_completed(futures):
            results[futures[fut]] = fut.result()
            progress.step()
    return results


class Progress:
    """One updating line on stderr: ``[label] k/n (t s)``."""

    def __init__(self, label: str, total: int) -> None:
        self.label, self.total, self.done = label, total, 0
        self.t0 = time.perf_counter()
        self._last = 0.0
        self.tty = sys.stderr.isatty()

    def step(self, k: int = 1) -> None:
        self.done += k
        now = time.perf_counter()
        if not self.label:
            return
        final = self.done >= self.total
        if final or now - self._last > (0.2 if self.tty else 5.0):
            self._last = now
            end = "\n" if final or not self.tty else "\r"
            print(f"[{self.label}] {self.done}/{self.total} ({now - self.t0:.1f} s)",
                  end=end, file=sys.stderr, flush=True)


def fmt(x: Any) -> str:
    if isinstance(x, float | np.floating):
        return repr(float(x))
    return str(x)


def write_csv(path: Path, header: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in rows:
        w.writerow([fmt(v) for v in row])
    write_text_atomic(path, buf.getvalue())


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


class Context:
    """What every experiment shares: arguments, and the default dataset rendered and
    calibrated once (``out/data/``) through the real pipeline.

    ``ctx.dataset_dir()`` renders the default dataset (seeded by ``--seed``) on first
    use; ``ctx.calibration()`` runs ``rasc.head.pipeline.calibrate_dataset`` on it once and
    writes ``out/data/calibration.json``; ``ctx.truth()`` is its ``ground_truth.json``.
    Experiments write into ``ctx.dir(name)`` and return a :class:`Section` for the report.
    """

    def __init__(self, args: argparse.Namespace) -> None:
        self.seed: int = args.seed
        self.quick: bool = args.quick
        self.out: Path = Path(args.out)
        self.workers: int = args.workers
        self._calibration = None
        self._truth = None

    @classmethod
    def from_argv(cls, doc: str, argv: Sequence[str] | None = None) -> Context:
        return cls(parse_args(doc, argv))

    def dir(self, name: str) -> Path:
        path = self.out / name
        path.mkdir(parents=True, exist_ok=True)
        return path

    def dataset_dir(self) -> Path:
        from rasc.sim.render import RenderOptions, render_dataset

        path = self.out / "data" / "dataset"
        if not (path / "manifest.json").is_file():
            import shutil
            shutil.rmtree(path, ignore_errors=True)
            path.parent.mkdir(parents=True, exist_ok=True)
            with stage("render the default dataset (intrinsics views + nine poses, both eyes)"):
                render_dataset(path, RenderOptions(seed=self.seed))
        return path

    def calibration(self):
        """The pipeline's calibration of the default dataset (rasc.head.pipeline.Calibration)."""
        if self._calibration is None:
            from rasc.head.pipeline import calibrate_dataset
            from rasc.vision.dataset import load_dataset

            ds = load_dataset(self.dataset_dir())
            with stage("calibrate the default dataset (detection, intrinsics, extrinsics, "
                       "RASC, loop closure)"):
                self._calibration = calibrate_dataset(ds)
            doc = self._calibration.to_dict()
            doc.pop("timings_s", None)  # wall times are not results: keep files identical
            write_json(self.out / "data" / "calibration.json", doc)
        return self._calibration

    def truth(self) -> dict:
        if self._truth is None:
            self._truth = read_json_document(self.dataset_dir() / "ground_truth.json",
                                             "ground truth")
        return self._truth


def script_main(run: Callable[[Context], Section], doc: str,
                argv: Sequence[str] | None = None) -> int:
    """What every experiment script's ``main`` does: arguments → ``run`` → its section."""
    print(run(Context.from_argv(doc, argv)).markdown)
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


def save_figure(fig, path_stem: Path) -> list[Path]:
    """Save a matplotlib figure as PNG and SVG, deterministically (no dates/ids).

    The tight bounding box is computed once and given to both formats: with
    ``bbox_inches="tight"`` every ``savefig`` draws the figure twice, and drawing (tick
    labels of log axes above all) is most of a quick reproduction's time (measured: the
    four E1 figures 3.5 s -> 2.5 s).
    """
    import matplotlib

    bbox = fig.get_tightbbox(fig.canvas.get_renderer()).padded(0.1)  # savefig's pad
    paths = []
    for ext, meta in ((".png", {"Software": None}), (".svg", {"Date": None})):
        path = path_stem.with_suffix(ext)
        buf = io.BytesIO()
        with matplotlib.rc_context({"svg.hashsalt": "rasc"}):
            fig.savefig(buf, format=ext[1:], dpi=120, metadata=meta, bbox_inches=bbox)
        from rasc.io import write_bytes_atomic
        write_bytes_atomic(path, buf.getvalue())
        paths.append(path)
    return paths
