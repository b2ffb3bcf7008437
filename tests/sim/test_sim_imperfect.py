"""Imperfect pan-tilt units in the simulation (rasc.sim.units, rasc.sim.scene, rasc render).

The truth is chosen here (a tilt axis 30 mm off the pan axis, 1° non-orthogonality, encoder
offsets and scales, a moved camera), the model is built from it, and the ground truth the
simulator reports is compared with MuJoCo's own camera frames and with what the chosen
numbers imply. Tolerances: GROUND_TRUTH_TOL (1e-9, rasc.sim.scene) for poses, as the
renderer itself checks; 1e-12 for parameters recovered from float64 model data (the
MJCF's numbers pass through MuJoCo's float64 compiler unchanged up to round-off).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import json
from pathlib import Path

import numpy as np
import pytest

from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import IDEAL, PanTiltUnit
from rasc.geometry.transforms import invert_transform
from rasc.sim.render import RenderOptions, render_dataset
from rasc.sim.scene import GROUND_TRUTH_TOL, HEAD_XML, StereoHeadSim, import_mujoco, scene_xml
from rasc.sim.units import UnitBuild, read_unit_file
from rasc.vision.board import DEFAULT_BOARD

from running import run_rasc

SMALL = RenderOptions(poses_deg=((0.0, 0.0), (8.0, 8.0), (-8.0, -6.0)), intrinsics_views=3)
SKEW_DEG = 1.0
IMPERFECT = UnitBuild(tilt_axis_offset_mm=(4.0, 30.0, -7.0), axis_skew_deg=SKEW_DEG,
                      pan_zero_deg=0.5, tilt_zero_deg=-0.5, pan_scale=1.003, tilt_scale=0.996)


run_cli = run_rasc                 # rasc ARGV in this process: (status, stdout, stderr)


def files_of(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file()}


def random_readings(rng, n):
    return zip(rng.uniform(-0.7, 0.7, n), rng.uniform(-0.5, 0.3, n), strict=True)


def check_chain_against_mujoco(sim, eye, rng, n=20):
    """Truth chain vs MuJoCo's camera frame at random readings (independent of the sim's
    own check: the expected pose is rebuilt here from the public ground truth)."""
    unit, T_cg, T_pb = sim.unit(eye), sim.T_cam_from_gaze(eye), sim.T_ptu_from_base(eye)
    worst = 0.0
    for pan, tilt in random_readings(rng, n):
        sim.set_angles(eye, pan, tilt)
        sim.forward()
        cam = sim.data.camera(f"{eye}_camera")
        R = np.diag([1.0, -1.0, -1.0]) @ cam.xmat.reshape(3, 3).T
        T_cam_from_scene = np.eye(4)
        T_cam_from_scene[:3, :3], T_cam_from_scene[:3, 3] = R, -R @ cam.xpos
        expected = T_cam_from_scene @ sim.T_scene_from_base
        worst = max(worst, float(np.abs(T_cg @ unit.T_gaze_from_ptu(pan, tilt) @ T_pb
                                        - expected).max()))
        assert sim.check_ground_truth(eye) <= GROUND_TRUTH_TOL
    sim.set_angles(eye, 0.0, 0.0)
    return worst


# -- the simulator -----------------------------------------------------------------------------

def test_ideal_build_is_the_stock_unit():
    with StereoHeadSim() as sim:
        for eye in EYES:
            assert sim.unit(eye) == IDEAL
            assert check_chain_against_mujoco(sim, eye, np.random.default_rng(1)) < 1e-12


def test_imperfect_unit_is_read_into_the_general_model():
    with StereoHeadSim(units={"left": IMPERFECT}) as sim:
        unit = sim.unit("left")
        # only the y component of the offset lies on the common normal of x and the
        # skewed tilt axis (sin δ, 0, cos δ): the observable distance is 30 mm
        assert unit.axis_distance == pytest.approx(0.030, abs=1e-12)
        assert unit.axis_angle_deg == pytest.approx(90.0 - SKEW_DEG, abs=1e-9)
        assert (unit.pan_scale, unit.tilt_scale) == (1.003, 0.996)
        as_built = sim.unit_as_built("left")[0]
        assert as_built.pan_offset == pytest.approx(np.radians(0.5), abs=1e-15)
        assert as_built.tilt_offset == pytest.approx(np.radians(-0.5), abs=1e-15)
        np.testing.assert_allclose(as_built.tilt_point, [0.004, 0.030, -0.007], atol=1e-15)
        assert sim.unit("right") == IDEAL
        assert check_chain_against_mujoco(sim, "left", np.random.default_rng(2)) < 1e-12
        assert check_chain_against_mujoco(sim, "right", np.random.default_rng(3)) < 1e-12


def test_encoder_model_turns_the_joints():
    with StereoHeadSim(units={"right": IMPERFECT}) as sim:
        sim.set_angles("right", 0.1, -0.2)
        assert sim.angles("right") == (0.1, -0.2)                    # the readings
        phi, tau = sim.joint_angles("right")
        assert phi == pytest.approx(1.003 * 0.1 + np.radians(0.5), abs=1e-15)
        assert tau == pytest.approx(0.996 * -0.2 - np.radians(0.5), abs=1e-15)
        # the range applies to the joint angle, and the error says both
        with pytest.raises(InputError, match=r"right pan = 59\.9 deg \(joint angle 60\.5.* is "
                                             r"outside the joint range"):
            sim.set_angles("right", np.radians(59.9), 0.0)


def test_camera_placement_on_the_tilt_link():
    build = UnitBuild(camera_position_mm=(60.0, 20.0, -10.0), camera_euler_deg=(0.0, 0.0, 0.0))
    with StereoHeadSim() as ref, StereoHeadSim(units={"left": build}) as sim:
        T_gaze_from_cam = invert_transform(sim.T_cam_from_gaze("left"))
        np.testing.assert_allclose(T_gaze_from_cam[:3, 3], [0.060, 0.020, -0.010], atol=1e-15)
        # no misalignment: OpenCV z = gaze +y, x = gaze −z, y = gaze −x (models/README.md)
        np.testing.assert_allclose(T_gaze_from_cam[:3, :3],
                                   [[0, -1, 0], [0, 0, 1], [-1, 0, 0]], atol=1e-15)
        np.testing.assert_array_equal(sim.T_cam_from_gaze("right"), ref.T_cam_from_gaze("right"))
        assert check_chain_against_mujoco(sim, "left", np.random.default_rng(4)) < 1e-12


def _head_variant(tmp_path: Path, old: str, new: str) -> Path:
    text = HEAD_XML.read_text()
    assert text.count(old) == 1
    head = tmp_path / "head.xml"
    head.write_text(text.replace(old, new))
    scene = tmp_path / "scene.xml"
    scene.write_text(scene_xml(DEFAULT_BOARD, head.name))
    return scene


def test_user_model_with_a_moved_tilt_joint(tmp_path):
    # The model: the tilt JOINT 30 mm along the link, frames still equal at home.
    scene = _head_variant(tmp_path, '<joint class="tilt" name="left_tilt_joint"/>',
                          '<joint class="tilt" name="left_tilt_joint" pos="0 0.03 0"/>')
    with StereoHeadSim(scene) as sim, \
            StereoHeadSim(units={"left": UnitBuild(tilt_axis_offset_mm=(0, 30, 0))}) as built:
        assert sim.unit("left") == built.unit("left")
        assert sim.unit("left").axis_distance == pytest.approx(0.03, abs=1e-15)
        np.testing.assert_allclose(sim.T_cam_from_gaze("left"), built.T_cam_from_gaze("left"),
                                   atol=1e-15)
        assert check_chain_against_mujoco(sim, "left", np.random.default_rng(5)) < 1e-12


def test_user_model_with_a_moved_tilt_body(tmp_path):
    # The tilt BODY 15 mm forward: at home the tilt link is no longer the ptu frame, and
    # the tilt axis (through the body origin) misses the pan axis by 15 mm.
    scene = _head_variant(tmp_path, '<body name="left_tilt_link">',
                          '<body name="left_tilt_link" pos="0 0.015 0">')
    with StereoHeadSim(scene) as sim, StereoHeadSim() as stock:
        assert sim.unit("left").axis_distance == pytest.approx(0.015, abs=1e-15)
        # the camera moved with the body: 15 mm further forward in the gaze (= ptu) frame
        shift = (invert_transform(sim.T_cam_from_gaze("left"))[:3, 3]
                 - invert_transform(stock.T_cam_from_gaze("left"))[:3, 3])
        np.testing.assert_allclose(shift, [0, 0.015, 0], atol=1e-15)
        assert check_chain_against_mujoco(sim, "left", np.random.default_rng(6)) < 1e-12


def test_user_model_with_a_moved_and_turned_pan_joint(tmp_path):
    # pan axis through a = (20, 10, −5) mm along p ∝ (1, 0.02, 0.01); tilt axis the stock
    # one through the ptu origin along z: distance |a · (p × z)| / |p × z|, angle acos(p·z)
    scene = _head_variant(tmp_path, '<joint class="pan" name="left_pan_joint"/>',
                          '<joint class="pan" name="left_pan_joint" pos="0.02 0.01 -0.005" '
                          'axis="1 0.02 0.01"/>')
    a, p, z = np.array([0.02, 0.01, -0.005]), np.array([1, 0.02, 0.01]), np.array([0, 0, 1.0])
    p = p / np.linalg.norm(p)
    n = np.cross(p, z)
    with StereoHeadSim(scene) as sim:
        unit = sim.unit("left")
        assert unit.axis_distance == pytest.approx(abs(a @ n) / np.linalg.norm(n), abs=1e-15)
        assert unit.axis_angle_deg == pytest.approx(np.degrees(np.arccos(p @ z)), abs=1e-12)
        assert check_chain_against_mujoco(sim, "left", np.random.default_rng(8)) < 1e-12


def test_user_model_with_a_joint_reference_angle(tmp_path):
    # MuJoCo turns a hinge by qpos − ref: the body pose as written is the joint's zero
    scene = _head_variant(tmp_path, '<joint class="pan" name="left_pan_joint"/>',
                          '<joint class="pan" name="left_pan_joint" ref="10"/>')
    with StereoHeadSim(scene) as sim, StereoHeadSim() as stock:
        assert sim.unit("left") == IDEAL
        np.testing.assert_array_equal(sim.T_cam_from_gaze("left"), stock.T_cam_from_gaze("left"))
        assert check_chain_against_mujoco(sim, "left", np.random.default_rng(7)) < 1e-12
        sim.set_angles("left", 0.3, 0.0)
        assert sim.joint_angles("left")[0] == pytest.approx(0.3, abs=1e-15)


def test_truth_that_disagrees_is_never_written(tmp_path, capsys, monkeypatch):
    """Yesterday's truth for the moved tilt body (the camera in the tilt body's frame, eq. 3
    about the ptu origin: 15 mm off at home) must be refused: one line, exit 2, nothing."""
    scene = _head_variant(tmp_path, '<body name="left_tilt_link">',
                          '<body name="left_tilt_link" pos="0 0.015 0">')
    original = StereoHeadSim._read_constants

    def old_style(self):
        original(self)
        mujoco = import_mujoco()
        d = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, d)
        b, cam = d.body("left_tilt_link"), d.camera("left_camera")
        T_scene_from_tilt = np.eye(4)
        T_scene_from_tilt[:3, :3], T_scene_from_tilt[:3, 3] = b.xmat.reshape(3, 3), b.xpos
        R = np.diag([1.0, -1.0, -1.0]) @ cam.xmat.reshape(3, 3).T
        T_cam_from_scene = np.eye(4)
        T_cam_from_scene[:3, :3], T_cam_from_scene[:3, 3] = R, -R @ cam.xpos
        self._T_cam_from_gaze["left"] = T_cam_from_scene @ T_scene_from_tilt
        self._unit["left"] = IDEAL

    monkeypatch.setattr(StereoHeadSim, "_read_constants", old_style)
    out = tmp_path / "ds"
    code, stdout, err = run_cli(["render", "--model", scene, "--out", out, "--quiet",
                                 "--intrinsics-views", 3, "--poses", "0,0;8,8;-8,-8"], capsys)
    assert code == 2 and stdout == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("rasc render: error: scene.xml: the left ground truth disagrees "
                               "with MuJoCo's left_camera frame at home (the intrinsics views)")
    assert " 15 mm" in lines[0], lines[0]
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["head.xml", "scene.xml"]


# -- rendering ---------------------------------------------------------------------------------

@pytest.mark.slow
def test_default_render_is_unchanged_by_the_unit_machinery(tmp_path):
    """Every geometric key set to the stock model's own values forces the MjSpec path; the
    images and manifest must be byte-identical to the untouched model's, the truth equal."""
    stock = {"left": UnitBuild(tilt_axis_offset_mm=(0, 0, 0), axis_skew_deg=0.0,
                               camera_position_mm=(48, 36, 21), camera_euler_deg=(1.3, -2.1, 0.8)),
             "right": UnitBuild(tilt_axis_offset_mm=(0, 0, 0), axis_skew_deg=0.0,
                                camera_position_mm=(52, 31, -18),
                                camera_euler_deg=(-0.9, 1.2, -0.6))}
    render_dataset(tmp_path / "a", SMALL, quiet=True)
    render_dataset(tmp_path / "b", SMALL, quiet=True, units=stock)
    a, b = files_of(tmp_path / "a"), files_of(tmp_path / "b")
    assert a.keys() == b.keys()
    for name in a:
        if name != "ground_truth.json":
            assert a[name] == b[name], name
    ga, gb = (json.loads(x["ground_truth.json"]) for x in (a, b))
    for eye in EYES:
        for key in ("T_cam_from_gaze", "T_ptu_from_base", "unit", "K"):
            np.testing.assert_allclose(ga[eye][key] if key != "unit" else
                                       PanTiltUnit.from_dict(ga[eye][key]).T_gaze_from_ptu(.1, .2),
                                       gb[eye][key] if key != "unit" else
                                       PanTiltUnit.from_dict(gb[eye][key]).T_gaze_from_ptu(.1, .2),
                                       rtol=0, atol=1e-15)


