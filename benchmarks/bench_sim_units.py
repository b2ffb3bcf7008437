"""Imperfect simulated units: the ground-truth check's worst disagreement and render time.

    .venv/bin/python benchmarks/bench_sim_units.py [--seed 0] [--repeat 1] [--json FILE]

Renders the default dataset (20 intrinsics views per eye, the paper's nine positions) with
(a) the stock, ideal units and (b) both units imperfect as in issue 10 (tilt axis 30 mm
off the pan axis, 1° non-orthogonality, 0.5° pan and tilt encoder zero offsets), and
reports for each the wall time and the largest element of
``T_cam_from_gaze · unit.T_gaze_from_ptu(readings) · T_ptu_from_base − T_cam_from_base``
(MuJoCo's camera frame) over every rendered view and both eyes, as the renderer checks it
(it refuses anything above 1e-9).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from _markdown import run_main  # noqa: E402

from rasc.sim.render import RenderOptions, render_dataset  # noqa: E402
from rasc.sim.scene import StereoHeadSim  # noqa: E402
from rasc.sim.units import UnitBuild  # noqa: E402

ISSUE_10 = UnitBuild(tilt_axis_offset_mm=(0.0, 30.0, 0.0), axis_skew_deg=1.0,
                     pan_zero_deg=0.5, tilt_zero_deg=0.5)


def run(units, seed: int) -> dict:
    worst = {"value": 0.0, "checks": 0}
    original = StereoHeadSim.check_ground_truth

    def recording(self, eye, where=""):
        value = original(self, eye, where)
        worst["value"] = max(worst["value"], value)
        worst["checks"] += 1
        return value

    StereoHeadSim.check_ground_truth = recording
    try:
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            render_dataset(Path(tmp) / "ds", RenderOptions(seed=seed), quiet=True, units=units)
            seconds = time.perf_counter() - t0
    finally:
        StereoHeadSim.check_ground_truth = original
    return {"seconds": seconds, "worst_disagreement": worst["value"], "checks": worst["checks"]}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--json", metavar="FILE")
    args = p.parse_args(argv)
    results = {}
    for name, units in (("ideal", None), ("issue10", {"left": ISSUE_10, "right": ISSUE_10})):
        runs = [run(units, args.seed) for _ in range(args.repeat)]
        results[name] = {"seconds": [r["seconds"] for r in runs],
                         "worst_disagreement": max(r["worst_disagreement"] for r in runs),
                         "checks": runs[0]["checks"]}
        r = results[name]
        print(f"{name:8s} render {min(r['seconds']):6.2f} s (best of {args.repeat}); ground "
              f"truth vs MuJoCo, worst element {r['worst_disagreement']:.2e} over "
              f"{r['checks']} checks")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(run_main(main, "Imperfect simulated units: ground-truth check and render time",
                      __file__))
