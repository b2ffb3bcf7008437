"""rasc.testing renders imperfect heads with the unit options of ``rasc render --unit``
(issue 20 item 5): every spelling a test may use gives the same units, the cache key
covers them (and the ideal head's key is unchanged), and the render is of that head."""

from __future__ import annotations

import pytest

from rasc.errors import InputError
from rasc.sim.render import RenderOptions
from rasc.sim.units import IDEAL_BUILD, UnitBuild, read_unit_file
from rasc.testing import unit_builds

OFFSET = (0.0, 20.0, 0.0)


def test_every_spelling_gives_the_units_of_rasc_render_unit(tmp_path):
    unit_file = tmp_path / "unit.toml"
    unit_file.write_text("[both]\ntilt_axis_offset_mm = [0.0, 20.0, 0.0]\n"
                         "[right]\npan_zero_deg = 0.5\n")
    from_file = unit_builds(unit_file)
    assert from_file == read_unit_file(unit_file)                       # the file: as the CLI
    assert from_file["right"].pan_zero_deg == 0.5 and from_file["left"].pan_zero_deg == 0.0
    both = {"left": UnitBuild(tilt_axis_offset_mm=OFFSET),
            "right": UnitBuild(tilt_axis_offset_mm=OFFSET)}
    assert unit_builds({"tilt_axis_offset_mm": OFFSET}) == both         # fields, both units
    assert unit_builds(UnitBuild(tilt_axis_offset_mm=OFFSET)) == both   # a UnitBuild
    per_eye = unit_builds({"left": {"axis_skew_deg": 1.0}})             # one eye: right ideal
    assert per_eye == {"left": UnitBuild(axis_skew_deg=1.0), "right": IDEAL_BUILD}
    assert unit_builds(None) is None


def test_a_bad_field_is_one_line_naming_it():
    with pytest.raises(InputError, match=r"units\.left\.tilt_offset_mm: unknown key"):
        unit_builds({"left": {"tilt_offset_mm": OFFSET}})
    with pytest.raises(InputError, match=r"units"):
        unit_builds({"pan_scale": -1.0})


def test_the_key_covers_the_units_and_keeps_the_ideal_heads():
    from rasc.datasets.render import render_key
    opts = RenderOptions(intrinsics_views=8)
    ideal = render_key(opts)
    assert render_key(opts, units=None) == ideal
    offset = render_key(opts, units=unit_builds({"tilt_axis_offset_mm": OFFSET}))
    assert offset != ideal
    assert render_key(opts, units=unit_builds({"tilt_axis_offset_mm": (0.0, 21.0, 0.0)})) \
        != offset


@pytest.mark.slow
def test_the_render_is_of_the_imperfect_head(rasc_render):
    """The paper's model cannot absorb a 20 mm tilt-axis offset: its hand-eye is ~10 mm
    off on this head (measured 9.8-10.2 mm, tests/head/test_doors_one_behaviour.py), far
    above the 1 mm an ideal head's 8-view render gives. So a paper-model error above
    5 mm shows the offset was rendered; the general model recovers it (< 0.5 mm)."""
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset

    data = rasc_render(intrinsics_views=8, units={"tilt_axis_offset_mm": OFFSET})
    ds = data.load()
    paper = calibrate_dataset(ds, CalibrationOptions(model="paper"))
    general = calibrate_dataset(ds)
    for eye in ("left", "right"):
        assert paper.errors[eye]["T_cam_from_gaze"]["translation"] > 5e-3, eye
        assert general.errors[eye]["T_cam_from_gaze"]["translation"] < 0.5e-3, eye
