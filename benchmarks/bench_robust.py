"""rasc-robust's cost beside RASC's: runtime per solve, as ratios measured side by side.

    .venv/bin/python benchmarks/bench_robust.py [--repeat 20]

Cases (each clean and with 20 % of the positions corrupted by rasc.handeye.corruption,
seeded): the paper's nine ±8° pan-tilt positions (84 triples: every one is a
hypothesis), 20 random pan-tilt positions in ±15° (1140 triples: 200 drawn), and Tabb's
88 real arm poses (tests/data/tabb-rwhe-dataset1). Noise as E9: eq. 13–14, 0.002 rad /
1 mm. For each case RASC, rasc-robust and the pose-residual refinement
(rasc.handeye.robust_refine, from RASC's result) are timed alternately in blocks, so
that all see the same load; the median CPU time of this process per solve (which other
processes' load does not inflate, unlike wall time on a shared machine) and the ratio to
RASC's are printed. No goal is set by the issue beyond measuring; rasc-robust does one batched RASC
over its hypotheses and a few RASC solves on the inliers, so a ratio of tens to a
hundred is what its design costs.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu  # noqa: E402
from rasc.geometry.transforms import make_transform, project_to_rotation  # noqa: E402
from rasc.handeye.corruption import (  # noqa: E402
    TRUE_T_CAM_FROM_GAZE,
    TRUE_T_PTU_FROM_WORLD,
    corrupt,
    pan_tilt_poses,
)
from rasc.handeye.noise import perturb_T_cam_from_world  # noqa: E402
from rasc.handeye.opencv import read_tabb_rwhe  # noqa: E402
from rasc.handeye.robust import solve_rasc_robust  # noqa: E402
from rasc.handeye.robust_refine import refine_handeye  # noqa: E402
from rasc.handeye.solver import solve_rasc  # noqa: E402

TABB = REPO / "tests" / "data" / "tabb-rwhe-dataset1"


def cases() -> list[tuple[str, np.ndarray, np.ndarray]]:
    out = []
    rng = np.random.default_rng(0)
    pt = np.radians(np.array(PAPER_POSES_DEG, dtype=float))
    G = T_gaze_from_ptu(pt[:, 0], pt[:, 1])
    nine = perturb_T_cam_from_world(TRUE_T_CAM_FROM_GAZE @ G @ TRUE_T_PTU_FROM_WORLD,
                                    0.002, 0.001, rng, "exponential")
    out.append(("nine ±8° pan-tilt", nine, G, pt))
    T20, G20, pt20 = pan_tilt_poses(20, rng)
    out.append(("20 pan-tilt ±15°",
                perturb_T_cam_from_world(T20, 0.002, 0.001, rng, "exponential"), G20, pt20))
    T_cw, T_gb, _ = read_tabb_rwhe(TABB)
    T_cw = make_transform(project_to_rotation(T_cw[:, :3, :3]), T_cw[:, :3, 3])
    T_gb = make_transform(project_to_rotation(T_gb[:, :3, :3]), T_gb[:, :3, 3])
    out.append(("Tabb 88 real arm poses", T_cw, T_gb, None))
    full = []
    for name, T, G, pt in out:
        full.append((f"{name}, clean", T, G))
        Tc, Gc, _, _ = corrupt(T, G, round(0.2 * len(T)), np.random.default_rng(1),
                               pan_tilt_rad=pt)
        full.append((f"{name}, 20 % corrupted", Tc, Gc))
    return full


def side_by_side(fns: dict, repeat: int, block: int = 5) -> dict[str, float]:
    """Median CPU time per call of each function, timed alternately in blocks
    (bench_handeye's :func:`median_times`, on the CPU clock)."""
    from bench_handeye import median_times

    return dict(zip(fns, median_times(list(fns.values()), repeat, block,
                                      clock=time.process_time), strict=True))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--repeat", type=int, default=20, help="solves per function (default 20)")
    args = p.parse_args(argv)
    print(f"{'case':40s} {'RASC ms':>9s} {'robust ms':>10s} {'ratio':>7s} "
          f"{'refine ms':>10s} {'ratio':>7s}")
    for name, T, G in cases():
        t = side_by_side({"rasc": lambda T=T, G=G: solve_rasc(T, G),
                          "robust": lambda T=T, G=G: solve_rasc_robust(T, G),
                          "refine": lambda T=T, G=G: refine_handeye(T, G, solve_rasc(T, G))},
                         args.repeat)
        print(f"{name:40s} {1e3 * t['rasc']:9.3f} {1e3 * t['robust']:10.2f} "
              f"{t['robust'] / t['rasc']:7.0f} {1e3 * t['refine']:10.1f} "
              f"{t['refine'] / t['rasc']:7.0f}", flush=True)
    return 0


if __name__ == "__main__":
    from _markdown import run_main

    raise SystemExit(run_main(main, "Robust hand-eye: time per solve beside RASC", __file__))
