"""Check ``rasc plan``'s prediction (issue 23): predicted σ against the spread of repeated
captures, and planned positions against the paper's nine and random positions.

For each position set — planned (greedy D-optimal, 2° grid, :func:`rasc.plan.plan`), the
paper's nine, and nine drawn at random (seeded) from the same usable candidates — ``--captures``
independent captures are made and calibrated by the pipeline with the whole-head
refinement (scales held, as planned). Each capture has its own seed: its own intrinsics
views (board poses drawn as ``rasc render`` draws them) and its own noise.

* ``--rendered``: rendered (``rasc.sim.render.render_dataset``, Gaussian pixel noise of
  ``RENDER_NOISE`` grey levels) and calibrated from the detected corners of its images;
* otherwise projected corners (``rasc.sim.synthetic.corner_dataset``) with
  ``NOISE_PX`` Gaussian corner noise: the prediction's noise model is then exact.

Every capture's errors against the truth (the renderer's ground truth, in the canonical
gauge the refinement estimates in) are appended, one JSON line per capture, to
``<out>/plan_check[_rendered]/<target>/captures.jsonl`` as it finishes; a run that is
stopped resumes where it stopped. The summary (``summary.csv``, printed as a Markdown
table) compares, per position set, eye and parameter (hand-eye rotation and translation
components, the unit's axis angle and axis distance):

* **predicted σ**: :func:`rasc.plan.predict` for the true head at the pixel noise the
  captures' reprojection residuals give (σ̂² = Σ RSS / Σ degrees of freedom, pooled over
  the set's captures: how least squares estimates σ²), never from the parameter spread;
* **measured σ**: the standard deviation of the capture's errors over captures, with its
  sampling error (σ/√(2(n−1)) for n captures), the mean error (bias) with its standard
  error, and the RMS error against the truth.

For renders it also splits the pose views' residuals into the part common to every
capture (the same positions render the same image up to noise: a systematic render and
detection error, which moves every capture's estimate the same way — a bias, not a
spread) and the part that changes from capture to capture, and predicts the spread with
that split (:meth:`rasc.plan.Information.covariance`'s separate noise of the intrinsics
and pose views: ``predicted_split``; with ``--jitter`` the common part is nearly nil and
this is the prediction with each kind of view's own noise, what ``rasc plan
--calibration`` does) and with each pose view's own noise (``predicted_view``: per
position and eye, its residuals' mean square over the captures).

``--supersample S`` (:attr:`rasc.sim.render.RenderOptions.supersample`, ``rasc render
--supersample``): every image is rendered at S times the size and averaged over S×S
pixels (``cv2.INTER_AREA``; the ground truth's camera matrix is the output size's,
exactly: the corners' mean error stays 0.0002 px), which cuts the render's systematic
corner errors (0.017 → 0.0076 px at 2×, 0.0057 px at 3×, pose views of the chessboard)
and with them the structure that independent noise does not describe. Results go to
``<target>[_jitter]_ss<S>``.

``--start I`` begins at capture I (seed 100 + I): two processes with their own ``--out``
split a run, and their ``captures.jsonl`` files joined make one.

    python experiments/plan_check.py [--rendered] [--captures N] [--target SPEC] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from rasc.sim import DEFAULT_SUPERSAMPLE  # noqa: E402

NOISE_PX = 0.05
RENDER_NOISE = 2.0            # grey levels
#: ``--jitter``: every capture places the target anew, at a distance (m) drawn uniformly
#: from JITTER_RANGE with the capture's seed (farther than the planned 1 m only, so that
#: every position still shows it whole): each corner's sub-pixel phase moves, so the
#: render's systematic corner errors differ between captures. (Captures recorded before
#: 09:05 UTC on 2026-11-26 cycled through 1.00, 1.02, 1.04, 1.06 m instead; every record
#: keeps its distance, and the prediction uses the recorded ones.)
JITTER_RANGE = (1.0, 1.06)
EYES = ("left", "right")
#: per eye: (key in the capture record, key in rasc.plan.summarise's std, factor to the
#: record's unit, unit)
PARAMETERS = (
    [(f"rot{a}", f"T_cam_from_gaze.rot{a}", 1.0, "deg") for a in "xyz"]
    + [(f"t{a}", f"T_cam_from_gaze.t{a}", 1e3, "mm") for a in "xyz"]
    + [("axis_angle", "unit.tilt_axis_x", float(np.degrees(1.0)), "deg"),
       ("axis_distance", "unit.tilt_point_y", 1e3, "mm")])


def canonical_truth(unit, T_cam_from_gaze, T_ptu_from_base) -> dict:
    """The truth in the canonical gauge the refinement estimates in."""
    from rasc.geometry.kinematics import canonical_gauge

    u, T_cg, T_pb = canonical_gauge(unit, np.asarray(T_cam_from_gaze, float),
                                    np.asarray(T_ptu_from_base, float))
    a = np.asarray(u.tilt_axis, float)
    return {"T_cam_from_gaze": T_cg, "T_ptu_from_base": T_pb, "unit": u,
            "tilt_axis_x": float(a[0] / a[2]), "tilt_point_y": float(u.tilt_point[1])}


def truth_head(board):
    """The renderer's true head (:class:`rasc.sim.synthetic.SyntheticHead`, canonical
    gauge), read from the simulator without rendering."""
    from rasc.geometry.kinematics import PanTiltUnit
    from rasc.sim.scene import StereoHeadSim
    from rasc.sim.synthetic import SyntheticHead

    with (StereoHeadSim() if board is None else StereoHeadSim(board=board)) as sim:
        gt = sim.ground_truth()
    parts = {e: canonical_truth(PanTiltUnit.from_dict(gt[e]["unit"]) if "unit" in gt[e]
                                else PanTiltUnit(), gt[e]["T_cam_from_gaze"],
                                gt[e]["T_ptu_from_base"]) for e in EYES}
    return SyntheticHead(K={e: np.asarray(gt[e]["K"], float) for e in EYES},
                         dist={e: np.resize(np.asarray(gt[e].get("dist", [0.0] * 5), float), 5)
                               for e in EYES},
                         T_cam_from_gaze={e: parts[e]["T_cam_from_gaze"] for e in EYES},
                         T_ptu_from_base={e: parts[e]["T_ptu_from_base"] for e in EYES},
                         unit={e: parts[e]["unit"] for e in EYES})


def record(cal, truth: dict, pose_files: list[str]) -> dict:
    """One capture's errors against ``truth`` (eye → :func:`canonical_truth`) and its
    residuals: σ̂ (RSS, dof), the intrinsics views' RMS and the pose views' residuals
    (files in position order, NaN for corners not kept)."""
    from scipy.spatial.transform import Rotation

    ref = cal.refinement
    out = {"rss": ref.rss, "dof": ref.dof, "sigma_px": ref.sigma,
           "rms_intrinsics": ref.rms_by_role.get("intrinsics"),
           "rms_pose": ref.rms_by_role.get("pose"), "n_corners": ref.n_corners}
    for eye in EYES:
        t = truth[eye]
        T = np.asarray(ref.T_cam_from_gaze[eye], float)
        rot = Rotation.from_matrix(T[:3, :3] @ t["T_cam_from_gaze"][:3, :3].T).as_rotvec()
        e = {f"rot{a}": float(np.degrees(v)) for a, v in zip("xyz", rot, strict=True)}
        e.update({f"t{a}": 1e3 * float(v) for a, v in
                  zip("xyz", T[:3, 3] - t["T_cam_from_gaze"][:3, 3], strict=True)})
        p = ref.parameters[eye]
        e["axis_angle"] = float(np.degrees(p["unit.tilt_axis_x"]["value"] - t["tilt_axis_x"]))
        e["axis_distance"] = 1e3 * (p["unit.tilt_point_y"]["value"] - t["tilt_point_y"])
        out[eye] = e
    # the pose views' residuals, image by image (the refinement's order: per eye the
    # intrinsics views, then the pose views)
    kept = ref.kept
    names = [(im.eye, im.name) for im in ref.images]
    offsets = {eye: 0 for eye in EYES}
    pose = {}
    for i, (eye, name) in enumerate(names):
        n = int(kept[i].sum())
        r = np.full(kept[i].shape + (2,), np.nan)
        r[kept[i]] = ref.residuals[eye][offsets[eye]:offsets[eye] + n]
        offsets[eye] += n
        pose[name] = r
    out["pose_residuals"] = [np.round(pose[f], 6).tolist() if f in pose else None
                             for f in pose_files]
    return out


def capture_rendered(poses, seed: int, board, truth, distance: float = 1.0,
                     supersample: int = 1) -> dict:
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.sim.render import RenderOptions, render_dataset
    from rasc.vision.dataset import load_dataset

    with tempfile.TemporaryDirectory(prefix="rasc-plan-check-") as tmp:
        render_dataset(Path(tmp) / "ds", RenderOptions(seed=seed, poses_deg=tuple(poses),
                                                       image_noise=RENDER_NOISE,
                                                       distance=distance,
                                                       supersample=supersample),
                       quiet=True, board=board)
        ds = load_dataset(Path(tmp) / "ds")
        cal = calibrate_dataset(ds, CalibrationOptions(model="general", scales="hold"))
    files = [f"poses/{eye}_{k:02d}.png" for eye in EYES for k in range(len(poses))]
    return record(cal, truth, files)


def capture_projected(poses, seed: int, board, truth, head) -> dict:
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.sim.synthetic import corner_dataset

    ds = corner_dataset(head, seed=seed, noise_px=NOISE_PX, poses_deg=poses,
                        **({} if board is None else {"board": board}))
    cal = calibrate_dataset(ds, CalibrationOptions(model="general", scales="hold"))
    files = [f"poses/{eye}_{k:02d}.png" for eye in EYES for k in range(len(poses))]
    return record(cal, truth, files)


def position_sets(setup) -> dict[str, list[tuple[float, float]]]:
    """Planned, the paper's nine, and nine random usable positions (seed 1)."""
    from rasc.geometry.kinematics import PAPER_POSES_DEG
    from rasc.plan import Information, candidate_grid, plan

    planned = plan(setup, 9, workspace_depth=None)
    info = Information(setup, candidate_grid(setup))
    rng = np.random.default_rng(1)
    random9 = [tuple(map(float, info.feasible[i]))
               for i in sorted(rng.choice(len(info.feasible), 9, replace=False))]
    return {"planned": planned.positions, "paper": [tuple(p) for p in PAPER_POSES_DEG],
            "random": random9}


