"""E6a (beyond the paper): gaze->camera error against image-space corner noise, RASC and Li.

Figure ``e6a/e6a_pixel_noise.png`` (+ .svg); raw results ``e6a/raw.csv``,
``e6a/pose_noise_raw.csv`` and ``e6a/eq13_matched_raw.csv``; summaries
``e6a/summary.csv``, ``e6a/pose_noise.csv``, ``e6a/summary.json``; the study itself in
``e6a/e6a_pixel_noise/``. Run::

    python -m experiments.e6a_pixel_noise [--seed S] [--quick] [--out DIR] [--workers N]

Protocol. The paper perturbs the extrinsics ``T_cam_from_world`` directly (eq. 13-14);
here the noise enters where it arises, in the image. The study
``experiments/specs/e6a_pixel_noise.toml`` runs on the default dataset
(``Context.study_dataset()``): the nine pose views per eye with the corners the pipeline
detected and kept; for each corner-noise level sigma (px) and sample the engine adds
independent Gaussian noise N(0, sigma^2) to both coordinates of every corner,
re-estimates every pose's extrinsics with the pipeline's intrinsics fixed, and RASC and
Li solve ``T_cam_from_gaze``, compared with the rendered truth (rotation: geodesic angle
in degrees; translation: Euclidean distance in mm; gross above 10 deg or 100 mm). The
engine seeds sample s of each cell by the cell's parameters, so results do not depend
on ``--workers`` or on which levels run. The engine also records each sample's
extrinsics error against the rendered truth (its ``pose_errors`` columns), expressed
here as the paper's eq. 13-14 parameters (per-axis RMS rotation in rad, translation in
mm), which puts every pixel level beside the paper's noise levels; RASC is then run on
the true extrinsics perturbed by eq. 13-14 at exactly those levels (the "matched
model").

--quick: the spec's ``[quick]`` table (levels 0, 0.1, 0.5, 2 px, 3 samples; the full
protocol's cells and draws) and 20 matched-model samples instead of 200.
"""

from __future__ import annotations

import numpy as np

from experiments._common import (
    PAPER_LEVELS,
    Context,
    Section,
    md_table,
    mean_std,
    read_csv,
    run_spec,
    save_figure,
    script_main,
    spawn_rngs,
    stage,
    write_csv,
    write_json,
)
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import T_gaze_from_ptu
from rasc.geometry.transforms import rotation_error_deg
from rasc.handeye.noise import perturb_T_cam_from_world
from rasc.handeye.solver import solve_rasc_batch

NAME = "e6a"
#: the study spec (experiments/specs/e6a_pixel_noise.toml)
SPEC = "e6a_pixel_noise"
SOLVERS = ("rasc", "li")
#: spawn_rngs key of the matched eq. 13-14 model; the level in milli-pixels follows
MODEL_RNG_KEY = (6, 3)
#: The eq. 13-14 model at the matched level (see ``run``): samples per level and eye.
#: Batched RASC makes 200 nearly free; the standard error of its mean is then ~5 %,
#: small beside the ~20 % of the 10 image-noise samples it is compared with.
MODEL_SAMPLES = 200
QUICK_MODEL_SAMPLES = 20
MODEL = "rasc-eq13"
ALL_METHODS = (*SOLVERS, MODEL)

# ------------------------------------------------------------------------ E6a itself

RAW_HEADER = ("corner_noise_px", "sample", "eye", "method", "status", "rotation_deg",
              "translation_mm", "quality", "detail")
AXES = ("x", "y", "z")
POSE_HEADER = ("corner_noise_px", "sample", "eye", *(f"pose_rot_{a}_rad" for a in AXES),
               *(f"pose_t_{a}_mm" for a in AXES))


def raw_rows(tidy: list[dict]) -> list[tuple]:
    """The study's tidy samples as :data:`RAW_HEADER` rows, in the study's order: status
    "ok", or the engine's failure status (``failed: <class>``, ``non-finite``, ``gross``)
    with the error's class or size as detail."""
    out = []
    for r in tidy:
        status = r["status"]
        detail = ("" if status == "ok" else
                  f"gross: {float(r['rotation_deg']):.4g} deg, "
                  f"{float(r['translation_mm']):.4g} mm" if status == "gross" else status)
        nums = [float(r[k]) if r[k] != "" else float("nan")
                for k in ("rotation_deg", "translation_mm", "quality")]
        out.append((float(r["corner_noise_px"]), int(r["sample"]), r["eye"], r["method"],
                    status, *nums, detail))
    return out


