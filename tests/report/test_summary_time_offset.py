"""The report's summary page on a continuous capture whose time offset δ was estimated
(issue 33): its model-fit test reads the pose images' angles at each image's time + δ, as
the refinement did, so it shows the ideal head's pose views at the noise level and says
at which δ; the closed form's hand-eye diagnostics, which read them at δ = 0, say so."""

from __future__ import annotations

import re

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from rasc.head.fit import MISFIT_F_WARN  # noqa: E402
from rasc.head.pipeline import CalibrationOptions, calibrate_dataset  # noqa: E402
from rasc.report.pdf import _summary  # noqa: E402
from rasc.report.verdict import verdict  # noqa: E402
from rasc.sim.synthetic import continuous_corner_dataset  # noqa: E402


def _summary_text(doc: dict) -> str:
    fig = plt.figure()
    try:
        _summary(fig, doc, verdict(doc), "cal.json", None)
        return "\n".join(t.get_text() for t in fig.findobj(matplotlib.text.Text))
    finally:
        plt.close(fig)


def test_summary_model_fit_at_the_estimated_offset():
    """30 ms off at 20°/s: before, the summary showed F ≈ 6.3e5 (pose views at 7.9 px
    with one board) for a capture the refinement fits at the noise level."""
    ds = continuous_corner_dataset(seed=0, clock_offset=0.030)
    doc = calibrate_dataset(ds, CalibrationOptions()).to_dict()
    text = _summary_text(doc)
    shown = {eye: float(F) for eye, F in re.findall(r"(left|right): F = (\S+) \(", text)}
    assert set(shown) == {"left", "right"}
    assert all(F < MISFIT_F_WARN for F in shown.values()), shown
    delta_ms = 1000 * doc["refinement"]["time_offset"]["value_s"]
    assert f"time + δ = {delta_ms:.3f} ms" in text
    assert text.count("(closed form, readings at δ = 0)") == 2
    # held δ: no δ to name
    held = calibrate_dataset(ds, CalibrationOptions(time_offset="hold")).to_dict()
    text = _summary_text(held)
    assert "time + δ" not in text and "readings at δ = 0" not in text
