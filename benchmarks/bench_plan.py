"""Time to plan nine positions from a 2° grid over the joint ranges (``rasc plan``).

    python benchmarks/bench_plan.py [--repeat N] [--target SPEC ...] [--no-reference]
                                    [--markdown FILE]

For each target, the time of :func:`rasc.plan.plan` (candidate visibility, the information
of every usable candidate, the greedy D-optimal choice; the triangulation prediction is
left out) per repetition, as wall time and as this process's CPU time (the machine is
shared: CPU time is the steadier figure), the usable candidates, and — unless
``--no-reference`` — the same plan by the reference path (the refinement's sparse
Jacobian image by image, every candidate evaluated at every greedy step), the ratio of
the two, and whether both chose the same positions.
"""

from __future__ import annotations

import argparse
import os
import time

TARGETS = ("chessboard:9x6,0.05", "charuco:16x12,0.075,0.056")


def _timed(fn):
    w0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w0, time.process_time() - c0


def main(argv=None) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--target", action="append", default=None, metavar="SPEC",
                   help=f"target(s), as rasc render --target (default: {', '.join(TARGETS)})")
    p.add_argument("--no-reference", action="store_true",
                   help="time the planner only, not the reference path beside it")
    args = p.parse_args(argv)
    from rasc.plan import Information, candidate_grid, greedy, nominal_setup, plan
    from rasc.vision.board import parse_target

    rows = []
    for spec in args.target or TARGETS:
        setup = nominal_setup(parse_target(spec), step_deg=2.0)
        for r in range(args.repeat):
            new, w_new, c_new = _timed(lambda s=setup: plan(s, 9, workspace_depth=None))
            row = [spec, str(r + 1), str(new.candidates), f"{w_new:.2f}", f"{c_new:.2f}"]
            if not args.no_reference:
                def reference(s=setup):
                    info = Information(s, candidate_grid(s), reference=True)
                    return [tuple(map(float, info.feasible[c]))
                            for c in greedy(info.I0, info.A, 9, lazy=False)]
                old, w_old, c_old = _timed(reference)
                row += [f"{w_old:.2f}", f"{c_old:.2f}", f"{c_old / c_new:.1f}",
                        "yes" if old == new.positions else "NO"]
            rows.append(row)
            print(f"bench_plan: {spec} repetition {r + 1}: {w_new:.2f} s wall, "
                  f"{c_new:.2f} s CPU", flush=True)
    head = ["target", "run", "usable candidates", "wall s", "CPU s"]
    if not args.no_reference:
        head += ["reference wall s", "reference CPU s", "CPU ratio", "same positions"]
    print()
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for row in rows:
        print("| " + " | ".join(row) + " |")
    return 0


if __name__ == "__main__":
    from _markdown import run_main

    raise SystemExit(run_main(main, "Capture planning: nine positions from a 2-degree grid",
                              __file__))
