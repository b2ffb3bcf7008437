"""Pose-residual refinement of any hand-eye result, with a robust loss and a covariance.

The closed forms solve the motion equations ``A X = X B`` (eq. 6–9) in two steps:
rotation first from the rotations alone, translation after. When the motions turn about
nearly one axis the rotation about it is weakly determined by the rotations, while a
unit that also translates (a robot arm) fixes it through its translations — information
the two-step closed form never uses for the rotation. The refinement solves rotation and
translation jointly, on the pose equation behind ``A X = X B`` (:mod:`rasc.handeye.robust`)::

    T_cam_from_world_k ≈ X · T_gaze_from_ptu_k · Y          X = T_cam_from_gaze,
                                                            Y = T_ptu_from_world

with residuals per position (independent between positions, unlike the n(n−1) motions,
which share their poses)::

    r_R,k = log(R_predᵀ R_k) / σ_R         (3, the target's frame: eq. 13's noise)
    r_t,k = (t_k − t_pred) / σ_t           (3, the camera frame: eq. 14's noise)

over the 12 unknowns (X and Y, each as a rotation vector perturbing the start on the left
and a translation), by ``scipy.optimize.least_squares`` with a robust loss (``huber`` by
default, at ``F_SCALE`` = 1.345 σ: 95 % of least squares' efficiency on Gaussian
residuals; ``soft_l1`` too). The scales σ_R, σ_t come from the data: the median residual
norm of the start (each 3-D residual's median norm is 1.538 σ), then once more from the
first solution's residuals, with a correction for the 12 fitted unknowns.

**Unknown scale.** A start that estimated the camera translations' scale
(``rasc-scale``, :mod:`rasc.handeye.scale`: ``t_cam_from_world (true) = s · t_given``),
or an explicit ``scale=``, adds s as a 13th unknown, refined jointly: the translation
residual becomes ``s · t_k − t_pred`` (in the unit's length unit), s is parametrised as
``s_0 · exp(u)`` (it stays positive; ``σ_s = s · σ_u``), and the translation residuals'
σ is corrected for 7 fitted unknowns instead of 6. The result's ``scale`` and
``std_scale`` replace the start's s; ``covariance_with_scale`` is the 7×7 covariance of X
and s (s last). Without a scale the camera translations are taken at face value.

Covariance: ``C = s² (Jᵀ W J)⁻¹`` with J the whitened residuals' Jacobian at the
solution (central differences), W the loss's weights there (1 for residuals inside the
Huber corner) and ``s² = Σ w r² / (m − p)`` (p = 12 unknowns, 13 with the scale); its
6×6 block for X, in the order
(rotation vector of ``R_est R_trueᵀ`` in radians, translation), is the result's
``covariance``. ``std_rotation_deg`` and ``std_translation`` are the square roots of the
traces of its two 3×3 blocks: the predicted RMS of the rotation error (as an angle) and of
the translation error (as a distance), comparable with the jackknife's
(:func:`rasc.handeye.methods.jackknife_uncertainty`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from rasc.errors import InputError, SolverFailure
from rasc.geometry.transforms import (
    make_transform,
    project_to_rotation,
    rotvec_from_matrix,
)
from rasc.handeye.robust import MEDIAN_NORM, _chordal_mean, _inv
from rasc.handeye.solver import HandEyeResult, quality_eq10, validate_poses

LOSSES = ("huber", "soft_l1", "linear")

#: The loss's corner in σ: Huber's 1.345 keeps 95 % of least squares' efficiency on
#: Gaussian residuals.
F_SCALE = 1.345

#: Unknowns: X's and Y's rotation vector and translation (and the scale's log, when
#: the scale is refined: N_PARAMS + 1).
N_PARAMS = 12

#: least_squares' tolerances (ftol, xtol, gtol): the problem is small and smooth.
TOL = 1e-12

#: Central-difference step of the covariance's Jacobian (radians; the translations' step
#: is this times the target distance).
STEP = 1e-6


@dataclass(frozen=True)
class RefinedHandEyeResult(HandEyeResult):
    """A hand-eye result refined on the pose residuals (module docstring).

    covariance : (6, 6) of X: rotation vector (rad) then translation (input's unit).
    std_rotation_deg, std_translation : √trace of its rotation and translation blocks.
    sigma_rotation_deg, sigma_translation : the noise scales read from the data.
    loss : the robust loss; start : the method it started from.
    T_ptu_from_world : (4, 4) Y, the target's pose in the unit's base frame.
    n_downweighted : positions with a residual beyond the loss's corner.
    start_details : what the start's ``to_dict`` said beyond a plain result
        (``rasc-robust``'s "robust", ``rasc-scale``'s "scale").
    inliers : the positions refined over when the start was ``rasc-robust``'s (its
        inliers; the rejected positions stay out), else empty (all of them).
    rejected : the start's rejected positions (:class:`rasc.handeye.robust.Rejection`).
    replaces : the start's ``replaces`` (:class:`rasc.handeye.robust.RobustHandEyeResult`:
        the method rasc-robust was chosen instead of, by
        :func:`rasc.handeye.robust_calibrate.closed_form`), else "".
    scale : the refined scale of the camera translations (NaN: not refined, the camera
        translations taken at face value).
    std_scale : its standard deviation (from the covariance).
    scale_start : the scale the refinement started from.
    residual_rms : RMS of the translation residuals at the solution (the unit's length
        unit; per component, as ``rasc-scale``'s).
    covariance_with_scale : (7, 7) of X and s (s last), or None without a scale.
    """

    covariance: Any = None
    std_rotation_deg: float = math.nan
    std_translation: float = math.nan
    sigma_rotation_deg: float = math.nan
    sigma_translation: float = math.nan
    loss: str = "huber"
    start: str = ""
    T_ptu_from_world: Any = None
    n_downweighted: int = 0
    start_details: Any = None
    inliers: tuple[int, ...] = ()
    rejected: tuple = ()
    replaces: str = ""
    scale: float = math.nan
    std_scale: float = math.nan
    scale_start: float = math.nan
    residual_rms: float = math.nan
    covariance_with_scale: Any = None

    @property
    def scale_refined(self) -> bool:
        """True when the camera translations' scale was refined with X."""
        return math.isfinite(self.scale)

    def to_dict(self) -> dict[str, Any]:
        """The starting method's result document with a ``refinement`` block (the refined pose,
        its covariance); with a refined scale, the ``scale`` block holds the refined s and
        its standard deviation."""
        out = super().to_dict()
        out.update(self.start_details or {})
        if self.scale_refined:
            out["scale"] = {
                "s": self.scale, "std": self.std_scale,
                "residual_rms": self.residual_rms, "start": self.scale_start,
                "meaning": "t_cam_from_world (true) = s * t_cam_from_world (given); "
                           "T_cam_from_gaze's translation is in the unit's length unit; "
                           "s refined jointly with T_cam_from_gaze (std from the "
                           "refinement's covariance)"}
        out["refinement"] = refinement_summary(self)
        return out


def refinement_summary(result: RefinedHandEyeResult) -> dict[str, Any]:
    """The refinement's numbers as a JSON-ready dict."""
    return {
        "start": result.start,
        "loss": result.loss,
        "residuals": "pose: T_cam_from_world_k vs T_cam_from_gaze T_gaze_from_ptu_k "
                     "T_ptu_from_world, rotation and translation jointly",
        "sigma_rotation_deg": result.sigma_rotation_deg,
        "sigma_translation": result.sigma_translation,
        "std_rotation_deg": result.std_rotation_deg,
        "std_translation": result.std_translation,
        "covariance": np.asarray(result.covariance).tolist(),
        "covariance_order": "rotation vector of R_est R_true^T (rad, x y z), then "
                            "translation (input's length unit, x y z)",
        "n_downweighted": result.n_downweighted,
        "T_ptu_from_world": np.asarray(result.T_ptu_from_world).tolist(),
        **({"scale": result.scale, "std_scale": result.std_scale,
            "covariance_with_scale": np.asarray(result.covariance_with_scale).tolist(),
            "covariance_with_scale_order": "covariance's order, then the scale s"}
           if result.scale_refined else {}),
    }


def _exp(r: np.ndarray) -> np.ndarray:
    """Rodrigues' formula for one rotation vector (3,) → (3, 3) (series below 1e-6 rad)."""
    theta = math.sqrt(float(r @ r))
    K = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    if theta < 1e-6:
        return np.eye(3) + K + 0.5 * K @ K
    return (np.eye(3) + math.sin(theta) / theta * K
            + (1.0 - math.cos(theta)) / theta ** 2 * K @ K)


def _log(R: np.ndarray) -> np.ndarray:
    """Rotation vectors of rotations (n, 3, 3), the atan2 form (accurate near 0); angles
    within 1e-3 rad of π go through scipy (the skew part loses the axis there)."""
    w = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0],
                  R[:, 1, 0] - R[:, 0, 1]], axis=1)
    s = 0.5 * np.linalg.norm(w, axis=1)
    c = 0.5 * (np.trace(R, axis1=1, axis2=2) - 1.0)
    theta = np.arctan2(s, c)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(s > 1e-8, theta / (2.0 * s), 0.5 + theta ** 2 / 12.0)
    out = f[:, None] * w
    near_pi = theta > math.pi - 1e-3
    if near_pi.any():
        out[near_pi] = rotvec_from_matrix(R[near_pi])
    return out


