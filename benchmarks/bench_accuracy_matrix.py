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
            "(experiments.accuracy.lens_cell_passes). Rendered lens cells wait for rendering "
            "through any lens.", 90))
        print()
        print(acc.lens_markdown_table(lens := [acc.run_lens_cell(c, args.seed)
                                               for c in acc.LENS_CELLS]))
        failed += [r for r in lens if not acc.lens_cell_passes(r)[0]]
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
