"""``rasc render`` and ``rasc calibrate`` end to end, through the command line.

The default dataset is rendered and calibrated once per test run by the real command line
in subprocesses (``python -m rasc``; the session fixture ``default_cli_run`` of
tests/shared_fixtures.py, shared with the other modules that need that dataset); the other
datasets (same seed again, a modified head model, image noise, lens distortion) and the
many bad inputs go through :func:`rasc.cli.main` in-process to keep the module fast (a
refusal in a real process, exit status 2 and one line: tests/cli/test_hostile.py, for
calibrate's input documents under /dev/zero and for the second of two renders into one
--out).
Expected values come from each dataset's ``ground_truth.json`` (read from the MuJoCo
model) or from the inputs the test chose, never from the code under test. Every bad input
must give exit status 2, exactly one line on stderr naming the file and the problem,
nothing on stdout, no output file and no temporary file.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import difflib
import json
import math
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
import pytest

from rasc.geometry.frames import EYES
from rasc.head.base_to_ptu import cyclopean_base, perturb_mounts
from rasc.sim.scene import HEAD_XML, scene_xml
from rasc.vision.board import DEFAULT_BOARD

from running import run_rasc

#: Same bounds as tests/head/test_pipeline.py (issue 3): T_cam_from_gaze per eye, and the
#: loop-closure T_ptuL_from_ptuR (about the sum of both eyes' errors, so twice as loose).
HANDEYE_ROT_DEG = 0.05
HANDEYE_TRANS_M = 1.5e-3
LOOP_ROT_DEG = 0.1
LOOP_TRANS_M = 3.0e-3
K_PX = 0.25


run_cli = run_rasc                 # rasc ARGV in this process: (status, stdout, stderr)


def rotation_deg(R_a, R_b) -> float:
    c = (np.trace(np.asarray(R_a) @ np.asarray(R_b).T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def errors(T_est, T_true) -> tuple[float, float]:
    T_est, T_true = np.asarray(T_est), np.asarray(T_true)
    return rotation_deg(T_est[:3, :3], T_true[:3, :3]), \
        float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3]))


def read_json(path) -> dict:
    return json.loads(Path(path).read_text())


def assert_recovered(cal: dict, truth: dict, rot=HANDEYE_ROT_DEG, trans=HANDEYE_TRANS_M,
                     loop_rot=LOOP_ROT_DEG, loop_trans=LOOP_TRANS_M, k_px=K_PX) -> dict:
    """Errors recomputed here from the calibration JSON and the dataset's truth."""
    measured = {}
    for eye in EYES:
        r, t = errors(cal["eyes"][eye]["T_cam_from_gaze"], truth[eye]["T_cam_from_gaze"])
        assert r <= rot and t <= trans, f"{eye}: {r:.4f} deg, {1e3 * t:.3f} mm"
        K, K_true = np.asarray(cal["eyes"][eye]["K"]), np.asarray(truth[eye]["K"])
        assert np.all(np.abs((K - K_true)[[0, 1, 0, 1], [0, 1, 2, 2]]) <= k_px), eye
        measured[eye] = (r, t)
    r, t = errors(cal["base_to_ptu"]["T_ptuL_from_ptuR"], truth["T_ptuL_from_ptuR"])
    assert r <= loop_rot and t <= loop_trans, f"loop closure: {r:.4f} deg, {1e3 * t:.3f} mm"
    measured["loop"] = (r, t)
    return measured


