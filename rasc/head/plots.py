"""Residual plots of a whole-head refinement (``rasc calibrate --plots DIR``).

One PNG per eye, ``residuals_<eye>.png``: left, every kept corner's residual vector
(px) as a scatter with the 1σ, 3σ and rejection circles; right, the per-image RMS
(intrinsics views, then pose views) with rejected corners marked. matplotlib with the
Agg backend, written atomically.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from rasc.geometry.frames import EYES
from rasc.io import write_bytes_atomic

#: the files :func:`residual_plots` writes into its folder (checked as outputs first)
PLOT_FILES = tuple(f"residuals_{eye}.png" for eye in EYES)


def residual_plots(result, folder: str | Path) -> list[Path]:
    """Write one residual plot per eye of a :class:`rasc.head.refine.RefinementResult`
    into ``folder`` (created if missing); returns the paths written."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for eye in EYES:
        r = result.residuals[eye]
        fig = Figure(figsize=(10, 4.2))
        ax, bx = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1, 1.6]})
        ax.scatter(r[:, 0], r[:, 1], s=2, alpha=0.4, color="tab:blue", linewidths=0)
        t = np.linspace(0, 2 * np.pi, 200)
        for k, style in ((1, ":"), (3, "--")):
            ax.plot(k * result.sigma * np.cos(t), k * result.sigma * np.sin(t), style,
                    color="k", lw=0.8, label=f"{k}σ")
        ax.set_aspect("equal")
        ax.set_xlabel("residual u (px)")
        ax.set_ylabel("residual v (px)")
        ax.set_title(f"{eye}: {len(r)} corners, σ = {result.sigma:.3f} px")
        ax.legend(loc="upper right", fontsize=8)
        ims = [im for im in result.images if im.eye == eye]
        x = np.arange(len(ims))
        colours = ["tab:green" if im.role == "intrinsics" else "tab:orange" for im in ims]
        bx.bar(x, [im.rms for im in ims], color=colours)
        bx.plot(x, [im.max for im in ims], "k_", label="max")
        for i, im in enumerate(ims):
            if im.rejected:
                bx.annotate(f"{len(im.rejected)} rejected", (i, im.max), fontsize=7,
                            rotation=90, va="bottom", ha="center", color="tab:red")
        bx.set_xticks(x, [Path(im.name).stem for im in ims], rotation=90, fontsize=6)
        bx.set_ylabel("px")
        bx.set_title("per image: RMS (green intrinsics, orange pose views), max")
        bx.legend(loc="upper right", fontsize=8)
        fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
        path = folder / PLOT_FILES[EYES.index(eye)]
        write_bytes_atomic(path, buf.getvalue())
        out.append(path)
    return out
