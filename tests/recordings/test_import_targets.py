"""rasc import takes every target rasc reads (chessboard, ChArUco, AprilGrid, a Kalibr
target yaml), through the one reader of targets (rasc.vision.board), by both doors: a
bag with its TOML configuration and a folder of images with a CSV of angles.

The outcome tests render a small dataset with the target seen in part (the (30°, 0)
position shows a part of it in each eye), play it into a recording, import it through
the command line, and check that the manifest names the target, that detection on the
imported images finds the renderer's corners (the ids the truth lists, at the truth's
pixels), and that the imported dataset calibrates to the rendered one's calibration
(PNG is lossless and the readings at rest are the rendered angles) and near the truth.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rasc.errors import InputError
from rasc.recordings import ImportConfig, load_config
from rasc.recordings.synth import write_intrinsics_recording, write_recording
from rasc.vision.board import parse_target

from rendered_views import seen_against_truth

CHARUCO = "charuco:12x9,0.06,0.045"
APRILGRID = "aprilgrid:7x5,0.08,0.3"
KALIBR_YAML = "target_type: 'aprilgrid'\ntagCols: 7\ntagRows: 5\ntagSize: 0.08\ntagSpacing: 0.3\n"
#: three intrinsics views per eye and five positions, (30, 0) showing part of the target
SMALL = {"intrinsics_views": 3,
         "poses_deg": [[0, 0], [8, 8], [30, 0], [-8, -8], [8, -8]]}
TOPICS_JOINTS = ('[topics]\nleft = "/left/image_raw"\nright = "/right/image_raw"\n'
                 '[joints]\nleft = {topic = "/joint_states", pan = "left_pan", '
                 'tilt = "left_tilt"}\nright = {topic = "/joint_states", pan = "right_pan", '
                 'tilt = "right_tilt"}\n')


def _check_imported(imported_path, rendered, spec):
    """The manifest names the target; each pose image's detection finds only corners the
    renderer's truth lists inside the image, within 0.1 px RMS of them (the saddle
    detector: 0.01-0.04 px on such renders, docs/topics/targets.md; a corner given the
    wrong id is a square, tens of pixels, off), some view in part; the calibration is the
    rendered dataset's and near the truth. Returns the corners found per pose image."""
    from rasc.head.pipeline import calibrate_dataset
    from rasc.vision.camera import detect_corners
    from rasc.vision.dataset import load_dataset

    board = parse_target(spec)
    manifest = json.loads((imported_path / "manifest.json").read_text())
    assert manifest["board"] == board.to_dict()
    ds = load_dataset(imported_path)
    assert ds.board == board
    truth_file = {(e.eye, e.view): e for e in rendered.select(role="pose")}
    found = []
    for e in ds.select(role="pose"):
        src = truth_file[(e.eye, e.view)]
        # exact from a bag; from a CSV's degrees to the last bit of the radians
        assert abs(e.pan - src.pan) <= 1e-15 and abs(e.tilt - src.tilt) <= 1e-15
        corners = detect_corners(ds.read(e), board, "saddle")   # calibrate's default
        assert corners is not None, e.file
        seen, rms = seen_against_truth(corners, rendered.truth["views"][src.file]["corners"])
        assert rms < 0.1, (e.file, rms)
        found.append(len(seen))
    assert min(found) < board.n_corners and max(found) == board.n_corners, found
    cal = calibrate_dataset(ds)
    ref = calibrate_dataset(rendered)
    for eye in ("left", "right"):
        a, b = getattr(cal.head, eye), getattr(ref.head, eye)
        # the same images and angles: the same calibration, to rounding (a wrong pairing
        # of images and angles moves the hand-eye by millimetres)
        assert np.max(np.abs(a.K - b.K)) < 1e-6
        assert np.max(np.abs(a.T_cam_from_gaze - b.T_cam_from_gaze)) < 1e-9
        # and near the renderer's truth: 0.04-0.07 mm and under 0.002 deg measured here;
        # 1 mm and 0.1 deg are far below a wrong corner order or frame (cm, degrees)
        d = np.linalg.inv(rendered.T_cam_from_gaze(eye)) @ a.T_cam_from_gaze
        assert np.linalg.norm(d[:3, 3]) < 1e-3, (eye, d[:3, 3])
        angle = math.degrees(math.acos(np.clip((np.trace(d[:3, :3]) - 1) / 2, -1, 1)))
        assert angle < 0.1, (eye, angle)
    return found