def assert_views_match_truth(manifest: Path) -> dict:
    """Every pose view's T_cam_from_world (MuJoCo's, as rendered) equals the ground truth's
    chain at the manifest's readings; returns the ground truth."""
    gt = json.loads((manifest.parent / "ground_truth.json").read_text())
    images = json.loads(manifest.read_text())["images"]
    poses = [im for im in images if im["role"] == "pose"]
    # the manifest records the commanded readings
    assert [(im["pan"], im["tilt"]) for im in poses[::2]] == list(SMALL.poses_deg)
    for eye in EYES:
        unit = PanTiltUnit.from_dict(gt[eye]["unit"], where=f"{eye}.unit")
        T_cg, T_pb = np.array(gt[eye]["T_cam_from_gaze"]), np.array(gt[eye]["T_ptu_from_base"])
        for im in (im for im in poses if im["eye"] == eye):
            view = gt["views"][im["file"]]
            T = T_cg @ unit.T_gaze_from_ptu(np.radians(im["pan"]), np.radians(im["tilt"])) @ T_pb
            np.testing.assert_allclose(T @ np.array(view["T_base_from_world"]),
                                       view["T_cam_from_world"], rtol=0, atol=GROUND_TRUTH_TOL)
    return gt


def test_moved_tilt_joint_model_renders_with_correct_truth(tmp_path):
    scene = _head_variant(tmp_path, '<joint class="tilt" name="right_tilt_joint"/>',
                          '<joint class="tilt" name="right_tilt_joint" pos="0 0.03 0"/>')
    gt = assert_views_match_truth(render_dataset(tmp_path / "ds", SMALL, quiet=True,
                                                 model_path=scene))
    assert PanTiltUnit.from_dict(gt["right"]["unit"]).axis_distance == pytest.approx(0.03)
    assert PanTiltUnit.from_dict(gt["left"]["unit"]) == IDEAL