def pose_rows(tidy: list[dict]) -> list[tuple]:
    """Each (sigma, sample, eye)'s extrinsics error (the engine's pose-error columns,
    the same on every method's row: taken once) as :data:`POSE_HEADER` rows."""
    out, seen = [], set()
    for r in tidy:
        key = (r["corner_noise_px"], r["sample"], r["eye"])
        if key in seen:
            continue
        seen.add(key)
        out.append((float(r["corner_noise_px"]), int(r["sample"]), r["eye"],
                    *(float(r[f"pose_rot_{a}_rad"]) for a in AXES),
                    *(float(r[f"pose_t_{a}_mm"]) for a in AXES)))
    return out


def matched_model(dataset: dict, pose_rows: list[dict], n_samples: int,
                  seed: int) -> list[tuple]:
    """RASC under the paper's eq. 13-14 noise at the level the image noise produced.

    For each sigma > 0 of ``pose_rows`` (``pose_noise.csv``), the true extrinsics of the
    study's dataset (``dataset``: ``Context.study_dataset()``, its ``T_cam_from_world_true``)
    are perturbed by eq. 13-14 (exponential variant, so the matrices stay rigid) with
    ``sigma_r``, ``sigma_t`` set to the measured per-axis RMS, ``n_samples`` times per
    eye, and solved by batched RASC. Rows as ``raw.csv`` (method ``rasc-eq13``,
    ``sample`` = sample index). One generator per level: ``spawn_rngs(seed, 1, 6, 3,
    milli-px)``.
    """
    rows = []
    for p in pose_rows:
        sigma = float(p["corner_noise_px"])
        if sigma == 0:
            continue
        sigma_r, sigma_t = float(p["eq13_sigma_r_rad"]), float(p["eq13_sigma_t_mm"]) / 1000
        rng = spawn_rngs(seed, 1, *MODEL_RNG_KEY, int(round(1000 * sigma)))[0]
        for eye in EYES:
            d = dataset["eyes"][eye]
            T_true = np.asarray(d["T_cam_from_world_true"], float)
            pan_tilt = np.asarray(d["pan_tilt_rad"], float)
            T_gp = T_gaze_from_ptu(pan_tilt[:, 0], pan_tilt[:, 1])
            T = np.broadcast_to(T_true, (n_samples, *T_true.shape))
            T_noisy = perturb_T_cam_from_world(T, sigma_r, sigma_t, rng, variant="exponential")
            res = solve_rasc_batch(T_noisy, T_gp)
            X_true = np.asarray(d["T_cam_from_gaze_true"], float)
            rot = rotation_error_deg(res.T_cam_from_gaze[:, :3, :3], X_true[:3, :3])
            trans = 1000.0 * np.linalg.norm(res.T_cam_from_gaze[:, :3, 3] - X_true[:3, 3],
                                            axis=1)
            rows += [(sigma, k, eye, MODEL, "ok", float(rot[k]), float(trans[k]),
                      float(res.quality[k]), "") for k in range(n_samples)]
    return rows


def summarise(raw: list[dict]) -> list[tuple]:
    """Per (sigma, method, eye): n, failures, mean/std of rotation (deg) and translation (mm)
    over the non-failed samples, mean quality (eq. 10)."""
    groups: dict[tuple, list[dict]] = {}
    for r in raw:
        groups.setdefault((float(r["corner_noise_px"]), r["method"], r["eye"]), []).append(r)
    out = []
    for (sigma, method, eye), rs in sorted(groups.items(),
                                           key=lambda kv: (kv[0][0], ALL_METHODS.index(kv[0][1]),
                                                           EYES.index(kv[0][2]))):
        ok = [r for r in rs if r["status"] == "ok"]
        rm, rsd = mean_std(r["rotation_deg"] for r in ok)
        tm, tsd = mean_std(r["translation_mm"] for r in ok)
        qm, _ = mean_std(r["quality"] for r in ok)
        out.append((sigma, method, eye, len(rs), len(rs) - len(ok), rm, rsd, tm, tsd, qm))
    return out