def files_of(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def default(default_cli_run):
    """The default dataset and its calibration, both by the real command line (conftest:
    rendered with stderr empty, calibrated with stdout and stderr empty). Read-only."""
    return default_cli_run


# ------------------------------------------------------------------- happy paths

def test_subprocess_render_and_calibrate_recover_the_truth(default):
    ds = default / "ds"
    names = set(files_of(ds))
    assert names == {"manifest.json", "ground_truth.json",
                     *(f"intrinsics/{e}_{k:03d}.png" for e in EYES for k in range(20)),
                     *(f"poses/{e}_{k:02d}.png" for e in EYES for k in range(9))}
    # the folder was built under a temporary name and renamed: nothing else left beside it
    assert sorted(p.name for p in default.iterdir()) == ["cal.json", "ds"]
    # mkdtemp's private mode is not passed on to the dataset
    assert ds.stat().st_mode & 0o777 == 0o777 & ~_umask()
    cal, truth = read_json(default / "cal.json"), read_json(ds / "ground_truth.json")
    assert cal["format"] == "rasc-calibration/1" and cal["base_to_ptu"]["source"] == \
        "whole-head refinement (initialised by loop closure)"      # --model general
    assert_recovered(cal, truth)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_same_seed_gives_identical_files_and_calibration(default, tmp_path, capsys):
    """Issue 3: same seed → byte-identical images, manifest and ground truth; and the
    calibration JSON identical except its timings (and the dataset path as given)."""
    code, _, err = run_cli(["render", "--out", tmp_path / "again", "--quiet"], capsys)
    assert code == 0 and err == ""
    first, again = files_of(default / "ds"), files_of(tmp_path / "again")
    assert first.keys() == again.keys()
    differ = [name for name in first if first[name] != again[name]]
    assert differ == []
    code, out, err = run_cli(["calibrate", tmp_path / "again", "--quiet"], capsys)  # stdout
    assert code == 0 and err == ""
    a, b = (default / "cal.json").read_text().splitlines(), out.splitlines()
    changed = [line for line in difflib.unified_diff(a, b, n=0, lineterm="")
               if line[:1] in "+-" and not line.startswith(("+++", "---"))]
    timing_keys = ('"detection"', '"intrinsics"', '"extrinsics"', '"hand-eye"',
                   '"base-to-ptu"', '"model-fit check"', '"refinement"', '"dataset"')
    assert changed, "the dataset path differs, so the diff cannot be empty"
    assert all(line[1:].strip().startswith(timing_keys) for line in changed), changed
    doc_a, doc_b = read_json(default / "cal.json"), json.loads(out)
    for d in (doc_a, doc_b):
        d.pop("timings_s"), d.pop("dataset")
    assert doc_a == doc_b


def modified_head(folder: Path) -> Path:
    """A copy of the default head with both cameras moved and turned in their housings,
    other focal lengths, a 0.2012 m baseline and another mount rotation; returns a scene
    that includes it (rasc.sim.scene.scene_xml), written next to it."""
    changes = {
        ("body", "left_ptu_link"): {"pos": "0.01 0.005 0.10", "axisangle": "0.2 1 0.4 -1.5"},
        ("body", "right_ptu_link"): {"pos": "-0.01 -0.005 -0.10",
                                     "axisangle": "0.2 1 0.4 1.5"},
        ("body", "left_camera_link"): {"pos": "0.040 0.045 0.015"},
        ("body", "right_camera_link"): {"pos": "0.060 0.025 -0.010"},
        ("camera", "left_camera"): {"euler": "-1.0 -1.0 -1.2", "focalpixel": "1105 1102.5"},
        ("camera", "right_camera"): {"euler": "1.1 0.4 1.7", "focalpixel": "1190 1188"},
    }
    tree = ET.parse(HEAD_XML)
    for (tag, name), attrs in changes.items():
        element = tree.getroot().find(f".//{tag}[@name='{name}']")
        assert element is not None, name
        for key, value in attrs.items():
            assert element.get(key) != value  # a real change of the default
            element.set(key, value)
    folder.mkdir(parents=True)
    tree.write(folder / "stereo_head.xml")
    scene = folder / "scene.xml"
    scene.write_text(scene_xml(DEFAULT_BOARD, "stereo_head.xml"))
    return scene


def test_modified_model_is_recovered_just_as_well(default, tmp_path, capsys):
    scene = modified_head(tmp_path / "model")
    code, _, err = run_cli(["render", "--model", scene, "--out", tmp_path / "ds", "--quiet"],
                           capsys)
    assert code == 0 and err == ""
    code, _, err = run_cli(["calibrate", tmp_path / "ds", "--out", tmp_path / "cal.json",
                            "--quiet"], capsys)
    assert code == 0 and err == ""
    truth = read_json(tmp_path / "ds" / "ground_truth.json")
    default_truth = read_json(default / "ds" / "ground_truth.json")
    assert truth["model_file"] == "scene.xml"
    # the edit reached the truth: baseline 2·|(0.01, 0.005, 0.10)| = 0.20125 m (1e-9 m:
    # MuJoCo's float64 kinematics), and the focal lengths written in the XML
    assert np.linalg.norm(np.asarray(truth["T_ptuL_from_ptuR"])[:3, 3]) == \
        pytest.approx(2 * np.sqrt(0.01**2 + 0.005**2 + 0.10**2), abs=1e-9)
    assert np.asarray(truth["left"]["K"])[0, 0] == pytest.approx(1105, abs=1e-3)
    # ... and differs from the default geometry by far more than the bounds
    for eye in EYES:
        r, t = errors(truth[eye]["T_cam_from_gaze"], default_truth[eye]["T_cam_from_gaze"])
        assert r > 1.0 and t > 5e-3, (eye, r, t)
    r, t = errors(truth["T_ptuL_from_ptuR"], default_truth["T_ptuL_from_ptuR"])
    assert r > 0.5 and t > 0.09
    cal = read_json(tmp_path / "cal.json")
    assert_recovered(cal, truth)
    for eye in EYES:  # the model's base is cyclopean too
        r, t = errors(cal["eyes"][eye]["T_ptu_from_base"], truth[eye]["T_ptu_from_base"])
        assert r <= LOOP_ROT_DEG and t <= LOOP_TRANS_M


#: a small render of a target seen in part: (30, 0) shows a part of it in each eye
TARGET_RENDER = ["--intrinsics-views", "5", "--poses", "0,0;8,8;30,0;-8,-8;8,-8", "--quiet"]


def test_model_and_target_together_render_that_model_with_that_target(tmp_path, capsys):
    """``--model`` with ``--target`` (refused before: "give --target or --model, not
    both"): the model's head with the target in place of the model's own. The modified
    head's scene (its own 9x6 chessboard) with a ChArUco board: the manifest and the truth
    name the ChArUco board, the truth is the modified head's, detection finds the ids the
    truth lists where it lists them, and the calibration recovers that head."""
    from rasc.vision.board import parse_target
    from rasc.vision.camera import detect_corners
    from rasc.vision.dataset import load_dataset

    from rendered_views import seen_against_truth

    spec = "charuco:12x9,0.06,0.045"
    scene = modified_head(tmp_path / "model")
    code, _, err = run_cli(["render", "--model", scene, "--target", spec, "--out",
                            tmp_path / "ds", *TARGET_RENDER], capsys)
    assert code == 0 and err == ""
    board = parse_target(spec)
    truth = read_json(tmp_path / "ds" / "ground_truth.json")
    assert read_json(tmp_path / "ds" / "manifest.json")["board"] == board.to_dict()
    assert truth["board"] == board.to_dict() and truth["model_file"] == "scene.xml"
    assert np.asarray(truth["left"]["K"])[0, 0] == pytest.approx(1105, abs=1e-3)  # the model's
    ds = load_dataset(tmp_path / "ds")
    found = []
    for e in ds.select(role="pose"):
        corners = detect_corners(ds.read(e), board, "saddle")
        seen, rms = seen_against_truth(corners, truth["views"][e.file]["corners"])
        # 0.01-0.02 px measured (saddle detector on renders, docs/topics/targets.md); the
        # model's old chessboard, still drawn, would put corners tens of pixels away
        assert rms < 0.1, (e.file, rms)
        found.append(len(seen))
    assert min(found) < board.n_corners == max(found), found
    code, _, err = run_cli(["calibrate", tmp_path / "ds", "--out", tmp_path / "cal.json",
                            "--quiet"], capsys)
    assert code == 0 and err == ""
    assert_recovered(read_json(tmp_path / "cal.json"), truth)


def test_model_with_target_is_the_stock_render_for_the_stock_scene(tmp_path, capsys):
    """The stock scene given as ``--model`` with ``--target``: its chessboard replaced by
    the target, lights and settings the stock scene's, so the images are byte for byte
    those of ``--target`` alone; a model of the head alone gets the stock scene around
    it, the same images again."""
    from rasc.sim.scene import SCENE_XML

    spec = "aprilgrid:7x5,0.08,0.3"
    renders = {}
    for name, model in (("alone", []), ("scene", ["--model", SCENE_XML]),
                        ("head", ["--model", HEAD_XML])):
        code, _, err = run_cli(["render", *model, "--target", spec, "--intrinsics-views", "3",
                                "--poses", "0,0;8,8;-8,-8", "--quiet", "--out",
                                tmp_path / name], capsys)
        assert code == 0 and err == ""
        renders[name] = {f: b for f, b in files_of(tmp_path / name).items()
                         if f.endswith(".png")}
    assert len(renders["alone"]) == 12
    assert renders["scene"] == renders["alone"] == renders["head"]


def test_noise_and_blur_still_calibrate(default, tmp_path, capsys):
    """--noise 2 --blur 0.7: measured left 0.018 deg / 0.21 mm, right 0.008 deg / 0.52 mm,
    about as clean renders; the looser bounds (0.1 deg, 3 mm; K 0.5 px) leave room for
    other seeds."""
    code, _, err = run_cli(["render", "--out", tmp_path / "ds", "--noise", 2, "--blur", 0.7,
                            "--quiet"], capsys)
    assert code == 0 and err == ""
    # the images really are degraded: against the clean render, a difference of the
    # noise's size (2 grey levels, blurred edges add some), not 0 and not more than 5
    clean = cv2.imread(str(default / "ds" / "poses" / "left_04.png"), cv2.IMREAD_GRAYSCALE)
    noisy = cv2.imread(str(tmp_path / "ds" / "poses" / "left_04.png"), cv2.IMREAD_GRAYSCALE)
    diff = np.abs(clean.astype(float) - noisy)
    assert 1.0 < diff.mean() < 5.0
    code, _, err = run_cli(["calibrate", tmp_path / "ds", "--out", tmp_path / "cal.json",
                            "--quiet"], capsys)
    assert code == 0 and err == ""
    cal = read_json(tmp_path / "cal.json")
    assert_recovered(cal, read_json(tmp_path / "ds" / "ground_truth.json"), rot=0.1,
                     trans=3e-3, loop_rot=0.2, loop_trans=6e-3, k_px=0.5)
    clean_cal = read_json(default / "cal.json")
    for eye in EYES:  # the calibration sees the noise
        assert cal["eyes"][eye]["intrinsics_rms"] > clean_cal["eyes"][eye]["intrinsics_rms"]


@pytest.mark.slow
def test_distortion_is_rendered_and_recovered(tmp_path, capsys):
    """--distortion=-0.2,0.05 (barrel), calibrated with the default k1k2 model: measured
    k1 within 0.0005 and k2 within 0.002 of the truth (bounds 0.005, 0.01: a corner at the
    image corner moves ~5 px per 0.01 of k1), T_cam_from_gaze left 0.018 deg / 0.36 mm,
    right 0.008 deg / 0.98 mm (the clean bounds)."""
    code, _, err = run_cli(["render", "--out", tmp_path / "ds", "--distortion=-0.2,0.05",
                            "--quiet"], capsys)
    assert code == 0 and err == ""
    truth = read_json(tmp_path / "ds" / "ground_truth.json")
    code, _, err = run_cli(["calibrate", tmp_path / "ds", "--out", tmp_path / "cal.json",
                            "--quiet"], capsys)
    assert code == 0 and err == ""
    cal = read_json(tmp_path / "cal.json")
    for eye in EYES:
        assert truth[eye]["dist"] == [-0.2, 0.05, 0.0, 0.0, 0.0]
        assert cal["eyes"][eye]["dist_model"] == "k1k2"
        k1, k2 = cal["eyes"][eye]["dist"][:2]
        assert abs(k1 + 0.2) <= 0.005 and abs(k2 - 0.05) <= 0.01, (eye, k1, k2)
    assert_recovered(cal, truth)


def test_negative_option_value_without_equals_says_how(tmp_path, capsys):
    code, out, err = run_cli(["render", "--distortion", "-0.2,0.05", "--out", tmp_path / "d"],
                             capsys)
    assert code == 2 and out == "" and not (tmp_path / "d").exists()
    assert err.splitlines() == ["rasc render: error: argument --distortion: expected one "
                                "argument (a value starting with '-' is written with '=', "
                                "e.g. --distortion=-0.2) (see rasc render --help)"]


def test_distortion_warp_is_rasc_sim_distort():
    """The warp render builds once per eye gives rasc.sim.scene.distort's pixels, image after
    image, grey or colour."""
    from rasc.sim.scene import distort, distortion_warp

    rng = np.random.default_rng(7)
    images = rng.integers(0, 256, (2, 120, 160), dtype=np.uint8)
    K = np.array([[150.0, 0, 79.5], [0, 151.0, 59.5], [0, 0, 1]])
    dist = np.array([-0.2, 0.05, 0.001, -0.002, 0.0])
    warp = distortion_warp(K, dist, (160, 120))
    for image in images:  # the same warp, reused
        warped = warp(image)
        np.testing.assert_array_equal(warped, distort(image, K, dist))
        assert not np.array_equal(warped, image)
        colour = warp(np.repeat(image[..., None], 3, axis=2))
        for c in range(3):
            np.testing.assert_array_equal(colour[..., c], warped)


def test_measured_mounts_replace_loop_closure(default, tmp_path, capsys):
    """--mounts: the base uses the given T_ptuL_from_ptuR (here the truth turned by 0.5 deg
    and moved by 2 mm, the paper's measured-mount accuracy); hand-eye does not change."""
    truth = read_json(default / "ds" / "ground_truth.json")
    T_given = perturb_mounts(np.asarray(truth["T_ptuL_from_ptuR"]), 0.5, 2e-3,
                             np.random.default_rng(11))
    mounts = tmp_path / "mounts.json"
    mounts.write_text(json.dumps({"T_ptuL_from_ptuR": T_given.tolist()}))
    code, _, err = run_cli(["calibrate", default / "ds", "--mounts", mounts, "--model", "paper",
                            "--out", tmp_path / "cal.json", "--quiet"], capsys)
    assert code == 0 and err == ""
    cal, loop_cal = read_json(tmp_path / "cal.json"), read_json(default / "cal.json")
    base = cal["base_to_ptu"]
    assert base["source"] == "measured mounts"
    np.testing.assert_array_equal(base["T_ptuL_from_ptuR"], T_given)  # JSON keeps floats
    for eye, T in zip(EYES, cyclopean_base(T_given), strict=True):
        np.testing.assert_allclose(cal["eyes"][eye]["T_ptu_from_base"], T, atol=1e-12)
        assert cal["eyes"][eye]["T_cam_from_gaze"] == loop_cal["eyes"][eye]["T_cam_from_gaze"]
    # errors against the truth are the perturbation chosen (1e-9: rounding)
    err_mounts = cal["errors_against_truth"]["T_ptuL_from_ptuR"]
    assert err_mounts["rotation_deg"] == pytest.approx(0.5, abs=1e-9)
    assert err_mounts["translation"] == pytest.approx(2e-3, abs=1e-9)
    # loop closure is still computed and reported beside it
    assert base["loop_closure"]["T_ptuL_from_ptuR"] == \
        loop_cal["base_to_ptu"]["loop_closure"]["T_ptuL_from_ptuR"]


@pytest.mark.slow
def test_small_board_is_refused_or_warned_at_render(tmp_path, capsys):
    """At 4.6 m the default board's squares are 12.5 px, where the detector was measured
    to find none: an error before anything is rendered. At 4.3 m (13.4 px, all found
    but close to the limit) a warning, printed even with --quiet (a warning is no
    progress)."""
    code, out, err = run_cli(["render", "--out", tmp_path / "far", "--distance", 4.6,
                              "--intrinsics-views", 3, "--poses", "0,0;8,0;0,8"], capsys)
    assert code == 2 and out == "" and not (tmp_path / "far").exists()
    assert err.splitlines() == ["rasc render: error: --distance 4.6: board squares would be "
                                "only 12.5 px in the pose views, where corner detection fails "
                                "(measured: none found at 12.5 px); bring the board closer"]
    assert os.listdir(tmp_path) == []
    code, _, err = run_cli(["render", "--out", tmp_path / "ds", "--distance", 4.3, "--quiet",
                            "--intrinsics-views", 3, "--poses", "0,0;8,0;0,8"], capsys)
    assert code == 0
    assert err.splitlines() == ["rasc render: warning: board squares are only 13.4 px in the "
                                "pose views at --distance 4.3; corner detection was measured "
                                "to fail below ~13 px"], err


# -------------------------------------------------------------- calibrate: bad inputs

@pytest.fixture
def copy(default, tmp_path):
    """A fresh copy of the default dataset, and an empty folder for --out."""
    shutil.copytree(default / "ds", tmp_path / "ds")
    (tmp_path / "out").mkdir()
    return tmp_path


def fails(argv, capsys, out_dir: Path, command: str) -> str:
    """Exit 2, one line on stderr, nothing on stdout, nothing in ``out_dir``."""
    code, out, err = run_cli(argv, capsys)
    lines = err.splitlines()
    assert code == 2 and out == "", (code, err)
    assert len(lines) == 1 and lines[0].startswith(f"rasc {command}: error: "), err
    assert sorted(os.listdir(out_dir)) == []
    return lines[0]


def edit_manifest(folder: Path, change) -> None:
    m = read_json(folder / "manifest.json")
    change(m)
    (folder / "manifest.json").write_text(json.dumps(m))


def index_of(folder: Path, file: str) -> int:
    return [im["file"] for im in read_json(folder / "manifest.json")["images"]].index(file)


def blank(path: Path, size=(1280, 960)) -> None:
    cv2.imwrite(str(path), np.full(size[::-1], 235, np.uint8))


def _truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[:300])  # PNG header intact, pixels cut off


