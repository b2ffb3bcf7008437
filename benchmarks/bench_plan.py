"""Time to plan nine positions from a 2° grid over the joint ranges (``rasc plan``).

    python benchmarks/bench_plan.py [--repeat N] [--target SPEC]

Prints the wall time of :func:`rasc.plan.plan` (candidate visibility, the refinement's
Jacobian over every usable candidate, the greedy D-optimal choice; the triangulation
prediction is left out) per repetition, and the usable candidates.
"""

from __future__ import annotations

import argparse
import os
import time


def main(argv=None) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--target", default="chessboard:9x6,0.05")
    args = p.parse_args(argv)
    from rasc.plan import nominal_setup, plan
    from rasc.vision.board import parse_target

    setup = nominal_setup(parse_target(args.target), step_deg=2.0)
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        result = plan(setup, 9, workspace_depth=None)
        print(f"bench_plan: {args.target}: {time.perf_counter() - t0:.2f} s wall, "
              f"{result.candidates} usable candidates of the 2-degree grid")
    return 0


if __name__ == "__main__":
    from _markdown import run_main

    raise SystemExit(run_main(main, "Capture planning: nine positions from a 2-degree grid",
                              __file__))