def _se_std(n: int) -> float:
    """Relative standard error of a sample standard deviation of n normal draws."""
    return 1.0 / np.sqrt(2.0 * (n - 1)) if n > 1 else float("nan")


def residual_split(recs: list[dict]) -> dict[str, float]:
    """The pose views' residuals split (per coordinate, px): ``common``, the part every
    capture shares (the per-corner mean over captures, less its own noise), and
    ``independent``, the scatter about it; ``intrinsics``: the intrinsics views' residual
    σ per coordinate. Each corrected by the capture's dof (σ̂² / mean squared residual)."""
    first = next(np.asarray(v, float) for v in recs[0]["pose_residuals"] if v is not None)
    stack = np.stack([np.stack([np.full(first.shape, np.nan) if v is None
                                else np.asarray(v, float) for v in rec["pose_residuals"]])
                      for rec in recs])                    # (captures, images, corners, 2)
    n = len(recs)
    common = np.all(np.isfinite(stack), axis=(0, -1))   # corners kept in every capture
    x = stack[:, common]                                 # (captures, K, 2)
    mean = x.mean(axis=0)
    var_ind = float(np.mean(np.var(x, axis=0, ddof=1)))
    var_common = max(float(np.mean(mean ** 2)) - var_ind / n, 0.0)
    # a least-squares fit's residuals are smaller than the noise: mean square × m / dof
    # (m residual coordinates) is σ̂², the estimate the prediction uses
    scale = float(np.mean([2 * rec["n_corners"] / rec["dof"] for rec in recs]))
    var_int = float(np.mean([rec["rms_intrinsics"] ** 2 / 2 for rec in recs]))
    return {"common": float(np.sqrt(var_common * scale)),
            "independent": float(np.sqrt(var_ind * scale)),
            "intrinsics": float(np.sqrt(var_int * scale)), "corners": int(common.sum())}


