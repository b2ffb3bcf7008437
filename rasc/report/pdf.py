"""The calibration report: a PDF of :data:`PAGES` pages (matplotlib's PDF backend,
``PdfPages``), written atomically.

1. summary — the verdict (:mod:`rasc.report.verdict`) with its reason, the key numbers,
   the model-fit test and every check;
2. the head — base, mounts (ptu frames), pan and tilt axes and cameras at pan = tilt = 0,
   the baseline, in 3-D and from above;
3. parameters — every parameter with ± σ, and those the data could not determine, with
   the reason;
4. reprojection residuals per eye — scatter (du, dv) and histogram of |r|;
5. corner coverage of each eye's images — every view's corners and outline on the image;
6. per-view RMS per eye, outliers marked (of the images given; without them, of the
   calibration).

Pages 4 and 5 need the images (``dataset``); without them they say so. The same
calibration and images give the same bytes (no creation date in the PDF).
"""

from __future__ import annotations

import math
import os
import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from rasc.geometry.frames import EYES
from rasc.report.verdict import Verdict, verdict

PAGES = 6
PAGE_SIZE = (11.69, 8.27)          # A4 landscape, inches
#: a view whose RMS exceeds this multiple of its eye's median view RMS is marked an outlier
OUTLIER_FACTOR = 3.0
COLOURS = {"usable": "#1a7f37", "check": "#b35900", "unusable": "#c62828"}
ROLE_COLOURS = {"intrinsics": "#1f77b4", "pose": "#ff7f0e"}
OUTLIER_COLOUR = "#7b1fa2"


def _fmt(v: float | None, unit: str = "") -> str:
    if v is None:
        return "—"
    return f"{v:.6g}{(' ' + unit) if unit else ''}"


def _length(v: float | None, unit: str | None) -> str:
    if v is None:
        return "—"
    if unit == "m":
        return f"{1000 * v:.4g} mm"
    return f"{v:.4g} {unit or ''}".rstrip()


def _text_page(fig, lines: list[tuple[str, dict]], top: float = 0.95, step: float = 0.028,
               bottom: float = 0.03):
    """Lines of text down the page from ``top``; when they would run below ``bottom``
    (many checks, long reasons), every font and the spacing shrink alike to fit."""
    wrapped = []
    for text, style in lines:
        if "\n" not in text and style.get("fontsize", 9) <= 9 and len(text) > 150:
            text = textwrap.fill(text, 150, subsequent_indent="    ")
        wrapped.append((text, {"fontsize": 9, **style}))
    height = sum(step * st["fontsize"] / 9 * (t.count("\n") + 1) for t, st in wrapped)
    scale = min(1.0, (top - bottom) / height) if height > 0 else 1.0
    y = top
    for text, style in wrapped:
        style = {**style, "fontsize": style["fontsize"] * scale}
        fig.text(0.05, y, text, va="top", **style)
        y -= step * style["fontsize"] / 9 * (text.count("\n") + 1)
    return y


# ---------------------------------------------------------------------------- pages

