"""One gauge everywhere (issue 30): the renderer writes its truth in the calibration's base
(the cyclopean base of the canonical units), so that a correct calibration of a head whose
encoder zeros are off shows no error in its mounts, and the truth's points land where the
images put them; ``errors_against_truth`` compares in that base whatever base a truth
file was written in."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from rasc.geometry.kinematics import cyclopean_base
from rasc.geometry.lens import project_points
from rasc.geometry.transforms import invert_transform, rotation_angle
from rasc.head.pipeline import CalibrationOptions, calibrate_dataset, errors_against_truth
from rasc.sim.render import RenderOptions, render_in_memory
from rasc.sim.scene import StereoHeadSim
from rasc.sim.units import UnitBuild

ZEROS = {"left": UnitBuild(pan_zero_deg=0.4, tilt_zero_deg=-0.3),
         "right": UnitBuild(pan_zero_deg=-0.2, tilt_zero_deg=0.25)}


def test_the_truths_base_is_the_cyclopean_base_of_its_units():
    with StereoHeadSim(units=ZEROS) as sim:
        T_pb = {eye: sim.T_ptu_from_base(eye) for eye in ("left", "right")}
        T_bbl = sim.T_base_from_base_link
        gt = sim.ground_truth()
    cyc = cyclopean_base(T_pb["left"] @ invert_transform(T_pb["right"]))
    np.testing.assert_allclose(cyc[0], T_pb["left"], atol=1e-12)
    np.testing.assert_allclose(cyc[1], T_pb["right"], atol=1e-12)
    # base_link is turned from it by about the mean pan zero, (0.4 - 0.2) / 2 deg
    assert np.degrees(rotation_angle(T_bbl[:3, :3])) == pytest.approx(0.1, abs=2e-3)
    assert gt["T_base_from_base_link"] == T_bbl.tolist() and "cyclopean" in gt["base"]
    # the stock head: base_link is the base, exactly (its renders keep their bytes)
    with StereoHeadSim() as sim:
        assert np.array_equal(sim.T_base_from_base_link, np.eye(4))
        assert np.array_equal(sim.T_scene_from_base, sim.T_scene_from_base_link)


@pytest.fixture(scope="module")
def zeros_calibration():
    ds = render_in_memory(RenderOptions(intrinsics_views=8, seed=3, image_noise=1.0),
                          units=ZEROS, quiet=True)
    return ds, calibrate_dataset(ds, CalibrationOptions())


@pytest.mark.slow
def test_a_correct_calibration_has_no_mount_error_and_truth_lands_on_the_images(
        zeros_calibration):
    ds, cal = zeros_calibration
    for eye in ("left", "right"):
        e = cal.errors[eye]["T_ptu_from_base"]
        # was 0.100 deg, the mean pan zero, for a correct calibration
        assert e["rotation_deg"] < 0.01 and e["translation"] < 0.5e-3, (eye, e)
    # the truth's board corners, projected through the calibration at each pose view's
    # readings, land on the detected corners (were 2.2-2.7 px off)
    P = ds.board.object_points()
    for eye in ("left", "right"):
        est = getattr(cal.head, eye)
        r = cal.eyes[eye]
        for f, (pan, tilt) in zip(r.pose_files, r.pan_tilt, strict=True):
            T_bw = np.asarray(ds.truth["views"][f]["T_base_from_world"])
            T_cw = est.T_cam_from_base(pan, tilt) @ T_bw
            uv = project_points(P @ T_cw[:3, :3].T + T_cw[:3, 3], est.K, est.dist)
            d = np.linalg.norm(uv - r.corners["pose"][f], axis=1)
            assert np.sqrt(np.mean(d ** 2)) < 0.2, (eye, f, d.max())


@pytest.mark.slow
def test_errors_against_truth_do_not_depend_on_the_truths_base(zeros_calibration):
    ds, cal = zeros_calibration
    # the same truth written in base_link (as rasc render did before 0.3), and in a base
    # turned and shifted anywhere: the same errors
    T_other = np.eye(4)
    T_other[:3, :3] = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    T_other[:3, 3] = (0.3, -0.1, 1.2)
    for T_base_from_other in (np.asarray(ds.truth["T_base_from_base_link"]), T_other):
        moved = copy.deepcopy(ds.truth)
        for eye in ("left", "right"):
            moved[eye]["T_ptu_from_base"] = (np.asarray(moved[eye]["T_ptu_from_base"])
                                             @ T_base_from_other).tolist()
        e = errors_against_truth(cal, moved)
        for eye in ("left", "right"):
            for q in ("T_ptu_from_base", "T_cam_from_gaze"):
                for k in ("rotation_deg", "translation"):
                    assert e[eye][q][k] == pytest.approx(cal.errors[eye][q][k], abs=1e-9)
        assert e["T_ptuL_from_ptuR"]["translation"] == pytest.approx(
            cal.errors["T_ptuL_from_ptuR"]["translation"], abs=1e-9)
