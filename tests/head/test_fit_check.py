"""The paper model's fit check (rasc.head.fit): silent on the ideal head, fires at a 5 mm
tilt-axis offset, on projected corners and on renders."""

from __future__ import annotations

import numpy as np
import pytest

from rasc.geometry.kinematics import PanTiltUnit
from rasc.head.fit import MISFIT_F_WARN, REMEDY, eye_fit, misfit_warning
from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
from rasc.sim.synthetic import corner_dataset, default_head

EYES = ("left", "right")


def _paper(unit, seed, noise_px=0.03):
    ds = corner_dataset(default_head(unit), seed=seed, noise_px=noise_px)
    return calibrate_dataset(ds, CalibrationOptions(model="paper"))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_silent_on_the_ideal_head(seed):
    cal = _paper(PanTiltUnit(), seed)
    assert all(cal.model_fit[eye].F < MISFIT_F_WARN for eye in EYES), cal.model_fit
    assert not any(REMEDY in w for w in cal.warnings)


@pytest.mark.parametrize("seed", [0, 1])
def test_fires_at_a_5_mm_tilt_axis_offset(seed):
    cal = _paper(PanTiltUnit(tilt_point=(0.0, 0.005, 0.0)), seed, noise_px=0.05)
    # measured F ≈ 500-4000 here: far above the threshold whatever the seed
    assert all(cal.model_fit[eye].F > 20 * MISFIT_F_WARN for eye in EYES), cal.model_fit
    (w,) = [w for w in cal.warnings if REMEDY in w]
    assert w.startswith("the paper's pan-tilt model (eq. 3) does not fit the pose views: left F")
    assert "\n" not in w


def test_encoder_offsets_fit_the_paper_model():
    # the paper's unit absorbs encoder zero offsets exactly (docs/METHOD.md §10): no misfit
    cal = _paper(PanTiltUnit(pan_offset=np.radians(0.5), tilt_offset=np.radians(0.5)), 0)
    assert all(cal.model_fit[eye].F < MISFIT_F_WARN for eye in EYES)


def test_noise_free_exact_model_has_no_extra_residual():
    # no noise: both fits reach ~0 (OpenCV's calibrateCamera and solvePnP stop at a few
    # 1e-6 px here), so F is a ratio of two convergence remainders and means nothing —
    # check the residuals themselves: 1e-4 px is 300x below any corner noise
    ds = corner_dataset(default_head(), seed=0, noise_px=0.0)
    cal = calibrate_dataset(ds, CalibrationOptions(model="paper"))
    for eye in EYES:
        f = cal.model_fit[eye]
        assert f.rms_model < 1e-4 and f.rms_free < 1e-4


def test_warning_names_only_the_eyes_above_threshold():
    from rasc.head.fit import EyeFit
    fits = {"left": EyeFit(F=1.2, rms_model=0.03, rms_free=0.03, views=9),
            "right": EyeFit(F=900.0, rms_model=0.4, rms_free=0.03, views=9)}
    w = misfit_warning(fits)
    assert "right F = 900" in w and "left" not in w.split(":")[1]
    assert misfit_warning({"left": fits["left"]}) is None
    assert eye_fit.__doc__


@pytest.mark.slow
@pytest.mark.parametrize("offset_mm, fires", [(0, False), (5, True)])
def test_on_renders(tmp_path, offset_mm, fires, capsys):
    # 8 intrinsics views instead of the default 20: the check compares the pose views'
    # residuals under one board against one board per view, both through the same K, so
    # the intrinsics views only need to give a good K. Measured with 8: F = 0.68 / 1.4
    # (left / right) at 0 mm, ~7000-8400 at 5 mm, against the threshold 5. The commands
    # run as rasc.cli.main in this process (the warning is main's stderr line; the process
    # boundary is not the claim here).
    from rasc.cli import main

    assert main(["render", "--out", str(tmp_path / "ds"), "--quiet", "--intrinsics-views",
                 "8", "--tilt-axis-offset", f"0,{offset_mm},0"]) == 0, capsys.readouterr().err
    capsys.readouterr()
    assert main(["calibrate", str(tmp_path / "ds"), "--model", "paper", "--quiet",
                 "--out", str(tmp_path / "cal.json")]) == 0
    r = capsys.readouterr()
    warned = [line for line in r.err.splitlines() if line.endswith(REMEDY)]
    assert len(warned) == (1 if fires else 0), r.err


def test_a_significant_but_negligible_excess_is_no_misfit():
    # many corners make a tiny structured excess significant: an ideal head's ChArUco
    # views at planned ±20° positions gave F = 5.39 with RMS 0.0329 px under one board
    # against 0.0314 px per view (4.8 % more): no misfit. A 5 mm tilt-axis offset leaves
    # 5-13x the per-view RMS; at the threshold's edge, 12 % more is one.
    from rasc.head.fit import EyeFit, is_misfit

    assert not is_misfit(5.39, 0.0329, 0.0314)
    assert misfit_warning({"right": EyeFit(F=5.39, rms_model=0.0329, rms_free=0.0314,
                                           views=9)}) is None
    assert is_misfit(5.39, 0.0352, 0.0314) and is_misfit(900.0, 0.4, 0.03)
    assert not is_misfit(MISFIT_F_WARN, 1.0, 0.03)        # F not above the threshold
    assert is_misfit(6.0)                                 # the RMS unknown: F decides
