"""A head described in a URDF, compiled by MuJoCo, in the bench (rasc.sim.urdf,
``rasc render --urdf``; docs/topics/urdf-head.md): ground truth at every pose, the camera
poses equal to the exported calibration's, the names a ROS user's URDF has, refusals, and
the round trip export -> render -> calibrate (slow)."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rasc.cli import main
from rasc.export.urdf import to_urdf
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import PanTiltUnit, canonical_gauge
from rasc.geometry.transforms import invert_transform
from rasc.head.model import EyeCalibration, HeadCalibration
from rasc.sim.synthetic import default_head

#: an imperfect unit: tilt axis skewed and 10 mm off the pan axis, encoder zeros and a
#: pan scale (the export's mimic joint)
UNIT = PanTiltUnit(tilt_axis=(0.02, 0.0, 1.0), tilt_point=(0.0, 0.01, 0.0),
                   pan_offset=0.01, tilt_offset=-0.005, pan_scale=1.004, tilt_scale=1.0)
#: the exported head's cameras see the paper's nine positions whole from 1.4 m
DISTANCE = 1.4


def _head() -> HeadCalibration:
    truth = default_head(UNIT)
    return HeadCalibration(*(EyeCalibration(truth.K[eye], truth.dist[eye],
                                            truth.T_cam_from_gaze[eye],
                                            truth.T_ptu_from_base[eye], (1280, 960), UNIT)
                             for eye in EYES))


@pytest.mark.parametrize("joints", ["readings", "angles"])
def test_exported_urdf_renders_with_truth(tmp_path, joints):
    from rasc.sim.scene import GROUND_TRUTH_TOL, StereoHeadSim
    from rasc.sim.urdf import UrdfHead

    head = _head()
    path = tmp_path / "head.urdf"
    path.write_text(to_urdf(head, joints=joints))
    K = {eye: getattr(head, eye).K for eye in EYES}
    rng = np.random.default_rng(31)
    with StereoHeadSim(UrdfHead(path, K=K, image_size=(1280, 960))) as sim:
        for eye in EYES:
            # MuJoCo keeps the camera's intrinsics in float32: K within 1e-4 px
            assert np.abs(sim.K(eye) - K[eye]).max() < 1e-4
        assert sim.units["left"].pan_scale == (UNIT.pan_scale if joints == "readings" else 1.0)
        for _ in range(6):
            r = {eye: rng.uniform(-0.3, 0.3, 2) for eye in EYES}
            for eye in EYES:
                sim.set_angles(eye, *r[eye])
            for eye in EYES:
                assert sim.check_ground_truth(eye) <= GROUND_TRUTH_TOL
            # the calibration's readings: the URDF's joint values, or, for "angles", the
            # readings whose joint angles they are
            cal = {eye: r[eye] if joints == "readings" else
                   ((r[eye][0] - UNIT.pan_offset) / UNIT.pan_scale,
                    (r[eye][1] - UNIT.tilt_offset) / UNIT.tilt_scale) for eye in EYES}
            T_sim = {eye: sim.T_cam_from_base(eye) for eye in EYES}
            T_cal = {eye: getattr(head, eye).T_cam_from_base(*cal[eye]) for eye in EYES}
            # the bases may differ by a rigid move: compare camera-to-camera poses
            ref_sim, ref_cal = invert_transform(T_sim["left"]), invert_transform(T_cal["left"])
            assert np.abs(T_sim["right"] @ ref_sim - T_cal["right"] @ ref_cal).max() < 1e-9
        sim.set_angles("left", 0.0, 0.0)
        T0_sim, T0_cal = sim.T_cam_from_base("left"), head.left.T_cam_from_base(
            *((0.0, 0.0) if joints == "readings" else
              (-UNIT.pan_offset / UNIT.pan_scale, -UNIT.tilt_offset)))
        sim.set_angles("left", 0.2, -0.1)
        T1_cal = head.left.T_cam_from_base(*((0.2, -0.1) if joints == "readings" else
                                             ((0.2 - UNIT.pan_offset) / UNIT.pan_scale,
                                              -0.1 - UNIT.tilt_offset)))
        motion_sim = sim.T_cam_from_base("left") @ invert_transform(T0_sim)
        assert np.abs(motion_sim - T1_cal @ invert_transform(T0_cal)).max() < 1e-9


#: a head as a ROS user writes it: both pan joints on base_link (no ptu link), continuous
#: pan joints, ROS-style names, a camera link and its optical frame, visual boxes, and a
#: link that already holds a name the bench needs (left_ptu_link)
USER_URDF = """<?xml version="1.0"?>
<robot name="my_head">
  <link name="torso"><visual><geometry><box size="0.05 0.4 0.02"/></geometry></visual></link>
  <link name="left_ptu_link"/>
  <joint name="bracket" type="fixed"><parent link="torso"/><child link="left_ptu_link"/>
    <origin xyz="0 0 -0.05"/></joint>
  {eyes}