def _resize(path: Path) -> None:
    cv2.imwrite(str(path), cv2.resize(cv2.imread(str(path), cv2.IMREAD_GRAYSCALE), (640, 480)))


def _degenerate_intrinsics(ds: Path) -> None:
    """Three left intrinsics views that are one view three times: focal length unknown."""
    for k in (1, 2):
        shutil.copy(ds / "intrinsics/left_000.png", ds / f"intrinsics/left_00{k}.png")
    edit_manifest(ds, lambda m: m.__setitem__("images", [
        im for im in m["images"] if not (im["eye"] == "left" and im["role"] == "intrinsics"
                                         and im["file"] > "intrinsics/left_002.png")]))


def _too_few_pose_views(ds: Path) -> None:
    for k in range(2, 9):
        blank(ds / f"poses/left_{k:02d}.png")


CALIBRATE_CASES = {
    # name: (change to the copied dataset, message after "<manifest>: ")
    "missing image": (lambda ds: (ds / "poses/left_03.png").unlink(),
                      r"images\[46\] \(poses/left_03.png\): file does not exist"),
    "unreadable image": (lambda ds: (ds / "poses/left_03.png").write_text("not a PNG"),
                         r"images\[46\] \(poses/left_03.png\): cannot read"),
    "truncated image": (lambda ds: _truncate(ds / "poses/right_05.png"),
                        r"images\[\d+\] \(poses/right_05.png\): cannot read image"),
    "manifest names a missing file": (
        lambda ds: edit_manifest(ds, lambda m: m["images"].append(
            {"file": "poses/left_99.png", "eye": "left", "role": "pose", "pan": 1.0,
             "tilt": 2.0, "view": "99"})),
        r"images\[58\] \(poses/left_99.png\): file does not exist"),
    "manifest lacks pan": (
        lambda ds: edit_manifest(ds, lambda m: m["images"][50].pop("pan")),
        r"images\[50\] \(poses/left_05.png\): missing field 'pan'"),
    "manifest lacks eye": (
        lambda ds: edit_manifest(ds, lambda m: m["images"][3].pop("eye")),
        r"images\[3\] \(intrinsics/left_003.png\): missing field 'eye'"),
    "manifest lacks board": (lambda ds: edit_manifest(ds, lambda m: m.pop("board")),
                             r"missing field 'board'"),
    "manifest is not JSON": (lambda ds: (ds / "manifest.json").write_text("{\n  'format'"),
                             r"malformed JSON"),
    "mixed image sizes in one eye": (
        lambda ds: _resize(ds / "poses/right_04.png"),
        r"images\[\d+\] \(poses/right_04.png\) is 640x480 but intrinsics/right_000.png is "
        r"1280x960: all right images must have one size"),
    "board in too few pose views": (
        _too_few_pose_views,
        r"left pose images: board 9x6 found in 2 of 9 \(first without: poses/left_02.png\) "
        r"though the intrinsics images show it; hand-eye needs at least 3 pan-tilt"),
    "pan/tilt written in radians, angle_unit deg": (
        lambda ds: edit_manifest(ds, lambda m: [
            e.update(pan=math.radians(e["pan"]), tilt=math.radians(e["tilt"]))
            for e in m["images"] if e["role"] == "pose"]),
        r"left pose images: the unit's motions turn 0\.017\d× as far as the camera's .*: "
        r"read as rad the angles match \(1×\); set angle_unit to 'rad'"),
    "no intrinsics images for one eye": (
        lambda ds: edit_manifest(ds, lambda m: m.__setitem__("images", [
            e for e in m["images"] if not (e["role"] == "intrinsics" and e["eye"] == "right")])),
        r"no intrinsics images of the right eye \(role 'intrinsics': views of the board moved "
        r"in front of the fixed camera\)"),
    "fewer than 3 pose images": (
        lambda ds: edit_manifest(ds, lambda m: m.__setitem__("images", [
            e for e in m["images"] if not (e["role"] == "pose" and e["eye"] == "right"
                                           and e["view"] not in ("00", "01"))])),
        r"right pose images: 2 in the manifest; hand-eye needs at least 3 images with role "
        r"'pose'"),
    "wrong board size": (
        lambda ds: edit_manifest(ds, lambda m: m["board"].__setitem__("inner_corners",
                                                                      [10, 7])),
        r"left intrinsics images: board 10x7 not found in 20 of 20 \(first: "
        r"intrinsics/left_000.png\): check board.inner_corners"),
    "board missing from most intrinsics views": (
        lambda ds: [blank(ds / f"intrinsics/right_{k:03d}.png") for k in range(11)],
        r"right intrinsics images: board 9x6 not found in 11 of 20 \(first: "
        r"intrinsics/right_000.png\): check those images \(the whole board in view, sharp, "
        r"evenly lit\), then check board.inner_corners"),
    "degenerate intrinsics views": (
        _degenerate_intrinsics,
        r"left intrinsics images: calibrate_intrinsics: all 3 views show the board at nearly "
        r"the same orientation .* add views with the board tilted"),
    "malformed ground truth": (
        lambda ds: (ds / "ground_truth.json").write_text('{"views": {}}'),
        None),  # checked below: the error names ground_truth.json, not the manifest
}


