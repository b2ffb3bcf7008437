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
    from rasc.geometry.kinematics import PanTiltUnit
    from rasc.head.model import EyeCalibration, HeadCalibration

    gt = sim.ground_truth()
    eyes = {eye: EyeCalibration(
        K=np.array(gt[eye]["K"]), dist=np.zeros(5),
        T_cam_from_gaze=np.array(gt[eye]["T_cam_from_gaze"]),
        T_ptu_from_base=np.array(gt[eye]["T_ptu_from_base"]),
        image_size=tuple(gt[eye]["image_size"]), unit=PanTiltUnit.from_dict(gt[eye]["unit"]))
        for eye in ("left", "right")}
    return HeadCalibration(**eyes)


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
