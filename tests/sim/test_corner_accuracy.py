"""Corner accuracy on renders against the renderer's truth: ChArUco as accurate as the
chessboard (issue 23).

The ChArUco corners used to be refined by cornerSubPix alone, 0.08–0.10 px RMS on these
renders; the chessboard's by cornerSubPix then saddle points, 0.013–0.023 px. The error
was cornerSubPix's, not the texture's: the chessboard with cornerSubPix alone is as far
off, and that error is a sinusoid of the corner's sub-pixel position (pixel locking).
"""

from __future__ import annotations

import numpy as np
import pytest

from rasc.vision.board import Board, CharucoBoard

pytestmark = pytest.mark.slow

#: RMS of the corner error per view, px. Measured with "saddle" on 1280x960 renders at
#: 1 m: chessboard 0.013-0.023 px, ChArUco 0.008-0.027 px (12x9 and 16x12 boards, 0° to
#: ±45°); cornerSubPix alone 0.07-0.10 px. 0.04 px is 1.5x the worst measured and half
#: of what the old path gives.
RMS_TOL_PX = 0.04


def _rms(d: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(d ** 2, axis=1))))


def _views(board, poses, method):
    from rasc.sim.scene import StereoHeadSim
    from rasc.vision.camera import detect_corners

    out = {}
    truth_P = board.object_points()
    with StereoHeadSim(board=board) as sim:
        for pan, tilt in poses:
            sim.set_angles("left", np.radians(pan), np.radians(tilt))
            image = sim.render_grey("left")
            truth = sim.project_world_points("left", truth_P)
            c = detect_corners(image, board, method, min_corners=8)
            assert c is not None, (board.describe(), pan, tilt)
            seen = np.isfinite(c[:, 0])
            out[(pan, tilt)] = (int(seen.sum()), _rms(c[seen] - truth[seen]))
    return out


def test_charuco_corners_are_as_accurate_as_the_chessboard():
    chess = _views(Board((9, 6), 0.05), [(0, 0), (8, 8), (-8, -8)], "saddle")
    board = CharucoBoard((12, 9), 0.06, 0.045)
    poses = [(0, 0), (8, 8), (-8, -8), (30, 0), (-30, 0)]
    charuco = _views(board, poses, "saddle")
    for key, (n, rms) in {**chess, **charuco}.items():
        assert rms < RMS_TOL_PX, (key, n, rms)
    # as accurate as the chessboard: the worst ChArUco view within 1.5x the worst
    # chessboard view (measured 0.017 vs 0.021 px)
    assert max(r for _, r in charuco.values()) < 1.5 * max(r for _, r in chess.values())
    # many corners at every amplitude (measured 88, 66, 88, 24, 56 of 88)
    assert all(n >= 20 for n, _ in charuco.values())
    # the old refinement (cornerSubPix only) is the 0.08-0.10 px one: this test tells
    # the two apart
    classic = _views(board, [(0, 0)], "classic")
    assert classic[(0, 0)][1] > 2 * charuco[(0, 0)][1]
