"""Pan-tilt kinematics, eq. 3 of the paper (docs/METHOD.md §2).

    R_gaze_from_ptu(φ, τ) = Rz(τ) · Rx(−φ),   t_gaze_from_ptu = 0

φ is pan, τ is tilt, in radians. The ptu frame is x = up, y = forward, z = left: the pan
joint turns about the ptu x axis (vertical), the tilt joint about the panned z axis by
−τ, so positive pan turns the line of sight (+y) to the left and positive tilt raises it.
"""

from __future__ import annotations

import numpy as np


def R_gaze_from_ptu(pan: np.ndarray | float, tilt: np.ndarray | float) -> np.ndarray:
    """Eq. 3. ``pan``, ``tilt`` in radians, broadcast together → (..., 3, 3)."""
    pan, tilt = np.broadcast_arrays(np.asarray(pan, dtype=float), np.asarray(tilt, dtype=float))
    cp, sp = np.cos(pan), np.sin(pan)
    ct, st = np.cos(tilt), np.sin(tilt)
    R = np.empty(pan.shape + (3, 3))
    R[..., 0, 0] = ct
    R[..., 0, 1] = -st * cp
    R[..., 0, 2] = -st * sp
    R[..., 1, 0] = st
    R[..., 1, 1] = ct * cp
    R[..., 1, 2] = ct * sp
    R[..., 2, 0] = 0.0
    R[..., 2, 1] = -sp
    R[..., 2, 2] = cp
    return R


def T_gaze_from_ptu(pan: np.ndarray | float, tilt: np.ndarray | float) -> np.ndarray:
    """Eq. 3 as 4×4 transforms (pure rotation about the unit's centre) → (..., 4, 4)."""
    R = R_gaze_from_ptu(pan, tilt)
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., 3, 3] = 1.0
    return T


#: The paper's nine positions (pan, tilt) in degrees (docs/METHOD.md §9, E1), home first.
PAPER_POSES_DEG = (
    (0.0, 0.0),
    (8.0, 8.0), (8.0, 0.0), (8.0, -8.0),
    (0.0, 8.0), (0.0, -8.0),
    (-8.0, 8.0), (-8.0, 0.0), (-8.0, -8.0),
)