</robot>
"""
EYE = """
  <link name="ptu_{e}_yaw"><visual><geometry><box size="0.03 0.03 0.03"/></geometry></visual></link>
  <link name="ptu_{e}_pitch"/>
  <link name="cam_{e}"/>
  <link name="cam_{e}_optical"/>
  <joint name="ptu_{e}_pan" type="continuous"><parent link="torso"/><child link="ptu_{e}_yaw"/>
    <origin xyz="0 {y} 0.05" rpy="0 0 {yaw}"/><axis xyz="0 0 1"/></joint>
  <joint name="ptu_{e}_tilt" type="revolute"><parent link="ptu_{e}_yaw"/>
    <child link="ptu_{e}_pitch"/>
    <origin xyz="0.004 0 0.06" rpy="0.01 0 0"/><axis xyz="0 -1 0.02"/>
    <limit lower="-0.8" upper="0.8" effort="1" velocity="1"/></joint>
  <joint name="cam_{e}_joint" type="fixed"><parent link="ptu_{e}_pitch"/><child link="cam_{e}"/>
    <origin xyz="0.03 0 0.02" rpy="0 0.02 0"/></joint>
  <joint name="cam_{e}_optical_joint" type="fixed"><parent link="cam_{e}"/>
    <child link="cam_{e}_optical"/><origin rpy="-1.5707963267948966 0 -1.5707963267948966"/></joint>