SUMMARY_HEADER = ("corner_noise_px", "method", "eye", "n", "failures", "rotation_mean_deg",
                  "rotation_std_deg", "translation_mean_mm", "translation_std_mm",
                  "quality_mean")


def summarise_pose_noise(raw: list[dict]) -> list[tuple]:
    """Per sigma: RMS over samples and eyes per camera axis, and the eq. 13-14 equivalent
    (sigma_r, sigma_t = RMS over the three axes) as a multiple of the paper's level 1."""
    groups: dict[float, list[dict]] = {}
    for r in raw:
        groups.setdefault(float(r["corner_noise_px"]), []).append(r)
    out = []
    for sigma in sorted(groups):
        rs = groups[sigma]

        def rms(col, rs=rs):
            return float(np.sqrt(np.mean([float(r[col]) ** 2 for r in rs])))
        rot = [rms(f"pose_rot_{a}_rad") for a in AXES]
        tr = [rms(f"pose_t_{a}_mm") for a in AXES]
        sr, st = float(np.sqrt(np.mean(np.square(rot)))), float(np.sqrt(np.mean(np.square(tr))))
        out.append((sigma, sr, st, sr / PAPER_LEVELS[0][0], st / PAPER_LEVELS[0][1], *rot, *tr))
    return out


POSE_SUMMARY_HEADER = ("corner_noise_px", "eq13_sigma_r_rad", "eq13_sigma_t_mm",
                       "multiple_of_paper_level1_r", "multiple_of_paper_level1_t",
                       *(f"pose_rot_{a}_rad" for a in AXES), *(f"pose_t_{a}_mm" for a in AXES))


def slopes(summary: list[dict]) -> dict[str, float]:
    """Least-squares slope through the origin of mean error against sigma (sigma > 0), per
    method and eye: ``<method>_<eye>_deg_per_px`` and ``..._mm_per_px``."""
    out = {}
    for method in SOLVERS:
        for eye in EYES:
            rs = [r for r in summary if r["method"] == method and r["eye"] == eye
                  and float(r["corner_noise_px"]) > 0]
            s = np.array([float(r["corner_noise_px"]) for r in rs])
            for col, unit in (("rotation_mean_deg", "deg"), ("translation_mean_mm", "mm")):
                y = np.array([float(r[col]) for r in rs])
                out[f"{method}_{eye}_{unit}_per_px"] = float(s @ y / (s @ s))
    return out