def test_imperfect_render_ground_truth_matches_every_view(tmp_path):
    units = {"left": IMPERFECT, "right": UnitBuild(tilt_axis_offset_mm=(0, -15, 0),
                                                   axis_skew_deg=-0.5, pan_zero_deg=-0.3)}
    gt = assert_views_match_truth(render_dataset(tmp_path / "ds", SMALL, quiet=True,
                                                 units=units))
    assert PanTiltUnit.from_dict(gt["right"]["unit"]).axis_distance == pytest.approx(0.015)
    assert gt["left"]["unit_as_built"]["build"] == IMPERFECT.to_dict()
    assert gt["right"]["unit_as_built"]["build"] == units["right"].to_dict()


# -- the parameter file and options ------------------------------------------------------------

#: the parameter file of docs/guide/calibrate.md ("Imperfect units")
GUIDE_UNIT_FILE = """\
[both]
tilt_axis_offset_mm = [0, 30, 0]
axis_skew_deg = 1.0

[left]
pan_zero_deg = 0.5
tilt_zero_deg = -0.5
pan_scale = 1.002
tilt_scale = 0.998
camera_position_mm = [48, 36, 21]
camera_euler_deg = [1.3, -2.1, 0.8]
"""


def test_unit_file_both_then_each_eye(tmp_path):
    """[both] for both eyes, then each eye's table over it (the guide's file, and a
    [right] table that overrides [both]'s skew)."""
    path = tmp_path / "unit.toml"
    path.write_text(GUIDE_UNIT_FILE + "[right]\naxis_skew_deg = -1\n")
    units = read_unit_file(path)
    assert units["left"] == UnitBuild(tilt_axis_offset_mm=(0, 30, 0), axis_skew_deg=1.0,
                                      pan_zero_deg=0.5, tilt_zero_deg=-0.5, pan_scale=1.002,
                                      tilt_scale=0.998, camera_position_mm=(48, 36, 21),
                                      camera_euler_deg=(1.3, -2.1, 0.8))
    assert units["right"] == UnitBuild(tilt_axis_offset_mm=(0, 30, 0), axis_skew_deg=-1.0)


