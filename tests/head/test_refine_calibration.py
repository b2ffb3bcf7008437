"""rasc.head.pipeline.refine_calibration: the general model from a closed-form calibration
gives what ``calibrate_dataset(..., model="general")`` gives, and reuses the closed form's
model-fit check instead of making it again (projected corners: no render)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

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
    closed = calibrate_dataset(ds, CalibrationOptions(model="paper"))
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
        calibrate_dataset(ds, CalibrationOptions(model="paper"))
    assert calls == []


def _truth() -> dict:
    """A ground truth of ``rasc render``'s layout (the values do not matter here)."""
    eye = {"K": np.eye(3).tolist(), "T_cam_from_gaze": np.eye(4).tolist(),
           "T_ptu_from_base": np.eye(4).tolist()}
    return {"left": dict(eye), "right": dict(eye), "T_ptuL_from_ptuR": np.eye(4).tolist(),
            "views": {"poses/left_00.png": {"eye": "left",
                                            "T_cam_from_world": np.eye(4).tolist()}}}


def _without(path: str):
    def change(t):
        *head, last = path.split(".")
        for k in head:
            t = t[k]
        del t[last]
    return change


def _set(path: str, value):
    def change(t):
        *head, last = path.split(".")
        for k in head:
            t = t[k]
        t[last] = value
    return change


STRUCTURE_CASES = {
    "no right eye": (_without("right"), "missing field 'right'"),
    "no K": (_without("left.K"), "missing field left.K"),
    "no T_cam_from_gaze": (_without("right.T_cam_from_gaze"),
                           "missing field right.T_cam_from_gaze"),
    "no mount": (_without("T_ptuL_from_ptuR"), "missing field 'T_ptuL_from_ptuR'"),
    "K of the wrong shape": (_set("left.K", [[1, 0], [0, 1]]),
                             r"left\.K: expected a 3x3 matrix, got shape \(2, 2\)"),
    "NaN in a transform": (_set("right.T_ptu_from_base", [[float("nan")] * 4] * 4),
                           r"right\.T_ptu_from_base: contains NaN or infinity"),
    "text for a matrix": (_set("T_ptuL_from_ptuR", "identity"),
                          r"T_ptuL_from_ptuR: not a numeric 4x4 matrix"),
    "a transform not rigid": (_set("left.T_cam_from_gaze", [[2, 0, 0, 0], [0, 1, 0, 0],
                                                            [0, 0, 1, 0], [0, 0, 0, 1]]),
                              r"left\.T_cam_from_gaze: rotation part is not orthonormal"),
    "K not a camera matrix": (_set("right.K", [[1, 0, 0], [0, 1, 0], [0, 0, 2]]),
                              r"right\.K: not upper triangular with last row \[0, 0, 1\]"),
    "eye not an object": (_set("left", [1, 2]), r"left: expected an object"),
    "view without its pose": (_set("views", {"poses/left_00.png": {"eye": "left"}}),
                              r"missing field views.poses/left_00.png.T_cam_from_world"),
}


@pytest.mark.parametrize("case", list(STRUCTURE_CASES))
def test_a_ground_truth_of_the_wrong_shape_is_refused_before_any_work(case, monkeypatch):
    """Valid JSON without a field the comparison reads (or with a matrix of the wrong
    shape, or not finite) is refused with the file and the field named, before detection
    and calibration, not after them (and never as NaN errors)."""
    from pathlib import Path

    from rasc.errors import InputError
    from rasc.head import pipeline

    change, message = STRUCTURE_CASES[case]
    truth = _truth()
    pipeline.check_ground_truth(truth, "gt.json")           # the control: accepted
    change(truth)
    ds = _dataset()
    calls = []
    monkeypatch.setattr(pipeline, "calibrate_eye", lambda *a, **k: calls.append(1))
    ds.ground_truth = Path("gt.json")
    ds.load_ground_truth = lambda: truth
    with pytest.raises(InputError, match=rf"^gt\.json: {message}"):
        calibrate_dataset(ds, CalibrationOptions(model="paper"))
    assert calls == []
