"""``rasc-scale``: hand-eye with the scale of the camera translations unknown.

Camera poses from monocular visual odometry or structure from motion carry their
translations in an unknown unit: ``t_cam_from_world_true = s · t_given``. With (P) of
:mod:`rasc.handeye.robust`, ``T_cam_from_world_k = X · T_gaze_from_ptu_k · Y``, the
rotations do not see s (eq. 6–9 give R_X as for RASC), and the translations are linear in
``t_X``, ``t_Y`` and s::

    s · t_cw^k − R_X R_gp^k t_Y − t_X = R_X t_gp^k                          (S)

(3n equations, 7 unknowns; ``X = T_cam_from_gaze``, ``Y = T_ptu_from_world``), solved by
linear least squares. The unit's own translations ``t_gp^k`` fix the scale: for a unit
that does not translate (a pan-tilt head, eq. 3) the right-hand side is zero, s and the
translations are only known up to one common factor, and :func:`solve_rasc_scaled`
raises :class:`~rasc.errors.DegenerateDataError` (RASC's ``t_X`` is then simply in the
camera translations' own unit). It raises too, each with its own reason
(:func:`scale_undetermined`), when every camera translation is zero (nothing to scale),
when (S)'s columns are nearly dependent, or when s comes out known to worse than
:data:`MAX_SCALE_RSD` of itself. The result's translation is in the unit's length unit.
``--refine`` (:func:`rasc.handeye.robust_refine.refine_handeye`) refines s jointly with
X and gives its standard deviation from the covariance.

:func:`scale_fit` compares the translations' fit of (S) with s free against s = 1; the
advice (:func:`rasc.handeye.advice.translation_warnings`) names an unknown scale when the
scaled fit is far better (:data:`FAR_BETTER`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rasc.errors import DegenerateDataError, SolverFailure
from rasc.handeye.solver import MIN_PAIR_ROTATION_RAD, HandEyeResult, solve_rasc

NAME = "rasc-scale"

#: (S)'s columns scaled to unit norm must have cond ≤ this (RASC's cond(CᵀC) limit of 1e4
#: on the normal equations is 100 on the matrix itself): above it the unit's
#: translations are too small to fix s.
MAX_COND = 100.0

#: The scale's relative standard error (from the residuals) must be at most this.
MAX_SCALE_RSD = 0.1

#: The scaled fit is "far better" when its translation residual RMS is below this
#: fraction of the fit with s = 1, and s is off 1 by more than ``SCALE_OFF``.
FAR_BETTER = 0.2
SCALE_OFF = 0.05


@dataclass(frozen=True)
class ScaledHandEyeResult(HandEyeResult):
    """RASC's rotation with (S)'s translation and scale.

    scale : s, the factor that brings the camera translations to the unit's length unit.
    residual_rms : RMS of (S)'s residuals at the solution (the unit's length unit).
    std_scale : s's standard error from (S)'s residuals (R_X held: the rotation's error
        is not in it; ``--refine`` gives one with it).
    """

    scale: float = math.nan
    residual_rms: float = math.nan
    std_scale: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """The result document with a ``scale`` block: the estimated scale of the camera
        translations."""
        out = super().to_dict()
        out["scale"] = {"s": self.scale, "std": self.std_scale,
                        "residual_rms": self.residual_rms,
                        "meaning": "t_cam_from_world (true) = s * t_cam_from_world (given); "
                                   "T_cam_from_gaze's translation is in the unit's length "
                                   "unit; std from (S)'s residuals with R_cam_from_gaze held"}
        return out


@dataclass(frozen=True)
class ScaleFit:
    """(S) solved with s free and with s = 1 (residual RMS each, in the unit's unit)."""

    scale: float
    rms_scaled: float
    rms_unscaled: float
    t_cam_from_gaze: np.ndarray
    std_scale: float = math.nan


def _system(R_X: np.ndarray, T_cw: np.ndarray, T_gp: np.ndarray):
    n = len(T_cw)
    A = np.zeros((3 * n, 7))
    A[:, 0:3] = -np.tile(np.eye(3), (n, 1))                       # t_X
    A[:, 3:6] = -(R_X @ T_gp[:, :3, :3]).reshape(3 * n, 3)        # t_Y
    A[:, 6] = T_cw[:, :3, 3].reshape(-1)                          # s
    b = (T_gp[:, :3, 3] @ R_X.T).reshape(-1)
    return A, b


def _scale_fit(R_X: np.ndarray, T_cam_from_world: np.ndarray,
               T_gaze_from_ptu: np.ndarray) -> ScaleFit | str:
    """(S) with s free and with s = 1, or the reason s is not determined (one clause)."""
    T_cw = np.asarray(T_cam_from_world, dtype=float)
    T_gp = np.asarray(T_gaze_from_ptu, dtype=float)
    A, b = _system(np.asarray(R_X, dtype=float), T_cw, T_gp)
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
        return "the poses are not finite numbers"
    if not np.any(b):
        return ("the unit's motions do not translate (a unit that only turns, such as a "
                "pan-tilt head), so they do not fix the scale; the hand-eye translation "
                "is then known in the camera translations' own unit: use --method rasc")
    if not np.any(A[:, 6]):
        return ("every camera translation (T_cam_from_world's) is zero, so there is "
                "nothing to scale, though the unit translates: a target seen from a "
                "moving camera moves in it; give each T_cam_from_world with its "
                "translation (the target's position in the camera)")
    norms = np.linalg.norm(A, axis=0)
    sv = np.linalg.svd(A / norms, compute_uv=False)
    cond = sv[0] / sv[-1] if sv[-1] > 0 else math.inf
    if not cond <= MAX_COND:
        return (f"the translations do not separate the scale from the hand-eye "
                f"translation (cond {cond:.3g} > {MAX_COND:g} of (S)'s columns): the "
                "unit's translations are too small against its rotations, or the camera "
                "translations barely change between positions; add positions that "
                "translate the unit further")
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    # s's standard error from the residuals; a scale known to worse than MAX_SCALE_RSD
    # of itself is not a number to return
    dof = max(A.shape[0] - A.shape[1], 1)
    var = float(np.sum((A @ x - b) ** 2)) / dof * np.linalg.inv(A.T @ A)[6, 6]
    std = math.sqrt(max(var, 0.0))
    if not std <= MAX_SCALE_RSD * abs(x[6]):
        return (f"the scale comes out as {x[6]:.3g} ± {std:.2g}, known to worse than "
                f"{MAX_SCALE_RSD:.0%} of itself: the translations are too noisy for the "
                "unit's motions; add positions that translate the unit further")
    x1 = np.linalg.lstsq(A[:, :6], b - A[:, 6], rcond=None)[0]
    rms = float(np.sqrt(np.mean((A @ x - b) ** 2)))
    rms1 = float(np.sqrt(np.mean((A[:, :6] @ x1 - (b - A[:, 6])) ** 2)))
    return ScaleFit(float(x[6]), rms, rms1, x[:3], std)


def scale_fit(R_X: np.ndarray, T_cam_from_world: np.ndarray,
              T_gaze_from_ptu: np.ndarray) -> ScaleFit | None:
    """(S) with s free and with s = 1; None when s is not determined
    (:func:`scale_undetermined` says why): a unit that does not translate (right-hand
    side zero), camera translations all zero, cond above :data:`MAX_COND`, or a
    relative standard error above :data:`MAX_SCALE_RSD`."""
    fit = _scale_fit(R_X, T_cam_from_world, T_gaze_from_ptu)
    return None if isinstance(fit, str) else fit


def scale_undetermined(R_X: np.ndarray, T_cam_from_world: np.ndarray,
                       T_gaze_from_ptu: np.ndarray) -> str | None:
    """Why (S) does not determine s (one clause, with what to do), or None when it does."""
    fit = _scale_fit(R_X, T_cam_from_world, T_gaze_from_ptu)
    return fit if isinstance(fit, str) else None


def scale_warning(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                  R_cam_from_gaze: np.ndarray) -> str | None:
    """One sentence when the translations fit a scaled solution far better than the
    given scale (:data:`FAR_BETTER`), else None."""
    with np.errstate(all="ignore"):
        fit = scale_fit(R_cam_from_gaze, T_cam_from_world, T_gaze_from_ptu)
    if fit is None or not (fit.scale > 0 and math.isfinite(fit.rms_unscaled)):
        return None
    if fit.rms_scaled >= FAR_BETTER * fit.rms_unscaled or abs(fit.scale - 1) <= SCALE_OFF:
        return None
    return (f"the camera translations fit far better once multiplied by a common scale "
            f"s = {fit.scale:.4g} (residual RMS {fit.rms_scaled:.3g} against "
            f"{fit.rms_unscaled:.3g} at s = 1): poses without metric scale (monocular "
            "visual odometry, structure from motion) or in another length unit than the "
            f"unit's; solve with --method {NAME}, which estimates s")


def solve_rasc_scaled(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *,
                      min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
                      check_rigid: bool = True) -> ScaledHandEyeResult:
    """Hand-eye and the camera translations' scale (module docstring).

    Parameters
    ----------
    T_cam_from_world : (n, 4, 4), translations in any unit (s · them is the truth).
    T_gaze_from_ptu : (n, 4, 4), the unit's motions (a robot arm's
        ``T_gripper_from_base``), translations in the unit's length unit.
    min_rotation_rad, check_rigid : as :func:`~rasc.handeye.solver.solve_rasc`.

    Returns
    -------
    ScaledHandEyeResult
        method "rasc-scale"; ``scale`` s; ``T_cam_from_gaze`` with its translation in
        the unit's length unit; quality and diagnostics RASC's (scale-free). Raises
        :class:`DegenerateDataError` when the unit's translations cannot fix s, and
        :class:`SolverFailure` when the data give s ≤ 0.
    """
    rasc = solve_rasc(T_cam_from_world, T_gaze_from_ptu, min_rotation_rad=min_rotation_rad,
                      check_rigid=check_rigid)
    T_cw = np.asarray(T_cam_from_world, dtype=float)
    T_gp = np.asarray(T_gaze_from_ptu, dtype=float)
    R_X = np.asarray(rasc.T_cam_from_gaze)[:3, :3]
    fit = _scale_fit(R_X, T_cw, T_gp)
    if isinstance(fit, str):
        raise DegenerateDataError(f"{NAME}: cannot estimate the scale of the camera "
                                  f"translations: {fit}")
    if not fit.scale > 0:
        raise SolverFailure(f"rasc-scale: the data give a scale of {fit.scale:.3g} (not "
                            "positive): the camera poses and the unit's motions are "
                            "inconsistent; check that they belong together")
    T = np.eye(4)
    T[:3, :3] = R_X
    T[:3, 3] = fit.t_cam_from_gaze
    return ScaledHandEyeResult(T_cam_from_gaze=T, quality=rasc.quality, method=NAME,
                               diagnostics=rasc.diagnostics, scale=fit.scale,
                               residual_rms=fit.rms_scaled, std_scale=fit.std_scale)