def _summary(fig, doc: dict, v: Verdict, source: str, dataset: str | None) -> None:
    ref = doc.get("refinement") or {}
    model = (doc.get("options") or {}).get("model", "?")
    lines: list[tuple[str, dict]] = [
        ("rasc calibration report", {"fontsize": 18, "weight": "bold"}),
        (f"calibration: {source}", {}),
        (f"images: {dataset or 'not given (pass --dataset DIR for residuals and coverage)'}",
         {}),
        (f"model: {model}; detector: {(doc.get('options') or {}).get('detector', '?')}; "
         f"length unit: {doc.get('length_unit') or 'that of the board'}", {}),
        ("", {}),
        ("\n".join(textwrap.wrap(f"Verdict: {v.line()}", 95)),
         {"fontsize": 14, "weight": "bold", "color": COLOURS[v.level]}),
        ("", {}),
    ]
    if ref:
        rr = ref.get("rms_by_role_px") or {}
        lines.append((f"whole-head refinement: reprojection RMS {_fmt(ref.get('rms_before_px'))} "
                      f"px (closed form) -> {_fmt(ref.get('rms_after_px'))} px over "
                      f"{ref.get('corners')} corners ({ref.get('rejected_corners')} rejected)",
                      {}))
        lines.append((f"    intrinsics views {_fmt(rr.get('intrinsics'))} px, pose views "
                      f"{_fmt(rr.get('pose'))} px; corner noise sigma "
                      f"{_fmt(ref.get('sigma_px'))} px per coordinate", {}))
    delta = _time_offset(doc)
    for eye in EYES:
        e = (doc.get("eyes") or {}).get(eye) or {}
        hu = e.get("handeye_uncertainty") or {}
        lines.append((f"{eye}: intrinsics RMS {_fmt(e.get('intrinsics_rms'))} px; hand-eye "
                      f"quality (eq. 10) {_fmt(e.get('quality'))}; jackknife "
                      f"{_fmt(hu.get('rotation_deg'))} deg, "
                      f"{_length(hu.get('translation'), doc.get('length_unit'))}"
                      # the closed form that seeded the refinement read the angles at the
                      # images' stamps; the refinement replaced them
                      + ("" if delta is None else " (closed form, readings at δ = 0)"), {}))
    lines.append(("", {}))
    at = {(fit or {}).get("time_offset_s") for fit in (doc.get("paper_model_fit") or {}).values()}
    at = next(iter(at)) if len(at) == 1 else None
    lines.append(("Model-fit test (does the paper's unit, eq. 3, explain the pose views? "
                  "F ~ 1 yes, F >> 1 no):", {"weight": "bold"}))
    if isinstance(at, float):
        lines.append((f"  the pose images' readings at each image's time + δ = "
                      f"{1000 * at:.3f} ms (the refinement's estimate)", {}))
    for eye, fit in (doc.get("paper_model_fit") or {}).items():
        lines.append((f"  {eye}: F = {_fmt(fit.get('F'))} (threshold "
                      f"{_fmt(fit.get('threshold_F'))}; pose-view RMS one board "
                      f"{_fmt(fit.get('rms_model_px'))} px, a board per view "
                      f"{_fmt(fit.get('rms_free_px'))} px; {fit.get('views')} views)"
                      + ("" if model == "paper" else
                         " - shown only: the general model fits its own unit"), {}))
    sc = ref.get("scales") or {}
    if sc:
        lines.append((f"  encoder scales: {'estimated' if sc.get('estimated') else 'held at 1'}"
                      f" (mode {sc.get('mode')}, F = {_fmt(sc.get('F'))} against "
                      f"{_fmt(sc.get('threshold_F'))})", {}))
    lines.append(("", {}))
    lines.append(("Checks (rasc.report.verdict):", {"weight": "bold"}))
    for c in v.checks:
        mark = "ok  " if c.passed else ("FAIL" if c.level == "unusable" else "look")
        val = "" if c.value is None else f" [{c.value:.3g} vs {c.threshold:.3g}]"
        text = f"  {mark} {c.name}{val}: " + (c.message if not c.passed else "passed")
        lines.append(("\n".join(textwrap.wrap(text, 130, subsequent_indent="        ")),
                      {"family": "monospace", "fontsize": 8,
                       "color": "black" if c.passed else COLOURS[c.level]}))
    _text_page(fig, lines)


def _frame(ax, T_base_from_frame: np.ndarray, size: float, label: str, top: bool) -> None:
    """Draw a frame's axes (x red, y green, z blue) in plot coordinates."""
    o = T_base_from_frame[:3, 3]
    for k, col in enumerate(("r", "g", "b")):
        a = T_base_from_frame[:3, k] * size
        p, q = _plot(o), _plot(o + a)
        if top:
            ax.plot([p[0], q[0]], [p[1], q[1]], color=col, lw=1.5)
        else:
            ax.plot([p[0], q[0]], [p[1], q[1]], [p[2], q[2]], color=col, lw=1.5)
    p = _plot(o)
    # cameras labelled above their origin, mounts below, the base to the right
    dy = 12 if "camera" in label else (-14 if "ptu" in label else -4)
    if top:
        ax.annotate(label, (p[0], p[1]), fontsize=8, xytext=(4, dy), ha="center",
                    textcoords="offset points")
    elif "ptu" not in label:
        ax.text(p[0], p[1], p[2] + (0.3 * size if "camera" in label else -0.4 * size), label,
                fontsize=7, ha="center")


def _plot(p: np.ndarray) -> np.ndarray:
    """Base (x up, y forward, z left) → plot (right, forward, up)."""
    p = np.asarray(p, float)
    return np.array([-p[2], p[1], p[0]])


