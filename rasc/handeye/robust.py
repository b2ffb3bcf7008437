"""``rasc-robust``: hand-eye that rejects bad positions (consensus, then RASC on the inliers).

Consistent data satisfy, at every position k, the pose equation behind ``A X = X B``::

    T_cam_from_world_k = X · T_gaze_from_ptu_k · Y                              (P)

with ``X = T_cam_from_gaze`` (the paper's T_cg) and ``Y = T_ptu_from_world``, the
target's fixed pose in the unit's base frame (for a robot arm ``T_base_from_world``).
Eq. 6–7's motions ``A_ij = T_cw^i (T_cw^j)⁻¹`` follow from (P) by eliminating Y. So a
hypothesis X gives each position its own estimate of Y::

    Y_k = (X · T_gaze_from_ptu_k)⁻¹ · T_cam_from_world_k

and a position that does not belong (a misdetected board, a pose logged beside the
wrong motion, a wrong angle reading) is one whose ``Y_k`` lands away from the others'.
Its **residuals** are the rotation angle of ``R_Yᵀ R_Yk`` and the distance
``‖t_Yk − t_Y‖`` (the error of (P)'s prediction of the pose, in the camera, in the
input's length unit); Y is the mean of the Y_k over the positions the hypothesis is fit to
(chordal mean of the rotations, mean of the translations).

Algorithm (:func:`solve_rasc_robust`):

1. **Hypotheses** from minimal samples of 3 positions (the fewest whose motions turn
   about two axes), each solved by RASC's closed form (Park–Martin rotation, eq. 6–9;
   eq. 7 translation): every triple when there are at most ``max_draws`` of them, else
   ``max_draws`` triples drawn with ``numpy.random.default_rng(seed)`` (same seed → same
   bits). A degenerate triple (motions about one axis) gives no hypothesis.
2. **Noise scale from the data**: the hypothesis with the least median residual (each
   residual divided by its lowest median over hypotheses, so rotation and translation are
   comparable) is the initial fit; RASC on the half of the positions it fits best
   refines it; the noise scales are read from that fit's residuals as a robust scale
   ``σ = q25(r) / 1.101`` (the lower quartile of a 3-D Gaussian error's norm is
   1.101 σ: it stays honest up to 75 % of bad positions, where a median would not above
   50 %). The thresholds are ``THRESHOLD_SIGMAS`` σ (the 99.9 % point of that norm: a
   good position is rejected by one of the two tests about 2 times in 1000), never below
   a floor of round-off (``FLOOR_ROTATION_RAD``, ``FLOOR_RELATIVE`` of the target
   distance).
3. **MSAC**: every hypothesis is scored by ``Σ_k min((r_k/τ)², 1)`` over both residuals;
   the best one's inliers (both residuals within threshold) are solved by RASC, the
   residuals measured again against that solution as 3-D vectors, their covariance
   estimated from the inliers (:func:`_covariance`: an anisotropic error, as PnP's, is
   measured as such), and the inlier set recomputed with the Mahalanobis distance against
   the 99.9 % bound that allows for that covariance being estimated from the inliers
   themselves (:func:`_limit`, Hotelling's), until it is stable (at most ``MAX_ROUNDS``
   rounds).

The result (:class:`RobustHandEyeResult`) is RASC's on the inliers (its quality and
diagnostics are those of the inliers) and names each rejected position and why (rotation
residual, translation residual, or both, each against its threshold). Fewer than 3
consistent positions, or inliers that are degenerate, raise
:class:`~rasc.errors.DegenerateDataError`: no number is returned that the data do not
support.

:func:`rasc.handeye.robust_calibrate.closed_form` is the outlier policy ``rasc calibrate``
and ``rasc handeye`` both use: RASC, or ``rasc-robust`` when the consistency checks of
:mod:`rasc.handeye.advice` flag the RASC solution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations
from typing import Any

import numpy as np

from rasc.errors import DegenerateDataError, InputError, RascError
from rasc.geometry.transforms import rotvec_from_matrix
from rasc.handeye.solver import (
    MIN_AXIS_SPREAD,
    MIN_PAIR_ROTATION_RAD,
    HandEyeResult,
    diagnose,
    solve_rasc,
    solve_rasc_batch,
)

#: Name of the method in :data:`rasc.handeye.methods.METHODS`.
NAME = "rasc-robust"

#: Minimal sample: 3 positions give 3 motions, which turn about two axes in general.
MINIMAL = 3

#: Hypotheses drawn at most; all triples are used when there are no more than this
#: (9 positions: 84 triples). With half the positions bad a triple is clean with
#: probability 1/8 (a little less without replacement), so 200 draws miss every clean
#: triple with probability (7/8)^200 ≈ 2.6e-12.
MAX_DRAWS = 200

#: Threshold in σ of the residual norm: √(χ²₃ at 0.999) = 4.03 for a 3-D Gaussian error.
THRESHOLD_SIGMAS = 4.03

#: The lower quartile of the norm of a 3-D standard Gaussian: √(χ²₃ at 0.25) = 1.101.
Q25_NORM = 1.101

#: The median of the norm of a 3-D standard Gaussian: √(χ²₃ at 0.5) = 1.538.
MEDIAN_NORM = 1.538

#: Thresholds never go below round-off: noise-free data still leave residuals of ~1e-15.
FLOOR_ROTATION_RAD = 1e-9
FLOOR_RELATIVE = 1e-9

#: Inliers needed to measure the residuals' 3×3 covariance (else isotropic).
MIN_FOR_COVARIANCE = 8

#: Rounds of "solve the inliers, measure, re-select".
MAX_ROUNDS = 5


@dataclass(frozen=True)
class Rejection:
    """A position left out by ``rasc-robust``.

    index : the position (0-based, in the input's order).
    rotation_deg, translation : its residuals against the final solution (the rotation
        of (P)'s error in degrees, the translation in the input's length unit).
    reason : "rotation residual", "translation residual" or both, against the thresholds.
    """

    index: int
    rotation_deg: float
    translation: float
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """The rejection as the result document writes it (position, residuals, reason)."""
        return {"position": self.index, "rotation_residual_deg": self.rotation_deg,
                "translation_residual": self.translation, "reason": self.reason}


@dataclass(frozen=True)
class RobustHandEyeResult(HandEyeResult):
    """RASC on the inliers, with what the consensus decided.

    ``T_cam_from_gaze``, ``quality`` and ``diagnostics`` are RASC's on the inliers.

    Attributes
    ----------
    inliers : tuple of int
        Positions used (indices into the input).
    rejected : tuple of Rejection
        One :class:`Rejection` per position left out.
    sigma_rotation_deg, sigma_translation : float
        The noise scale read from the data.
    threshold_rotation_deg, threshold_translation : float
        The rejection thresholds along the residuals' widest axis (``limit_sigmas`` σ
        there).
    limit_sigmas : float
        The Mahalanobis distance a position must stay within (:func:`_limit`).
    n_hypotheses : int
        Minimal-sample hypotheses scored.
    seed : int
        Their draw's seed.
    replaces : str
        The method the user asked for that this result was chosen instead of, when
        :func:`rasc.handeye.robust_calibrate.closed_form` switched (its note names the
        rejected positions), else "".
    flagged : tuple of str
        What flagged that method's solution (:func:`rasc.handeye.robust_calibrate.contamination`).
    """

    inliers: tuple[int, ...] = ()
    rejected: tuple[Rejection, ...] = ()
    sigma_rotation_deg: float = math.nan
    sigma_translation: float = math.nan
    threshold_rotation_deg: float = math.nan
    threshold_translation: float = math.nan
    n_hypotheses: int = 0
    seed: int = 0
    limit_sigmas: float = math.nan
    replaces: str = ""
    flagged: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """RASC's result document with a ``robust`` block: the inliers and each rejected
        position."""
        out = super().to_dict()
        out["robust"] = robust_summary(self)
        return out


def robust_summary(result: RobustHandEyeResult) -> dict[str, Any]:
    """The consensus's decisions as a JSON-ready dict."""
    return {
        "algorithm": ("MSAC over minimal samples of 3 positions (RASC / Park-Martin), "
                      "then RASC on the inliers"),
        "inliers": list(result.inliers),
        "rejected": [r.to_dict() for r in result.rejected],
        "sigma_rotation_deg": result.sigma_rotation_deg,
        "sigma_translation": result.sigma_translation,
        "threshold_rotation_deg": result.threshold_rotation_deg,
        "threshold_translation": result.threshold_translation,
        "threshold_rule": (f"Mahalanobis distance under the inliers' own residual "
                           f"covariance within {result.limit_sigmas:.3g} (99.9 % for a 3-D "
                           f"Gaussian error, covariance estimated from the "
                           f"{len(result.inliers)} inliers)"),
        "n_hypotheses": result.n_hypotheses,
        "seed": result.seed,
        **({"chosen_instead_of": result.replaces,
            "because": "; ".join(result.flagged)} if result.replaces else {}),
    }