@pytest.mark.parametrize("case", list(CALIBRATE_CASES))
def test_calibrate_bad_input(case, copy, capsys):

    change, message = CALIBRATE_CASES[case]
    ds = copy / "ds"
    change(ds)
    line = fails(["calibrate", ds, "--out", copy / "out" / "cal.json", "--quiet"], capsys,
                 copy / "out", "calibrate")
    if message is None:
        assert line == f"rasc calibrate: error: {ds / 'ground_truth.json'}: missing field " \
                       "'left'"
    else:
        assert re.match(rf"rasc calibrate: error: {re.escape(str(ds / 'manifest.json'))}: "
                        rf"{message}", line), line


def test_length_unit_from_the_manifest_reaches_the_calibration(default, copy, capsys):
    """rasc render states metres; a manifest without length_unit gives a calibration that
    says its lengths are in the board's square_size unit. (--model paper: the unit is read
    from the manifest before any model is fitted, and the default model's calibration of
    this dataset says "m" too, default_cli_run's cal.json; the paper model saves the
    whole-head refinement, about 1 s of CPU per calibration.)"""
    ds = copy / "ds"
    assert read_json(ds / "manifest.json")["length_unit"] == "m"
    assert read_json(default / "cal.json")["length_unit"] == "m"    # --model general
    code, _, _ = run_cli(["calibrate", ds, "--model", "paper", "--out", copy / "m.json",
                          "--quiet"], capsys)
    assert code == 0 and read_json(copy / "m.json")["length_unit"] == "m"
    edit_manifest(ds, lambda m: m.pop("length_unit"))
    code, _, _ = run_cli(["calibrate", ds, "--model", "paper", "--out", copy / "none.json",
                          "--quiet"], capsys)
    assert read_json(copy / "none.json")["length_unit"] == \
        "that of the dataset's board.square_size"