def _head(fig, head, unit: str | None) -> None:
    from rasc.geometry.transforms import invert_transform

    T_cam = {e: invert_transform(getattr(head, e).T_cam_from_base(0.0, 0.0)) for e in EYES}
    T_ptu = {e: invert_transform(getattr(head, e).T_ptu_from_base) for e in EYES}
    cl, cr = T_cam["left"][:3, 3], T_cam["right"][:3, 3]
    baseline = float(np.linalg.norm(cl - cr))
    size = 0.25 * max(baseline, 1e-9)
    ax3 = fig.add_axes((0.0, 0.08, 0.5, 0.8), projection="3d")
    ax2 = fig.add_axes((0.63, 0.12, 0.34, 0.72))
    for ax, top in ((ax3, False), (ax2, True)):
        _frame(ax, np.eye(4), size, "base", top)
        for e in EYES:
            _frame(ax, T_ptu[e], 0.7 * size, f"{e} ptu", top)
            _frame(ax, T_cam[e], size, f"{e} camera", top)
            u = getattr(head, e).unit
            # pan axis: the ptu frame's x; tilt axis (at pan 0) through tilt_point
            for d, q, style in ((np.array([1.0, 0, 0]), np.zeros(3), "k--"),
                                (np.asarray(u.tilt_axis), np.asarray(u.tilt_point), "k:")):
                ends = [T_ptu[e][:3, :3] @ (q + s * size * d) + T_ptu[e][:3, 3]
                        for s in (-1.2, 1.2)]
                a, b = _plot(ends[0]), _plot(ends[1])
                if top:
                    ax.plot([a[0], b[0]], [a[1], b[1]], style, lw=0.8)
                else:
                    ax.plot([a[0], b[0]], [a[1], b[1]], [a[2], b[2]], style, lw=0.8)
        a, b = _plot(cl), _plot(cr)
        if top:
            ax.plot([a[0], b[0]], [a[1], b[1]], color="0.4", lw=2, alpha=0.6)
        else:
            ax.plot([a[0], b[0]], [a[1], b[1]], [a[2], b[2]], color="0.4", lw=2, alpha=0.6)
    u = f" [{unit}]" if unit else ""
    ax3.set_xlabel(f"right (-z){u}", fontsize=8, labelpad=6)
    ax3.set_ylabel(f"forward (y){u}", fontsize=8, labelpad=6)
    ax3.set_zlabel(f"up (x){u}", fontsize=8, labelpad=6)
    ax3.tick_params(labelsize=6)
    pts = np.array([_plot(p) for p in (cl, cr, T_ptu["left"][:3, 3], T_ptu["right"][:3, 3],
                                       np.zeros(3))])
    # half the extent of the frames' origins plus the longest arrow (all of it in view)
    mid, span = pts.mean(axis=0), 0.5 * max(np.ptp(pts, axis=0).max(), size) + 1.3 * size
    for setter, k in ((ax3.set_xlim, 0), (ax3.set_ylim, 1), (ax3.set_zlim, 2)):
        setter(mid[k] - span, mid[k] + span)
    ax3.set_title("the head at pan = tilt = 0 (x red, y green, z blue;\npan axis dashed, "
                  "tilt axis dotted, baseline grey)", fontsize=9)
    ax2.set_aspect("equal")
    ax2.set_xlim(mid[0] - span, mid[0] + span)
    ax2.set_ylim(mid[1] - span, mid[1] + span)
    ax2.set_xlabel(f"right (-z){u}", fontsize=8)
    ax2.set_ylabel(f"forward (y){u}", fontsize=8)
    ax2.tick_params(labelsize=7)
    ax2.set_title(f"from above; baseline (camera centres) {_length(baseline, unit)}",
                  fontsize=9)
    fig.suptitle("The calibrated head", fontsize=13)


def _lens_row(doc: dict, eye: str) -> str:
    """The eye's lens model and the calibration's dist_model, one row."""
    lens_model = ((doc.get("head") or {}).get(eye) or {}).get("lens", "pinhole")
    dm = (doc.get("options") or {}).get("dist_model", "?")
    return f"lens {lens_model} (dist_model {dm})"


def _time_offset(doc: dict) -> float | None:
    """The calibration's estimated camera-to-encoder time offset (s), or None."""
    d = (doc.get("refinement") or {}).get("time_offset")
    if isinstance(d, dict) and d.get("estimated") and isinstance(d.get("value_s"), float):
        return d["value_s"]
    return None


