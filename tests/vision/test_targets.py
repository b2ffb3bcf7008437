"""ChArUco targets: description, detection by id with partial views, calibration on
corner subsets, positions files (issue 23). No rendering: OpenCV's own drawing of the
board, warped by a known homography, is the image."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from rasc.errors import InputError
from rasc.vision.board import (
    Board,
    CharucoBoard,
    board_from_dict,
    parse_target,
)
from rasc.vision.camera import (
    calibrate_intrinsics,
    detect_charuco,
    detect_corners,
    estimate_extrinsics,
)

BOARD = CharucoBoard((8, 6), 0.04, 0.03, "DICT_5X5_100")


def test_description_round_trip_and_old_chessboards():
    assert board_from_dict(BOARD.to_dict()) == BOARD
    assert parse_target("charuco:8x6,0.04,0.03,DICT_5X5_100") == BOARD
    # an old manifest's board (no type) is still a chessboard
    assert board_from_dict({"inner_corners": [9, 6], "square_size": 0.05}) == Board((9, 6), 0.05)
    assert BOARD.n_corners == 7 * 5
    P = BOARD.object_points()
    assert np.allclose(P[0], 0) and np.allclose(P[8], [0.04, 0.04, 0])   # id 8 = (1, 1)


@pytest.mark.parametrize("d, msg", [
    ({"type": "charuco", "squares": [8, 6], "square_size": 0.04}, "marker_size"),
    ({"type": "charuco", "squares": [8, 6], "square_size": 0.04, "marker_size": 0.05},
     "below square_size"),
    ({"type": "charuco", "squares": [30, 30], "square_size": 0.04, "marker_size": 0.03,
      "dictionary": "DICT_4X4_50"}, "markers"),
    ({"type": "circlegrid", "squares": [8, 6]}, "type"),
])
def test_bad_descriptions_name_the_field(d, msg):
    with pytest.raises(InputError, match=msg):
        board_from_dict(d, "manifest.json: board")


def _view(H: np.ndarray, size=(800, 600), px=100) -> tuple[np.ndarray, np.ndarray]:
    """The board drawn at ``px`` per square, warped by H (board pixels → image): the image
    and the true pixels of every corner (id order)."""
    sx, sy = BOARD.squares
    art = BOARD.texture(px)
    img = cv2.warpPerspective(art, H, size, flags=cv2.INTER_AREA, borderValue=128)
    # corner id k at board (i+1, j+1) squares from the pattern's top-left; pixel centres
    # at integers: the edge between pixels px-1 and px is at px - 0.5
    P = (BOARD.object_points()[:, :2] / BOARD.square_size + 1) * px - 0.5
    uv = cv2.perspectiveTransform(P.reshape(-1, 1, 2), H).reshape(-1, 2)
    return img, uv


def test_detection_by_id_whole_and_partial():
    H = np.array([[0.8, 0.08, 60.0], [-0.05, 0.85, 50.0], [1e-5, 2e-5, 1.0]])
    img, truth = _view(H)
    c = detect_charuco(img, BOARD)
    assert c is not None and np.isfinite(c).all()
    # 0.1 px: cornerSubPix on a warped drawing (measured 0.02-0.05 px here)
    assert np.sqrt(np.mean(np.sum((c - truth) ** 2, axis=1))) < 0.1
    # the right part of the image blanked: the corners there are NaN, the rest found
    img2 = img.copy()
    img2[:, 420:] = 128
    c2 = detect_charuco(img2, BOARD)
    seen = np.isfinite(c2[:, 0])
    assert 8 <= seen.sum() < BOARD.n_corners
    assert np.all(truth[seen, 0] < 420)
    # away from the cut (whose edge pulls cornerSubPix within its window) as accurate
    away = seen & (truth[:, 0] < 405)
    assert np.sqrt(np.mean(np.sum((c2[away] - truth[away]) ** 2, axis=1))) < 0.1
    assert np.abs(c2[seen] - truth[seen]).max() < 1.5
    # too few corners: None (not an error); detect_corners dispatches by target
    assert detect_corners(img2, BOARD, min_corners=BOARD.n_corners) is None


def _projected(K, T_cw, P, rng, noise=0.02, keep=None):
    p = P @ T_cw[:3, :3].T + T_cw[:3, 3]
    uv = p[:, :2] / p[:, 2:] * [K[0, 0], K[1, 1]] + K[:2, 2]
    uv = uv + rng.normal(0, noise, uv.shape)
    if keep is not None:
        uv[~keep] = np.nan
    return uv


def test_intrinsics_and_pose_from_corner_subsets():
    """Each view shows a different subset (a random half or more): K is recovered and each
    pose too, as from whole views."""
    from rasc.geometry.transforms import make_transform, matrix_from_rotvec

    rng = np.random.default_rng(3)
    K = np.array([[900.0, 0, 400], [0, 905, 300], [0, 0, 1]])
    P = BOARD.object_points()
    views, poses = {}, {}
    for k in range(8):
        R = matrix_from_rotvec(rng.uniform(-0.5, 0.5, 3))
        T = make_transform(R, [-0.12 + rng.uniform(-0.03, 0.03), -0.08, 0.6 + 0.1 * k / 8])
        keep = np.zeros(len(P), bool)
        keep[rng.choice(len(P), int(rng.integers(18, len(P))), replace=False)] = True
        views[f"v{k}"] = _projected(K, T, P, rng, keep=keep)
        poses[f"v{k}"] = T
    res = calibrate_intrinsics(views, BOARD, (800, 600), dist_model="none")
    # 0.02 px noise on ~25 corners x 8 views: fx to ~0.5 px (tolerance 3 px, 6 sigma-ish)
    assert abs(res.K[0, 0] - 900) < 3 and abs(res.K[1, 1] - 905) < 3
    assert abs(res.K[0, 2] - 400) < 3 and abs(res.K[1, 2] - 300) < 3
    T, rms = estimate_extrinsics(views["v0"], BOARD, K, np.zeros(5))
    assert rms < 0.06          # 0.02 px per coordinate noise: RMS ~0.028 px
    assert np.linalg.norm(T[:3, 3] - poses["v0"][:3, 3]) < 1e-3
    with pytest.raises(InputError, match="not enough"):
        bad = np.full((len(P), 2), np.nan)
        bad[:3] = views["v0"][:3] if np.isfinite(views["v0"][:3]).all() else [[1, 1]] * 3
        estimate_extrinsics(bad, BOARD, K, np.zeros(5))


def test_positions_file_round_trip(tmp_path):
    from rasc.sim.render import format_positions, parse_poses, read_positions

    poses = [(0.0, 0.0), (31.25, -12.5), (-45.0, 30.0)]
    f = tmp_path / "p.csv"
    f.write_text(format_positions(poses, "a comment"))
    assert read_positions(f) == tuple(poses)
    assert parse_poses(str(f)) == tuple(poses)
    t = tmp_path / "p.toml"
    t.write_text("positions = [[0, 0], [30, 10], [-30, -10]]\n")
    assert read_positions(t) == ((0.0, 0.0), (30.0, 10.0), (-30.0, -10.0))
    bad = tmp_path / "bad.csv"
    bad.write_text("pan,tilt\n1,2\n3;4\n")
    with pytest.raises(InputError, match="line 3"):
        read_positions(bad)


def test_manifest_names_its_target(tmp_path):
    from rasc.vision.dataset import load_dataset, write_manifest

    (tmp_path / "a.png").write_bytes(b"")
    write_manifest(tmp_path, BOARD, [{"file": "a.png", "eye": "left", "role": "intrinsics"}])
    ds = load_dataset(tmp_path)
    assert ds.board == BOARD and ds.to_manifest()["board"]["type"] == "charuco"
    bad = ds.to_manifest()
    bad["board"]["dictionary"] = "DICT_9X9_1"
    import json
    (tmp_path / "manifest.json").write_text(json.dumps(bad))
    with pytest.raises(InputError, match="manifest.json: board: .*dictionary"):
        load_dataset(tmp_path)


@pytest.mark.parametrize("spec, msg", [
    ("charuco:12x9,0.06", "expected charuco:SXxSY"),
    ("charuco:40x40,0.06,0.045", "need 800 markers"),
    ("chessboard:9x7,0.05", "nx \\+ ny even"),
    ("nope", "or a JSON file"),
])
def test_target_option_refusals_are_one_line(spec, msg):
    with pytest.raises(InputError, match=msg) as e:
        parse_target(spec)
    assert "\n" not in str(e.value) and spec in str(e.value)
