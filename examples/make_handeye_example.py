"""Generate ``examples/handeye_nine_poses.json``, the README's ``rasc handeye`` example.

A camera sits on a pan-tilt unit with a known ``T_cam_from_gaze`` (a few centimetres off
the unit's centre, its axes 1–3° off the ideal "looking along the gaze" mounting). It
views a chessboard about 1 m ahead at the paper's nine positions
(:data:`rasc.geometry.kinematics.PAPER_POSES_DEG`, ±8°). The document holds the commanded
pan/tilt (round degrees) and each ``T_cam_from_world`` as a camera calibration would
report it, with realistic noise:

- the unit reaches the commanded angles only to its encoder resolution: the true
  angles carry N(0, 0.01°) errors (a FLIR PTU-46 step is 0.013°);
- each extrinsic carries the paper's noise model, eq. 13–14 in exponential form, with
  σ_r = 0.0005 rad (0.03°) and σ_t = 0.5 mm, the size of ``solvePnP`` errors for a
  9×6 board at 1 m (docs/NOTES.md: 0.01–0.04° and 0.5–0.8 mm end to end).

Usage (from the repository root)::

    python examples/make_handeye_example.py            # rewrites the example, prints truth
    python examples/make_handeye_example.py --out other.json --seed 1

Lengths are metres, angles degrees.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu
from rasc.geometry.transforms import (
    invert_transform,
    make_transform,
    matrix_from_rotvec,
    rotation_angle,
)
from rasc.io import write_text_atomic

DEFAULT_OUT = "examples/handeye_nine_poses.json"
SIGMA_R_RAD = 5e-4
SIGMA_T_M = 5e-4
SIGMA_ENCODER_DEG = 0.01

#: The ideal mounting: camera +z (optical axis) along gaze +y (forward), camera +x
#: (right) along gaze −z (z is left), camera +y (down) along gaze −x (x is up).
#: Columns are the camera axes in gaze coordinates (R_gaze_from_cam).
R_GAZE_FROM_CAM_IDEAL = np.array([[0.0, -1.0, 0.0],
                                  [0.0, 0.0, 1.0],
                                  [-1.0, 0.0, 0.0]])


def true_T_cam_from_gaze() -> np.ndarray:
    """The example's ground truth, (4, 4), metres.

    The camera centre sits 42 mm above, 31 mm in front of and 65 mm left of the unit's
    centre (``t_gaze_from_cam``, gaze axes x up, y forward, z left); its axes are
    turned 2.1° off the ideal mounting about a fixed oblique axis.
    """
    misalign = matrix_from_rotvec(np.radians(2.1) * np.array([0.48, -0.6, 0.64]))
    R_gaze_from_cam = R_GAZE_FROM_CAM_IDEAL @ misalign
    t_gaze_from_cam = np.array([0.042, 0.031, 0.065])
    return invert_transform(make_transform(R_gaze_from_cam, t_gaze_from_cam))


def _true_T_ptu_from_world() -> np.ndarray:
    """The board about 1 m ahead, seen face-on and upright at home, slightly turned."""
    # At home (gaze = ptu) the camera sees the board's origin (a corner) up-left of the
    # image centre, so that a 9×6, 50 mm board is centred, 1.0 m deep, turned by 3°.
    R_cam_from_world = matrix_from_rotvec(np.radians([2.0, -3.0, 1.0]))
    t_cam_from_world = np.array([-0.2, -0.125, 1.0])
    T_cam_from_world_home = make_transform(R_cam_from_world, t_cam_from_world)
    return invert_transform(true_T_cam_from_gaze()) @ T_cam_from_world_home


def _perturb(T: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Eq. 13–14, exponential form: R' = R exp([ω]x), t' = t + δ."""
    omega = rng.normal(0.0, SIGMA_R_RAD, 3)
    delta = rng.normal(0.0, SIGMA_T_M, 3)
    return make_transform(T[:3, :3] @ matrix_from_rotvec(omega), T[:3, 3] + delta)


def make_document(seed: int = 0) -> dict:
    """The ``rasc-handeye/1`` document for ``seed`` (deterministic)."""
    rng = np.random.default_rng(seed)
    T_cam_from_gaze = true_T_cam_from_gaze()
    T_ptu_from_world = _true_T_ptu_from_world()
    positions = []
    for pan, tilt in PAPER_POSES_DEG:
        pan_true, tilt_true = np.radians(np.array([pan, tilt])
                                         + rng.normal(0.0, SIGMA_ENCODER_DEG, 2))
        T_cw = T_cam_from_gaze @ T_gaze_from_ptu(pan_true, tilt_true) @ T_ptu_from_world
        T_cw = _perturb(T_cw, rng)
        positions.append({"pan": pan, "tilt": tilt,
                          "T_cam_from_world": np.round(T_cw, 9).tolist()})
    t = T_cam_from_gaze[:3, 3]
    return {
        "format": "rasc-handeye/1",
        "description": (
            f"made by examples/make_handeye_example.py --seed {seed}: board 1 m ahead, "
            f"paper's nine positions, encoder noise {SIGMA_ENCODER_DEG} deg, extrinsics "
            f"noise eq. 13-14 sigma_r {SIGMA_R_RAD} rad, sigma_t {SIGMA_T_M} m; true "
            f"t_cam_from_gaze ({t[0]:.4f}, {t[1]:.4f}, {t[2]:.4f}) m"),
        "angle_unit": "deg",
        "length_unit": "m",
        "positions": positions,
    }


def format_document(doc: dict) -> str:
    """Readable, deterministic JSON: one position per block, one matrix row per line."""
    head = {k: v for k, v in doc.items() if k != "positions"}
    lines = ["{"]
    lines += [f"  {json.dumps(k)}: {json.dumps(v)}," for k, v in head.items()]
    lines.append('  "positions": [')
    for k, pos in enumerate(doc["positions"]):
        rows = ",\n      ".join(json.dumps(row) for row in pos["T_cam_from_world"])
        comma = "," if k < len(doc["positions"]) - 1 else ""
        lines.append(f'    {{"pan": {json.dumps(pos["pan"])}, "tilt": {json.dumps(pos["tilt"])},'
                     f'\n     "T_cam_from_world": [{rows}]}}{comma}')
    lines += ["  ]", "}"]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=DEFAULT_OUT)
    args = parser.parse_args(argv)
    write_text_atomic(args.out, format_document(make_document(args.seed)))
    T = true_T_cam_from_gaze()
    misalign_deg = np.degrees(rotation_angle(R_GAZE_FROM_CAM_IDEAL.T @ T[:3, :3].T))
    print(f"wrote {args.out}")
    print("true T_cam_from_gaze (metres):")
    print(np.array2string(T, precision=6, suppress_small=True))
    print(f"t_cam_from_gaze = {np.round(T[:3, 3] * 1000, 3).tolist()} mm; "
          f"rotation {misalign_deg:.3f} deg off the ideal mounting")
    return 0


if __name__ == "__main__":
    sys.exit(main())