def view_noise(recs: list[dict], positions: int, varying: bool = False) -> np.ndarray:
    """Each pose view's own corner noise per coordinate (px), (positions, 2) for the left
    and right eye: its residuals' mean square over the captures, corrected by the dof as
    :func:`residual_split` does (the render's corner errors are independent within a view
    but their size depends on how the board lies in the image: 0.011–0.021 px).
    ``varying``: only the part that changes from capture to capture (the scatter about
    each corner's mean: captures at one placement)."""
    scale = float(np.mean([2 * rec["n_corners"] / rec["dof"] for rec in recs]))
    out = np.full((positions, len(EYES)), np.nan)
    for e in range(len(EYES)):
        for k in range(positions):
            v = np.stack([np.asarray(rec["pose_residuals"][e * positions + k], float)
                          for rec in recs if rec["pose_residuals"][e * positions + k]
                          is not None] or [np.full((1, 2), np.nan)])
            if np.isfinite(v).sum() < 4:
                continue
            ms = float(np.nanmean(np.nanvar(v, axis=0, ddof=1))) if varying \
                else float(np.nanmean(np.square(v)))
            out[k, e] = np.sqrt(ms * scale)
    return out


def summarise(setup, sets, by_set: dict[str, list[dict]], rendered: bool,
              jitter: bool = False) -> tuple[list, list]:
    """Rows of the summary table (see the module docstring) and text lines; ``rendered``:
    with the split of the residuals (captures at one placement); ``jitter``: each capture
    at its own target distance (the prediction: the mean of the captures' covariances)."""
    from dataclasses import replace

    from rasc.plan import Information
    from rasc.plan import summarise as plan_summarise

    rows, lines = [], []
    for name, recs in by_set.items():
        n = len(recs)
        if n < 3:
            continue
        sigma = float(np.sqrt(sum(r["rss"] for r in recs) / sum(r["dof"] for r in recs)))
        distances = [r.get("distance", 1.0) for r in recs] if jitter else [1.0]
        infos = [Information(replace(setup, distance=d), np.asarray(sets[name], float),
                             margin=0.0) for d in distances]
        info = infos[0]
        chosen = list(range(len(info.feasible)))
        std, _ = plan_summarise(info.names, np.mean([i.covariance(chosen, sigma)
                                                     for i in infos], axis=0))
        split_std = None
        if rendered:
            sp = residual_split(recs)
            cov = np.mean([i.covariance(chosen, sp["independent"],
                                        intrinsics_noise_px=sp["intrinsics"])
                           for i in infos], axis=0)
            split_std, _ = plan_summarise(info.names, cov)
            vn = view_noise(recs, len(sets[name]), varying=not jitter)
            vn = np.where(np.isfinite(vn), vn, sp["independent"])
            view_std, _ = plan_summarise(info.names, np.mean(
                [i.covariance(chosen, vn, intrinsics_noise_px=sp["intrinsics"])
                 for i in infos], axis=0))
            bias_cov = info.covariance(chosen, sp["common"], intrinsics_noise_px=0.0)
            bias_std, _ = plan_summarise(info.names, bias_cov)
            lines.append(f"{name}: residual σ̂ {sigma:.4f} px; pose views: common "
                         f"{sp['common']:.4f} px, independent {sp['independent']:.4f} px "
                         f"({sp['corners']} corners); intrinsics views {sp['intrinsics']:.4f} px")
        else:
            lines.append(f"{name}: residual σ̂ {sigma:.4f} px" + (
                f" (target at {min(distances):.3f} to {max(distances):.3f} m)" if jitter
                else f" (corner noise {NOISE_PX} px)"))
        for eye in EYES:
            for key, pname, factor, unit in PARAMETERS:
                k = f"{eye}.{pname}"
                f = factor
                pred = std[k] * f
                v = np.array([r[eye][key] for r in recs])
                sd = float(np.std(v, ddof=1))
                row = {"positions": name, "eye": eye, "parameter": key, "unit": unit,
                       "captures": n, "sigma_px": sigma, "predicted": pred,
                       "measured_std": sd, "std_se": sd * _se_std(n),
                       "mean": float(v.mean()), "mean_se": sd / np.sqrt(n),
                       "rms": float(np.sqrt(np.mean(v ** 2))), "ratio": sd / pred}
                if split_std is not None:
                    row["predicted_split"] = split_std[k] * f
                    row["predicted_bias"] = bias_std[k] * f
                    row["predicted_view"] = view_std[k] * f
                rows.append(row)
    for name in by_set:
        mine = [r for r in rows if r["positions"] == name]
        if not mine:
            continue
        k = sum(abs(r["ratio"] - 1) <= 0.25 for r in mine)
        text = (f"{name}: {len(mine)} parameters, measured/predicted σ median "
                f"{np.median([r['ratio'] for r in mine]):.2f} "
                f"({min(r['ratio'] for r in mine):.2f}–{max(r['ratio'] for r in mine):.2f}), "
                f"{k} within ±25 %")
        if "predicted_split" in mine[0]:
            q = [r["measured_std"] / r["predicted_split"] for r in mine]
            z = [r["mean"] / r["predicted_bias"] for r in mine if r["predicted_bias"] > 0]
            text += (f"; with the split: median {np.median(q):.2f} ({min(q):.2f}–"
                     f"{max(q):.2f}), {sum(abs(v - 1) <= 0.25 for v in q)} within ±25 %; "
                     + (f"bias / predicted bias σ: RMS {np.sqrt(np.mean(np.square(z))):.2f}"
                        if z else "no common part"))
            w = [r["measured_std"] / r["predicted_view"] for r in mine]
            text += (f"; with each view's own noise: median {np.median(w):.2f} "
                     f"({min(w):.2f}–{max(w):.2f}), {sum(abs(v - 1) <= 0.25 for v in w)} "
                     "within ±25 %")
        text += (f"; one σ from {mine[0]['captures']} captures has a sampling error of "
                 f"{100 * _se_std(mine[0]['captures']):.0f} %")
        lines.append(text)
    return rows, lines