# ------------------------------------------------------------------------ residuals

def _inv(T: np.ndarray) -> np.ndarray:
    out = np.zeros_like(T)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -(Rt @ T[..., :3, 3, None])[..., 0]
    out[..., 3, 3] = 1.0
    return out


def _angle(R: np.ndarray) -> np.ndarray:
    """Rotation angle of (..., 3, 3), accurate near 0 (atan2 of sin and cos)."""
    s = 0.5 * np.sqrt((R[..., 2, 1] - R[..., 1, 2]) ** 2 + (R[..., 0, 2] - R[..., 2, 0]) ** 2
                      + (R[..., 1, 0] - R[..., 0, 1]) ** 2)
    c = 0.5 * (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0)
    return np.arctan2(s, c)


def _chordal_mean(R: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted chordal mean of rotations R (S, n, 3, 3) with weights w (S, n)."""
    M = np.einsum("sn,snij->sij", w, R)
    U, _, Vt = np.linalg.svd(M)
    d = np.sign(np.linalg.det(U @ Vt))
    U[..., :, 2] *= d[..., None]
    return U @ Vt


def pose_residuals(T_cam_from_gaze: np.ndarray, T_cam_from_world: np.ndarray,
                   T_gaze_from_ptu: np.ndarray, fit: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Each position's residuals of (P) under each hypothesis.

    Parameters
    ----------
    T_cam_from_gaze : (S, 4, 4) or (4, 4) hypotheses X.
    T_cam_from_world, T_gaze_from_ptu : (n, 4, 4).
    fit : (S, n) or (n,) weights of the positions Y is averaged over (default: all).

    Returns
    -------
    rotation_rad, translation : (S, n) (or (n,)) residuals (angle of R_Yᵀ R_Yk, radians;
        ‖t_Yk − t_Y‖ in the input's length unit).
    """
    X = np.asarray(T_cam_from_gaze, dtype=float)
    single = X.ndim == 2
    X = X[None] if single else X
    n = len(T_cam_from_world)
    w = np.ones((len(X), n)) if fit is None else np.broadcast_to(
        np.asarray(fit, dtype=float), (len(X), n))
    Y = _inv(X[:, None] @ T_gaze_from_ptu[None]) @ T_cam_from_world[None]     # (S, n, 4, 4)
    RY = _chordal_mean(Y[..., :3, :3], w)                                      # (S, 3, 3)
    tY = np.einsum("sn,sni->si", w, Y[..., :3, 3]) / w.sum(axis=1)[:, None]
    rot = _angle(np.swapaxes(RY, -1, -2)[:, None] @ Y[..., :3, :3])
    trans = np.linalg.norm(Y[..., :3, 3] - tY[:, None], axis=-1)
    return (rot[0], trans[0]) if single else (rot, trans)


# -------------------------------------------------------------------- consensus

def _hypotheses(T_cw: np.ndarray, T_gp: np.ndarray, draws: int, seed: int,
                min_rotation_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """(X (S, 4, 4), samples (S, 3)) from the non-degenerate minimal samples."""
    n = len(T_cw)
    if math.comb(n, MINIMAL) <= draws:
        samples = np.array(list(combinations(range(n), MINIMAL)), dtype=int)
    else:
        rng = np.random.default_rng(seed)
        samples = np.sort(np.array([rng.choice(n, MINIMAL, replace=False)
                                    for _ in range(draws)]), axis=1)
    # triples whose unit motions turn about one axis are left out before the batched
    # solve (one degenerate sample makes it raise); 10x RASC's own limit leaves margin
    # for its camera-side check
    Q = T_gp[:, :3, :3]
    a, b = samples[:, [0, 0, 1]], samples[:, [1, 2, 2]]
    beta = rotvec_from_matrix(Q[a] @ np.swapaxes(Q[b], -1, -2))           # (S, 3, 3)
    lam = np.linalg.eigvalsh(np.einsum("spi,spj->sij", beta, beta))
    samples = samples[lam[:, 1] >= 10 * MIN_AXIS_SPREAD * np.maximum(lam[:, 2], 1e-300)]
    if not len(samples):
        raise DegenerateDataError("rasc-robust: no 3 positions turn about two axes; "
                                  "add positions that move both joints")
    try:                       # the batched solve: one call, unless some sample is degenerate
        X = solve_rasc_batch(T_cw[samples], T_gp[samples],
                             min_rotation_rad=min_rotation_rad, check_rigid=False
                             ).T_cam_from_gaze
        return np.asarray(X), samples
    except RascError:
        pass
    keep, X = [], []
    for s, idx in enumerate(samples):
        try:
            X.append(solve_rasc(T_cw[idx], T_gp[idx], min_rotation_rad=min_rotation_rad,
                                check_rigid=False).T_cam_from_gaze)
            keep.append(s)
        except RascError:
            continue
    if not keep:
        raise DegenerateDataError("rasc-robust: no 3 positions turn about two axes; "
                                  "add positions that move both joints")
    return np.array(X), samples[keep]


def _sigma(r: np.ndarray, floor: float) -> float:
    """Robust noise scale of residual norms r (3-D errors): lower quartile / 1.101."""
    return max(float(np.quantile(r, 0.25)) / Q25_NORM, floor / THRESHOLD_SIGMAS)


def _inlier_sigma(r: np.ndarray, floor: float) -> float:
    """σ of a 3-D Gaussian error from the inliers' residual norms: their median / 1.538
    (the median of a 3-D standard Gaussian's norm, √(χ²₃ at 0.5)), which the 4σ cut
    barely moves (a mean of squares would shrink round by round), times
    √(3m / (3m − 6)) for the 6 unknowns (X's and Y's rotation, or translation) fitted to
    the 3m numbers of m inliers."""
    m = r.size
    dof = math.sqrt(3 * m / max(3 * m - 6, 1))
    return max(float(np.median(r)) / MEDIAN_NORM * dof, floor / THRESHOLD_SIGMAS)


def _limit(m: int) -> float:
    """The Mahalanobis distance a good position stays within with probability 0.999 when
    the covariance is estimated from m positions: Hotelling's prediction bound
    √(p (m² − 1) / (m (m − p)) · F_{p, m−p}(0.999)), p = 3 (5.5 for m = 20, 4.3 for
    m = 88; √χ²₃ = 4.03 as m grows). With fewer than :data:`MIN_FOR_COVARIANCE` inliers
    (isotropic scale from the median): :data:`THRESHOLD_SIGMAS`."""
    if m < MIN_FOR_COVARIANCE:
        return THRESHOLD_SIGMAS
    from scipy.special import fdtri  # the F distribution's quantile

    p = 3
    return math.sqrt(p * (m * m - 1) / (m * (m - p)) * float(fdtri(p, m - p, 0.999)))


def _describe(k: int, rot: float, trans: float, d_r: float, d_t: float,
              limit: float) -> Rejection:
    parts = []
    if d_r > limit:
        parts.append(f"rotation residual {math.degrees(rot):.3g}° ({d_r:.3g} σ > "
                     f"{limit:.3g} σ)")
    if d_t > limit:
        parts.append(f"translation residual {trans:.3g} ({d_t:.3g} σ > {limit:.3g} σ)")
    if not parts:   # the inlier set had not settled after MAX_ROUNDS rounds
        parts.append(f"left out in the last of {MAX_ROUNDS} rounds (rotation "
                     f"{d_r:.3g} σ, translation {d_t:.3g} σ, limit {limit:.3g} σ)")
    return Rejection(k, math.degrees(rot), float(trans), " and ".join(parts))


def _residual_vectors(X: np.ndarray, T_cw: np.ndarray, T_gp: np.ndarray, fit: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) rotation vectors of R_Yᵀ R_Yk (radians) and (n, 3) t_Yk − t_Y, Y the mean
    over the positions ``fit``."""
    w = np.asarray(fit, dtype=float)
    Y = _inv(X[None] @ T_gp) @ T_cw
    RY = _chordal_mean(Y[None, :, :3, :3], w[None])[0]
    tY = w @ Y[:, :3, 3] / w.sum()
    return rotvec_from_matrix(RY.T @ Y[:, :3, :3]), Y[:, :3, 3] - tY


def _covariance(v: np.ndarray, floor: float) -> np.ndarray:
    """The 3×3 covariance of residual vectors v (m, 3) of the inliers: Σ v vᵀ / (m − 2)
    (each axis has 3m numbers against the 6 unknowns of X and Y), so an error larger
    along one axis than the others (a pose from PnP is less sure of its tilt than of its
    turn about the optical axis) is measured as such. With fewer than
    :data:`MIN_FOR_COVARIANCE` inliers: isotropic, from the median norm
    (:func:`_inlier_sigma`). Never below the round-off floor."""
    m = len(v)
    f2 = (floor / THRESHOLD_SIGMAS) ** 2
    if m < MIN_FOR_COVARIANCE:
        return (_inlier_sigma(np.linalg.norm(v, axis=1), floor) ** 2 + f2) * np.eye(3)
    return v.T @ v / (m - 2) + f2 * np.eye(3)


def _mahalanobis(v: np.ndarray, C: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("ni,ij,nj->n", v, np.linalg.inv(C), v))


def solve_rasc_robust(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *,
                      seed: int = 0, max_draws: int = MAX_DRAWS,
                      min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
                      check_rigid: bool = True) -> RobustHandEyeResult:
    """RASC that leaves out the positions the others contradict (module docstring).

    Parameters
    ----------
    T_cam_from_world, T_gaze_from_ptu : array-like, shape (n, 4, 4)
        As :func:`rasc.handeye.solver.solve_rasc`.
    seed : int
        Seed of the minimal samples' draw (used only when there are more than
        ``max_draws`` triples); the same seed gives the same bits.
    max_draws : int
        Hypotheses drawn at most (:data:`MAX_DRAWS`).
    min_rotation_rad, check_rigid : as :func:`~rasc.handeye.solver.solve_rasc`.

    Returns
    -------
    RobustHandEyeResult
        method "rasc-robust". Raises :class:`~rasc.errors.DegenerateDataError` when the
        data (all of them, or the consistent ones) cannot determine X.
    """
    # the whole set's validation and degeneracy check, exactly as RASC's
    _, T_cw, T_gp = diagnose(T_cam_from_world, T_gaze_from_ptu,
                             min_rotation_rad=min_rotation_rad, check_rigid=check_rigid)
    n = len(T_cw)
    if not (isinstance(max_draws, int) and max_draws >= 1):
        raise InputError(f"max_draws: expected an integer >= 1, got {max_draws!r}")
    X, samples = _hypotheses(T_cw, T_gp, max_draws, seed, min_rotation_rad)
    S = len(X)
    fit = np.zeros((S, n))
    fit[np.arange(S)[:, None], samples] = 1.0
    rot, trans = pose_residuals(X, T_cw, T_gp, fit)                          # (S, n)
    distance = float(np.median(np.linalg.norm(T_cw[:, :3, 3], axis=1)))
    floor_r, floor_t = FLOOR_ROTATION_RAD, FLOOR_RELATIVE * max(distance, 1e-300)

    # 2. initial fit (least median, both residuals made comparable) and the noise scale
    med_r = np.maximum(np.median(rot, axis=1), floor_r)
    med_t = np.maximum(np.median(trans, axis=1), floor_t)
    best = int(np.argmin(np.maximum(med_r / med_r.min(), med_t / med_t.min())))
    order = np.argsort(np.maximum(rot[best] / med_r[best], trans[best] / med_t[best]),
                       kind="stable")
    half = np.sort(order[:max(MINIMAL + 1, (n + 1) // 2)])
    try:
        X0 = solve_rasc(T_cw[half], T_gp[half], min_rotation_rad=min_rotation_rad,
                        check_rigid=False).T_cam_from_gaze
        r0, t0 = pose_residuals(X0, T_cw, T_gp, np.isin(np.arange(n), half))
    except RascError:                                      # the best half is degenerate
        r0, t0 = rot[best], trans[best]
    sigma_r, sigma_t = _sigma(r0, floor_r), _sigma(t0, floor_t)

    # 3. MSAC over the hypotheses, then RASC on the inliers until the set is stable
    tau_r, tau_t = THRESHOLD_SIGMAS * sigma_r, THRESHOLD_SIGMAS * sigma_t
    cost = (np.minimum((rot / tau_r) ** 2, 1.0) + np.minimum((trans / tau_t) ** 2, 1.0)
            ).sum(axis=1)
    h = int(np.argmin(cost))
    inl = (rot[h] <= tau_r) & (trans[h] <= tau_t)
    result = None
    for _ in range(MAX_ROUNDS):
        if inl.sum() < MINIMAL:
            raise DegenerateDataError(
                f"rasc-robust: only {int(inl.sum())} of {n} positions agree with each "
                f"other (thresholds {math.degrees(tau_r):.3g}° and {tau_t:.3g}); at least "
                f"{MINIMAL} consistent positions are needed")
        idx = np.flatnonzero(inl)
        solved = inl.copy()
        try:
            result = solve_rasc(T_cw[idx], T_gp[idx], min_rotation_rad=min_rotation_rad,
                                check_rigid=False)
        except DegenerateDataError as exc:
            raise DegenerateDataError(f"rasc-robust: the {idx.size} consistent positions "
                                      f"of {n} are degenerate: {exc}") from None
        rv, tv = _residual_vectors(np.asarray(result.T_cam_from_gaze), T_cw, T_gp, inl)
        C_r, C_t = _covariance(rv[inl], floor_r), _covariance(tv[inl], floor_t)
        d_r, d_t = _mahalanobis(rv, C_r), _mahalanobis(tv, C_t)
        limit = _limit(int(inl.sum()))
        new = (d_r <= limit) & (d_t <= limit)
        if np.array_equal(new, inl):
            break
        inl = new
    inl = solved          # the set the result was solved on (the same at a fixed point)
    r, t = np.linalg.norm(rv, axis=1), np.linalg.norm(tv, axis=1)
    rejected = tuple(_describe(int(k), float(r[k]), float(t[k]), float(d_r[k]),
                               float(d_t[k]), limit) for k in np.flatnonzero(~inl))
    sigma_r, sigma_t = math.sqrt(np.trace(C_r) / 3), math.sqrt(np.trace(C_t) / 3)
    tau_r = limit * math.sqrt(np.linalg.eigvalsh(C_r)[-1])
    tau_t = limit * math.sqrt(np.linalg.eigvalsh(C_t)[-1])
    return RobustHandEyeResult(
        T_cam_from_gaze=result.T_cam_from_gaze, quality=result.quality, method=NAME,
        diagnostics=result.diagnostics, inliers=tuple(int(k) for k in np.flatnonzero(inl)),
        rejected=rejected, sigma_rotation_deg=math.degrees(sigma_r),
        sigma_translation=sigma_t, threshold_rotation_deg=math.degrees(tau_r),
        threshold_translation=tau_t, n_hypotheses=S, seed=int(seed), limit_sigmas=limit)
