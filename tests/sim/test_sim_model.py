"""The MuJoCo stereo head (sim/models) and rasc.sim.scene's ground truth, without rendering.

The truth chosen here is the model file itself: these tests read its attributes
independently (xml.etree) or recompute them from the paper's formulas (eq. 3, the
cyclopean base of docs/CONTRACTS.md) and compare with what rasc.sim.scene reads from the
compiled model.
"""

import json
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from rasc.errors import InputError
from rasc.geometry.kinematics import T_gaze_from_ptu
from rasc.geometry.transforms import (
    invert_transform,
    make_transform,
    matrix_from_rotvec,
    rotation_angle,
    rotvec_from_matrix,
)
from rasc.sim.scene import (
    DEFAULT_BOARD,
    HEAD_XML,
    MODELS_DIR,
    SCENE_XML,
    Board,
    StereoHeadSim,
    T_base_from_world_facing,
    import_mujoco,
    scene_xml,
)

EYES = ("left", "right")
#: Model transforms are composed in float64 from float64 body poses: 1e-9 is ~1e6 ulps of
#: headroom and still ~1e-7 of the smallest quantity compared (a 1 mm offset, a 1° angle).
TOL = 1e-9
DENSE_BOARD = Board((30, 29), 1.0 / 32)  # ~1 m x 1 m, 870 corners (triangulation tests)


@pytest.fixture(scope="module")
def sim():
    with StereoHeadSim() as s:
        yield s


@pytest.fixture
def mujoco_messages():
    """Collect MuJoCo's warnings: the user-warning callback and Python warnings."""
    mujoco = import_mujoco()
    messages = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield messages, caught
    finally:
        mujoco.set_mju_user_warning(previous)


def _run_and_collect_warnings(model):
    """mj_forward, then 200 steps from a non-home pose; MuJoCo's runtime warning counters."""
    mujoco = import_mujoco()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    counts = [int(w.number) for w in data.warning]
    data.qpos[:] = np.clip(0.3, model.jnt_range[:, 0], model.jnt_range[:, 1])
    for _ in range(200):
        mujoco.mj_step(model, data)
    return counts, [int(w.number) for w in data.warning]


# -- compilation ---------------------------------------------------------------------------

def test_warning_capture_itself_works(mujoco_messages):
    # Guard for the next test: a model with a deprecated attribute must be reported.
    messages, caught = mujoco_messages
    import_mujoco().MjModel.from_xml_string(
        '<mujoco><statistic meaninertia="1"/><worldbody/></mujoco>')
    assert messages or caught


@pytest.mark.parametrize("source", sorted(p.name for p in MODELS_DIR.glob("*.xml"))
                         + ["generated:default", "generated:dense"])
def test_every_scene_compiles_without_warnings(source, mujoco_messages):
    messages, caught = mujoco_messages
    mujoco = import_mujoco()
    if source == "generated:default":
        model = mujoco.MjModel.from_xml_string(scene_xml(DEFAULT_BOARD))
    elif source == "generated:dense":
        model = mujoco.MjModel.from_xml_string(scene_xml(DENSE_BOARD))
    else:
        model = mujoco.MjModel.from_xml_path(str(MODELS_DIR / source))
    after_forward, after_steps = _run_and_collect_warnings(model)
    assert messages == [] and [str(w.message) for w in caught] == []
    assert after_forward == [0] * len(after_forward)
    assert after_steps == [0] * len(after_steps)