def test_calibrate_li_names_its_home_view(copy, capsys):
    """--method li: each eye's output names the home view (the (0, 0) one, "00"); without
    a (0, 0) view the first is taken, with a warning per eye. (--model paper: the home
    view is the hand-eye step's, before any whole-head refinement, which would cost about
    1 s of CPU per calibration.)"""
    ds = copy / "ds"
    code, _, err = run_cli(["calibrate", ds, "--method", "li", "--model", "paper", "--out",
                            copy / "li.json", "--quiet"], capsys)
    cal = read_json(copy / "li.json")
    assert code == 0 and err == ""
    assert [cal["eyes"][eye]["handeye_home_view"] for eye in EYES] == ["00", "00"]
    edit_manifest(ds, lambda m: m.__setitem__("images", [
        e for e in m["images"] if not (e["role"] == "pose" and e["pan"] == e["tilt"] == 0)]))
    code, _, err = run_cli(["calibrate", ds, "--method", "li", "--model", "paper", "--out",
                            copy / "li2.json", "--quiet"], capsys)
    assert code == 0
    assert [line.split(": ")[2] for line in err.splitlines()] == ["left eye", "right eye"]
    assert all("no position at pan = tilt = 0: Li's home is the first position" in line
               and line.endswith("add a pose view at (0, 0)") for line in err.splitlines())
    cal = read_json(copy / "li2.json")
    first = [cal["eyes"][eye]["pose_views"][0]["view"] for eye in EYES]
    assert [cal["eyes"][eye]["handeye_home_view"] for eye in EYES] == first


