"""rasc export: each format read back by a reader rasc did not write (yourdfpy's forward
kinematics, PyYAML, cv2.FileStorage) and compared with rasc's own model; the command's
refusals (one line, exit 2, nothing written)."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
import yaml

from rasc.errors import InputError
from rasc.export import FORMATS, ExportOptions, export_calibration
from rasc.export.urdf import R_REP103_FROM_RASC_BASE
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import IDEAL, PanTiltUnit
from rasc.geometry.transforms import invert_transform
from rasc.head.model import EyeCalibration, HeadCalibration
from rasc.head.use import CalibrationFile
from rasc.sim.synthetic import default_head

#: every term of the general unit away from the ideal one: pan axis off x, tilt axis
#: skewed (not orthogonal), tilt point off the pan axis, encoder zeros and scales; the
#: right eye's pan scale is exactly 1 (URDF without mimic for that joint)
UNITS = {"left": PanTiltUnit(pan_axis=(1.0, 0.02, -0.01), tilt_axis=(0.03, 0.01, 1.0),
                             tilt_point=(0.004, 0.012, -0.003), pan_offset=0.011,
                             tilt_offset=-0.007, pan_scale=1.004, tilt_scale=0.997),
         "right": PanTiltUnit(pan_axis=(1.0, -0.01, 0.015), tilt_axis=(-0.02, 0.0, 1.0),
                              tilt_point=(0.0, -0.008, 0.002), pan_offset=-0.005,
                              tilt_offset=0.009, pan_scale=1.0, tilt_scale=1.002)}


def make_head(dist=(-0.05, 0.02, 0.001, -0.0005, 0.0), units=UNITS, scale=1.0,
              skew=0.0) -> HeadCalibration:
    """The synthetic head (rasc.sim.synthetic.default_head) with the units above; lengths
    multiplied by ``scale`` (1000: millimetres)."""
    h = default_head(units, dist=dist)
    eyes = []
    for eye in EYES:
        T_cg, T_pb = h.T_cam_from_gaze[eye].copy(), h.T_ptu_from_base[eye].copy()
        T_cg[:3, 3] *= scale
        T_pb[:3, 3] *= scale
        u = h.unit[eye]
        unit = PanTiltUnit(**{**u.to_dict(), "tilt_point": [x * scale for x in u.tilt_point]})
        K = h.K[eye].copy()
        K[0, 1] = skew
        eyes.append(EyeCalibration(K, h.dist[eye], T_cg, T_pb, (1280, 960), unit))
    return HeadCalibration(*eyes)


def readings(seed: int, n: int) -> np.ndarray:
    """n random readings (pan_left, tilt_left, pan_right, tilt_right), radians, ±35°."""
    return np.random.default_rng(seed).uniform(-0.6, 0.6, (n, 4))


def test_the_units_exercise_every_term():
    for unit in UNITS.values():
        for field in ("pan_axis", "tilt_axis", "tilt_point", "pan_offset", "tilt_offset",
                      "tilt_scale"):
            assert getattr(unit, field) != getattr(IDEAL, field), field
        assert unit.axis_distance > 1e-3 and abs(unit.axis_angle_deg - 90.0) > 0.2
    assert UNITS["left"].pan_scale != 1.0 and UNITS["right"].pan_scale == 1.0


# ------------------------------------------------------------------------------- URDF

def load_urdf(text: str):
    yourdfpy = pytest.importorskip("yourdfpy")
    return yourdfpy.URDF.load(io.StringIO(text), load_meshes=False)


@pytest.mark.parametrize("joints", ["readings", "angles"])
def test_urdf_forward_kinematics_is_rascs(joints):
    """yourdfpy's forward kinematics of the exported URDF equals T_cam_from_base to
    1e-9 over random readings, with the joint values the URDF says it takes."""
    head = make_head()
    text = export_calibration(head, ExportOptions("urdf", joints=joints)).files["head.urdf"]
    robot = load_urdf(text)
    assert sorted(robot.actuated_joint_names) == sorted(f"{e}_{j}" for e in EYES
                                                        for j in ("pan", "tilt"))
    worst = 0.0
    for r in readings(0, 200):
        cfg = {}
        for eye, (pan, tilt) in zip(EYES, (r[:2], r[2:]), strict=True):
            if joints == "angles":        # the driver applies φ = s·pan + o itself
                pan, tilt = (float(a) for a in getattr(head, eye).unit.angles(pan, tilt))
            cfg[f"{eye}_pan"], cfg[f"{eye}_tilt"] = pan, tilt
        robot.update_cfg(cfg)
        for eye, (pan, tilt) in zip(EYES, (r[:2], r[2:]), strict=True):
            T_base_from_cam = robot.get_transform(f"{eye}_camera_optical_frame", "rasc_base")
            want = getattr(head, eye).T_cam_from_base(pan, tilt)
            worst = max(worst, np.abs(invert_transform(T_base_from_cam) - want).max())
            # the gaze link is rasc's gaze frame
            T_gaze = robot.get_transform(f"{eye}_gaze", f"{eye}_ptu")
            want = invert_transform(getattr(head, eye).unit.T_gaze_from_ptu(pan, tilt))
            worst = max(worst, np.abs(T_gaze - want).max())
    assert worst < 1e-9
    # base_link has REP 103's axes: rasc's base x (up) is its z, y (forward) its x
    assert np.allclose(robot.get_transform("rasc_base", "base_link")[:3, :3],
                       R_REP103_FROM_RASC_BASE, atol=1e-15)
    # and the optical frame sits in the camera link as REP 103 says (z forward = x)
    T = robot.get_transform("left_camera_optical_frame", "left_camera_link")
    assert np.allclose(T[:3, :3] @ [0, 0, 1], [1, 0, 0], atol=1e-15)
    assert np.allclose(T[:3, :3] @ [1, 0, 0], [0, -1, 0], atol=1e-15)


def test_urdf_scales_are_mimic_multipliers_and_zeros_are_origins():
    """readings: a joint with scale s ≠ 1 is moved through <mimic multiplier="s"> of the
    published joint (the left eye's), one with s = 1 directly (the right pan)."""
    head = make_head()
    robot = load_urdf(export_calibration(head, ExportOptions("urdf")).files["head.urdf"])
    joints = {j.name: j for j in robot.robot.joints}
    assert joints["left_pan_joint"].mimic.joint == "left_pan"
    assert joints["left_pan_joint"].mimic.multiplier == UNITS["left"].pan_scale
    assert joints["left_tilt_joint"].mimic.multiplier == UNITS["left"].tilt_scale
    assert joints["right_pan"].mimic is None and "right_pan_joint" not in joints
    assert all(j.mimic is None or j.mimic.offset == 0.0 for j in joints.values())
    # angles: no mimic at all
    robot = load_urdf(export_calibration(head, ExportOptions("urdf", joints="angles"))
                      .files["head.urdf"])
    assert all(j.mimic is None for j in robot.robot.joints)


def test_urdf_lengths_are_metres():
    """A calibration in millimetres gives the same URDF poses as the one in metres."""
    pytest.importorskip("yourdfpy")
    poses = {}
    for unit, scale in (("m", 1.0), ("mm", 1000.0)):
        cal = CalibrationFile(make_head(scale=scale), unit, None, f"cal-{unit}.json")
        robot = load_urdf(export_calibration(cal, ExportOptions("urdf")).files["head.urdf"])
        robot.update_cfg({"left_pan": 0.1, "left_tilt": -0.2, "right_pan": 0.05,
                          "right_tilt": 0.3})
        poses[unit] = robot.get_transform("right_camera_optical_frame", "rasc_base")
    assert np.abs(poses["m"] - poses["mm"]).max() < 1e-12
    with pytest.raises(InputError, match="length_unit 'inch'"):
        export_calibration(CalibrationFile(make_head(), "inch", None, "x"),
                           ExportOptions("urdf"))


# ------------------------------------------------------------------------ camera_info

@pytest.mark.parametrize("dist, model", [
    ((-0.05, 0.02, 0.001, -0.0005, 0.003), "plumb_bob"),
    ((-0.05, 0.02, 0.001, -0.0005), "plumb_bob"),
    ((), "plumb_bob"),
    ((-0.05, 0.02, 0.001, -0.0005, 0.003, 0.01, -0.002, 1e-5), "rational_polynomial")])
def test_camera_info_reads_back_field_by_field(dist, model):
    head = make_head(dist=dist, skew=0.25)
    files = export_calibration(head, ExportOptions("camera-info")).files
    assert set(files) == {"left.yaml", "right.yaml"}
    for eye in EYES:
        doc = yaml.safe_load(files[f"{eye}.yaml"])
        e = getattr(head, eye)
        assert set(doc) == {"image_width", "image_height", "camera_name", "camera_matrix",
                            "distortion_model", "distortion_coefficients",
                            "rectification_matrix", "projection_matrix"}
        assert (doc["image_width"], doc["image_height"]) == e.image_size
        assert doc["camera_name"] == eye
        assert doc["distortion_model"] == model
        D = list(dist) + [0.0] * (5 - len(dist)) if model == "plumb_bob" else list(dist)
        for key, rows, cols, want in (("camera_matrix", 3, 3, e.K),
                                      ("distortion_coefficients", 1, len(D), D),
                                      ("rectification_matrix", 3, 3, np.eye(3)),
                                      ("projection_matrix", 3, 4,
                                       np.hstack([e.K, np.zeros((3, 1))]))):
            m = doc[key]
            assert (m["rows"], m["cols"]) == (rows, cols), key
            assert all(isinstance(v, float) for v in m["data"]), key
            assert np.array_equal(np.reshape(m["data"], (rows, cols)),
                                  np.reshape(want, (rows, cols))), key


# ----------------------------------------------------------------------------- OpenCV

def read_filestorage(text: str, tmp_path):
    import cv2

    path = tmp_path / "stereo.yaml"
    path.write_text(text)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert fs.isOpened()
    return fs


@pytest.mark.parametrize("gaze", [None, (0.2, -0.1, -0.15, 0.05)])
def test_opencv_filestorage_reads_back(gaze, tmp_path):
    head = make_head()
    text = export_calibration(head, ExportOptions("opencv", gaze=gaze)).files["stereo.yaml"]
    fs = read_filestorage(text, tmp_path)
    g = (0.0,) * 4 if gaze is None else gaze
    T = {eye: getattr(head, eye).T_cam_from_base(*a)
         for eye, a in zip(EYES, (g[:2], g[2:]), strict=True)}
    T21 = T["right"] @ invert_transform(T["left"])
    want = {"K1": head.left.K, "D1": head.left.dist.reshape(1, -1), "K2": head.right.K,
            "D2": head.right.dist.reshape(1, -1), "R": T21[:3, :3], "T": T21[:3, 3:],
            "T_cam_from_base1": T["left"], "T_cam_from_base2": T["right"]}
    for k, eye in enumerate(EYES, start=1):
        e = getattr(head, eye)
        want |= {f"T_cam_from_gaze{k}": e.T_cam_from_gaze,
                 f"T_ptu_from_base{k}": e.T_ptu_from_base,
                 f"pan_axis{k}": np.reshape(e.unit.pan_axis, (3, 1)),
                 f"tilt_axis{k}": np.reshape(e.unit.tilt_axis, (3, 1)),
                 f"tilt_point{k}": np.reshape(e.unit.tilt_point, (3, 1))}
        for field in ("pan_offset", "tilt_offset", "pan_scale", "tilt_scale"):
            assert abs(fs.getNode(f"{field}{k}").real() - getattr(e.unit, field)) < 1e-12
        size = fs.getNode(f"image_size{k}")
        assert (int(size.at(0).real()), int(size.at(1).real())) == e.image_size
    for name, M in want.items():
        got = fs.getNode(name).mat()
        assert got is not None and got.shape == M.shape, name
        assert np.abs(got - M).max() < 1e-12, name
    assert fs.getNode("length_unit").string() == "m"
    assert np.allclose([fs.getNode("gaze").at(i).real() for i in range(4)], g, atol=0)
    # E and F as cv2.stereoCalibrate gives them: a base point seen by both eyes at this
    # gaze satisfies x2ᵀ F x1 = 0 in ideal pixels (an independent check of R, T's sense)
    F, E = fs.getNode("F").mat(), fs.getNode("E").mat()
    p_base = np.random.default_rng(1).uniform([-0.2, 0.8, -0.2], [0.2, 1.5, 0.2], (20, 3))
    x = {}
    for eye in EYES:
        P = getattr(head, eye).projection_matrix(*(g[:2] if eye == "left" else g[2:]))
        h = (P @ np.c_[p_base, np.ones(20)].T).T
        x[eye] = h / h[:, 2:]
    rel = np.einsum("ni,ij,nj->n", x["right"], F, x["left"]) / np.linalg.norm(F)
    assert np.abs(rel).max() < 1e-9
    t = T21[:3, 3]
    t_cross = np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])
    assert np.abs(E - t_cross @ T21[:3, :3]).max() < 1e-12


