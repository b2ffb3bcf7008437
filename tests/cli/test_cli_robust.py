"""``rasc handeye`` on documents with bad positions (``--method rasc-robust``, and the
default's outlier policy, the one ``rasc calibrate`` uses) and with camera translations
in an unknown unit (``--method rasc-scale [--refine]``)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rasc.geometry.transforms import rotation_error_deg
from rasc.handeye.corruption import TRUE_T_CAM_FROM_GAZE, arm_poses, corrupt, pan_tilt_poses
from rasc.handeye.noise import perturb_T_cam_from_world


def _errors(T) -> tuple[float, float]:
    T = np.asarray(T)
    return (float(rotation_error_deg(T[:3, :3], TRUE_T_CAM_FROM_GAZE[:3, :3])),
            float(np.linalg.norm(T[:3, 3] - TRUE_T_CAM_FROM_GAZE[:3, 3])))


def _poses():
    rng = np.random.default_rng(0)
    T_cw, T_gp, pt = pan_tilt_poses(20, rng)
    T_cw = perturb_T_cam_from_world(T_cw, 0.002, 0.001, rng, "exponential")
    T_cw, T_gp, bad, _ = corrupt(T_cw, T_gp, 5, rng, pan_tilt_rad=pt)
    return T_cw, T_gp, np.flatnonzero(bad).tolist()


def _write(path, T_cw, T_gp, **top):
    doc = {"format": "rasc-handeye/1", **top,
           "positions": [{"T_gaze_from_ptu": G.tolist(), "T_cam_from_world": T.tolist()}
                         for G, T in zip(T_gp, T_cw, strict=True)]}
    path.write_text(json.dumps(doc), encoding="utf-8")


def _document(path):
    T_cw, T_gp, bad = _poses()
    _write(path, T_cw, T_gp, length_unit="m")
    return bad


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
    inliers."""
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
    assert "robust" in doc and "chosen_instead_of" not in doc["robust"]   # asked for


def test_the_default_method_follows_the_outlier_policy_of_calibrate(tmp_path, capsys):
    """The same file with the default method: rasc handeye calls the library's policy
    (closed_form, what rasc calibrate calls): rasc-robust is chosen, the result says
    instead of what and why, the policy's sentence is the one warning naming the
    rejected positions, the same as the Python door's, and the answer is rasc-robust's:
    within 0.6° / 5 mm of the truth where RASC on every position is degrees and
    decimetres off (9.8° / 308 mm measured). Before: the default kept RASC's answer and
    only warned. --method li on the same file: Li's answer, no switch."""
    from rasc.handeye.methods import solve
    from rasc.handeye.robust_calibrate import closed_form

    T_cw, T_gp, bad = _poses()
    poses = tmp_path / "poses.json"
    _write(poses, T_cw, T_gp, length_unit="m")
    closed = closed_form("rasc", T_cw, T_gp)
    assert closed.method == "rasc-robust" and len(closed.notes) == 1
    out = tmp_path / "rasc.json"
    rc, stdout, stderr = _run(["handeye", poses, "--out", out], capsys)
    assert rc == 0 and stdout == ""
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["method"] == "rasc-robust" and doc["robust"]["chosen_instead_of"] == "rasc"
    assert [r["position"] for r in doc["robust"]["rejected"]] == bad
    assert [line for line in stderr.splitlines() if "reject" in line] == [
        f"rasc handeye: warning: {closed.notes[0]}"]
    np.testing.assert_allclose(doc["T_cam_from_gaze"], closed.result.T_cam_from_gaze,
                               rtol=0, atol=1e-12)
    rot, trans = _errors(doc["T_cam_from_gaze"])
    assert rot < 0.6 and trans < 0.005
    rasc_rot, rasc_trans = _errors(solve("rasc", T_cw, T_gp).T_cam_from_gaze)
    assert rasc_rot > 5 and rasc_trans > 0.1
    rc, _, stderr = _run(["handeye", poses, "--method", "li", "--out", tmp_path / "li.json"],
                         capsys)
    doc = json.loads((tmp_path / "li.json").read_text(encoding="utf-8"))
    assert rc == 0 and doc["method"] == "li" and "robust" not in doc
    assert "reject" not in stderr and "--method rasc-robust" in stderr


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
    # an unknown scale is no outlier: the default keeps RASC (nothing to reject)
    assert json.loads((tmp_path / "rasc.json").read_text(encoding="utf-8"))["method"] == "rasc"
    # rasc-scale itself is not told to use rasc-scale
    rc, _, stderr = _run(["handeye", poses, "--method", "rasc-scale", "--out", out], capsys)
    assert rc == 0 and "rasc-scale" not in stderr


