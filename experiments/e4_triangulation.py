"""E4 — Table 1 of the paper: triangulation with the calibrated stereo head (docs/METHOD.md §9).

The paper maps pan/tilt angles and both eyes' image points of 2772 features on
1 m × 1 m planes at 1.622, 1.771 and 1.8615 m to base coordinates with its calibrated
model (hand-eye by RASC, mounts measured: < 1°, 2–3 mm) and reports the error: mean
x 1.02, y 0.57, z 18.3 mm, std 8.8, 12.8, 53.7 mm (x along the baseline, y vertical,
z the depth); the closer two planes about 6 mm in z.

Here: a 22×21-corner chessboard of 40 mm squares (1.00 × 0.96 m with its quiet zone,
462 corners) is rendered by the MuJoCo head at each depth from two pan/tilt poses
(both eyes verging on the plane centre, then the same plus a common offset), its corners
are detected in both images (``detect_corners(method="saddle")``; the images rendered
as the datasets are, at ``RenderOptions.supersample``'s default), the angles carry a
seeded encoder noise of 3 arc-seconds, and each point is triangulated (eq. 15–19, least
squares and total least squares) with four models that separate the error sources:

* ``true``: the model's true intrinsics, hand-eye and mounts (detection noise only);
* ``cal_true_mounts``: the pipeline's intrinsics and hand-eye (``ctx.calibration()``),
  the true mounts;
* ``cal_loop_closure``: the pipeline's whole head (mounts by loop closure, eq. 11–12);
* ``cal_measured_mounts``: the pipeline's intrinsics and hand-eye with measured mounts,
  as the paper preferred: the true ``T_ptuL_from_ptuR`` turned by 0.5° about a random
  axis and moved 2.5 mm in a random direction (``perturb_mounts``, seeded), then
  ``cyclopean_base``. This is the row beside the paper's Table 1; more draws of the
  mount error go to ``mount_draws.csv``.

Errors are estimate − truth against the board corners' true base coordinates (the
sim's ``T_base_from_world`` and ``Board.object_points``), reported in the paper's axis
order: lateral = our −z (positive to the head's right), vertical = our x (up),
depth = our y (forward).

Run::

    python -m experiments.e4_triangulation [--seed S] [--quick] [--out DIR] [--workers N]

Writes ``<out>/e4/``: ``poses.csv``, ``detections.csv``, ``points.csv`` (raw, per point),
``mount_draws.csv``, then from those ``table1.csv``, ``summary.json`` and
``fig_table1.png``/``.svg``.

``--quick`` (the reduced protocol, for tests) keeps the middle plane (1.771 m) with its
two poses (924 points, every model and both methods as in the full run), 4 draws of
the mount error instead of 20, and the figure as PNG only.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from experiments._common import (
    Context,
    Section,
    md_table,
    read_csv,
    script_main,
    spawn_rngs,
    write_csv,
    write_json,
)
from experiments._figures import save_experiment_figure
from rasc.errors import DegenerateDataError
from rasc.geometry.frames import EYES
from rasc.geometry.transforms import rotvec_from_matrix
from rasc.head.base_to_ptu import cyclopean_base, perturb_mounts
from rasc.head.model import EyeCalibration, HeadCalibration
from rasc.vision.board import Board

NAME = "e4"
#: spawn_rngs key of this experiment (independent of every other experiment's draws)
KEY = 4

#: the paper's three planes, metres from the base along base +y
PLANE_DEPTHS_M = (1.622, 1.771, 1.8615)
#: --quick: the middle plane only
QUICK_DEPTHS_M = (1.771,)
#: 23×22 squares of 40 mm: the pattern is 0.92 × 0.88 m, the white quiet zone one square
#: wider on every side, 1.00 × 0.96 m — the paper's 1 m × 1 m plane; 22 + 21 is odd, so
#: the corner order is fixed by the colours (docs/CONTRACTS.md)
BOARD = Board((22, 21), 0.04)
#: nominal half-baseline for aiming (sim/models/README.md: units at base z = ±0.15 m);
#: only the commanded angles depend on it
HALF_BASELINE_AIM_M = 0.15
#: the second pose at plane k: (Δpan, Δtilt) in degrees added to both eyes' verging pose
#: (verging: 4.6–5.3° at these depths); keeps |angle| ≤ 8° (the calibrated range) and the
#: whole board with its quiet zone in both images
POSE_OFFSETS_DEG = ((2.5, 4.0), (-2.5, -4.0), (2.5, -4.0))
#: encoder noise on every reported angle, arc-seconds (1σ): "a few arc-seconds"
ENCODER_SIGMA_ARCSEC = 3.0
#: measured mounts: the middle of the paper's "< 1°, 2–3 mm"
MOUNT_ROTATION_DEG = 0.5
MOUNT_TRANSLATION_M = 0.0025
#: further seeded draws of the mount error (same sizes, random directions)
N_MOUNT_DRAWS, N_MOUNT_DRAWS_QUICK = 20, 4

MODELS = ("true", "cal_true_mounts", "cal_loop_closure", "cal_measured_mounts")
MODEL_LABELS = {
    "true": "true model, detected corners",
    "cal_true_mounts": "calibrated intrinsics + hand-eye, true mounts",
    "cal_loop_closure": "calibrated, mounts by loop closure",
    "cal_measured_mounts": "calibrated, measured mounts (0.5°, 2.5 mm)",
}
METHODS = ("ls", "tls")
AXES = ("lateral", "vertical", "depth")
#: the paper's Table 1, mm, in (lateral x, vertical y, depth z) order
PAPER_MEAN_MM = (1.02, 0.57, 18.3)
PAPER_STD_MM = (8.8, 12.8, 53.7)
#: the simulation's goal: a tenth of the paper's std
GOAL_STD_MM = (0.9, 1.3, 5.4)


# ------------------------------------------------------------------------ geometry

def paper_axes(p_base: np.ndarray) -> np.ndarray:
    """Base points (N, 3) in our axes (x up, y forward, z left) → the paper's order
    (lateral = −z, positive to the right; vertical = x; depth = y), (N, 3)."""
    p_base = np.asarray(p_base, dtype=float)
    return np.stack([-p_base[:, 2], p_base[:, 0], p_base[:, 1]], axis=1)


def plane_poses_deg(depth: float, k: int) -> list[tuple[float, float, float, float]]:
    """The two commanded poses at plane ``k`` at ``depth`` m:
    (pan_left, tilt_left, pan_right, tilt_right) in degrees.

    Pose 0: each eye turned towards the plane centre (positive pan turns left, so the
    left eye pans negative); pose 1: the same plus ``POSE_OFFSETS_DEG[k]`` on both eyes.
    """
    verge = float(np.degrees(np.arctan(HALF_BASELINE_AIM_M / depth)))
    dpan, dtilt = POSE_OFFSETS_DEG[k % len(POSE_OFFSETS_DEG)]
    return [(-verge, 0.0, verge, 0.0), (-verge + dpan, dtilt, verge + dpan, dtilt)]


def head_from_truth(truth: dict) -> HeadCalibration:
    """The true model (intrinsics, hand-eye, mounts) from a ``ground_truth.json`` dict."""
    return HeadCalibration(**{eye: EyeCalibration(
        K=np.asarray(truth[eye]["K"], float), dist=np.asarray(truth[eye]["dist"], float),
        T_cam_from_gaze=np.asarray(truth[eye]["T_cam_from_gaze"], float),
        T_ptu_from_base=np.asarray(truth[eye]["T_ptu_from_base"], float),
        image_size=tuple(truth[eye]["image_size"])) for eye in EYES})


def with_mounts(head: HeadCalibration, T_ptuL_from_ptuR: np.ndarray) -> HeadCalibration:
    """``head`` with its mounts replaced by the cyclopean base of ``T_ptuL_from_ptuR``."""
    T_pb = dict(zip(EYES, cyclopean_base(T_ptuL_from_ptuR), strict=True))
    return HeadCalibration(**{eye: EyeCalibration(
        K=getattr(head, eye).K, dist=getattr(head, eye).dist,
        T_cam_from_gaze=getattr(head, eye).T_cam_from_gaze, T_ptu_from_base=T_pb[eye],
        image_size=getattr(head, eye).image_size) for eye in EYES})


def triangulate_points(head: HeadCalibration, uv_left: np.ndarray, uv_right: np.ndarray,
                       angles_rad: np.ndarray, method: str) -> np.ndarray:
    """Base coordinates (N, 3) of matched pixels with each point's own angles.

    ``angles_rad`` (N, 4): pan_left, tilt_left, pan_right, tilt_right (the reported
    angles); docs/METHOD.md §6 via :meth:`rasc.head.model.HeadCalibration.triangulate`.
    """
    a = np.asarray(angles_rad, dtype=float)
    return head.triangulate(uv_left, uv_right, a[:, 0], a[:, 1], a[:, 2], a[:, 3],
                            method=method)


# ------------------------------------------------------------------------ simulation

def render_and_detect(depths: Sequence[float], rng: np.random.Generator) -> list[dict]:
    """Render the board at each depth from each pose, detect the corners in both eyes.

    ``depths`` are taken from :data:`PLANE_DEPTHS_M` (their index picks the pose offset).
    Returns one dict per (plane, pose): ``depth``, ``pose``, commanded angles
    ``angles_cmd_deg`` (4,), reported angles ``angles_rad`` (4,) = commanded + encoder
    noise, ``uv_left``/``uv_right`` (N, 2) detected pixels, ``p_base`` (N, 3) true
    corner positions, ``corner_rms`` {eye: px} detection error against the projected
    truth. Runs in this process (one OpenGL context).
    """
    from rasc.geometry.transforms import transform_points
    from rasc.sim import DEFAULT_SUPERSAMPLE
    from rasc.sim.scene import StereoHeadSim, T_base_from_world_facing
    from rasc.vision.camera import detect_corners

    sigma = np.radians(ENCODER_SIGMA_ARCSEC / 3600.0)
    views = []
    with StereoHeadSim(board=BOARD) as sim:
        P_world = BOARD.object_points()
        for depth in depths:
            k = PLANE_DEPTHS_M.index(depth)
            sim.set_target(T_base_from_world_facing(BOARD, distance=depth))
            p_base = transform_points(sim.T_base_from_world, P_world)
            for pose, cmd in enumerate(plane_poses_deg(depth, k)):
                cmd_rad = np.radians(cmd)
                sim.set_angles("left", cmd_rad[0], cmd_rad[1])
                sim.set_angles("right", cmd_rad[2], cmd_rad[3])
                view = {"depth": depth, "pose": pose, "angles_cmd_deg": cmd,
                        "angles_rad": cmd_rad + rng.normal(0.0, sigma, 4), "p_base": p_base,
                        "corner_rms": {}}
                for eye in EYES:
                    # as a dataset's images are rendered (RenderOptions' default)
                    image = sim.render_grey(eye, supersample=DEFAULT_SUPERSAMPLE)
                    uv = detect_corners(image, BOARD, method="saddle")
                    if uv is None:
                        raise DegenerateDataError(
                            f"E4: plane {depth} m, pose {pose} {cmd} deg, {eye} eye: board "
                            f"not found; keep the whole board with its quiet zone in view "
                            f"(smaller pose offsets)")
                    truth = sim.project_world_points(eye, P_world)
                    view[f"uv_{eye}"] = uv
                    view["corner_rms"][eye] = float(np.sqrt(np.mean(np.sum(
                        (uv - truth) ** 2, axis=1))))
                views.append(view)
    return views


def stack_views(views: list[dict]) -> dict[str, np.ndarray]:
    """Concatenate the views' points: uv_left, uv_right (N, 2), angles_rad (N, 4),
    p_base (N, 3), depth (N,), pose (N,), point (N,) (index on the board)."""
    n = [v["uv_left"].shape[0] for v in views]
    return {
        "uv_left": np.concatenate([v["uv_left"] for v in views]),
        "uv_right": np.concatenate([v["uv_right"] for v in views]),
        "angles_rad": np.concatenate([np.tile(v["angles_rad"], (m, 1))
                                      for v, m in zip(views, n, strict=True)]),
        "p_base": np.concatenate([v["p_base"] for v in views]),
        "depth": np.concatenate([np.full(m, v["depth"]) for v, m in zip(views, n, strict=True)]),
        "pose": np.concatenate([np.full(m, v["pose"]) for v, m in zip(views, n, strict=True)]),
        "point": np.concatenate([np.arange(m) for m in n]),
    }


def predicted_depth_bias_mm(P: dict[str, np.ndarray], draws: list[dict[str, str]],
                            baseline_m: float) -> np.ndarray:
    """First-order depth bias of each mount draw, mm (one per row of mount_draws.csv).

    A vergence error δ (rad; the mount's rotation error about the vertical, +: the right
    unit believed turned left) makes the rays meet nearer: ``δZ ≈ −Z² δ / b``; a baseline
    believed longer by Δb scales depth up: ``δZ ≈ Z Δb / b``. Averaged over the points'
    true depths Z (the ``true`` model's rows of points.csv).
    """
    Z = P["true"][P["model"] == "true", 1]
    out = []
    for r in draws:
        delta = np.radians(float(r["rot_err_x_deg"]))
        dbl = float(r["baseline_length_err_mm"]) / 1000.0
        out.append(1000.0 * float(np.mean(-Z ** 2 * delta / baseline_m + Z * dbl / baseline_m)))
    return np.array(out)


def mount_error_components(T_meas: np.ndarray, T_true: np.ndarray) -> np.ndarray:
    """Rotation error of a measured ``T_ptuL_from_ptuR`` as a rotation vector in the left
    ptu frame (x up, y forward, z left), degrees (3,): ``log(R_meas R_trueᵀ)``. Its x
    component is the vergence error (the right unit turned about the vertical)."""
    return np.degrees(rotvec_from_matrix(T_meas[:3, :3] @ T_true[:3, :3].T))


# ------------------------------------------------------------------------ statistics

def load_points(path) -> dict[str, np.ndarray]:
    """points.csv as arrays: model, depth (m), pose, point (N,); true, ls, tls (N, 3) m."""
    rows = read_csv(path)
    return {"model": np.array([r["model"] for r in rows]),
            "depth": np.array([float(r["depth_m"]) for r in rows]),
            "pose": np.array([int(r["pose"]) for r in rows]),
            "point": np.array([int(r["point"]) for r in rows]),
            **{k: np.array([[float(r[f"{c}_{k}"]) for c in "xyz"] for r in rows])
               for k in ("true", "ls", "tls")}}


def error_mm(P: dict[str, np.ndarray], model: str, method: str,
             depth: float | None = None) -> np.ndarray:
    """Errors (estimate − truth) in the paper's axes, mm, (n, 3), of one model's points
    (optionally one plane)."""
    sel = P["model"] == model
    if depth is not None:
        sel &= P["depth"] == depth
    return 1000.0 * (paper_axes(P[method][sel]) - paper_axes(P["true"][sel]))


def error_stats(P: dict[str, np.ndarray], model: str, method: str,
                depth: float | None = None) -> dict:
    """n, mean, std (ddof 1), RMS per axis (lateral, vertical, depth) and the mean 3-D
    error, mm."""
    e = error_mm(P, model, method, depth)
    return {"n": int(e.shape[0]), "mean": e.mean(axis=0).tolist(),
            "std": e.std(axis=0, ddof=1).tolist(),
            "rms": np.sqrt(np.mean(e ** 2, axis=0)).tolist(),
            "norm_mean": float(np.mean(np.linalg.norm(e, axis=1)))}


def _f(x: float, d: int = 2) -> str:
    return f"{x:.{d}f}"


# ------------------------------------------------------------------------ experiment

def run(ctx: Context) -> Section:
    out = ctx.dir(NAME)
    depths = QUICK_DEPTHS_M if ctx.quick else PLANE_DEPTHS_M
    n_draws = N_MOUNT_DRAWS_QUICK if ctx.quick else N_MOUNT_DRAWS
    rng_encoder, rng_mount = spawn_rngs(ctx.seed, 2, KEY)
    cal = ctx.calibration()
    truth = ctx.truth()
    T_pLpR_true = np.asarray(truth["T_ptuL_from_ptuR"], float)

    views = render_and_detect(depths, rng_encoder)
    pts = stack_views(views)
    n_points = int(pts["point"].size)

    # the four models (module docstring)
    true_head = head_from_truth(truth)
    cal_true_mounts = HeadCalibration(**{eye: EyeCalibration(
        K=getattr(cal.head, eye).K, dist=getattr(cal.head, eye).dist,
        T_cam_from_gaze=getattr(cal.head, eye).T_cam_from_gaze,
        T_ptu_from_base=getattr(true_head, eye).T_ptu_from_base,
        image_size=getattr(cal.head, eye).image_size) for eye in EYES})
    T_pLpR_draws = [perturb_mounts(T_pLpR_true, MOUNT_ROTATION_DEG, MOUNT_TRANSLATION_M, r)
                    for r in spawn_rngs(ctx.seed, n_draws, KEY, 1)]
    heads = {"true": true_head, "cal_true_mounts": cal_true_mounts,
             "cal_loop_closure": cal.head,
             "cal_measured_mounts": with_mounts(cal.head, T_pLpR_draws[0])}

    # raw results first: the poses, the detections, every triangulated point
    write_csv(out / "poses.csv",
              ["depth_m", "pose", "eye", "pan_cmd_deg", "tilt_cmd_deg", "pan_reported_deg",
               "tilt_reported_deg", "corner_rms_px"],
              [[v["depth"], v["pose"], eye, v["angles_cmd_deg"][2 * e],
                v["angles_cmd_deg"][2 * e + 1], float(np.degrees(v["angles_rad"][2 * e])),
                float(np.degrees(v["angles_rad"][2 * e + 1])), v["corner_rms"][eye]]
               for v in views for e, eye in enumerate(EYES)])
    write_csv(out / "detections.csv",
              ["depth_m", "pose", "point", "u_left", "v_left", "u_right", "v_right"],
              [[pts["depth"][i], int(pts["pose"][i]), int(pts["point"][i]),
                *pts["uv_left"][i].tolist(), *pts["uv_right"][i].tolist()]
               for i in range(n_points)])
    est = {(m, meth): triangulate_points(heads[m], pts["uv_left"], pts["uv_right"],
                                         pts["angles_rad"], meth)
           for m in MODELS for meth in METHODS}
    write_csv(out / "points.csv",
              ["model", "depth_m", "pose", "point", "x_true", "y_true", "z_true",
               "x_ls", "y_ls", "z_ls", "x_tls", "y_tls", "z_tls"],
              [[m, pts["depth"][i], int(pts["pose"][i]), int(pts["point"][i]),
                *pts["p_base"][i].tolist(), *est[m, "ls"][i].tolist(),
                *est[m, "tls"][i].tolist()]
               for m in MODELS for i in range(n_points)])
    draw_rows = []
    for d, T in enumerate(T_pLpR_draws):
        e = 1000.0 * (paper_axes(triangulate_points(
            with_mounts(cal.head, T), pts["uv_left"], pts["uv_right"], pts["angles_rad"],
            "ls")) - paper_axes(pts["p_base"]))
        w = mount_error_components(T, T_pLpR_true)
        draw_rows.append([d, *w.tolist(),
                          1000.0 * float(np.linalg.norm(T[:3, 3] - T_pLpR_true[:3, 3])),
                          1000.0 * float(np.linalg.norm(T[:3, 3])
                                         - np.linalg.norm(T_pLpR_true[:3, 3])),
                          *e.mean(axis=0).tolist(), *e.std(axis=0, ddof=1).tolist()])
    write_csv(out / "mount_draws.csv",
              ["draw", "rot_err_x_deg", "rot_err_y_deg", "rot_err_z_deg", "trans_err_mm",
               "baseline_length_err_mm",
               "mean_lateral_mm", "mean_vertical_mm", "mean_depth_mm", "std_lateral_mm",
               "std_vertical_mm", "std_depth_mm"], draw_rows)

    # everything below is computed from the files just written
    return report(ctx, out, depths, n_points)


def report(ctx: Context, out, depths: Sequence[float], n_points: int) -> Section:
    P = load_points(out / "points.csv")
    draws = read_csv(out / "mount_draws.csv")
    poses = read_csv(out / "poses.csv")
    stats = {(m, meth, d): error_stats(P, m, meth, d)
             for m in MODELS for meth in METHODS for d in (None, *depths)}
    table_rows = []
    for (m, meth, d), s in stats.items():
        table_rows.append([m, meth, "all" if d is None else d, s["n"], *s["mean"], *s["std"],
                           *s["rms"], s["norm_mean"]])
    write_csv(out / "table1.csv",
              ["model", "method", "depth_m", "n", *(f"mean_{a}_mm" for a in AXES),
               *(f"std_{a}_mm" for a in AXES), *(f"rms_{a}_mm" for a in AXES),
               "mean_3d_mm"], table_rows)
    corner_rms = [float(p["corner_rms_px"]) for p in poses]
    baseline_m = float(np.linalg.norm(np.asarray(ctx.truth()["T_ptuL_from_ptuR"])[:3, 3]))
    summary = {
        "n_points": n_points, "n_planes": len(depths), "depths_m": list(depths),
        "n_poses_per_plane": 2, "corners_per_view": BOARD.n_corners,
        "corner_rms_px_max": max(corner_rms),
        "paper_mean_mm": list(PAPER_MEAN_MM), "paper_std_mm": list(PAPER_STD_MM),
        "goal_std_mm": list(GOAL_STD_MM),
        "models": {m: {meth: {k: stats[m, meth, None][k] for k in ("mean", "std", "rms")}
                       for meth in METHODS} for m in MODELS},
        "per_depth_mean_depth_mm": {m: {str(d): stats[m, "ls", d]["mean"][2] for d in depths}
                                    for m in MODELS},
        "mount_draws_mean_depth_mm": [float(r["mean_depth_mm"]) for r in draws],
        "mount_error": {"rotation_deg": MOUNT_ROTATION_DEG,
                        "translation_mm": 1000.0 * MOUNT_TRANSLATION_M},
        "encoder_sigma_arcsec": ENCODER_SIGMA_ARCSEC,
        "baseline_m": baseline_m,
        "ls_tls_max_difference_mm": {
            m: 1000.0 * float(np.abs(P["ls"][P["model"] == m] - P["tls"][P["model"] == m]).max())
            for m in MODELS},
    }
    write_json(out / "summary.json", summary)
    files = [out / n for n in ("poses.csv", "detections.csv", "points.csv", "mount_draws.csv",
                               "table1.csv", "summary.json")]
    files += plot(P, stats, draws, depths, baseline_m, out, quick=ctx.quick)
    return Section(NAME, "E4 — Table 1: triangulation with the calibrated model",
                   markdown(ctx, P, stats, draws, depths, n_points, corner_rms, baseline_m,
                            summary["ls_tls_max_difference_mm"]),
                   files, summary)


# ------------------------------------------------------------------------ figure

def plot(P: dict[str, np.ndarray], stats: dict, draws: list[dict[str, str]],
         depths: Sequence[float], baseline_m: float, out, quick: bool = False) -> list:
    """Figure from points.csv and mount_draws.csv (three panels, see the titles)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8))
    # (a) depth error per plane, per model: mean ± std (symlog: from 0.1 mm to 0.1 m)
    ax = axes[0]
    colours = dict(zip(MODELS, ("tab:green", "tab:blue", "tab:purple", "tab:red"), strict=True))
    step = 0.006 if len(depths) > 1 else 0.02
    for j, m in enumerate(MODELS):
        x = np.array(depths) + (j - 1.5) * step
        ax.errorbar(x, [stats[m, "ls", d]["mean"][2] for d in depths],
                    yerr=[stats[m, "ls", d]["std"][2] for d in depths], fmt="o", capsize=3,
                    color=colours[m], label=MODEL_LABELS[m])
    ax.axhline(PAPER_MEAN_MM[2], color="k", ls="--", lw=1,
               label=f"paper: mean {PAPER_MEAN_MM[2]} mm (all planes)")
    ax.axhspan(PAPER_MEAN_MM[2] - PAPER_STD_MM[2], PAPER_MEAN_MM[2] + PAPER_STD_MM[2],
               color="0.88", zorder=0, label=f"paper: ± std {PAPER_STD_MM[2]} mm")
    ax.set_yscale("symlog", linthresh=1.0)
    ax.set_xlabel("plane depth (m)")
    ax.set_ylabel("depth error, estimate − truth (mm), LS\n"
                  "symlog axis: linear within ±1 mm, logarithmic beyond")
    ax.set_title("(a) depth error by plane: mean ± std")
    ax.legend(fontsize=7, loc="lower left")
    # (b) the headline model's depth error across the nearest plane (pose 0)
    ax = axes[1]
    d0 = depths[0]
    sel = (P["model"] == "cal_measured_mounts") & (P["depth"] == d0) & (P["pose"] == 0)
    true, est = paper_axes(P["true"][sel]), paper_axes(P["ls"][sel])
    sc = ax.scatter(true[:, 0], true[:, 1], c=1000.0 * (est[:, 2] - true[:, 2]), s=12,
                    cmap="viridis")
    fig.colorbar(sc, ax=ax, label="depth error (mm), LS")
    ax.set_aspect("equal")
    ax.set_xlabel("lateral (m, + right)")
    ax.set_ylabel("vertical (m, + up)")
    ax.set_title(f"(b) measured mounts, {d0} m plane, pose 0")
    # (c) mount draws: mean depth error against its first-order prediction
    ax = axes[2]
    mdep = np.array([float(r["mean_depth_mm"]) for r in draws])
    pred = predicted_depth_bias_mm(P, draws, baseline_m)
    ax.plot(pred, mdep, "o", color="tab:red",
            label=f"one draw of the mount error ({MOUNT_ROTATION_DEG}°, "
                  f"{1000 * MOUNT_TRANSLATION_M:g} mm)")
    lim = 1.1 * max(np.abs(pred).max(), np.abs(mdep).max())
    ax.plot([-lim, lim], [-lim, lim], "k--", lw=1, label="measured = predicted")
    ax.set_xlabel("first-order prediction mean(−Z²δ/b + Z·Δb/b) (mm)")
    ax.set_ylabel("mean depth error over all points (mm), LS")
    ax.set_title("(c) measured mounts: depth bias per draw")
    ax.legend(fontsize=8)
    fig.tight_layout()
    paths = save_experiment_figure(fig, out / "fig_table1", quick)
    plt.close(fig)
    return paths


