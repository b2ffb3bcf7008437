"""The stereo room's rig: ``rasc_cli``, the rendered default dataset and its in-process
calibration (``default_calibration``, the paper model): fixtures of
:mod:`shared_fixtures` (see there); and ``gaze_pairs`` (defined here): the simulated
stock head's true calibration and a chessboard rendered by both eyes at :data:`GAZES`,
with the board corners' truth.
"""

from __future__ import annotations

import numpy as np
import pytest

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
default_calibration = shared.default_calibration
default_dataset = shared.default_dataset
rasc_cli = shared.rasc_cli

from stereo_rig import GAZES, GazePair, board_facing, true_head  # noqa: E402,F401


@pytest.fixture(scope="session")
def gaze_pairs():
    """``(head, board, pairs)``: the stock head's truth, its chessboard, and a
    :class:`GazePair` at each of :data:`GAZES` (1280×960; 8 renders in all)."""
    from rasc.head.use import look_at
    from rasc.sim.scene import StereoHeadSim

    pairs = []
    with StereoHeadSim() as sim:
        head = true_head(sim)
        board = sim.board
        for name, point, d_left, d_right in GAZES:
            p = np.array(point, dtype=float)
            readings = {}
            for eye, d in (("left", d_left), ("right", d_right)):
                fix = look_at(getattr(head, eye), p)
                readings[eye] = (fix.pan + np.radians(d[0]), fix.tilt + np.radians(d[1]))
                sim.set_angles(eye, *readings[eye])
            sim.set_target(board_facing(board, p))
            P_world = board.object_points()
            T = sim.T_base_from_world
            p_base = P_world @ T[:3, :3].T + T[:3, 3]
            pairs.append(GazePair(
                name, readings["left"], readings["right"],
                {eye: sim.render_grey(eye) for eye in ("left", "right")}, p_base,
                {eye: sim.project_world_points(eye, P_world) for eye in ("left", "right")}))
        return head, board, pairs
