"""Target detection on renders: chessboard, ChArUco and AprilGrid at 0°, ±8° and ±30°.

    python benchmarks/bench_targets.py [--out DIR] [--seed S] [--repeat N]

Renders (``rasc.sim.render.render_dataset``, 1280×960, board 1 m ahead, no noise) the
default 9×6 chessboard of 50 mm squares at (0, 0) and (±8°, ±8°) (it leaves the image at
±30°), a 12×9 ChArUco board of 60 mm squares with 45 mm markers and a 7×5 AprilGrid of
80 mm tags with spacing 0.3 (about the ChArUco board's size) at (0, 0), (±8°, ±8°) and
(±30°, 0), and prints for each pose image: the corners found against those inside the
image (the renderer's truth), their RMS and largest distance to the truth, and the
median detection time over ``--repeat`` runs (``detect_corners`` with the
calibration's default detector, ``saddle``, for the chessboard).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

POSES = ((0, 0), (8, 8), (-8, -8), (30, 0), (-30, 0))


def main(argv=None) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--out", default=None, help="render folder (default: a temporary one)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--repeat", type=int, default=5)
    args = p.parse_args(argv)
    import cv2
    import numpy as np

    from rasc.geometry.lens import project_points
    from rasc.sim.render import RenderOptions, render_dataset
    from rasc.vision.board import DEFAULT_BOARD, AprilGrid, CharucoBoard
    from rasc.vision.camera import detect_corners

    targets = {"chessboard 9x6, 50 mm": DEFAULT_BOARD,
               "ChArUco 12x9, 60/45 mm": CharucoBoard((12, 9), 0.06, 0.045),
               "AprilGrid 7x5, 80 mm, 0.3": AprilGrid((7, 5), 0.08, 0.3)}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.out or tmp)
        print("| target | pan, tilt | eye | found / in image | RMS vs truth | max | time |")
        print("| --- | --- | --- | --- | --- | --- | --- |")
        for name, board in targets.items():
            poses = POSES if board.partial_views else POSES[:3]
            d = root / f"{board.type}_{args.seed}"
            if not (d / "manifest.json").exists():
                render_dataset(d, RenderOptions(seed=args.seed, intrinsics_views=3,
                                                poses_deg=poses), quiet=True, board=board)
            truth = json.loads((d / "ground_truth.json").read_text())
            for k, pose in enumerate(poses):
                for eye in ("left", "right"):
                    f = f"poses/{eye}_{k:02d}.png"
                    img = cv2.imread(str(d / f), cv2.IMREAD_GRAYSCALE)
                    times = []
                    for _ in range(args.repeat):
                        t0 = time.perf_counter()
                        c = detect_corners(img, board, method="saddle")
                        times.append(time.perf_counter() - t0)
                    v = truth["views"][f]
                    if "corners" in v:      # a target seen in part: truth by id
                        ids, uv = np.array(v["corners"]["ids"]), np.array(v["corners"]["uv"])
                    else:                   # the chessboard: project every corner
                        T = np.array(v["T_cam_from_world"])
                        P = board.object_points() @ T[:3, :3].T + T[:3, 3]
                        uv = project_points(P, np.array(truth[eye]["K"]), None)
                        ids = np.arange(len(uv))
                    ms = f"{1e3 * np.median(times):.0f} ms"
                    if c is None:
                        print(f"| {name} | {pose} | {eye} | 0 / {len(ids)} | — | — | {ms} |")
                        continue
                    seen = np.flatnonzero(np.isfinite(c[:, 0]))
                    at = dict(zip(ids.tolist(), uv, strict=True))
                    e = np.array([np.linalg.norm(c[i] - at[i]) for i in seen])
                    print(f"| {name} | {pose} | {eye} | {len(seen)} / {len(ids)} | "
                          f"{np.sqrt(np.mean(e ** 2)):.3f} px | {e.max():.3f} px | {ms} |",
                          flush=True)
    return 0


if __name__ == "__main__":
    from _markdown import run_main

    raise SystemExit(run_main(main, "Target detection on renders: chessboard, ChArUco, "
                                    "AprilGrid", __file__))
