"""The accuracy matrix: every cell of the covering design, rendered, calibrated through its
door, reported and scored against the truth (``experiments/accuracy.py``).

    python benchmarks/bench_accuracy_matrix.py [--workers N] [--seed S] [--out DIR]
                                               [--markdown docs/results/accuracy_matrix.md]

Prints the design (factors, levels, cells, the pairs they cover), every cell's figures
and the normalized errors pooled over the matrix; ``--out`` keeps ``cells.json``. Exit
status 1 when a cell fails the matrix's rule (:func:`experiments.accuracy.cell_passes`).
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import textwrap
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # experiments/
sys.path.insert(0, str(Path(__file__).resolve().parent))       # _markdown

from _markdown import add_markdown_option, markdown_page  # noqa: E402

LEGEND = (
    "How to read the table. Every cell is rendered with truth and calibrated through its "
    "door (the command line's file is compared with the Python API's: 'doors agree'); its "
    "report is built (pages). Errors are against the truth in the calibration's own gauge. "
    "χ²/n: eᵀΣ⁻¹e over every parameter the refinement estimated, over their number (1 "
    "when the σ are right); within 3σ: the share of |z| ≤ 3; worst quantity: the block (an "
    "eye's intrinsics, hand-eye rotation or translation, unit axes, encoder scales; the "
    "mounts' rotation or translation) farthest outside, as d² against the χ² bound of its "
    "dimension (with --model paper: the hand-eye against its jackknife error, bounded by "
    "3·F(3, n − 1), the jackknife's σ being estimated from the n positions). A cell passes "
    "when its report builds, its doors agree, and it is within every bound or its verdict "
    "is not 'usable'.")


def main(argv=None) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=None, help="folder for cells.json (default: none)")
    add_markdown_option(p)
    args = p.parse_args(argv)
    from experiments import accuracy as acc

    cells = acc.covering_cells()
    valid = [dict(zip(acc.FACTORS, c, strict=True))
             for c in itertools.product(*acc.FACTORS.values())]
    valid = [c for c in valid if acc._valid(c)]
    pairs = set().union(*(acc._pairs(c) for c in valid))
    with markdown_page(args.markdown, "The accuracy matrix", __file__, argv):
        print("Factors and levels (experiments/accuracy.py):")
        for f, levels in acc.FACTORS.items():
            print(f"  {f}: {', '.join(levels)}")
        design = (f"{len(cells)} cells of {len(valid)} valid combinations cover all "
                  f"{len(pairs)} pairs of levels (a chessboard, seen whole, is never at "
                  f"±30°); {acc.INTRINSICS_VIEWS} intrinsics views per eye, image noise "
                  f"{acc.IMAGE_NOISE:g} grey levels, seed {args.seed} + the cell's index; a "
                  f"quantity's bound is the χ² quantile of its dimension at {acc.BOUND_P:g}.")
        print(textwrap.fill(design, 90))
        t0 = time.perf_counter()
        results = acc.run_matrix(None if args.out is None else Path(args.out), cells,
                                 args.seed, workers=args.workers, log=lambda s: None)
        wall = time.perf_counter() - t0
        print(f"{len(cells)} cells in {wall:.0f} s wall on {args.workers} worker(s).")
        print()
        print(textwrap.fill(LEGEND, 90))
        print()
        print(acc.markdown_tables(results))
        print()
        failed = [r for r in results if not acc.cell_passes(r)[0]]
        print(f"{len(results) - len(failed)} of {len(results)} cells pass the matrix's rule.")
        print()
        print(textwrap.fill(
            f"The lens factor, on projected corners ({acc.LENS_NOISE_PX:g} px per coordinate, "
            f"seed {args.seed}): each lens with its right dist_model, and the 170° fisheye "
            "calibrated as a pinhole (k1k2), which must be warned and not called usable "
            "(experiments.accuracy.lens_cell_passes).", 90))
        print()
        print(acc.lens_markdown_table(lens := [acc.run_lens_cell(c, args.seed)
                                               for c in acc.LENS_CELLS]))
        failed += [r for r in lens if not acc.lens_cell_passes(r)[0]]
        print()
        print(textwrap.fill(
            f"Continuous motion on projected corners ({acc.CONTINUOUS_NOISE_PX:g} px, "
            f"{acc.CONTINUOUS_SPEED_DEG_S:g} deg/s through the paper's nine positions, 10 "
            f"frames/s, joints at 200 Hz, seed {args.seed}), calibrated with the defaults (δ "
            "estimated; the last cell holds it at 0 and must not be called usable); "
            "'imperfect': a tilt axis 25 mm off the pan axis, skewed 0.5°, a pan scale of "
            "1.006. δ error against the truth, and its d² (bound 15.1 for one component); "
            "a cell passes when within every bound (experiments.accuracy."
            "continuous_cell_passes).", 90))
        print()
        print(acc.continuous_markdown_table(cont := [acc.run_continuous_cell(c, args.seed)
                                                     for c in acc.CONTINUOUS_CELLS]))
        failed += [r for r in cont if not acc.continuous_cell_passes(r)[0]]
        print()
        render = acc.CONTINUOUS_RENDER
        print(textwrap.fill(
            f"Rendered cells beyond the design (experiments.accuracy.EXTRA_CELLS; paper "
            f"positions, the defaults, the design's noise and views): a "
            f"{acc.FISHEYE_FOV_DEG:g}° fisheye calibrated with dist_model fisheye; a "
            f"continuous capture ({render['motion_speed_deg_s']:g} deg/s, "
            f"{render['frame_rate']:g} frames/s, {1e3 * render['exposure']:g} ms exposures of "
            f"{render['subframes']} sub-frames, up to {render['max_frames']} frames per eye, "
            f"δ = {1e3 * render['clock_offset']:g} ms) calibrated with the defaults (δ "
            "estimated), through the Python, command-line and import doors (import: "
            "played into a bag, rasc import --continuous, rasc calibrate; 'doors agree' "
            "there: every parameter within 0.01 σ of the rendered dataset's calibration); "
            f"the last at {acc.CONTINUOUS_FAST_RENDER['motion_speed_deg_s']:g} deg/s with "
            "rasc render's own exposure (10 ms of 8 sub-frames), "
            f"{acc.CONTINUOUS_FAST_RENDER['max_frames']} frames per eye. "
            "The same rule as the design's cells.", 90))
        print()
        extra = acc.run_matrix(None, acc.EXTRA_CELLS, args.seed, workers=args.workers,
                               log=lambda s: None, quiet=True)
        print(acc.extra_markdown_table(extra))
        failed += [r for r in extra if not acc.cell_passes(r)[0]]
        print()
        for what, line in acc.refused_combinations().items():
            print(f"Refused, in one line: {what}: {line!r}")
        print()
        n = len(results) + len(lens) + len(cont) + len(extra)
        print(f"{n - len(failed)} of {n} cells pass.")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