@pytest.mark.parametrize("text, message", [
    ("[left]\ntilt_ofset_mm = [0, 1, 0]\n", r"unit.toml: left.tilt_ofset_mm: unknown key"),
    ("[centre]\npan_scale = 1\n", r"unit.toml: centre: unknown table"),
    ("pan_scale = 1\n", r"unit.toml: pan_scale: unknown table or key"),
    ("[both]\npan_scale = '1'\n", r'unit.toml: both.pan_scale: expected a number, got "1"'),
    ("[right]\npan_scale = 0\n", r"unit.toml: right.pan_scale: must be positive"),
    ("[left]\ntilt_zero_deg = nan\n", r"unit.toml: left.tilt_zero_deg: must be finite"),
    ("[left]\ncamera_position_mm = [1, inf, 0]\n",
     r"unit.toml: left.camera_position_mm\[1\]: must be finite"),
    ("[left]\ncamera_euler_deg = [1, 2]\n", r"unit.toml: left.camera_euler_deg: expected 3"),
    ("[both]\naxis_skew_deg = 90\n", r"unit.toml: both.axis_skew_deg: must be within"),
    ("[left\n", r"unit.toml: not valid TOML"),
    ("[left]\npan_scale = true\n", r"unit.toml: left.pan_scale: expected a number, got true"),
])
def test_unit_file_errors_are_one_line(tmp_path, text, message):
    path = tmp_path / "unit.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as info:
        read_unit_file(path)
    assert "\n" not in str(info.value)


