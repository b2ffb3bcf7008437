"""Import speed of ``rasc import`` on a bag of realistic size, and the calibration from an
imported bag against the rendered dataset's.

    .venv/bin/python benchmarks/bench_import.py [--kinds ros1,ros2-sqlite3,ros2-mcap]
        [--encoding mono8] [--positions 20] [--work DIR]

1. Renders (or finds in the rasc.testing cache) the default dataset's geometry with 8
   intrinsics views per eye (1280x960 images).
2. Speed: plays ``--positions`` pan-tilt positions (the paper's nine in turn) into a bag
   per kind, at 2 images per second per eye (3 images per position: 1 while moving,
   2 at rest) and 100 Hz joint states: 20 positions give 2 x 60 images and 3000 joint
   messages (~147 MB of raw mono8). Times :func:`rasc.recordings.import_bag` (scan,
   pairing, reading back and decoding the chosen images, writing PNGs and the manifest;
   the page cache is warm: the bag was just written) and prints MB of bag per second of
   wall time and of this process's CPU time.
3. Calibration: plays the nine positions once (one capture per position), imports, and
   calibrates; prints the largest differences from the rendered dataset's calibration
   (K, T_cam_from_gaze, T_ptu_from_base of both eyes).
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("MUJOCO_GL", "egl")

from rasc.recordings import ImportConfig, JointSource, import_bag  # noqa: E402
from rasc.recordings.synth import (  # noqa: E402
    JOINT_NAMES,
    JOINT_TOPIC,
    TOPICS,
    write_intrinsics_recording,
    write_recording,
)


def _config() -> ImportConfig:
    return ImportConfig(board={"inner_corners": [9, 6], "square_size": 0.05}, length_unit="m",
                        topics=dict(TOPICS),
                        joints={e: JointSource(JOINT_TOPIC, *JOINT_NAMES[e])
                                for e in ("left", "right")})


def _err(T1, T2):
    d = np.linalg.inv(T1) @ T2
    return (math.degrees(math.acos(np.clip((np.trace(d[:3, :3]) - 1) / 2, -1, 1))),
            float(np.linalg.norm(d[:3, 3])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", default="ros1,ros2-sqlite3,ros2-mcap")
    ap.add_argument("--encoding", default="mono8")
    ap.add_argument("--positions", type=int, default=20)
    ap.add_argument("--work", help="folder for the bags (default: a temporary one)")
    args = ap.parse_args()
    from rasc.head.pipeline import calibrate_dataset
    from rasc.testing import render_cached
    from rasc.vision.dataset import load_dataset

    cache = os.environ.get("RASC_CACHE_DIR") or str(Path(tempfile.gettempdir()) / "rasc-bench")
    small = render_cached(cache, intrinsics_views=8).load()
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="bench-import-"))
    work.mkdir(parents=True, exist_ok=True)
    cfg = _config()
    try:
        intr = write_intrinsics_recording(small, work / "intrinsics.bag", encoding="png")
        print(f"bag: {args.positions} positions, 2 images/s per eye, 100 Hz joint states, "
              f"{args.encoding} 1280x960")
        for kind in args.kinds.split(","):
            bag = work / ("pose.bag" if kind == "ros1" else f"pose-{kind}")
            write_recording(small, bag, kind=kind, encoding=args.encoding,
                            positions=args.positions, image_rate_hz=2.0, still_s=1.0,
                            move_s=0.5)
            out = work / f"ds-{kind}"
            c0, t0 = time.process_time(), time.perf_counter()
            res = import_bag(bag, out, cfg)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            mb = res.bytes_read / 1e6
            print(f"{kind:13s} {mb:7.1f} MB, {res.n_pose // 2} captures: {wall:5.2f} s wall "
                  f"({mb / wall:6.1f} MB/s), {cpu:5.2f} s CPU ({mb / cpu:6.1f} MB/s)")
            shutil.rmtree(out)
            shutil.rmtree(bag) if bag.is_dir() else bag.unlink()
        # calibration: the nine positions once, against the rendered dataset
        ref = calibrate_dataset(small)
        bag = work / "nine.bag"
        write_recording(small, bag, kind="ros1", encoding=args.encoding, image_rate_hz=2.0)
        import_bag(bag, work / "ds-nine", cfg, intrinsics=intr)
        cal = calibrate_dataset(load_dataset(work / "ds-nine"))
        for eye in ("left", "right"):
            a, b = getattr(cal.head, eye), getattr(ref.head, eye)
            he = _err(a.T_cam_from_gaze, b.T_cam_from_gaze)
            pb = _err(a.T_ptu_from_base, b.T_ptu_from_base)
            dk = np.max(np.abs(a.K - b.K))
            print(f"calibration from the bag vs the rendered dataset, {eye}: K {dk:.3g} px, "
                  f"T_cam_from_gaze {he[0]:.3g} deg {he[1]:.3g} m, "
                  f"T_ptu_from_base {pb[0]:.3g} deg {pb[1]:.3g} m")
    finally:
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