def _parameter_rows(doc: dict) -> tuple[dict[str, list[str]], list[str]]:
    from rasc.head.refine.model import parameter_unit

    ref = doc.get("refinement") or {}
    unit = doc.get("length_unit")
    rows: dict[str, list[str]] = {}
    params = ref.get("parameters") or {}
    for group in (*EYES, "head"):
        out = []
        order = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "T_",
                 "unit.")
        for name, p in sorted((params.get(group) or {}).items(), key=lambda kv: (
                next((i for i, o in enumerate(order) if kv[0].startswith(o)), 99), kv[0])):
            if p.get("value") is None and p.get("std") is None:
                continue
            # the unit from the parameter table (a file written before rasc 0.3 may
            # label a scale or an axis component a length); a derived figure keeps its own
            try:
                u = parameter_unit(name)
            except KeyError:
                u = p.get("unit", "")
            if u == "length":
                val = "(in the transform)" if p.get("value") is None else \
                    _length(p["value"], unit)
                out.append(f"{name:34s} {val:>14s} ± {_length(p.get('std'), unit)}")
            else:
                val = "(in the transform)" if p.get("value") is None else f"{p['value']:.6g}"
                std = "—" if p.get("std") is None else f"{p['std']:.3g}"
                out.append(f"{name:34s} {val:>14s} ± {std} {u if u != '1' else ''}".rstrip())
            if p.get("held"):
                out[-1] += "  (held)"
        if group in EYES:     # the lens model its distortion terms belong to
            out.insert(0, _lens_row(doc, group))
        rows[group] = out
    undetermined = []
    for d in ref.get("not_identifiable") or []:
        undetermined.append(f"{d.get('eye')} {d.get('parameter')}: {d.get('reason')}")
    if not params:
        for eye in EYES:
            e = (doc.get("eyes") or {}).get(eye) or {}
            K = np.array(e.get("K", np.eye(3)))
            hu = e.get("handeye_uncertainty") or {}
            rows[eye] = [_lens_row(doc, eye),
                         f"fx {K[0, 0]:.6g}  fy {K[1, 1]:.6g}  cx {K[0, 2]:.6g}  "
                         f"cy {K[1, 2]:.6g} px (no σ: model paper)",
                         f"dist {np.round(e.get('dist', []), 6).tolist()}",
                         f"hand-eye jackknife σ: {_fmt(hu.get('rotation_deg'), 'deg')}, "
                         f"{_length(hu.get('translation'), unit)}"]
        T = np.array((doc.get("base_to_ptu") or {}).get("T_ptuL_from_ptuR", np.eye(4)))
        t = ", ".join(_length(x, unit) for x in T[:3, 3])
        rows["head"] = [f"T_ptuL_from_ptuR translation {t} (no σ: model paper; source: "
                        f"{(doc.get('base_to_ptu') or {}).get('source', '?')})"]
        undetermined.append("no whole-head refinement (model paper): calibrate with "
                            "--model general for every parameter's σ")
    return rows, undetermined


def _parameters(fig, doc: dict) -> None:
    rows, undetermined = _parameter_rows(doc)
    fig.suptitle("Every parameter with ± σ (1 standard deviation; rotations: σ of a small "
                 "rotation about each axis)", fontsize=11)
    mono = {"family": "monospace", "fontsize": 7}
    for k, eye in enumerate(EYES):
        fig.text(0.03 + 0.49 * k, 0.92, f"{eye} eye", fontsize=10, weight="bold", va="top")
        fig.text(0.03 + 0.49 * k, 0.89, "\n".join(rows.get(eye, [])), va="top", **mono)
    y = 0.89 - 0.0135 * max(len(rows.get(e, [])) for e in EYES) - 0.03
    fig.text(0.03, y, "head (the right unit's frame in the left one)", fontsize=10,
             weight="bold", va="top")
    fig.text(0.03, y - 0.03, "\n".join(rows.get("head", [])), va="top", **mono)
    y -= 0.03 + 0.0135 * len(rows.get("head", [])) + 0.03
    fig.text(0.03, y, "Not determined by the data (held at the gauge, not reported as numbers)",
             fontsize=10, weight="bold", va="top")
    wrapped = [textwrap.fill(u, 150, subsequent_indent="    ") for u in undetermined]
    fig.text(0.03, y - 0.03, "\n".join(wrapped) or "(none)", va="top", **mono)