# ------------------------------------------------------------------------ report text

def _quad(a: float, b: float) -> float:
    """The part of std ``a`` not explained by std ``b`` (in quadrature), ≥ 0."""
    return float(np.sqrt(max(a * a - b * b, 0.0)))


def _triple(v: Sequence[float], d: int = 2) -> str:
    return " / ".join(_f(x, d) for x in v)


def markdown(ctx: Context, P: dict[str, np.ndarray], stats: dict, draws: list[dict[str, str]],
             depths: Sequence[float],
             n_points: int, corner_rms: list[float], baseline_m: float,
             lstls: dict[str, float]) -> str:
    poses = [plane_poses_deg(d, PLANE_DEPTHS_M.index(d)) for d in depths]
    pose_text = "; ".join(
        f"{d} m: " + ", ".join("L ({:+.2f}°, {:+.1f}°) R ({:+.2f}°, {:+.1f}°)".format(*p)
                               for p in ps) for d, ps in zip(depths, poses, strict=True))
    h = stats["cal_measured_mounts", "ls", None]
    ht = stats["cal_measured_mounts", "tls", None]
    t1 = [["paper (real head, measured mounts)", *map(str, PAPER_MEAN_MM),
           *map(str, PAPER_STD_MM)],
          ["ours, measured mounts, LS", *(_f(v) for v in h["mean"]),
           *(_f(v) for v in h["std"])],
          ["ours, measured mounts, TLS", *(_f(v) for v in ht["mean"]),
           *(_f(v) for v in ht["std"])]]
    if len(depths) > 1:
        t1 += [[f"ours, measured mounts, LS, {d} m plane",
                *(_f(v) for v in stats["cal_measured_mounts", "ls", d]["mean"]),
                *(_f(v) for v in stats["cal_measured_mounts", "ls", d]["std"])]
               for d in depths]
    dec, meets = [], {}
    for m in MODELS:
        for meth in METHODS:
            s = stats[m, meth, None]
            meets[m, meth] = all(sd <= g for sd, g in zip(s["std"], GOAL_STD_MM, strict=True))
            dec.append([MODEL_LABELS[m], meth.upper(), *(_f(v, 3) for v in s["mean"]),
                        *(_f(v, 3) for v in s["std"]), _f(s["norm_mean"], 3),
                        "yes" if meets[m, meth] else "no"])
    per_depth = [[d, *(f"{_f(stats[m, 'ls', d]['mean'][2])} ± "
                       f"{_f(stats[m, 'ls', d]['std'][2])}" for m in MODELS)] for d in depths]
    mdep = np.array([float(r["mean_depth_mm"]) for r in draws])
    pred = predicted_depth_bias_mm(P, draws, baseline_m)
    sd = {m: stats[m, "ls", None]["std"] for m in MODELS}
    mn = {m: stats[m, "ls", None]["mean"] for m in MODELS}
    cal_part = [_quad(a, b) for a, b in zip(sd["cal_true_mounts"], sd["true"], strict=True)]
    mount_part = [_quad(a, b) for a, b in zip(sd["cal_measured_mounts"],
                                              sd["cal_true_mounts"], strict=True)]
    by_plane = ", ".join(_f(stats["cal_measured_mounts", "ls", d]["mean"][2], 1) for d in depths)
    needed_deg = MOUNT_ROTATION_DEG * GOAL_STD_MM[2] / max(mount_part[2], 1e-9)
    z_far, z_near = max(depths), min(depths)
    slope = z_far ** 2 / baseline_m * np.radians(1.0) * 1000.0   # δZ ≈ Z² δ / b, mm per °
    ok_models = [f"*{MODEL_LABELS[m]}*" for m in MODELS if meets[m, "ls"]]
    in_range = mdep.min() <= PAPER_MEAN_MM[2] <= mdep.max()
    grows = (len(depths) > 1 and abs(stats["cal_measured_mounts", "ls", z_far]["mean"][2])
             > abs(stats["cal_measured_mounts", "ls", z_near]["mean"][2]))
    lc_vs_true = ("smaller than" if sd["cal_loop_closure"][2] < sd["cal_true_mounts"][2]
                  else "no smaller than")
    protocol = (
        f"**Protocol.** Board 22×21 inner corners, 40 mm squares (1.00 × 0.96 m with its "
        f"quiet zone), facing the head at {', '.join(f'{d} m' for d in depths)} (base +y); "
        f"two pan/tilt poses per plane, (pan, tilt) per eye: {pose_text}. Corners detected "
        f"in both rendered 1280×960 images with `detect_corners(method=\"saddle\")` "
        f"(error against the projected truth ≤ {max(corner_rms):.3f} px RMS per image); "
        f"reported angles carry N(0, {ENCODER_SIGMA_ARCSEC:g}″) encoder noise; "
        f"**{n_points} points** in all ({BOARD.n_corners} per image pair; the paper: "
        f"2772). Intrinsics and hand-eye from the pipeline's calibration of the default "
        f"dataset (seed {ctx.seed}). Measured mounts: the true `T_ptuL_from_ptuR` turned "
        f"{MOUNT_ROTATION_DEG}° about a random axis and moved "
        f"{1000 * MOUNT_TRANSLATION_M:g} mm in a random direction (draw 0 of {len(draws)}, "
        f"seeded), then the cyclopean base. Triangulation eq. 15–19, least squares (LS) "
        f"and total least squares (TLS). Errors are estimate − truth in mm, signed means, "
        f"std with ddof 1. **Axes as the paper's:** lateral = our −z (+ right), vertical = "
        f"our x (+ up), depth = our y (+ forward).\n")
    reading = (
        f"\n**Reading.** With the true model only the detected corners (≤ "
        f"{max(corner_rms):.3f} px) and the encoder noise remain: std "
        f"{_triple(sd['true'], 3)} mm (lateral / vertical / depth), depth bias "
        f"{_f(mn['true'][2], 3)} mm. The pipeline's intrinsics and hand-eye add "
        f"{_triple(cal_part, 3)} mm in quadrature (std {_triple(sd['cal_true_mounts'], 3)}, "
        f"depth bias {_f(mn['cal_true_mounts'][2], 3)} mm). Mounts by loop closure through "
        f"the same calibrated hand-eye give a depth std {lc_vs_true} the true mounts' "
        f"({_f(sd['cal_loop_closure'][2], 3)} against {_f(sd['cal_true_mounts'][2], 3)} mm): "
        f"the loop absorbs part of the hand-eye error. The measured mounts dominate "
        f"everything: they add {_triple(mount_part)} mm in quadrature and a depth bias of "
        f"{_f(mn['cal_measured_mounts'][2])} mm. A mount error moves the estimated base "
        f"frame: its vergence component δ (rotation about the vertical) biases depth by "
        f"about −Z²δ/b ({_f(slope, 0)} mm per degree at {z_far} m, b = {baseline_m:.3f} m), "
        f"a baseline length error Δb by ZΔb/b ({_f(z_far / baseline_m, 1)} mm per mm), and "
        f"its roll component (about the forward axis) makes a disparity error that grows "
        f"with height, which tilts the reconstructed planes (panel b). Over {len(draws)} "
        f"draws of the same-sized error the mean depth error runs from {_f(mdep.min(), 1)} "
        f"to {_f(mdep.max(), 1)} mm (RMS {_f(float(np.sqrt(np.mean(mdep ** 2))), 1)} mm)"
        f"{', a range that holds the paper' + chr(39) + 's 18.3 mm' if in_range else ''}, "
        f"within {_f(float(np.abs(mdep - pred).max()), 1)} mm of that first-order "
        f"prediction (panel c). "
        f"By plane this draw gives {by_plane} mm "
        f"(the paper: about 6 mm on the closer two planes); which values a head shows "
        f"depends on its particular mount error. "
        f"The goal (std ≤ {' / '.join(map(str, GOAL_STD_MM))} mm) is met by: "
        f"{'; '.join(ok_models) if ok_models else 'no model'}; "
        f"{'not' if not meets['cal_measured_mounts', 'ls'] else 'also'} by the measured "
        f"mounts, whose {MOUNT_ROTATION_DEG}° error is the limit: scaling linearly, the "
        f"depth std goal needs a mount measured to about {_f(needed_deg)}° (and the depth "
        f"bias shrinks in proportion). Like the paper, the "
        f"depth error is by far the largest"
        f"{' and grows with depth' if grows else ''}; the paper's std is "
        f"{_f(PAPER_STD_MM[2] / max(sd['cal_measured_mounts'][2], 1e-9), 1)}× ours in depth, "
        f"which we attribute to its real images: its corners and hand-eye were far noisier "
        f"than our rendered ones (E5 places its camera poses near the lowest level of its "
        f"own noise model). LS and TLS agree to {_f(1000 * lstls['cal_loop_closure'], 1)} µm "
        f"when the model is consistent (the rays nearly meet); with the measured mounts the "
        f"rays are skew and they differ by up to {_f(lstls['cal_measured_mounts'])} mm.\n")
    text = [
        protocol,
        "**Table 1 beside the paper** (mm; all planes, then each plane; the paper gives "
        "its table over all planes only):\n",
        md_table(["", "mean lateral (x)", "mean vertical (y)", "mean depth (z)",
                  "std lateral (x)", "std vertical (y)", "std depth (z)"], t1),
        "\n**Where the error comes from** (all planes, mm; goal: std ≤ "
        f"{' / '.join(map(str, GOAL_STD_MM))}, a tenth of the paper's):\n",
        md_table(["model", "method", "mean lat.", "mean vert.", "mean depth", "std lat.",
                  "std vert.", "std depth", "mean 3-D", "std goal met"], dec),
        "\n**Depth error by plane** (mean ± std, LS, mm; the paper: about 6 mm on the "
        "closer two planes):\n",
        md_table(["plane (m)", *(MODEL_LABELS[m] for m in MODELS)], per_depth),
        f"\n![Table 1 errors]({NAME}/fig_table1.png)\n",
        reading,
    ]
    return "\n".join(text)


def main(argv=None) -> int:
    return script_main(run, __doc__, argv)


if __name__ == "__main__":
    from rasc.interrupt import exit_process
    exit_process(main())
