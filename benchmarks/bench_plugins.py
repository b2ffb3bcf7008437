"""Plugin overhead: a hand-eye method called through rasc against the same function
called directly, on the paper's nine ±8° poses (rasc.testing.make_pose_set, level 2).

    .venv/bin/python benchmarks/bench_plugins.py [--repeat 300]

Rows: a trivial plugin that returns a constant 4×4 (pure overhead); the example user
solver ``examples/my_solver`` (module:function); RASC itself through the plugin path
(``solve_rasc(...).T_cam_from_gaze`` wrapped as a plugin) and through its built-in name.
"Through rasc" is ``rasc.handeye.methods.solve(name, ...)``, name resolution included
(cached after the first call). The wrapper validates the input and checks degeneracy
(:func:`rasc.handeye.solver.diagnose`, which runs RASC's analysis), validates the output
and computes eq. 10: the overhead is about one RASC solve, whatever the plugin. Time per
call of the best block of 10 calls over ``--repeat`` calls after a warm-up; the solver
yardstick (RASC, nine poses) is printed before and after, since this machine's speed
drifts, and the overhead is also given in yardsticks.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "examples" / "my_solver"))

import my_solver.solver  # noqa: E402
from _markdown import add_markdown_option, markdown_page  # noqa: E402

from rasc.handeye.methods import solve  # noqa: E402
from rasc.handeye.solver import solve_rasc  # noqa: E402
from rasc.testing import make_pose_set  # noqa: E402

CONSTANT = np.eye(4)


def constant(T_cam_from_world, T_gaze_from_ptu):
    """The cheapest plugin there is: the overhead alone."""
    return CONSTANT


def rasc_as_plugin(T_cam_from_world, T_gaze_from_ptu):
    return solve_rasc(T_cam_from_world, T_gaze_from_ptu).T_cam_from_gaze


def best_us(fn, repeat: int, block: int = 10) -> float:
    """Per-call time of the fastest block of ``block`` calls: on a shared machine the
    median carries the other users' load, the best block much less of it."""
    fn()
    times = []
    for _ in range(max(1, repeat // block)):
        t0 = time.perf_counter()
        for _ in range(block):
            fn()
        times.append((time.perf_counter() - t0) / block)
    return 1e6 * min(times)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=300)
    add_markdown_option(ap)
    args = ap.parse_args(argv)
    with markdown_page(args.markdown, "Plugin overhead: a solver called through rasc",
                       __file__, argv, summary=" ".join(__doc__.split("\n\n")[2].split())):
        run(args)


def run(args) -> None:
    s = make_pose_set(2, seed=0)
    T_cw, T_gp = s.T_cam_from_world, s.T_gaze_from_ptu
    yard0 = best_us(lambda: solve_rasc(T_cw, T_gp), args.repeat)
    rows = [
        ("constant 4x4 (pure overhead)", constant, "__main__:constant"),
        ("examples/my_solver", my_solver.solver.solve, "my_solver.solver:solve"),
        ("RASC as a plugin", rasc_as_plugin, "__main__:rasc_as_plugin"),
        ("RASC built-in name 'rasc'", lambda a, b: solve_rasc(a, b), "rasc"),
    ]
    print(f"nine poses, best block of 10 over {args.repeat} calls; RASC yardstick "
          f"{yard0:.0f} µs\n")
    print("| method | direct (µs) | through rasc (µs) | overhead (µs) | ratio | overhead "
          "/ yardstick |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for label, fn, name in rows:
        direct = best_us(lambda fn=fn: fn(T_cw, T_gp), args.repeat)
        wrapped = best_us(lambda name=name: solve(name, T_cw, T_gp), args.repeat)
        ratio = f"{wrapped / direct:.2f}×" if direct >= 1.0 else "—"
        print(f"| {label} | {direct:.1f} | {wrapped:.0f} | {wrapped - direct:.0f} | "
              f"{ratio} | {(wrapped - direct) / yard0:.2f} |")
    yard1 = best_us(lambda: solve_rasc(T_cw, T_gp), args.repeat)
    print(f"\nRASC yardstick after: {yard1:.0f} µs")


if __name__ == "__main__":
    main()
