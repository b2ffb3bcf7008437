"""The degradations real cameras show (issue 32; docs/topics/degradations.md): sensor shot
and read noise, vignetting, depth-dependent defocus, motion blur and JPEG compression,
each a ``RenderOptions`` field, a ``rasc render`` flag and a study parameter, off by
default (the renders, ground truth and cache keys of before).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

from dataclasses import asdict  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import rasc.sim.degrade as dg  # noqa: E402
from rasc.errors import InputError  # noqa: E402
from rasc.sim.render import CONTINUOUS, DEGRADATIONS, LENS_FIELDS, RenderOptions  # noqa: E402
from rasc.vision.board import Board  # noqa: E402

from running import run_rasc  # noqa: E402

BOARD = Board((9, 6), 0.05)
#: pose views of the stock 9x6 chessboard at 1 m, both eyes
POSES = [(0, 0), (8, 8), (-8, -8)]


# ------------------------------------------------------------------ the functions alone

@pytest.mark.parametrize("read_noise", [0.0, 20.0])
def test_shot_noise_variance_is_proportional_to_the_signal(read_noise):
    """Grey variance = (signal·gain + read²)/gain² (+1/12 of rounding), gain = full
    well / 255 electrons per grey level; the mean is the signal."""
    full_well = 10_000.0
    gain = full_well / 255.0
    rng = np.random.default_rng(7)
    for level in (20, 80, 200):
        flat = np.full((300, 300), level, np.uint8)
        out = dg.sensor_noise(flat, full_well, read_noise, rng).astype(float)
        expected = (level * gain + read_noise ** 2) / gain ** 2 + 1 / 12
        assert abs(out.mean() - level) < 0.05, (level, out.mean())
        assert abs(out.var() / expected - 1) < 0.05, (level, out.var(), expected)


def test_sensor_noise_off_draws_nothing():
    image = np.arange(256, dtype=np.uint8).reshape(16, 16)
    rng = np.random.default_rng(3)
    state = rng.bit_generator.state
    np.testing.assert_array_equal(dg.sensor_noise(image, 0.0, 0.0, rng), image)
    assert rng.bit_generator.state == state


def test_vignetting_loses_its_fraction_at_the_corners():
    flat = np.full((121, 161), 200, np.uint8)
    out = dg.vignette(flat, 0.4).astype(float)
    assert out[60, 80] == 200                              # the centre
    for v, u in ((0, 0), (0, 160), (120, 0), (120, 160)):
        assert out[v, u] == np.rint(200 * 0.6)
    # half way to the corner: 1 - 0.4 / 4
    assert abs(out[30, 40] - 200 * (1 - 0.4 / 4)) <= 0.5


@pytest.mark.parametrize("length, angle", [(6.0, 0.0), (9.0, 90.0), (10.0, 30.0)])
def test_motion_blur_spreads_a_point_along_its_direction(length, angle):
    """A point's image: its centroid unmoved, its spread along the motion that of a
    uniform segment (L²/12, plus the bilinear splat's 1/6 px²), none across."""
    k = dg.motion_kernel(length, angle)
    assert abs(k.sum() - 1) < 1e-12
    v, u = np.mgrid[0:k.shape[0], 0:k.shape[1]].astype(float)
    c = (k.shape[0] - 1) / 2
    mu, mv = (k * u).sum(), (k * v).sum()
    assert abs(mu - c) < 1e-9 and abs(mv - c) < 1e-9
    a = np.radians(angle)
    along = (u - c) * np.cos(a) + (v - c) * np.sin(a)
    across = -(u - c) * np.sin(a) + (v - c) * np.cos(a)
    assert abs((k * along ** 2).sum() - length ** 2 / 12) < 0.2
    assert (k * across ** 2).sum() < 0.2


def test_circle_of_confusion_is_the_thin_lens_one():
    fx, f_mm, N, s = 1000.0, 8.0, 2.0, 0.5
    c = dg.circle_of_confusion_px(np.array([0.5, 1.0, 1e9, 0.25]), fx, f_mm, N, s)
    far = fx * 0.008 / (N * (s - 0.008))     # at infinity: (f/N) f/(s-f) on the sensor
    np.testing.assert_allclose(c, [0.0, far / 2, far, far], rtol=1e-6)


def test_defocus_of_a_uniform_circle_is_the_disk():
    """A constant circle of confusion is a convolution with the disk of that diameter:
    a step edge widens to the disk's diameter (10-90 % rise within it)."""
    image = np.zeros((64, 64), np.uint8)
    image[:, 32:] = 200
    out = dg.defocus(image, np.full((64, 64), 12.0)).astype(float)[32]
    assert out[:20].max() == 0 and out[44:].min() == 200
    rise = np.flatnonzero((out > 20) & (out < 180))
    assert 6 <= len(rise) <= 12, rise
    np.testing.assert_array_equal(dg.defocus(image, np.zeros((64, 64))), image)


@pytest.mark.parametrize("bad, message", [
    (lambda im, rng: dg.sensor_noise(im, 0.5, 0, rng), r"^full_well must be"),
    (lambda im, rng: dg.vignette(im, 1.5), r"^vignetting must be"),
    (lambda im, rng: dg.motion_blur(im, -1), r"^motion_blur must be"),
    (lambda im, rng: dg.motion_blur(im, 3, float("nan")), r"^motion_angle must be"),
    (lambda im, rng: dg.jpeg(im, 101), r"^jpeg_quality must be"),
    (lambda im, rng: dg.defocus(im, np.zeros((3, 3))), r"^defocus: circle-of-confusion map"),
])
def test_the_functions_refuse_bad_values_in_one_line(bad, message):
    with pytest.raises(InputError, match=message):
        bad(np.zeros((8, 8), np.uint8), np.random.default_rng(0))


# ------------------------------------------------------------ on the renderer's truth

def _corner_rms(sim, options: RenderOptions) -> float:
    """RMS (px) of detected minus true corners over POSES and both eyes, the images as
    ``rasc render`` makes them (:func:`rasc.sim.render.view_image`)."""
    from rasc.sim.render import view_image
    from rasc.vision.camera import detect_corners

    rng = np.random.default_rng(options.seed)
    errors = []
    for pan, tilt in POSES:
        for eye in ("left", "right"):
            sim.set_angles(eye, np.radians(pan), np.radians(tilt))
            image = view_image(sim, eye, {}, rng, options)
            c = detect_corners(image, BOARD, "saddle", min_corners=8)
            assert c is not None and np.isfinite(c).all(), (eye, pan, tilt, options)
            errors.append(c - sim.project_world_points(eye, BOARD.object_points()))
    e = np.concatenate(errors)
    return float(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))