def plot(summary_csv, stem, draft: bool = False) -> list:
    """Error against sigma (log-log), from the summary file; sigma = 0 as dotted lines."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    rows = read_csv(summary_csv)
    fig, axes = plt.subplots(1, 2, figsize=(10.5, 4.4))
    colours = {"left": "tab:blue", "right": "tab:orange"}
    styles = {"rasc": ("-", "o", 1.6, "RASC"), "li": ("--", "s", 1.2, "Li"),
              MODEL: (":", "x", 1.0, "RASC, eq. 13–14 at matched level")}
    for ax, col, label in ((axes[0], "rotation_mean_deg", "rotation error (deg)"),
                           (axes[1], "translation_mean_mm", "translation error (mm)")):
        for method in ALL_METHODS:
            ls, marker, lw, name = styles[method]
            for eye in EYES:
                rs = [r for r in rows if r["method"] == method and r["eye"] == eye]
                pos = [(float(r["corner_noise_px"]), float(r[col])) for r in rs
                       if float(r["corner_noise_px"]) > 0]
                zero = [float(r[col]) for r in rs if float(r["corner_noise_px"]) == 0]
                if pos:
                    s, y = zip(*pos, strict=True)
                    ax.plot(s, y, ls=ls, marker=marker, lw=lw, color=colours[eye],
                            label=f"{name} {eye}")
                if zero and method == "rasc":
                    ax.axhline(zero[0], ls=(0, (1, 3)), lw=0.8, color=colours[eye])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("corner noise σ (px)")
        ax.set_ylabel(f"T_cam_from_gaze {label}")
        if draft:                  # --quick: no minor ticks (text layout is the cost)
            ax.yaxis.set_minor_locator(matplotlib.ticker.NullLocator())
            ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.grid(True, which="major" if draft else "both", alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle("E6a: hand-eye error vs image corner noise (mean over samples; "
                 "sparse dots: RASC at σ = 0)", fontsize=10)
    fig.tight_layout()     # also in a draft: without it the x labels run off the edge
    paths = save_figure(fig, stem, (".png",) if draft else (".png", ".svg"), draft)
    plt.close(fig)
    return paths


def _g(x, digits=3) -> str:
    return f"{float(x):.{digits}g}"


def _fit_slope(x, y) -> float:
    x, y = np.asarray(x, float), np.asarray(y, float)
    return float(x @ y / (x @ x))


def analyse(summary: list[dict], pose: list[dict], spec, camera: dict, n_model: int) -> dict:
    """summary.json from the summary and pose-noise files (pure): failures, slopes, RASC
    against Li, image noise against the matched model, the pixels per paper level."""
    sigmas = tuple(spec.axes["corner_noise_px"])
    by = {(float(r["corner_noise_px"]), r["method"], r["eye"]): r for r in summary}
    pos = [s for s in sigmas if s > 0]
    top = max(pos)
    # RASC vs Li over every (sigma > 0, eye, component) cell; image vs matched model
    cells = [(s, e, c) for s in pos for e in EYES
             for c in ("rotation_mean_deg", "translation_mean_mm")]
    rasc_better = sum(float(by[(s, "rasc", e)][c]) < float(by[(s, "li", e)][c])
                      for s, e, c in cells)
    li_excess = {c: float(np.mean([float(by[(s, "li", e)][c]) / float(by[(s, "rasc", e)][c])
                                   for s in pos for e in EYES]) - 1.0)
                 for c in ("rotation_mean_deg", "translation_mean_mm")}
    # sample-to-sample spread of RASC's error, relative to its mean (std / mean, averaged)
    rasc_spread = {c: float(np.mean([float(by[(s, "rasc", e)][c.replace("mean", "std")])
                                     / float(by[(s, "rasc", e)][c]) for s in pos for e in EYES]))
                   for c in ("rotation_mean_deg", "translation_mean_mm")}
    model_ratio = {c: float(np.mean([float(by[(s, "rasc", e)][c]) / float(by[(s, MODEL, e)][c])
                                     for s in pos for e in EYES]))
                   for c in ("rotation_mean_deg", "translation_mean_mm")}
    pr = {float(r["corner_noise_px"]): r for r in pose}
    px_per_level1 = {
        "rotation": PAPER_LEVELS[0][0] / _fit_slope(pos, [float(pr[s]["eq13_sigma_r_rad"])
                                                          for s in pos]),
        "translation": PAPER_LEVELS[0][1] / _fit_slope(pos, [float(pr[s]["eq13_sigma_t_mm"])
                                                             for s in pos])}
    return {
        "protocol": {"sigmas_px": list(sigmas), "samples": spec.samples, "seed": spec.seed,
                     "model_samples": n_model, "gross_rotation_deg": spec.gross_rotation_deg,
                     "gross_translation_mm": spec.gross_translation_mm,
                     "spec_sha256": spec.digest},
        "failures": {m: int(sum(int(r["failures"]) for r in summary if r["method"] == m))
                     for m in ALL_METHODS},
        "slopes": slopes(summary),
        "rasc_better_than_li_cells": [int(rasc_better), len(cells)],
        "li_mean_excess_over_rasc": li_excess,
        "rasc_relative_spread": rasc_spread,
        "image_over_matched_model": model_ratio,
        "px_per_paper_level1": px_per_level1,
        "eq13_equivalent": {f"{s!r}": {"sigma_r_rad": float(pr[s]["eq13_sigma_r_rad"]),
                                       "sigma_t_mm": float(pr[s]["eq13_sigma_t_mm"])}
                            for s in sigmas},
        "camera": camera,
        # per camera axis at the largest sigma: how unlike eq. 13-14's isotropic draws
        "extrinsics_rms_per_camera_axis_at_max_sigma": {
            "rotation_rad": [float(pr[top][f"pose_rot_{a}_rad"]) for a in AXES],
            "translation_mm": [float(pr[top][f"pose_t_{a}_mm"]) for a in AXES]},
    }


def run(ctx: Context) -> Section:
    """E6a through the study engine (``specs/e6a_pixel_noise.toml`` on the default
    dataset, with its pose-error columns), then the matched eq. 13-14 model, the summaries,
    the figure and the text from the files written."""
    n_model = QUICK_MODEL_SAMPLES if ctx.quick else MODEL_SAMPLES
    out = ctx.dir(NAME)
    with stage("E6a: corner noise x 2 eyes, extrinsics + RASC + Li (study engine)"):
        spec, tidy = run_spec(ctx, SPEC, out, pose_errors=True)
    sigmas = tuple(spec.axes["corner_noise_px"])
    n_samples = spec.samples
    write_csv(out / "raw.csv", RAW_HEADER, raw_rows(tidy))
    write_csv(out / "pose_noise_raw.csv", POSE_HEADER, pose_rows(tidy))
    # ---- from here on, everything derives from the files written
    pose = summarise_pose_noise(read_csv(out / "pose_noise_raw.csv"))
    write_csv(out / "pose_noise.csv", POSE_SUMMARY_HEADER, pose)
    pose_rows_ = read_csv(out / "pose_noise.csv")
    data = ctx.study_dataset()
    with stage(f"E6a: eq. 13-14 at the matched levels, {n_model} samples x 2 eyes, RASC batch"):
        write_csv(out / "eq13_matched_raw.csv", RAW_HEADER,
                  matched_model(data, pose_rows_, n_model, ctx.seed))
    write_csv(out / "summary.csv", SUMMARY_HEADER,
              summarise(read_csv(out / "raw.csv") + read_csv(out / "eq13_matched_raw.csv")))
    summ_rows = read_csv(out / "summary.csv")
    fig_paths = plot(out / "summary.csv", out / "e6a_pixel_noise", draft=ctx.quick)

    truth = ctx.truth()
    camera = {"image_size": truth["left"]["image_size"],
              "fy": float(np.array(truth["left"]["K"])[1, 1]),
              "inner_corners": list(data["board"]["inner_corners"]),
              "square_size": data["board"]["square_size"],
              "distance": truth.get("render_options", {}).get("target_distance", 1.0)}
    doc = analyse(summ_rows, pose_rows_, spec, camera, n_model)
    by = {(float(r["corner_noise_px"]), r["method"], r["eye"]): r for r in summ_rows}
    pr = {float(r["corner_noise_px"]): r for r in pose_rows_}
    pos = [s for s in sigmas if s > 0]
    top, low = max(pos), min(pos)
    px_per_level1 = doc["px_per_paper_level1"]

    def mean_over_eyes(method, sigma, col):
        return float(np.mean([float(by[(sigma, method, e)][col]) for e in EYES]))

    write_json(out / "summary.json", doc)
    md = _markdown(ctx, sigmas, n_samples, n_model, by, pr, doc)
    files = [out / f for f in ("raw.csv", "pose_noise_raw.csv", "eq13_matched_raw.csv",
                               "summary.csv", "pose_noise.csv", "summary.json")]
    headline = {
        "max_sigma_px": top, "min_positive_sigma_px": low,
        "rasc_rotation_deg_at_max_sigma": mean_over_eyes("rasc", top, "rotation_mean_deg"),
        "rasc_rotation_deg_at_min_positive_sigma": mean_over_eyes("rasc", low,
                                                                  "rotation_mean_deg"),
        "rasc_translation_mm_at_max_sigma": mean_over_eyes("rasc", top, "translation_mean_mm"),
        "rasc_translation_mm_at_min_positive_sigma": mean_over_eyes("rasc", low,
                                                                    "translation_mean_mm"),
        "li_translation_mm_at_max_sigma": mean_over_eyes("li", top, "translation_mean_mm"),
        "failures": sum(doc["failures"].values()),
        "rasc_better_than_li_cells": doc["rasc_better_than_li_cells"],
        "px_per_paper_level1_rotation": px_per_level1["rotation"],
        "px_per_paper_level1_translation": px_per_level1["translation"],
        **{f"slope_{k}": v for k, v in doc["slopes"].items()},
    }
    return Section(NAME, "E6a (beyond the paper): hand-eye error against image corner noise",
                   md, [*files, *fig_paths], headline)


def _markdown(ctx, sigmas, n_seeds, n_model, by, pr, doc) -> str:
    def cell(s, m, e):
        r = by[(s, m, e)]
        return (f"{_g(r['rotation_mean_deg'])} ± {_g(r['rotation_std_deg'], 2)} / "
                f"{_g(r['translation_mean_mm'])} ± {_g(r['translation_std_mm'], 2)}")

    def short(s, m, e):
        r = by[(s, m, e)]
        return f"{_g(r['rotation_mean_deg'])} / {_g(r['translation_mean_mm'])}"

    rows = [[f"{s:g}", f"{_g(pr[s]['eq13_sigma_r_rad'])} rad, {_g(pr[s]['eq13_sigma_t_mm'])} mm",
             *(cell(s, m, e) for m in SOLVERS for e in EYES)] for s in sigmas]
    table = md_table(["σ (px)", "extrinsics error as eq. 13–14 (σ_r, σ_t)",
                      "RASC left", "RASC right", "Li left", "Li right"], rows)
    model_rows = [[f"{s:g}", *(v for e in EYES
                               for v in (short(s, "rasc", e), short(s, MODEL, e)))]
                  for s in sigmas if s > 0]
    model_table = md_table(["σ (px)", "left: image noise", "left: eq. 13–14 matched",
                            "right: image noise", "right: eq. 13–14 matched"], model_rows)
    sl, p1, p8 = doc["slopes"], PAPER_LEVELS[0], PAPER_LEVELS[-1]
    lvl = doc["px_per_paper_level1"]
    mr = doc["image_over_matched_model"]
    top = max(sigmas)
    ax_r = doc["extrinsics_rms_per_camera_axis_at_max_sigma"]["rotation_rad"]
    ax_t = doc["extrinsics_rms_per_camera_axis_at_max_sigma"]["translation_mm"]
    lo, hi = min(lvl.values()), 8 * max(lvl.values())
    # rotation and translation levels map to the same pixel noise within 25 %?
    ratio_text = ("The ratio of the paper's rotation to translation levels is the one image "
                  "noise produces here." if max(lvl.values()) < 1.25 * min(lvl.values()) else
                  "The paper's rotation and translation levels correspond to different "
                  "amounts of image noise here.")
    agree = all(0.8 < v < 1.25 for v in mr.values())
    model_text = (
        f"Fed those matched levels, eq. 13–14 {'predicts' if agree else 'does not predict'} "
        f"RASC's errors: the image-noise mean is on average {_g(mr['rotation_mean_deg'], 2)}× "
        f"the model's in rotation and {_g(mr['translation_mean_mm'], 2)}× in translation. "
        f"The extrinsics' error has a shape that eq. 13–14, drawing alike on every axis, "
        f"does not have: at σ = {top:g} px its rotation part is {_g(ax_r[0], 2)}, "
        f"{_g(ax_r[1], 2)}, {_g(ax_r[2], 2)} rad RMS about the camera's x, y and optical axes"
        + (" (the board's tilt is poorly seen, its in-plane turn well)"
           if ax_r[2] < min(ax_r[:2]) else "")
        + f", and its translation part {_g(ax_t[0], 2)}, {_g(ax_t[1], 2)}, {_g(ax_t[2], 2)} mm"
        + (" (depth is poorly seen)" if ax_t[2] > max(ax_t[:2]) else "")
        + ". A noise model for this kind of bench would draw the extrinsics' error from the "
          "PnP covariance rather than isotropically.")
    better, n_cells = doc["rasc_better_than_li_cells"]
    ex = doc["li_mean_excess_over_rasc"]
    spread = doc["rasc_relative_spread"]
    cam = doc["camera"]
    ranking = (f"RASC's mean error is below Li's in {better} of {n_cells} (σ > 0, eye, "
               "rotation/translation) cells; on average Li's mean is "
               f"{100 * ex['rotation_mean_deg']:.0f} % above RASC's in rotation and "
               f"{100 * ex['translation_mean_mm']:.0f} % in translation, against a "
               f"sample-to-sample spread (std / mean) of {100 * spread['rotation_mean_deg']:.0f} % "
               f"and {100 * spread['translation_mean_mm']:.0f} %.")
    if better == n_cells and max(ex.values()) < min(spread.values()):
        ranking += (" That agrees with the paper's ranking (RASC lower on average; the "
                    "rotation difference not significant) but not with a *significant* "
                    "translation advantage: with the noise spread evenly over the views, "
                    "Li's dependence on the home view (E2) costs little.")
    elif better < n_cells / 2:
        ranking += " Unlike the paper, Li is the better of the two here more often than not."
    fails = ", ".join(f"{m} {n}" for m, n in doc["failures"].items())
    return f"""\
