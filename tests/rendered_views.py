"""Detections of a rendered dataset against the renderer's truth (plain functions).

Import them from any room (``from rendered_views import seen_against_truth``; tests/ is on
sys.path through the root conftest)."""

from __future__ import annotations

import numpy as np


def seen_against_truth(corners: np.ndarray, view_truth: dict) -> tuple[np.ndarray, float]:
    """A target seen in part, one view: the ids the detection ``corners`` (N, 2, NaN rows
    not seen) found and their RMS distance (px) to the renderer's truth for that view
    (``ground_truth.json`` ``views.<file>.corners``: ``ids``, ``uv``). Asserts that every id
    found is one the truth lists inside the image."""
    ids = np.array(view_truth["ids"])
    seen = np.flatnonzero(np.isfinite(corners[:, 0]))
    assert set(seen) <= set(ids)
    uv = np.array(view_truth["uv"])[np.searchsorted(ids, seen)]
    return seen, float(np.sqrt(np.mean(np.sum((corners[seen] - uv) ** 2, axis=1))))