def _arm_document(path, s_true: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    T_cw, T_gp = arm_poses(20, rng)
    T_cw = perturb_T_cam_from_world(T_cw, 0.002, 0.001, rng, "exponential")
    T_cw[:, :3, 3] /= s_true
    _write(path, T_cw, T_gp)


@pytest.mark.parametrize("s_true", [0.001, 1.7])
def test_rasc_scale_refine_refines_the_scale(s_true, tmp_path, capsys):
    """Camera translations in millimetres against an arm in metres (s = 0.001), and
    1.7×: ``--method rasc-scale --refine`` writes the refined s with its σ, within 4 σ
    of the truth, and a T_cam_from_gaze within 3× its predicted RMS error of the truth
    and no further from it than rasc-scale's own (measured 2.6 against 5.2 mm, 0.055°
    against 0.26°). Before: 668 mm off with the unrefined s still in the output."""
    poses = tmp_path / "arm.json"
    _arm_document(poses, s_true)
    out, plain = tmp_path / "refined.json", tmp_path / "scaled.json"
    rc, _, stderr = _run(["handeye", poses, "--method", "rasc-scale", "--refine",
                          "--out", out], capsys)
    assert rc == 0 and "rasc-scale" not in stderr
    doc = json.loads(out.read_text(encoding="utf-8"))
    scale, ref = doc["scale"], doc["refinement"]
    assert doc["method"] == "rasc-scale" and ref["start"] == "rasc-scale"
    assert abs(scale["s"] - s_true) < 4 * scale["std"] and scale["std"] < 2e-3 * s_true
    assert ref["scale"] == scale["s"] and np.array(ref["covariance_with_scale"]).shape == (7, 7)
    rot, trans = _errors(doc["T_cam_from_gaze"])
    assert trans < 3 * ref["std_translation"] and rot < 3 * ref["std_rotation_deg"]
    rc, _, _ = _run(["handeye", poses, "--method", "rasc-scale", "--out", plain], capsys)
    closed = json.loads(plain.read_text(encoding="utf-8"))
    assert scale["start"] == closed["scale"]["s"]
    c_rot, c_trans = _errors(closed["T_cam_from_gaze"])
    assert trans <= c_trans and rot <= c_rot


def test_rasc_scale_with_zero_camera_translations_says_so(tmp_path, capsys):
    """An arm's poses with every camera translation zero: one line, exit 2, no file,
    naming the zero camera translations (not 'a unit that only turns', as before)."""
    rng = np.random.default_rng(0)
    T_cw, T_gp = arm_poses(20, rng)
    T_cw[:, :3, 3] = 0.0
    poses = tmp_path / "zero.json"
    _write(poses, T_cw, T_gp)
    out = tmp_path / "out.json"
    rc, stdout, stderr = _run(["handeye", poses, "--method", "rasc-scale", "--out", out],
                              capsys)
    assert rc == 2 and stdout == "" and not out.exists()
    error = [line for line in stderr.splitlines() if "error" in line]
    assert len(error) == 1 and str(poses) in error[0]
    assert "every camera translation" in error[0] and "only turns" not in error[0]
