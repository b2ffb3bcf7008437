"""estimate_extrinsics on a large target seen in part: the board's origin may lie behind
the camera while every corner seen is in front (wide pan-tilt motions, issue 23)."""

from __future__ import annotations

import numpy as np

from rasc.geometry.transforms import make_transform, matrix_from_rotvec
from rasc.vision.board import CharucoBoard
from rasc.vision.camera import estimate_extrinsics


def test_partial_view_with_the_origin_behind_the_camera():
    board = CharucoBoard((40, 30), 0.085, 0.064, "DICT_5X5_1000")   # 3.4 m x 2.55 m
    K = np.array([[1150.0, 0, 639.5], [0, 1150.0, 479.5], [0, 0, 1]])
    dist = np.zeros(5)
    R = matrix_from_rotvec([0.0, np.radians(-60.0), 0.0])
    # board point (3.0, 1.2) straight ahead at 1 m; the board's x runs away from the camera
    T = make_transform(R, np.array([0.0, 0.0, 1.0]) - R @ np.array([3.0, 1.2, 0.0]))
    P = board.object_points()
    p = P @ T[:3, :3].T + T[:3, 3]
    assert T[2, 3] < 0                      # corner 0 behind the camera
    uv = np.full((len(P), 2), np.nan)
    front = p[:, 2] > 0.05
    uv[front] = (p[front] @ K.T)[:, :2] / p[front, 2:]
    inside = front & np.all(uv >= 0, axis=1) & (uv[:, 0] < 1280) & (uv[:, 1] < 960)
    uv[~inside] = np.nan
    assert inside.sum() >= 50
    T_est, rms = estimate_extrinsics(uv, board, K, dist)
    # exact corners: the pose to round-off (1e-9 m, 1e-9 rad scale; 1e-6 leaves margin
    # for the solver's stopping rule)
    assert rms < 1e-6
    assert np.abs(T_est - T).max() < 1e-6
