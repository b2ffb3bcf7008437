"""Continuous motion (docs/topics/continuous.md): detected corners against the truth at
mid-exposure, and the render cost of a continuous frame against a still one, measured
side by side in one run.

    .venv/bin/python benchmarks/bench_continuous.py [--frames 12] [--exposure 0.01]
        [--subframes 8] [--speeds 10,30,60] [--rolling-shutter 2e-5]

The scene: the stock head and its 9×6 chessboard of 50 mm squares at 1 m (1280×960
images), the left eye. The trajectory: minimum-jerk motions through the paper's nine
positions at each peak speed; ``frames`` frames spread evenly over it (mid-exposure
stamps). Per frame: a still render at the mid-exposure angles ("still") and the
exposure of ``exposure`` s averaged over ``subframes`` renders along the motion
(:func:`rasc.sim.render.continuous_grey`); with ``--rolling-shutter`` also the exposure
with that line time, its corners compared both with the mid-exposure projection and
with each corner projected at its own row's time. Corners: the pipeline's detector
(``saddle``) against the true projection (the simulator's ``project_world_points``).
Printed per speed: RMS and largest corner error (px), the frames where the board was
not found, the median wall time of one grey image.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rasc.geometry.kinematics import PAPER_POSES_DEG  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--exposure", type=float, default=0.01)
    ap.add_argument("--subframes", type=int, default=8)
    ap.add_argument("--speeds", default="10,30,60")
    ap.add_argument("--rolling-shutter", type=float, default=2e-5)
    args = ap.parse_args(argv)

    from rasc.sim.motion import Trajectory
    from rasc.sim.render import RenderOptions, continuous_grey
    from rasc.sim.scene import StereoHeadSim
    from rasc.vision.board import Board
    from rasc.vision.camera import detect_corners

    board = Board((9, 6), 0.05)
    P = board.object_points()
    eye = "left"
    print(f"{args.frames} frames per speed, exposure {1e3 * args.exposure:g} ms, "
          f"{args.subframes} sub-frames, 1280x960, left eye, saddle corners")
    print(f"{'speed':>6} {'kind':<22} {'RMS px':>7} {'max px':>7} {'lost':>4} "
          f"{'ms/image':>9}")
    with StereoHeadSim(board=board) as sim:
        sim.set_target(sim.facing_target(1.0))
        for speed in (float(s) for s in args.speeds.split(",")):
            traj = Trajectory(np.radians(PAPER_POSES_DEG), speed)
            # frames inside the motion, away from its ends
            stamps = np.linspace(0.05, traj.duration - 0.05, args.frames)
            kinds = {"still (mid-exposure)": RenderOptions(),
                     "continuous": RenderOptions(motion_speed_deg_s=speed,
                                                 exposure=args.exposure,
                                                 subframes=args.subframes)}
            if args.rolling_shutter:
                kinds["rolling shutter"] = RenderOptions(
                    motion_speed_deg_s=speed, exposure=args.exposure,
                    subframes=args.subframes, rolling_shutter=args.rolling_shutter)
            for kind, opts in kinds.items():
                errs, lost, times, row_errs = [], 0, [], []
                for t in stamps:
                    t0 = time.perf_counter()
                    if opts.motion_speed_deg_s:
                        image = continuous_grey(sim, eye, traj, float(t), opts)
                    else:
                        sim.set_angles(eye, *traj.angles(t, eye))
                        image = sim.render_grey(eye)
                    times.append(time.perf_counter() - t0)
                    sim.set_angles(eye, *traj.angles(t, eye))
                    truth = sim.project_world_points(eye, P)
                    c = detect_corners(image, board, "saddle")
                    if c is None:
                        lost += 1
                        continue
                    errs.append(c - truth)
                    if opts.rolling_shutter:
                        # each corner at its own row's time (found by iterating twice)
                        own = truth.copy()
                        mid_row = (sim.image_size[1] - 1) / 2
                        for _pass in range(2):
                            for i, (_u, v) in enumerate(own):
                                tr = t + (v - mid_row) * opts.rolling_shutter
                                sim.set_angles(eye, *traj.angles(tr, eye))
                                own[i] = sim.project_world_points(eye, P[i:i + 1])[0]
                        row_errs.append(c - own)
                _report(speed, kind, errs, lost, times)
                if row_errs:
                    _report(speed, "  vs own row's time", row_errs, lost, times)
    return 0


def _report(speed, kind, errs, lost, times):
    if errs:
        d = np.concatenate(errs)
        n = np.linalg.norm(d, axis=1)
        rms, worst = float(np.sqrt(np.mean(n ** 2))), float(n.max())
    else:
        rms = worst = float("nan")
    print(f"{speed:6g} {kind:<22} {rms:7.3f} {worst:7.3f} {lost:4d} "
          f"{1e3 * statistics.median(times):9.1f}")


if __name__ == "__main__":
    sys.exit(main())