@pytest.fixture(scope="module")
def sim():
    from rasc.sim.scene import StereoHeadSim, T_base_from_world_facing

    with StereoHeadSim(board=BOARD) as s:
        s.set_target(T_base_from_world_facing(BOARD, distance=1.0))
        yield s


@pytest.mark.slow
@pytest.mark.parametrize("base, field, strengths", [
    ({}, "full_well", [0.0, 2000.0, 300.0, 60.0]),               # fewer electrons: noisier
    ({}, "jpeg_quality", [0, 30, 5]),
    ({"full_well": 2000.0}, "motion_blur", [0.0, 8.0, 24.0]),
    ({"full_well": 2000.0, "focus_distance": 0.3}, "f_number", [16.0, 2.0, 1.0]),
    ({"full_well": 1000.0}, "vignetting", [0.0, 0.6, 0.9]),
])
def test_corner_error_grows_with_each_degradations_strength(sim, base, field, strengths):
    """Measured (docs/topics/degradations.md): each step raises the RMS by 8 % or more on
    these 6 views; the test asks for a strict rise at every step."""
    rms = [_corner_rms(sim, RenderOptions(seed=2, **base, **{field: s}).validate())
           for s in strengths]
    assert all(b > a for a, b in zip(rms, rms[1:], strict=False)), (field, rms)


