"""Hand-eye from two timestamped pose streams with the time offset estimated,
against a refined reference that ignores the offset and the same reference given it.

    .venv/bin/python benchmarks/bench_handeye_time_offset.py [--seeds 20] \
        [--markdown docs/results/handeye_time_offset.md]

Streams from :func:`rasc.handeye.pose_streams.make_pose_streams` (seeded; a pan-tilt unit
moving along sums of sines for 20 s, its poses at 200 Hz, the camera's at 30 Hz with
eq. 13–14 noise of 0.002 rad / 1 mm, 0.2 ms of stamp jitter on both, the true offset
drawn uniformly in ±50 ms per seed). Four solutions per seed:

- **estimated**: :func:`rasc.handeye.time_offset.solve_streams` (δ estimated jointly);
- **reference, naive**: each camera pose paired with the unit pose of nearest stamp (δ
  taken as 0), ``rasc-views`` (the closed form with the lowest translation error,
  docs/guide/solver.md) on all pairs, then the pose-residual refinement
  (:func:`rasc.handeye.robust_refine.refine_handeye`);
- **reference, true δ**: the same, paired at the stamps plus the true δ;
- **held at true δ**: :func:`~rasc.handeye.time_offset.solve_streams` with δ held at the
  truth (the unit interpolated, not the nearest sample: the best this data allow).

Printed: mean rotation and translation errors against the truth, the ratios of the
estimated solution's errors to each other's, the δ error against its σ (the z-score
``(δ̂ − δ)/σ``, its RMS and how often |z| ≤ 1.96), and the CPU time of the estimate against
the solve with δ held (process time, one run, alternating).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rasc.geometry.transforms import rotation_error_deg  # noqa: E402
from rasc.handeye.methods import solve  # noqa: E402
from rasc.handeye.pose_streams import make_pose_streams  # noqa: E402
from rasc.handeye.robust_refine import refine_handeye  # noqa: E402
from rasc.handeye.time_offset import (  # noqa: E402
    TimeOffsetOptions,
    nearest_pairs,
    solve_streams,
)

REFERENCE_METHOD = "rasc-views"
OFFSET_RANGE = 0.05


def errors(X: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """(rotation error in degrees, translation error in mm)."""
    return (float(rotation_error_deg(X[:3, :3], truth[:3, :3])),
            1e3 * float(np.linalg.norm(X[:3, 3] - truth[:3, 3])))


def reference(s, offset: float) -> np.ndarray:
    """The refined reference: nearest-stamp pairs at ``offset``, rasc-views, refinement."""
    G = nearest_pairs(s.times, s.unit_times, s.T_gaze_from_ptu, offset)
    start = solve(REFERENCE_METHOD, s.T_cam_from_world, G)
    return np.asarray(refine_handeye(s.T_cam_from_world, G, start).T_cam_from_gaze)


def run_case(title: str, seeds: int, **stream_options) -> None:
    rows = {k: [] for k in ("estimated", "naive", "true", "held")}
    deltas, cpu_est, cpu_held = [], [], []
    for seed in range(seeds):
        offset = float(np.random.default_rng(10_000 + seed).uniform(-OFFSET_RANGE,
                                                                    OFFSET_RANGE))
        s = make_pose_streams(seed, time_offset=offset, **stream_options)
        args = (s.times, s.T_cam_from_world, s.unit_times, s.T_gaze_from_ptu)
        t0 = time.process_time()
        est = solve_streams(*args)
        t1 = time.process_time()
        held = solve_streams(*args, TimeOffsetOptions(time_offset=offset))
        t2 = time.process_time()
        cpu_est.append(t1 - t0)
        cpu_held.append(t2 - t1)
        truth = s.T_cam_from_gaze
        rows["estimated"].append(errors(est.T_cam_from_gaze, truth))
        rows["held"].append(errors(held.T_cam_from_gaze, truth))
        rows["naive"].append(errors(reference(s, 0.0), truth))
        rows["true"].append(errors(reference(s, offset), truth))
        deltas.append((offset, est.time_offset, est.std_time_offset,
                       est.coarse_time_offset))
    print(f"\n{title}: {seeds} seeds, true offsets uniform in ±{1e3 * OFFSET_RANGE:g} ms\n")
    names = {"estimated": "estimated δ (solve_streams)",
             "naive": f"reference, naive pairs ({REFERENCE_METHOD} + refine)",
             "true": f"reference, true δ ({REFERENCE_METHOD} + refine)",
             "held": "δ held at the truth (solve_streams)"}
    est = np.array(rows["estimated"])
    print("| solution | rotation error ° (mean) | translation error mm (mean) "
          "| estimated / it, rotation | estimated / it, translation |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for key, label in names.items():
        e = np.array(rows[key])
        print(f"| {label} | {e[:, 0].mean():.4f} | {e[:, 1].mean():.3f} "
              f"| {est[:, 0].mean() / e[:, 0].mean():.3f} "
              f"| {est[:, 1].mean() / e[:, 1].mean():.3f} |")
    d = np.array(deltas)
    err = d[:, 1] - d[:, 0]
    z = err / d[:, 2]
    print()
    print("| δ error, ms (mean abs / max abs) | coarse step's error, ms (max abs) "
          "| σ of δ, ms (median) | RMS of z = error/σ | |z| ≤ 1.96 |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    print(f"| {1e3 * np.abs(err).mean():.4f} / {1e3 * np.abs(err).max():.4f} "
          f"| {1e3 * np.abs(d[:, 3] - d[:, 0]).max():.2f} "
          f"| {1e3 * np.median(d[:, 2]):.4f} | {np.sqrt(np.mean(z ** 2)):.2f} "
          f"| {np.mean(np.abs(z) <= 1.96):.0%} |")
    print(f"\nCPU time per solve (median): δ estimated {np.median(cpu_est):.2f} s, δ held "
          f"{np.median(cpu_held):.2f} s, ratio {np.median(cpu_est) / np.median(cpu_held):.2f}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--seeds", type=int, default=20, help="seeds per case (default 20)")
    args = p.parse_args(argv)
    run_case("200 Hz unit, 30 Hz camera", args.seeds)
    run_case("1000 Hz unit, 15 Hz camera", args.seeds, unit_rate=1000.0, camera_rate=15.0)
    return 0


if __name__ == "__main__":
    from _markdown import run_main

    raise SystemExit(run_main(main, "Hand-eye from timestamped pose streams: the time "
                              "offset", __file__))
