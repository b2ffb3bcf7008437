"""The nominal rig the test modules share (pure functions and constants, no fixtures).

Import them from any room (``from nominal_rig import PAPER, rig``; tests/ is on sys.path
through the root conftest):

- ``R_CAM_FROM_GAZE_NOMINAL``: the camera on its gaze frame at home (gaze x up, y forward,
  z left; cam x right = −gaze z, cam y down = −gaze x, optical axis cam z = gaze y).
- ``PAPER``: the paper's nine pan-tilt positions as ``T_gaze_from_ptu`` (9, 4, 4), eq. 3.
- ``rig(rng)``: a realistic eye, ``(T_cam_from_gaze, T_ptu_from_world)``.
- ``random_rigid(rng, n)``: n random rigid transforms.
- ``pan_tilt(poses_deg)``: ``T_gaze_from_ptu`` of (pan, tilt) pairs in degrees.
- ``plausible_head(seed)``: a plausible head calibration and its ``T_ptuL_from_ptuR``;
  ``HEAD_IMAGE_SIZE`` its cameras' image size.
"""

from __future__ import annotations

import numpy as np

from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu
from rasc.geometry.transforms import make_transform, matrix_from_rotvec

#: Camera axes in gaze coordinates at home: cam x (right) = −gaze z (left), cam y (down)
#: = −gaze x (up), cam z (optical axis) = gaze y (forward): a camera looking forward.
R_CAM_FROM_GAZE_NOMINAL = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def pan_tilt(poses_deg) -> np.ndarray:
    """``T_gaze_from_ptu`` (n, 4, 4) of (pan, tilt) pairs in degrees (eq. 3)."""
    p = np.radians(np.asarray(poses_deg, dtype=float))
    return T_gaze_from_ptu(p[:, 0], p[:, 1])


#: The paper's nine ±8° pan-tilt positions, ``T_gaze_from_ptu`` (9, 4, 4).
PAPER = pan_tilt(PAPER_POSES_DEG)


def rig(rng: np.random.Generator, board_position=None) -> tuple[np.ndarray, np.ndarray]:
    """A realistic eye: camera a few cm from the unit's centre and ~3° off nominal, board
    ~1 m ahead (drawn, or at ``board_position``, (3,) in the ptu frame, m, which draws
    nothing for it). Returns ``(T_cam_from_gaze, T_ptu_from_world)``, each (4, 4)."""
    X = make_transform(R_CAM_FROM_GAZE_NOMINAL @ matrix_from_rotvec(rng.normal(0, 0.05, 3)),
                       rng.uniform(-0.05, 0.05, 3))
    Y = make_transform(R_CAM_FROM_GAZE_NOMINAL.T @ matrix_from_rotvec(rng.normal(0, 0.05, 3)),
                       [rng.uniform(-0.3, 0.0), rng.uniform(0.9, 1.1), rng.uniform(-0.2, 0.2)]
                       if board_position is None else board_position)
    return X, Y


def random_rigid(rng: np.random.Generator, n: int, max_angle: float = np.pi,
                 t_scale: float = 1.0) -> np.ndarray:
    """n rigid transforms (n, 4, 4): uniform random axes, angles uniform in
    [0, max_angle), translations normal with standard deviation ``t_scale``."""
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = rng.uniform(0, max_angle, (n, 1))
    return make_transform(matrix_from_rotvec(axis * angle), rng.normal(0, t_scale, (n, 3)))


#: image size of the plausible head's cameras
HEAD_IMAGE_SIZE = (1280, 960)


def plausible_head(seed: int = 0):
    """A plausible head and its ``T_ptuL_from_ptuR``: 0.3 m baseline, 1.5° between the
    mounts, cameras a few cm and ~2° off nominal, different intrinsics and lenses per eye
    (k1 ≈ −0.2 to −0.3)."""
    from rasc.head.base_to_ptu import T_ptuL_from_ptuR_from_mounts, cyclopean_base
    from rasc.head.model import EyeCalibration, HeadCalibration

    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    T_LR = T_ptuL_from_ptuR_from_mounts([0.0, 0.0, -0.3] + rng.normal(0, 0.005, 3),
                                        np.radians(1.5) * axis / np.linalg.norm(axis))
    T_pb = cyclopean_base(T_LR)
    dists = ([-0.22, 0.06, 0.0008, -0.0005, 0.0], [-0.3, 0.09, -0.0004, 0.0007])
    eyes = []
    for k in range(2):
        f = rng.uniform(950, 1050)
        K = np.array([[f, 0, 639.5 + rng.normal(0, 5)], [0, f * 1.001, 479.5 + rng.normal(0, 5)],
                      [0, 0, 1]])
        T_cg = make_transform(R_CAM_FROM_GAZE_NOMINAL @ matrix_from_rotvec(rng.normal(0, 0.03, 3)),
                              rng.uniform(-0.05, 0.05, 3))
        eyes.append(EyeCalibration(K, dists[k], T_cg, T_pb[k], HEAD_IMAGE_SIZE))
    return HeadCalibration(*eyes), T_LR
