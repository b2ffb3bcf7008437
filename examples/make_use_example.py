"""Generate ``examples/use/``, the README's "Using a calibration" example.

A head with known parameters, in the shape of the simulated one (baseline 0.3 m, f ≈ 1000
px, 1280×960 images, mild barrel distortion, cameras a few centimetres and about a degree
off the ideal mounting):

- ``calibration.json``: the head as ``rasc calibrate`` would write it
  (``rasc-calibration/1``: ``length_unit``, the ``head`` model, and each eye's pose views
  at the paper's nine positions, ±8°, which record the calibrated joint range). Only what
  ``rasc.load_calibration`` reads is written; it is the truth, not a measurement.
- ``pixels.csv``: four base-frame points 1.6–1.9 m ahead (:data:`POINTS`), each eye
  turned towards them (angles in degrees), their exact distorted pixels to 1e-6 px: the
  input of ``rasc triangulate``, which must return :data:`POINTS`.
- ``points.csv``: the same points and angles for ``rasc project``.

Usage (from the repository root)::

    python examples/make_use_example.py            # rewrites examples/use/
    python examples/make_use_example.py --out DIR

Lengths are metres, angles degrees.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from rasc.geometry.kinematics import PAPER_POSES_DEG
from rasc.geometry.transforms import make_transform, matrix_from_rotvec
from rasc.head.base_to_ptu import T_ptuL_from_ptuR_from_mounts, cyclopean_base
from rasc.head.model import EyeCalibration, HeadCalibration
from rasc.io import dumps_json, write_text_atomic

HERE = Path(__file__).resolve().parent / "use"

#: Nominal camera on a gaze frame (x up, y forward, z left): optical axis = gaze +y.
R_CAM_FROM_GAZE_NOMINAL = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])

#: The example's base-frame points (m): x up, y forward, z left.
POINTS = np.array([[0.10, 1.60, 0.05], [-0.05, 1.70, -0.10], [0.00, 1.80, 0.20],
                   [0.15, 1.90, -0.15]])
#: The angles (deg) each eye is turned to for each point: (pan, tilt), left then right;
#: within the calibrated ±8° (outside it rasc triangulate and project warn).
ANGLES_DEG = np.array([[4.0, 3.0, -5.0, 3.0], [-1.0, -2.0, -8.0, -2.0], [7.0, 0.0, 2.0, 0.0],
                       [-2.0, 4.0, -7.5, 4.0]])


def make_head() -> HeadCalibration:
    """The example head (the truth)."""
    T_LR = T_ptuL_from_ptuR_from_mounts([0.002, -0.001, -0.300], np.radians([0.3, -0.2, 0.5]))
    T_pb = cyclopean_base(T_LR)
    eyes = []
    for k, (f, cx, cy, dist, rv, t) in enumerate((
            (1000.0, 641.2, 478.3, [-0.12, 0.05, 0.0, 0.0], [0.010, -0.015, 0.005],
             [0.031, 0.042, -0.018]),
            (1004.0, 637.9, 481.1, [-0.11, 0.04, 0.0, 0.0], [-0.012, 0.008, 0.011],
             [0.029, 0.040, 0.021]))):
        K = np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])
        T_cg = make_transform(R_CAM_FROM_GAZE_NOMINAL @ matrix_from_rotvec(rv), t)
        eyes.append(EyeCalibration(K, dist, T_cg, T_pb[k], (1280, 960)))
    return HeadCalibration(*eyes)


def calibration_document(head: HeadCalibration) -> dict:
    views = [{"view": f"{i:02d}", "pan_deg": p, "tilt_deg": t}
             for i, (p, t) in enumerate(PAPER_POSES_DEG)]
    return {"format": "rasc-calibration/1", "length_unit": "m",
            "description": "known parameters, written by examples/make_use_example.py",
            "head": head.to_dict(),
            "eyes": {e: {"pose_views": views} for e in ("left", "right")}}


def _csv(header: list[str], rows: list[list[str]]) -> str:
    return "\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n"


def make_files() -> dict[str, str]:
    """File name → text."""
    head = make_head()
    a = np.radians(ANGLES_DEG)
    uv_l = head.left.project(POINTS, a[:, 0], a[:, 1])
    uv_r = head.right.project(POINTS, a[:, 2], a[:, 3])
    angle_cells = [[f"{x:g}" for x in row] for row in ANGLES_DEG]
    labels = [f"p{i}" for i in range(len(POINTS))]
    pixels = _csv(["label", "u_left", "v_left", "u_right", "v_right", "pan_left", "tilt_left",
                   "pan_right", "tilt_right"],
                  [[labels[i]] + [f"{x:.6f}" for x in (*uv_l[i], *uv_r[i])] + angle_cells[i]
                   for i in range(len(POINTS))])
    points = _csv(["label", "x", "y", "z", "pan_left", "tilt_left", "pan_right", "tilt_right"],
                  [[labels[i]] + [f"{x:g}" for x in POINTS[i]] + angle_cells[i]
                   for i in range(len(POINTS))])
    return {"calibration.json": dumps_json(calibration_document(head)),
            "pixels.csv": pixels, "points.csv": points}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(HERE), help="folder (default examples/use)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in make_files().items():
        write_text_atomic(out / name, text)
    print(f"wrote {', '.join(make_files())} to {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