#: ``rasc plan``'s summary quantities (rasc.plan.summarise) from the per-component rows:
#: name → the components whose σ add in quadrature
SUMMARY_QUANTITIES = {"hand-eye rotation": ("rotx", "roty", "rotz"),
                      "hand-eye translation": ("tx", "ty", "tz"),
                      "axis distance": ("axis_distance",), "axis angle": ("axis_angle",)}


def summary_quantities(rows: list[dict], column: str = "predicted") -> list[dict]:
    """Per position set, eye and :data:`SUMMARY_QUANTITIES` entry: the predicted σ (the
    rows' ``column``: ``predicted``, ``predicted_split`` or ``predicted_view``) and the
    measured σ, each the root sum of squares of its components' σ (as
    :func:`rasc.plan.summarise` sums them), and their ratio."""
    out = []
    for name in dict.fromkeys(r["positions"] for r in rows):
        for eye in EYES:
            mine = {r["parameter"]: r for r in rows
                    if r["positions"] == name and r["eye"] == eye}
            for quantity, parts in SUMMARY_QUANTITIES.items():
                if not all(p in mine and column in mine[p] for p in parts):
                    continue
                pred = float(np.sqrt(sum(mine[p][column] ** 2 for p in parts)))
                meas = float(np.sqrt(sum(mine[p]["measured_std"] ** 2 for p in parts)))
                out.append({"positions": name, "eye": eye, "quantity": quantity,
                            "predicted": pred, "measured": meas, "ratio": meas / pred})
    return out


