"""The report's figures are not cropped (issue 25 item 7): every PNG the reproduction
writes keeps its drawn content clear of the image's edges. A figure whose bounding box
was computed before its layout engine ran (E3's old crop) has ink on its edge pixels."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))
from experiments.reproduce import EXPERIMENTS  # noqa: E402

#: the border band (pixels) that must hold background only: matplotlib's pad around the
#: tight box is 0.1 in (12 px at 120 dpi) and constrained layout's own pad 0.04 in (3 px
#: at the drafts' 72 dpi); ink on the outermost 2 px is content cut by the edge
MARGIN_PX = 2
#: a pixel differs from the background when a channel differs by more than this (PNG
#: antialiasing of a line ending near the edge stays below it only when it is faint)
INK = 24


def ink_on_edges(png: Path) -> list[str]:
    """The edges (top, bottom, left, right) whose outer MARGIN_PX band holds ink."""
    import cv2

    image = cv2.imread(str(png), cv2.IMREAD_COLOR)
    assert image is not None, png
    background = np.median(np.concatenate([image[0], image[-1], image[:, 0], image[:, -1]]),
                           axis=0)
    ink = np.any(np.abs(image.astype(int) - background) > INK, axis=2)
    m = MARGIN_PX
    bands = {"top": ink[:m], "bottom": ink[-m:], "left": ink[:, :m], "right": ink[:, -m:]}
    return [edge for edge, band in bands.items() if band.any()]


def test_the_check_sees_a_cropped_figure(tmp_path):
    """The old bug, made on purpose: the box taken before constrained layout runs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rasc.study.figures import save_figure

    def draw():
        fig, axes = plt.subplots(1, 2, figsize=(8, 3.5), layout="constrained")
        for ax in axes:
            ax.plot(np.arange(10) ** 2, label="data")
            ax.set_ylabel("a long y label (mm)")
            ax.set_title("a title")
        return fig

    fig = draw()
    bbox = fig.get_tightbbox(fig.canvas.get_renderer()).padded(0.1)   # before layout
    fig.savefig(tmp_path / "cropped.png", dpi=120, bbox_inches=bbox)
    plt.close(fig)
    assert ink_on_edges(tmp_path / "cropped.png")
    fig = draw()
    (good,) = save_figure(fig, tmp_path / "good", formats=(".png",))
    plt.close(fig)
    assert ink_on_edges(good) == []


@pytest.mark.slow
@pytest.mark.parametrize("name", [name for name, _ in EXPERIMENTS])
def test_no_report_figure_is_cropped(quick_experiments, name):
    ctx, section = quick_experiments(name)
    folder = ctx.out / importlib.import_module(f"experiments.{name}").NAME
    pngs = sorted(folder.glob("*.png"))
    assert pngs, folder
    cropped = {p.name: edges for p in pngs if (edges := ink_on_edges(p))}
    assert cropped == {}
