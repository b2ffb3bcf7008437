"""E6b (beyond the paper): hand-eye shoot-out — RASC, Li and OpenCV's five methods.

Figure ``e6b/e6b_shootout.png`` (+ .svg); raw results ``e6b/raw.csv``; summaries
``e6b/summary.csv``, ``e6b/summary.json``. Run::

    python -m experiments.e6b_shootout [--seed S] [--quick] [--out DIR] [--workers N]

Protocol. Three pose sets, each a 3x3 grid like the paper's nine, (pan, tilt) in
{-a, 0, a}^2 with the home (0, 0) first: a = 8 deg is the default dataset's pose renders
(``ctx.dataset_dir()``); a = 4 and 2 deg are rendered here with ``rasc.sim.scene.StereoHeadSim``
in the same scene (default model, board facing the head at the dataset's distance via
``T_base_from_world_facing``, as ``rasc.sim.render`` does; checked equal to the dataset's
recorded target pose). Corners are detected once per image ("saddle"); then, per set,
one noise-free run and ``N_SEEDS`` runs with Gaussian corner noise of ``SIGMA_PX`` px
(one generator per (set, seed): ``spawn_rngs(seed, N_SEEDS, 6, 2, milli-deg)``), each
re-estimating every pose's extrinsics with the pipeline's intrinsics fixed and giving the
SAME ``T_cam_from_world`` to every method of ``rasc.handeye.methods.METHODS``. A run of a method
fails when it raises (SolverFailure, DegenerateDataError, ...), returns NaN/inf, or is off
the truth by more than 10 deg or 100 mm (gross); errors are summarised over the runs that
did not fail, both eyes pooled.
"""

from __future__ import annotations

import sys

import numpy as np

from experiments._common import (
    GROSS_ROTATION_DEG,
    GROSS_TRANSLATION_MM,
    Context,
    EyeData,
    Section,
    md_table,
    noisy_extrinsics,
    pose_eye_data,
    pose_noise,
    read_csv,
    run_method,
    run_tasks,
    save_figure,
    script_main,
    spawn_rngs,
    stage,
    write_csv,
    write_json,
)
from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu
from rasc.handeye.methods import METHODS
from rasc.vision.camera import detect_corners
from rasc.vision.dataset import load_dataset

NAME = "e6b"
#: pose-set amplitudes a (deg): the nine (pan, tilt) in {-a, 0, a}^2; full and --quick
POSE_SETS_DEG = (8.0, 4.0, 2.0)
QUICK_POSE_SETS_DEG = (8.0, 2.0)
#: corner noise (px) of the seeded runs: ~20x the saddle detector's 0.012 px RMS on these
#: renders, a realistic figure for real images (OpenCV's stereo samples calibrate to
#: 0.41-0.46 px RMS, docs/NOTES.md), large enough that failure rates mean something
SIGMA_PX = 0.25
N_SEEDS = 10
QUICK_N_SEEDS = 2
RNG_KEY = (6, 2)
#: the default dataset is the paper's nine at this amplitude
DATASET_AMPLITUDE_DEG = 8.0
#: the rendered scene must be the dataset's: target pose and constants equal to this
#: (both come from the same model through quaternion round trips: ~1e-15 seen)
SAME_SCENE_ATOL = 1e-9


def grid_poses_deg(amplitude: float) -> tuple[tuple[float, float], ...]:
    """The paper's nine positions scaled to ``amplitude`` degrees, home (0, 0) first."""
    return tuple((pan * amplitude / 8.0, tilt * amplitude / 8.0)
                 for pan, tilt in PAPER_POSES_DEG)


def _check_dataset_poses(eyes: dict[str, EyeData]) -> None:
    """The ±8 deg set is the dataset's: its nine poses must be the paper's, home first."""
    want = np.radians(np.array(grid_poses_deg(DATASET_AMPLITUDE_DEG)))
    have_T = T_gaze_from_ptu(want[:, 0], want[:, 1])
    for eye, d in eyes.items():
        if d.T_gaze_from_ptu.shape != have_T.shape or \
                np.abs(d.T_gaze_from_ptu - have_T).max() > SAME_SCENE_ATOL:
            raise InputError(f"{d.files[0]}: the default dataset's {eye} pose views are not the "
                             "paper's nine ±8° positions (home first); E6b needs them")


