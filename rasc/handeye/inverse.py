"""RASC's rotation with two other translations: methods "rasc-inverse" and "rasc-views".

"rasc-inverse" solves the translation for the inverse transform (below); "rasc-views"
from each view's own translation (:func:`views_translation`, after the first).

The paper's eq. 7 solves ``A X = X B`` for ``X = T_cam_from_gaze`` with the design matrix
``(I − R_A)``, built from the noisy camera rotations; OpenCV's solvers solve for the
inverse ``Y = X⁻¹ = T_gaze_from_cam``. From ``A X = X B``, ``Y A = B Y``, whose
translation part is::

    (I − R_B) t_Y = t_B − R_Y t_A          R_Y = R_Xᵀ,  t_X = −R_X t_Y

with the unit's rotation ``R_B = Q_i Q_jᵀ`` (exactly known from the encoders) as the
design matrix. Why that matters (docs/METHOD.md §3, §8): in eq. 7 the noise of ``R_A``
sits both in the design matrix ``(I − R_A)`` (of size ≈ θ, the motion's angle) and, via
``t_A = t_i − R_A t_j``, in the right-hand side multiplied by the target distance
``|t_j|``. The two are correlated, so the least-squares solution is biased by about
``2 σ_r² |t| / θ²`` along the viewing direction — with the paper's ±8° motions and the
board 1 m away, tens of millimetres at its highest noise levels. With an exact design
matrix that product has zero mean and the bias goes. Both pair formulations still carry
the camera's rotation noise times the target distance in ``t_A``; the per-view equations
of "rasc-views" do not, which halves the translation error under the paper's noise and
under corner noise alike (measured: tests/handeye/test_inverse.py, README "Measured figures").

The rotation is RASC's (eq. 6, 8, 9) and so is the quality (eq. 10, which depends only
on the rotation); the pairs are all ordered pairs i ≠ j whose unit rotation is at least
``MIN_PAIR_ROTATION_RAD`` (as RASC). ``rasc`` stays the paper's method.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rasc.errors import DegenerateDataError
from rasc.geometry.transforms import make_transform, rotation_angle
from rasc.handeye.solver import (
    MAX_COND_CTC,
    MIN_PAIR_ROTATION_RAD,
    HandEyeResult,
    solve_rasc,
    validate_poses,
)


def inverse_translation(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                        R_cam_from_gaze: np.ndarray, *,
                        min_rotation_rad: float = MIN_PAIR_ROTATION_RAD
                        ) -> tuple[np.ndarray, float]:
    """Least-squares ``t_X`` of ``T_cam_from_gaze`` from the inverse formulation.

    Parameters
    ----------
    T_cam_from_world, T_gaze_from_ptu : numpy.ndarray, shape (n, 4, 4)
        Validated poses (literal eq. 13 matrices allowed: used as given).
    R_cam_from_gaze : numpy.ndarray, shape (3, 3)
        The rotation ``R_X`` (RASC's).
    min_rotation_rad : float
        Pairs whose unit rotation is smaller are left out.

    Returns
    -------
    (t_cam_from_gaze (3,), cond) where cond is cond(Σ (I − R_B)ᵀ(I − R_B)).
    Raises :class:`DegenerateDataError` when cond exceeds ``MAX_COND_CTC``.
    """
    R, t = T_cam_from_world[:, :3, :3], T_cam_from_world[:, :3, 3]
    Q, u = T_gaze_from_ptu[:, :3, :3], T_gaze_from_ptu[:, :3, 3]
    n = len(R)
    i, j = np.nonzero(~np.eye(n, dtype=bool))                    # all ordered pairs i ≠ j
    RB = Q[i] @ np.swapaxes(Q[j], -1, -2)                        # (K, 3, 3), exact
    keep = rotation_angle(RB) >= min_rotation_rad
    i, j, RB = i[keep], j[keep], RB[keep]
    RA = R[i] @ np.swapaxes(R[j], -1, -2)
    tA = t[i] - (RA @ t[j][..., None])[..., 0]
    tB = u[i] - (RB @ u[j][..., None])[..., 0]
    RY = R_cam_from_gaze.T
    C = np.eye(3) - RB                                           # the design matrix
    d = tB - tA @ RY.T                                           # t_B − R_Y t_A
    CtC = np.einsum("kji,kjl->il", C, C)
    Ctd = np.einsum("kji,kj->i", C, d)
    lam = np.linalg.eigvalsh(CtC)
    cond = float(lam[2] / lam[0]) if lam[0] > 0 else np.inf
    if not cond <= MAX_COND_CTC:
        raise DegenerateDataError(
            f"translation is not determined: cond(Σ (I − R_B)ᵀ(I − R_B)) = {cond:.3g} > "
            f"{MAX_COND_CTC:g}; the motions' rotation axes are nearly parallel; add "
            "positions that turn about a second axis (combine pan with tilt)")
    t_Y = np.linalg.solve(CtC, Ctd)
    return -R_cam_from_gaze @ t_Y, cond


def solve_rasc_inverse(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *,
                       min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
                       check_rigid: bool = True) -> HandEyeResult:
    """RASC's rotation (eq. 6–9) with the translation of the inverse formulation.

    Parameters
    ----------
    T_cam_from_world, T_gaze_from_ptu : array-like, shape (n, 4, 4)
        As :func:`rasc.handeye.solver.solve_rasc` (validated and checked for degeneracy
        by it).
    min_rotation_rad, check_rigid : as :func:`~rasc.handeye.solver.solve_rasc`.

    Returns
    -------
    HandEyeResult
        method "rasc-inverse"; quality (eq. 10) and diagnostics as RASC's, except
        ``cond_CtC``, which is that of the inverse formulation's normal equations.
    """
    base = solve_rasc(T_cam_from_world, T_gaze_from_ptu, min_rotation_rad=min_rotation_rad,
                      check_rigid=check_rigid)
    T_cw = validate_poses(T_cam_from_world, "T_cam_from_world", check_rigid=False)
    T_gp = validate_poses(T_gaze_from_ptu, "T_gaze_from_ptu", check_rigid=False)
    RX = np.asarray(base.T_cam_from_gaze)[:3, :3]
    tX, cond = inverse_translation(T_cw, T_gp, RX, min_rotation_rad=min_rotation_rad)
    return HandEyeResult(T_cam_from_gaze=make_transform(RX, tX), quality=base.quality,
                         method="rasc-inverse",
                         diagnostics=dataclasses.replace(base.diagnostics, cond_CtC=cond))


#: Per-view translation ill-conditioned: reject when cond(AᵀA) of the (3n × 6) system
#: of :func:`views_translation` exceeds this (the same bound as eq. 7's ``MAX_COND_CTC``:
#: 1 mm of error in the views' translations may then move t_X by 0.1 m).
MAX_COND_VIEWS = MAX_COND_CTC


def views_translation(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                      R_cam_from_gaze: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares ``t_X`` from each view's own translation, not from pairs.

    With the target fixed, every view satisfies ``T_cw^i = X T_gp^i Z`` (``Z =
    T_ptu_from_world``), whose translation part is linear in ``t_X`` and ``t_Z`` once
    ``R_X`` is known::

        t_cw^i = t_X + R_X R_gp^i t_Z + R_X t_gp^i                      (i = 1..n)

    3n equations, 6 unknowns, design ``[I, R_X R_gp^i]``. Nothing multiplies a camera
    rotation by the target distance, as ``t_A = t_i − R_A t_j`` does in every pair
    equation.

    Parameters
    ----------
    T_cam_from_world, T_gaze_from_ptu : numpy.ndarray, shape (n, 4, 4)
    R_cam_from_gaze : numpy.ndarray, shape (3, 3)

    Returns
    -------
    (t_cam_from_gaze (3,), t_ptu_from_world (3,), cond) with cond = cond(AᵀA).
    Raises :class:`DegenerateDataError` when cond exceeds ``MAX_COND_VIEWS``.
    """
    n = len(T_cam_from_world)
    Q, u = T_gaze_from_ptu[:, :3, :3], T_gaze_from_ptu[:, :3, 3]
    A = np.zeros((n, 3, 6))
    A[:, :, :3] = np.eye(3)
    A[:, :, 3:] = R_cam_from_gaze @ Q
    b = T_cam_from_world[:, :3, 3] - u @ R_cam_from_gaze.T
    A, b = A.reshape(-1, 6), b.reshape(-1)
    AtA = A.T @ A
    lam = np.linalg.eigvalsh(AtA)
    cond = float(lam[-1] / lam[0]) if lam[0] > 0 else np.inf
    if not cond <= MAX_COND_VIEWS:
        raise DegenerateDataError(
            f"translation is not determined: cond(AᵀA) = {cond:.3g} > {MAX_COND_VIEWS:g} "
            "for the views' translations; the unit's rotations are nearly about one axis; "
            "add positions that turn about a second axis (combine pan with tilt)")
    x = np.linalg.solve(AtA, A.T @ b)
    return x[:3], x[3:], cond


def solve_rasc_views(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *,
                     min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
                     check_rigid: bool = True) -> HandEyeResult:
    """RASC's rotation (eq. 6–9) with the translation from the views themselves
    (:func:`views_translation`): method "rasc-views".

    Parameters and checks as :func:`solve_rasc_inverse` (validation and degeneracy by
    :func:`rasc.handeye.solver.solve_rasc`). ``cond_CtC`` in the diagnostics is that of
    the per-view system. Assumes, as eq. 6–7 do, that the target does not move while the
    unit does.
    """
    base = solve_rasc(T_cam_from_world, T_gaze_from_ptu, min_rotation_rad=min_rotation_rad,
                      check_rigid=check_rigid)
    T_cw = validate_poses(T_cam_from_world, "T_cam_from_world", check_rigid=False)
    T_gp = validate_poses(T_gaze_from_ptu, "T_gaze_from_ptu", check_rigid=False)
    RX = np.asarray(base.T_cam_from_gaze)[:3, :3]
    tX, _, cond = views_translation(T_cw, T_gp, RX)
    return HandEyeResult(T_cam_from_gaze=make_transform(RX, tX), quality=base.quality,
                         method="rasc-views",
                         diagnostics=dataclasses.replace(base.diagnostics, cond_CtC=cond))