def test_calibrate_warns_when_pan_turns_the_other_way(copy, capsys):
    """Every pose's pan negated (a unit whose pan turns the other way than eq. 3): the
    calibration is written, and each eye warns that its camera looks backwards."""
    ds = copy / "ds"
    edit_manifest(ds, lambda m: [e.update(pan=-e["pan"]) for e in m["images"]
                                 if e["role"] == "pose"])
    code, out, err = run_cli(["calibrate", ds, "--out", copy / "cal.json", "--quiet"], capsys)
    assert code == 0 and (copy / "cal.json").is_file()
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert [w.split(":")[2].strip() for w in warnings] == ["left eye", "right eye"], warnings
    assert all("optical axis points backwards" in w for w in warnings)
    cal = read_json(copy / "cal.json")
    assert cal["eyes"]["left"]["handeye_uncertainty"]["rotation_deg"] < 0.1


def test_calibrate_bad_input_with_progress_ends_with_the_one_error_line(copy, capsys):
    ds = copy / "ds"
    _too_few_pose_views(ds)
    code, out, err = run_cli(["calibrate", ds, "--out", copy / "out" / "cal.json"], capsys)
    lines = err.splitlines()
    assert code == 2 and out == "" and os.listdir(copy / "out") == []
    assert [line for line in lines if "error" in line] == [lines[-1]]
    assert lines[-1].startswith("rasc calibrate: error: ") and lines[0].startswith("calibrate:")


