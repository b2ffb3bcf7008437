"""Supersampled renders (``RenderOptions.supersample``, ``rasc render --supersample``;
issue 32): rendered at S times the size and averaged over S x S pixels, the detected
corners come closer to the renderer's truth without a shift; S = 1 is the plain render
of before (its images, ground truth and cache keys unchanged), and the default
(``rasc.sim.DEFAULT_SUPERSAMPLE``, 2 since 2026-11-28) is one value that RenderOptions,
``rasc render`` and the study parameter share, with a cache key of its own.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import json  # noqa: E402
from dataclasses import asdict  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from rasc.errors import InputError  # noqa: E402
from rasc.sim import DEFAULT_SUPERSAMPLE  # noqa: E402
from rasc.sim.render import MAX_SUPERSAMPLE, RenderOptions  # noqa: E402
from rasc.vision.board import Board  # noqa: E402

from running import run_rasc  # noqa: E402

#: pose views of the stock 9x6 chessboard at 1 m, both eyes
POSES = [(0, 0), (8, 8), (-8, -8), (8, -8), (-8, 8)]


def _corner_errors(sim, board, supersample: int) -> np.ndarray:
    """Detected minus true corners (N, 2) over POSES and both eyes."""
    from rasc.vision.camera import detect_corners

    P = board.object_points()
    errors = []
    for pan, tilt in POSES:
        for eye in ("left", "right"):
            sim.set_angles(eye, np.radians(pan), np.radians(tilt))
            image = sim.render_grey(eye, supersample=supersample)
            assert image.shape == sim.image_size[::-1]
            c = detect_corners(image, board, "saddle", min_corners=8)
            assert c is not None and np.isfinite(c).all(), (eye, pan, tilt, supersample)
            errors.append(c - sim.project_world_points(eye, P))
    return np.concatenate(errors)


@pytest.mark.slow
def test_supersampled_corners_are_closer_to_the_truth_and_unshifted():
    """The default's renders (RenderOptions().supersample, 2) against the plain render's
    (1), on the same views: the corner error the default was chosen for."""
    from rasc.sim.scene import StereoHeadSim

    default = RenderOptions().supersample
    assert default > 1
    board = Board((9, 6), 0.05)
    with StereoHeadSim(board=board) as sim:
        e1, e2 = _corner_errors(sim, board, 1), _corner_errors(sim, board, default)
    rms1, rms2 = (float(np.sqrt(np.mean(np.sum(e ** 2, axis=1)))) for e in (e1, e2))
    # measured on these 10 views: 0.0197 px at S = 1, 0.0102 px at S = 2 (ratio 0.52);
    # 0.75 leaves room for another OpenGL and still needs a clear gain
    assert rms2 < 0.75 * rms1, (rms1, rms2)
    # no shift: a wrong pixel-centre convention would move every corner by
    # (S - 1) / (2 S) = 0.25 px at S = 2; measured mean errors within 0.001 px
    assert np.all(np.abs(e2.mean(axis=0)) < 0.005), e2.mean(axis=0)
    assert np.all(np.abs(e1.mean(axis=0)) < 0.005), e1.mean(axis=0)


def test_plain_render_is_the_renderer_at_the_image_size():
    """S = 1 is MuJoCo's renderer at the image size, converted to grey: the images of
    before, byte for byte (an independent render here, not the sim's path); S = 2 differs
    and has the same size."""
    from rasc.sim.scene import StereoHeadSim, import_mujoco
    from rasc.vision.camera import to_grey

    mujoco = import_mujoco()
    with StereoHeadSim(board=Board((9, 6), 0.05), image_size=(320, 240)) as sim:
        sim.set_angles("left", np.radians(4.0), np.radians(-3.0))
        plain = sim.render_grey("left")
        double = sim.render_grey("left", supersample=2)
        again = sim.render_grey("left")
        sim.forward()
        r = mujoco.Renderer(sim.model, height=240, width=320)
        try:
            r.update_scene(sim.data, camera="left_camera")
            reference = to_grey(r.render(), order="rgb")
        finally:
            r.close()
    np.testing.assert_array_equal(plain, reference)
    np.testing.assert_array_equal(again, plain)
    assert double.shape == plain.shape and not np.array_equal(double, plain)


def test_supersample_beyond_the_models_offscreen_buffer_renders():
    """A model whose <visual><global offwidth offheight> only fits the image size: the
    sim's copy of the model gets a buffer S times larger, the render works."""
    from rasc.sim.scene import StereoHeadSim

    with StereoHeadSim(board=Board((9, 6), 0.05), image_size=(160, 120)) as sim:
        g = sim.model.vis.global_
        g.offwidth, g.offheight = 160, 120
        assert sim.render_grey("left", supersample=3).shape == (120, 160)
        assert (g.offwidth, g.offheight) == (480, 360)


@pytest.mark.parametrize("value", [0, MAX_SUPERSAMPLE + 1, 1.5, True, "2"])
def test_bad_supersample_is_one_line_naming_the_field(value):
    with pytest.raises(InputError, match=rf"^supersample must be an integer from 1 to "
                                         rf"{MAX_SUPERSAMPLE}, got"):
        RenderOptions(supersample=value).validate()


@pytest.mark.parametrize("value", ["0", str(MAX_SUPERSAMPLE + 1)])
def test_rasc_render_refuses_a_bad_supersample_writing_nothing(tmp_path, capsys, value):
    out = tmp_path / "ds"
    status, stdout, err = run_rasc(["render", "--out", out, "--supersample", value,
                                    "--quiet"], capsys)
    assert status == 2 and stdout == ""
    assert err.strip().splitlines() == [
        f"rasc render: error: --supersample must be an integer from 1 to "
        f"{MAX_SUPERSAMPLE}, got {value}"]
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_cache_key_of_supersample_1_is_the_key_of_before():
    """The render key hashes the options without ``supersample`` at 1 (the plain render:
    the dict of before the field existed); any other S, the default among them, is
    another key, so a cached plain render is never served for the default's."""
    from rasc.datasets.keys import cache_key
    from rasc.datasets.render import render_key, render_what

    options = RenderOptions(seed=3, intrinsics_views=5, supersample=1)
    before = asdict(options)
    del before["supersample"]
    assert render_what(options)["options"] == render_what(before)["options"]
    assert render_key(options) == cache_key("render-folder", {"options": render_what(
        before)["options"], "model": None})
    default = RenderOptions(seed=3, intrinsics_views=5)
    assert render_what(default)["options"]["supersample"] == DEFAULT_SUPERSAMPLE == 2
    keys = {render_key(RenderOptions(seed=3, intrinsics_views=5, supersample=s))
            for s in range(1, MAX_SUPERSAMPLE + 1)}
    assert len(keys) == MAX_SUPERSAMPLE and render_key(default) in keys - {
        render_key(options)}


def test_the_default_is_one_value_for_python_the_command_and_a_study(tmp_path, capsys):
    """RenderOptions' default is what ``rasc render`` renders without --supersample (the
    ground truth records it) and what a study cell renders without the parameter."""
    from rasc.study.spec import PARAMS

    assert RenderOptions().supersample == PARAMS["supersample"].default \
        == DEFAULT_SUPERSAMPLE
    out = tmp_path / "ds"
    status, _, err = run_rasc(["render", "--out", out, "--intrinsics-views", "3",
                               "--poses", "0,0;8,8;-8,0", "--quiet"], capsys)
    assert status == 0, err
    truth = json.loads((out / "ground_truth.json").read_text())
    assert truth["render_options"]["supersample"] == DEFAULT_SUPERSAMPLE


def test_study_parameter_is_checked_and_its_default_keeps_the_cells(tmp_path):
    """The default (2) written out leaves a cell's identity, key and seeds as a spec
    without it (a spec's draws do not move with the default); 1 is a cell of its own."""
    from rasc.study import load_spec

    head = "seed = 5\nsamples = 2\nmethods = ['rasc']\n"
    base, same, plain = (tmp_path / f"{n}.toml" for n in "abc")
    base.write_text(head + "[axes]\nnoise_level = [1, 2]\n")
    same.write_text(head + "[fixed]\nsupersample = 2\n[axes]\nnoise_level = [1, 2]\n")
    plain.write_text(head + "[fixed]\nsupersample = 1\n[axes]\nnoise_level = [1, 2]\n")
    a, b, c = (load_spec(p) for p in (base, same, plain))
    assert [x.key for x in b.cells()] == [x.key for x in a.cells()]
    assert [x.seed_words for x in b.cells()] == [x.seed_words for x in a.cells()]
    assert {x.key for x in c.cells()}.isdisjoint(x.key for x in a.cells())
    assert all(x.render_value("supersample") == 2 for x in a.cells())
    assert all(x.render_value("supersample") == 1 for x in c.cells())
    bad = tmp_path / "bad.toml"
    bad.write_text(head + f"[fixed]\nsupersample = {MAX_SUPERSAMPLE + 1}\n")
    with pytest.raises(InputError, match=rf"bad.toml: fixed.supersample: expected an integer "
                                         rf"from 1 to {MAX_SUPERSAMPLE}"):
        load_spec(bad)
