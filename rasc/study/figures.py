"""A study's figures: for each axis, mean translation and rotation error against the
axis, one curve per method (and per combination of the other axes), with the bootstrap
confidence interval of each mean as error bars. PNG and SVG, deterministic bytes.
"""

from __future__ import annotations

import io
import itertools
from pathlib import Path

from rasc.io import write_bytes_atomic

PANELS = (("translation_mm", "translation error (mm)"), ("rotation_deg", "rotation error (°)"))
MARKERS = "osD^v<>px*h"


def save_figure(fig, path_stem: Path, formats: tuple[str, ...] = (".png", ".svg"),
                draft: bool = False) -> list[Path]:
    """Save a matplotlib figure as PNG and SVG (or the ``formats`` given) with no dates or
    random ids (same figure, same bytes), each written atomically. The tight bounding box
    is computed once; a ``draft`` (the experiments' --quick) skips it and uses 72 dpi."""
    import matplotlib

    if not draft:   # a layout engine (constrained layout) runs at draw: let it run first,
        fig.draw_without_rendering()     # or the box is the unlaid figure's (cropped)
    bbox = None if draft else fig.get_tightbbox(fig.canvas.get_renderer()).padded(0.1)
    dpi = 72 if draft else 120
    paths = []
    for ext, meta in ((".png", {"Software": None}), (".svg", {"Date": None})):
        if ext not in formats:
            continue
        path = path_stem.with_suffix(ext)
        buf = io.BytesIO()
        with matplotlib.rc_context({"svg.hashsalt": "rasc"}):
            fig.savefig(buf, format=ext[1:], dpi=dpi, metadata=meta, bbox_inches=bbox)
        write_bytes_atomic(path, buf.getvalue())
        paths.append(path)
    return paths


def _label(v) -> str:
    if isinstance(v, list | tuple):
        return "(" + ", ".join(f"{x:g}" for x in v) + ")" if v else "none"
    return f"{v:g}" if isinstance(v, float) else str(v)


def plot_study(spec, summary: list[list], folder: Path) -> list[Path]:
    """One figure per axis of ``spec`` that takes two values or more, from the summary
    rows (as :func:`rasc.study.engine.summarise` returns them): error against that axis,
    one curve per method and combination of the other varying axes. An axis with one
    value has no figure of its own and no part in the legends (it is held: the title says
    at what). None when no axis varies."""
    axes = list(spec.axes)
    varying = [a for a in axes if len(spec.axes[a]) > 1]
    held = [a for a in axes if len(spec.axes[a]) == 1]
    if not varying:
        return []
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rasc.study.spec import SUMMARY_TAIL

    folder.mkdir(parents=True, exist_ok=True)
    n_ax = len(axes)
    col = {name: 1 + n_ax + k for k, name in enumerate(SUMMARY_TAIL)}
    files = []
    held_text = "; ".join(f"{o} = {_label(spec.axes[o][0])}" for o in held)
    for axis in varying:
        a_index = axes.index(axis)
        values = list(spec.axes[axis])
        numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)
        xpos = {v: (float(v) if numeric else k) for k, v in enumerate(values)}
        others = [o for o in varying if o != axis]
        combos = list(itertools.product(*(spec.axes[o] for o in others)))
        fig, panels = plt.subplots(1, 2, figsize=(10, 4.2))
        for m_index, method in enumerate(spec.methods):
            for c_index, combo in enumerate(combos):
                fixed = dict(zip(others, combo, strict=True))
                sel = [r for r in summary if r[col["method"]] == method
                       and all(r[1 + axes.index(o)] == v for o, v in fixed.items())]
                label = method + "".join(f", {o}={_label(v)}" for o, v in fixed.items())
                style = dict(marker=MARKERS[m_index % len(MARKERS)], ms=4, capsize=2,
                             linestyle=("-", "--", ":", "-.")[c_index % 4], label=label,
                             color=f"C{m_index % 10}")
                for ax, (err, _) in zip(panels, PANELS, strict=True):
                    pts = [(xpos[r[1 + a_index]], r[col[f"{err}_mean"]],
                            r[col[f"{err}_ci_low"]], r[col[f"{err}_ci_high"]]) for r in sel
                           if r[col[f"{err}_mean"]] is not None]
                    pts.sort()
                    if not pts:
                        continue
                    x = [p[0] for p in pts]
                    y = [p[1] for p in pts]
                    lo = [p[1] - p[2] if p[2] == p[2] else 0.0 for p in pts]
                    hi = [p[3] - p[1] if p[3] == p[3] else 0.0 for p in pts]
                    ax.errorbar(x, y, yerr=[lo, hi], **style)
        for ax, (_, ylabel) in zip(panels, PANELS, strict=True):
            ax.set_xlabel(axis)
            ax.set_ylabel("mean " + ylabel)
            ax.grid(True, alpha=0.3)
            if not numeric:
                ax.set_xticks(range(len(values)), [_label(v) for v in values])
        handles, labels = panels[0].get_legend_handles_labels()
        if handles:
            panels[0].legend(fontsize=7)
        fig.suptitle(f"{spec.name}: error against {axis} (mean, {spec.confidence:.0%} "
                     f"bootstrap CI; {spec.samples} samples per cell)"
                     + (f"\nheld: {held_text}" if held_text else ""), fontsize=10)
        files += save_figure(fig, folder / axis)
        plt.close(fig)
    return files