def render_pose_set(ctx: Context, amplitude: float, board) -> dict[str, EyeData]:
    """Render the nine-pose grid of ``amplitude`` deg for both eyes and detect its corners.

    Same scene as the default dataset (checked: board, target pose, per-eye
    ``T_cam_from_gaze``); intrinsics are the pipeline's (``ctx.calibration()``).

    Raises
    ------
    rasc.errors.InputError
        The scene differs from the dataset's, the dataset was rendered with image
        degradation, or a render has no detectable board (names the image).
    """
    from rasc.sim.scene import StereoHeadSim, T_base_from_world_facing

    truth, cal = ctx.truth(), ctx.calibration()
    opts = truth.get("render_options", {})
    if any(opts.get(k) for k in ("noise_sigma", "blur_sigma")) or any(opts.get("dist", [])):
        raise InputError("ground_truth.json: render_options: the dataset was rendered with "
                         "noise, blur or distortion; E6b renders clean images, so its pose "
                         "sets would differ; render the default dataset without them")
    home_view = truth["views"]["poses/left_00.png"]
    poses = grid_poses_deg(amplitude)
    out: dict[str, EyeData] = {}
    with StereoHeadSim() as sim:
        if sim.board != board:
            raise InputError(f"{sim.model_file}: its board {sim.board} is not the dataset's "
                             f"{board}")
        sim.set_target(T_base_from_world_facing(sim.board,
                                                distance=opts.get("target_distance", 1.0)))
        if np.abs(sim.T_base_from_world - np.array(home_view["T_base_from_world"])).max() \
                > SAME_SCENE_ATOL:
            raise InputError("ground_truth.json: views: the dataset's target pose is not the "
                             "default facing pose; E6b cannot render the same scene")
        images: dict[str, list] = {eye: [] for eye in EYES}
        T_cw: dict[str, list] = {eye: [] for eye in EYES}
        for pan, tilt in poses:
            for eye in EYES:
                sim.set_angles(eye, np.radians(pan), np.radians(tilt))
            for eye in EYES:
                images[eye].append(sim.render_grey(eye))   # as rasc.sim.render
                T_cw[eye].append(sim.T_cam_from_world(eye))
        X_sim = {eye: sim.T_cam_from_gaze(eye) for eye in EYES}
    pt = np.radians(np.array(poses))
    for eye in EYES:
        X_true = np.array(truth[eye]["T_cam_from_gaze"], dtype=float)
        if np.abs(X_sim[eye] - X_true).max() > SAME_SCENE_ATOL:
            raise InputError(f"ground_truth.json: {eye}: T_cam_from_gaze differs from the "
                             "default model's; E6b cannot render the same head")
        files = tuple(f"render±{amplitude:g}/{eye}_{k:02d}" for k in range(len(poses)))
        corners = []
        for name, image in zip(files, images[eye], strict=True):
            c = detect_corners(image, board, method="saddle")
            if c is None:
                raise InputError(f"{name}: board not found in the rendered image")
            corners.append(c)
        intr = cal.eyes[eye].intrinsics
        out[eye] = EyeData(eye=eye, files=files, corners=np.array(corners),
                           T_gaze_from_ptu=T_gaze_from_ptu(pt[:, 0], pt[:, 1]),
                           K=np.array(intr.K), dist=np.array(intr.dist),
                           T_cam_from_gaze_true=X_true,
                           T_cam_from_world_true=np.array(T_cw[eye]))
    return out


RAW_HEADER = ("pose_set_deg", "sigma_px", "seed", "eye", "method", "status", "rotation_deg",
              "translation_mm", "quality", "detail")


POSE_HEADER = ("pose_set_deg", "sigma_px", "seed", "eye", "eq13_sigma_r_rad", "eq13_sigma_t_mm")