def test_calibrate_missing_dataset_and_output_folder(copy, capsys):
    line = fails(["calibrate", copy / "nowhere", "--quiet"], capsys, copy / "out", "calibrate")
    assert line == f"rasc calibrate: error: {copy / 'nowhere'}: no such dataset folder"
    (copy / "empty").mkdir()
    line = fails(["calibrate", copy / "empty", "--quiet"], capsys, copy / "out", "calibrate")
    assert f"{copy / 'empty' / 'manifest.json'}: no manifest" in line
    line = fails(["calibrate", copy / "ds", "--out", copy / "no" / "cal.json", "--quiet"],
                 capsys, copy / "out", "calibrate")
    assert line.endswith(f"{copy / 'no' / 'cal.json'}: cannot write: folder {copy / 'no'} "
                         "does not exist")


def test_mounts_in_another_unit_or_far_from_loop_closure(default, tmp_path, capsys):
    """The true mounts in millimetres (a 300 m baseline) are refused: loop closure says
    0.3; the true mounts turned by 5° are used, with a warning that they and loop closure
    disagree (the paper: loop closure 2-3° off at worst)."""
    truth = np.asarray(read_json(default / "ds" / "ground_truth.json")["T_ptuL_from_ptuR"])
    in_mm = truth.copy()
    in_mm[:3, 3] *= 1000.0
    mounts = tmp_path / "mounts.json"
    mounts.write_text(json.dumps({"format": "rasc-mounts/1", "T_ptuL_from_ptuR": in_mm.tolist(),
                                  "description": "measured with calipers"}))
    (tmp_path / "out").mkdir()
    line = fails(["calibrate", default / "ds", "--mounts", mounts, "--out",
                  tmp_path / "out" / "cal.json", "--quiet"], capsys, tmp_path / "out",
                 "calibrate")
    # the model's baseline is 0.300 m (sim/models/README.md), loop closure 0.56 mm off
    # loop closure's baseline, printed to 4 significant digits, is within 1 mm of 0.3 m
    assert re.fullmatch(r"rasc calibrate: error: the measured mounts \(T_ptuL_from_ptuR\) put "
                        r"the units 300 apart but loop closure measures 0\.(29\d*|30\d*|3) "
                        r"\(in the unit of board\.square_size\): give its translation in that "
                        r"unit", line), line
    turned = perturb_mounts(truth, 5.0, 0.0, np.random.default_rng(2))
    mounts.write_text(json.dumps({"T_ptuL_from_ptuR": turned.tolist()}))
    code, _, err = run_cli(["calibrate", default / "ds", "--mounts", mounts, "--model", "paper",
                            "--out", tmp_path / "cal.json", "--quiet"], capsys)
    assert code == 0
    # (the rotation alone was perturbed: the translations differ by loop closure's 0.56 mm)
    (line,) = err.splitlines()
    assert re.fullmatch(r"rasc calibrate: warning: the measured mounts and loop closure differ "
                        r"by 5° and 0\.000\d+ \(baseline 0\.3\): one of them is wrong; check "
                        r"the mounts' frames \(T_ptuL_from_ptuR: the right unit's frame in the "
                        r"left one\) and the hand-eye warnings", line), line
    cmp = read_json(tmp_path / "cal.json")["base_to_ptu"]["measured_vs_loop_closure"]
    assert cmp["rotation_deg"] == pytest.approx(5.0, abs=0.05)   # loop closure: 0.02° off


def _rigid_but_scaled() -> dict:
    T = np.eye(4)
    T[:3, :3] *= 1.1
    return {"T_ptuL_from_ptuR": T.tolist()}


@pytest.mark.parametrize("content, fragment", [
    (None, "no such file (the mounts file)"),
    ("{not json", "malformed JSON at line 1, column 2"),
    (json.dumps({"T": np.eye(4).tolist()}), "expected an object with field T_ptuL_from_ptuR"),
    (json.dumps(_rigid_but_scaled()), "T_ptuL_from_ptuR"),
    (json.dumps({"T_ptuL_from_ptuR": [[1, 0], [0, 1]]}), "T_ptuL_from_ptuR"),
    (json.dumps({"T_ptuL_from_ptuR": np.eye(4).tolist(), "length_unit": "mm"}),
     "unknown key 'length_unit'; allowed: format, T_ptuL_from_ptuR, description"),
    (json.dumps({"T_ptuL_from_ptuR": np.eye(4).tolist(), "format": "rasc-mounts/2"}),
     "format = 'rasc-mounts/2': expected 'rasc-mounts/1'"),
])
def test_calibrate_bad_mounts_file(content, fragment, copy, capsys):
    mounts = copy / "mounts.json"
    if content is not None:
        mounts.write_text(content)
    line = fails(["calibrate", copy / "ds", "--mounts", mounts, "--out",
                  copy / "out" / "cal.json", "--quiet"], capsys, copy / "out", "calibrate")
    assert line.startswith(f"rasc calibrate: error: {mounts}: ") and fragment in line, line