**Protocol.** Default dataset (seed {ctx.seed}): the nine ±8° pose renders per eye with
the corners the pipeline detected ("saddle") and kept, then Gaussian noise N(0, σ²) added
to both coordinates of every corner; σ ∈ {{{", ".join(f"{s:g}" for s in sigmas)}}} px,
{n_seeds} samples per level (the study `experiments/specs/e6a_pixel_noise.toml`, run by
the study engine, which seeds every sample by its cell's parameters and its index); every
pose's extrinsics re-estimated with the pipeline's intrinsics fixed; RASC and Li (home =
the (0, 0) view) solve `T_cam_from_gaze`; errors against the rendered truth (rotation:
geodesic angle; translation: distance). Mean ± sample std over the samples. Failures
(exception, NaN, or above {doc['protocol']['gross_rotation_deg']:g}° /
{doc['protocol']['gross_translation_mm']:g} mm): {fails}. The paper has no
image-space experiment: it says (section 4) that the error "arise[s] predominantly from the
calibration procedure (image noise and errors in corner detection)" and models it by eq.
13–14 on `T_cam_from_world`. The second column measures what σ px of corner noise does to
the extrinsics, in the paper's own parameters (per-axis RMS of the rotation-error vector and
of the translation error, over views, eyes and samples), which puts each row beside the
paper's noise sets (E1's names): set 1 = ({p1[0]:g} rad, {p1[1]:g} mm) … set 8 =
({p8[0]:g} rad, {p8[1]:g} mm).