def summary_lines(rows: list[dict]) -> list[str]:
    """How many of ``rasc plan``'s summary quantities the prediction puts within ±25 %,
    per prediction the rows carry, with each quantity's count and ratio range."""
    lines = []
    for column, label in (("predicted", "one pooled σ̂"),
                          ("predicted_split", "each kind of view's own noise"),
                          ("predicted_view", "each pose view's own noise")):
        q = summary_quantities(rows, column)
        if not q:
            continue
        within = [abs(x["ratio"] - 1) <= 0.25 for x in q]
        parts = []
        for quantity in SUMMARY_QUANTITIES:
            r = [x["ratio"] for x in q if x["quantity"] == quantity]
            k = sum(abs(v - 1) <= 0.25 for v in r)
            parts.append(f"{quantity} {k} of {len(r)} ({min(r):.2f}–{max(r):.2f})")
        lines.append(f"rasc plan's summary quantities, predicted with {label}: "
                     f"{sum(within)} of {len(q)} within ±25 % — " + "; ".join(parts))
    return lines


def markdown(rows: list[dict]) -> str:
    split = any("predicted_split" in r for r in rows)
    head = ["positions", "eye", "parameter", "n", "predicted σ", "measured σ ± se",
            "ratio", "mean ± se", "RMS"]
    if split:
        head += ["predicted (split)", "ratio (split)", "bias σ (common part)",
                 "predicted (each view)", "ratio (each view)"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["positions"], r["eye"], f"{r['parameter']} ({r['unit']})",
                 str(r["captures"]), f"{r['predicted']:.3g}",
                 f"{r['measured_std']:.3g} ± {r['std_se']:.2g}", f"{r['ratio']:.2f}",
                 f"{r['mean']:+.2g} ± {r['mean_se']:.2g}", f"{r['rms']:.3g}"]
        if split:
            cells += [f"{r['predicted_split']:.3g}",
                      f"{r['measured_std'] / r['predicted_split']:.2f}",
                      f"{r['predicted_bias']:.3g}", f"{r['predicted_view']:.3g}",
                      f"{r['measured_std'] / r['predicted_view']:.2f}"]
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--captures", type=int, default=8)
    p.add_argument("--start", type=int, default=0, metavar="I",
                   help="first capture index (seed 100 + I): split a long run between "
                        "processes, each with its own --out, and join the captures.jsonl")
    p.add_argument("--out", type=Path, default=REPO / "out")
    p.add_argument("--rendered", action="store_true", help="render the captures")
    p.add_argument("--target", default=None, metavar="SPEC",
                   help="the target, as rasc render --target (default: the stock chessboard)")
    p.add_argument("--jitter", action="store_true",
                   help="each capture with the target at another distance (JITTER_DISTANCES)")
    p.add_argument("--supersample", type=int, default=DEFAULT_SUPERSAMPLE, metavar="S",
                   help="render every image at S times the size and average it down "
                        "(RenderOptions.supersample, default %(default)s; 1: the plain "
                        "render, whose systematic corner errors are twice as large)")
    p.add_argument("--summary-only", action="store_true",
                   help="summarise the captures recorded so far, capture nothing")
    args = p.parse_args(argv)
    from rasc.io import write_text_atomic
    from rasc.plan import PlanSetup
    from rasc.sim.synthetic import default_head
    from rasc.vision.board import DEFAULT_BOARD, parse_target

    board = parse_target(args.target) if args.target else None
    tag = re.sub(r"[^A-Za-z0-9]+", "_", args.target or "chessboard").strip("_")
    folder = args.out / ("plan_check_rendered" if args.rendered else "plan_check") / (
        tag + ("_jitter" if args.jitter else "")
        + (f"_ss{args.supersample}" if args.supersample > 1 else ""))
    folder.mkdir(parents=True, exist_ok=True)
    head = truth_head(board) if args.rendered else default_head()
    truth = {e: canonical_truth(head.unit[e], head.T_cam_from_gaze[e], head.T_ptu_from_base[e])
             for e in EYES}
    # the captures are calibrated with the scales held: planned and predicted so too
    setup = PlanSetup(head=head, board=board or DEFAULT_BOARD, scales="hold")
    sets = position_sets(setup)
    for name, poses in sets.items():
        print(f"{name}: " + " ".join(f"({a:g},{b:g})" for a, b in poses), file=sys.stderr)
    log = folder / "captures.jsonl"
    done: dict[str, dict[int, dict]] = {name: {} for name in sets}
    if log.exists():
        for line in log.read_text().splitlines():
            rec = json.loads(line)
            if rec["positions"] == [list(p) for p in sets[rec["set"]]]:
                done[rec["set"]][rec["seed"]] = rec
    if not args.summary_only:
        for s in range(args.start, args.captures):
            for name, poses in sets.items():
                if 100 + s in done[name]:
                    continue
                t0 = time.perf_counter()
                distance = float(np.random.default_rng([100 + s, 7]).uniform(*JITTER_RANGE)) \
                    if args.jitter else 1.0
                rec = capture_rendered(poses, 100 + s, board, truth, distance,
                                       args.supersample) \
                    if args.rendered \
                    else capture_projected(poses, 100 + s, board, truth, head)
                rec.update({"set": name, "seed": 100 + s, "distance": distance,
                            "positions": [list(p) for p in poses]})
                with open(log, "a") as fh:
                    fh.write(json.dumps(rec) + "\n")
                done[name][100 + s] = rec
                print(f"capture {s + 1}/{args.captures} {name}: σ̂ {rec['sigma_px']:.4f} px, "
                      f"{time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    by_set = {name: [d[k] for k in sorted(d)] for name, d in done.items()}
    rows, lines = summarise(setup, sets, by_set, args.rendered, jitter=args.jitter)
    if not rows:
        print("plan_check: fewer than 3 captures per position set, nothing to summarise",
              file=sys.stderr)
        return 0
    from rasc.study.summary import csv_text  # rasc's one CSV writer

    header = list(rows[0])
    write_text_atomic(folder / "summary.csv",
                      csv_text(header, [[r[k] for k in header] for r in rows]))
    lines += summary_lines(rows)
    text = "\n".join(lines) + "\n\n" + markdown(rows) + "\n"
    write_text_atomic(folder / "summary.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