def test_static_scene_is_the_default_board():
    # scene.xml is what scene_xml(DEFAULT_BOARD) generates: same geometry, numerics, texture.
    mujoco = import_mujoco()
    static = mujoco.MjModel.from_xml_path(str(SCENE_XML))
    generated = mujoco.MjModel.from_xml_string(scene_xml(DEFAULT_BOARD))
    for name in ("board_pattern", "board_quiet_zone"):
        np.testing.assert_array_equal(static.geom(name).size, generated.geom(name).size)
        np.testing.assert_array_equal(static.geom(name).pos, generated.geom(name).pos)
    np.testing.assert_array_equal(static.mat_texrepeat, generated.mat_texrepeat)
    for name in ("rasc_board_inner_corners", "rasc_board_square_size"):
        np.testing.assert_array_equal(static.numeric(name).data, generated.numeric(name).data)
    assert static.nbody == generated.nbody and static.ncam == generated.ncam
    # and it is literally the generator's output (regenerate it: sim/models/README.md)
    assert SCENE_XML.read_text() == scene_xml(head_path="stereo_head.xml", generated=False)


# -- kinematics ----------------------------------------------------------------------------

def _body_pose(sim, name):
    b = sim.data.body(name)
    return make_transform(b.xmat.reshape(3, 3), b.xpos)


def _random_angles(sim, eye, rng, n):
    (p0, p1), (t0, t1) = sim.joint_range(eye)
    pans = np.concatenate([[0.0, p0, p1, 0.0], rng.uniform(p0, p1, n)])
    tilts = np.concatenate([[0.0, t0, t1, 1e-9], rng.uniform(t0, t1, n)])
    return zip(pans, tilts, strict=True)


@pytest.mark.parametrize("eye", EYES)
def test_gaze_frame_follows_eq3(sim, eye):
    # The tilt body's frame relative to the ptu frame is eq. 3, and joint axes meet at
    # the unit's centre, for home, the range limits, a tiny tilt and random angles.
    rng = np.random.default_rng(3)
    for pan, tilt in _random_angles(sim, eye, rng, 40):
        sim.set_angles(eye, pan, tilt)
        sim.forward()
        T_scene_from_ptu = _body_pose(sim, f"{eye}_ptu_link")
        T_scene_from_gaze = _body_pose(sim, f"{eye}_tilt_link")
        T_gaze_from_ptu_model = invert_transform(T_scene_from_gaze) @ T_scene_from_ptu
        np.testing.assert_allclose(T_gaze_from_ptu_model, T_gaze_from_ptu(pan, tilt), atol=TOL)
        for joint in ("pan", "tilt"):
            anchor = sim.data.joint(f"{eye}_{joint}_joint").xanchor
            np.testing.assert_allclose(anchor, T_scene_from_ptu[:3, 3], atol=TOL)
        # pan about the fixed ptu x axis; tilt about the panned −z axis
        pan_axis = sim.data.joint(f"{eye}_pan_joint").xaxis
        tilt_axis = sim.data.joint(f"{eye}_tilt_joint").xaxis
        np.testing.assert_allclose(pan_axis, T_scene_from_ptu[:3, 0], atol=TOL)
        panned_z = T_scene_from_ptu[:3, :3] @ np.array([0.0, -np.sin(pan), np.cos(pan)])
        np.testing.assert_allclose(tilt_axis, -panned_z, atol=TOL)
    sim.set_angles(eye, 0.0, 0.0)


def _T_cam_from_scene_test(xpos, xmat):
    # Written here independently of rasc.sim.scene: MuJoCo camera axes → OpenCV (docs/NOTES.md).
    R = np.diag([1.0, -1.0, -1.0]) @ np.asarray(xmat).reshape(3, 3).T
    return make_transform(R, -R @ np.asarray(xpos))


