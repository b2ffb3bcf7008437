"""Li's baseline (IEEE T-RA 1998) as the paper compares with it: docs/METHOD.md §4.

Motions are taken from one home view h only (the paper's (0, 0) pose)::

    A_k = T_cw^k (T_cw^h)^-1:  R_A = R_k R_hᵀ,  t_A = t_k − R_A t_h       (k ≠ h)
    B_k = T_gp^k (T_gp^h)^-1   likewise

and ``X = T_cam_from_gaze`` minimises, over SE(3), the Frobenius norm of the 4×4
difference summed over the motions::

    Σ_k ‖A_k X − X B_k‖²_F = Σ_k ‖R_A R_X − R_X R_B‖² + ‖R_A t_X + t_A − R_X t_B − t_X‖²

(9 unit-free rotation residuals and 3 translation residuals in the input's length unit
per motion, unweighted). For a pan-tilt unit ``t_B = 0``, so the translation residuals
do not depend on R_X and the two parts decouple: the unit of length does not matter.
X is parametrised by a rotation vector and a translation, started from the neutral
guess (identity, zero), and solved by Levenberg–Marquardt
(``scipy.optimize.least_squares``) with an analytic Jacobian. Every equation contains
the home view: an error there biases all of them, which is what experiment E2 shows.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from rasc.errors import SolverFailure
from rasc.geometry.transforms import make_transform, matrix_from_rotvec, skew
from rasc.handeye.solver import MIN_PAIR_ROTATION_RAD, HandEyeResult, diagnose, quality_eq10

#: Stopping tolerances of least_squares (ftol, xtol, gtol). Tight, because the problem
#: is tiny (6 unknowns) and LM converges quadratically near a zero-residual solution:
#: noise-free data are recovered to ~1e-15 in a few iterations.
TOL = 1e-12


def _left_jacobian(r: np.ndarray) -> np.ndarray:
    """SO(3) left Jacobian: ``exp(r + δ) ≈ exp(J_l(r) δ) exp(r)``; (3,) → (3, 3)."""
    theta = float(np.linalg.norm(r))
    K = skew(r)
    if theta < 1e-4:                      # series; the next terms are below 1e-17
        a, b = 0.5 - theta**2 / 24.0, 1.0 / 6.0 - theta**2 / 120.0
    else:
        a = (1.0 - np.cos(theta)) / theta**2
        b = (theta - np.sin(theta)) / theta**3
    return np.eye(3) + a * K + b * (K @ K)


class _Problem:
    """Residuals and Jacobian of Σ_k ‖A_k X − X B_k‖², vectorised over the K motions."""

    def __init__(self, RA, tA, RB, tB):
        self.RA, self.tA, self.RB, self.tB = RA, tA, RB, tB
        self.J0 = np.zeros((RA.shape[0], 12, 6))
        self.J0[:, 9:, 3:] = RA - np.eye(3)                       # ∂e_t/∂t_X

    def residuals(self, x: np.ndarray) -> np.ndarray:
        RX, tX = matrix_from_rotvec(x[:3]), x[3:]
        ER = self.RA @ RX - RX @ self.RB                          # (K, 3, 3)
        et = self.RA @ tX + self.tA - self.tB @ RX.T - tX         # (K, 3)
        return np.concatenate([ER.reshape(-1, 9), et], axis=1).ravel()

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        RX = matrix_from_rotvec(x[:3])
        D = skew(_left_jacobian(x[:3]).T) @ RX                    # D_m = [J_l e_m]× R_X
        dER = (np.einsum("kij,mjl->kmil", self.RA, D)
               - np.einsum("mij,kjl->kmil", D, self.RB))          # (K, m, 3, 3)
        d_et = -np.einsum("mij,kj->kmi", D, self.tB)              # (K, m, 3)
        J = self.J0.copy()
        J[:, :9, :3] = dER.reshape(-1, 3, 9).transpose(0, 2, 1)
        J[:, 9:, :3] = d_et.transpose(0, 2, 1)
        return J.reshape(-1, 6)


#: A position is the home pose when its unit motion is the identity to this tolerance
#: (pan = tilt = 0 gives the identity exactly; an encoder reading of 1e-9 rad too).
HOME_ATOL = 1e-9


#: What a pan-tilt user is told when no position is at pan = tilt = 0.
NO_HOME_POSE = ("no position at pan = tilt = 0: Li's home is the first position (every "
                "motion is taken from there)")


def _at_home(T_gaze_from_ptu: np.ndarray) -> np.ndarray:
    """Indices of the positions whose unit motion is the identity (pan = tilt = 0)."""
    T = np.asarray(T_gaze_from_ptu, dtype=float)
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        return np.array([], dtype=int)
    return np.flatnonzero(np.abs(T - np.eye(4)).max(axis=(1, 2)) <= HOME_ATOL)


def home_index(T_gaze_from_ptu: np.ndarray) -> int:
    """The default home view: the first position whose unit motion is the identity (the
    (0, 0) pose of a pan-tilt unit), else the first position (a robot arm's data)."""
    at_home = _at_home(T_gaze_from_ptu)
    return int(at_home[0]) if at_home.size else 0


def has_home_pose(T_gaze_from_ptu: np.ndarray) -> bool:
    """Whether some position's unit motion is the identity (pan = tilt = 0)."""
    return bool(_at_home(T_gaze_from_ptu).size)


def solve_li(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
             home: int | None = None, *,
             min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
             check_rigid: bool = True) -> HandEyeResult:
    """Li's method: non-linear least squares over the motions from the home view.

    Parameters
    ----------
    T_cam_from_world : array-like, shape (n, 4, 4)
        ``T_cw`` at each position (may be the paper's literal noisy matrices with
        ``check_rigid=False``).
    T_gaze_from_ptu : array-like, shape (n, 4, 4)
        The unit's motion ``T_gp`` (eq. 3), or ``T_gripper_from_base`` for an arm.
    home : int, optional
        The home view's index; by default :func:`home_index`: the position at pan = tilt
        = 0 (identity motion), or the first position when there is none.
    min_rotation_rad : float
        Used only by the degeneracy check (≥ 2 motions from home rotating at least
        this much, about different axes); every motion enters the cost.
    check_rigid : bool
        As :func:`rasc.handeye.solver.solve_rasc`.

    Returns
    -------
    HandEyeResult
        method "li"; ``quality`` is eq. 10 over all pairs i ≠ j (comparable with RASC);
        diagnostics describe the n − 1 home motions. Raises ``DegenerateDataError``
        for degenerate data and :class:`SolverFailure` if the optimiser does not converge.
    """
    if home is None:
        home = home_index(T_gaze_from_ptu)
    diagnostics, T_cw, T_gp = diagnose(T_cam_from_world, T_gaze_from_ptu, home=home,
                                       min_rotation_rad=min_rotation_rad,
                                       check_rigid=check_rigid)
    n = T_cw.shape[0]
    k = np.array([i for i in range(n) if i != home])
    R, t = T_cw[:, :3, :3], T_cw[:, :3, 3]
    Q, u = T_gp[:, :3, :3], T_gp[:, :3, 3]
    RA = R[k] @ R[home].T
    tA = t[k] - RA @ t[home]
    RB = Q[k] @ Q[home].T
    tB = u[k] - RB @ u[home]
    problem = _Problem(RA, tA, RB, tB)
    fit = least_squares(problem.residuals, np.zeros(6), jac=problem.jacobian, method="lm",
                        ftol=TOL, xtol=TOL, gtol=TOL)
    if fit.status <= 0 or not np.all(np.isfinite(fit.x)):
        raise SolverFailure(f"Li's optimisation did not converge ({fit.message}); the "
                            "data may be inconsistent or nearly degenerate")
    RX = matrix_from_rotvec(fit.x[:3])
    quality = float(quality_eq10(np.ascontiguousarray(R)[None], np.ascontiguousarray(Q)[None],
                                 RX[None])[0])
    return HandEyeResult(T_cam_from_gaze=make_transform(RX, fit.x[3:]), quality=quality,
                         method="li", diagnostics=diagnostics)