def _no_images(fig, what: str) -> None:
    fig.text(0.5, 0.5, f"{what}: needs the images.\nPass --dataset DIR (the dataset the "
             "calibration was made from).", ha="center", va="center", fontsize=12)


def _residuals_how(doc: dict) -> str:
    """How the residuals were computed beyond the plain case, one line ("" for none):
    each eye's lens when one is not a pinhole, and a continuous capture's δ."""
    parts = []
    lenses = {eye: ((doc.get("head") or {}).get(eye) or {}).get("lens", "pinhole")
              for eye in EYES}
    if set(lenses.values()) != {"pinhole"}:
        parts.append("projected through each eye's lens ("
                     + ", ".join(f"{eye} {lens}" for eye, lens in lenses.items()) + ")")
    d = _time_offset(doc)
    if d is not None:
        parts.append(f"pose readings at each image's time + δ = {1e3 * d:.3f} ms")
    return "; ".join(parts)


def _residuals(fig, data, doc: dict | None = None) -> None:
    from matplotlib.ticker import MaxNLocator

    how = _residuals_how(doc or {})
    fig.suptitle("Reprojection residuals per eye (intrinsics views: own board pose; pose "
                 "views: one board through the whole head)" + (f"\n{how}" if how else ""),
                 fontsize=11)
    for k, eye in enumerate(EYES):
        ax_s = fig.add_subplot(2, 2, 2 * k + 1)
        ax_h = fig.add_subplot(2, 2, 2 * k + 2)
        allr = []
        n_rejected = 0
        for role in ("intrinsics", "pose"):
            views = data.of(eye, role)
            if not views:
                continue
            r = np.concatenate([v.residuals[v.kept] for v in views])
            n_rejected += sum(int((~v.kept).sum()) for v in views)
            allr.append(r)
            ax_s.scatter(r[:, 0], r[:, 1], s=3, alpha=0.5, color=ROLE_COLOURS[role],
                         label=f"{role} ({len(views)} views)")
        r = np.concatenate(allr) if allr else np.zeros((0, 2))
        if not len(r):
            for ax in (ax_s, ax_h):
                ax.text(0.5, 0.5, f"{eye}: no view of the target", ha="center",
                        va="center", transform=ax.transAxes)
                ax.set_axis_off()
            continue
        norm = np.linalg.norm(r, axis=1)
        rms = float(np.sqrt(np.mean(norm ** 2)))
        lim = max(float(np.percentile(np.abs(r), 99.5)) * 1.3, 1e-6)
        ax_s.set_xlim(-lim, lim)
        ax_s.set_ylim(-lim, lim)
        ax_s.set_aspect("equal")
        ax_s.axhline(0, color="0.7", lw=0.5)
        ax_s.axvline(0, color="0.7", lw=0.5)
        ax_s.set_xlabel("du [px]", fontsize=8)
        ax_s.set_ylabel("dv [px]", fontsize=8)
        for axis in (ax_s.xaxis, ax_s.yaxis, ax_h.xaxis):
            axis.set_major_locator(MaxNLocator(5))
        ax_s.tick_params(labelsize=7)
        ax_s.legend(fontsize=7, loc="upper right")
        rej = f"; {n_rejected} rejected, not drawn" if n_rejected else ""
        ax_s.set_title(f"{eye}: {len(norm)} corners, RMS {rms:.3g} px{rej}", fontsize=9)
        ax_h.hist(norm, bins=40, color="0.5")
        ax_h.axvline(rms, color="k", lw=1, ls="--", label=f"RMS {rms:.3g} px")
        ax_h.set_xlabel("|residual| [px]", fontsize=8)
        ax_h.set_ylabel("corners", fontsize=8)
        ax_h.tick_params(labelsize=7)
        ax_h.legend(fontsize=7)
        ax_h.set_title(f"{eye}: distribution of |residual|", fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.94))