"""
USER_JOINTS = "ptu_left_pan,ptu_left_tilt,ptu_right_pan,ptu_right_tilt"
USER_CAMERAS = "cam_left_optical,cam_right_optical"


def _user_urdf(folder: Path, tilt_y: float = -1.0) -> Path:
    path = folder / "my_head.urdf"
    path.write_text(USER_URDF.format(eyes="".join(
        EYE.format(e=e, y=y, yaw=yaw) for e, y, yaw in (("left", 0.15, 0.01),
                                                        ("right", -0.15, -0.01))))
        .replace('axis xyz="0 -1 0.02"', f'axis xyz="0 {tilt_y:g} 0.02"'))
    return path


@pytest.mark.parametrize("tilt_y", [-1.0, 1.0], ids=["tilt-up", "tilt-down"])
def test_user_urdf_renders_with_truth(tmp_path, capsys, tilt_y):
    """Both tilt senses: positive tilt raising the gaze (the stock head's), and lowering
    it (REP 103's positive pitch about +y), where the canonical base's y points backwards
    and the target must still go in front of the cameras."""
    from rasc.vision.dataset import load_dataset

    path = _user_urdf(tmp_path, tilt_y)
    out = tmp_path / "ds"
    rc = main(["render", "--urdf", str(path), "--urdf-joints", USER_JOINTS,
               "--urdf-cameras", USER_CAMERAS, "--intrinsics-views", "3",
               "--poses", "0,0;6,4;-6,-4", "--quiet", "--out", str(out)])
    assert rc == 0, capsys.readouterr().err
    gt = json.loads((out / "ground_truth.json").read_text())
    assert gt["model_file"] == "my_head.urdf"
    assert gt["urdf"]["joints"] == USER_JOINTS.split(",")
    # the target in front: every corner of every pose view inside the image, 1 m ahead
    ds = load_dataset(out)
    for name, view in gt["views"].items():
        if name.startswith("poses/"):
            T = np.asarray(view["T_cam_from_world"])
            centre = T[:3, :3] @ ds.board.centre() + T[:3, 3]
            assert 0.9 < centre[2] < 1.1, (name, centre)
    for eye in EYES:
        unit = PanTiltUnit.from_dict(gt[eye]["unit"])
        # the URDF's tilt joint: 4 mm off the pan axis (z) along x (forward), its axis
        # (0, ∓1, 0.02) turned 0.01 rad about x; the unit's tilt axis is minus the
        # joint's (eq. 3: the mechanism turns by +tau about -z'), so the angle to the pan
        # axis (0, 0, 1) is arccos(-a_z)
        a = np.array([0.0, tilt_y, 0.02])
        a = Rotation.from_euler("x", 0.01).apply(a / np.linalg.norm(a))
        assert unit.axis_distance == pytest.approx(0.004, abs=1e-9)
        assert unit.axis_angle_deg == pytest.approx(np.degrees(np.arccos(-a[2])), abs=1e-9)
    # the stock cameras' intrinsics by default (stereo_head.xml: left focalpixel 1152)
    assert gt["left"]["K"][0][0] == pytest.approx(1152.0, abs=1e-3)
    assert len(list((out / "poses").glob("*.png"))) == 6


def _refused(capsys, argv, fragment, out: Path) -> None:
    rc = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and fragment in err[0], err
    assert not out.exists()


def test_refusals(tmp_path, capsys):
    path = _user_urdf(tmp_path)
    out = tmp_path / "ds"
    base = ["render", "--urdf", str(path), "--urdf-cameras", USER_CAMERAS, "--quiet",
            "--out", str(out)]
    # the default names are rasc export's: this URDF has other joints
    _refused(capsys, base, "no joint named 'left_pan' (the left pan joint; name it with "
             "--urdf-joints)", out)
    _refused(capsys, base + ["--urdf-joints", "a,b,c"], "expected 4 comma-separated", out)
    _refused(capsys, base + ["--urdf-joints", "ptu_left_pan,bracket,ptu_right_pan,"
                             "ptu_right_tilt"], "joint 'bracket' is 'fixed'", out)
    _refused(capsys, ["render", "--urdf", str(path), "--urdf-joints", USER_JOINTS,
                      "--urdf-cameras", "cam_left,nope", "--out", str(out)],
             "no link named 'nope'", out)
    _refused(capsys, base + ["--urdf-joints", USER_JOINTS, "--model", str(path)],
             "give --model or --urdf, not both", out)
    _refused(capsys, base + ["--urdf-joints", USER_JOINTS, "--tilt-axis-offset=0,1,0"],
             "edit the URDF instead", out)
    _refused(capsys, ["render", "--urdf-joints", USER_JOINTS, "--out", str(out)],
             "--urdf-joints: only with --urdf HEAD.urdf", out)
    bad = tmp_path / "bad.urdf"
    bad.write_text("<mujoco/>")
    _refused(capsys, ["render", "--urdf", str(bad), "--out", str(out)], "not a URDF", out)
    _refused(capsys, ["render", "--urdf", str(tmp_path / "none.urdf"), "--out", str(out)],
             "file not found", out)
    # the export's mimic joints: name the joint the driver publishes, not its follower
    urdf = tmp_path / "head.urdf"
    urdf.write_text(to_urdf(_head(), joints="readings"))
    _refused(capsys, ["render", "--urdf", str(urdf), "--urdf-joints",
                      "left_pan_joint,left_tilt,right_pan,right_tilt", "--out", str(out)],
             "follows joint 'left_pan' (<mimic>)", out)
    _refused(capsys, ["render", "--urdf", str(urdf), "--encoder-zero", "0.5,0", "--out",
                      str(out)], "come from the URDF's <mimic> joints", out)


def round_trip_sigmas(exported: HeadCalibration, path: Path) -> dict[str, float]:
    """(calibrated − exported) / σ for every parameter the refinement reports with a σ,
    the exported head put into the refinement's (canonical) gauge."""
    from rasc.head.use import load_calibration

    got = load_calibration(path)
    calibration = json.loads(path.read_text())
    params = calibration["refinement"]["parameters"]
    out, mount = {}, {}
    for eye in EYES:
        e = getattr(exported, eye)
        unit, T_cg, T_pb = canonical_gauge(e.unit, e.T_cam_from_gaze, e.T_ptu_from_base)
        mount[eye] = T_pb
        p = params[eye]
        truth = {"fx": e.K[0, 0], "fy": e.K[1, 1], "cx": e.K[0, 2], "cy": e.K[1, 2],
                 "k1": 0.0, "k2": 0.0, "unit.pan_scale": unit.pan_scale,
                 "unit.tilt_scale": unit.tilt_scale,
                 "unit.tilt_axis_x": unit.tilt_axis[0] / unit.tilt_axis[2],
                 "unit.tilt_point_y": unit.tilt_point[1],
                 **{f"T_cam_from_gaze.t{a}": T_cg[i, 3] for i, a in enumerate("xyz")}}
        for k, v in truth.items():
            out[f"{eye}.{k}"] = (p[k]["value"] - v) / p[k]["std"]
        # rotations: a small left perturbation R = exp(δ) R_true, σ of δ in degrees
        d = Rotation.from_matrix(getattr(got, eye).T_cam_from_gaze[:3, :3]
                                 @ T_cg[:3, :3].T).as_rotvec()
        for i, a in enumerate("xyz"):
            out[f"{eye}.T_cam_from_gaze.rot{a}"] = \
                d[i] / np.radians(p[f"T_cam_from_gaze.rot{a}"]["std"])
    T = mount["left"] @ invert_transform(mount["right"])
    T_got = np.asarray(calibration["refinement"]["T_ptuL_from_ptuR"])
    d = Rotation.from_matrix(T_got[:3, :3] @ T[:3, :3].T).as_rotvec()
    h = calibration["refinement"]["parameters"]["head"]
    for i, a in enumerate("xyz"):
        out[f"T_ptuL_from_ptuR.t{a}"] = \
            (h[f"T_ptuL_from_ptuR.t{a}"]["value"] - T[i, 3]) / h[f"T_ptuL_from_ptuR.t{a}"]["std"]
        out[f"T_ptuL_from_ptuR.rot{a}"] = d[i] / np.radians(h[f"T_ptuL_from_ptuR.rot{a}"]["std"])
    return out


#: the round trip's bound, in σ: 38 parameters of a noise-free render, none farther than
#: this from the exported value (measured: 2.6 σ the largest, issue 31's report)
ROUND_TRIP_SIGMAS = 4.0


@pytest.mark.slow
def test_round_trip_export_render_calibrate(tmp_path, capsys):
    head = _head()
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(head.to_dict()))
    urdf, ds, got = tmp_path / "head.urdf", tmp_path / "ds", tmp_path / "got.json"
    for argv in (["export", str(cal), "--format", "urdf", "--out", str(urdf)],
                 ["render", "--urdf", str(urdf), "--urdf-intrinsics", str(cal),
                  "--distance", str(DISTANCE), "--quiet", "--out", str(ds)],
                 ["calibrate", str(ds), "--model", "general", "--quiet", "--out", str(got)]):
        assert main(argv) == 0, capsys.readouterr().err
    sig = round_trip_sigmas(head, got)
    assert len(sig) == 38
    worst = max(sig, key=lambda k: abs(sig[k]))
    print(f"round trip: largest difference {sig[worst]:+.2f} sigma ({worst})")
    assert abs(sig[worst]) < ROUND_TRIP_SIGMAS, (worst, sig[worst])


def test_render_cached_urdf_head(tmp_path):
    """rasc.testing.render_cached renders a UrdfHead, keyed by the file and its names:
    the same head found again, another intrinsics a new key."""
    from rasc.sim.urdf import UrdfHead
    from rasc.testing import render_cached

    head = _head()
    path = tmp_path / "head.urdf"
    path.write_text(to_urdf(head, joints="angles"))
    K = {eye: getattr(head, eye).K for eye in EYES}
    opts = dict(intrinsics_views=3, poses_deg=((0.0, 0.0), (5.0, 3.0), (-5.0, -3.0)),
                distance=DISTANCE)
    cache = tmp_path / "cache"
    a = render_cached(cache, UrdfHead(path, K=K, image_size=(1280, 960)), **opts)
    b = render_cached(cache, UrdfHead(path, K=K, image_size=(1280, 960)), **opts)
    c = render_cached(cache, UrdfHead(path), **opts)
    assert a.key == b.key != c.key and a.path == b.path
    assert np.abs(np.asarray(a.truth["right"]["K"]) - K["right"]).max() < 1e-4
    assert a.truth["model_file"] == "head.urdf"


def test_package_meshes(tmp_path, capsys, monkeypatch):
    """A ROS package's layout: the URDF in PKG/urdf/, its meshes as package://PKG/meshes/…
    (MuJoCo opens no package:// name): found above the URDF; a missing one is one line."""
    from rasc.sim.urdf import mesh_file

    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    pkg = tmp_path / "my_head"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "meshes").mkdir()
    (pkg / "meshes" / "tetra.obj").write_text(
        "v 0 0 0\nv 0.02 0 0\nv 0 0.02 0\nv 0 0 0.02\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    path = _user_urdf(pkg / "urdf")
    text = path.read_text().replace(
        '<link name="torso">', '<link name="torso"><visual><geometry><mesh '
        'filename="package://my_head/meshes/tetra.obj"/></geometry></visual>')
    path.write_text(text)
    assert mesh_file("package://my_head/meshes/tetra.obj", path) == \
        str((pkg / "meshes" / "tetra.obj").resolve())
    argv = ["render", "--urdf", str(path), "--urdf-joints", USER_JOINTS, "--urdf-cameras",
            USER_CAMERAS, "--intrinsics-views", "3", "--poses", "0,0;6,4;-6,-4", "--quiet"]
    assert main(argv + ["--out", str(tmp_path / "ds")]) == 0, capsys.readouterr().err
    (pkg / "meshes" / "tetra.obj").unlink()
    _refused(capsys, argv + ["--out", str(tmp_path / "ds2")], "tetra.obj", tmp_path / "ds2")