def test_jpeg_at_quality_100_is_almost_no_jpeg(sim):
    from rasc.sim.render import view_image

    sim.set_angles("left", 0.0, 0.0)
    plain = view_image(sim, "left", {}, None, RenderOptions())
    q100 = view_image(sim, "left", {}, None, RenderOptions(jpeg_quality=100))
    diff = np.abs(q100.astype(int) - plain.astype(int))
    assert diff.max() <= 4 and diff.mean() < 0.5, (diff.max(), diff.mean())
    assert abs(_corner_rms(sim, RenderOptions(jpeg_quality=100))
               - _corner_rms(sim, RenderOptions())) < 0.003


def test_depth_buffer_is_the_boards_depth_and_defocus_follows_it(sim):
    """The depth the defocus uses is the board's true depth at its corners (MuJoCo's
    buffer against the truth); focused at the near edge of a board turned 40° about
    the vertical, the near half stays sharper than the far half, and focused at the far
    edge the other way round."""
    from rasc.geometry.transforms import invert_transform, make_transform, matrix_from_rotvec
    from rasc.sim.render import view_image

    eye = "left"
    sim.set_angles("left", 0.0, 0.0)
    T_base_from_cam = invert_transform(sim.T_cam_from_base(eye))
    R = matrix_from_rotvec([0.0, np.radians(40.0), 0.0])
    T_cw = make_transform(R, np.array([0.0, 0.0, 0.8]) - R @ BOARD.centre())
    saved = sim.T_base_from_world.copy()
    try:
        sim.set_target(T_base_from_cam @ T_cw)
        P = BOARD.object_points()
        z = (P @ T_cw[:3, :3].T + T_cw[:3, 3])[:, 2]
        uv = np.rint(sim.project_world_points(eye, P)).astype(int)
        depth = sim.render_depth(eye)
        # depth at the nearest pixel centre: the plane's slope over half a pixel (<1 mm)
        np.testing.assert_allclose(depth[uv[:, 1], uv[:, 0]], z, atol=2e-3)
        near, far = z.min(), z.max()
        near_cols = np.argsort(z)[: len(z) // 3]
        far_cols = np.argsort(z)[-len(z) // 3:]

        def sharpness(image, ids):
            g = np.abs(np.diff(image.astype(float), axis=1))
            return np.mean([g[v - 6:v + 6, u - 6:u + 6].max() for u, v in uv[ids]])

        at_near = view_image(sim, eye, {}, None, RenderOptions(
            focus_distance=float(near), f_number=1.4, focal_length_mm=8.0))
        at_far = view_image(sim, eye, {}, None, RenderOptions(
            focus_distance=float(far), f_number=1.4, focal_length_mm=8.0))
        assert sharpness(at_near, near_cols) > 1.3 * sharpness(at_near, far_cols)
        assert sharpness(at_far, far_cols) > 1.3 * sharpness(at_far, near_cols)
    finally:
        sim.set_target(saved)


# ------------------------------------------------------- off by default: nothing changes

def test_defaults_change_no_byte_no_truth_and_no_key(tmp_path):
    """At their defaults the degradations leave the image, the ground truth's
    render_options and the cache key those of before they existed."""
    from rasc.datasets.keys import cache_key
    from rasc.datasets.render import render_key, render_what

    # the plain render (supersample 1, the default before 2026-11-28): the key of before
    options = RenderOptions(seed=3, intrinsics_views=5, image_noise=2.0, blur=0.7,
                            supersample=1)
    before = asdict(options)
    for k in (*DEGRADATIONS, *CONTINUOUS, *LENS_FIELDS):   # fields added since, at defaults
        del before[k]
    before.pop("supersample")
    assert render_what(options)["options"] == render_what(before)["options"]
    assert set(render_what(options)["options"]) == set(before)
    assert render_key(options) == cache_key("render-folder", {"options": render_what(
        before)["options"], "model": None})
    for k, v in (("full_well", 500.0), ("vignetting", 0.2), ("jpeg_quality", 50),
                 ("focus_distance", 2.0), ("motion_blur", 3.0)):
        changed = RenderOptions(seed=3, intrinsics_views=5, image_noise=2.0, blur=0.7,
                                supersample=1, **{k: v})
        assert render_what(changed)["options"][k] == v
        assert render_key(changed) != render_key(options)


def test_default_view_is_the_image_of_before(sim):
    """view_image at the default degradations is the render blurred and noised as before
    (rasc.sim.degrade.degrade: blur, then noise from the same rng)."""
    from rasc.sim.render import view_image

    sim.set_angles("right", np.radians(3.0), 0.0)
    options = RenderOptions(image_noise=3.0, blur=0.8, seed=5)
    now = view_image(sim, "right", {}, np.random.default_rng(5), options)
    before = dg.degrade(sim.render_grey("right", supersample=options.supersample),
                        np.random.default_rng(5), blur_sigma=0.8, noise_sigma=3.0)
    np.testing.assert_array_equal(now, before)


# ------------------------------------------------------------------- every door refuses

@pytest.mark.parametrize("field, value, message", [
    ("full_well", -1.0, r"^full_well must be a number from 0 to 1e\+07"),
    ("full_well", 0.5, r"^full_well must be 0 \(no sensor noise\) or at least 1 electron"),
    ("read_noise", 5.0, r"^read_noise 5 electrons needs the sensor's full_well"),
    ("vignetting", 1.0, r"^vignetting must be a number from 0 to 0.95"),
    ("motion_blur", 51.0, r"^motion_blur must be a number from 0 to 50"),
    ("motion_angle", float("inf"), r"^motion_angle"),
    ("focus_distance", -2.0, r"^focus_distance must be a number from 0 to 1000"),
    ("f_number", 0.1, r"^f_number must be a number from 0.5 to 64"),
    ("focal_length_mm", 0.0, r"^focal_length_mm must be a positive number"),
    ("focus_distance", 0.005, r"^focus_distance 0.005 m must be beyond the focal length"),
    ("jpeg_quality", 101, r"^jpeg_quality must be an integer from 1 to 100 \(0: no JPEG\)"),
    ("jpeg_quality", 50.0, r"^jpeg_quality must be an integer"),
])
def test_bad_degradation_is_one_line_naming_the_field(field, value, message):
    with pytest.raises(InputError, match=message) as info:
        RenderOptions(**{field: value}).validate()
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("args, line", [
    (["--full-well", "-5"], "--full-well must be a number from 0 to 1e+07 (electrons at "
                            "grey level 255; 0 = none), got -5"),
    (["--read-noise", "3"], "--read-noise 3 electrons needs the sensor's --full-well "
                            "(electrons at grey level 255) to convert electrons to grey "
                            "levels"),
    (["--vignetting", "2"], "--vignetting must be a number from 0 to 0.95 (fraction of "
                            "light lost at the corners), got 2"),
    (["--motion-blur", "60"], "--motion-blur must be a number from 0 to 50 (pixels), got 60"),
    (["--f-number", "100"], "--f-number must be a number from 0.5 to 64 (f-number), got 100"),
    (["--jpeg-quality", "101"], "--jpeg-quality must be an integer from 1 to 100 (0: no "
                                "JPEG), got 101"),
])
def test_rasc_render_refuses_a_bad_degradation_writing_nothing(tmp_path, capsys, args, line):
    out = tmp_path / "ds"
    status, stdout, err = run_rasc(["render", "--out", out, *args, "--quiet"], capsys)
    assert status == 2 and stdout == ""
    assert err.strip().splitlines() == [f"rasc render: error: {line}"]
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_study_parameters_are_checked_and_their_defaults_keep_the_cells(tmp_path):
    from rasc.study import load_spec

    head = "seed = 5\nsamples = 2\nmethods = ['rasc']\n"
    base, same, swept = (tmp_path / f"{n}.toml" for n in "abc")
    base.write_text(head + "[axes]\nnoise_level = [1, 2]\n")
    same.write_text(head + "[fixed]\nfull_well = 0\njpeg_quality = 0\nf_number = 2.8\n"
                    "[axes]\nnoise_level = [1, 2]\n")
    swept.write_text(head + "[fixed]\nfull_well = 5000\n"
                     "[axes]\nnoise_level = [1, 2]\njpeg_quality = [0, 90, 30]\n")
    a, b, c = (load_spec(p) for p in (base, same, swept))
    assert [x.key for x in b.cells()] == [x.key for x in a.cells()]
    assert [x.seed_words for x in b.cells()] == [x.seed_words for x in a.cells()]
    assert len(c.cells()) == 6
    assert sorted({x.render_value("jpeg_quality") for x in c.cells()}) == [0, 30, 90]
    bad = tmp_path / "bad.toml"
    bad.write_text(head + "[fixed]\nvignetting = 1.5\n")
    with pytest.raises(InputError, match=r"bad.toml: fixed.vignetting: expected a number "
                                         r"from 0 to 0.95"):
        load_spec(bad)


def test_rasc_testing_renders_with_a_degradation():
    """rasc.testing's render (the rasc_dataset fixture's) takes the fields as they are;
    the ground truth records the one not at its default, the key differs."""
    from rasc.testing import render_cached

    common = dict(intrinsics_views=3, poses_deg=((0, 0), (8, 0), (0, 8)), seed=4)
    plain = render_cached(None, **common)
    ds = render_cached(None, **common, vignetting=0.3)
    assert ds.truth["render_options"]["vignetting"] == 0.3
    assert "vignetting" not in plain.truth["render_options"] and ds.key != plain.key
    entry = ds.select("left", "pose")[0]
    # the same view, each lit pixel darker by 0.3 (r / r_corner)^2
    img, ref = ds.read(entry).astype(float), plain.read(plain.select("left", "pose")[0])
    h, w = img.shape
    v, u = np.mgrid[0:h, 0:w]
    r2 = ((u - (w - 1) / 2) ** 2 + (v - (h - 1) / 2) ** 2) / (((w - 1) / 2) ** 2
                                                             + ((h - 1) / 2) ** 2)
    lit = ref > 100
    slope, one = np.polyfit(r2[lit], img[lit] / ref[lit], 1)
    assert abs(slope + 0.3) < 0.02 and abs(one - 1) < 0.01, (slope, one)


def test_scene_record_carries_the_degradations_to_re_rendered_pose_views():
    """intrinsics_from = "dataset" re-renders pose views in a dataset's scene: its record
    holds the degradations the dataset was rendered with, and only those."""
    from rasc.datasets.calibration import _scene_record

    view = {"T_base_from_world": np.eye(4).tolist()}
    base = {"seed": 1, "target_distance": 1.0, "noise_sigma": 0.0, "blur_sigma": 0.0,
            "dist": [0.0] * 5}
    truth = {"render_options": base, "views": {"poses/left_00.png": view},
             **{eye: {"unit_as_built": {}} for eye in ("left", "right")}}
    plain = _scene_record(truth, ["poses/left_00.png"])["render_options"]
    assert plain == base
    truth["render_options"] = {**base, "full_well": 4000.0, "jpeg_quality": 50}
    record = _scene_record(truth, ["poses/left_00.png"])["render_options"]
    assert record == {**base, "full_well": 4000.0, "jpeg_quality": 50}