def _task(task) -> tuple[list[tuple], list[tuple]]:
    """One (pose set, sigma, seed): both eyes' extrinsics, then every method on them; also
    the extrinsics' error as eq. 13-14 parameters. Top level for the workers;
    ``METHODS`` is looked up by name at call time."""
    amplitude, sigma, seed_index, rng, eyes, board, methods = task
    rows, pose_rows = [], []
    for data in eyes:
        T_cw = noisy_extrinsics(data, board, sigma, rng)
        rot_rms, t_rms = pose_noise(T_cw, data.T_cam_from_world_true)
        pose_rows.append((amplitude, sigma, seed_index, data.eye,
                          float(np.sqrt(np.mean(rot_rms**2))),
                          1000.0 * float(np.sqrt(np.mean(t_rms**2)))))
        for name in methods:
            r = run_method(METHODS[name], T_cw, data.T_gaze_from_ptu, data.T_cam_from_gaze_true)
            rows.append((amplitude, sigma, seed_index, data.eye, name, r["status"],
                         r["rotation_deg"], r["translation_mm"], r["quality"], r["detail"]))
    return rows, pose_rows


SUMMARY_HEADER = ("pose_set_deg", "method", "n", "failures", "exceptions", "nans", "gross",
                  "rotation_median_deg", "rotation_mean_deg", "translation_median_mm",
                  "translation_mean_mm", "clean_failures", "clean_rotation_deg",
                  "clean_translation_mm", "first_failure")


def summarise(raw: list[dict], methods: tuple[str, ...]) -> list[tuple]:
    """Per (pose set, method), both eyes pooled: noisy runs (sigma > 0) → failure counts by
    kind and median/mean errors over the runs that did not fail; noise-free run → its
    failures and mean errors over the eyes; the first failure's detail."""
    out = []
    sets = sorted({float(r["pose_set_deg"]) for r in raw}, reverse=True)
    nan = float("nan")
    for a in sets:
        for m in methods:
            rs = [r for r in raw if float(r["pose_set_deg"]) == a and r["method"] == m]
            noisy = [r for r in rs if float(r["sigma_px"]) > 0]
            clean = [r for r in rs if float(r["sigma_px"]) == 0]
            ok = [r for r in noisy if r["status"] == "ok"]
            clean_ok = [r for r in clean if r["status"] == "ok"]
            rot = np.array([float(r["rotation_deg"]) for r in ok])
            tr = np.array([float(r["translation_mm"]) for r in ok])
            kinds = [sum(r["status"] == k for r in noisy) for k in ("exception", "nan", "gross")]
            first = next((r["detail"] for r in rs if r["status"] != "ok"), "")
            out.append((
                a, m, len(noisy), len(noisy) - len(ok), *kinds,
                float(np.median(rot)) if ok else nan, float(rot.mean()) if ok else nan,
                float(np.median(tr)) if ok else nan, float(tr.mean()) if ok else nan,
                len(clean) - len(clean_ok),
                float(np.mean([float(r["rotation_deg"]) for r in clean_ok])) if clean_ok else nan,
                float(np.mean([float(r["translation_mm"]) for r in clean_ok]))
                if clean_ok else nan,
                first))
    return out


MARKERS = "osD^v<>px*h"


