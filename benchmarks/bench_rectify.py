"""Rectification at any gaze beside OpenCV's for a fixed rig, as ratios measured side by side.

    .venv/bin/python benchmarks/bench_rectify.py [--repeat 60]
        [--markdown docs/results/rectify_speed.md]

The head: the simulated stock head's truth (rasc.sim.scene.StereoHeadSim, 1280×960) with
lens distortion k1 = −0.2, k2 = 0.05 added to both eyes. The gaze: left pan −12°, tilt
5°, right pan 10°, tilt 6° (readings). Rows:

* the maps for one gaze: :func:`rasc.stereo.rectify.rectify_head` (both eyes' poses from
  the readings, the relative pose, ``cv2.stereoRectify``, two
  ``cv2.initUndistortRectifyMap``) against OpenCV's ``stereoRectify`` and two
  ``initUndistortRectifyMap`` for a fixed rig whose ``R, T`` are given (the same
  cameras); for each remap-table type (the issue's goal: at most 1.2× OpenCV's);
* the geometry alone (``maps=False``) against ``stereoRectify`` alone: the cost of the
  head's kinematics, which the maps hide;
* rectifying a 1280×960 grey pair once the maps exist:
  :func:`rasc.stereo.rectify.rectify_images` against two ``cv2.remap``.

Each pair of functions is timed alternately in blocks (bench_handeye's
``median_times``, on this process's CPU clock, which counts OpenCV's threads too and
which other processes' load does not inflate); the medians and their ratio are printed.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rasc.geometry.kinematics import PanTiltUnit  # noqa: E402
from rasc.geometry.transforms import invert_transform  # noqa: E402
from rasc.head.model import EyeCalibration, HeadCalibration  # noqa: E402
from rasc.stereo.rectify import (  # noqa: E402
    MAP_TYPES,
    RectifyOptions,
    rectify_head,
    rectify_images,
)

DIST = (-0.2, 0.05, 0.0, 0.0, 0.0)
READINGS_DEG = {"left": (-12.0, 5.0), "right": (10.0, 6.0)}


def stock_head() -> HeadCalibration:
    """The simulated head's truth, with :data:`DIST` on both lenses."""
    from rasc.sim.scene import StereoHeadSim

    with StereoHeadSim() as sim:
        gt = sim.ground_truth()
    return HeadCalibration(**{eye: EyeCalibration(
        K=np.array(gt[eye]["K"]), dist=np.array(DIST),
        T_cam_from_gaze=np.array(gt[eye]["T_cam_from_gaze"]),
        T_ptu_from_base=np.array(gt[eye]["T_ptu_from_base"]),
        image_size=tuple(gt[eye]["image_size"]), unit=PanTiltUnit.from_dict(gt[eye]["unit"]))
        for eye in ("left", "right")})


def side_by_side(fns: dict, repeat: int, block: int = 5) -> dict[str, float]:
    from bench_handeye import median_times

    return dict(zip(fns, median_times(list(fns.values()), repeat, block,
                                      clock=time.process_time), strict=True))


def main(argv=None) -> int:
    from _markdown import add_markdown_option  # for --help (run_main takes it off)

    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--repeat", type=int, default=60,
                   help="calls per function (default 60)")
    add_markdown_option(p)
    args = p.parse_args(argv)
    head = stock_head()
    left, right = (tuple(np.radians(READINGS_DEG[e])) for e in ("left", "right"))
    T = {e: getattr(head, e).T_cam_from_base(*np.radians(READINGS_DEG[e]))
         for e in ("left", "right")}
    T_rl = T["right"] @ invert_transform(T["left"])
    R, t = T_rl[:3, :3].copy(), T_rl[:3, 3].reshape(3, 1).copy()
    K1, K2, d1, d2 = head.left.K, head.right.K, head.left.dist, head.right.dist
    size = head.left.image_size

    def opencv(kind=None):
        R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(K1, d1, K2, d2, size, R, t,
                                                    flags=cv2.CALIB_ZERO_DISPARITY, alpha=-1)
        if kind is not None:
            cv2.initUndistortRectifyMap(K1, d1, R1, P1, size, kind)
            cv2.initUndistortRectifyMap(K2, d2, R2, P2, size, kind)

    print(f"OpenCV {cv2.__version__}, {cv2.getNumThreads()} threads; image {size[0]}×{size[1]}; "
          f"median CPU time of {args.repeat} calls each\n")
    print("| what | rasc ms | OpenCV ms | ratio |")
    print("| --- | ---: | ---: | ---: |")
    rows = []
    for name, kind in MAP_TYPES.items():
        options = RectifyOptions(map_type=name)
        tm = side_by_side({"rasc": lambda o=options: rectify_head(head, left, right, o),
                           "cv": lambda k=kind: opencv(k)}, args.repeat)
        rows.append((f"maps for one gaze ({name} tables)", tm))
    tm = side_by_side({"rasc": lambda: rectify_head(head, left, right, maps=False),
                       "cv": lambda: opencv(None)}, max(args.repeat, 200))
    rows.append(("geometry alone (R1, R2, P1, P2, Q)", tm))
    rect = rectify_head(head, left, right)
    rng = np.random.default_rng(0)
    pair = [rng.integers(0, 256, (size[1], size[0]), dtype=np.uint8) for _ in range(2)]
    (m1l, m2l), (m1r, m2r) = rect.maps["left"], rect.maps["right"]
    tm = side_by_side({"rasc": lambda: rectify_images(rect, *pair),
                       "cv": lambda: (cv2.remap(pair[0], m1l, m2l, cv2.INTER_LINEAR),
                                      cv2.remap(pair[1], m1r, m2r, cv2.INTER_LINEAR))},
                      args.repeat)
    rows.append(("rectify a 1280×960 pair, maps given (remap)", tm))
    for name, tm in rows:
        print(f"| {name} | {1e3 * tm['rasc']:.3f} | {1e3 * tm['cv']:.3f} | "
              f"{tm['rasc'] / tm['cv']:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    from _markdown import run_main

    raise SystemExit(run_main(main, "Rectification at any gaze: time beside OpenCV's",
                              __file__))
