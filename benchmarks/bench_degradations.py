"""The camera degradations (docs/topics/degradations.md): detected corners against the
renderer's truth for each degradation at a few strengths.

    .venv/bin/python benchmarks/bench_degradations.py [--seeds 2]

The scene: the stock head and its 9×6 chessboard of 50 mm squares (1280×960 images) at
1 m, the paper's nine pose views of each eye (18 images), made as ``rasc render`` makes
them (:func:`rasc.sim.render.view_image`, the render's rng seeded per seed). The corners:
the pipeline's detector (``saddle``) on the grey image, against the true projection of
the board's corners (the simulator's ``project_world_points``). Printed: per row the
options, the corners' RMS error (px) over all views and seeds, and the views where the
board was not found.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rasc.geometry.kinematics import PAPER_POSES_DEG  # noqa: E402

#: (label, RenderOptions fields) of each row
ROWS = [
    ("none", {}),
    ("full_well 20000 e", {"full_well": 20000.0}),
    ("full_well 2000 e", {"full_well": 2000.0}),
    ("full_well 2000 e, read_noise 20 e", {"full_well": 2000.0, "read_noise": 20.0}),
    ("full_well 300 e", {"full_well": 300.0}),
    ("vignetting 0.5", {"vignetting": 0.5}),
    ("vignetting 0.5, full_well 2000 e", {"vignetting": 0.5, "full_well": 2000.0}),
    ("motion_blur 4 px", {"motion_blur": 4.0}),
    ("motion_blur 16 px", {"motion_blur": 16.0}),
    ("motion_blur 16 px, full_well 2000 e", {"motion_blur": 16.0, "full_well": 2000.0}),
    ("focus 0.5 m, f/2.8 (8 mm)", {"focus_distance": 0.5}),
    ("focus 0.3 m, f/1.4 (8 mm)", {"focus_distance": 0.3, "f_number": 1.4}),
    ("focus 0.3 m, f/1.4, full_well 2000 e",
     {"focus_distance": 0.3, "f_number": 1.4, "full_well": 2000.0}),
    ("jpeg_quality 100", {"jpeg_quality": 100}),
    ("jpeg_quality 75", {"jpeg_quality": 75}),
    ("jpeg_quality 30", {"jpeg_quality": 30}),
    ("jpeg_quality 10", {"jpeg_quality": 10}),
]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2, help="render seeds per row")
    args = parser.parse_args(argv)

    from rasc.sim.render import RenderOptions, view_image
    from rasc.sim.scene import StereoHeadSim, T_base_from_world_facing
    from rasc.vision.board import Board
    from rasc.vision.camera import detect_corners

    board = Board((9, 6), 0.05)
    print("| degradation | corner RMS (px) | views without the board |")
    print("|---|---|---|")
    with StereoHeadSim(board=board) as sim:
        sim.set_target(T_base_from_world_facing(board, distance=1.0))
        for label, fields in ROWS:
            errors, missed = [], 0
            for seed in range(args.seeds):
                options = RenderOptions(seed=seed, **fields).validate()
                rng = np.random.default_rng(seed)
                for pan, tilt in PAPER_POSES_DEG:
                    for eye in ("left", "right"):
                        sim.set_angles(eye, np.radians(pan), np.radians(tilt))
                        image = view_image(sim, eye, {}, rng, options)
                        c = detect_corners(image, board, "saddle")
                        if c is None or not np.isfinite(c).all():
                            missed += 1
                            continue
                        errors.append(c - sim.project_world_points(eye, board.object_points()))
            e = np.concatenate(errors)
            rms = float(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))
            print(f"| {label} | {rms:.4f} | {missed} of {18 * args.seeds} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
