"""E8 — beyond the paper: wide pan-tilt motions with a ChArUco board seen in part (issue 23).

The hand-eye translation error grows like 1/θ for motions of angle θ (eq. 7's
``(I − A_ij)`` is of size θ), and the paper's protocol keeps the whole chessboard in view,
hence its ±8° at a 1 m board. A ChArUco board counts when seen in part, so the motions can
be as wide as the joint ranges allow. For two heads — the ideal unit and a tilt axis
20 mm off the pan axis (along the common normal, the observable direction) — the MuJoCo
head is rendered (``rasc.sim.render.render_dataset``) and calibrated by the pipeline:

* ``chessboard ±8°``: the paper's protocol (the default 9×6 board of 50 mm squares, the
  paper's nine positions);
* ``charuco ±A°`` for A = 8, 15, 30, 45: a wall-sized ChArUco board (20×15 squares of
  170 mm, 127 mm markers, DICT_5X5_250: 3.4 m × 2.55 m) 1 m ahead, the paper's nine
  positions scaled to ±A° (tilt clipped to the joint range, ±30° at most: the tilt joint
  stops at +30°); a position where an eye sees fewer than ``MIN_VIEW_CORNERS`` corners is
  skipped by the pipeline (one line, not an error). The board is sized so that the image
  is full of corners at every position up to ±30° (the camera's half field of view is
  29° × 23°, so the board spans ±(30° + 29°) across and ±(30° + 23°) up and down, plus
  the eyes' ±0.15 m): the per-view pose error then stays the same at every amplitude and
  only eq. 7's ``(I − A)`` grows (``experiments/e8_limits.py`` measures both). A smaller
  board seen in part (16×12 squares of 75 mm) shows fewer corners at wide positions and
  loses most of the 1/θ gain to them.

Each seed places the target anew, at a distance drawn from :data:`PLACEMENT_RANGE_M`
with the seed (:func:`placement_distance`; the same for every head and protocol of the
seed). A render's corner errors are nearly all a deterministic function of where the
board falls on the pixel grid (0.016 px RMS in the pose views, the same with no image
noise or with 0.7 px of blur; ``experiments/plan_check.py`` and docs/topics/plan.md), so
seeds at one placement would share them: more seeds would average only the intrinsics
views and the image noise, and every protocol's error would carry one draw of its
systematic part.

Each is scored against the renderer's truth, closed form (``paper``: RASC + loop
closure) and refined (``general``: the whole-head refinement, ``--scales auto``):
hand-eye error (rotation, translation, per eye; canonical gauge) and the triangulation
error of E7 (:func:`experiments.e7_model_mismatch.triangulation_errors`: 21×21 points on
planes at 1.6–1.9 m seen from two poses, projected through the true head). The figure
draws the hand-eye translation error against A with the 1/θ law through the ChArUco ±8°
point. ``--synthetic``: projected corners with 0.015 px noise (``rasc.sim.synthetic``,
the same board and positions) instead of renders.

``--quick``: the ideal head only, ChArUco at ±8° and ±30°, 8 intrinsics views per eye.

Run::

    python experiments/e8_wide.py [--seed S] [--seeds N] [--quick] [--out DIR]
                                  [--workers N] [--synthetic]

Writes ``<out>/e8/``: ``cases.csv`` (one row per head × protocol × model × eye),
``triangulation.csv``, ``summary.json``, then from those ``fig_wide_motions.png`` and
``e8.md``.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:       # run as a script: experiments.e7_model_mismatch
    sys.path.insert(0, str(REPO))

from experiments.e7_model_mismatch import _csv, triangulation_errors, true_head  # noqa: E402

NAME = "e8"
EYES = ("left", "right")
MODELS = ("paper", "general")
#: (head id, label, UnitBuild fields for both units)
HEADS = (("ideal", "ideal unit", {}),
         ("offset20", "tilt axis 20 mm off", {"tilt_axis_offset_mm": (0.0, 20.0, 0.0)}))
#: (protocol id, target, amplitude in degrees)
PROTOCOLS = (("chess8", "chessboard", 8.0), ("charuco8", "charuco", 8.0),
             ("charuco15", "charuco", 15.0), ("charuco30", "charuco", 30.0),
             ("charuco45", "charuco", 45.0))
QUICK_HEADS = ("ideal",)
QUICK_PROTOCOLS = ("charuco8", "charuco30")
#: the ChArUco board: a wall (3.4 m × 2.55 m) that fills the image at every position up
#: to ±30° (module docstring)
CHARUCO = dict(squares=(20, 15), square_size=0.17, marker_size=0.127,
               dictionary="DICT_5X5_250")
#: the tilt joint's range is [-45°, +30°] (rasc/sim/models/stereo_head.xml): tilts are
#: clipped symmetrically to ±30°
TILT_LIMIT_DEG = 30.0
N_INTRINSICS = 20
N_INTRINSICS_QUICK = 8
SYNTHETIC_NOISE_PX = 0.015        # as E7's
#: the rendered target's distance ahead of the head (m), drawn per seed: as
#: experiments/plan_check.py's --jitter (farther than 1 m only, so that the chessboard
#: stays whole at ±8°)
PLACEMENT_RANGE_M = (1.0, 1.06)


def placement_distance(seed: int) -> float:
    """The rendered target's distance for ``seed`` (module docstring)."""
    return float(np.random.default_rng([seed, 8]).uniform(*PLACEMENT_RANGE_M))