Cells: rotation error (deg) ± std / translation error (mm) ± std.

{table}
![E6a: hand-eye error against corner noise](e6a/e6a_pixel_noise.png)

Is eq. 13–14 a faithful stand-in for image noise? The same RASC, fed the true extrinsics
perturbed by eq. 13–14 (exponential variant) at exactly the (σ_r, σ_t) of the second column
({n_model} samples per level and eye); cells: mean rotation (deg) / translation (mm):

{model_table}
**Reading.** Above the noise-free floor (the σ = 0 row: detection and intrinsics errors
alone) the errors grow in proportion to the corner noise: RASC {_g(sl['rasc_left_deg_per_px'])}
/ {_g(sl['rasc_right_deg_per_px'])} deg and {_g(sl['rasc_left_mm_per_px'])} /
{_g(sl['rasc_right_mm_per_px'])} mm per pixel of σ (left / right eye; slope through the
origin of the means). {ranking} The mapping to the paper's noise sets: for this camera
({cam['image_size'][0]}×{cam['image_size'][1]}, fy ≈ {cam['fy']:.0f} px, a
{cam['inner_corners'][0]}×{cam['inner_corners'][1]}-corner board of
{1000 * cam['square_size']:g} mm squares at {cam['distance']:g} m) the paper's set 1
corresponds to about {_g(lvl['rotation'], 2)} px of corner noise by its rotation part and
{_g(lvl['translation'], 2)} px by its translation part, so its eight sets span roughly
{_g(lo, 2)}–{_g(hi, 2)} px: far coarser than sub-pixel detection (the pipeline's saddle
refinement has about 0.012 px RMS on these renders, rasc.vision.camera). {ratio_text}
{model_text}
"""


def main(argv=None) -> int:
    return script_main(run, __doc__, argv)


if __name__ == "__main__":
    from rasc.interrupt import exit_process
    exit_process(main())