def plot(summary_csv, stem) -> list:
    """Median errors and failures against the pose-set amplitude, from the summary file."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    rows = read_csv(summary_csv)
    methods = list(dict.fromkeys(r["method"] for r in rows))
    sets = sorted({float(r["pose_set_deg"]) for r in rows})
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.4))
    width = 0.8 / max(1, len(methods))
    for k, m in enumerate(methods):
        rs = sorted((r for r in rows if r["method"] == m), key=lambda r: float(r["pose_set_deg"]))
        a = [float(r["pose_set_deg"]) for r in rs]
        style = dict(marker=MARKERS[k % len(MARKERS)], label=m, color=f"C{k % 10}",
                     lw=2.0 if m == "rasc" else 1.0)
        for ax, col in ((axes[0], "rotation_median_deg"), (axes[1], "translation_median_mm")):
            y = [float(r[col]) for r in rs]
            ax.plot(a, y, **style)
        x = np.arange(len(sets)) + (k - (len(methods) - 1) / 2) * width
        fails = [int(next(r["failures"] for r in rs if float(r["pose_set_deg"]) == s))
                 for s in sets]
        axes[2].bar(x, fails, width=width, color=f"C{k % 10}",
                    label=m if any(fails) else None)
    for ax, label in ((axes[0], "median rotation error (deg)"),
                      (axes[1], "median translation error (mm)")):
        ax.set_yscale("log")
        ax.set_xscale("log", base=2)
        ax.set_xticks(sets, [f"±{s:g}°" for s in sets])
        ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.set_xlabel("pose set (3×3 grid of pan, tilt)")
        ax.set_ylabel(f"T_cam_from_gaze {label}")
        ax.grid(True, which="both", alpha=0.3)
    n = int(rows[0]["n"]) if rows else 0
    axes[2].set_xticks(np.arange(len(sets)), [f"±{s:g}°" for s in sets])
    axes[2].set_ylim(0, max(1, n) * 1.05)
    axes[2].set_ylabel(f"failures (of {n} noisy runs)")
    axes[2].set_xlabel("pose set")
    axes[2].grid(True, axis="y", alpha=0.3)
    axes[2].yaxis.get_major_locator().set_params(integer=True)
    if any(int(r["failures"]) for r in rows):
        axes[2].legend(fontsize=7)
    axes[0].legend(fontsize=7)
    fig.suptitle("E6b: hand-eye methods on identical rendered data, corner noise "
                 "(medians over runs that did not fail, both eyes; RASC, Park and Horaud "
                 "overlap in rotation)", fontsize=10)
    fig.tight_layout()
    paths = save_figure(fig, stem)
    plt.close(fig)
    return paths


def _g(x, digits=3) -> str:
    x = float(x)
    return "—" if not np.isfinite(x) else f"{x:.{digits}g}"


def run(ctx: Context) -> Section:
    sets = QUICK_POSE_SETS_DEG if ctx.quick else POSE_SETS_DEG
    n_seeds = QUICK_N_SEEDS if ctx.quick else N_SEEDS
    methods = tuple(METHODS)
    out = ctx.dir(NAME)
    board = load_dataset(ctx.dataset_dir()).board
    pose_sets: dict[float, dict[str, EyeData]] = {}
    with stage(f"E6b: pose sets ±{', ±'.join(f'{a:g}' for a in sets)} deg: detect the "
               "dataset's, render and detect the others"):
        for a in sets:
            if a == DATASET_AMPLITUDE_DEG:
                pose_sets[a] = pose_eye_data(ctx)
                _check_dataset_poses(pose_sets[a])
            else:
                pose_sets[a] = render_pose_set(ctx, a, board)
    tasks = []
    for a in sets:
        rngs = spawn_rngs(ctx.seed, n_seeds + 1, *RNG_KEY, int(round(1000 * a)))
        eyes = [pose_sets[a][e] for e in EYES]
        # generator 0 feeds the noise-free run (draws, scaled by 0), 1.. the noisy seeds
        tasks.append((a, 0.0, 0, rngs[0], eyes, board, methods))
        tasks += [(a, SIGMA_PX, k, rngs[k + 1], eyes, board, methods) for k in range(n_seeds)]
    with stage(f"E6b: {len(sets)} pose sets x (1 clean + {n_seeds} noisy) x 2 eyes x "
               f"{len(methods)} methods"):
        results = run_tasks(_task, tasks, ctx.workers, label="E6b")
    write_csv(out / "raw.csv", RAW_HEADER, [row for rows, _ in results for row in rows])
    write_csv(out / "pose_noise_raw.csv", POSE_HEADER,
              [row for _, rows in results for row in rows])
    # ---- from here on, everything derives from the files written
    noisy = [r for r in read_csv(out / "pose_noise_raw.csv") if float(r["sigma_px"]) > 0]
    eq13 = {k: float(np.sqrt(np.mean([float(r[k]) ** 2 for r in noisy])))
            for k in ("eq13_sigma_r_rad", "eq13_sigma_t_mm")}
    write_csv(out / "summary.csv", SUMMARY_HEADER,
              summarise(read_csv(out / "raw.csv"), methods))
    rows = read_csv(out / "summary.csv")
    fig_paths = plot(out / "summary.csv", out / "e6b_shootout")
    by = {(float(r["pose_set_deg"]), r["method"]): r for r in rows}
    doc = {
        "protocol": {"pose_sets_deg": list(sets), "sigma_px": SIGMA_PX, "n_seeds": n_seeds,
                     "seed": ctx.seed, "methods": list(methods),
                     "gross_rotation_deg": GROSS_ROTATION_DEG,
                     "gross_translation_mm": GROSS_TRANSLATION_MM},
        "noisy_runs_per_cell": 2 * n_seeds,
        # what the corner noise did to the extrinsics (RMS per axis over the noisy runs)
        "extrinsics_error_as_eq13": eq13,
        **{key: {m: {f"{a:g}": conv(by[(a, m)][col]) for a in sets} for m in methods}
           for key, col, conv in (
               ("failures", "failures", int), ("clean_failures", "clean_failures", int),
               ("median_rotation_deg", "rotation_median_deg", float),
               ("median_translation_mm", "translation_median_mm", float),
               ("clean_rotation_deg", "clean_rotation_deg", float),
               ("clean_translation_mm", "clean_translation_mm", float))},
    }
    doc = _json_ready(doc)
    write_json(out / "summary.json", doc)
    md = _markdown(ctx, sets, n_seeds, methods, by, doc)
    headline = {"failures": doc["failures"], "clean_failures": doc["clean_failures"],
                "median_rotation_deg": doc["median_rotation_deg"],
                "median_translation_mm": doc["median_translation_mm"],
                "noisy_runs_per_cell": doc["noisy_runs_per_cell"]}
    return Section(NAME, "E6b (beyond the paper): hand-eye shoot-out on identical rendered "
                   "data at ±8°, ±4°, ±2°", md,
                   [out / "raw.csv", out / "pose_noise_raw.csv", out / "summary.csv",
                    out / "summary.json", *fig_paths],
                   headline)


def _json_ready(obj):
    """NaN (no run succeeded) → None: JSON has no NaN."""
    if isinstance(obj, dict):
        return {k: _json_ready(v) for k, v in obj.items()}
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def _failure_kinds(r: dict) -> str:
    n = int(r["failures"])
    if n == 0:
        return "0"
    kinds = [f"{int(r[k])} {label}" for k, label in (("exceptions", "exc."), ("nans", "NaN"),
                                                      ("gross", "gross")) if int(r[k])]
    return f"**{n}** ({', '.join(kinds)})"


def _markdown(ctx, sets, n_seeds, methods, by, doc) -> str:
    n_runs = doc["noisy_runs_per_cell"]
    table_rows = []
    for a in sets:
        for m in methods:
            r = by[(a, m)]
            clean = ("fails" if int(r["clean_failures"]) == 2 else
                     f"{_g(r['clean_rotation_deg'])} / {_g(r['clean_translation_mm'])}"
                     + (" (1 eye fails)" if int(r["clean_failures"]) == 1 else ""))
            table_rows.append([f"±{a:g}°", m, clean,
                               f"{_g(r['rotation_median_deg'])} / {_g(r['rotation_mean_deg'])}",
                               f"{_g(r['translation_median_mm'])} / "
                               f"{_g(r['translation_mean_mm'])}",
                               _failure_kinds(r)])
    table = md_table(["set", "method", "noise-free: rot (deg) / trans (mm)",
                      f"σ = {SIGMA_PX:g} px: rot median / mean (deg)",
                      "trans median / mean (mm)", f"failures of {n_runs}"], table_rows)
    reasons = []
    for m in methods:
        details = [by[(a, m)]["first_failure"] for a in sets if by[(a, m)]["first_failure"]]
        if details:
            reasons.append(f"- {m}: {details[0]}")
    reasons_md = "\n".join(reasons) if reasons else "- none"

    def fails(m):
        return sum(int(by[(a, m)]["failures"]) for a in sets)

    def med(a, m, col):
        return float(by[(a, m)][col])

    small, big = min(sets), max(sets)
    ok_methods = [m for m in methods if fails(m) == 0]
    failed = [f"{m} (" + ", ".join(f"±{a:g}°: {by[(a, m)]['failures']}" for a in sets) + ")"
              for m in methods if fails(m)]
    reading = [f"Methods that never failed: {', '.join(ok_methods) or 'none'}; methods that "
               f"failed (failures of {n_runs} per set): {', '.join(failed) or 'none'}."]
    if "rasc" in ok_methods:
        def ratio(m, col):
            return med(small, m, col) / med(small, "rasc", col)
        rel = ", ".join(f"{m} {ratio(m, 'rotation_median_deg'):.2f} / "
                        f"{ratio(m, 'translation_median_mm'):.2f}"
                        for m in ok_methods if m != "rasc")
        grow_r = (med(small, "rasc", "rotation_median_deg")
                  / med(big, "rasc", "rotation_median_deg"))
        grow_t = (med(small, "rasc", "translation_median_mm")
                  / med(big, "rasc", "translation_median_mm"))
        reading.append(
            f"At ±{small:g}°, the other surviving methods' medians relative to RASC's (rotation /"
            f" translation): {rel or 'none'}.")
        agree = {m: max(abs(med(a, m, "rotation_median_deg")
                            / med(a, "rasc", "rotation_median_deg") - 1.0) for a in sets)
                 for m in ("opencv-park", "opencv-horaud") if m in ok_methods}
        if agree:
            reading.append(
                "RASC and OpenCV's Park compute the same Park–Martin rotation (for a pure-"
                "rotation unit, all ordered pairs and OpenCV's pairs i < j give the same sums) "
                "and differ in translation only because OpenCV writes eq. 7 for the inverse "
                "transform, which weights the residuals differently (rasc/opencv_handeye.py); "
                "largest relative difference of the median rotation error from RASC's over the "
                "sets: " + ", ".join(f"{m} {100 * v:.2g} %" for m, v in agree.items()) + ".")
        reading.append(
            f"Making the motions {big / small:g}× smaller multiplies RASC's median errors by "
            f"{grow_r:.2g} (rotation) and {grow_t:.2g} (translation): the camera's relative "
            "rotations carry the same absolute noise while the rotations shrink, and eq. 7's "
            "`(I − A_ij)` shrinks with the rotation angle, so the same extrinsics noise moves "
            "`t_cg` further.")
    reading = " ".join(reading)
    notes = _sim_notes_comparison(sets, methods, by, n_runs, doc["extrinsics_error_as_eq13"])
    return f"""\