@pytest.mark.parametrize("eye", EYES)
def test_chain_reproduces_rendered_camera_pose(sim, eye):
    # Eq. 1–2 with the ground truth read at home and eq. 3 from rasc.geometry.kinematics equals the
    # camera pose MuJoCo renders from (data.cam_xpos/xmat), at random angles of both eyes.
    rng = np.random.default_rng(4)
    other = "right" if eye == "left" else "left"
    sim.set_angles(other, 0.2, -0.1)  # the other eye must not matter
    sim.forward()   # body poses are read from data: a fresh sim has not computed them yet
    T_scene_from_base = _body_pose(sim, "base_link")
    for pan, tilt in _random_angles(sim, eye, rng, 25):
        sim.set_angles(eye, pan, tilt)
        sim.forward()
        cam = sim.data.camera(f"{eye}_camera")
        expected = _T_cam_from_scene_test(cam.xpos, cam.xmat) @ T_scene_from_base
        chain = sim.T_cam_from_gaze(eye) @ T_gaze_from_ptu(pan, tilt) @ sim.T_ptu_from_base(eye)
        np.testing.assert_allclose(chain, expected, atol=TOL)
        np.testing.assert_allclose(sim.T_cam_from_base(eye), expected, atol=TOL)
    sim.set_angles(eye, 0.0, 0.0)
    sim.set_angles(other, 0.0, 0.0)   # leave the module's sim at home for the next test
    sim.set_angles(other, 0.0, 0.0)


def test_home_keyframe_is_pan_tilt_zero(sim):
    mujoco = import_mujoco()
    key = mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_KEY, "home")
    assert key >= 0
    np.testing.assert_array_equal(sim.model.key_qpos[key], np.zeros(sim.model.nq))
    data = mujoco.MjData(sim.model)
    mujoco.mj_resetDataKeyframe(sim.model, data, key)
    mujoco.mj_forward(sim.model, data)
    for eye in EYES:  # gaze = ptu at home
        np.testing.assert_allclose(data.body(f"{eye}_tilt_link").xmat,
                                   data.body(f"{eye}_ptu_link").xmat, atol=TOL)


def test_joint_ranges_like_a_real_unit(sim):
    for eye in EYES:   # at home whatever ran before on the module's sim
        sim.set_angles(eye, 0.0, 0.0)
    for eye in EYES:
        (p0, p1), (t0, t1) = sim.joint_range(eye)
        np.testing.assert_allclose(np.degrees([p0, p1, t0, t1]), [-60, 60, -45, 30], atol=1e-9)
        with pytest.raises(InputError, match=f"{eye} pan = 61 deg is outside"):
            sim.set_angles(eye, np.radians(61), 0.0)
        with pytest.raises(InputError, match=f"{eye} tilt = -46 deg is outside"):
            sim.set_angles(eye, 0.0, np.radians(-46))
        with pytest.raises(InputError, match="tilt"):
            sim.set_angles(eye, 0.0, np.nan)
        assert sim.angles(eye) == (0.0, 0.0)


# -- the head's geometry -------------------------------------------------------------------

def test_base_frame_is_cyclopean(sim):
    # docs/CONTRACTS.md: origins ±b/2 along base z, R_base_from_ptuL = exp(−v/2),
    # R_base_from_ptuR = exp(+v/2), v = log R_ptuL_from_ptuR; |v| 1–2°, not a principal axis.
    T_base_from_ptuL = invert_transform(sim.T_ptu_from_base("left"))
    T_base_from_ptuR = invert_transform(sim.T_ptu_from_base("right"))
    np.testing.assert_allclose(T_base_from_ptuL[:3, 3], [0, 0, 0.15], atol=TOL)
    np.testing.assert_allclose(T_base_from_ptuR[:3, 3], [0, 0, -0.15], atol=TOL)
    v = rotvec_from_matrix(sim.T_ptuL_from_ptuR()[:3, :3])
    np.testing.assert_allclose(T_base_from_ptuL[:3, :3], matrix_from_rotvec(-v / 2), atol=TOL)
    np.testing.assert_allclose(T_base_from_ptuR[:3, :3], matrix_from_rotvec(v / 2), atol=TOL)
    assert 1.0 <= np.degrees(np.linalg.norm(v)) <= 2.0
    assert np.max(np.abs(v)) / np.linalg.norm(v) < 0.9  # at least two axes involved
    np.testing.assert_allclose(sim.T_ptuL_from_ptuR(),
                               sim.T_ptu_from_base("left") @ T_base_from_ptuR, atol=TOL)


