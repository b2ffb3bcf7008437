"""RASC's gaze-to-camera calibration as the paper writes it (section 3.2, eq. 6–10).

The reference: each equation written out plainly, one ordered pair at a time, with
numpy and scipy's Rotation. It is what the solver means; :mod:`rasc.handeye.solver` (with
its private kernels, :mod:`rasc.handeye._kernels`) computes the same numbers fast, and the
tests hold the two together (tests/handeye/test_kernels_vs_paper.py). Notation as in
docs/METHOD.md §3 (the paper's section 3.2): at each of n positions k the camera
calibration gives the target's pose ``T_cw^k`` (``T_cam_from_world``) and the unit
reports ``T_gp^k`` (``T_gaze_from_ptu``, eq. 3; for a robot arm ``T_gripper_from_base``).
The unknown is ``X = T_cg`` (``T_cam_from_gaze``) in ``A_ij X = X B_ij``.

Literal noise: the paper's eq. 13 leaves ``R_cw`` slightly non-orthogonal. The logarithm
(eq. 8) is then taken of each view's nearest rotation; eq. 7 and eq. 10 use the matrices
as given. At a half turn (angle π) the log has no sign of its own: this reference takes
scipy's, the kernels choose the sign that agrees with the other pairs.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

from rasc.errors import DegenerateDataError
from rasc.handeye.result import MAX_COND_CTC, MIN_PAIR_ROTATION_RAD


class Solution(NamedTuple):
    """``T_cam_from_gaze`` (4, 4), eq. 10's ``quality``, and eq. 9's ``M`` (3, 3)."""

    T_cam_from_gaze: np.ndarray
    quality: float
    M: np.ndarray


def ordered_pairs(n: int, pairs: str = "all") -> list[tuple[int, int]]:
    """The pairs (i, j) the sums run over: every ordered pair i ≠ j ("all", the paper's
    choice, docs/METHOD.md §3), or each unordered pair once as i > j ("half": OpenCV's
    pair set and orientation)."""
    return [(i, j) for i in range(n) for j in range(n) if i != j and (pairs == "all" or i > j)]


def relative_motion(T_i: np.ndarray, T_j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 6–7's relative motion ``T_i T_j⁻¹``: rotation ``R_i R_jᵀ`` and translation
    ``t_i − R_i R_jᵀ t_j`` (``A_ij`` from two camera poses, ``B_ij`` from two unit poses),
    with the matrices as given (no re-orthogonalisation)."""
    R = T_i[:3, :3] @ T_j[:3, :3].T
    return R, T_i[:3, 3] - R @ T_j[:3, 3]


def nearest_rotation(R: np.ndarray) -> np.ndarray:
    """The rotation closest to a 3×3 matrix in the Frobenius norm: ``U diag(1, 1, ±1) Vᵀ``
    of its SVD ``R = U Σ Vᵀ`` (the polar factor, det +1)."""
    U, _, Vt = np.linalg.svd(R)
    return U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt


def log_rotation(R: np.ndarray) -> np.ndarray:
    """Eq. 8's canonical coordinates: ``log R`` as an axis-angle vector (angle in [0, π]),
    of the nearest rotation when R is not quite orthogonal. scipy's conversion is robust
    at angle 0 and π (the paper's formula divides by sin φ)."""
    return Rotation.from_matrix(nearest_rotation(R)).as_rotvec()


def rotation_eq9(alphas: list[np.ndarray], betas: list[np.ndarray]) -> tuple[np.ndarray,
                                                                            np.ndarray]:
    """Eq. 8–9 (Park & Martin): ``α = R_X β`` for every pair; ``M = Σ β αᵀ`` and
    ``R_X = (MᵀM)^(-1/2) Mᵀ``.

    Computed as the polar factor of Mᵀ: with ``M = U Σ Vᵀ``, ``(MᵀM)^(-1/2) Mᵀ = V Uᵀ``
    whenever MᵀM is non-singular; ``V diag(1, 1, ±1) Uᵀ`` also exists when M has rank 2
    (two rotation axes fix a rotation) and keeps det +1 should noise flip the sign of
    det M. Returns ``(R_X, M)``.
    """
    M = np.zeros((3, 3))
    for alpha, beta in zip(alphas, betas, strict=True):
        M += np.outer(beta, alpha)                                        # eq. 9
    U, _, Vt = np.linalg.svd(M)
    V = Vt.T
    R_X = V @ np.diag([1.0, 1.0, np.linalg.det(V @ U.T)]) @ U.T
    return R_X, M


