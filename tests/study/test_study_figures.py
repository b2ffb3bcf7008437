"""A study's figures (issue 25 item 7): a figure per axis that varies, none for an axis
with one value (which stays out of the legends and is named in the title), every figure
clear of its edges."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from rasc.study.figures import plot_study
from rasc.study.spec import SUMMARY_TAIL


def _summary(axes: dict, methods) -> list[list]:
    """Summary rows as rasc.study.engine.summarise lays them out: cell, axis values,
    then SUMMARY_TAIL (method, n, ok, then per error mean/CI...)."""
    import itertools
    rows = []
    for cell, values in enumerate(itertools.product(*axes.values())):
        for m in methods:
            tail = {name: 1.0 for name in SUMMARY_TAIL}
            tail["method"] = m
            for err in ("translation_mm", "rotation_deg"):
                x = 1.0 + 0.1 * cell
                tail[f"{err}_mean"], tail[f"{err}_ci_low"], tail[f"{err}_ci_high"] = \
                    x, x - 0.05, x + 0.05
            rows.append([cell, *values, *(tail[n] for n in SUMMARY_TAIL)])
    return rows


def test_one_valued_axes_get_no_figure_and_no_legend_entries(tmp_path):
    axes = {"noise_level": [1, 2, 4], "eye": ["left"], "blur": [0.5]}
    spec = SimpleNamespace(axes=axes, methods=["rasc", "li"], name="s", confidence=0.95,
                           samples=5)
    files = plot_study(spec, _summary(axes, spec.methods), tmp_path)
    assert sorted(f.name for f in files) == ["noise_level.png", "noise_level.svg"]
    svg = (tmp_path / "noise_level.svg").read_text()
    assert "held: eye = left; blur = 0.5" in svg          # the title names what is held
    assert "eye=left" not in svg and "blur=" not in svg    # not in the legend's labels
    # drawn content clear of the edges (the bounding box taken after the layout)
    import matplotlib.image as mpimg
    img = mpimg.imread(tmp_path / "noise_level.png")[..., :3]
    ink = np.any(img < 0.95, axis=-1)
    assert not ink[:2].any() and not ink[-2:].any() and not ink[:, :2].any() \
        and not ink[:, -2:].any()


def test_no_varying_axis_no_figure(tmp_path):
    axes = {"eye": ["left"]}
    spec = SimpleNamespace(axes=axes, methods=["rasc"], name="s", confidence=0.95, samples=5)
    assert plot_study(spec, _summary(axes, spec.methods), tmp_path) == []
