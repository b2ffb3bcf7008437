"""E11 (beyond the paper) — calibration accuracy against the field of view and the lens
model, the wrong model beside the right one (issue 32, item 5).

Protocol:

* **Heads**: the stock synthetic head (``rasc.sim.synthetic.default_head``: its units,
  hand-eyes and mounts) with both cameras' lenses replaced, at each horizontal field of
  view of :data:`FOVS` (the focal length that puts rays ``fov / 2`` off the axis at the
  1280-px image's left and right edges, ``rasc.sim.lens_render.focal_for_fov``):
  a **pinhole** lens with radial distortion :data:`PINHOLE_DIST` (60°–120°: a
  rectilinear lens of 150° is not built) and a **fisheye** (OpenCV's equidistant model,
  k1–k4 :data:`FISHEYE_DIST`, 60°–150°).
* **Data**: ``rasc.sim.synthetic.corner_dataset``: the board's corners projected through
  the lens (20 intrinsics views per eye spread over the whole image, the paper's nine
  pan-tilt positions at 1 m), Gaussian noise of :data:`NOISE_PX` px on each coordinate;
  seeds ``seed … seed + SEEDS − 1``.
* **Calibrations**: ``calibrate_dataset`` with the default options (the general model,
  its whole-head refinement) and each ``dist_model`` of :data:`FITS`: ``k1k2`` (the
  default pinhole model), ``rational`` (OpenCV's k1–k6, p1 p2) and ``fisheye``. The
  model that built the data is the right one (pinhole data: ``k1k2``; fisheye data:
  ``fisheye``); the others are wrong models. "warned": the calibration's warnings
  include the wrong-lens warning (``rasc.vision.camera.wrong_lens_warning``).
* **Reported**: per field of view, lens and fitted model, the hand-eye
  (``T_cam_from_gaze``) rotation (degrees) and translation (mm) errors against the
  truth (RMS over both eyes and the seeds), the intrinsics reprojection RMS (px; the
  better of OpenCV's calibrator and the refinement over the intrinsics views, as the
  wrong-lens check reads it), and whether the wrong-lens warning was given.
* **Rendered** (full protocol only): one dataset rendered through a 150° fisheye
  (``RenderOptions(lens="fisheye", fov=150)``, corners detected in the images),
  calibrated with ``fisheye`` and with ``k1k2``.

``--quick`` (for tests): one seed; the fisheye at 90° and 150° fitted with ``fisheye``
and ``k1k2``, the pinhole at 60° fitted with ``k1k2``; no rendered dataset.

Run::

    python -m experiments.e11_lenses [--seed S] [--quick] [--out DIR]

Writes ``<out>/e11/``: ``cases.csv`` (one row per case and seed), ``lenses.csv`` (the
table), ``summary.json``, ``e11_lenses.png`` (+ .svg).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from experiments._common import (
    Context,
    Section,
    md_table,
    script_main,
    stage,
    write_csv,
    write_json,
)

NAME = "e11"
TITLE = "E11 — beyond the paper: calibration accuracy against field of view and lens model"

#: horizontal fields of view (degrees across the 1280-px image)
FOVS = (60, 90, 120, 150)
#: the lenses: name → (lens model, coefficients, the fields of view it is built for)
LENSES = {
    "pinhole": ("pinhole", (-0.05, 0.01, 0.0, 0.0, 0.0), (60, 90, 120)),
    "fisheye": ("fisheye", (0.02, -0.01, 0.003, -0.0005), FOVS),
}
PINHOLE_DIST = LENSES["pinhole"][1]
FISHEYE_DIST = LENSES["fisheye"][1]
#: the calibration's dist_model fitted to each, and the right one for each lens
FITS = ("k1k2", "rational", "fisheye")
RIGHT = {"pinhole": "k1k2", "fisheye": "fisheye"}
#: corner noise (px, each coordinate) and seeds per case
NOISE_PX = 0.05
SEEDS = 3
#: the quick protocol's cases: (lens, fov, fit)
QUICK = (("fisheye", 90, "fisheye"), ("fisheye", 90, "k1k2"),
         ("fisheye", 150, "fisheye"), ("fisheye", 150, "k1k2"),
         ("pinhole", 60, "k1k2"))
#: the rendered point: the lens and its field of view, the models fitted
RENDERED = ("fisheye", 150, ("fisheye", "k1k2"))
CASE_HEADER = ("data", "lens", "fov_deg", "fit", "seed", "eye", "handeye_rotation_deg",
               "handeye_translation_mm", "intrinsics_rms_px", "warned", "failure")
TABLE_HEADER = ("data", "lens", "fov_deg", "fit", "right_model", "cases",
                "handeye_rotation_deg", "handeye_translation_mm", "intrinsics_rms_px",
                "warned", "failed")


def lens_head(lens: str, fov: float):
    """The stock synthetic head with both cameras' lenses ``lens`` (:data:`LENSES`) of
    horizontal field of view ``fov`` degrees (the principal points kept)."""
    from rasc.geometry.frames import EYES
    from rasc.sim.lens_render import focal_for_fov
    from rasc.sim.synthetic import IMAGE_SIZE, default_head

    model, dist, _ = LENSES[lens]
    head = default_head()
    f = focal_for_fov(fov, IMAGE_SIZE[0], dist, model)
    K = {eye: np.array([[f, 0.0, k[0, 2]], [0.0, f, k[1, 2]], [0.0, 0.0, 1.0]])
         for eye, k in head.K.items()}
    return dataclasses.replace(head, K=K, dist={eye: np.asarray(dist, float) for eye in EYES},
                               lens={eye: model for eye in EYES})


def synthetic_dataset(lens: str, fov: float, seed: int):
    """:func:`lens_head`'s corners (``corner_dataset``) with its truth in
    ``rasc render``'s layout (the canonical gauge) for ``errors_against_truth``."""
    from rasc.geometry.frames import EYES
    from rasc.geometry.kinematics import canonical_gauge
    from rasc.sim.synthetic import corner_dataset

    ds = corner_dataset(lens_head(lens, fov), seed=seed, noise_px=NOISE_PX)
    h = ds.truth
    truth = {"image_size": list(ds.sizes["left"]),
             "T_ptuL_from_ptuR": h.T_ptuL_from_ptuR().tolist()}
    for eye in EYES:
        u, T_cg, T_pb = canonical_gauge(h.unit[eye], h.T_cam_from_gaze[eye],
                                        h.T_ptu_from_base[eye])
        truth[eye] = {"K": h.K[eye].tolist(), "dist": h.dist[eye].tolist(),
                      "lens": h.lens_model(eye), "T_cam_from_gaze": T_cg.tolist(),
                      "T_ptu_from_base": T_pb.tolist(), "unit": u.to_dict()}
    ds.load_ground_truth = lambda: truth
    ds.ground_truth = Path("<synthetic truth>")
    return ds