@pytest.mark.slow
def test_charuco_seen_in_part_imported_from_a_bag_calibrates(rasc_render, rasc_cli,
                                                             tmp_path):
    """A ChArUco board named in the configuration's [board] table (the manifest's board
    object), a ROS 1 bag of PNG images and a ROS 2 MCAP bag of intrinsics views."""
    rendered = rasc_render(target=CHARUCO, **SMALL)
    write_recording(rendered, tmp_path / "pose.bag", encoding="png", image_rate_hz=2.0)
    write_intrinsics_recording(rendered, tmp_path / "intr", kind="ros2-mcap", encoding="png")
    cfg = tmp_path / "import.toml"
    cfg.write_text('[board]\ntype = "charuco"\nsquares = [12, 9]\nsquare_size = 0.06\n'
                   'marker_size = 0.045\nlength_unit = "m"\n' + TOPICS_JOINTS)
    code, _, err = rasc_cli("import", tmp_path / "pose.bag", "--intrinsics", tmp_path / "intr",
                            "--config", cfg, "--out", tmp_path / "ds", "--quiet")
    assert code == 0, err
    found = _check_imported(tmp_path / "ds", rendered, CHARUCO)
    assert len(found) == 2 * len(SMALL["poses_deg"])


@pytest.mark.slow
def test_aprilgrid_from_a_kalibr_yaml_imported_from_a_csv_folder_calibrates(
        rasc_render, rasc_cli, tmp_path):
    """An AprilGrid given as Kalibr's target yaml (``--target FILE.yaml``), the rendered
    images with a CSV of their angles in degrees (printed with repr: read back exactly)."""
    rendered = rasc_render(target=APRILGRID, **SMALL)
    (tmp_path / "aprilgrid.yaml").write_text(KALIBR_YAML)
    rows = ["file,eye,pan,tilt,view"]
    for e in rendered.images:
        rows.append(f"{e.file},{e.eye},{math.degrees(e.pan)!r},{math.degrees(e.tilt)!r},"
                    f"{e.view}" if e.role == "pose" else f"{e.file},{e.eye},,,")
    (tmp_path / "angles.csv").write_text("\n".join(rows) + "\n")
    code, _, err = rasc_cli("import", rendered.path, "--csv", tmp_path / "angles.csv",
                            "--target", tmp_path / "aprilgrid.yaml", "--angle-unit", "deg",
                            "--length-unit", "m", "--out", tmp_path / "ds", "--quiet")
    assert code == 0, err
    found = _check_imported(tmp_path / "ds", rendered, APRILGRID)
    assert len(found) == 2 * len(SMALL["poses_deg"])


# ---------------------------------------------------------------- the configuration

@pytest.mark.parametrize("board_toml, spec", [
    ('[board]\ninner_corners = [9, 6]\nsquare_size = 0.05\n', "chessboard:9x6,0.05"),
    ('[board]\ntype = "charuco"\nsquares = [12, 9]\nsquare_size = 0.06\nmarker_size = 0.045\n'
     'dictionary = "DICT_5X5_100"\n', CHARUCO),
    ('[board]\ntype = "aprilgrid"\ntags = [7, 5]\ntag_size = 0.08\ntag_spacing = 0.3\n',
     APRILGRID),
    ('[board]\ntarget_type = "aprilgrid"\ntagCols = 7\ntagRows = 5\ntagSize = 0.08\n'
     'tagSpacing = 0.3\n', APRILGRID),
    ('target = "charuco:12x9,0.06,0.045"\n', CHARUCO),
    ('target = "aprilgrid.yaml"\n', APRILGRID),
], ids=["chessboard", "charuco", "aprilgrid", "kalibr fields", "inline", "kalibr yaml"])
def test_the_configuration_names_any_target(tmp_path, monkeypatch, board_toml, spec):
    """Each way of naming a target gives the target the same description gives
    ``rasc render --target``; a Kalibr yaml named by a relative path is read beside the
    configuration file (the working directory elsewhere)."""
    folder = tmp_path / "config"
    folder.mkdir()
    (folder / "aprilgrid.yaml").write_text(KALIBR_YAML)
    (folder / "import.toml").write_text(board_toml + TOPICS_JOINTS)
    monkeypatch.chdir(tmp_path)
    cfg = load_config(folder / "import.toml")
    assert cfg.target() == parse_target(spec)
    assert cfg.board == parse_target(spec).to_dict()