def test_cameras_nominal_with_offsets_and_misalignment(sim):
    # Nominal: OpenCV z = gaze +y, x = gaze −z, y = gaze −x; optical centre a few cm from
    # the rotation centre in every axis; 1–3° misalignment; the two eyes differ.
    R_gaze_from_cam_nominal = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
    centres, misalignments = [], []
    for eye in EYES:
        T_gaze_from_cam = invert_transform(sim.T_cam_from_gaze(eye))
        angle = np.degrees(rotation_angle(R_gaze_from_cam_nominal.T @ T_gaze_from_cam[:3, :3]))
        assert 1.0 <= angle <= 3.0, (eye, angle)
        centre = T_gaze_from_cam[:3, 3]
        assert np.all((np.abs(centre) >= 0.01) & (np.abs(centre) <= 0.1)), (eye, centre)
        centres.append(centre)
        misalignments.append(R_gaze_from_cam_nominal.T @ T_gaze_from_cam[:3, :3])
    assert np.linalg.norm(centres[0] - centres[1]) > 0.01
    assert np.degrees(rotation_angle(misalignments[0].T @ misalignments[1])) > 1.0


def _xml_camera(eye, path=HEAD_XML):
    root = ET.parse(path).getroot()
    (cam,) = [c for c in root.iter("camera") if c.get("name") == f"{eye}_camera"]
    defaults = {k: v for d in root.iter("default") for c in d.findall("camera")
                for k, v in c.attrib.items()}
    attrs = {**defaults, **cam.attrib}
    return {k: np.array(attrs[k].split(), dtype=float)
            for k in ("resolution", "focalpixel", "principalpixel")}


@pytest.mark.parametrize("eye", EYES)
def test_intrinsics_match_the_xml_attributes(sim, eye):
    # docs/NOTES.md: fx = focalpixel_x, cx = W/2 − principalpixel_x − 0.5 (pixel centres at
    # integers, note the minus sign). MuJoCo stores the lengths in float32: 1e-3 px.
    a = _xml_camera(eye)
    (w, h), (fx, fy), (px, py) = a["resolution"], a["focalpixel"], a["principalpixel"]
    assert sim.image_size == (1280, 960) == (w, h)
    K = sim.K(eye)
    np.testing.assert_allclose(K, [[fx, 0, w / 2 - px - 0.5], [0, fy, h / 2 - py - 0.5],
                                   [0, 0, 1]], atol=1e-3)
    assert abs(fx - 1150) < 10 and abs(fy - 1150) < 10 and fx != fy
    assert 1 <= abs(px) <= 10 and 1 <= abs(py) <= 10


def test_intrinsics_scale_with_the_render_size():
    with StereoHeadSim(image_size=(640, 480)) as half, StereoHeadSim() as full:
        for eye in EYES:
            K, K2 = half.K(eye), full.K(eye)
            # pixel centres: u_half + 0.5 = (u_full + 0.5) / 2
            np.testing.assert_allclose(K[:2, :2], K2[:2, :2] / 2, atol=1e-9)
            np.testing.assert_allclose(K[:2, 2] + 0.5, (K2[:2, 2] + 0.5) / 2, atol=1e-9)


# -- the target ----------------------------------------------------------------------------