def case_rows(data: str, lens: str, fov: float, fit: str, seed: int, ds) -> list[tuple]:
    """Calibrate ``ds`` with ``dist_model`` ``fit``: one row of :data:`CASE_HEADER` per
    eye (a calibration that fails: one row per eye with its error, NaN numbers)."""
    from rasc.errors import RascError
    from rasc.geometry.frames import EYES
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.vision.camera import WRONG_LENS_REMEDY, lens_check_rms

    try:
        cal = calibrate_dataset(ds, CalibrationOptions(dist_model=fit))
    except RascError as exc:
        reason = f"{type(exc).__name__}: {str(exc).split(': ', 1)[-1][:90]}"
        return [(data, lens, fov, fit, seed, eye, math.nan, math.nan, math.nan, False,
                 reason) for eye in EYES]
    e = cal.errors
    rows = []
    for eye in EYES:
        intr = cal.eyes[eye].intrinsics
        rms = lens_check_rms(intr.lens_check) if intr.lens_check else None
        warned = any(w.startswith(f"{eye} eye:") and WRONG_LENS_REMEDY in w
                     for w in cal.warnings)
        rows.append((data, lens, fov, fit, seed, eye,
                     e[eye]["T_cam_from_gaze"]["rotation_deg"],
                     1000 * e[eye]["T_cam_from_gaze"]["translation"],
                     float(intr.rms if rms is None else rms), warned, ""))
    return rows


