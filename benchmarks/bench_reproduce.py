"""Reproduction benchmark: wall time of every stage of ``python -m experiments.reproduce``, full
protocol and ``--quick``, side by side in one run, with a yardstick for the machine.

    .venv/bin/python benchmarks/bench_reproduce.py [--seed 0] [--workers 2] [--skip-full]
                                                   [--before REF]

Each mode runs as a fresh process (what a user runs: imports, rendering and plotting
included) into a temporary folder; its per-stage times are read from the REPORT.md it
writes, its total is the process's wall time. Goals: the full reproduction under 60 s
(issue 4) and ``--quick`` under 10 s (issue 8) on the 2-core bench machine.

``--before REF`` (a git commit, branch or tag, e.g. ``main``) also runs that version of
the reproduction (``git archive REF`` into a temporary folder, with this environment's
Python) alternately with this one, so the before/after table comes from one run under
the same load: its columns are ``quick before``, ``quick after`` (and the same for the
full run), its rows the union of both versions' stages; and it compares the two
versions' raw results (every CSV and JSON file, byte for byte) per mode.

Absolute times move with the machine and its load, so the table also gives each total
scaled by a yardstick measured in the same run, before and after: the median time of
one RASC solve on Tabb's 88 poses (numpy, single-threaded; bench_handeye.py's "RASC="
column), which took 0.96-0.99 ms on the machine where the goals were set. The
reproduction mixes numpy with rendering (llvmpipe), OpenCV and matplotlib, so the scaled
figure is an estimate; OpenCV's own PARK solve varied 49-93 ms between runs here and
makes a worse yardstick.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from _markdown import run_main  # noqa: E402

GOALS_S = {"full": 60.0, "quick": 10.0}
#: the yardstick's median on the machine where the goals were met (README: 0.96-0.99 ms)
YARDSTICK_REFERENCE_MS = 0.975


def yardstick_ms(repeat: int = 200) -> float:
    """Median ms of one RASC solve on Tabb's 88 poses in OpenCV's roles and pairs (the
    "RASC=" column of bench_handeye.py, timed the same way)."""
    from bench_handeye import TABB, median_time

    from rasc.geometry.transforms import make_transform, project_to_rotation
    from rasc.handeye.opencv import read_tabb_rwhe
    from rasc.handeye.solver import solve_rasc

    T_cw, T_gb, _ = read_tabb_rwhe(TABB)
    T_cw = make_transform(project_to_rotation(T_cw[:, :3, :3]), T_cw[:, :3, 3])
    T_gb = make_transform(project_to_rotation(T_gb[:, :3, :3]), T_gb[:, :3, 3])
    return 1e3 * median_time(lambda: solve_rasc(T_gb, T_cw, pairs="half",
                                                min_rotation_rad=0.0), repeat)


def stage_times(report: Path) -> list[tuple[str, float]]:
    """The rows of REPORT.md's "Wall time" table (stage, seconds), total excluded."""
    text = report.read_text(encoding="utf-8")
    table = text[text.index("## Wall time"):]
    rows = re.findall(r"^\| (?!stage|\*\*total)(.+?) \| ([0-9.]+) \|$", table, re.MULTILINE)
    return [(name, float(sec)) for name, sec in rows]


def run_mode(quick: bool, seed: int, workers: int, folder: Path,
             repo: Path = REPO) -> tuple[float, list]:
    """Run one reproduction of the code in ``repo`` as a fresh process: (wall s, stages)."""
    cmd = [sys.executable, "-m", "experiments.reproduce", "--seed", str(seed),
           "--workers", str(workers), "--out", str(folder)] + (["--quick"] if quick else [])
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
           "PYTHONPATH": str(repo)}     # this version's rasc, not the installed one
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, cwd=repo, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        tail = proc.stderr.strip().splitlines()[-1:] or ["(no message)"]
        raise SystemExit(f"bench_reproduce: {' '.join(cmd)} (in {repo}) failed: {tail[0]}")
    return wall, stage_times(folder / "REPORT.md")


def compare_results(a: Path, b: Path) -> tuple[int, list[str]]:
    """The raw results (every CSV and JSON file) of two runs: (how many, the names of
    those that differ in their bytes or exist in one run only)."""
    def files(root: Path) -> dict[str, bytes]:
        return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*")
                if p.is_file() and p.suffix in (".csv", ".json")}
    fa, fb = files(a), files(b)
    names = sorted(set(fa) | set(fb))
    return len(names), [n for n in names if fa.get(n) != fb.get(n)]