@pytest.mark.parametrize("board", [DEFAULT_BOARD, DENSE_BOARD], ids=["9x6", "dense"])
def test_board_geometry_and_site(board):
    # Printed face (the pattern box's −z face) at z = 0 of the site frame, squares
    # (nx+1)×(ny+1) of size s centred on the corner grid, a larger white box behind it.
    with StereoHeadSim(board=board) as s:
        assert s.board == board
        nx, ny = board.inner_corners
        sq = board.square_size
        g = s.model.geom("board_pattern")
        np.testing.assert_allclose(g.size[:2], [(nx + 1) * sq / 2, (ny + 1) * sq / 2], atol=1e-12)
        np.testing.assert_allclose(g.pos, [(nx - 1) * sq / 2, (ny - 1) * sq / 2, g.size[2]],
                                   atol=1e-12)
        mat = s.model.geom_matid[g.id]
        np.testing.assert_allclose(s.model.mat_texrepeat[mat], [(nx + 1) / 2, (ny + 1) / 2])
        q = s.model.geom("board_quiet_zone")
        assert q.pos[2] - q.size[2] >= g.pos[2] + g.size[2] - 1e-12  # behind the print
        assert np.all(q.size[:2] >= g.size[:2] + sq - 1e-12)  # one square of white margin
        site = s.model.site("board_origin")
        assert site.bodyid[0] == s.model.body("board_link").id
        np.testing.assert_array_equal(site.pos, 0.0)
        rng = np.random.default_rng(5)
        T = T_base_from_world_facing(board, 1.3, (0.05, -0.1)) @ make_transform(
            matrix_from_rotvec(rng.normal(0, 0.3, 3)), rng.normal(0, 0.05, 3))
        s.set_target(T)
        np.testing.assert_allclose(s.T_base_from_world, T, atol=TOL)
        for eye in EYES:
            np.testing.assert_allclose(
                s.T_cam_from_world(eye), s.T_cam_from_base(eye) @ T, atol=TOL)


def test_object_points_follow_the_contract():
    P = Board((3, 2), 0.1).object_points()
    np.testing.assert_allclose(P, [[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0],
                                   [0, 0.1, 0], [0.1, 0.1, 0], [0.2, 0.1, 0]], atol=1e-15)


def test_facing_pose_puts_the_board_upright_ahead():
    T = T_base_from_world_facing(DEFAULT_BOARD, 1.0)
    P_base = DEFAULT_BOARD.object_points() @ T[:3, :3].T + T[:3, 3]
    np.testing.assert_allclose(P_base.mean(axis=0), [0, 1, 0], atol=1e-12)
    # corner (0,0) top left seen from the head: up (+x) and left (+z); board +z away.
    assert P_base[0, 0] > 0 and P_base[0, 2] > 0
    np.testing.assert_allclose(T[:3, 2], [0, 1, 0])


# -- a modified model ----------------------------------------------------------------------

def test_modified_model_changes_the_ground_truth(tmp_path, monkeypatch):
    text = HEAD_XML.read_text()
    old_pos, new_pos = 'pos="0.048 0.036 0.021"', 'pos="0.058 0.026 0.041"'
    old_f, new_f = 'focalpixel="1152 1148.5"', 'focalpixel="1200 1190"'
    assert text.count(old_pos) == 1 and text.count(old_f) == 1
    head = tmp_path / "stereo_head_modified.xml"
    head.write_text(text.replace(old_pos, new_pos).replace(old_f, new_f))
    with StereoHeadSim() as ref, StereoHeadSim(board=DEFAULT_BOARD, head_path=head) as mod:
        def centre(s, eye):
            return invert_transform(s.T_cam_from_gaze(eye))[:3, 3]
        np.testing.assert_allclose(centre(mod, "left") - centre(ref, "left"),
                                   [0.01, -0.01, 0.02], atol=TOL)
        np.testing.assert_allclose(mod.T_cam_from_gaze("left")[:3, :3],
                                   ref.T_cam_from_gaze("left")[:3, :3], atol=TOL)
        np.testing.assert_allclose(mod.K("left")[[0, 1], [0, 1]], [1200, 1190], atol=1e-3)
        np.testing.assert_allclose(mod.T_cam_from_gaze("right"), ref.T_cam_from_gaze("right"),
                                   atol=TOL)
        assert mod.ground_truth()["model_file"] == str(head.resolve())
    monkeypatch.chdir(tmp_path)  # a relative head path is taken from the working folder
    with StereoHeadSim(board=DEFAULT_BOARD, head_path=head.name) as rel:
        np.testing.assert_allclose(rel.K("left")[[0, 1], [0, 1]], [1200, 1190], atol=1e-3)