# ----------------------------------------------------------------------------- Kalibr

def test_kalibr_camchain_reads_back():
    head = make_head(dist=(-0.05, 0.02, 0.001, -0.0005, 0.0))
    gaze = (0.1, 0.05, -0.2, -0.1)
    doc = yaml.safe_load(export_calibration(head, ExportOptions("kalibr", gaze=gaze))
                         .files["camchain.yaml"])
    assert set(doc) == {"cam0", "cam1"}
    for cam, eye in (("cam0", "left"), ("cam1", "right")):
        c, e = doc[cam], getattr(head, eye)
        assert c["camera_model"] == "pinhole" and c["distortion_model"] == "radtan"
        assert c["intrinsics"] == [e.K[0, 0], e.K[1, 1], e.K[0, 2], e.K[1, 2]]
        assert c["distortion_coeffs"] == list(e.dist[:4])
        assert c["resolution"] == list(e.image_size)
        assert isinstance(c["rostopic"], str) and c["rostopic"].startswith("/")
    assert "T_cn_cnm1" not in doc["cam0"]
    # T_cn_cnm1 maps cam0 coordinates into cam1: a base point in each camera's frame
    T10 = np.array(doc["cam1"]["T_cn_cnm1"])
    assert T10.shape == (4, 4)
    p_base = np.array([0.1, 1.2, -0.05, 1.0])
    p0 = head.left.T_cam_from_base(*gaze[:2]) @ p_base
    p1 = head.right.T_cam_from_base(*gaze[2:]) @ p_base
    assert np.abs(T10 @ p0 - p1).max() < 1e-12