def target(kind: str):
    from rasc.vision.board import DEFAULT_BOARD, CharucoBoard

    return DEFAULT_BOARD if kind == "chessboard" else CharucoBoard(**CHARUCO)


def positions(amplitude: float) -> tuple[tuple[float, float], ...]:
    """The paper's nine positions (rasc.geometry.kinematics.PAPER_POSES_DEG) scaled to
    ±amplitude, tilt clipped to ±TILT_LIMIT_DEG."""
    from rasc.geometry.kinematics import PAPER_POSES_DEG

    a, t = amplitude / 8.0, min(amplitude, TILT_LIMIT_DEG) / 8.0
    return tuple((p * a, q * t) for p, q in PAPER_POSES_DEG)


@dataclass(frozen=True)
class CaseTask:
    """One case of E8 (:func:`run_case`): the head (its id and the unit's imperfections,
    fields of :class:`rasc.sim.units.UnitBuild`), the protocol (its name, target kind and
    amplitude), the seed, the intrinsics views, and whether it is projected
    (``synthetic``) instead of rendered."""

    head: str
    fields: dict
    protocol: str
    target: str
    amplitude_deg: float
    seed: int
    intrinsics_views: int
    synthetic: bool


def run_case(task: CaseTask) -> dict:
    """Render (or project) one head × protocol, calibrate closed form and refined, score."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    head_id, fields, proto, kind = task.head, task.fields, task.protocol, task.target
    amp, seed, n_intr, synthetic = (task.amplitude_deg, task.seed, task.intrinsics_views,
                                    task.synthetic)
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset, refine_calibration

    board = target(kind)
    poses = positions(amp)
    distance = 1.0 if synthetic else placement_distance(seed)
    skipped: list[str] = []
    if synthetic:
        dataset, truth = _synthetic(fields, seed, board, poses, n_intr)
    else:
        from rasc.sim.render import RenderOptions, render_dataset
        from rasc.sim.units import UnitBuild
        from rasc.vision.dataset import load_dataset

        tmp = tempfile.TemporaryDirectory(prefix=f"rasc-e8-{head_id}-{proto}-")
        units = {eye: UnitBuild(**fields) for eye in EYES} if fields else None
        render_dataset(Path(tmp.name) / "ds", RenderOptions(seed=seed, poses_deg=poses,
                                                            intrinsics_views=n_intr,
                                                            distance=distance),
                       units=units, quiet=True, board=board)
        dataset = load_dataset(Path(tmp.name) / "ds")
        truth = dataset.load_ground_truth()
    cal_p = calibrate_dataset(dataset, CalibrationOptions(model="paper"),
                              log=lambda s: skipped.append(s)
                              if "skipped" in s else None)
    cal_g = refine_calibration(cal_p, dataset)
    true = true_head(truth)
    out = {"head": head_id, "protocol": proto, "target": kind, "amplitude_deg": amp,
           "seed": seed, "distance_m": distance,
           "positions_deg": [list(p) for p in poses],
           "positions_used": {eye: len(cal_p.eyes[eye].pose_files) for eye in EYES},
           "skipped": skipped, "models": {}}
    for model, cal in (("paper", cal_p), ("general", cal_g)):
        e = cal.errors
        out["models"][model] = {
            "handeye": {eye: {"rotation_deg": e[eye]["T_cam_from_gaze"]["rotation_deg"],
                              "translation_mm": 1000 * e[eye]["T_cam_from_gaze"]["translation"]}
                        for eye in EYES},
            "triangulation": triangulation_errors(true, cal.head)}
    if not synthetic:
        tmp.cleanup()
    return out


def _synthetic(fields: dict, seed: int, board, poses, n_intr):
    from rasc.geometry.kinematics import PanTiltUnit, canonical_gauge
    from rasc.sim.synthetic import corner_dataset, default_head

    d = fields.get("tilt_axis_offset_mm", (0.0, 0.0, 0.0))
    unit = PanTiltUnit(tilt_point=tuple(v / 1000.0 for v in d))
    ds = corner_dataset(default_head(unit), seed=seed, noise_px=SYNTHETIC_NOISE_PX,
                        board=board, poses_deg=poses, n_intrinsics=n_intr)
    truth = {"image_size": list(ds.sizes["left"]),
             "T_ptuL_from_ptuR": ds.truth.T_ptuL_from_ptuR().tolist()}
    for eye in EYES:
        u, T_cg, T_pb = canonical_gauge(ds.truth.unit[eye], ds.truth.T_cam_from_gaze[eye],
                                        ds.truth.T_ptu_from_base[eye])
        truth[eye] = {"K": ds.truth.K[eye].tolist(), "dist": ds.truth.dist[eye].tolist(),
                      "T_cam_from_gaze": T_cg.tolist(), "T_ptu_from_base": T_pb.tolist(),
                      "unit": u.to_dict()}
    ds.load_ground_truth = lambda: truth
    ds.ground_truth = Path("<synthetic truth>")
    return ds, truth


# ----------------------------------------------------------------------------- outputs

def combine(results: list[dict]) -> list[dict]:
    """One entry per head × protocol (in run order) over its seeds: hand-eye errors the
    RMS over the seeds (per eye), triangulation errors the mean over the seeds (per
    plane), positions used the fewest; ``seeds`` the number merged."""
    groups: dict[tuple, list[dict]] = {}
    for r in results:
        groups.setdefault((r["head"], r["protocol"]), []).append(r)
    out = []
    for rs in groups.values():
        c = {k: rs[0][k] for k in ("head", "protocol", "target", "amplitude_deg")}
        c["seeds"] = len(rs)
        c["positions_used"] = {e: min(r["positions_used"][e] for r in rs) for e in EYES}
        c["models"] = {}
        for m in MODELS:
            he = {e: {q: float(np.sqrt(np.mean([r["models"][m]["handeye"][e][q] ** 2
                                                 for r in rs])))
                      for q in ("rotation_deg", "translation_mm")} for e in EYES}
            tri = [{"depth_m": t["depth_m"], "points": t["points"],
                    "mean_mm": float(np.mean([r["models"][m]["triangulation"][i]["mean_mm"]
                                              for r in rs])),
                    "rms_mm": float(np.mean([r["models"][m]["triangulation"][i]["rms_mm"]
                                             for r in rs]))}
                   for i, t in enumerate(rs[0]["models"][m]["triangulation"])]
            c["models"][m] = {"handeye": he, "triangulation": tri}
        out.append(c)
    return out


def _he(r: dict, model: str) -> float:
    """Hand-eye translation error (mm), mean of the two eyes."""
    return float(np.mean([r["models"][model]["handeye"][e]["translation_mm"] for e in EYES]))


def _tri(r: dict, model: str) -> float:
    t = r["models"][model]["triangulation"]
    return float(sum(x["mean_mm"] * x["points"] for x in t) / sum(x["points"] for x in t))


def write_raw(results: list[dict], folder: Path) -> None:
    from rasc.io import write_text_atomic

    rows = []
    for r in results:
        for model in MODELS:
            for eye in EYES:
                h = r["models"][model]["handeye"][eye]
                rows.append([r["head"], r["protocol"], r["target"], r["amplitude_deg"],
                             r["seed"], model, eye, r["positions_used"][eye],
                             f"{h['rotation_deg']:.6g}", f"{h['translation_mm']:.6g}"])
    _csv(folder / "cases.csv", ["head", "protocol", "target", "amplitude_deg", "seed", "model",
                                "eye", "positions_used", "handeye_rotation_deg",
                                "handeye_translation_mm"], rows)
    rows = [[r["head"], r["protocol"], r["seed"], model, t["depth_m"], t["points"],
             f"{t['mean_mm']:.6g}", f"{t['rms_mm']:.6g}"]
            for r in results for model in MODELS for t in r["models"][model]["triangulation"]]
    _csv(folder / "triangulation.csv", ["head", "protocol", "seed", "model", "depth_m",
                                        "points", "mean_mm", "rms_mm"], rows)
    write_text_atomic(folder / "summary.json", json.dumps(results, indent=1, sort_keys=True)
                      + "\n")


def figure(results: list[dict], folder: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    heads = [h for h, _, _ in HEADS if any(r["head"] == h for r in results)]
    labels = {h: lab for h, lab, _ in HEADS}
    fig = Figure(figsize=(5.2 * len(heads), 8.6))
    axes = fig.subplots(2, len(heads), squeeze=False)
    for col, h in enumerate(heads):
        rs = [r for r in results if r["head"] == h]
        ch = sorted((r for r in rs if r["target"] == "charuco"),
                    key=lambda r: r["amplitude_deg"])
        chess = [r for r in rs if r["target"] == "chessboard"]
        for row, (fn, what) in enumerate(((_he, "hand-eye translation error (mm, mean of "
                                                "eyes)"),
                                          (_tri, "triangulation mean error, 1.6–1.9 m (mm)"))):
            ax = axes[row][col]
            for model, style in (("paper", "o-"), ("general", "s-")):
                name = "closed form" if model == "paper" else "refined"
                if ch:
                    ax.plot([r["amplitude_deg"] for r in ch], [fn(r, model) for r in ch],
                            style, label=f"ChArUco, {name}")
                for r in chess:
                    ax.plot([r["amplitude_deg"]], [fn(r, model)],
                            "D" if model == "paper" else "^", ms=9, mfc="none",
                            label=f"chessboard ±8° (paper), {name}")
            if row == 0 and ch:
                amps = np.array([r["amplitude_deg"] for r in ch])
                ref = [r for r in ch if r["amplitude_deg"] == min(amps)][0]
                for model, ls in (("paper", ":"), ("general", "--")):
                    ax.plot(amps, fn(ref, model) * amps.min() / amps, ls, color="grey",
                            label=f"1/θ through ChArUco ±{amps.min():g}° "
                                  f"({'closed form' if model == 'paper' else 'refined'})")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ticks = sorted({r["amplitude_deg"] for r in rs})
            ax.set_xticks(ticks, [f"±{t:g}°" for t in ticks])
            ax.minorticks_off()
            ax.set_xlabel("pan-tilt amplitude A (positions: the paper's nine scaled to ±A)")
            ax.set_ylabel(what, fontsize=9)
            ax.set_title(labels[h], fontsize=10)
            ax.grid(True, alpha=0.3)
    # one legend for all panels, below them (inside, it hid points)
    handles, names = axes[0][0].get_legend_handles_labels()
    ncol = 3 if len(heads) > 1 else 2         # one head (--quick): a narrower figure
    rows = -(-len(names) // ncol)
    fig.legend(handles, names, loc="lower center", ncol=ncol, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, (0.25 * rows + 0.2) / 8.6, 1, 1))
    from rasc.io import write_bytes_atomic

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
    path = folder / "fig_wide_motions.png"
    write_bytes_atomic(path, buf.getvalue())
    return path


def markdown(results: list[dict], args, folder: Path) -> str:
    labels = {h: lab for h, lab, _ in HEADS}
    source = ("projected corners, 0.015 px noise (rasc.sim.synthetic), not renders"
              if args.synthetic else "rendered MuJoCo heads")
    b = CHARUCO
    lines = ["## E8 — beyond the paper: wide motions with a ChArUco board seen in part", "",
             (f"Seeds {args.seed}…{args.seed + n - 1} (hand-eye: RMS over the seeds; "
              f"triangulation: mean over the seeds)" if (n := results[0].get("seeds", 1)) > 1
              else f"Seed {args.seed}") + f"; {source}; "
             + ("--quick (ideal head, ChArUco ±8° and ±30°, 8 intrinsics views per eye); "
                if args.quick else "")
             + f"ChArUco {b['squares'][0]}×{b['squares'][1]} squares of "
             f"{1000 * b['square_size']:g} mm ({b['dictionary']}; "
             f"{b['squares'][0] * b['square_size']:g} m × {b['squares'][1] * b['square_size']:g}"
             + (" m) 1 m ahead" if args.synthetic else
                f" m) {PLACEMENT_RANGE_M[0]:.2f}–{PLACEMENT_RANGE_M[1]:.2f} m ahead (drawn per "
                "seed)") + "; positions: the "
             f"paper's nine scaled to ±A (tilt at most ±{TILT_LIMIT_DEG:g}°). Hand-eye error "
             "in the canonical gauge, translation in mm, per eye (L; R); triangulation: "
             "E7's planes, mean error.", "",
             "| head | protocol | positions used (L/R) | hand-eye closed form | hand-eye "
             "refined | triangulation closed form | refined |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        def he(model, r=r):
            return "; ".join(f"{r['models'][model]['handeye'][e]['rotation_deg']:.4f}° "
                             f"{r['models'][model]['handeye'][e]['translation_mm']:.3f} mm"
                             for e in EYES)
        proto = (f"{r['target']} ±{r['amplitude_deg']:g}°")
        lines.append(f"| {labels[r['head']]} | {proto} | {r['positions_used']['left']}/"
                     f"{r['positions_used']['right']} | {he('paper')} | {he('general')} | "
                     f"{_tri(r, 'paper'):.3f} mm | {_tri(r, 'general'):.3f} mm |")
    lines += ["", "The bar (issue 23): hand-eye translation error at ±30° at most a third "
              "of ±8°'s on the same head (mean of the eyes):", ""]
    for h in [h for h, _, _ in HEADS if any(r["head"] == h for r in results)]:
        rs = {r["protocol"]: r for r in results if r["head"] == h}
        for base in ("chess8", "charuco8"):
            if base in rs and "charuco30" in rs:
                for model in MODELS:
                    ratio = _he(rs["charuco30"], model) / _he(rs[base], model)
                    lines.append(f"- {labels[h]}, {model}: ChArUco ±30° / {base} = "
                                 f"{ratio:.3f} ({'met' if ratio <= 1 / 3 else 'NOT met'})")
    if results[0].get("seeds", 1) == 1 and not args.synthetic:
        lines += ["", "One placement: its ratios scatter, each a draw of the render's "
                  "systematic corner errors at that placement; `--seeds N` (every seed its "
                  "own placement) gives their RMS over N placements (docs/topics/"
                  "wide-motions.md reports 24)."]
    lines += ["", f"Figure: `{(folder / 'fig_wide_motions.png').name}`."]
    return "\n".join(lines) + "\n"


def compute(folder: Path, seed: int, quick: bool, workers: int, synthetic: bool,
            seeds: int = 1) -> list[dict]:
    """Every head × protocol for seeds ``seed`` … ``seed + seeds − 1`` (each seed its own
    intrinsics views and, with pixel noise, its own noise); raw CSV/JSON in ``folder``,
    one row per seed. Returns the per-seed results (:func:`combine` merges them)."""
    n_intr = N_INTRINSICS_QUICK if quick else N_INTRINSICS
    tasks = [CaseTask(h, f, p, kind, amp, seed + k, n_intr, synthetic)
             for k in range(seeds)
             for h, _, f in HEADS if not quick or h in QUICK_HEADS
             for p, kind, amp in PROTOCOLS if not quick or p in QUICK_PROTOCOLS]
    # rasc.study's executors (one pool runner; an interrupt stops every worker), with
    # progress; results in task order, whatever the worker count
    from experiments._common import run_tasks

    results = run_tasks(run_case, tasks, workers, label="e8 cases")
    write_raw(results, folder)
    return results


def run(ctx):
    """The report's E8 section (experiments.reproduce): --quick projects corners."""
    from experiments._common import Section

    folder = ctx.dir(NAME)
    results = combine(compute(folder, ctx.seed, ctx.quick, ctx.workers, synthetic=ctx.quick))
    fig = figure(results, folder)
    args = argparse.Namespace(seed=ctx.seed, synthetic=ctx.quick, quick=ctx.quick)
    text = markdown(results, args, folder)
    body = text.split("\n", 1)[1] if text.startswith("## ") else text
    # in the report the figure is shown, not named (e8.md beside it names the file)
    body = body.replace(f"Figure: `{Path(fig).name}`.",
                        f"![E8: hand-eye translation error against the motion amplitude, "
                        f"with the 1/θ law]({NAME}/{Path(fig).name})")
    return Section(NAME, "E8 — beyond the paper: wide motions with a ChArUco board",
                   body, files=[fig])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--seed", type=int, default=0, help="master seed (default 0)")
    p.add_argument("--quick", action="store_true",
                   help="ideal head, ChArUco ±8° and ±30° only, 8 intrinsics views")
    p.add_argument("--out", type=Path, default=REPO / "out", help="output folder (default out)")
    p.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    p.add_argument("--synthetic", action="store_true",
                   help="projected corners instead of renders")
    p.add_argument("--seeds", type=int, default=1,
                   help="seeds per case, from --seed on (default 1)")
    args = p.parse_args(argv)
    folder = args.out / NAME
    folder.mkdir(parents=True, exist_ok=True)
    results = combine(compute(folder, args.seed, args.quick, args.workers, args.synthetic,
                              seeds=args.seeds))
    figure(results, folder)
    from rasc.io import write_text_atomic

    write_text_atomic(folder / "e8.md", markdown(results, args, folder))
    print(f"e8: wrote {folder}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    from rasc.interrupt import exit_process
    exit_process(main())
