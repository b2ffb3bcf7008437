"""``rasc handeye --method rasc-robust [--refine]`` on a document with bad positions."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rasc.geometry.transforms import rotation_error_deg
from rasc.handeye.corruption import TRUE_T_CAM_FROM_GAZE, corrupt, pan_tilt_poses
from rasc.handeye.noise import perturb_T_cam_from_world


def _document(path):
    rng = np.random.default_rng(0)
    T_cw, T_gp, pt = pan_tilt_poses(20, rng)
    T_cw = perturb_T_cam_from_world(T_cw, 0.002, 0.001, rng, "exponential")
    T_cw, T_gp, bad, _ = corrupt(T_cw, T_gp, 5, rng, pan_tilt_rad=pt)
    doc = {"format": "rasc-handeye/1", "length_unit": "m",
           "positions": [{"T_gaze_from_ptu": G.tolist(), "T_cam_from_world": T.tolist()}
                         for G, T in zip(T_gp, T_cw, strict=True)]}
    path.write_text(json.dumps(doc), encoding="utf-8")
    return np.flatnonzero(bad).tolist()


def _run(argv, capsys):
    from rasc.cli import main

    capsys.readouterr()
    status = main([str(a) for a in argv])
    out = capsys.readouterr()
    return status, out.out, out.err


@pytest.mark.slow
def test_rasc_robust_names_the_rejected_positions_and_refines(tmp_path, capsys):
    """Five of 20 positions corrupted (every kind): the result names exactly those,
    lands within 0.6° / 5 mm of the truth (clean RASC on these draws: ~0.25° / 3 mm,
    E9), says so on stderr (one line), and --refine adds a 6x6 covariance over the
    inliers; plain RASC on the same file warns and suggests rasc-robust."""
    poses = tmp_path / "poses.json"
    bad = _document(poses)
    out = tmp_path / "robust.json"
    rc, stdout, stderr = _run(["handeye", poses, "--method", "rasc-robust", "--refine",
                               "--out", out], capsys)
    assert rc == 0 and stdout == ""
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert [r["position"] for r in doc["robust"]["rejected"]] == bad
    assert all(r["reason"] for r in doc["robust"]["rejected"])
    C = np.array(doc["refinement"]["covariance"])
    assert C.shape == (6, 6) and doc["refinement"]["start"] == "rasc-robust"
    T = np.array(doc["T_cam_from_gaze"])
    assert float(rotation_error_deg(T[:3, :3], TRUE_T_CAM_FROM_GAZE[:3, :3])) < 0.6
    assert np.linalg.norm(T[:3, 3] - TRUE_T_CAM_FROM_GAZE[:3, 3]) < 0.005
    lines = stderr.splitlines()
    assert len(lines) == 1 and "5 position(s) rejected" in lines[0]
    rc, _, stderr = _run(["handeye", poses, "--out", tmp_path / "rasc.json"], capsys)
    assert rc == 0 and "--method rasc-robust" in stderr


def test_rasc_scale_on_arm_poses_and_the_warning_of_rasc(tmp_path, capsys):
    """Arm poses (the unit translates) with the camera translations divided by 0.37:
    rasc-scale writes s (to 1 %) in the result's scale block and a translation within
    1 cm of the truth (5 mm measured on such data, tests/handeye/test_robust.py); RASC on
    the same file warns with the scale cause and names rasc-scale, not a length unit."""
    from rasc.handeye.corruption import arm_poses

    rng = np.random.default_rng(0)
    T_cw, T_gp = arm_poses(20, rng)
    T_cw = perturb_T_cam_from_world(T_cw, 0.002, 0.001, rng, "exponential")
    T_cw[:, :3, 3] /= 0.37
    poses = tmp_path / "arm.json"
    poses.write_text(json.dumps({
        "format": "rasc-handeye/1",
        "positions": [{"T_gaze_from_ptu": G.tolist(), "T_cam_from_world": T.tolist()}
                      for G, T in zip(T_gp, T_cw, strict=True)]}), encoding="utf-8")
    out = tmp_path / "scaled.json"
    rc, _, _ = _run(["handeye", poses, "--method", "rasc-scale", "--out", out], capsys)
    assert rc == 0
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert abs(doc["scale"]["s"] - 0.37) < 0.0037
    T = np.array(doc["T_cam_from_gaze"])
    assert np.linalg.norm(T[:3, 3] - TRUE_T_CAM_FROM_GAZE[:3, 3]) < 0.01
    rc, _, stderr = _run(["handeye", poses, "--out", tmp_path / "rasc.json"], capsys)
    assert rc == 0 and "common scale" in stderr and "--method rasc-scale" in stderr
    assert "length unit?" not in stderr and "behind the camera" not in stderr
