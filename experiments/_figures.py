"""Figure saving for the experiments: PNG and SVG in the full protocol, PNG only in
``--quick`` (the reduced protocol, for tests; the SVG doubles the drawing time)."""

from __future__ import annotations

import io
from pathlib import Path

from rasc.io import write_bytes_atomic
from rasc.study.figures import save_figure


def save_experiment_figure(fig, path_stem: Path, quick: bool) -> list[Path]:
    """``rasc.study.figures.save_figure`` (PNG and SVG, deterministic bytes), or with
    ``quick`` the same PNG alone (same dpi, same tight bounding box, no date)."""
    if not quick:
        return save_figure(fig, path_stem)
    fig.draw_without_rendering()     # the layout engine first, then the box (not cropped)
    bbox = fig.get_tightbbox(fig.canvas.get_renderer()).padded(0.1)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120, metadata={"Software": None}, bbox_inches=bbox)
    path = path_stem.with_suffix(".png")
    write_bytes_atomic(path, buf.getvalue())
    return [path]
