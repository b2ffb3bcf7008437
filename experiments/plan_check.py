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

    python experiments/plan_check.py [--captures N] [--out DIR] [--rendered]

``--rendered``: each capture is rendered instead (``rasc.sim.render.render_dataset``,
its own seed, Gaussian pixel noise of ``RENDER_NOISE`` grey levels so that the corner
errors differ between captures) and calibrated from its images; the prediction is made
for the renderer's true head (its ground truth) with the corner noise the refinement
measured on the first capture (``sigma_px``), as a user would.

Writes ``<out>/plan_check/plan_check.csv`` and prints it.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
NOISE_PX = 0.05
RENDER_NOISE = 2.0            # grey levels
EYES = ("left", "right")


def measure_rendered(poses, seed: int) -> dict:
    import tempfile

    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.sim.render import RenderOptions, render_dataset
    from rasc.vision.dataset import load_dataset

    with tempfile.TemporaryDirectory(prefix="rasc-plan-check-") as tmp:
        render_dataset(Path(tmp) / "ds", RenderOptions(seed=seed, poses_deg=tuple(poses),
                                                       image_noise=RENDER_NOISE), quiet=True)
        ds = load_dataset(Path(tmp) / "ds")
        truth = ds.load_ground_truth()
        cal = calibrate_dataset(ds, CalibrationOptions(model="general", scales="hold"))
    out = {"sigma_px": cal.refinement.sigma, "truth": truth}
    for eye in EYES:
        out[f"{eye}.handeye_translation_mm"] = \
            1e3 * cal.errors[eye]["T_cam_from_gaze"]["translation"]
        out[f"{eye}.axis_distance_mm"] = 1e3 * float(
            cal.refinement.parameters[eye]["unit.tilt_point_y"]["value"])
    return out


def head_from_truth(truth: dict):
    """The renderer's true head (canonical gauge) as the planner's head model."""
    from rasc.geometry.kinematics import PanTiltUnit, canonical_gauge
    from rasc.sim.synthetic import SyntheticHead

    parts = {}
    for eye in EYES:
        t = truth[eye]
        parts[eye] = canonical_gauge(PanTiltUnit.from_dict(t["unit"]),
                                     np.asarray(t["T_cam_from_gaze"], float),
                                     np.asarray(t["T_ptu_from_base"], float))
    return SyntheticHead(K={e: np.asarray(truth[e]["K"], float) for e in EYES},
                         dist={e: np.asarray(truth[e]["dist"], float) for e in EYES},
                         T_cam_from_gaze={e: parts[e][1] for e in EYES},
                         T_ptu_from_base={e: parts[e][2] for e in EYES},
                         unit={e: parts[e][0] for e in EYES})


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
    p.add_argument("--rendered", action="store_true", help="render the captures")
    args = p.parse_args(argv)
    from rasc.geometry.kinematics import PAPER_POSES_DEG
    from rasc.io import write_text_atomic
    from rasc.plan import _Information, candidate_grid, nominal_setup, plan, predict

    setup = nominal_setup(noise_px=NOISE_PX)
    first = None
    if args.rendered:
        from rasc.plan import PlanSetup
        from rasc.vision.board import DEFAULT_BOARD

        first = measure_rendered(PAPER_POSES_DEG, 100)
        setup = PlanSetup(head=head_from_truth(first["truth"]), board=DEFAULT_BOARD,
                          noise_px=first["sigma_px"])
        print(f"rendered: corner noise measured by the refinement {first['sigma_px']:.4f} "
              "px", file=sys.stderr, flush=True)
    planned = plan(setup, 9, workspace_depth=None)
    info = _Information(setup, candidate_grid(setup))
    rng = np.random.default_rng(1)
    random9 = [tuple(map(float, info.feasible[i]))
               for i in rng.choice(len(info.feasible), 9, replace=False)]
    sets = {"planned": planned.positions, "paper": list(PAPER_POSES_DEG), "random": random9}
    rows = []
    for name, poses in sets.items():
        pred = predict(setup, poses, workspace_depth=None).summary
        if args.rendered:
            meas = [first if (name == "paper" and s == 0) else measure_rendered(poses, 100 + s)
                    for s in range(args.captures)]
        else:
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
    from rasc.study.summary import csv_text  # rasc's one CSV writer
    text = csv_text(["positions", "quantity", "predicted_sigma", "measured_rms", "ratio",
                     "captures", "positions_deg"], rows, field=str)
    folder = args.out / ("plan_check_rendered" if args.rendered else "plan_check")
    folder.mkdir(parents=True, exist_ok=True)
    write_text_atomic(folder / "plan_check.csv", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