def test_kalibr_refuses_what_radtan_pinhole_cannot_hold():
    with pytest.raises(InputError, match=r"left.dist: k3..k6 = 0.003 .*radtan"):
        export_calibration(make_head(dist=(-0.05, 0.02, 0.0, 0.0, 0.003)),
                           ExportOptions("kalibr"))
    with pytest.raises(InputError, match=r"left.K: skew 0.5 px"):
        export_calibration(make_head(skew=0.5), ExportOptions("kalibr"))


def test_options_refuse_what_a_format_has_not():
    with pytest.raises(InputError, match="gaze: not for format urdf"):
        ExportOptions("urdf", gaze=(0.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match="gaze: not for format camera-info"):
        ExportOptions("camera-info", gaze=(0.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match="joints: only for format urdf"):
        ExportOptions("kalibr", joints="angles")
    with pytest.raises(InputError, match="format 'sdf'"):
        ExportOptions("sdf")
    with pytest.raises(InputError, match=r"gaze\[2\] \(radians\): 10 is out of range"):
        ExportOptions("opencv", gaze=(0.0, 0.0, 10, 0.0))
    with pytest.raises(InputError, match="gaze: expected 4 readings"):
        ExportOptions("kalibr", gaze=(0.0, 0.0))


def test_a_refusal_names_the_calibration_file(rasc_cli, tmp_path):
    """A unit rasc cannot convert to metres, and a lens Kalibr cannot hold: the file."""
    head = make_head(dist=(-0.05, 0.02, 0.0, 0.0, 0.003)).to_dict()
    for unit, fmt, fragment in (("furlong", "urdf", "cal.json: length_unit 'furlong'"),
                                ("mm", "kalibr", "cal.json: left.dist: k3..k6 = 0.003")):
        cal = tmp_path / "cal.json"
        cal.write_text(json.dumps({"format": "rasc-calibration/1", "head": head,
                                   "length_unit": unit}))
        status, out, err = rasc_cli("export", str(cal), "--format", fmt,
                                    "--out", str(tmp_path / "out"))
        assert status == 2 and out == "" and fragment in err and len(err.splitlines()) == 1
        assert [p.name for p in tmp_path.iterdir()] == ["cal.json"]


# ---------------------------------------------------------------------------- command

@pytest.fixture
def cal_file(tmp_path):
    path = tmp_path / "cal.json"
    path.write_text(json.dumps(make_head().to_dict()))
    return path


def test_command_formats_match_the_library(rasc_cli, cal_file, tmp_path):
    """Each format through the command equals the library's text; --gaze in degrees is
    the library's gaze in radians."""
    from rasc.head.use import read_calibration

    cal = read_calibration(cal_file)
    status, out, err = rasc_cli("export", str(cal_file), "--format", "urdf")
    assert (status, err) == (0, "")
    assert out == export_calibration(cal, ExportOptions("urdf")).files["head.urdf"]
    status, out, err = rasc_cli("export", str(cal_file), "--format", "kalibr",
                                "--gaze=10,-5,-10,5", "--angle-unit", "deg",
                                "--out", str(tmp_path / "chain.yaml"))
    assert status == 0 and out == "" and "export: wrote" in err
    want = export_calibration(cal, ExportOptions(
        "kalibr", gaze=tuple(np.radians([10, -5, -10, 5])))).files["camchain.yaml"]
    assert (tmp_path / "chain.yaml").read_text() == want
    status, out, err = rasc_cli("export", str(cal_file), "--format", "camera-info",
                                "--out", str(tmp_path / "info"))
    assert status == 0
    assert sorted(p.name for p in (tmp_path / "info").iterdir()) == ["left.yaml",
                                                                     "right.yaml"]


def test_the_command_offers_the_librarys_choices():
    """rasc/commands/export.py spells the choices without importing the library (a bare
    start-up for --help): they are the library's."""
    import argparse

    from rasc.commands import export as command
    from rasc.export.urdf import JOINT_VALUES

    parser = command.add_parser(argparse.ArgumentParser().add_subparsers())
    choices = {a.dest: tuple(a.choices) for a in parser._actions if a.choices}
    assert choices["format"] == FORMATS and choices["joints"] == JOINT_VALUES


@pytest.mark.parametrize("argv, fragment", [
    (["--format", "camera-info"], "give --out FOLDER"),
    (["--format", "urdf", "--gaze", "0,0,0,0", "--angle-unit", "deg", "--out", "o.urdf"],
     "gaze: not for format urdf"),
    (["--format", "opencv", "--gaze", "0,0,0,0", "--out", "o.yaml"],
     "--gaze: give --angle-unit"),
    (["--format", "opencv", "--gaze", "0,0,0", "--angle-unit", "deg", "--out", "o.yaml"],
     "expected PAN_LEFT,TILT_LEFT"),
    (["--format", "opencv", "--gaze", "0,0,400,0", "--angle-unit", "deg", "--out",
      "o.yaml"], "beyond"),
    (["--format", "opencv", "--out", "{cal}"], "is the input file"),
    (["--format", "kalibr", "--out", "o.yaml"], "k3..k6"),
])
def test_command_refusals_write_nothing(rasc_cli, tmp_path, argv, fragment, monkeypatch):
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(make_head(dist=(-0.05, 0.02, 0.0, 0.0, 0.003)).to_dict()))
    before = cal.read_bytes()
    monkeypatch.chdir(tmp_path)
    status, out, err = rasc_cli("export", str(cal), *[a.format(cal=cal) for a in argv])
    assert status == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rasc export: error: "), err
    assert fragment in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.json"]
    assert cal.read_bytes() == before
