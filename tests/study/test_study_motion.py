"""``rasc study``'s continuous-motion parameters (issue 33): RenderOptions' motion fields
(motion_speed_deg_s, exposure, clock_offset, ...) fixed or swept as the degradations are,
checked before anything runs, and leaving a cell's identity unchanged at their defaults.
A rendered study with them is the example of docs/guide/studies.md ("A head that never
stops"), run by the docs tests."""

from __future__ import annotations

import dataclasses

import pytest
from test_study import assert_refused, write

from rasc.sim.render import CONTINUOUS, RenderOptions
from rasc.study import load_spec
from rasc.study.spec import PARAMS

HEAD = "seed = 5\nsamples = 2\nmethods = ['rasc']\n"

BAD = [
    ("[fixed]\nsubframes = 65\n", "fixed.subframes: expected an integer from 1 to 64"),
    ("[fixed]\nmotion_speed_deg_s = 600\n", "fixed.motion_speed_deg_s: expected a number "
                                            "from 0 to 500"),
    ("[fixed]\nmotion_speed_deg_s = 30\n[axes]\nclock_offset = [0.0, 11.0]\n",
     "axes.clock_offset[1]: expected a number from -10 to 10 (seconds), got 11"),
    ("[fixed]\nmotion_speed_deg_s = 30\nexposure = 0\n",
     "fixed.exposure: expected a number above 0 and at most 1 (seconds), got 0"),
    ("[fixed]\nclock_offset = 0.02\n", "fixed.clock_offset: is for continuous motion: give "
                                       "motion_speed_deg_s > 0 in every cell"),
    ("[fixed]\nclock_offset = 0.02\n[axes]\nmotion_speed_deg_s = [0.0, 30.0]\n",
     "fixed.clock_offset: is for continuous motion"),
    ("[fixed]\nmotion_speed_deg_s = 30\nintrinsics_from = 'dataset'\n",
     "fixed.motion_speed_deg_s: a continuous capture is rendered whole; not with "
     "intrinsics_from = 'dataset'"),
]


@pytest.mark.parametrize(("text", "message"), BAD)
def test_bad_motion_parameter_is_one_line_naming_the_key(tmp_path, capsys, text, message):
    assert_refused(tmp_path, capsys, HEAD + text, message)


def test_every_motion_field_is_a_study_parameter_with_the_renderers_default():
    defaults = RenderOptions()
    for key in CONTINUOUS:
        assert PARAMS[key].kind == "render", key
        assert PARAMS[key].default == getattr(defaults, key), key


def test_defaults_keep_the_cells_and_a_sweep_makes_new_ones(tmp_path):
    base = load_spec(write(tmp_path, HEAD + "[axes]\nnoise_level = [1, 2]\n", "a.toml"))
    fields = "".join(f"{k} = {PARAMS[k].default!r}\n" for k in CONTINUOUS)
    same = load_spec(write(tmp_path, HEAD + "[fixed]\n" + fields
                           + "[axes]\nnoise_level = [1, 2]\n", "b.toml"))
    assert [c.key for c in same.cells()] == [c.key for c in base.cells()]
    assert [c.seed_words for c in same.cells()] == [c.seed_words for c in base.cells()]
    swept = load_spec(write(tmp_path, HEAD + "[fixed]\nmotion_speed_deg_s = 30.0\n"
                            "[axes]\nclock_offset = [0.0, 0.02]\nexposure = [0.002, 0.03]\n",
                            "c.toml"))
    cells = swept.cells()
    assert len(cells) == 4 and len({c.key for c in cells}) == 4
    assert sorted({c.render_value("clock_offset") for c in cells}) == [0.0, 0.02]
    assert {c.render_value("motion_speed_deg_s") for c in cells} == {30.0}
    assert not {c.key for c in cells} & {c.key for c in base.cells()}


def test_a_cell_renders_the_motion_it_names(monkeypatch):
    """render_task builds RenderOptions with the cell's motion fields (the renderer and
    the calibration replaced: only the options are looked at)."""
    import rasc.datasets.calibration as calibration
    import rasc.sim.render as render
    from rasc.study.datasets import RenderTask, render_task

    seen = {}

    def fake_render(options, **_):
        seen["options"] = options
        return object()

    monkeypatch.setattr(render, "render_in_memory", fake_render)
    monkeypatch.setattr(calibration, "calibrate", lambda ds, **_: {"ok": True})
    fields = {f.name for f in dataclasses.fields(RenderTask)}
    args = {"key": "k", "render": {"motion_speed_deg_s": 45.0, "clock_offset": -0.05,
                                   "max_frames": 7, "subframes": 3}, "seed": 1,
            "where": "spec.toml"}
    task = RenderTask(**{k: v for k, v in args.items() if k in fields})
    assert render_task(task) == {"ok": True}
    o = seen["options"]
    assert (o.motion_speed_deg_s, o.clock_offset, o.max_frames, o.subframes) == (
        45.0, -0.05, 7, 3)
    assert o.exposure == RenderOptions().exposure