class _Problem:
    """The pose residuals over p = (X's rotation vector, t_X, Y's rotation vector, t_Y
    [, u]); with ``scale0`` the camera translations are ``scale0 · exp(u) · t_given``."""

    def __init__(self, T_cw, T_gp, X0, Y0, scale0: float | None = None):
        self.R, self.t = T_cw[:, :3, :3], T_cw[:, :3, 3]
        self.G = T_gp
        self.RX0, self.RY0 = X0[:3, :3], Y0[:3, :3]
        self.w = np.ones(2)
        self.scale0 = scale0

    @property
    def n_params(self) -> int:
        return N_PARAMS + (self.scale0 is not None)

    def scale(self, p) -> float:
        """The camera translations' scale at p (1 when not refined)."""
        return 1.0 if self.scale0 is None else self.scale0 * math.exp(p[N_PARAMS])

    def transforms(self, p):
        X = make_transform(_exp(p[0:3]) @ self.RX0, p[3:6])
        Y = make_transform(_exp(p[6:9]) @ self.RY0, p[9:12])
        return X, Y

    def raw(self, p):
        X, Y = self.transforms(p)
        P = X @ self.G @ Y
        r = _log(np.swapaxes(P[:, :3, :3], -1, -2) @ self.R)
        return r, self.scale(p) * self.t - P[:, :3, 3]

    def residuals(self, p):
        r, t = self.raw(p)
        return np.concatenate([r / self.w[0], t / self.w[1]], axis=1).ravel()


