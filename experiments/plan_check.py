"""Check ``rasc plan``'s prediction (issue 23): predicted σ against the spread of repeated
captures, and planned positions against the paper's nine and random positions.

For each position set — planned (greedy D-optimal, 2° grid), the paper's nine, and nine
drawn at random from the same usable candidates (seeded) — ``--captures`` captures of the
nominal head (:func:`rasc.sim.synthetic.default_head`) are projected with
``NOISE_PX`` Gaussian corner noise (``rasc.sim.synthetic.corner_dataset``, each capture
its own seed: its own intrinsics views and noise), calibrated by the pipeline with the
whole-head refinement (scales held, as planned), and the hand-eye translation error (mm,
against the truth in the canonical gauge) and axis-distance error are measured. The
measured RMS over captures is set beside the predicted σ (root sum of the three
components' σ for the translation). Projected corners, not renders: the prediction's
noise model is then exact, so the comparison tests the prediction itself.

    python experiments/plan_check.py [--captures N] [--out DIR]

Writes ``<out>/plan_check/plan_check.csv`` and prints it.
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
NOISE_PX = 0.05
EYES = ("left", "right")


def measure(poses, seed: int) -> dict:
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.sim.synthetic import corner_dataset, default_head

    ds = corner_dataset(default_head(), seed=seed, noise_px=NOISE_PX, poses_deg=poses)
    cal = calibrate_dataset(ds, CalibrationOptions(model="general", scales="hold"))
    out = {}
    for eye in EYES:
        T = getattr(cal.head, eye).T_cam_from_gaze
        out[f"{eye}.handeye_translation_mm"] = 1e3 * float(
            np.linalg.norm(T[:3, 3] - ds.truth.T_cam_from_gaze[eye][:3, 3]))
        out[f"{eye}.axis_distance_mm"] = 1e3 * float(
            cal.refinement.parameters[eye]["unit.tilt_point_y"]["value"])
    return out


def main(argv=None) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--captures", type=int, default=8)
    p.add_argument("--out", type=Path, default=REPO / "out")
    args = p.parse_args(argv)
    from rasc.geometry.kinematics import PAPER_POSES_DEG
    from rasc.io import write_text_atomic
    from rasc.plan import _Information, candidate_grid, nominal_setup, plan, predict

    setup = nominal_setup(noise_px=NOISE_PX)
    planned = plan(setup, 9, workspace_depth=None)
    info = _Information(setup, candidate_grid(setup))
    rng = np.random.default_rng(1)
    random9 = [tuple(map(float, info.feasible[i]))
               for i in rng.choice(len(info.feasible), 9, replace=False)]
    sets = {"planned": planned.positions, "paper": list(PAPER_POSES_DEG), "random": random9}
    rows = []
    for name, poses in sets.items():
        pred = predict(setup, poses, info=info, workspace_depth=None).summary
        meas = [measure(poses, 100 + s) for s in range(args.captures)]
        for key in ("left.handeye_translation_mm", "right.handeye_translation_mm",
                    "left.axis_distance_mm", "right.axis_distance_mm"):
            v = np.array([m[key] for m in meas])
            rms = float(np.sqrt(np.mean(v ** 2)))
            rows.append([name, key, f"{pred[key]:.4g}", f"{rms:.4g}",
                         f"{rms / pred[key]:.3f}", args.captures,
                         ";".join(f"{a:g},{b:g}" for a, b in poses)])
            print(f"{name:8s} {key:30s} predicted {pred[key]:.4g} measured RMS {rms:.4g} "
                  f"(ratio {rms / pred[key]:.2f})", file=sys.stderr, flush=True)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["positions", "quantity", "predicted_sigma", "measured_rms", "ratio",
                "captures", "positions_deg"])
    w.writerows(rows)
    folder = args.out / "plan_check"
    folder.mkdir(parents=True, exist_ok=True)
    write_text_atomic(folder / "plan_check.csv", buf.getvalue())
    print(buf.getvalue())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
