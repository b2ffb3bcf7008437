"""``rasc rectify``: the geometry and the rectified images it writes, and its refusals
(one line, exit status 2, nothing written)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rasc.vision.images import read_image, write_image

EYES = ("left", "right")


@pytest.fixture
def pair_files(tmp_path, gaze_pairs):
    """The true head as rasc-head/1 and the 'asymmetric' gaze's renders as PNG files."""
    head, board, pairs = gaze_pairs
    g = next(p for p in pairs if p.name == "asymmetric")
    (tmp_path / "head.json").write_text(json.dumps(head.to_dict()))
    for eye in EYES:
        write_image(tmp_path / f"{eye}.png", g.images[eye])
    readings = {eye: ",".join(repr(float(np.degrees(a))) for a in getattr(g, eye)) for eye in EYES}
    return tmp_path, readings, board, g


def _argv(root, readings, *more):
    return ("rectify", str(root / "head.json"), f"--left-readings={readings['left']}",
            f"--right-readings={readings['right']}", "--angle-unit", "deg", *more)


@pytest.mark.slow
def test_writes_geometry_and_rectified_images_whose_corners_share_rows(rasc_cli,
                                                                        pair_files):
    from rasc.stereo.rectify import rectify_head
    from rasc.vision.camera import detect_corners

    root, readings, board, g = pair_files
    out = root / "out"
    status, stdout, stderr = rasc_cli(*_argv(root, readings, "--left", str(root / "left.png"),
                                             "--right", str(root / "right.png"),
                                             "--out", str(out)))
    assert (status, stdout, stderr) == (0, "", "")
    doc = json.loads((out / "rectification.json").read_text())
    assert doc["format"] == "rasc-rectification/1" and doc["angle_unit"] == "deg"
    assert np.allclose([doc["readings"]["left"]["pan"], doc["readings"]["left"]["tilt"]],
                       np.degrees(g.left), atol=1e-9)
    # the geometry is the library's at these readings
    from rasc.head.model import HeadCalibration

    head = HeadCalibration.from_dict(json.loads((root / "head.json").read_text()))
    rect = rectify_head(head, g.left, g.right)
    for key in ("R1", "R2", "P1", "P2", "Q"):
        assert np.allclose(doc[key], getattr(rect, key), atol=1e-9), key
    assert doc["baseline"] == pytest.approx(rect.baseline)
    # the images: the board's corners on the same rows (fixed-point maps; detection-limited)
    found = [detect_corners(read_image(out / f"{eye}.png"), board) for eye in EYES]
    rows = np.sqrt(np.mean((found[0][:, 1] - found[1][:, 1]) ** 2))
    assert rows < 0.2, rows


@pytest.mark.slow
@pytest.mark.parametrize(("more", "message"), [
    (("--left", "{root}/left.png"), r"--left without --right"),
    (("--left", "{root}/left.png", "--right", "{root}/small.png"),
     r"--right .*small\.png: 12×10 pixels, the calibration's images are 1280×960"),
    (("--left", "{root}/left.png", "--right", "{root}/head.json"),
     r"head\.json: cannot read image"),
])
def test_refusals_write_nothing(rasc_cli, pair_files, more, message):
    import re

    root, readings, _, _ = pair_files
    write_image(root / "small.png", np.zeros((10, 12), np.uint8))
    out = root / "out"
    argv = _argv(root, readings, *(m.format(root=root) for m in more), "--out", str(out))
    status, stdout, stderr = rasc_cli(*argv)
    assert status == 2 and stdout == "" and len(stderr.splitlines()) == 1, stderr
    assert re.search(message, stderr), stderr
    assert not out.exists()


@pytest.mark.slow
@pytest.mark.parametrize(("left", "unit", "message"), [
    ("-10", "deg", r"--left-readings -10: expected 2 numbers"),
    ("-10,0", "rad", r"--left-readings -10,0: pan = -10 rad is beyond .*--angle-unit deg"),
    ("x,0", "deg", r"--left-readings x,0\[0\]: expected a number, got \"x\""),
])
def test_bad_readings_are_refused(rasc_cli, pair_files, left, unit, message):
    import re

    root, _, _, _ = pair_files
    out = root / "out"
    status, stdout, stderr = rasc_cli("rectify", str(root / "head.json"),
                                      f"--left-readings={left}", "--right-readings=0,0",
                                      "--angle-unit", unit, "--out", str(out))
    assert status == 2 and len(stderr.splitlines()) == 1 and re.search(message, stderr), \
        stderr
    assert not out.exists()


@pytest.mark.slow
@pytest.mark.parametrize("alpha", ["2", "nan", "-0.5"])
def test_alpha_outside_opencvs_range_is_refused(rasc_cli, pair_files, alpha):
    root, readings, _, _ = pair_files
    out = root / "out"
    status, _, stderr = rasc_cli(*_argv(root, readings, f"--alpha={alpha}", "--out",
                                        str(out)))
    assert status == 2 and stderr.splitlines() == [
        f"rasc rectify: error: --alpha: expected -1 (OpenCV's default scaling) or a number "
        f"from 0 to 1, got {float(alpha)!r}"], stderr
    assert not out.exists()
