"""Study throughput: the local process pool and a dask LocalCluster, 1 and 2 workers,
side by side in one run.

    .venv/bin/python benchmarks/bench_study.py [--samples 30] [--renders 4]

Two studies, each run afresh on every executor (each executor started before the clock
starts, so start-up is not counted; it is printed apart):

* **samples**: E1-like cells (noise sets 1-8 x both eyes, literal eq. 13-14 noise) with
  RASC, Li and OpenCV's Park on one dataset, rendered beforehand and copied into each
  run's folder, so only the samples are timed: cells/s and samples/s (one sample = one
  noisy pose set solved by every method);
* **renders**: ``--renders`` cells that each need their own dataset (board distance
  swept; 8 intrinsics views per eye, one sample): rendered and calibrated datasets/s.

The outputs of every executor are compared byte for byte (CSV, JSON, figures). The
study engine's dataset cache is off (RASC_CACHE_DIR=none): every run renders.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
# every executor renders its datasets afresh: the study engine's dataset cache would
# otherwise serve the later runs what the first one rendered
os.environ["RASC_CACHE_DIR"] = "none"

from _markdown import run_main  # noqa: E402

from rasc.study import load_spec, run_study  # noqa: E402
from rasc.study.executors import DaskExecutor, ProcessExecutor  # noqa: E402
from rasc.vision.dataset import forget_detections  # noqa: E402

SAMPLES_SPEC = """\
name = "bench-samples"
seed = 0
samples = {samples}
methods = ["rasc", "li", "opencv-park"]
[fixed]
intrinsics_views = 8
noise_model = "literal"
[axes]
noise_level = [1, 2, 3, 4, 5, 6, 7, 8]
eye = ["left", "right"]
"""

RENDERS_SPEC = """\
name = "bench-renders"
seed = 0
samples = 1
methods = ["rasc"]
[fixed]
intrinsics_views = 8
[axes]
distance = [{distances}]
"""


def files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def timed_run(spec, out: Path, make, seed_from: Path | None) -> tuple[float, float]:
    """(start-up s, run s) of ``spec`` into ``out`` on the executor ``make()``."""
    resume = False
    if seed_from is not None:           # the dataset rendered beforehand: time samples only
        out.mkdir()
        shutil.copytree(seed_from / "datasets", out / "datasets")
        shutil.copy(seed_from / "study.json", out / "study.json")
        resume = True
    forget_detections()   # this process detects afresh, as a pool's new processes do
    t0 = time.perf_counter()
    ex = make()
    if isinstance(ex, ProcessExecutor):   # start the pool's processes now
        list(ex.map_unordered(abs, [0] * ex.workers))
    t1 = time.perf_counter()
    try:
        run_study(spec, out, resume=resume, quiet=True, executor=ex)
        t2 = time.perf_counter()
    finally:
        ex.close()
    return t1 - t0, t2 - t1


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=30)
    ap.add_argument("--renders", type=int, default=4)
    args = ap.parse_args(argv)
    executors = [("process pool", 1, lambda: ProcessExecutor(1)),
                 ("process pool", 2, lambda: ProcessExecutor(2)),
                 ("dask LocalCluster", 1, lambda: DaskExecutor("local", 1)),
                 ("dask LocalCluster", 2, lambda: DaskExecutor("local", 2))]
    with tempfile.TemporaryDirectory(prefix="bench_study_") as tmp:
        tmp = Path(tmp)
        (tmp / "samples.toml").write_text(SAMPLES_SPEC.format(samples=args.samples))
        distances = ", ".join(f"{1.0 + 0.1 * k:.1f}" for k in range(args.renders))
        (tmp / "renders.toml").write_text(RENDERS_SPEC.format(distances=distances))
        s_spec, r_spec = load_spec(tmp / "samples.toml"), load_spec(tmp / "renders.toml")
        n_cells, n_r = len(s_spec.cells()), len(r_spec.cells())
        print("rendering the samples study's dataset once ...", file=sys.stderr)
        run_study(s_spec, tmp / "warm", quiet=True)
        rows, outputs = [], {}
        for name, workers, make in executors:
            print(f"{name}, {workers} worker(s) ...", file=sys.stderr)
            tag = f"{name.split()[0]}{workers}"
            su, ts = timed_run(s_spec, tmp / f"s-{tag}", make, tmp / "warm")
            su2, tr = timed_run(r_spec, tmp / f"r-{tag}", make, None)
            outputs[tag] = (files(tmp / f"s-{tag}"), files(tmp / f"r-{tag}"))
            rows.append((name, workers, (su + su2) / 2, n_cells / ts,
                         n_cells * s_spec.samples / ts, n_r / tr))
        ref = next(iter(outputs.values()))
        same = all(v == ref for v in outputs.values())
    print(f"{os.cpu_count()} CPUs; samples study: {n_cells} cells x {s_spec.samples} samples x "
          f"{len(s_spec.methods)} methods ({', '.join(s_spec.methods)}); renders study: "
          f"{n_r} datasets (8 intrinsics views + 9 poses per eye, 1280x960)\n")
    print("| executor | workers | start-up s | cells/s | samples/s | datasets/s |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for name, w, su, cps, sps, dps in rows:
        print(f"| {name} | {w} | {su:.2f} | {cps:.2f} | {sps:.1f} | {dps:.3f} |")
    print(f"\nsame bytes on every executor: {'yes' if same else 'NO'}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(run_main(main, "Study throughput: process pool and dask", __file__))
