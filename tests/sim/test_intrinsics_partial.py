"""Intrinsics views of a wall-sized target seen in part (rasc.sim.render)."""

from __future__ import annotations

import numpy as np

from rasc.sim.render import (
    INTRINSICS_DISTANCE_M,
    PARTIAL_INTRINSICS_CORNERS,
    PARTIAL_INTRINSICS_FAR,
    _visible,
    intrinsics_board_poses,
    visible_corners,
)
from rasc.vision.board import CharucoBoard

K = np.array([[1150.0, 0, 639.5], [0, 1150.0, 479.5], [0, 0, 1]])
SIZE = (1280, 960)


def test_a_wall_is_seen_in_part_and_near():
    wall = CharucoBoard((20, 15), 0.17, 0.127, "DICT_5X5_250")      # 3.4 m x 2.55 m
    poses = intrinsics_board_poses(np.random.default_rng(3), wall, K, SIZE, 12)
    centre = np.array([9.5, 7.0, 0.0]) * wall.square_size
    for T in poses:
        assert len(visible_corners(T, wall, K, SIZE)[0]) >= PARTIAL_INTRINSICS_CORNERS
        d = np.linalg.norm(T[:3, :3] @ centre + T[:3, 3])
        assert d <= PARTIAL_INTRINSICS_FAR * INTRINSICS_DISTANCE_M[1] + 1e-9
    # not whole: a 3.4 m board that near cannot fit the image
    assert not any(_visible(T, wall, K, SIZE) for T in poses)


def test_a_board_up_to_1_5_m_is_still_seen_whole():
    board = CharucoBoard((16, 12), 0.075, 0.056)
    for T in intrinsics_board_poses(np.random.default_rng(3), board, K, SIZE, 6):
        assert _visible(T, board, K, SIZE)
