"""``rasc detect`` (issue 25 item 5): images → the points CSV ``rasc triangulate`` reads,
with each image's detection status. Checked end to end on the default render: the
matched corners triangulate back onto a board of the right size."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest


def _rows(path):
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    return list(csv.DictReader(lines))


@pytest.mark.slow
def test_dataset_points_triangulate_onto_the_board(default_cli_run, rasc_cli, tmp_path):
    ds, cal = default_cli_run / "ds", default_cli_run / "cal.json"
    manifest = json.loads((ds / "manifest.json").read_text())
    poses = [im for im in manifest["images"] if im["role"] == "pose"]
    nx, ny = manifest["board"]["inner_corners"]
    square = manifest["board"]["square_size"]
    out = tmp_path / "points.csv"
    status, stdout, err = rasc_cli("detect", ds, "--out", out, "--quiet")
    assert status == 0 and stdout == "" and err == ""
    text = out.read_text()
    # the status of every pose image, one comment line each
    assert sum(line.startswith("# left ") or line.startswith("# right ")
               for line in text.splitlines()) == len(poses)
    rows = _rows(out)
    views = sorted({im["view"] for im in poses})
    assert len(rows) == len(views) * nx * ny
    status, stdout, err = rasc_cli("triangulate", cal, out, "--angle-unit", "deg")
    assert status == 0, err
    points = json.loads(stdout)["points"]
    # each pair is one corner seen twice: detectors are good to 0.02-0.05 px here, and a
    # corner matched to the wrong one reprojects tens of pixels away
    worst = max(max(p["residual_px"].values()) for p in points)
    assert worst < 0.2
    # adjacent corners of one view lie one square apart (0.05 m): at 1 m with 0.03 px
    # corners the depth error is ~0.1 mm; a wrong order or pairing is centimetres off
    p = np.array([q["p_base"] for q in points]).reshape(len(views), ny, nx, 3)
    steps = np.concatenate([np.linalg.norm(np.diff(p, axis=2), axis=-1).ravel(),
                            np.linalg.norm(np.diff(p, axis=1), axis=-1).ravel()])
    assert np.max(np.abs(steps - square)) < 0.5e-3


@pytest.mark.slow
def test_image_files_with_a_board_description(default_dataset, rasc_cli, tmp_path):
    import cv2

    ds = default_dataset
    manifest = json.loads((ds / "manifest.json").read_text())
    pose = {(im["eye"], im["view"]): im for im in manifest["images"] if im["role"] == "pose"}
    left, right = pose[("left", "03")], pose[("right", "03")]
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((960, 1280), 128, np.uint8))
    angles = f"{left['pan']},{left['tilt']},{right['pan']},{right['tilt']}"
    out = tmp_path / "pairs.csv"
    status, _, err = rasc_cli("detect", "--board", "9x6", "--angle-unit", "deg", "--quiet",
                              "--pair", ds / left["file"], ds / right["file"], angles,
                              "--pair", ds / left["file"], blank, angles, "--out", out)
    assert status == 0
    # one warning naming the image without the board; its view left out
    assert err.strip().splitlines() == [
        f"rasc detect: warning: board not found in 1 of 4 image(s) (first: {blank}); "
        "view(s) 2 left out"]
    assert f"# right {blank} (view 2): board not found" in out.read_text()
    rows = _rows(out)
    assert len(rows) == 54 and {r["label"].split(":")[0] for r in rows} == {"1"}
    # the same corners as the dataset door gives for that view
    whole = tmp_path / "whole.csv"
    assert rasc_cli("detect", ds, "--out", whole, "--quiet")[0] == 0
    same = [r for r in _rows(whole) if r["label"].startswith("03:")]
    keys = ("u_left", "v_left", "u_right", "v_right", "pan_left", "tilt_right")
    assert [[float(r[k]) for k in keys] for r in rows] == \
        [[float(r[k]) for k in keys] for r in same]


def test_refusals_are_one_line(rasc_cli, tmp_path):
    import cv2

    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.zeros((48, 64), np.uint8))
    board = tmp_path / "grid.json"           # a bare board object with a wrong field
    board.write_text('{"type": "aprilgrid", "tags": [6, 6], "tag_size": 0.088, '
                     '"family": "tag36h11"}')
    cases = [
        (["detect", "--board", board, "--angle-unit", "deg", "--pair", blank, blank,
          "0,0,0,0"], f"{board}: board: unknown family 'tag36h11'"),
        (["detect"], "give a dataset folder or --pair"),
        (["detect", "--pair", blank, blank, "0,0,0,0"], "--pair needs --board"),
        (["detect", "--board", "9x6", "--angle-unit", "deg", "--pair", blank, blank, "0,0"],
         "--pair 1 ("),
        (["detect", "--board", "9x6", "--angle-unit", "deg", "--pair", blank, blank,
          "0,0,0,0", "--out", blank], "is the input file"),
        (["detect", "--board", "9x6", "--angle-unit", "deg", "--pair", blank, blank,
          "0,0,0,0"], "no view has the board in both its left and right image"),
    ]
    for argv, message in cases:
        status, out, err = rasc_cli(*argv)
        assert status == 2 and out == "", argv
        said = [line for line in err.splitlines() if not line.startswith("detect: ")]
        assert len(said) == 1 and said[0].startswith("rasc detect: error: ") \
            and message in said[0], (argv, err)         # (progress lines aside)
    assert blank.stat().st_size > 0


def test_board_file_holds_the_bare_board_object_of_any_target(rasc_cli, tmp_path):
    """``--board FILE``: the board object alone, as a manifest's ``board`` field is written
    (issue 30 item 6), for a target other than the chessboard too; a manifest holding it
    gives the same points. Before, a bare AprilGrid or ChArUco object was refused with
    "missing field 'board'"."""
    import cv2

    from rasc.vision.board import AprilGrid

    board = AprilGrid((3, 2), 0.05, 0.3, "t36h11")
    margin = 80
    texture = board.texture()
    image = np.full((texture.shape[0] + 2 * margin, texture.shape[1] + 2 * margin), 255,
                    np.uint8)
    image[margin:-margin, margin:-margin] = texture
    png = tmp_path / "grid.png"
    cv2.imwrite(str(png), image)
    bare, manifest = tmp_path / "grid.json", tmp_path / "manifest.json"
    bare.write_text(json.dumps(board.to_dict()))
    manifest.write_text(json.dumps({"board": board.to_dict(), "angle_unit": "deg",
                                    "images": []}))
    outputs = []
    for source in (bare, manifest):
        out = tmp_path / f"{source.stem}.csv"
        status, _, err = rasc_cli("detect", "--board", source, "--angle-unit", "deg",
                                  "--quiet", "--pair", png, png, "0,0,0,0", "--out", out)
        assert status == 0, err
        outputs.append(out.read_text())
    assert outputs[0] == outputs[1]
    rows = _rows(tmp_path / "grid.csv")
    assert len(rows) == board.n_corners
    # the corners lie where the texture drew them: board x, y map to pixels by one scale
    # (the texel) and a shift; the saddle detector is good to ~0.05 px on a sharp texture
    ids = [int(r["label"].split(":")[1]) for r in rows]
    xy = board.object_points()[ids, :2]
    uv = np.array([[float(r["u_left"]), float(r["v_left"])] for r in rows])
    A = np.column_stack([xy, np.ones(len(xy))])
    fit, *_ = np.linalg.lstsq(A, uv, rcond=None)
    assert np.max(np.abs(A @ fit - uv)) < 0.1
    scale = fit[0, 0]                                    # pixels per metre, x and y alike
    assert scale > 0 and abs(fit[1, 1] - scale) < 1e-3 * scale
    assert max(abs(fit[0, 1]), abs(fit[1, 0])) < 1e-3 * scale
