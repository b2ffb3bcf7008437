"""rasc.testing renders with a target (the descriptions ``rasc render --target`` reads)
and returns rasc's one dataset class."""

import pytest

from rasc.testing import dataset_key, render_cached, target_board
from rasc.vision import Dataset
from rasc.vision.board import Board, CharucoBoard

SMALL = {"intrinsics_views": 3, "poses_deg": [[0, 0], [8, 0], [0, 8]]}
CHARUCO = "charuco:12x9,0.06,0.045"


def test_every_spelling_gives_the_target_of_rasc_render_target(tmp_path):
    """A description, the manifest's board object (dict, or a JSON file of it) and a
    board give the same target; None is the model's board."""
    board = CharucoBoard((12, 9), 0.06, 0.045)
    path = tmp_path / "board.json"
    path.write_text('{"type": "charuco", "squares": [12, 9], "square_size": 0.06, '
                    '"marker_size": 0.045}')
    for spelling in (CHARUCO, board.to_dict(), path, board):
        assert target_board(spelling) == board
    assert target_board("chessboard:7x4,0.04") == Board((7, 4), 0.04)
    assert target_board(None) is None
    with pytest.raises(TypeError, match="target"):
        target_board(3)


@pytest.mark.slow
def test_a_charuco_render_is_a_dataset_of_that_target(tmp_path):
    """Keyed by the target (another key than the chessboard's), read back as a Dataset
    whose board is the ChArUco board, its truth listing the corners seen per view."""
    ds = render_cached(tmp_path, target=CHARUCO, **SMALL)
    assert isinstance(ds, Dataset) and ds.board == target_board(CHARUCO)
    assert ds.key == dataset_key(ds.options, target=CHARUCO) != dataset_key(ds.options)
    assert all("corners" in v for v in ds.truth["views"].values())
    assert ds.T_cam_from_gaze("left").shape == (4, 4)
    again = render_cached(tmp_path, target=CHARUCO, **SMALL)
    assert again.path == ds.path                     # from the cache
