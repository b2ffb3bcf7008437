"""Pipeline benchmark: ``rasc render`` + ``rasc calibrate`` of the default dataset, per
stage, with the accuracy against the renderer's ground truth and what limits it.

    .venv/bin/python benchmarks/bench_pipeline.py [--seed 0] [--distance 1.0]
        [--intrinsics-views 20] [--sweep] [--sweep-seeds 3] [--json FILE]

1. Wall time per stage on one dataset (rendering, detection, intrinsics, extrinsics,
   hand-eye solve, base-to-ptu, the rest (reading the manifest and image headers, error
   report), total). Goal (issue 3): the whole under 20 s on the 2-core bench machine.
2. Accuracy per eye: T_cam_from_gaze (rotation deg, translation mm), K, and the
   loop-closure T_ptuL_from_ptuR, all against ``ground_truth.json``.
3. What limits it: the same RASC solve (eq. 6-9, nine positions) fed with
   (a) the renderer's true T_cam_from_world, (b) extrinsics from the detected corners with
   the TRUE K, (c) the pipeline's (detected corners, calibrated K); with the per-view
   extrinsics errors of (b) and (c), split into depth (along the optical axis) and
   lateral translation.
4. ``--sweep``: the accuracy at other board distances and numbers of intrinsics views,
   over ``--sweep-seeds`` seeds (the seed moves only the intrinsics views: pose views have
   no random part without image noise).
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

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from _markdown import run_main  # noqa: E402

from rasc.geometry.frames import EYES  # noqa: E402
from rasc.geometry.kinematics import T_gaze_from_ptu  # noqa: E402
from rasc.geometry.transforms import rotation_error_deg  # noqa: E402
from rasc.handeye.solver import solve_rasc  # noqa: E402
from rasc.head.pipeline import CalibrationOptions, calibrate_dataset  # noqa: E402
from rasc.sim.render import RenderOptions, render_dataset  # noqa: E402
from rasc.vision.camera import estimate_extrinsics  # noqa: E402
from rasc.vision.dataset import forget_detections, load_dataset  # noqa: E402

STAGES = ("detection", "intrinsics", "extrinsics", "hand-eye", "base-to-ptu")


def err(T_est, T_true) -> tuple[float, float]:
    """(rotation deg, translation mm) between two transforms in metres."""
    T_est, T_true = np.asarray(T_est), np.asarray(T_true)
    return (float(rotation_error_deg(T_est[:3, :3], T_true[:3, :3])),
            1e3 * float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3])))


def run_once(folder: Path, options: RenderOptions) -> dict:
    """Render into ``folder``, calibrate, and measure everything; returns a JSON-ready dict."""
    t0 = time.perf_counter()
    render_dataset(folder, options, quiet=True)
    t_render = time.perf_counter() - t0
    forget_detections()   # time detection itself, not the detections kept from a run before
    t0 = time.perf_counter()
    dataset = load_dataset(folder)
    cal = calibrate_dataset(dataset, CalibrationOptions(model="paper"))
    t_cal = time.perf_counter() - t0
    truth = dataset.load_ground_truth()
    timings = {"rendering": t_render, **{s: cal.timings.get(s, 0.0) for s in STAGES}}
    timings["other"] = t_cal - sum(cal.timings.get(s, 0.0) for s in STAGES)
    timings["total"] = t_render + t_cal
    out = {"options": {"seed": options.seed, "distance_m": options.distance,
                       "intrinsics_views": options.intrinsics_views},
           "timings_s": timings, "eyes": {}}
    for eye in EYES:
        r = cal.eyes[eye]
        K, K_true = r.intrinsics.K, np.asarray(truth[eye]["K"])
        T_gp = T_gaze_from_ptu(r.pan_tilt[:, 0], r.pan_tilt[:, 1])
        T_cg_true = truth[eye]["T_cam_from_gaze"]
        T_true = np.array([truth["views"][f]["T_cam_from_world"] for f in r.pose_files])
        corners = dataset.detect(eye, "pose", method=cal.options.detector).corners
        T_trueK = np.array([estimate_extrinsics(corners[f], dataset.board, K_true,
                                                np.zeros(5))[0] for f in r.pose_files])
        sources = {"true extrinsics": T_true, "detected corners, true K": T_trueK,
                   "pipeline": r.T_cam_from_world}
        he = {name: err(solve_rasc(T, T_gp).T_cam_from_gaze, T_cg_true)
              for name, T in sources.items()}
        assert np.allclose(he["pipeline"], err(r.handeye.T_cam_from_gaze, T_cg_true))
        extr = {}
        for name in ("detected corners, true K", "pipeline"):
            rot, depth, lateral = [], [], []
            for T, T_t in zip(sources[name], T_true, strict=True):
                rot.append(err(T, T_t)[0])
                d = 1e3 * (T[:3, 3] - T_t[:3, 3])  # camera frame: z is the optical axis
                depth.append(abs(d[2]))
                lateral.append(float(np.hypot(d[0], d[1])))
            extr[name] = {"rotation_deg_mean": float(np.mean(rot)),
                          "rotation_deg_max": float(np.max(rot)),
                          "depth_mm_mean": float(np.mean(depth)),
                          "lateral_mm_mean": float(np.mean(lateral))}
        out["eyes"][eye] = {
            "T_cam_from_gaze": dict(zip(("rotation_deg", "translation_mm"),
                                        he["pipeline"], strict=True)),
            "K_error_px": {"fx": K[0, 0] - K_true[0, 0], "fy": K[1, 1] - K_true[1, 1],
                           "cx": K[0, 2] - K_true[0, 2], "cy": K[1, 2] - K_true[1, 2]},
            "intrinsics_rms_px": r.intrinsics.rms,
            "quality": r.handeye.quality,
            "handeye_by_source": {k: {"rotation_deg": v[0], "translation_mm": v[1]}
                                  for k, v in he.items()},
            "extrinsics_error": extr,
        }
    rot, trans = err(cal.base["T_ptuL_from_ptuR"], truth["T_ptuL_from_ptuR"])
    out["loop_closure"] = {"rotation_deg": rot, "translation_mm": trans}
    return out


def print_report(res: dict) -> None:
    o = res["options"]
    print(f"\nrasc render + rasc calibrate, default model, seed {o['seed']}, board at "
          f"{o['distance_m']:g} m, {o['intrinsics_views']} intrinsics views + 9 pan-tilt "
          "positions per eye (1280x960)\n")
    print("| stage | wall time (s) |\n| --- | ---: |")
    for stage, t in res["timings_s"].items():
        label = {"other": "other (manifest, image headers, error report)"}.get(stage, stage)
        print(f"| {'**total**' if stage == 'total' else label} | {t:.2f} |")
    print("\n| eye | T_cam_from_gaze rotation (deg) | translation (mm) | fx, fy, cx, cy "
          "error (px) | intrinsics RMS (px) | quality (eq. 10) |\n"
          "| --- | ---: | ---: | --- | ---: | ---: |")
    for eye in EYES:
        e = res["eyes"][eye]
        k = e["K_error_px"]
        print(f"| {eye} | {e['T_cam_from_gaze']['rotation_deg']:.4f} | "
              f"{e['T_cam_from_gaze']['translation_mm']:.3f} | "
              f"{k['fx']:+.3f}, {k['fy']:+.3f}, {k['cx']:+.3f}, {k['cy']:+.3f} | "
              f"{e['intrinsics_rms_px']:.4f} | {e['quality']:.2e} |")
    lc = res["loop_closure"]
    print(f"\nLoop-closure T_ptuL_from_ptuR: {lc['rotation_deg']:.4f} deg, "
          f"{lc['translation_mm']:.3f} mm")
    print("\nWhat limits the accuracy: the same RASC solve on three sets of extrinsics\n")
    print("| eye | extrinsics from | hand-eye rotation (deg) | translation (mm) | "
          "extrinsics rotation mean / max (deg) | depth / lateral error mean (mm) |\n"
          "| --- | --- | ---: | ---: | ---: | ---: |")
    for eye in EYES:
        e = res["eyes"][eye]
        for name, h in e["handeye_by_source"].items():
            x = e["extrinsics_error"].get(name)
            xs = (f"{x['rotation_deg_mean']:.4f} / {x['rotation_deg_max']:.4f} | "
                  f"{x['depth_mm_mean']:.3f} / {x['lateral_mm_mean']:.3f}") if x else "0 | 0"
            print(f"| {eye} | {name} | {h['rotation_deg']:.2g} | {h['translation_mm']:.3g} "
                  f"| {xs} |")


def sweep(seeds: int, base: RenderOptions, work: Path) -> list[dict]:
    settings = [(d, base.intrinsics_views) for d in (1.0, 1.5, 2.0, 3.0)] + \
        [(base.distance, n) for n in (10, 40)]
    rows = []
    for distance, n in settings:
        runs = []
        for seed in range(seeds):
            folder = work / f"d{distance:g}_n{n}_s{seed}"
            runs.append(run_once(folder, RenderOptions(seed=seed, distance=distance,
                                                       intrinsics_views=n)))
        rows.append({"distance_m": distance, "intrinsics_views": n, "runs": runs})
    print(f"\nSweep ({seeds} seeds each; mean and worst over seeds and both eyes)\n")
    print("| board distance (m) | intrinsics views | T_cam_from_gaze rotation mean / max "
          "(deg) | translation mean / max (mm) | same with true K: translation mean (mm) "
          "| loop closure max (deg, mm) |\n| ---: | ---: | ---: | ---: | ---: | ---: |")
    for row in rows:
        rot = [r["eyes"][e]["T_cam_from_gaze"]["rotation_deg"] for r in row["runs"] for e in EYES]
        tr = [r["eyes"][e]["T_cam_from_gaze"]["translation_mm"] for r in row["runs"]
              for e in EYES]
        tk = [r["eyes"][e]["handeye_by_source"]["detected corners, true K"]["translation_mm"]
              for r in row["runs"] for e in EYES]
        lr = max(r["loop_closure"]["rotation_deg"] for r in row["runs"])
        lt = max(r["loop_closure"]["translation_mm"] for r in row["runs"])
        print(f"| {row['distance_m']:g} | {row['intrinsics_views']} | {np.mean(rot):.4f} / "
              f"{np.max(rot):.4f} | {np.mean(tr):.3f} / {np.max(tr):.3f} | {np.mean(tk):.3f} "
              f"| {lr:.4f}, {lt:.3f} |")
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--distance", type=float, default=1.0)
    p.add_argument("--intrinsics-views", type=int, default=20)
    p.add_argument("--sweep", action="store_true", help="also sweep distance and views")
    p.add_argument("--sweep-seeds", type=int, default=3)
    p.add_argument("--json", metavar="FILE", help="write the raw results here")
    args = p.parse_args(argv)
    options = RenderOptions(seed=args.seed, distance=args.distance,
                            intrinsics_views=args.intrinsics_views)
    with tempfile.TemporaryDirectory(prefix="bench_pipeline.") as tmp:
        work = Path(tmp)
        result = {"main": run_once(work / "main", options)}
        print_report(result["main"])
        if args.sweep:
            result["sweep"] = sweep(args.sweep_seeds, options, work)
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(run_main(main, "Pipeline: render and calibrate the default dataset", __file__))
