"""Tsai–Lenz-style hand-eye: motions between consecutive positions, rotation by the
Kabsch/SVD fit of the motions' rotation vectors, translation by stacked least squares.

rasc's plugin contract: ``solve(T_cam_from_world (n, 4, 4), T_gaze_from_ptu (n, 4, 4))
-> T_cam_from_gaze (4, 4)``. rasc validates the input and refuses degenerate data before
calling it, checks what it returns, and adds the quality (eq. 10), the diagnostics and
the jackknife error estimate. Only numpy and scipy are needed here.
"""

import numpy as np
from scipy.spatial.transform import Rotation


def solve(T_cam_from_world, T_gaze_from_ptu):
    """X = T_cam_from_gaze from A_k X = X B_k over the motions k -> k+1 (and last -> first)."""
    T_cw = np.asarray(T_cam_from_world, dtype=float)
    T_gp = np.asarray(T_gaze_from_ptu, dtype=float)
    n = len(T_cw)
    i = np.arange(n)
    j = (i + 1) % n
    A = T_cw[i] @ np.linalg.inv(T_cw[j])          # camera motions
    B = T_gp[i] @ np.linalg.inv(T_gp[j])          # unit motions
    alpha = Rotation.from_matrix(A[:, :3, :3]).as_rotvec()
    beta = Rotation.from_matrix(B[:, :3, :3]).as_rotvec()
    # alpha_k = R_X beta_k: the rotation that best maps the betas onto the alphas
    U, _, Vt = np.linalg.svd(alpha.T @ beta)
    R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    # (R_A - I) t_X = R_X t_B - t_A, all motions stacked
    C = (A[:, :3, :3] - np.eye(3)).reshape(-1, 3)
    d = (B[:, :3, 3] @ R.T - A[:, :3, 3]).reshape(-1)
    t = np.linalg.lstsq(C, d, rcond=None)[0]
    X = np.eye(4)
    X[:3, :3], X[:3, 3] = R, t
    return X