def _coverage(fig, data) -> dict[str, float]:
    from scipy.spatial import ConvexHull

    from rasc.report.data import COVERAGE_GRID, coverage
    from rasc.vision.board import spans_plane

    fig.suptitle("Corner coverage of each eye's images (every view's corners and outline)",
                 fontsize=11)
    out = {}
    for k, eye in enumerate(EYES):
        ax = fig.add_subplot(1, 2, k + 1)
        w, h = data.image_size[eye]
        for role in ("intrinsics", "pose"):
            for n, v in enumerate(data.of(eye, role)):
                c = v.corners
                ax.scatter(c[:, 0], c[:, 1], s=1, color=ROLE_COLOURS[role],
                           label=f"{role} views" if n == 0 else None)
                if spans_plane(c):        # a hull needs corners off one line
                    hull = c[ConvexHull(c).vertices]
                    ax.fill(hull[:, 0], hull[:, 1], color=ROLE_COLOURS[role], alpha=0.06)
                    ax.plot(*np.r_[hull, hull[:1]].T, color=ROLE_COLOURS[role], lw=0.5)
        cov = coverage([v.corners for v in data.of(eye, "intrinsics")], (w, h))
        out[eye] = cov
        for i in range(1, COVERAGE_GRID[0]):
            ax.axvline(i * w / COVERAGE_GRID[0], color="0.85", lw=0.5)
        for j in range(1, COVERAGE_GRID[1]):
            ax.axhline(j * h / COVERAGE_GRID[1], color="0.85", lw=0.5)
        ax.set_xlim(0, w)
        ax.set_ylim(h, 0)
        ax.set_aspect("equal")
        ax.set_xlabel("u [px]", fontsize=8)
        ax.set_ylabel("v [px]", fontsize=8)
        ax.tick_params(labelsize=7)
        # below the image, not over its corners
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2,
                  markerscale=5)
        ax.set_title(f"{eye} ({w}x{h}): intrinsics corners touch {100 * cov:.0f} % of the "
                     f"{COVERAGE_GRID[0]}x{COVERAGE_GRID[1]} cells", fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    return out


def per_view_rms(doc: dict, data=None) -> dict[str, list[tuple[str, str, float, bool]]]:
    """Per eye, (file, role, RMS px, outlier) of every view: of the images ``data`` gives
    when there are any (the views the other pages draw, over the corners the calibration
    kept), else the refinement's per-image RMS, else the intrinsics per-view RMS; an
    outlier has rejected corners (or none kept), was an intrinsics outlier, or has an RMS
    above :data:`OUTLIER_FACTOR` times its eye's median."""
    out: dict[str, list[tuple[str, str, float, bool]]] = {e: [] for e in EYES}
    ref = doc.get("refinement") or {}
    flagged = {e: set(((doc.get("eyes") or {}).get(e) or {}).get("intrinsics_outliers") or [])
               for e in EYES}
    if data is not None and data.views:
        for v in data.views:
            r = v.residuals[v.kept]
            rms = float(np.sqrt(np.mean(np.sum(r ** 2, axis=1)))) if len(r) else math.nan
            out[v.eye].append((v.file, v.role, rms,
                               not math.isfinite(rms) or not bool(v.kept.all())))
    elif ref.get("images"):
        for im in ref["images"]:
            rms = float(im["rms"]) if im.get("rms") is not None else math.nan
            # an image whose corners were all rejected has no RMS: an outlier
            out[im["eye"]].append((im["file"], im["role"], rms,
                                   bool(im.get("rejected_corners")) or not math.isfinite(rms)))
    else:
        for e in EYES:
            for f, rms in (((doc.get("eyes") or {}).get(e) or {}).get(
                    "intrinsics_per_view_rms") or {}).items():
                out[e].append((f, "intrinsics", float(rms), False))
    for e in EYES:
        finite = [r for _, _, r, _ in out[e] if math.isfinite(r)]
        med = float(np.median(finite)) if finite else 0.0
        out[e] = [(f, role, r, bad or f in flagged[e] or (med > 0 and r > OUTLIER_FACTOR * med))
                  for f, role, r, bad in out[e]]
    return out


def _per_view(fig, doc: dict, data) -> None:
    from matplotlib.patches import Patch

    rows = per_view_rms(doc, data)
    whose = "the images given" if data is not None and data.views else "the calibration's"
    fig.suptitle(f"RMS of each view, {whose} (outliers: rejected corners, flagged as an "
                 f"intrinsics outlier, or > {OUTLIER_FACTOR:g}x the eye's median)",
                 fontsize=11)
    for k, eye in enumerate(EYES):
        ax = fig.add_subplot(2, 1, k + 1)
        r = rows[eye]
        if not r:
            ax.text(0.5, 0.5, f"{eye}: no views", ha="center", va="center",
                    transform=ax.transAxes)
            ax.set_axis_off()
            continue
        x = np.arange(len(r))
        # an image without an RMS (every corner rejected) is drawn at 0, marked
        heights = [v if math.isfinite(v) else 0.0 for _, _, v, _ in r]
        colours = [OUTLIER_COLOUR if bad else ROLE_COLOURS[role] for _, role, _, bad in r]
        ax.bar(x, heights, color=colours)
        for i, (_, _, _, bad) in enumerate(r):
            if bad:
                ax.plot(i, heights[i], "kx", ms=6)
        ax.legend(handles=[Patch(color=ROLE_COLOURS["intrinsics"], label="intrinsics view"),
                           Patch(color=ROLE_COLOURS["pose"], label="pose view"),
                           Patch(color=OUTLIER_COLOUR, label="outlier (x)")],
                  fontsize=7, loc="upper left", bbox_to_anchor=(1.005, 1.0))
        ax.set_xticks(x)
        ax.set_xticklabels([str(Path(f).with_suffix("")) for f, _, _, _ in r], rotation=90,
                           fontsize=6 if len(r) <= 60 else 4)
        ax.set_xlim(-0.6, len(r) - 0.4)
        ax.set_ylabel("RMS [px]", fontsize=8)
        ax.tick_params(axis="y", labelsize=7)
        finite = [v for _, _, v, _ in r if math.isfinite(v)]
        med = float(np.median(finite)) if finite else 0.0
        ax.axhline(med, color="k", lw=0.8, ls="--")
        n_bad = sum(b for *_, b in r)
        ax.set_title(f"{eye}: {len(r)} views, median {med:.3g} px (dashed), "
                     f"{n_bad} outlier(s)", fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.94))


