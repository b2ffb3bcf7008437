"""E5 — base-to-ptu calibration: loop closure against measured mounts (docs/METHOD.md §5, §9).

The paper (section 3.3) closes the loop through both units and a target seen by both
cameras at once (eq. 11–12) and finds the result 2–3° and about 1 cm off; it prefers
measuring the mounts (< 1°, 2–3 mm). Here:

* loop closure over the nine simultaneous views of the default dataset, with the
  pipeline's extrinsics and hand-eye (``ctx.calibration()``), against the model's true
  ``T_ptuL_from_ptuR``;
* measured mounts: the truth turned by a seeded rotation error drawn uniformly in
  [0, 1)° about a random axis and moved by a translation error drawn uniformly in
  [2, 3] mm in a random direction (``rasc.head.base_to_ptu.perturb_mounts``), several draws;
* why the paper's loop closure was worse: the paper's eq. 13–14 noise (its eight levels,
  docs/METHOD.md §8, exponential variant so every pose stays a rotation) added to both eyes'
  ``T_cam_from_world`` of the nine views, Monte-Carlo, then loop closure (a) with the
  hand-eye re-solved by RASC from the same noisy views (what a user of the method gets)
  and (b) with the pipeline's hand-eye held fixed (loop closure's own sensitivity).

Errors: rotation = geodesic angle between estimate and truth (degrees); translation =
distance between the two baselines' end points (mm); baseline length = signed length
difference (mm) (``rasc.head.base_to_ptu.mount_errors``).

Run::

    python -m experiments.e5_base_to_ptu [--seed S] [--quick] [--out DIR] [--workers N]

Writes ``<out>/e5/``: ``loop_closure.json``, ``measured_draws.csv``, ``montecarlo.csv``
(raw, per sample), then from those ``e5_table.csv``, ``summary.json`` and
``fig_base_to_ptu.png``/``.svg``.

``--quick`` (the reduced protocol, for tests) keeps the loop closure on the rendered
views unchanged, 5 measured-mount draws instead of 20, three Monte-Carlo levels (0, the
upper sub-paper level and the paper's level 2) with 8 samples each instead of eleven
levels with 100, both variants, and the figure as PNG only.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from experiments._common import (
    PAPER_LEVELS,
    Context,
    Section,
    md_table,
    read_csv,
    run_tasks,
    script_main,
    spawn_rngs,
    write_csv,
    write_json,
)
from experiments._figures import save_experiment_figure
from rasc.geometry.kinematics import T_gaze_from_ptu
from rasc.geometry.transforms import (
    invert_transform,
    make_transform,
    project_to_rotation,
    rotation_error_deg,
)
from rasc.handeye.noise import perturb_T_cam_from_world
from rasc.handeye.solver import solve_rasc_batch
from rasc.head.base_to_ptu import mount_errors, perturb_mounts

NAME = "e5"
#: spawn_rngs key of this experiment
KEY = 5
#: measured mounts: rotation error uniform in [0, 1) deg, translation uniform in [2, 3] mm
MEASURED_ROTATION_DEG = (0.0, 1.0)
MEASURED_TRANSLATION_MM = (2.0, 3.0)
N_MEASURED, N_MEASURED_QUICK = 20, 5
#: Monte-Carlo: level 0 (the rendered pipeline's own poses), two levels below the paper's
#: range (same σ_t/σ_r = 200 mm/rad) where loop closure crosses the paper's figures, and
#: the paper's eight levels (σ_r rad, σ_t mm)
SUB_LEVELS = ((0.001, 0.2), (0.0025, 0.5))
LEVELS = ((0.0, 0.0), *SUB_LEVELS, *PAPER_LEVELS)
QUICK_LEVELS = ((0.0, 0.0), SUB_LEVELS[1], PAPER_LEVELS[1])
#: samples per level: more than the paper's 30 (cheap here) for smooth means
N_SAMPLES, N_SAMPLES_QUICK = 100, 8
VARIANTS = ("resolved", "fixed")
VARIANT_LABELS = {"resolved": "hand-eye re-solved from the noisy views",
                  "fixed": "hand-eye held at the pipeline's"}
#: the paper's figures (section 3.3)
PAPER_LOOP_DEG, PAPER_LOOP_MM = (2.0, 3.0), 10.0
PAPER_MEASURED_DEG, PAPER_MEASURED_MM = 1.0, (2.0, 3.0)


# ------------------------------------------------------------------------ loop closure

def loop_closure_batch(T_cw_left: np.ndarray, T_cw_right: np.ndarray,
                       T_cg_left: np.ndarray, T_cg_right: np.ndarray,
                       T_gp_left: np.ndarray, T_gp_right: np.ndarray) -> np.ndarray:
    """Eq. 11–12 averaged over the views, for S samples at once.

    Parameters
    ----------
    T_cw_left, T_cw_right : ndarray, shape (S, m, 4, 4)
        ``T_cam_from_world`` of the m simultaneous views in each eye.
    T_cg_left, T_cg_right : ndarray, shape (S, 4, 4) or (4, 4)
        Hand-eye ``T_cam_from_gaze`` of each eye.
    T_gp_left, T_gp_right : ndarray, shape (m, 4, 4)
        Each unit's motion (eq. 3) at each view.

    Returns
    -------
    T_ptuL_from_ptuR : ndarray, shape (S, 4, 4)
        Rotation: the chordal L2 mean of the views' rotations (projection of their
        element-wise mean onto SO(3)), translation: the arithmetic mean — the same
        average as :func:`rasc.head.base_to_ptu.T_ptuL_from_ptuR_loop_closure` (tested).
    """
    T_cg_left = np.asarray(T_cg_left, float)
    T_cg_right = np.asarray(T_cg_right, float)
    if T_cg_left.ndim == 2:
        T_cg_left = T_cg_left[None]
    if T_cg_right.ndim == 2:
        T_cg_right = T_cg_right[None]
    # eq. 12: T_ptu_from_world = T_ptu_from_gaze T_gaze_from_cam T_cam_from_world per eye
    T_pw_L = invert_transform(T_gp_left)[None] @ invert_transform(T_cg_left)[:, None] \
        @ T_cw_left
    T_pw_R = invert_transform(T_gp_right)[None] @ invert_transform(T_cg_right)[:, None] \
        @ T_cw_right
    T = T_pw_L @ invert_transform(T_pw_R)                              # (S, m, 4, 4)
    return make_transform(project_to_rotation(T[:, :, :3, :3].mean(axis=1)),
                          T[:, :, :3, 3].mean(axis=1))


def errors_batch(T_est: np.ndarray, T_true: np.ndarray) -> np.ndarray:
    """(S, 3): rotation error (deg), translation error (mm), baseline length error (mm)
    of estimates (S, 4, 4) against the truth (4, 4), metres in."""
    rot = rotation_error_deg(T_est[:, :3, :3], T_true[None, :3, :3])
    trans = 1000.0 * np.linalg.norm(T_est[:, :3, 3] - T_true[:3, 3], axis=1)
    base = 1000.0 * (np.linalg.norm(T_est[:, :3, 3], axis=1) - np.linalg.norm(T_true[:3, 3]))
    return np.stack([rot, trans, base], axis=1)


@dataclass(frozen=True)
class MonteCarloTask:
    """One noise level of the loop-closure Monte-Carlo (:func:`montecarlo_task`)."""

    #: the level's index (its generator's key)
    level: int
    sigma_r: float                  # rad
    sigma_t: float                  # m
    seed: int
    n_samples: int
    #: the views both eyes saw at once: {eye: (m, 4, 4)}
    T_cw: dict
    T_gp: dict
    #: the calibrated hand-eye transforms {eye: (4, 4)}, the true T_ptuL_from_ptuR (4, 4)
    T_cg: dict
    T_true: np.ndarray


def montecarlo_task(task: MonteCarloTask) -> np.ndarray:
    """One noise level: (2, S, 3) errors for the variants ("resolved", "fixed")."""
    (rng,) = spawn_rngs(task.seed, 1, KEY, task.level)
    S = task.n_samples
    noisy = {}
    for eye in ("left", "right"):   # left first, then right: a fixed draw order
        T = np.broadcast_to(task.T_cw[eye], (S, *task.T_cw[eye].shape))
        noisy[eye] = perturb_T_cam_from_world(T, task.sigma_r, task.sigma_t, rng,
                                              variant="exponential")
    T_cg_resolved = {eye: solve_rasc_batch(noisy[eye], task.T_gp[eye]).T_cam_from_gaze
                     for eye in ("left", "right")}
    out = []
    for T_cg in (T_cg_resolved, task.T_cg):
        T = loop_closure_batch(noisy["left"], noisy["right"], T_cg["left"], T_cg["right"],
                               task.T_gp["left"], task.T_gp["right"])
        out.append(errors_batch(T, task.T_true))
    return np.stack(out)


# ------------------------------------------------------------------------ experiment

def run(ctx: Context) -> Section:
    out = ctx.dir(NAME)
    levels = QUICK_LEVELS if ctx.quick else LEVELS
    n_samples = N_SAMPLES_QUICK if ctx.quick else N_SAMPLES
    n_measured = N_MEASURED_QUICK if ctx.quick else N_MEASURED
    cal = ctx.calibration()
    truth = ctx.truth()
    T_true = np.asarray(truth["T_ptuL_from_ptuR"], float)

    # the views both eyes saw at the same time (the pipeline's pairing)
    L, R = cal.eyes["left"], cal.eyes["right"]
    common = [v for v in L.views if v in set(R.views)]
    iL = [L.views.index(v) for v in common]
    iR = [R.views.index(v) for v in common]
    T_cw = {"left": L.T_cam_from_world[iL], "right": R.T_cam_from_world[iR]}
    T_gp = {"left": T_gaze_from_ptu(L.pan_tilt[iL, 0], L.pan_tilt[iL, 1]),
            "right": T_gaze_from_ptu(R.pan_tilt[iR, 0], R.pan_tilt[iR, 1])}
    T_cg = {"left": L.handeye.T_cam_from_gaze, "right": R.handeye.T_cam_from_gaze}

    # loop closure as the pipeline computed it
    T_loop = np.asarray(cal.base["loop_closure"]["T_ptuL_from_ptuR"], float)
    err = mount_errors(T_loop, T_true)
    write_json(out / "loop_closure.json", {
        "views": common, "T_ptuL_from_ptuR": T_loop.tolist(), "T_true": T_true.tolist(),
        "rotation_error_deg": err.rotation_deg, "translation_error_mm": 1000 * err.translation,
        "baseline_length_error_mm": 1000 * err.baseline_length,
        "spread": cal.base["loop_closure"]["spread"],
        "handeye_error": {eye: cal.errors[eye]["T_cam_from_gaze"] for eye in ("left", "right")},
        # the views' own error: the largest over both eyes' pose extrinsics
        "pose_error_max": {
            "rotation_deg": max(cal.errors[e]["pose_extrinsics_max"]["rotation_deg"]
                                for e in ("left", "right")),
            "translation_mm": 1000 * max(cal.errors[e]["pose_extrinsics_max"]["translation"]
                                         for e in ("left", "right"))},
    })

    # measured mounts, seeded draws
    rows = []
    for k, rng in enumerate(spawn_rngs(ctx.seed, n_measured, KEY, 0)):
        rot = float(rng.uniform(*MEASURED_ROTATION_DEG))
        trans = float(rng.uniform(*MEASURED_TRANSLATION_MM)) / 1000.0
        me = mount_errors(perturb_mounts(T_true, rot, trans, rng), T_true)
        rows.append([k, me.rotation_deg, 1000 * me.translation, 1000 * me.baseline_length])
    write_csv(out / "measured_draws.csv",
              ["draw", "rotation_deg", "translation_mm", "baseline_length_mm"], rows)

    # Monte-Carlo: eq. 13–14 noise on both eyes' views, loop closure
    tasks = [MonteCarloTask(level=k, sigma_r=sr, sigma_t=st / 1000.0, seed=ctx.seed,
                            n_samples=n_samples, T_cw=T_cw, T_gp=T_gp, T_cg=T_cg,
                            T_true=T_true) for k, (sr, st) in enumerate(levels)]
    results = run_tasks(montecarlo_task, tasks, ctx.workers, label="E5 loop closure")
    write_csv(out / "montecarlo.csv",
              ["level", "sigma_r_rad", "sigma_t_mm", "variant", "sample", "rotation_deg",
               "translation_mm", "baseline_length_mm"],
              [[k, sr, st, v, s, *res[j, s].tolist()]
               for k, ((sr, st), res) in enumerate(zip(levels, results, strict=True))
               for j, v in enumerate(VARIANTS) for s in range(n_samples)])

    return report(ctx, out)


def crossing(x: Sequence[float], y: Sequence[float], target: float) -> float | None:
    """First ``x`` at which ``y`` (increasing on the whole) reaches ``target``, linear
    between samples; None when it never does."""
    for k in range(1, len(x)):
        if y[k - 1] < target <= y[k]:
            return float(x[k - 1] + (target - y[k - 1]) * (x[k] - x[k - 1]) / (y[k] - y[k - 1]))
    return float(x[0]) if len(y) and y[0] >= target else None


def report(ctx: Context, out) -> Section:
    import json

    with open(out / "loop_closure.json") as f:
        loop = json.load(f)
    measured = read_csv(out / "measured_draws.csv")
    mc = read_csv(out / "montecarlo.csv")
    m_rot = np.array([float(r["rotation_deg"]) for r in measured])
    m_tr = np.array([float(r["translation_mm"]) for r in measured])
    m_bl = np.array([float(r["baseline_length_mm"]) for r in measured])

    levels = sorted({(int(r["level"]), float(r["sigma_r_rad"]), float(r["sigma_t_mm"]))
                     for r in mc})
    table = []
    stats: dict[str, dict[str, list[float]]] = {v: {} for v in VARIANTS}
    for v in VARIANTS:
        cols: dict[str, list[float]] = {k: [] for k in ("sigma_r", "sigma_t", "rot_mean",
                                                        "rot_std", "tr_mean", "tr_std",
                                                        "bl_mean", "bl_std")}
        for k, sr, st in levels:
            sel = [r for r in mc if int(r["level"]) == k and r["variant"] == v]
            e = np.array([[float(r["rotation_deg"]), float(r["translation_mm"]),
                           float(r["baseline_length_mm"])] for r in sel])
            mean, std = e.mean(axis=0), e.std(axis=0, ddof=1)
            for name, val in zip(cols, (sr, st, mean[0], std[0], mean[1], std[1], mean[2],
                                        std[2]), strict=True):
                cols[name].append(float(val))
            table.append([k, sr, st, v, len(sel), *mean.tolist(), *std.tolist()])
        stats[v] = cols
    write_csv(out / "e5_table.csv",
              ["level", "sigma_r_rad", "sigma_t_mm", "variant", "n", "rotation_deg_mean",
               "translation_mm_mean", "baseline_length_mm_mean", "rotation_deg_std",
               "translation_mm_std", "baseline_length_mm_std"], table)

    crossings = {v: {"rot_2deg_sigma_r": crossing(stats[v]["sigma_r"], stats[v]["rot_mean"],
                                                  PAPER_LOOP_DEG[0]),
                     "rot_3deg_sigma_r": crossing(stats[v]["sigma_r"], stats[v]["rot_mean"],
                                                  PAPER_LOOP_DEG[1]),
                     "tr_10mm_sigma_t": crossing(stats[v]["sigma_t"], stats[v]["tr_mean"],
                                                 PAPER_LOOP_MM)}
                 for v in VARIANTS}
    summary = {
        "loop_closure": {"rotation_deg": loop["rotation_error_deg"],
                         "translation_mm": loop["translation_error_mm"],
                         "baseline_length_mm": loop["baseline_length_error_mm"],
                         "n_views": len(loop["views"])},
        "measured": {"n_draws": len(measured), "rotation_deg_mean": float(m_rot.mean()),
                     "rotation_deg_max": float(m_rot.max()),
                     "translation_mm_mean": float(m_tr.mean()),
                     "translation_mm_max": float(m_tr.max())},
        "montecarlo": {v: stats[v] for v in VARIANTS},
        "crossings": crossings,
        "pose_error_max": loop["pose_error_max"],
        "n_samples": len([r for r in mc if r["level"] == "0" and r["variant"] == "fixed"]),
        "paper": {"loop_closure_deg": list(PAPER_LOOP_DEG), "loop_closure_mm": PAPER_LOOP_MM,
                  "measured_deg_max": PAPER_MEASURED_DEG,
                  "measured_mm": list(PAPER_MEASURED_MM)},
    }
    write_json(out / "summary.json", summary)
    files = [out / n for n in ("loop_closure.json", "measured_draws.csv", "montecarlo.csv",
                               "e5_table.csv", "summary.json")]
    files += plot(stats, loop, m_rot, m_tr, out, quick=ctx.quick)
    return Section(NAME, "E5 — base-to-ptu: loop closure against measured mounts",
                   markdown(ctx, loop, m_rot, m_tr, m_bl, stats, summary), files, summary)


def plot(stats: dict, loop: dict, m_rot: np.ndarray, m_tr: np.ndarray, out,
         quick: bool = False) -> list:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    colours = {"resolved": "tab:blue", "fixed": "tab:orange"}
    x_measured = -0.6  # where our measured-mount draws are drawn (a labelled tick)
    for ax, key, unit, paper_loop, paper_meas, ours, meas in (
            (axes[0], "rot", "rotation error (deg)", PAPER_LOOP_DEG,
             (1e-3, PAPER_MEASURED_DEG), loop["rotation_error_deg"], m_rot),
            (axes[1], "tr", "translation error (mm)",
             (PAPER_LOOP_MM * 0.8, PAPER_LOOP_MM * 1.2), PAPER_MEASURED_MM,
             loop["translation_error_mm"], m_tr)):
        x = np.array(stats["resolved"]["sigma_r"]) * 1000.0
        for v in VARIANTS:
            ax.errorbar(x * (1.04 if v == "fixed" else 1.0), stats[v][f"{key}_mean"],
                        yerr=stats[v][f"{key}_std"], fmt="o-", capsize=3, color=colours[v],
                        label=f"loop closure, eq. 13–14 noise on the views; "
                              f"{VARIANT_LABELS[v]} (mean ± std)")
        ax.axhspan(*paper_loop, color="tab:red", alpha=0.15,
                   label="paper: loop closure, 2–3° / ~1 cm")
        ax.axhspan(*paper_meas, color="tab:green", alpha=0.15,
                   label="paper: measured mounts, < 1° / 2–3 mm")
        ax.plot([0.0], [ours], "k*", ms=12, label="ours: loop closure on the rendered views")
        ax.plot(np.full_like(meas, x_measured), meas, "g_", ms=12,
                label="ours: measured mounts (seeded draws)")
        ax.set_xscale("symlog", linthresh=1.0)
        ticks = [0.0, 1.0, 2.5, 5.0, 10.0, 20.0, 40.0]
        ax.set_xticks([x_measured, *ticks],
                      ["meas.", *(f"{t:g}" for t in ticks)])
        ax.set_xlim(-1.0, 55.0)
        ax.set_xlabel("eq. 13–14 noise level σ_r (mrad); σ_t = 0.2 mm per mrad")
        ax.set_ylabel(unit)
        ax.set_yscale("log")
    axes[0].set_title("T_ptuL_from_ptuR: rotation error")
    axes[1].set_title("T_ptuL_from_ptuR: translation error")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8,
               bbox_to_anchor=(0.5, -0.02))
    fig.tight_layout(rect=(0, 0.14, 1, 1))
    paths = save_experiment_figure(fig, out / "fig_base_to_ptu", quick)
    plt.close(fig)
    return paths


def _f(x: float | None, d: int = 2) -> str:
    return "—" if x is None else f"{x:.{d}f}"


def _crossing_text(summary: dict, variant: str, stats: dict) -> str:
    """'its rotation error reaches 2° at …; its translation error …' from the crossings."""
    c = summary["crossings"][variant]
    s = stats[variant]
    if c["rot_2deg_sigma_r"] is not None:
        rot = (f"its rotation error reaches 2° at σ_r ≈ {c['rot_2deg_sigma_r']:.4f} rad"
               + (f" and 3° at {c['rot_3deg_sigma_r']:.4f} rad"
                  if c["rot_3deg_sigma_r"] is not None else ""))
    else:
        rot = (f"its rotation error stays below 2° up to σ_r = {s['sigma_r'][-1]:g} rad "
               f"({s['rot_mean'][-1]:.2f}°)")
    if c["tr_10mm_sigma_t"] is not None:
        tr = f"its translation error reaches 1 cm at σ_t ≈ {c['tr_10mm_sigma_t']:.2f} mm"
    else:
        tr = (f"its translation error stays below 1 cm up to σ_t = {s['sigma_t'][-1]:g} mm "
              f"({s['tr_mean'][-1]:.1f} mm)")
    return f"{rot}; {tr}"


def _set_name(sigma_r: float, sigma_t: float) -> str:
    """A noise level by E1's names: set 0 (none), set k (the paper's k-th), or below set 1."""
    if sigma_r == 0 and sigma_t == 0:
        return "set 0"
    for k, level in enumerate(PAPER_LEVELS):
        if (sigma_r, sigma_t) == tuple(level):
            return f"set {k + 1}"
    return "below set 1"


def markdown(ctx: Context, loop: dict, m_rot, m_tr, m_bl, stats: dict, summary: dict) -> str:
    res, fix = stats["resolved"], stats["fixed"]
    n_levels = len(res["sigma_r"])
    paper_first = PAPER_LEVELS[0]
    rows = [["paper: loop closure (real head)", "2–3", "~10", ""],
            ["paper: measured mounts", "< 1", "2–3", ""],
            [f"ours: loop closure over {summary['loop_closure']['n_views']} rendered views",
             _f(loop["rotation_error_deg"], 4), _f(loop["translation_error_mm"], 3),
             _f(loop["baseline_length_error_mm"], 3)],
            [f"ours: measured mounts, {len(m_rot)} draws (mean; max)",
             f"{_f(m_rot.mean())}; {_f(m_rot.max())}", f"{_f(m_tr.mean())}; {_f(m_tr.max())}",
             f"{_f(np.abs(m_bl).mean())}; {_f(np.abs(m_bl).max())} (absolute)"]]
    mc_rows = [[_set_name(res['sigma_r'][k], res['sigma_t'][k]),
                f"{res['sigma_r'][k]:g} / {res['sigma_t'][k]:g}",
                f"{_f(res['rot_mean'][k], 3)} ± {_f(res['rot_std'][k], 3)}",
                f"{_f(res['tr_mean'][k], 2)} ± {_f(res['tr_std'][k], 2)}",
                f"{_f(fix['rot_mean'][k], 3)} ± {_f(fix['rot_std'][k], 3)}",
                f"{_f(fix['tr_mean'][k], 2)} ± {_f(fix['tr_std'][k], 2)}"]
               for k in range(n_levels)]
    pe = summary["pose_error_max"]
    sets = "the paper's sets 1–8" if n_levels == 11 else "a subset of the paper's sets"
    k1 = next((k for k in range(n_levels)
               if (res["sigma_r"][k], res["sigma_t"][k]) == paper_first), None)
    c = summary["crossings"]["resolved"]
    c2, c3 = c["rot_2deg_sigma_r"], c["rot_3deg_sigma_r"]
    better = loop["rotation_error_deg"] < m_rot.mean() and \
        loop["translation_error_mm"] < m_tr.mean()
    text = [
        f"**Protocol.** Loop closure (eq. 11–12) over the {summary['loop_closure']['n_views']} "
        f"simultaneous views of the default dataset (the paper's nine ±8° poses, both eyes, "
        f"board 1 m ahead; seed {ctx.seed}), with the pipeline's extrinsics and RASC "
        f"hand-eye; rotations averaged by the chordal L2 mean, translations by the mean. "
        f"Measured mounts: the true `T_ptuL_from_ptuR` with a rotation error uniform in "
        f"[{MEASURED_ROTATION_DEG[0]:g}, {MEASURED_ROTATION_DEG[1]:g})° about a random axis "
        f"and a translation error uniform in [{MEASURED_TRANSLATION_MM[0]:g}, "
        f"{MEASURED_TRANSLATION_MM[1]:g}] mm in a random direction, {len(m_rot)} seeded "
        f"draws. Monte-Carlo: the paper's eq. 13–14 noise (exponential form, so every pose "
        f"stays rigid) added to both eyes' nine `T_cam_from_world` (the pipeline's), "
        f"{summary['n_samples']} samples per level, at set 0 (no added noise), two levels "
        f"below set 1 and {sets}"
        f"{'' if n_levels == 11 else ' (--quick)'} (E1's names); then loop closure with the "
        f"hand-eye re-solved by RASC from the same noisy views, or held at the pipeline's.\n",
        "**Base-to-ptu errors beside the paper** (`T_ptuL_from_ptuR` against the truth):\n",
        md_table(["", "rotation (°)", "translation (mm)", "baseline length (mm)"], rows),
        "\n**Loop closure under the paper's noise model** (mean ± std over the samples):\n",
        md_table(["noise set", "σ_r (rad) / σ_t (mm)", "rotation (°), hand-eye re-solved",
                  "translation (mm), re-solved", "rotation (°), hand-eye fixed",
                  "translation (mm), fixed"], mc_rows),
        f"\n![E5 base-to-ptu]({NAME}/fig_base_to_ptu.png)\n",
        f"\n**Reading.** On rendered images loop closure is "
        f"{_f(loop['rotation_error_deg'], 3)}° and {_f(loop['translation_error_mm'], 2)} mm "
        f"off: {'better' if better else 'not better'} than measuring the mounts "
        f"({_f(m_rot.mean())}° and {_f(m_tr.mean())} mm on average)"
        f"{', the reverse of the paper' if better else ', as in the paper'}. The difference "
        f"is the camera poses: the pipeline's per-view extrinsics are within "
        f"{pe['rotation_deg']:.4f}° ({np.radians(pe['rotation_deg']):.1e} rad) and "
        f"{pe['translation_mm']:.3f} mm of the truth, far below the lowest level of the "
        f"paper's noise model ({paper_first[0]} rad, {paper_first[1]:g} mm). With that noise "
        f"model on the views, loop closure with the hand-eye re-solved from the same views "
        f"(what the method gives a user): {_crossing_text(summary, 'resolved', stats)}"
        + (f"; at set 1, the paper's lowest level, it is {_f(res['rot_mean'][k1])}° / "
           f"{_f(res['tr_mean'][k1], 1)} mm off" if k1 is not None else "")
        + f". With the hand-eye held fixed: {_crossing_text(summary, 'fixed', stats)}. "
        f"Most of the loop's error thus comes from the hand-eye, which ±8° motions "
        f"determine poorly under such noise (E1); averaging nine views keeps the loop "
        f"itself robust. "
        + (f"So the paper's 2–3° is what its own noise model predicts at σ_r ≈ {c2:.4f}–"
           f"{c3:.4f} rad ({np.degrees(c2):.2f}–{np.degrees(c3):.2f}° per axis on every "
           f"view), about its lowest level: real camera poses of that quality make loop "
           f"closure worse than a measurement of the mounts, as the paper found; poses as "
           f"good as ours make it better.\n"
           if c2 is not None and c3 is not None else
           "The paper's 2–3° is not reached within these levels with this dataset.\n"),
    ]
    return "\n".join(text)


def main(argv=None) -> int:
    return script_main(run, __doc__, argv)


if __name__ == "__main__":
    from rasc.interrupt import exit_process
    exit_process(main())