def _sigmas(r: np.ndarray, t: np.ndarray, n_fit: int) -> tuple[float, float]:
    """σ of the rotation and translation residuals: median norm / 1.538, corrected for
    the unknowns fitted (the rotations fix 6 of the 12; the translations the other 6,
    and the scale when it is refined: ``n_fit`` 13)."""
    m = 3 * len(r)
    n_rot = N_PARAMS // 2
    return (float(np.median(np.linalg.norm(r, axis=1))) / MEDIAN_NORM
            * math.sqrt(m / max(m - n_rot, 1)),
            float(np.median(np.linalg.norm(t, axis=1))) / MEDIAN_NORM
            * math.sqrt(m / max(m - (n_fit - n_rot), 1)))


def _weights(z: np.ndarray, loss: str) -> np.ndarray:
    """The loss's IRLS weight ρ'(z²)·… per residual z (in units of F_SCALE)."""
    a = np.abs(z) / F_SCALE
    if loss == "huber":
        return np.where(a <= 1.0, 1.0, 1.0 / np.maximum(a, 1e-300))
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + a ** 2)
    return np.ones_like(z)


def target_start(X0: np.ndarray, T_gaze_from_ptu: np.ndarray,
                 T_cam_from_world: np.ndarray) -> np.ndarray:
    """The refinement's start for ``Y = T_ptu_from_world`` given X0: the chordal mean of
    each position's ``Y_k = (X0 T_gaze_from_ptu_k)⁻¹ T_cam_from_world_k`` rotation and
    the mean of their translations."""
    Yk = _inv(X0[None] @ T_gaze_from_ptu) @ T_cam_from_world
    return make_transform(_chordal_mean(Yk[None, :, :3, :3], np.ones((1, len(Yk))))[0],
                          Yk[:, :3, 3].mean(axis=0))


