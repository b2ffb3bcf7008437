"""``experiments/plan_check.py``'s count of ``rasc plan``'s summary quantities within ±25 %
(issue 32: the plan's validation at the default supersample): each quantity's σ is the
root sum of squares of its components' σ, as :func:`rasc.plan.summarise` forms it, for the
prediction and the measurement alike."""

from __future__ import annotations

import numpy as np
import pytest

from experiments.plan_check import summary_lines, summary_quantities


def _rows(seed: int) -> tuple[list[dict], dict]:
    """Per-component rows of one position set with drawn σ, and the expected ratio of
    each (eye, quantity)."""
    rng = np.random.default_rng(seed)
    parts = {"hand-eye rotation": ("rotx", "roty", "rotz"),
             "hand-eye translation": ("tx", "ty", "tz"),
             "axis distance": ("axis_distance",), "axis angle": ("axis_angle",)}
    rows, expected = [], {}
    for eye in ("left", "right"):
        for quantity, names in parts.items():
            pred = rng.uniform(0.5, 2.0, len(names))
            meas = pred * rng.uniform(0.6, 1.6, len(names))
            expected[eye, quantity] = float(np.linalg.norm(meas) / np.linalg.norm(pred))
            rows += [{"positions": "planned", "eye": eye, "parameter": n,
                      "predicted": 1.0, "predicted_split": p, "measured_std": m}
                     for n, p, m in zip(names, pred, meas, strict=True)]
    return rows, expected


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_summary_quantities_add_components_in_quadrature(seed):
    rows, expected = _rows(seed)
    q = summary_quantities(rows, "predicted_split")
    assert len(q) == 8
    for x in q:
        assert x["ratio"] == pytest.approx(expected[x["eye"], x["quantity"]], rel=1e-12)
    within = sum(abs(v - 1) <= 0.25 for v in expected.values())
    line = [t for t in summary_lines(rows) if "each kind of view's own noise" in t]
    assert line and f": {within} of 8 within ±25 %" in line[0], line