def rendered_rows(seed: int) -> list[tuple]:
    """The rendered point (:data:`RENDERED`): a dataset rendered through the lens,
    calibrated with each of its fits."""
    from rasc.sim.render import RenderOptions, render_in_memory

    lens, fov, fits = RENDERED
    with stage(f"E11: render a {fov}° {lens} dataset"):
        ds = render_in_memory(RenderOptions(lens=lens, fov=fov, seed=seed), quiet=True)
    rows = []
    for fit in fits:
        with stage(f"E11: calibrate the rendered {lens} with {fit}"):
            rows += case_rows("rendered", lens, fov, fit, seed, ds)
    return rows


def cases(quick: bool) -> list[tuple[str, int, str]]:
    if quick:
        return list(QUICK)
    return [(lens, fov, fit) for lens, (_, _, fovs) in LENSES.items() for fov in fovs
            for fit in FITS]


def table(rows: list[tuple]) -> list[tuple]:
    """One row of :data:`TABLE_HEADER` per (data, lens, fov, fit): RMS over eyes and
    seeds of the hand-eye errors, mean intrinsics RMS, warned and failed counts."""
    groups: dict[tuple, list[tuple]] = {}
    for r in rows:
        groups.setdefault(r[:4], []).append(r)
    out = []
    for (data, lens, fov, fit), rs in groups.items():
        ok = [r for r in rs if not r[10]]

        def rms(i, ok=ok):
            return float(np.sqrt(np.mean([r[i] ** 2 for r in ok]))) if ok else math.nan

        out.append((data, lens, fov, fit, fit == RIGHT[lens], len(rs), rms(6), rms(7),
                    float(np.mean([r[8] for r in ok])) if ok else math.nan,
                    sum(bool(r[9]) for r in rs), len(rs) - len(ok)))
    return out


# ------------------------------------------------------------------ report

STYLE = {"k1k2": ("C0", "o"), "rational": ("C2", "s"), "fisheye": ("C3", "^")}


def figure(summary: list[tuple], folder: Path, quick: bool) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from experiments._figures import save_experiment_figure

    fig, axes = plt.subplots(1, 3, figsize=(14.0, 4.4))
    synth = [r for r in summary if r[0] == "synthetic"]
    for lens, ls in (("fisheye", "-"), ("pinhole", ":")):
        for fit in FITS:
            rs = sorted((r for r in synth if r[1] == lens and r[3] == fit
                         and np.isfinite(r[6])), key=lambda r: r[2])
            if not rs:
                continue
            c, m = STYLE[fit]
            label = f"{lens} data, {fit} fit" + (" (right)" if fit == RIGHT[lens] else "")
            kw = {"color": c, "marker": m, "linestyle": ls, "label": label,
                  "fillstyle": "full" if fit == RIGHT[lens] else "none"}
            x = [r[2] for r in rs]
            axes[0].plot(x, [r[6] for r in rs], **kw)
            axes[1].plot(x, [r[7] for r in rs], **kw)
            axes[2].plot(x, [r[8] for r in rs], **kw)
    for r in summary:
        if r[0] == "rendered" and np.isfinite(r[6]):
            c, _ = STYLE[r[3]]
            for ax, i in zip(axes, (6, 7, 8), strict=True):
                ax.plot([r[2]], [r[i]], marker="*", markersize=13, color=c, linestyle="",
                        label=f"rendered {r[1]}, {r[3]} fit" if ax is axes[0] else None)
    for ax, ylabel in ((axes[0], "hand-eye rotation error (°, RMS)"),
                       (axes[1], "hand-eye translation error (mm, RMS)"),
                       (axes[2], "intrinsics reprojection RMS (px)")):
        ax.set_yscale("log")
        ax.set_xlabel("horizontal field of view (°)")
        ax.set_ylabel(ylabel)
        ax.set_xticks(FOVS)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7.5, title="data and fitted model", title_fontsize=8)
    stars = "; stars: rendered images" if any(r[0] == "rendered" for r in summary) else ""
    fig.suptitle("Calibration through each lens model against the field of view "
                 f"(synthetic corners, {NOISE_PX} px noise; open markers: a model other "
                 f"than the data's{stars})", fontsize=11)
    fig.tight_layout()
    try:
        return save_experiment_figure(fig, folder / "e11_lenses", quick)
    finally:
        plt.close(fig)