def export_ref(ref: str, folder: Path) -> Path:
    """The tree of git ``ref`` of this repository, extracted into ``folder``."""
    folder.mkdir(parents=True)
    archive = subprocess.run(["git", "archive", "--format=tar", ref], cwd=REPO,
                             capture_output=True)
    if archive.returncode != 0:
        raise SystemExit(f"bench_reproduce: git archive {ref}: "
                         f"{archive.stderr.decode().strip()}")
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)
    return folder


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--skip-full", action="store_true", help="time --quick only")
    ap.add_argument("--before", metavar="REF",
                    help="also time git REF (e.g. main): a before/after table in one run")
    args = ap.parse_args(argv)

    ystick = yardstick_ms()
    modes = ["quick"] + ([] if args.skip_full else ["full"])
    versions = ["before", "after"] if args.before else ["after"]
    results = {}
    with tempfile.TemporaryDirectory(prefix="bench_reproduce_") as tmp:
        repos = {"after": REPO}
        if args.before:
            repos["before"] = export_ref(args.before, Path(tmp) / "before-src")
        for mode in modes:
            for version in versions:
                print(f"running reproduce.py{' --quick' if mode == 'quick' else ''} "
                      f"({version}) ...", file=sys.stderr, flush=True)
                results[mode, version] = run_mode(mode == "quick", args.seed, args.workers,
                                                  Path(tmp) / f"{mode}-{version}",
                                                  repos[version])
        same = {mode: compare_results(Path(tmp) / f"{mode}-before", Path(tmp) / f"{mode}-after")
                for mode in modes} if args.before else {}
    ystick_after = yardstick_ms()

    load = os.getloadavg()
    print(f"{os.cpu_count()} CPUs, {args.workers} workers, seed {args.seed}; load average "
          f"{load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} at the end; yardstick "
          f"(RASC on Tabb's 88 poses) {ystick:.3f} ms before, {ystick_after:.3f} ms after "
          f"(reference machine: {YARDSTICK_REFERENCE_MS} ms)"
          + (f"; before = {args.before}, after = this tree" if args.before else ""))
    cols = [(m, v) for m in modes for v in versions]
    names: list[str] = []
    for c in cols:
        names += [n for n, _ in results[c][1] if n not in names]
    width = max(len(n) for n in names) + 2
    heads = [f"{m}{' ' + v if args.before else ''} (s)" for m, v in cols]
    cw = max(14, *(len(h) + 2 for h in heads))
    print(f"\n{'stage':<{width}}" + "".join(f"{h:>{cw}}" for h in heads))
    for name in names:
        cells = []
        for c in cols:
            t = dict(results[c][1]).get(name)
            cells.append(f"{t:>{cw}.1f}" if t is not None else f"{'—':>{cw}}")
        print(f"{name:<{width}}" + "".join(cells))
    print(f"{'process wall time':<{width}}" + "".join(f"{results[c][0]:>{cw}.1f}"
                                                      for c in cols))
    y = statistics.mean([ystick, ystick_after])
    scale = YARDSTICK_REFERENCE_MS / y
    print(f"{'scaled to the reference':<{width}}"
          + "".join(f"{results[c][0] * scale:>{cw}.1f}" for c in cols))
    print(f"{'goal':<{width}}" + "".join(f"{GOALS_S[m]:>{cw}.0f}" for m, _ in cols))
    for mode, (n, differ) in same.items():
        print(f"\n{mode}: raw results (CSV/JSON) before and after: {n} files, "
              + (f"{len(differ)} differ: {', '.join(differ)}" if differ else
                 "all byte-identical"))
    print("\n" + "; ".join(
        f"{m}{' ' + v if args.before else ''}: goal "
        f"{'met' if results[m, v][0] <= GOALS_S[m] else 'NOT met'} here, "
        f"{'met' if results[m, v][0] * scale <= GOALS_S[m] else 'NOT met'} scaled to the "
        "reference machine" for m, v in cols))
    return 0


if __name__ == "__main__":
    sys.exit(run_main(main, "Reproduction: wall time per stage", __file__))
