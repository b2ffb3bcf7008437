"""The stereo room's rig, importable by its tests (``from stereo_rig import ...``; a
conftest is not a module to import by name): the gazes, a board facing a point, the
simulated head's truth as a calibration."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The gazes (name, the base point both eyes fixate (x up, y forward, z left; metres),
#: then (pan, tilt) added to each eye's fixation, degrees). Every reading is within ±30°.
GAZES = (
    # (readings that result, pan and tilt per eye, degrees)
    ("converging", (0.0, 0.75, 0.0), (0.0, 0.0), (0.0, 0.0)),     # (-11, -4), (11, -4)
    ("diverging", (0.0, 1.6, 0.0), (8.0, 0.0), (-8.0, 0.0)),      # (4, -3), (-3, -1)
    ("asymmetric", (0.35, 1.0, 0.3), (-2.0, 1.5), (1.0, -1.0)),   # (8, 17), (25, 14)
    ("down-right", (-0.45, 1.0, -0.5), (1.5, -1.0), (-1.0, 2.0)),  # (-30, -25), (-21, -23)
)


@dataclass
class GazePair:
    """One gaze: readings (radians), the two rendered grey images, the board's inner
    corners in the base frame (truth) and their ideal pixels in each eye (truth)."""

    name: str
    left: tuple[float, float]
    right: tuple[float, float]
    images: dict[str, np.ndarray]
    p_base: np.ndarray
    uv_true: dict[str, np.ndarray]


def true_head(sim):
    """The simulated head's ground truth as a HeadCalibration (no lens distortion)."""
    from rasc.head.model import HeadCalibration

    return HeadCalibration.from_truth(sim.ground_truth())


def board_facing(board, p_base: np.ndarray) -> np.ndarray:
    """The board's pose (T_base_from_world) with its centre at ``p_base``, upright, its
    face turned to the base origin."""
    from scipy.spatial.transform import Rotation

    from rasc.geometry.transforms import make_transform
    from rasc.sim.mjcf import T_base_from_world_facing

    ahead = T_base_from_world_facing(board)        # centre 1 m ahead (base +y), upright
    d = p_base / np.linalg.norm(p_base)
    yaw = np.arctan2(d[2], d[1])                   # about base x (up): towards +z (left)
    pitch = np.arcsin(np.clip(d[0], -1, 1))        # then up
    R = (Rotation.from_rotvec([yaw, 0, 0]) * Rotation.from_rotvec(
        [0, 0, -pitch])).as_matrix()
    R_bw = R @ ahead[:3, :3]
    return make_transform(R_bw, p_base - R_bw @ board.centre())



def gazes_on(sim, render: bool = True) -> tuple:
    """``(head, board, pairs)`` for a :class:`rasc.sim.scene.StereoHeadSim`: its truth, its
    board and a :class:`GazePair` at each of :data:`GAZES` (the readings that fixate each
    gaze's point with the true head, plus its offsets); ``render``: also render both eyes
    (else ``images`` is empty: the true pixels only)."""
    from rasc.head.use import look_at

    head = true_head(sim)
    board = sim.board
    pairs = []
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
            {eye: sim.render_grey(eye) for eye in ("left", "right")} if render else {},
            p_base,
            {eye: sim.project_world_points(eye, P_world) for eye in ("left", "right")}))
    return head, board, pairs