# -- ground truth as data ------------------------------------------------------------------

def test_ground_truth_is_json_ready_and_consistent(sim):
    gt = json.loads(json.dumps(sim.ground_truth(), allow_nan=False))
    assert gt["board"] == {"inner_corners": [9, 6], "square_size": 0.05}
    assert gt["image_size"] == [1280, 960]
    assert gt["model_file"] == str(SCENE_XML.resolve())
    np.testing.assert_allclose(gt["T_ptuL_from_ptuR"], sim.T_ptuL_from_ptuR(), atol=0)
    for eye in EYES:
        np.testing.assert_allclose(gt[eye]["K"], sim.K(eye), atol=0)
        np.testing.assert_allclose(gt[eye]["T_cam_from_gaze"], sim.T_cam_from_gaze(eye), atol=0)
        np.testing.assert_allclose(gt[eye]["T_ptu_from_base"], sim.T_ptu_from_base(eye), atol=0)
        assert gt[eye]["dist"] == [0.0] * 5


# -- bad input -----------------------------------------------------------------------------

def test_bad_input_is_refused(sim, tmp_path):
    with pytest.raises(InputError, match="eye: expected 'left' or 'right', got 'centre'"):
        sim.K("centre")
    with pytest.raises(InputError, match="T_base_from_world"):
        sim.set_target(np.diag([2.0, 1.0, 1.0, 1.0]))
    with pytest.raises(InputError, match="model file not found"):
        StereoHeadSim(tmp_path / "missing.xml")
    with pytest.raises(InputError, match=r"nx \+ ny even"):
        Board((8, 6), 0.05)
    with pytest.raises(InputError, match="square_size must be a positive number"):
        Board((9, 6), 0.0)
    with pytest.raises(InputError, match="exceeds the model's offscreen buffer"):
        StereoHeadSim(image_size=(2000, 1000))
    with pytest.raises(InputError, match="give model_path or head_path"):
        StereoHeadSim(SCENE_XML, board=DEFAULT_BOARD, head_path=HEAD_XML)
    with StereoHeadSim(HEAD_XML) as head_only:  # the head alone: no target
        assert head_only.board is None and head_only.ground_truth()["board"] is None
        with pytest.raises(InputError, match="no target"):
            head_only.T_cam_from_world("left")
    broken = tmp_path / "broken.xml"
    broken.write_text(HEAD_XML.read_text().replace('name="left_camera"', 'name="l_cam"'))
    with pytest.raises(InputError, match="no camera named 'left_camera'"):
        StereoHeadSim(broken)
    garbage = tmp_path / "garbage.xml"
    garbage.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(InputError, match="MuJoCo cannot load the model"):
        StereoHeadSim(garbage)


def test_interrupt_while_mujoco_loads_is_an_interrupt_not_a_gl_error(monkeypatch):
    """A SIGTERM that arrives while mujoco's extension loads surfaces as that import's own
    error; it must stay an interrupt (exit 130, "interrupted"), not become "cannot render
    offscreen; install …" (seen under `timeout 3 rasc render` on a loaded machine)."""
    import sys as _sys

    from rasc import interrupt
    from rasc.errors import RascError
    from rasc.sim import scene

    monkeypatch.setitem(_sys.modules, "mujoco", None)       # `import mujoco` raises ImportError
    monkeypatch.setattr(scene, "_gl_choice", "egl")
    monkeypatch.setattr(interrupt, "_RECEIVED", [])
    with pytest.raises(RascError, match="cannot render offscreen"):
        import_mujoco()                                      # no signal: a broken backend
    monkeypatch.setattr(interrupt, "_RECEIVED", [15])
    with pytest.raises(KeyboardInterrupt):
        import_mujoco()
