"""rasc.vision.camera.saddle_points and the ChArUco window rule, on drawn corners."""

from __future__ import annotations

import numpy as np

from rasc.vision.board import CharucoBoard
from rasc.vision.camera import charuco_saddle_window, saddle_points


def _corner_image(x0: float, y0: float, size: int = 41) -> np.ndarray:
    """A chessboard corner at (x0, y0) (pixel centres at integers), each pixel its exact
    white area (an area-sampled, anti-aliased image; separable: the share of the pixel
    right of x0 and below y0), grey 20/235."""
    i = np.arange(size, dtype=float)
    fx = np.clip(i - x0 + 0.5, 0.0, 1.0)[None, :]
    fy = np.clip(i - y0 + 0.5, 0.0, 1.0)[:, None]
    white = fx * (1 - fy) + (1 - fx) * fy
    return np.rint(20 + 215 * white).astype(np.uint8)


def test_saddle_points_find_drawn_corners_and_refuse_a_spot():
    rng = np.random.default_rng(7)
    truth = 20 + rng.uniform(0, 1, size=(6, 2))
    found = []
    for x0, y0 in truth:
        img = _corner_image(x0, y0)
        c, ok = saddle_points(img, np.array([[20.0, 20.0]]) + rng.uniform(-0.7, 0.7, 2), 6,
                              2.0)
        assert ok.all()
        found.append(c[0])
    # area-sampled edges carry their sub-pixel position; 8-bit rounding and the fitted
    # quadratic leave 0.003 px RMS, 0.005 px at most (measured over 60 random positions
    # with r = 6, sigma = 2); 0.01 px is twice that and an eighth of cornerSubPix's 0.08
    # px pixel locking on rendered edges
    assert np.abs(np.array(found) - truth).max() < 0.01
    # a bright spot is a maximum, not a saddle (the fitted Hessian is definite): refused
    ys, xs = np.mgrid[0:41, 0:41]
    spot = np.rint(20 + 215 * np.exp(-((xs - 20.3) ** 2 + (ys - 19.8) ** 2) / 50.0))
    c, ok = saddle_points(spot.astype(np.uint8), np.array([[20.0, 20.0]]), 4, 1.3)
    assert not ok.any() and np.all(c == [[20.0, 20.0]])


def test_charuco_window_stays_inside_the_white_margin():
    board = CharucoBoard((12, 9), 0.06, 0.045)      # margin 1/8 of the square
    # large squares: the chessboard's cap (6 px, sigma 2)
    assert charuco_saddle_window(board, 80.0) == (6, 2.0)
    # 30 px squares: margin 3.75 px < a quarter of the side (7.5): r = 3
    r, sigma = charuco_saddle_window(board, 30.0)
    assert r == 3 and abs(sigma - 1.0) < 1e-12
    # thin margins (markers 0.9 of the square) shrink it further, never below 2
    assert charuco_saddle_window(CharucoBoard((5, 5), 0.1, 0.09), 60.0)[0] == 3
    assert charuco_saddle_window(CharucoBoard((5, 5), 0.1, 0.09), 10.0)[0] == 2