@pytest.mark.slow
def test_cli_options_equal_the_file(tmp_path, capsys):
    common = ["--quiet", "--intrinsics-views", 3, "--poses", "0,0;8,8;-8,-8"]
    path = tmp_path / "unit.toml"
    path.write_text("[both]\ntilt_axis_offset_mm = [0, 30, 0]\naxis_skew_deg = 1.0\n"
                    "pan_zero_deg = 0.5\ntilt_zero_deg = 0.5\n")
    code, _, err = run_cli(["render", "--out", tmp_path / "a", "--unit", path, *common], capsys)
    assert code == 0, err
    code, _, err = run_cli(["render", "--out", tmp_path / "b", "--tilt-axis-offset", "0,30,0",
                            "--axis-skew", 1, "--encoder-zero", "0.5,0.5", *common], capsys)
    assert code == 0, err
    assert files_of(tmp_path / "a") == files_of(tmp_path / "b")
    # without --quiet: one line per imperfect unit says what was built
    code, _, err = run_cli(["render", "--out", tmp_path / "d", "--axis-skew", 1,
                            "--tilt-axis-offset", "0,30,0", *common[1:]], capsys)
    assert code == 0, err
    for eye in EYES:
        assert (f"render: {eye} unit: tilt axis 30 mm from the pan axis, 89.0000 deg between "
                f"the axes, encoder zeros +0/+0 deg and scales 1/1 (pan/tilt)") in err
    for argv, message in ((["--tilt-axis-offset", "0,30"],
                           "--tilt-axis-offset: expected 3 numbers (X,Y,Z in millimetres)"),
                          (["--encoder-zero", "nan,0"], '--encoder-zero[0]: must be finite'),
                          (["--axis-skew", 90], "--axis-skew: expected a finite angle"),
                          (["--unit", tmp_path / "missing.toml"], "missing.toml: unit parameter "
                                                                   "file not found")):
        code, out, err = run_cli(["render", "--out", tmp_path / "c", *argv, *common], capsys)
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, err
        assert message in err
        assert not (tmp_path / "c").exists()