def fit_problem(problem: _Problem, p: np.ndarray, *, loss: str, distance: float,
                extra_steps: np.ndarray, what: str
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve ``problem`` (a :class:`_Problem`, or one with more unknowns after the 12 of
    X and Y) from ``p``: the noise scales from the start, then once more from the first
    solution (:func:`_sigmas`), ``least_squares`` with ``loss`` each time, and the
    covariance ``s² (Jᵀ W J)⁻¹`` from central differences at the solution (steps
    :data:`STEP` for rotations, ``STEP · distance`` for translations, ``extra_steps`` for
    the unknowns after the 12). Returns ``(p, z, C)``: the solution, its whitened
    residuals and the covariance of all unknowns. Raises :class:`SolverFailure` (naming
    ``what``) when the optimiser does not converge or the covariance is singular."""
    n_params = problem.n_params
    floor = (1e-12, 1e-12 * distance)
    for _ in range(2):                     # σ from the start, then from the first solution
        r, t = problem.raw(p)
        s_r, s_t = _sigmas(r, t, n_params)
        problem.w = np.array([max(s_r, floor[0]), max(s_t, floor[1])])
        fit = least_squares(problem.residuals, p, loss=loss, f_scale=F_SCALE,
                            ftol=TOL, xtol=TOL, gtol=TOL, x_scale="jac")
        if fit.status <= 0 or not np.all(np.isfinite(fit.x)):
            raise SolverFailure(f"the pose-residual refinement did not converge "
                                f"({fit.message})")
        p = fit.x
    # covariance from the whitened Jacobian at the solution (central differences)
    z = problem.residuals(p)
    steps = np.r_[np.full(3, STEP), np.full(3, STEP * distance),
                  np.full(3, STEP), np.full(3, STEP * distance), extra_steps]
    J = np.empty((z.size, n_params))
    for i in range(n_params):
        e = np.zeros(n_params)
        e[i] = steps[i]
        J[:, i] = (problem.residuals(p + e) - problem.residuals(p - e)) / (2 * steps[i])
    w = _weights(z, loss)
    s2 = float(np.sum(w * z ** 2)) / max(z.size - n_params, 1)
    H = J.T @ (w[:, None] * J)
    try:
        C = s2 * np.linalg.inv(H)
    except np.linalg.LinAlgError:
        raise SolverFailure(f"the pose-residual refinement's covariance is singular: the "
                            f"data do not determine {what}") from None
    if not (np.all(np.isfinite(C)) and np.all(np.diag(C) >= 0)):
        raise SolverFailure(f"the pose-residual refinement's covariance is not finite: the "
                            f"data do not determine {what}")
    return p, z, C


def refine_handeye(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                   result: HandEyeResult | np.ndarray, *, loss: str = "huber",
                   check_rigid: bool = True, scale: float | None = None
                   ) -> RefinedHandEyeResult:
    """Refine ``result`` (any method's, or a 4×4 ``T_cam_from_gaze``) on the pose
    residuals, rotation and translation jointly (module docstring).

    Parameters
    ----------
    T_cam_from_world, T_gaze_from_ptu : (n, 4, 4), as for any method.
    result : the start: a HandEyeResult (its diagnostics are kept) or a (4, 4). A
        ``rasc-robust`` result is refined over its inliers only; a ``rasc-scale`` result
        (one with a ``scale``) refines its scale jointly.
    loss : "huber" (default), "soft_l1" or "linear" (plain least squares).
    check_rigid : as :func:`~rasc.handeye.solver.solve_rasc`.
    scale : the camera translations' scale to start from and refine
        (``t_true = scale · t_given``); default: the start's ``scale`` when it has one,
        else none (the translations taken at face value).

    Returns
    -------
    RefinedHandEyeResult
        method ``"<start>+refine"``. Raises :class:`SolverFailure` when the optimiser
        does not converge or the covariance is singular (data that do not determine X,
        or the scale), :class:`InputError` for a scale that is not a positive number.
    """
    if loss not in LOSSES:
        raise InputError(f"loss: expected one of {LOSSES}, got {loss!r}")
    T_cw = validate_poses(T_cam_from_world, "T_cam_from_world", check_rigid=check_rigid)
    T_gp = validate_poses(T_gaze_from_ptu, "T_gaze_from_ptu", check_rigid=check_rigid)
    if len(T_cw) != len(T_gp):
        raise InputError(f"T_cam_from_world has {len(T_cw)} positions, T_gaze_from_ptu "
                         f"{len(T_gp)}")
    if scale is None:
        start_scale = getattr(result, "scale", None)
        scale = float(start_scale) if start_scale is not None \
            and math.isfinite(float(start_scale)) else None
    elif isinstance(scale, bool) or not isinstance(scale, (int, float, np.floating)) \
            or not (math.isfinite(float(scale)) and float(scale) > 0):
        raise InputError(f"scale: expected a positive finite number, got {scale!r}")
    start = result.method if isinstance(result, HandEyeResult) else "given"
    inliers = tuple(getattr(result, "inliers", ()) or ())
    if inliers:          # rasc-robust's start: refine on the positions it kept
        T_cw, T_gp = T_cw[list(inliers)], T_gp[list(inliers)]
    X0 = np.asarray(result.T_cam_from_gaze if isinstance(result, HandEyeResult) else result,
                    dtype=float)
    # nearest rotations of (possibly literal eq. 13) input
    T_cw = T_cw.copy()
    T_cw[:, :3, :3] = project_to_rotation(T_cw[:, :3, :3])
    s0 = 1.0 if scale is None else float(scale)
    T_scaled = T_cw.copy()
    T_scaled[:, :3, 3] *= s0                 # in the unit's length unit
    Y0 = target_start(X0, T_gp, T_scaled)
    problem = _Problem(T_cw, T_gp, X0, Y0, None if scale is None else s0)
    n_params = problem.n_params
    distance = max(float(np.median(np.linalg.norm(T_scaled[:, :3, 3], axis=1))), 1e-300)
    p = np.zeros(n_params)
    p[3:6], p[9:12] = X0[:3, 3], Y0[:3, 3]
    what = "T_cam_from_gaze" if scale is None else "T_cam_from_gaze and the scale"
    p, z, C = fit_problem(problem, p, loss=loss, distance=distance,
                          extra_steps=np.full(n_params - N_PARAMS, STEP), what=what)
    X, Y = problem.transforms(p)
    CX = C[:6, :6].copy()
    scale_fields: dict[str, Any] = {}
    if scale is not None:
        s_hat = problem.scale(p)
        # s = s0 exp(u): the delta method, ds = s du
        D = np.diag(np.r_[np.ones(6), s_hat])
        CXs = D @ C[np.ix_([0, 1, 2, 3, 4, 5, N_PARAMS], [0, 1, 2, 3, 4, 5, N_PARAMS])] @ D
        CXs.flags.writeable = False
        scale_fields = {"scale": s_hat, "std_scale": math.sqrt(CXs[6, 6]),
                        "scale_start": s0, "covariance_with_scale": CXs}
    per_position = np.abs(z.reshape(len(T_cw), 6)).max(axis=1)
    R = np.ascontiguousarray(T_cw[None, :, :3, :3])
    Q = np.ascontiguousarray(T_gp[None, :, :3, :3])
    quality = float(quality_eq10(R, Q, X[None, :3, :3])[0])
    diagnostics = result.diagnostics if isinstance(result, HandEyeResult) else None
    if diagnostics is None:
        from rasc.handeye.solver import diagnose

        diagnostics = diagnose(T_cw, T_gp, check_rigid=check_rigid)[0]
    CX.flags.writeable = False
    return RefinedHandEyeResult(
        T_cam_from_gaze=X, quality=quality, method=f"{start}+refine",
        diagnostics=diagnostics, covariance=CX,
        std_rotation_deg=math.degrees(math.sqrt(np.trace(CX[:3, :3]))),
        std_translation=math.sqrt(np.trace(CX[3:, 3:])),
        sigma_rotation_deg=math.degrees(problem.w[0]), sigma_translation=problem.w[1],
        loss=loss, start=start, T_ptu_from_world=Y,
        n_downweighted=int(np.sum(per_position > F_SCALE)) if loss != "linear" else 0,
        start_details={k: v for k, v in (result.to_dict().items()
                                         if isinstance(result, HandEyeResult) else ())
                       if k in ("robust", "scale")},
        inliers=inliers, rejected=tuple(getattr(result, "rejected", ()) or ()),
        replaces=str(getattr(result, "replaces", "") or ""),
        residual_rms=float(np.sqrt(np.mean(problem.raw(p)[1] ** 2))),
        **scale_fields)
