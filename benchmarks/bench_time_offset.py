"""Calibration from continuous motion (issue 33): the camera-to-encoder time offset δ.

    .venv/bin/python benchmarks/bench_time_offset.py [--seeds 10] [--repeat 3] [--renders]

1. CPU time of the whole-head refinement with δ estimated against without, in one run,
   on the same continuous capture (projected corners, true δ = 0, so both models fit):
   best of ``--repeat`` each, side by side, and their ratio. Goal: ≤ 1.5×.
2. δ against the truth (−30, 0, +20 ms) over ``--seeds`` seeds: the largest error, the
   mean predicted σ and the observed spread (sample std of the error). Goal: within 1 ms;
   σ within 0.5–2× of the spread.
3. Hand-eye error (T_cam_from_gaze translation against the truth, both eyes' mean, in
   mm) of a continuous capture against a stop-and-go capture that takes three times as
   long (the same 9 positions, each held for a rest so that the whole lasts 3× the
   continuous motion, one image per eye per rest, as ``rasc import`` keeps): projected
   corners, same noise, same intrinsics views. Goal: continuous ≤ 1.5× stop-and-go.
4. ``--renders``: the same two captures rendered (rasc.sim.render, MuJoCo; the
   continuous one with 2 sub-frames over a 4 ms exposure, 24 frames per eye), δ = 20 ms.

The captures: the paper's 9 positions joined by minimum-jerk motions at a peak of
20°/s (rasc.sim.motion.Trajectory), cameras at 10 frames/s, joints at 200 Hz,
0.03 px corner noise, 20 intrinsics views per eye, the ideal unit (its gauge is the
truth's own).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from _markdown import run_main  # noqa: E402

from rasc.geometry.kinematics import PAPER_POSES_DEG  # noqa: E402
from rasc.head.pipeline import CalibrationOptions, calibrate_dataset  # noqa: E402
from rasc.head.refine import observations_from_calibration, refine_head  # noqa: E402
from rasc.sim.motion import Trajectory  # noqa: E402
from rasc.sim.synthetic import continuous_corner_dataset, corner_dataset  # noqa: E402

EYES = ("left", "right")
SPEED = 20.0
FRAME_RATE = 10.0


def _handeye_mm(cal, truth) -> float:
    return 1000 * float(np.mean([np.linalg.norm(getattr(cal.head, e).T_cam_from_gaze[:3, 3]
                                                - truth.T_cam_from_gaze[e][:3, 3])
                                 for e in EYES]))


def section_cpu(args) -> None:
    print("## 1. refinement CPU time, with δ against without (one run)\n")
    ds = continuous_corner_dataset(seed=args.seed, speed_deg_s=SPEED, frame_rate=FRAME_RATE)
    cal = calibrate_dataset(ds, CalibrationOptions(model="paper"))
    obs = observations_from_calibration(cal, ds.board)
    n = sum(len(obs.eyes[e].pose) for e in EYES)
    cpu = {False: [], True: []}
    iters = {}
    for _ in range(args.repeat):
        for with_delta in (False, True):
            t0 = time.process_time()
            res = refine_head(obs, time_offset=with_delta)
            cpu[with_delta].append(time.process_time() - t0)
            iters[with_delta] = res.iterations
    a, b = min(cpu[False]), min(cpu[True])
    print(f"{n} pose images, true δ = 0; best of {args.repeat}\n")
    print("| refinement | CPU (s) | iterations |")
    print("| --- | --- | --- |")
    print(f"| without δ | {a:.3f} | {iters[False]} |")
    print(f"| with δ | {b:.3f} | {iters[True]} |")
    print(f"\nratio with/without: {b / a:.2f} (goal ≤ 1.5)\n")


def section_delta(args) -> None:
    print(f"## 2. δ against the truth over {args.seeds} seeds\n")
    print("| true δ (ms) | max abs error (ms) | mean σ (ms) | observed spread (ms) | "
          "spread / σ |")
    print("| --- | --- | --- | --- | --- |")
    for delta in (-0.030, 0.0, 0.020):
        err, sig = [], []
        for seed in range(args.seeds):
            ds = continuous_corner_dataset(seed=args.seed + seed, clock_offset=delta,
                                           speed_deg_s=SPEED, frame_rate=FRAME_RATE)
            d = calibrate_dataset(ds).refinement.time_offset
            err.append(d["value_s"] - delta)
            sig.append(d["std_s"])
        err, sig = 1000 * np.array(err), 1000 * np.array(sig)
        spread = float(np.std(err, ddof=1)) if len(err) > 1 else float("nan")
        print(f"| {1000 * delta:+.0f} | {np.abs(err).max():.2e} | {sig.mean():.2e} | "
              f"{spread:.2e} | {spread / sig.mean():.2f} |")
    print("\n(the same seeds give the same corners: δ only moves the joint stream's stamps, "
          "so equal errors across δ show the estimate is equivariant in δ)\n")


def section_handeye(args) -> None:
    traj = Trajectory(np.radians(np.asarray(PAPER_POSES_DEG, float)), SPEED)
    t_cont = traj.duration
    t_stop = 3 * t_cont
    rest = (t_stop - t_cont) / len(PAPER_POSES_DEG)
    print("## 3. hand-eye error: continuous against stop-and-go three times as long "
          "(projected corners)\n")
    print(f"continuous: {t_cont:.2f} s, {FRAME_RATE:g} frames/s; stop-and-go: the same "
          f"motions plus a {rest:.2f} s rest at each of the {len(PAPER_POSES_DEG)} positions "
          f"({t_stop:.2f} s), one image per eye per rest\n")
    print("| seed | continuous (mm) | stop-and-go (mm) | δ error (ms) |")
    print("| --- | --- | --- | --- |")
    cont, stop = [], []
    for seed in range(args.seeds):
        ds = continuous_corner_dataset(seed=args.seed + seed, clock_offset=0.02,
                                       speed_deg_s=SPEED, frame_rate=FRAME_RATE)
        cal = calibrate_dataset(ds)
        cont.append(_handeye_mm(cal, ds.truth))
        derr = 1000 * (cal.refinement.time_offset["value_s"] - 0.02)
        sg = corner_dataset(seed=args.seed + seed)
        stop.append(_handeye_mm(calibrate_dataset(sg), sg.truth))
        print(f"| {args.seed + seed} | {cont[-1]:.4f} | {stop[-1]:.4f} | {derr:+.1e} |")
    print(f"\nmean: continuous {np.mean(cont):.4f} mm, stop-and-go {np.mean(stop):.4f} mm; "
          f"ratio {np.mean(cont) / np.mean(stop):.2f} (goal ≤ 1.5) in a third of the time\n")


def section_renders(args, tmp: Path) -> None:
    from rasc.sim.render import RenderOptions, render_dataset
    from rasc.vision.dataset import load_dataset

    print("## 4. rendered: continuous against stop-and-go\n")
    base = RenderOptions(intrinsics_views=20, seed=args.seed)
    moving = dataclasses.replace(base, motion_speed_deg_s=SPEED, frame_rate=FRAME_RATE,
                                 max_frames=60, subframes=2, exposure=0.004,
                                 clock_offset=0.02)
    print("| capture | pose images | δ (ms) | hand-eye left (mm) | right (mm) |")
    print("| --- | --- | --- | --- | --- |")
    for name, opts in (("continuous", moving), ("stop-and-go", base)):
        folder = tmp / name
        render_dataset(folder, opts, quiet=True)
        ds = load_dataset(folder)
        cal = calibrate_dataset(ds)
        d = cal.refinement.time_offset
        dtxt = (f"{1000 * d['value_s']:.4f} ± {1000 * d['std_s']:.4f}"
                if d.get("estimated") else "—")
        e = {eye: 1000 * cal.errors[eye]["T_cam_from_gaze"]["translation"] for eye in EYES}
        print(f"| {name} | {len(ds.select(role='pose'))} | {dtxt} | {e['left']:.4f} | "
              f"{e['right']:.4f} |")
    print()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--seeds", type=int, default=10)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--renders", action="store_true")
    args = p.parse_args(argv)
    print(f"load average before: {os.getloadavg()[0]:.1f}\n")
    section_cpu(args)
    section_delta(args)
    section_handeye(args)
    if args.renders:
        with tempfile.TemporaryDirectory(prefix="rasc-bench-delta-") as tmp:
            section_renders(args, Path(tmp))
    return 0


if __name__ == "__main__":
    sys.exit(run_main(main, "Calibration from continuous motion: the time offset",
                      __file__))