@pytest.mark.parametrize("board_toml, match", [
    ('[board]\ntype = "charuco"\nsquares = [12, 9]\nsquare_size = 0.06\n',
     r"import\.toml: board: missing field 'marker_size'$"),
    ('[board]\ntype = "aprilgrid"\ntags = [7, 5]\ntag_size = 0.08\nsquare_size = 0.05\n',
     r"import\.toml: board: unknown field 'square_size' for a aprilgrid target$"),
    ('target = "charuco:12x9,0.06"\n', r"import\.toml: target 'charuco:12x9,0\.06': expected "
                                       r"charuco:SXxSY"),
    ('target = "missing.yaml"\n', r"import\.toml: target 'missing\.yaml': no such file "
                                r"beside the configuration"),
    ('target = "charuco:12x9,0.06,0.045"\n[board]\ninner_corners = [9, 6]\n'
     'square_size = 0.05\n', r"import\.toml: \[board\] and target both name the target"),
    ('board = 3\n', r"import\.toml: \[board\] must be a table$"),
], ids=["charuco missing field", "aprilgrid unknown field", "inline form", "no such file",
        "both", "not a table"])
def test_a_bad_target_in_the_configuration_is_one_line(tmp_path, board_toml, match):
    (tmp_path / "import.toml").write_text(board_toml + TOPICS_JOINTS)
    with pytest.raises(InputError, match=match) as info:
        load_config(tmp_path / "import.toml")
    assert "\n" not in str(info.value)


def test_a_bad_target_given_in_python_is_refused_before_anything_is_written(tmp_path):
    """ImportConfig's board is checked by the target reader before the import reads or
    writes anything (it failed in the final check, naming the temporary folder)."""
    from rasc.recordings import import_image_folder

    (tmp_path / "imgs").mkdir()
    (tmp_path / "a.csv").write_text("file,eye\n")
    cfg = ImportConfig(board={"type": "charuco", "squares": [12, 9], "square_size": 0.06})
    with pytest.raises(InputError, match=r"^options: board: missing field 'marker_size'$"):
        import_image_folder(tmp_path / "imgs", tmp_path / "a.csv", tmp_path / "ds", cfg)
    assert not (tmp_path / "ds").exists()


def test_cli_target_and_board_do_not_go_together(tmp_path, rasc_cli):
    (tmp_path / "imgs").mkdir()
    (tmp_path / "a.csv").write_text("file,eye\n")
    code, out, err = rasc_cli("import", tmp_path / "imgs", "--csv", tmp_path / "a.csv",
                              "--target", CHARUCO, "--board", "9x6", "--square-size", "0.05",
                              "--out", tmp_path / "ds")
    assert code == 2 and out == ""
    assert err == ("rasc import: error: --target names the whole target: give --target or "
                   "--board with --square-size, not both\n")
    code, out, err = rasc_cli("import", tmp_path / "imgs", "--csv", tmp_path / "a.csv",
                              "--target", "charuco:12x9", "--out", tmp_path / "ds")
    assert code == 2 and err.startswith("rasc import: error: --target 'charuco:12x9': "
                                        "expected charuco:") and err.count("\n") == 1
    assert not (tmp_path / "ds").exists()