# ---------------------------------------------------------------------------- writing

def write_report(doc: dict[str, Any], out: str | os.PathLike, *, dataset=None,
                 source: str = "calibration", log=lambda s: None) -> Verdict:
    """Write the report of the calibration document ``doc`` to ``out`` (PDF, atomically:
    :func:`rasc.io.write_bytes_atomic`, after every page is drawn); ``dataset`` (a
    :class:`rasc.vision.dataset.Dataset`, optional) for the residual and coverage pages
    and the verdict's checks of the images. Returns the verdict."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    from rasc.head.use import calibration_from_document
    from rasc.io import write_bytes_atomic
    from rasc.report.data import coverage, rejected_corners, report_data

    head = calibration_from_document(doc, source).head
    data = None
    cov = None
    fit = None
    if dataset is not None:
        log("detecting corners and computing residuals")
        options = doc.get("options") or {}
        min_corners = options.get("min_corners")
        data = report_data(head, dataset, options.get("detector", "saddle"),
                           **({"min_corners": int(min_corners)}
                              if isinstance(min_corners, int) else {}),
                           rejected=rejected_corners(doc),
                           time_offset=_time_offset(doc))
        for line in data.skipped:
            log(f"left out of the residual pages: {line}")
        cov = {e: coverage([v.corners for v in data.of(e, "intrinsics")], data.image_size[e])
               for e in EYES}
        fit = data.rms_by_role()
    v = verdict(doc, cov, fit)
    buffer = io.BytesIO()
    with plt.rc_context({"font.size": 8}), \
            PdfPages(buffer, metadata={"CreationDate": None, "Creator": "rasc report"}) as pdf:
        pages = [lambda f: _summary(f, doc, v, source,
                                    None if dataset is None else str(dataset.root)),
                 lambda f: _head(f, head, doc.get("length_unit")),
                 lambda f: _parameters(f, doc),
                 (lambda f: _residuals(f, data, doc)) if data is not None
                 else (lambda f: _no_images(f, "Reprojection residuals")),
                 (lambda f: _coverage(f, data)) if data is not None
                 else (lambda f: _no_images(f, "Corner coverage")),
                 lambda f: _per_view(f, doc, data)]
        for draw in pages:
            fig = plt.figure(figsize=PAGE_SIZE)
            try:
                draw(fig)
                pdf.savefig(fig)
            finally:
                plt.close(fig)
    write_bytes_atomic(out, buffer.getvalue())
    return v