def test_unit_file_example(tmp_path, capsys, monkeypatch):
    """The guide's parameter file and command: both units built as the file says."""
    toml = GUIDE_UNIT_FILE
    argv = ["render", "--unit", "unit.toml", "--out", "real_head", "--intrinsics-views", "3",
            "--poses", "0,0;8,8;-8,-8"]
    (tmp_path / "unit.toml").write_text(toml)
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(argv + ["--quiet"], capsys)
    assert code == 0 and out == "" and err == "", err
    gt = json.loads((tmp_path / "real_head" / "ground_truth.json").read_text())
    for eye in EYES:   # [both]: 30 mm along y (the common normal), 1° skew
        unit = PanTiltUnit.from_dict(gt[eye]["unit"])
        assert unit.axis_distance == pytest.approx(0.030, abs=1e-12)
        assert unit.axis_angle_deg == pytest.approx(89.0, abs=1e-9)
    left = read_unit_file(tmp_path / "unit.toml")["left"]
    assert (left.pan_zero_deg, left.tilt_zero_deg, left.pan_scale) == (0.5, -0.5, 1.002)
    assert gt["left"]["unit_as_built"]["build"] == left.to_dict()
    assert PanTiltUnit.from_dict(gt["left"]["unit"]).tilt_scale == 0.998