def translation_eq7(R_As: list[np.ndarray], t_As: list[np.ndarray], t_Bs: list[np.ndarray],
                    R_X: np.ndarray) -> np.ndarray:
    """Eq. 7 for a unit that may also translate: ``(I − R_A) t_X = t_A − R_X t_B`` for every
    pair, stacked to ``C t_X = d`` and solved by least squares, ``t_X = (CᵀC)⁻¹ Cᵀd``
    (erratum: the paper prints ``(CᵀC)^(-1/2)``; docs/METHOD.md §3). For a pan-tilt unit
    ``t_B = 0``.

    Raises :class:`DegenerateDataError` when cond(CᵀC) exceeds ``MAX_COND_CTC``: the
    motions' rotation axes are (nearly) parallel and the translation along them is not
    determined.
    """
    C = np.concatenate([np.eye(3) - R_A for R_A in R_As])                # (3K, 3)
    d = np.concatenate([t_A - R_X @ t_B for t_A, t_B in zip(t_As, t_Bs, strict=True)])
    CtC = C.T @ C
    lam = np.linalg.eigvalsh(CtC)
    if not lam[0] * MAX_COND_CTC >= lam[2]:
        raise DegenerateDataError(
            f"cond(CᵀC) = {lam[2] / lam[0] if lam[0] > 0 else np.inf:.3g} > "
            f"{MAX_COND_CTC:g} (eq. 7): the motions' rotation axes are nearly parallel")
    return np.linalg.solve(CtC, C.T @ d)


def quality_eq10(R_cw: np.ndarray, R_gp: np.ndarray, R_X: np.ndarray) -> float:
    """Eq. 10: the mean over all ordered pairs i ≠ j of ``‖R_X B_ij R_Xᵀ − A_ij‖_F``, with
    ``A_ij = R_cw^i (R_cw^j)ᵀ`` and ``B_ij = R_gp^i (R_gp^j)ᵀ`` as given. The paper found
    solutions with a quality above 1 unusable."""
    n = len(R_cw)
    norms = [np.linalg.norm(R_X @ (R_gp[i] @ R_gp[j].T) @ R_X.T - R_cw[i] @ R_cw[j].T)
             for i, j in ordered_pairs(n, "all")]
    return float(np.mean(norms))


def solve(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *, pairs: str = "all",
          min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
          R_X: np.ndarray | None = None) -> Solution:
    """RASC, eq. 6–10, for n positions (n, 4, 4) each.

    For every pair (i, j) of ``pairs`` (:func:`ordered_pairs`): ``A_ij`` from the camera
    poses, ``B_ij`` from the unit's (eq. 6). A pair whose unit rotation ``|β|`` is below
    ``min_rotation_rad`` carries no usable axis and is left out of eq. 7–9 (the solver's
    rule, ``MIN_PAIR_ROTATION_RAD``); eq. 10 runs over all i ≠ j. ``R_X`` given: eq. 9 is
    skipped and eq. 7 solved for that rotation.

    No input validation and no degeneracy analysis beyond eq. 7's condition:
    :func:`rasc.handeye.solver.solve_rasc` is the function to call on real data.
    """
    T_cw = np.asarray(T_cam_from_world, dtype=float)
    T_gp = np.asarray(T_gaze_from_ptu, dtype=float)
    R_views = [nearest_rotation(T[:3, :3]) for T in T_cw]      # for eq. 8's logs only
    alphas, betas, R_As, t_As, t_Bs = [], [], [], [], []
    for i, j in ordered_pairs(len(T_cw), pairs):
        R_A, t_A = relative_motion(T_cw[i], T_cw[j])                      # eq. 6
        R_B, t_B = relative_motion(T_gp[i], T_gp[j])
        beta = log_rotation(R_B)                                          # eq. 8
        if np.linalg.norm(beta) < min_rotation_rad:
            continue
        alphas.append(log_rotation(R_views[i] @ R_views[j].T))
        betas.append(beta)
        R_As.append(R_A)
        t_As.append(t_A)
        t_Bs.append(t_B)
    if len(betas) < 2:
        raise DegenerateDataError(f"only {len(betas)} motion(s) of the unit rotate by at "
                                  f"least {min_rotation_rad:g} rad: eq. 9 needs two axes")
    R_X_eq9, M = rotation_eq9(alphas, betas)                              # eq. 8–9
    R_X = R_X_eq9 if R_X is None else np.asarray(R_X, dtype=float)
    t_X = translation_eq7(R_As, t_As, t_Bs, R_X)                          # eq. 7
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R_X, t_X
    return Solution(T, quality_eq10(T_cw[:, :3, :3], T_gp[:, :3, :3], R_X), M)  # eq. 10