def _num(v: float, fmt: str) -> str:
    return "—" if not np.isfinite(v) else format(v, fmt)


def markdown(summary: list[tuple], files, quick: bool, seeds: int) -> str:
    rows = [(r[0], r[1], f"{r[2]:g}", f"`{r[3]}`" + (" (right)" if r[4] else " (other)"),
             _num(r[6], ".4f"), _num(r[7], ".3f"), _num(r[8], ".3f"),
             f"{r[9]}/{r[5]}", f"{r[10]}/{r[5]}" if r[10] else "")
            for r in summary]
    return "\n".join([
        f"![E11]({NAME}/{files[0].name})", "",
        "The stock synthetic head with both cameras' lenses replaced at each horizontal "
        "field of view: a pinhole with radial distortion (k1 k2 = "
        f"{PINHOLE_DIST[0]:g}, {PINHOLE_DIST[1]:g}) and OpenCV's equidistant fisheye "
        f"(k1–k4 = {', '.join(f'{v:g}' for v in FISHEYE_DIST)}); the board's corners "
        f"projected through the lens with {NOISE_PX} px noise "
        f"({seeds} seed{'s' if seeds > 1 else ''}), calibrated with the default options "
        "(general model) and each `dist_model`. Errors against the truth, RMS over both "
        "eyes and the seeds; intrinsics RMS as the wrong-lens check reads it (the better "
        "of OpenCV's calibrator and the refinement); right: the model that made the data, "
        "other: another model (the pinhole `k1k2` on fisheye data is the wrong model; "
        "`rational` is flexible enough to follow a fisheye); warned: eyes given the "
        "wrong-lens warning; failed: eyes whose calibration stopped with an error."
        + (" Quick protocol: five cases, one seed, no rendered dataset." if quick else
           " \"rendered\": a dataset rendered through a 150° fisheye "
           "(`rasc render --lens fisheye --fov 150`), corners detected in its images."),
        "",
        md_table(("data", "lens", "field of view (°)", "fitted model",
                  "hand-eye rotation (°)", "hand-eye translation (mm)",
                  "intrinsics RMS (px)", "warned", "failed"), rows), ""])


def run(ctx: Context) -> Section:
    folder = ctx.dir(NAME)
    seeds = 1 if ctx.quick else SEEDS
    rows: list[tuple] = []
    with stage("E11: calibrate synthetic corners through each lens"):
        for lens, fov, fit in cases(ctx.quick):
            for s in range(seeds):
                ds = synthetic_dataset(lens, fov, ctx.seed + s)
                rows += case_rows("synthetic", lens, fov, fit, ctx.seed + s, ds)
    if not ctx.quick:
        rows += rendered_rows(ctx.seed)
    write_csv(folder / "cases.csv", CASE_HEADER, rows)
    summary = table(rows)
    write_csv(folder / "lenses.csv", TABLE_HEADER, summary)
    write_json(folder / "summary.json",
               {"seed": ctx.seed, "quick": ctx.quick, "seeds": seeds, "noise_px": NOISE_PX,
                "rows": [dict(zip(TABLE_HEADER, r, strict=True)) for r in summary]})
    files = figure(summary, folder, ctx.quick)
    return Section(NAME, TITLE, markdown(summary, files, ctx.quick, seeds),
                   files=[folder / "cases.csv", folder / "lenses.csv",
                          folder / "summary.json", *files],
                   summary={f"{r[0]}|{r[1]}|{r[2]}|{r[3]}": r[6] for r in summary})


def main(argv=None) -> int:
    return script_main(run, __doc__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