# ------------------------------------------------------------------ render: bad inputs

RENDER_CASES = {
    # name: (extra arguments, message fragment); "{out}" is the --out folder
    "poses syntax": (["--poses", "1,2;3"],
                     '--poses[1]: expected 2 numbers (pan,tilt in degrees), got 1: "3"'),
    "too few poses": (["--poses", "0,0;8,8"], "--poses: need at least 3 pan-tilt positions"),
    "pose not finite": (["--poses", "0,0;nan,8;8,0"],
                        '--poses[1][0]: must be finite, got "nan"'),
    "pose outside the joint range": (
        ["--poses", "0,0;8,8;100,0"],
        "--poses: item 2 (100,0): left pan = 100 deg is outside the joint range [-60, 60]"),
    "distortion not numbers": (["--distortion", "a,b"],
                               '--distortion[0]: expected a number, got "a"'),
    "distortion too long": (["--distortion", "0.1,0.2,0,0,0,0"],
                            "--distortion: at most 5 coefficients"),
    "distortion not finite": (["--distortion", "nan"],
                              '--distortion[0]: must be finite, got "nan"'),
    "fisheye with five coefficients": (
        ["--lens", "fisheye", "--distortion", "0.1,0,0,0,0"],
        "--distortion: a fisheye lens has at most 4 coefficients (k1,k2,k3,k4), got 5"),
    "pinhole of 180 degrees": (["--fov", "180"], "--fov must be a field of view in degrees, "
                               "above 0 and below 180 for a pinhole lens"),
    "fisheye past its fold": (["--lens", "fisheye", "--fov", "170", "--distortion=-0.5,0,0,0"],
                              "--fov 170 deg lies past the lens model's fold"),
    "defocus through a fisheye": (["--lens", "fisheye", "--focus-distance", "1"],
                                  "--focus-distance: defocus is not rendered through --lens "
                                  "fisheye"),
    "distortion pushes the board out": (
        ["--distortion", "0.3"],
        "--distortion 0.3,0,0,0,0: at pan, tilt = (8, 8) deg the distortion moves corners "
        "of the board outside the left image"),
    "board too close": (["--distance", "0.6"],
                        "--distance 0.6: at pan, tilt = (0, 0) deg the corners"),
    "distance not finite": (["--distance", "inf"], "--distance: must be finite, got Infinity"),
    "negative seed": (["--seed", "-1"], "--seed must be an integer from 0 to 2**63-1, got -1"),
    "negative noise": (["--noise", "-1"], "--noise must be a number from 0 to 255"),
    "blur not finite": (["--blur", "nan"], "--blur: must be finite, got NaN"),
    "too few intrinsics views": (["--intrinsics-views", "2"],
                                 "--intrinsics-views: need an integer of at least 3"),
    "missing model": (["--model", "{tmp}/nowhere.xml"], "--model {tmp}/nowhere.xml: file not"),
    "model without target": (["--model", str(HEAD_XML)],
                             f"{HEAD_XML}: the model has no calibration target"),
    "model with a bad target": (["--model", str(HEAD_XML), "--target", "charuco:12x9,0.06"],
                                "--target 'charuco:12x9,0.06': expected charuco:SXxSY"),
}


@pytest.mark.parametrize("case", list(RENDER_CASES))
def test_render_bad_input(case, tmp_path, capsys):
    extra, fragment = RENDER_CASES[case]
    extra = [a.replace("{tmp}", str(tmp_path)) for a in extra]
    parent = tmp_path / "parent"
    parent.mkdir()
    line = fails(["render", "--out", parent / "ds", "--quiet", *extra], capsys, parent,
                 "render")
    assert fragment.replace("{tmp}", str(tmp_path)) in line, line


def test_render_out_folder_problems(tmp_path, capsys):
    parent = tmp_path / "parent"
    (parent / "full").mkdir(parents=True)
    (parent / "full" / "keep.txt").write_text("mine")
    (parent / "file").write_text("mine")
    before = files_of(parent)
    for out, message in (
            (parent / "full", f"--out {parent / 'full'}: exists and is not empty; rasc render "
                              "never replaces files: name a new folder, or remove this one "
                              "first"),
            (parent / "file", f"--out {parent / 'file'}: exists as a file; name a new folder"),
            (parent / "no" / "ds", f"{parent / 'no' / 'ds'}: cannot write: folder "
                                   f"{parent / 'no'} does not exist")):
        code, stdout, err = run_cli(["render", "--out", out, "--quiet"], capsys)
        assert code == 2 and stdout == ""
        assert err.splitlines() == [f"rasc render: error: {message}"]
    assert files_of(parent) == before and sorted(os.listdir(parent)) == ["file", "full"]
