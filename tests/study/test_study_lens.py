"""``rasc study``'s lens parameters (issue 32): RenderOptions' ``lens`` and ``fov`` and
the calibration's ``dist_model``, fixed or swept as the degradations are, checked before
anything runs, and leaving a cell's identity unchanged at their defaults. The spec of
docs/guide/studies.md ("Through a wide lens") is loaded by the docs tests."""

from __future__ import annotations

import dataclasses

import pytest
from test_study import assert_refused, write

from rasc.sim.render import LENS_FIELDS, RenderOptions
from rasc.study import load_spec
from rasc.study.spec import PARAMS

HEAD = "seed = 5\nsamples = 2\nmethods = ['rasc']\n"

BAD = [
    ("[fixed]\nlens = 'omni'\n", "fixed.lens: "),
    ("[fixed]\nfov = 200\n", "fixed.fov: expected a number from 0 to 180"),
    ("[axes]\ndist_model = ['k1k2', 'k9']\n", "axes.dist_model[1]: "),
    ("[fixed]\nlens = 'fisheye'\nintrinsics_from = 'dataset'\n",
     "fixed.lens: is the lens of a dataset rendered and calibrated whole; not with "
     "intrinsics_from = 'dataset'"),
]


@pytest.mark.parametrize(("text", "message"), BAD)
def test_bad_lens_parameter_is_one_line_naming_the_key(tmp_path, capsys, text, message):
    assert_refused(tmp_path, capsys, HEAD + text, message)


def test_the_lens_fields_are_study_parameters_with_the_renderers_defaults():
    defaults = RenderOptions()
    for key in LENS_FIELDS:
        assert PARAMS[key].kind == "render", key
        assert PARAMS[key].default == getattr(defaults, key), key
    assert PARAMS["dist_model"].kind == "render"


def test_defaults_keep_the_cells_and_a_sweep_makes_new_ones(tmp_path):
    base = load_spec(write(tmp_path, HEAD + "[axes]\nnoise_level = [1, 2]\n", "a.toml"))
    fields = "".join(f"{k} = {PARAMS[k].default!r}\n" for k in (*LENS_FIELDS, "dist_model"))
    same = load_spec(write(tmp_path, HEAD + "[fixed]\n" + fields
                           + "[axes]\nnoise_level = [1, 2]\n", "b.toml"))
    assert [c.key for c in same.cells()] == [c.key for c in base.cells()]
    assert [c.seed_words for c in same.cells()] == [c.seed_words for c in base.cells()]
    swept = load_spec(write(tmp_path, HEAD + "[fixed]\nlens = 'fisheye'\nfov = 150\n"
                            "[axes]\ndist_model = ['fisheye', 'k1k2']\n", "c.toml"))
    cells = swept.cells()
    assert len({c.key for c in cells}) == 2
    assert [c.render_value("dist_model") for c in cells] == ["fisheye", "k1k2"]
    assert not {c.key for c in cells} & {c.key for c in base.cells()}


@pytest.mark.parametrize(("render", "dist_model"), [
    ({"lens": "fisheye", "fov": 150.0, "distortion": [0.02, -0.01, 0.003, -0.0005]},
     "fisheye"),                                    # '' = the lens's own
    ({"lens": "fisheye", "fov": 150.0, "dist_model": "k1k2"}, "k1k2"),
    ({}, None),                                     # the pinhole: the options' default
])
def test_a_cell_renders_the_lens_and_calibrates_with_its_model(monkeypatch, render,
                                                                dist_model):
    """render_task builds RenderOptions with the cell's lens and calibrates with its
    dist_model (the renderer and the calibration replaced: only the arguments are
    looked at)."""
    import rasc.datasets.calibration as calibration
    import rasc.sim.render as sim_render
    from rasc.study.datasets import RenderTask, render_task

    seen = {}

    def fake_render(options, **_):
        seen["options"] = options
        return object()

    def fake_calibrate(ds, dist_model=None, **_):
        seen["dist_model"] = dist_model
        return {"ok": True}

    monkeypatch.setattr(sim_render, "render_in_memory", fake_render)
    monkeypatch.setattr(calibration, "calibrate", fake_calibrate)
    fields = {f.name for f in dataclasses.fields(RenderTask)}
    args = {"key": "k", "render": render, "seed": 1, "where": "spec.toml"}
    assert render_task(RenderTask(**{k: v for k, v in args.items() if k in fields})) \
        == {"ok": True}
    o = seen["options"]
    assert (o.lens, o.fov) == (render.get("lens", "pinhole"), render.get("fov", 0.0))
    assert seen["dist_model"] == dist_model
