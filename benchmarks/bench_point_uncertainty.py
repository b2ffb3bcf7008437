"""Triangulation σ, predicted (rasc.head.uncertainty, first order) against observed
(Monte-Carlo), per base axis (x up, y forward, z left).

    .venv/bin/python benchmarks/bench_point_uncertainty.py [--renders 16] [--noise 4]

A. Pixel noise on synthetic projections: a plausible head (tests/nominal_rig.py), four
   points 0.6–3 m ahead, exact pixels + N(0, 0.3²) (seed 7), 4000 draws.
B. Calibration covariance: the whole-head refinement of a small rendered dataset
   (8 intrinsics views per eye, the paper's 9 positions); 1000 calibrations drawn from
   N(θ̂, Σ_θ) (seed 11), the same pixels triangulated with each.
C. On renders: the dataset rendered ``--renders`` times with image noise ``--noise``
   grey levels (seeds 0, 1, ...: the pose views' scene is the same, only the noise
   differs), the corners of all nine pose views detected in both eyes and triangulated
   with the TRUE head (ground truth): the spread of each corner's point across renders
   against the σ predicted from the detector's noise (the spread across renders of each
   corner's detection error, pooled; its per-corner mean, a detector bias, removed).
   Printed per axis: sqrt(mean observed variance) / sqrt(mean predicted variance) over
   all corners, and the median of the per-corner ratios.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))
os.environ.setdefault("MUJOCO_GL", "egl")

AXES = ("x (up)", "y (forward)", "z (left)")


def _print(title: str, ratio: np.ndarray) -> None:
    print(title)
    for k, a in enumerate(AXES):
        col = ratio[:, k] if ratio.ndim == 2 else ratio[k:k + 1]
        print(f"  {a:12s} observed/predicted: " + ", ".join(f"{r:.3f}" for r in col))


def part_a() -> None:
    from rasc.head.uncertainty import point_uncertainty

    from nominal_rig import plausible_head

    head, _ = plausible_head(0)
    pts = np.array([[0.0, 1.0, 0.0], [0.2, 2.0, -0.3], [-0.1, 3.0, 0.4], [0.05, 0.6, 0.1]])
    ang = np.radians([3.0, -2.0, -4.0, -2.0])
    uvl, uvr = head.project(pts, *ang)
    sig = 0.3
    unc = point_uncertainty(head, uvl, uvr, *ang, pixel_sigma=sig)
    rng = np.random.default_rng(7)
    M, n = 4000, len(pts)
    UL = (uvl[None] + sig * rng.standard_normal((M, n, 2))).reshape(-1, 2)
    UR = (uvr[None] + sig * rng.standard_normal((M, n, 2))).reshape(-1, 2)
    P = head.triangulate(UL, UR, *ang).reshape(M, n, 3)
    _print("A. pixel noise 0.3 px, 4000 draws, four points (per point):",
           P.std(axis=0, ddof=1) / unc.sigma)
    print("   predicted sigma (mm):", np.round(1000 * unc.sigma, 4).tolist())


def part_b(cache: str) -> None:
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.head.uncertainty import covariance_from_refinement, perturbed_head, point_uncertainty
    from rasc.testing import render_cached

    cal = calibrate_dataset(render_cached(cache, intrinsics_views=8).load(),
                            CalibrationOptions(model="general"))
    head, cov = cal.head, covariance_from_refinement(cal.refinement)
    pts = np.array([[0.0, 1.0, 0.0], [0.2, 2.0, -0.3], [-0.1, 1.5, 0.4], [0.05, 0.6, 0.1]])
    ang = np.radians([3.0, -2.0, -4.0, -2.0])
    uvl, uvr = head.project(pts, *ang)
    unc = point_uncertainty(head, uvl, uvr, *ang, pixel_sigma=0.0, covariance=cov)
    rng = np.random.default_rng(11)
    w, V = np.linalg.eigh(cov.matrix)
    L = V * np.sqrt(np.clip(w, 0.0, None))
    P = np.array([perturbed_head(head, cov.names, L @ rng.standard_normal(len(w)))
                  .triangulate(uvl, uvr, *ang) for _ in range(1000)])
    _print(f"B. calibration covariance ({len(cov.names)} parameters), 1000 draws (per point):",
           P.std(axis=0, ddof=1) / unc.sigma)
    print("   predicted sigma (mm):", np.round(1000 * unc.sigma, 4).tolist())


def part_c(cache: str, renders: int, noise: float) -> None:
    from rasc.head.model import EyeCalibration, HeadCalibration
    from rasc.head.uncertainty import point_uncertainty
    from rasc.testing import render_cached

    det: dict[tuple[str, str], list[np.ndarray]] = {}
    truth = None
    for seed in range(renders):
        r = render_cached(cache, intrinsics_views=3, seed=seed, image_noise=noise)
        ds = r.load()
        gt = r.truth
        if truth is None:
            truth = gt
        for eye in ("left", "right"):
            d = ds.detect(eye, "pose", method="saddle", min_found=1, board_seen=True)
            for f, c in d.corners.items():
                det.setdefault((eye, d.entries[f].view), []).append(c)
        print(f"   render {seed + 1}/{renders}", file=sys.stderr)
    gt = truth
    size = tuple(gt["image_size"])
    head = HeadCalibration(**{e: EyeCalibration(
        K=gt[e]["K"], dist=gt[e]["dist"], T_cam_from_gaze=gt[e]["T_cam_from_gaze"],
        T_ptu_from_base=gt[e]["T_ptu_from_base"], image_size=size) for e in ("left", "right")})
    obs_var, pred_var, ratios, errs = [], [], [], []
    views = sorted({v for _, v in det})
    for view in views:
        cl, cr = np.array(det[("left", view)]), np.array(det[("right", view)])
        if len(cl) != renders or len(cr) != renders:
            continue
        # detector noise: spread across renders of each corner (bias removed)
        errs += [cl - cl.mean(axis=0), cr - cr.mean(axis=0)]
    e = np.concatenate([x.reshape(renders, -1) for x in errs], axis=1)
    sigma_px = float(np.sqrt(np.sum(e ** 2) / (e.size - e.size / renders)))
    for view in views:
        cl, cr = np.array(det[("left", view)]), np.array(det[("right", view)])
        if len(cl) != renders or len(cr) != renders:
            continue
        v = gt["views"][f"poses/left_{view}.png"]
        vr = gt["views"][f"poses/right_{view}.png"]
        ang = np.radians([v["pan"], v["tilt"], vr["pan"], vr["tilt"]])
        P = np.array([head.triangulate(cl[k], cr[k], *ang) for k in range(renders)])
        unc = point_uncertainty(head, cl.mean(axis=0), cr.mean(axis=0), *ang,
                                pixel_sigma=sigma_px)
        ov = P.var(axis=0, ddof=1)
        pv = unc.sigma ** 2
        obs_var.append(ov)
        pred_var.append(pv)
        ratios.append(np.sqrt(ov / pv))
    ov, pv, ra = (np.concatenate(x) for x in (obs_var, pred_var, ratios))
    print(f"C. on renders: {renders} renders, noise {noise:g} grey levels, {len(ov)} corners "
          f"of {len(obs_var)} pose views; detector noise sigma {sigma_px:.4f} px per "
          "coordinate")
    for k, a in enumerate(AXES):
        print(f"  {a:12s} sqrt(mean obs var / mean pred var) = "
              f"{np.sqrt(ov[:, k].mean() / pv[:, k].mean()):.3f}; median per-corner ratio "
              f"{np.median(ra[:, k]):.3f}; predicted sigma (median) "
              f"{1000 * np.median(np.sqrt(pv[:, k])):.4f} mm")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--renders", type=int, default=16)
    ap.add_argument("--noise", type=float, default=4.0)
    ap.add_argument("--parts", default="abc")
    args = ap.parse_args()
    cache = os.environ.get("RASC_CACHE_DIR") or str(Path(tempfile.gettempdir()) / "rasc-bench")
    if "a" in args.parts:
        part_a()
    if "b" in args.parts:
        part_b(cache)
    if "c" in args.parts:
        part_c(cache, args.renders, args.noise)


if __name__ == "__main__":
    main()
