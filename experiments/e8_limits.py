"""E8's diagnosis: what limits the gain of wide pan-tilt motions (issue 23).

The closed form's hand-eye translation comes from eq. 7, ``(I − R_A) t_X = R_X t_B − t_A``
over the pairs of positions: its error is the error of the camera motions' translations
divided by the size of ``(I − R_A)`` (≈ θ), hence the 1/θ law — if the per-view pose
error stays the same. For each board and amplitude (the paper's nine positions scaled to
±A, E8's :func:`experiments.e8_wide.positions`), projected corners with 0.015 px noise
(:func:`rasc.sim.synthetic.corner_dataset`, seeds 0…n−1, both eyes) and the TRUE
intrinsics, so that only the per-view pose noise acts:

* corners per view (mean, fewest);
* the per-view pose error (IPPE + LM, :func:`rasc.vision.camera.estimate_extrinsics`):
  rotation (arc seconds) and camera centre (mm), RMS;
* the closed form's hand-eye translation error (:func:`rasc.handeye.solver.solve_rasc`,
  all pairs), RMS, with the full pose error, with the rotation error only (each view's
  estimated rotation, its true camera centre) and with the centre error only;
* the singular values of ``(I − R_A)`` stacked over all pairs (eq. 7's conditioning).

Run::

    python experiments/e8_limits.py [--seeds N] [--out DIR]

Writes ``<out>/e8/limits.csv`` and prints the table (``limits.md`` beside it).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from experiments.e7_model_mismatch import _csv  # noqa: E402
from experiments.e8_wide import CHARUCO, EYES, positions  # noqa: E402

#: (label, CharucoBoard fields): E8's wall and the smaller board it replaced
BOARDS = (("16x12 of 75 mm (1.2 m x 0.9 m)",
           dict(squares=(16, 12), square_size=0.075, marker_size=0.056,
                dictionary="DICT_5X5_100")),
          ("20x15 of 170 mm (3.4 m x 2.55 m, E8's)", CHARUCO))
AMPLITUDES = (8.0, 15.0, 30.0, 45.0)
NOISE_PX = 0.015


def _handeye_error_mm(T_cw, T_gp, T_true) -> float:
    from rasc.handeye.solver import solve_rasc

    X = solve_rasc(np.array(T_cw), np.array(T_gp)).T_cam_from_gaze
    return 1e3 * float(np.linalg.norm(X[:3, 3] - T_true[:3, 3]))


def case(board, amplitude: float, seeds: int) -> dict:
    """One board × amplitude over ``seeds`` seeds and both eyes (module docstring)."""
    from rasc.geometry.transforms import make_transform, rotation_angle
    from rasc.sim.synthetic import corner_dataset, default_head
    from rasc.vision.camera import estimate_extrinsics

    head = default_head()
    poses = positions(amplitude)
    n, rot, cen, full, r_only, c_only = [], [], [], [], [], []
    sv = None
    for seed in range(seeds):
        ds = corner_dataset(head, seed=seed, noise_px=NOISE_PX, board=board,
                            poses_deg=poses, n_intrinsics=3)
        for eye in EYES:
            det = ds.detections[(eye, "pose")]
            T_cw, T_r, T_c, T_gp = [], [], [], []
            for f, c in det.corners.items():
                e = det.entries[f]
                T_true = head.T_cam_from_base(eye, e.pan, e.tilt) \
                    @ ds.views_T_base_from_world[e.view]
                T_est, _ = estimate_extrinsics(c, board, head.K[eye], head.dist[eye])
                n.append(int(np.isfinite(c[:, 0]).sum()))
                R_e, R_t = T_est[:3, :3], T_true[:3, :3]
                c_e, c_t = -R_e.T @ T_est[:3, 3], -R_t.T @ T_true[:3, 3]
                rot.append(3600 * np.degrees(rotation_angle(R_e @ R_t.T)))
                cen.append(1e3 * np.linalg.norm(c_e - c_t))
                T_cw.append(T_est)
                T_r.append(make_transform(R_e, -R_e @ c_t))
                T_c.append(make_transform(R_t, -R_t @ c_e))
                T_gp.append(head.unit[eye].T_gaze_from_ptu(e.pan, e.tilt))
            X = head.T_cam_from_gaze[eye]
            full.append(_handeye_error_mm(T_cw, T_gp, X))
            r_only.append(_handeye_error_mm(T_r, T_gp, X))
            c_only.append(_handeye_error_mm(T_c, T_gp, X))
            if sv is None:
                R = [T[:3, :3] for T in T_gp]
                M = np.vstack([np.eye(3) - Ri @ Rj.T for i, Ri in enumerate(R)
                               for j, Rj in enumerate(R) if i != j])
                sv = np.linalg.svd(M, compute_uv=False)

    def rms(v):
        return float(np.sqrt(np.mean(np.square(v))))

    return {"amplitude_deg": amplitude, "corners_mean": float(np.mean(n)),
            "corners_min": int(min(n)), "rotation_arcsec": rms(rot), "centre_mm": rms(cen),
            "handeye_mm": rms(full), "handeye_rotation_only_mm": rms(r_only),
            "handeye_centre_only_mm": rms(c_only), "sv_min": float(sv[-1]),
            "sv_max": float(sv[0])}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--seeds", type=int, default=6, help="seeds per case (default 6)")
    p.add_argument("--out", type=Path, default=REPO / "out", help="output folder (default out)")
    args = p.parse_args(argv)
    from rasc.io import write_text_atomic
    from rasc.vision.board import CharucoBoard

    folder = args.out / "e8"
    folder.mkdir(parents=True, exist_ok=True)
    rows, lines = [], [
        f"Projected corners ({NOISE_PX} px), true intrinsics, seeds 0…{args.seeds - 1}, both "
        "eyes; RMS. Hand-eye: closed form's translation error.", "",
        "| board | ±A | corners/view (fewest) | pose rotation | camera centre | hand-eye | "
        "rotation error only | centre error only | (I − A) smallest / largest s.v. |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for label, fields in BOARDS:
        board = CharucoBoard(**fields)
        for amp in AMPLITUDES:
            r = case(board, amp, args.seeds)
            rows.append([label, f"{amp:g}", f"{r['corners_mean']:.1f}", r["corners_min"],
                         f"{r['rotation_arcsec']:.4g}", f"{r['centre_mm']:.4g}",
                         f"{r['handeye_mm']:.4g}", f"{r['handeye_rotation_only_mm']:.4g}",
                         f"{r['handeye_centre_only_mm']:.4g}", f"{r['sv_min']:.4g}",
                         f"{r['sv_max']:.4g}"])
            lines.append(f"| {label} | ±{amp:g}° | {r['corners_mean']:.0f} ({r['corners_min']}) "
                         f"| {r['rotation_arcsec']:.2f}″ | {r['centre_mm']:.3f} mm | "
                         f"{r['handeye_mm']:.4f} mm | {r['handeye_rotation_only_mm']:.4f} mm | "
                         f"{r['handeye_centre_only_mm']:.4f} mm | {r['sv_min']:.2f} / "
                         f"{r['sv_max']:.2f} |")
            print(lines[-1], flush=True)
    _csv(folder / "limits.csv", ["board", "amplitude_deg", "corners_mean", "corners_min",
                                 "rotation_arcsec", "centre_mm", "handeye_mm",
                                 "handeye_rotation_only_mm", "handeye_centre_only_mm",
                                 "sv_min", "sv_max"], rows)
    write_text_atomic(folder / "limits.md", "\n".join(lines) + "\n")
    print(f"e8_limits: wrote {folder}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    from rasc.interrupt import exit_process
    exit_process(main())
