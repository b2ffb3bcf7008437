"""rasc.head.pipeline.refine_calibration: the general model from a closed-form calibration
gives what ``calibrate_dataset(..., model="general")`` gives, and reuses the closed form's
model-fit check instead of making it again (projected corners: no render)."""

from __future__ import annotations

import dataclasses

import numpy as np

from rasc.geometry.kinematics import PanTiltUnit
from rasc.head import fit
from rasc.head.pipeline import CalibrationOptions, calibrate_dataset, refine_calibration
from rasc.io import dumps_json
from rasc.sim.synthetic import corner_dataset, default_head


def _dataset():
    # a unit that breaks the paper's model (20 mm between the axes), so the refinement
    # has something to do; 0.03 px of corner noise, seeded
    unit = PanTiltUnit(tilt_axis=(0.0, 0.0, 1.0), tilt_point=(0.0, 0.02, 0.0))
    return corner_dataset(default_head(unit), seed=3, noise_px=0.03)


def _without_timings(cal) -> str:
    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k != "timings_s"}
        return [strip(v) for v in x] if isinstance(x, list) else x
    return dumps_json(strip(cal.to_dict()))


def test_refine_calibration_is_calibrate_with_the_general_model(monkeypatch):
    ds = _dataset()
    calls = []
    real = fit.calibration_fit
    monkeypatch.setattr(fit, "calibration_fit",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    closed = calibrate_dataset(ds)
    assert len(calls) == 1 and closed.model_fit is not None
    refined = refine_calibration(closed, ds)
    assert len(calls) == 1                      # the closed form's check, reused
    assert refined.model_fit is closed.model_fit
    assert "model-fit check" in refined.timings and "refinement" in refined.timings
    general = calibrate_dataset(ds, dataclasses.replace(CalibrationOptions(), model="general"))
    assert len(calls) == 2
    # the same document, number for number (only the stage timings differ)
    assert _without_timings(refined) == _without_timings(general)
    # and the refinement did change the head (the control that the comparison has teeth)
    assert not np.allclose(refined.head.left.T_cam_from_gaze, closed.head.left.T_cam_from_gaze,
                           atol=1e-9)


def test_an_unreadable_ground_truth_is_refused_before_any_work(monkeypatch):
    """The ground truth is read first: its error comes before detection and calibration
    (seconds of work on real images), not after them."""
    from pathlib import Path

    import pytest

    from rasc.errors import InputError
    from rasc.head import pipeline

    ds = _dataset()
    calls = []
    monkeypatch.setattr(pipeline, "calibrate_eye", lambda *a, **k: calls.append(1))

    def unreadable():
        raise InputError("ground_truth.json: malformed JSON (line 1, column 2)")

    ds.ground_truth = Path("ground_truth.json")
    ds.load_ground_truth = unreadable
    with pytest.raises(InputError, match="malformed JSON"):
        calibrate_dataset(ds)
    assert calls == []
