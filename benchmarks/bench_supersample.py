"""Supersampled renders: detected corners against the renderer's truth and the render
time, for ``RenderOptions.supersample`` S = 1 … 4, measured side by side.

    .venv/bin/python benchmarks/bench_supersample.py [--repeat 3] [--max 4]
        [--markdown docs/results/supersample.md]

The scene: the stock head and its 9×6 chessboard of 50 mm squares (1280×960 images). The
views: the paper's nine pose views of each eye at 1 m, and six intrinsics views per eye
(the board poses ``rasc render`` draws, seed 0). Each S has its own simulator (its own
offscreen renderer, S times the size); every view is rendered by each in turn (the order
rotating from view to view, ``repeat`` times), so that all see the same load. The
corners: the pipeline's detector (``saddle``) on the grey image, against the true
projection of the board's corners (the simulator's ``project_world_points``). Printed:
per S and kind of view, the corners' RMS error (px), their mean error (x, y: a shift of
every corner, which a wrong pixel-centre convention would give), the largest error, the
median wall time of one grey image and its ratio to S = 1. Then the default
(``rasc.sim.DEFAULT_SUPERSAMPLE``, what ``RenderOptions.supersample`` and ``rasc render``
use) against this run's trade: each step from S − 1 to S, the share of the pose views'
corner error it removes and the render time it adds; the default is the largest S whose
step still removes at least a quarter of the error (``STEP_GAIN``); beside it, what the
default costs and buys where it was measured outside this script (``ELSEWHERE``).
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
from rasc.geometry.transforms import invert_transform  # noqa: E402

INTRINSICS_VIEWS = 6
#: the rule the default follows: the largest S whose step from S - 1 removes at least this
#: share of the pose views' corner RMS error (each further step removes less, for more
#: added render time than the last)
STEP_GAIN = 0.25

#: What the default costs and buys beyond this script's renders, measured once by the
#: commands named (the lead's bench machine: 2 shared AMD EPYC cores, no GPU, EGL), for
#: the plain render (S = 1) and the default (S = 2): (what, S = 1, S = 2, measured by).
ELSEWHERE = (
    ("the reproduction's CPU time (user + system)", "141.1 s", "194.5 s (+38 %)",
     "`python -m experiments.reproduce` (`make reproduce`: 2 workers, caches off), "
     "2026-11-28, load average 10–16 (wall 441 s and 516 s: not comparable)"),
    ("its render CPU time (`StereoHeadSim.render_camera`, 1168 images) and share",
     "31.9 s (23 %)", "90.0 s (46 %; E10's 18 stay plain)", "the same two runs"),
    ("`reproduce --quick` (the suite runs it 2–3 times): CPU, render CPU",
     "27.9 s, 2.3 s", "32.2 s, 5.4 s", "`python -m experiments.reproduce --quick`"),
    ("the test suite's CPU time (460–625 s measured, developer guide)", "—",
     "+50–90 s, estimated", "35 ms more CPU per 1280x960 image (the reproduction's "
     "renders: 21 → 56 ms) over an estimated 1000–2000 images (about 80 places in "
     "tests/ render), 4 s per quick run"),
    ("E8: closed-form hand-eye error, ChArUco ±30° over ±8° (ideal unit, one placement; "
     "0.25–0.27 on projected corners)", "0.540", "0.263", "the reproduction's E8"),
    ("E5: loop closure on the rendered views", "0.0206°, 0.56 mm", "0.0161°, 0.13 mm",
     "the reproduction's E5"),
    ("E4: the true model from detected corners, std lateral / vertical / depth",
     "0.058 / 0.059 / 0.344 mm", "0.043 / 0.044 / 0.250 mm", "the reproduction's E4"),
    ("the plan's prediction (each kind of view's noise), within ±25 %: `rasc plan`'s "
     "summary quantities; components", "19 of 24; 37 of 48", "23 of 24; 43 of 48",
     "`python experiments/plan_check.py --rendered --jitter --captures 40 "
     "--supersample S` (chessboard, the same 40 captures)"),
    ("— of them the unit's axis angle (measured / predicted σ)", "3 of 6 (0.78–1.52)",
     "6 of 6 (0.94–1.21)", "the same"),
)


def main(argv=None) -> int:
    from _markdown import add_markdown_option

    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--repeat", type=int, default=3, help="renders of each view per S "
                                                         "(default 3)")
    p.add_argument("--max", type=int, default=4, help="the largest S (default 4)")
    add_markdown_option(p)
    args = p.parse_args(argv)

    from rasc.sim.render import intrinsics_board_poses
    from rasc.sim.scene import StereoHeadSim, T_base_from_world_facing
    from rasc.vision.detect import detect_corners

    factors = list(range(1, args.max + 1))
    sims = {s: StereoHeadSim() for s in factors}
    ref = sims[1]
    board, size = ref.board, ref.image_size
    P = board.object_points()
    errors = {(s, kind): [] for s in factors for kind in ("pose", "intrinsics")}
    times = {s: [] for s in factors}
    n = 0

    def shoot(kind: str, eye: str) -> None:
        nonlocal n
        order = [factors[(n + k) % len(factors)] for k in range(len(factors))]
        n += 1
        truth = ref.project_world_points(eye, P)
        images = {}
        for _ in range(args.repeat):
            for s in order:
                t0 = time.perf_counter()
                images[s] = sims[s].render_grey(eye, supersample=s)
                times[s].append(time.perf_counter() - t0)
        for s in factors:
            c = detect_corners(images[s], board, "saddle")
            if c is None:
                raise SystemExit(f"S = {s}: board not found in a {kind} view of {eye}")
            seen = np.isfinite(c[:, 0])
            errors[s, kind].append(c[seen] - truth[seen])

    try:
        rng = np.random.default_rng(0)
        for eye in ("left", "right"):
            T_base_from_cam = invert_transform(ref.T_cam_from_base(eye))
            for T_cw in intrinsics_board_poses(rng, board, ref.K(eye), size,
                                               INTRINSICS_VIEWS):
                for sim in sims.values():
                    sim.set_target(T_base_from_cam @ T_cw)
                shoot("intrinsics", eye)
        for sim in sims.values():
            sim.set_target(T_base_from_world_facing(board))
        for pan, tilt in PAPER_POSES_DEG:
            for sim in sims.values():
                for eye in ("left", "right"):
                    sim.set_angles(eye, np.radians(pan), np.radians(tilt))
            for eye in ("left", "right"):
                shoot("pose", eye)
    finally:
        for sim in sims.values():
            sim.close()

    median = {s: statistics.median(times[s]) for s in factors}
    print(f"stock head and 9x6 chessboard, {size[0]}x{size[1]}; {len(PAPER_POSES_DEG)} pose "
          f"views and {INTRINSICS_VIEWS} intrinsics views per eye; {args.repeat} renders "
          f"of each view per S\n")
    print("| S | views | corners | RMS px | mean x, y px | max px | ms/image | time ratio |")
    print("| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for s in factors:
        for kind in ("pose", "intrinsics"):
            e = np.concatenate(errors[s, kind])
            r = np.linalg.norm(e, axis=1)
            mx, my = e.mean(axis=0)
            print(f"| {s} | {kind} | {len(e)} | {np.sqrt(np.mean(r ** 2)):.4f} | "
                  f"{mx:+.4f}, {my:+.4f} | {r.max():.4f} | {1e3 * median[s]:.0f} | "
                  f"{median[s] / median[1]:.2f} |", flush=True)
    rms = {s: float(np.sqrt(np.mean(np.sum(np.concatenate(errors[s, "pose"]) ** 2, axis=1))))
           for s in factors}
    print_default(rms, median)
    return 0


def print_default(rms: dict[int, float], median: dict[int, float]) -> None:
    """The default against this run's trade (pose views' RMS error ``rms`` and median
    time per image ``median``, per S), then :data:`ELSEWHERE`."""
    from rasc.sim import DEFAULT_SUPERSAMPLE

    factors = sorted(rms)
    print("\n## The default\n")
    print("| step | pose views' RMS px | error removed | time per image added | "
          "error removed per added ms (px) |")
    print("| --- | --- | ---: | ---: | ---: |")
    chosen = factors[0]
    for s in factors[1:]:
        gain = 1 - rms[s] / rms[s - 1]
        added = median[s] - median[s - 1]
        if gain >= STEP_GAIN:
            chosen = s
        print(f"| {s - 1} → {s} | {rms[s - 1]:.4f} → {rms[s]:.4f} | {100 * gain:.0f} % | "
              f"{1e3 * added:+.0f} ms ({median[s] / median[s - 1]:.2f}×) | "
              f"{(rms[s - 1] - rms[s]) / (1e3 * added):.2e} |")
    verdict = ("agrees with" if chosen == DEFAULT_SUPERSAMPLE else
               "DIFFERS from (revisit the default:")
    print(f"\nThe largest S whose step removes at least {100 * STEP_GAIN:.0f} % of the "
          f"pose views' corner error: S = {chosen}; this {verdict} the default, "
          f"rasc.sim.DEFAULT_SUPERSAMPLE = {DEFAULT_SUPERSAMPLE}"
          + ("." if chosen == DEFAULT_SUPERSAMPLE else ")."))
    if ELSEWHERE:
        print("\nWhat the default costs and buys beyond these renders (measured once, by "
              "the command named; not re-run by this script):\n")
        print("| what | S = 1 | S = 2 | measured by |")
        print("| --- | --- | --- | --- |")
        for what, one, two, how in ELSEWHERE:
            print(f"| {what} | {one} | {two} | {how} |")


if __name__ == "__main__":
    from _markdown import run_main

    raise SystemExit(run_main(main, "Supersampled renders: corner error and render time",
                              __file__))