**Protocol.** Pose sets: 3×3 grids of (pan, tilt) ∈ {{−a, 0, a}}², home first, for a ∈
{{{", ".join(f"{a:g}" for a in sets)}}}°; ±8° is the default dataset (seed {ctx.seed}), the
others are rendered in the same scene. Corners detected once ("saddle"); extrinsics with
the pipeline's intrinsics fixed; per set one noise-free run and {n_seeds} runs with Gaussian
corner noise σ = {SIGMA_PX:g} px (seeded per set and run), both eyes: {n_runs} noisy runs
per (set, method), every method on identical `T_cam_from_world`. Failure: an exception, a
NaN/inf result, or an error above {GROSS_ROTATION_DEG:g}° or {GROSS_TRANSLATION_MM:g} mm
(gross). Errors against the rendered truth, over the runs that did not fail, eyes pooled.
The paper compares RASC with Li only (E1, E2); OpenCV's methods and these small motions are
beyond it: the reference values beside ours are the facts measured with OpenCV in
docs/NOTES.md.

{table}
![E6b: hand-eye shoot-out](e6b/e6b_shootout.png)

First failure message per method:

{reasons_md}

**Reading.** {reading}

{notes}
"""


def _sim_notes_comparison(sets, methods, by, n_runs, eq13) -> str:
    """docs/NOTES.md's measured OpenCV facts beside what this run shows (data-driven)."""
    def cell(m, a):
        r = by[(a, m)]
        n = int(r["failures"])
        if n == n_runs:
            return f"±{a:g}°: all {n} failed" + (", noise-free too" if int(r["clean_failures"])
                                                 else "")
        return (f"±{a:g}°: {n}/{n_runs} failed, median {_g(r['rotation_median_deg'])}° / "
                f"{_g(r['translation_median_mm'])} mm")

    facts = {"opencv-park": "Park: ±5° → 0.65° / 38 mm, ±10° → 0.29° / 15 mm, ±30° → 0.11° / "
                            "5.8 mm",
             "opencv-tsai": "Tsai fails at ±5° (15° / 99 mm)",
             "opencv-andreff": "Andreff returns NaN at ±5° and ±10°"}
    lines = ["| docs/NOTES.md (OpenCV 4.x, 4×4 grid, OpenCV's test noise) | here "
             f"(3×3 grid, σ = {SIGMA_PX:g} px corners) |", "|---|---|"]
    lines += [f"| {fact} | {'; '.join(cell(m, a) for a in sets)} |"
              for m, fact in facts.items() if m in methods]
    said = []
    if "opencv-park" in methods:
        park = [float(by[(a, "opencv-park")]["translation_median_mm"]) for a in sorted(sets)]
        if all(np.isfinite(park)) and all(x > y for x, y in zip(park, park[1:], strict=False)):
            said.append(
                "Park's error grows as the motions shrink, as in docs/NOTES.md; its values are "
                f"smaller: {SIGMA_PX:g} px of corner noise perturbed our extrinsics by "
                f"{eq13['eq13_sigma_r_rad']:.2g} rad and {eq13['eq13_sigma_t_mm']:.2g} mm per "
                "axis (RMS), against OpenCV's test noise of 0.002 rad and 0.005 length units "
                "(on translations of 0.5–1.5 units) plus 0.001 on the gripper poses.")
    if "opencv-tsai" in methods:
        failing = [a for a in sets if int(by[(a, "opencv-tsai")]["failures"]) == n_runs]
        working = [a for a in sets if int(by[(a, "opencv-tsai")]["failures"]) == 0]
        detail = next((by[(a, "opencv-tsai")]["first_failure"] for a in failing), "")
        if failing and working and max(failing) < min(working):
            said.append(f"Tsai works at ±{min(working):g}° and fails at every run from "
                        f"±{max(failing):g}° down, consistent with its failure at ±5° in "
                        "docs/NOTES.md" + (": OpenCV logs 'Not enough informative motions' and "
                                       "returns exactly the identity, which "
                                       "rasc.handeye.opencv turns into a SolverFailure."
                                       if "identity" in detail else "."))
    if "opencv-andreff" in methods and all(
            int(by[(a, "opencv-andreff")]["failures"]) == n_runs
            and int(by[(a, "opencv-andreff")]["clean_failures"]) == 2 for a in sets):
        said.append("Andreff fails on every set, noise-free or not, and not because the "
                    "motions are small: its linear system (rotation and translation solved "
                    "together) has the unit's translations as its only right-hand side, and "
                    "a pan-tilt unit's motions have none, so the system is homogeneous and "
                    "its solution's rotation is zero (OpenCV's 'determinant(R) is null' "
                    "above). docs/NOTES.md saw this as a NaN at ±5° and ±10°; it fails at any "
                    "motion range on pan-tilt data.")
    return ("How this compares with the OpenCV behaviour measured earlier on this machine "
            "(different grid and noise, so compare tendencies, not values):\n\n"
            + "\n".join(lines) + "\n\n" + " ".join(said) + "\n")


def main(argv=None) -> int:
    return script_main(run, __doc__, argv)


if __name__ == "__main__":
    sys.exit(main())
