"""E9 on a real image sequence: rwhe-kuka-1 (30 views of a 28×17 board from a camera on a
KUKA arm; Ali et al., Sensors 2019) with corrupted positions injected.

The images are not redistributable: they are read in place (``--data``, default
``../shared/data/rwhe-kuka-1`` beside the repository) and the run stops with one line
when they are absent. Detection, intrinsics and per-view extrinsics as
tests/vision/test_real_images.py does them (rasc.vision); the arm's poses
``RobotPosesVec.txt`` (T_base_from_gripper, metres → mm). No truth exists: errors are
against RASC on the clean 30. Corruptions as E9 (rasc.handeye.corruption, a wrong joint
reading turning the arm's pose about a random axis), 0/5/20/50 % of the 30 positions,
``--samples`` draws each (default 10), seeded by ``(--seed, 30, fraction index, sample)``.

Run::

    python -m experiments.e9_kuka [--data DIR] [--out DIR] [--seed S] [--samples N]

Writes ``<out>/e9/kuka.csv`` (one row per solve) and prints the table.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from experiments._common import md_table, write_csv
from experiments.e9_outliers import FRACTIONS, RAW_HEADER, _solve_all, precision_recall, summarise

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data" / "rwhe-kuka-1"
METHODS = ("rasc", "rasc-robust", "li", "opencv-park")


def load(folder: Path):
    """(T_cam_from_world (30, 4, 4) mm, T_gripper_from_base (30, 4, 4) mm)."""
    from rasc.geometry.transforms import invert_transform
    from rasc.vision.board import Board
    from rasc.vision.camera import calibrate_intrinsics, detect_views, estimate_extrinsics

    board = Board((28, 17), 20.0)                 # squaresize.txt: 20 mm
    images = {f"{k:02d}": folder / f"{k:02d}.jpg" for k in range(1, 31)}
    corners, missing = detect_views(images, board)
    if missing:
        raise SystemExit(f"e9_kuka: board not found in {missing}")
    intr = calibrate_intrinsics(corners, board, (1928, 1208))
    T_cw = np.array([estimate_extrinsics(corners[n], board, intr.K, intr.dist)[0]
                     for n in images])
    T_bg = np.loadtxt(folder / "RobotPosesVec.txt").reshape(-1, 4, 4)
    T_bg[:, :3, 3] *= 1000.0
    return T_cw, invert_transform(T_bg)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--data", type=Path, default=DATA, help=f"the images (default {DATA})")
    p.add_argument("--out", type=Path, default=REPO / "out", help="output folder")
    p.add_argument("--seed", type=int, default=0, help="master seed (default 0)")
    p.add_argument("--samples", type=int, default=10, help="draws per fraction (default 10)")
    args = p.parse_args(argv)
    if not (args.data / "RobotPosesVec.txt").is_file():
        print(f"e9_kuka: error: {args.data}: no RobotPosesVec.txt (the rwhe-kuka-1 images "
              "are read in place, never copied)", file=sys.stderr)
        return 2
    from rasc.handeye.corruption import corrupt
    from rasc.handeye.methods import solve

    T_cw, T_gb = load(args.data)
    T_ref = np.asarray(solve("rasc", T_cw, T_gb).T_cam_from_gaze)
    rows = []
    for f_i, fraction in enumerate(FRACTIONS):
        for s in range(args.samples if fraction else 1):
            rng = np.random.default_rng((args.seed, 30, f_i, s))
            Tc, Tg, bad, _ = corrupt(T_cw, T_gb, round(fraction * len(T_cw)), rng)
            rows += _solve_all(Tc, Tg, bad, T_ref, METHODS, 1.0, fraction, s)
    folder = args.out / "e9"
    folder.mkdir(parents=True, exist_ok=True)
    write_csv(folder / "kuka.csv", RAW_HEADER, rows)
    summ = summarise(rows)
    table = []
    for m in METHODS:
        table.append((m, *[f"{summ[f'{f:g}|{m}']['median_rotation_deg']:.3g}° / "
                           f"{summ[f'{f:g}|{m}']['median_translation_mm']:.3g} mm"
                           for f in FRACTIONS]))
    print(md_table(("method", *[f"{100 * f:g} %" for f in FRACTIONS]), table))
    prec, rec = precision_recall(rows)
    print(f"rasc-robust: precision {prec:.3f}, recall {rec:.3f} (rejected against corrupted)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
