"""The stereo room's rig: ``rasc_cli``, the rendered default dataset and its in-process
calibration (``default_calibration``, the paper model): fixtures of
:mod:`shared_fixtures` (see there); and ``gaze_pairs`` (defined here): the simulated
stock head's true calibration and a chessboard rendered by both eyes at :data:`GAZES`,
with the board corners' truth.
"""

from __future__ import annotations

import pytest

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
default_calibration = shared.default_calibration
default_dataset = shared.default_dataset
rasc_cli = shared.rasc_cli

from stereo_rig import gazes_on  # noqa: E402


@pytest.fixture(scope="session")
def gaze_pairs():
    """``(head, board, pairs)``: the stock head's truth, its chessboard, and a
    :class:`GazePair` at each of :data:`GAZES` (1280×960; 8 renders in all)."""
    from rasc.sim.scene import StereoHeadSim

    with StereoHeadSim() as sim:
        return gazes_on(sim)
