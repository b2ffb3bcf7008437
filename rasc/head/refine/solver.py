"""The fit: Levenberg–Marquardt with the soft-L1 loss, corner rejection, and the
covariance σ² (JᵀJ)⁻¹ at the optimum (:func:`refine_head`). See :mod:`rasc.head.refine`,
"Solver", "Robustness" and "Uncertainty"."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import scipy.sparse as sp

from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.head.refine.identifiability import _identifiable
from rasc.head.refine.model import (
    DIST_MODELS,
    DIST_NAMES,
    DIST_PARAMS,
    GAUGE,
    UNIT_DEFAULTS,
    HeadObservations,
    ImageResidual,
    RefinementResult,
    parameter_unit,
    unit_from_parameters,
)
from rasc.head.refine.problem import _Problem
from rasc.head.refine.timing import MAX_TIME_OFFSET_S

#: Reject corners farther than this many robust standard deviations (either coordinate)
#: and farther than REJECT_FLOOR_PX: below a tenth of a pixel a residual is the
#: detector's ordinary error (rendered corners have σ ≈ 0.01 px with heavier tails than
#: a Gaussian: 5σ alone rejected 5 % of them), not a gross error.
REJECT_K = 5.0
REJECT_FLOOR_PX = 0.1


# ----------------------------------------------------------------------------- the fit

def _soft_l1(r: np.ndarray, f: float) -> tuple[float, np.ndarray]:
    """Cost ½ f² Σ 2(√(1 + (r/f)²) − 1) and the IRLS weights 1/√(1 + (r/f)²)."""
    z = (r / f) ** 2
    s = np.sqrt(1.0 + z)
    return float(f * f * np.sum(s - 1.0)), 1.0 / s


def _levenberg_marquardt(prob: _Problem, x: np.ndarray, *, f_scale: float,
                         max_iter: int = 100) -> tuple[np.ndarray, int]:
    """Minimise the soft-L1 cost of ``prob``'s residuals from ``x``.

    Levenberg–Marquardt on the normal equations: each step solves the dense n × n system
    (JᵀWJ + λ·diag(JᵀWJ)) δ = −JᵀWr (W: iteratively reweighted soft-L1 weights) by
    Cholesky. n is a few hundred (six per board pose), so this direct solve takes
    milliseconds; scipy.optimize.least_squares' sparse path (trf + LSMR, tried first with
    the same jac_sparsity) needs hundreds of LSMR iterations per step on this
    ill-conditioned problem: 3.9-5 s on the default dataset against 2 s for the whole
    refinement here. Stops when the cost falls by less than 1e-9 relative or the step
    is below 1e-6 (scaled units). Returns (x, iterations).
    """
    from scipy.linalg import cho_factor, cho_solve

    # (called within one BLAS thread, see refine_head)
    r = prob.residuals(x)
    cost, w = _soft_l1(r, f_scale)
    lam = 1e-4
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007  (it is returned)
        J = prob.jacobian_lm(x, r, h=1e-6)
        sw = np.sqrt(w)
        Jw = sp.diags(sw) @ J
        H = (Jw.T @ Jw).toarray()
        g = Jw.T @ (sw * r)
        dH = np.diag(H).copy()
        dH[dH == 0] = 1.0
        improved = False
        while lam < 1e12:
            try:
                step = -cho_solve(cho_factor(H + lam * np.diag(dH)), g)
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            r_new = prob.residuals(x + step)
            cost_new, w_new = _soft_l1(r_new, f_scale)
            if np.isfinite(cost_new) and cost_new < cost:
                improved = True
                break
            lam *= 10.0
        if not improved:
            break
        x = x + step
        # converged: the cost falls by less than 1e-9 of itself, or no parameter moves by
        # more than 1e-6 of its scale (1e-4 px, 1e-7 rad, 1e-7 of the board distance):
        # both far below any standard deviation here
        done = (cost - cost_new) < 1e-9 * cost or np.max(np.abs(step)) < 1e-6
        r, cost, w = r_new, cost_new, w_new
        lam = max(lam / 10.0, 1e-12)
        if done:
            break
    return x, it


#: The unit parameters ``estimate_scales=False`` holds at their nominal value (1). The
#: paper's ±8° pose views fix an encoder scale to ~2e-4 (1σ, measured on renders), and
#: between two eyes verging at 1.7 m that uncertainty moves triangulated depth by
#: ~0.3 mm: on the default renders the triangulation mean error was 0.45-0.57 mm with the
#: scales estimated against 0.16-0.25 mm held (ideal head), 0.41-0.55 against
#: 0.22-0.34 mm (30 mm offset). But a scale error that is held hides in the hand-eye
#: almost without a trace (pan scale 1.01 held: 10 mm hand-eye error, pose-view RMS up by
#: only 17 %), so they are estimated unless the encoders are known to be exact.
SCALES = ("pan_scale", "tilt_scale")


def refine_head(obs: HeadObservations, *, sigma0: float | None = None,
                reject_k: float = REJECT_K, max_iter: int = 100,
                estimate_scales: bool = True,
                start: RefinementResult | None = None,
                time_offset: bool = False) -> RefinementResult:
    """Refine the whole head from its corners (see the module docstring).

    Parameters
    ----------
    obs : HeadObservations
        Corners and the closed form's initial values.
    sigma0 : float, optional
        Expected corner noise per coordinate (px) for the robust loss's scale; default
        from the intrinsics views' residuals at the initial guess.
    reject_k : float
        Rejection threshold in robust standard deviations.
    estimate_scales : bool
        Estimate the encoder scales (default); False holds them at 1 (:data:`SCALES`).
    start : RefinementResult, optional
        A refinement of the same observations to start from (its identifiability test,
        parameter values and kept corners are re-used).
    time_offset : bool
        A continuous capture (``obs.has_stream``): estimate the camera-to-encoder time
        offset δ from 0 (:mod:`rasc.head.refine.timing`); held at 0 (the dataset's
        readings) when the corners cannot determine it (``time_offset`` of the result
        says so). Pose images that fit as outliers (:func:`rasc.vision.camera.outlier_threshold`
        of their RMS: blurred frames) are dropped and named (``frames_rejected``).

    Returns
    -------
    RefinementResult

    Raises
    ------
    DegenerateDataError
        The corners cannot determine the basic parameters.
    """
    from threadpoolctl import threadpool_limits

    # One BLAS thread: the dense solves here are a few hundred wide, where waking a
    # second thread on a busy 2-core machine was measured to cost 0.3-0.5 s per solve
    # (against 1 ms on one thread).
    with threadpool_limits(1, user_api="blas"):
        return _refine_head(obs, sigma0=sigma0, reject_k=reject_k, max_iter=max_iter,
                            hold=() if estimate_scales else SCALES, start=start,
                            time_offset=time_offset)


def _refine_head(obs: HeadObservations, *, sigma0, reject_k, max_iter,
                 hold: tuple[str, ...], start: RefinementResult | None = None,
                 time_offset: bool = False) -> RefinementResult:
    t_start = time.perf_counter()
    if obs.dist_model not in DIST_PARAMS:
        raise InputError(f"refinement: unknown dist_model {obs.dist_model!r}")
    if time_offset and not obs.has_stream:
        raise InputError("refinement: the time offset needs every pose image's time and "
                         "a joint stream")
    tested = time_offset
    if start is not None and start.identifiability is not None \
            and start.time_offset.get("tested", False) == time_offset:
        # the same data: the null directions are the same; only the held ones differ
        free_all, dropped = start.identifiability
    else:
        free_all, dropped = _identifiable(obs, (), time_offset=time_offset)
    time_offset = time_offset and not any(dd["parameter"] == "time_offset" for dd in dropped)
    free = {eye: [n for n in names if n not in hold] for eye, names in free_all.items()}
    dist_held = tuple(dict.fromkeys(dd["parameter"] for dd in dropped
                                    if dd["parameter"] in DIST_NAMES))
    prob = _Problem(obs, free, dist_held, time_offset=time_offset)
    x0 = np.zeros(len(prob.names))
    r0 = prob.all_residuals(x0)
    if prob.seen.all():
        rms_before = float(np.sqrt(np.mean(np.sum(r0 ** 2, axis=-1))))
        intr = r0[prob.img_role == 0]
    else:                        # partial views: only the corners they show
        rms_before = float(np.sqrt(np.mean(np.sum(r0[prob.seen] ** 2, axis=-1))))
        intr = r0[prob.seen & (prob.img_role == 0)[:, None]]
    if sigma0 is None:
        sigma0 = float(np.sqrt(np.mean(intr ** 2))) if intr.size else 0.1
    sigma0 = max(sigma0, 1e-3)
    iterations = 0
    x = x0.copy()
    if start is not None:
        # warm start from another refinement of the same observations (same initial
        # rotations, so every parameter, perturbations included, carries over by name)
        known = dict(zip(start.names, start.values, strict=True))
        for j, name in enumerate(prob.names):
            if name in known:
                x[j] = (known[name] - prob.p0[j]) / prob.scale[j]
        if start.kept is not None:
            prob.mask &= start.kept
    # (a refinement started from another keeps its corners, and so its dropped frames)
    frames_rejected: list[dict[str, Any]] = [] if start is None else list(start.frames_rejected)
    for _ in range(2):   # fit; reject; refit once without the rejected corners
        x, nit = _levenberg_marquardt(prob, x, f_scale=3.0 * sigma0, max_iter=max_iter)
        iterations += nit
        r = prob.all_residuals(x)
        kept_r = r[prob.mask]
        sig = 1.4826 * float(np.median(np.abs(kept_r - np.median(kept_r, axis=0))))
        bad = np.any(np.abs(r) > max(reject_k * sig, REJECT_FLOOR_PX), axis=-1) & prob.mask
        if obs.has_stream and np.isfinite(reject_k):
            # a continuous capture: whole pose frames that fit as outliers (blur, a frame
            # whose time is not its own) go, by the one per-view rule of the intrinsics
            # judged on all the corners they showed, the ones just rejected included
            frames = _outlier_frames(prob, r, prob.mask)
            for i, rms, threshold in frames:
                bad[i] = prob.mask[i]
                frames_rejected.append({"eye": EYES[prob.img_eye[i]],
                                        "file": prob.img_name[i], "rms_px": rms,
                                        "threshold_px": threshold})
        if not bad.any():
            break
        prob.mask &= ~bad
    # uncertainty: σ² (JᵀJ)⁻¹, J by central differences, plain least squares at the optimum
    r = prob.all_residuals(x)
    rk = r[prob.mask]
    m, n = rk.size, len(prob.names)
    dof = int(m - n)
    sigma = float(np.sqrt(np.sum(rk ** 2) / max(m - n, 1)))
    J = prob.jacobian(x)
    G = (J.T @ J).toarray()
    D = np.sqrt(np.diag(G))
    cov_x = np.linalg.inv(G / np.outer(D, D)) / np.outer(D, D) * sigma ** 2
    cov = cov_x * np.outer(prob.scale, prob.scale)
    std = np.sqrt(np.diag(cov))
    p = prob.p0 + prob.scale * x
    delta = {}
    if tested or obs.has_stream:
        delta = {"tested": tested, "estimated": prob.time_col is not None,
                 "value_s": prob.time_offset(x),
                 "std_s": None if prob.time_col is None else float(std[prob.time_col])}
        if prob.time_col is not None and abs(delta["value_s"]) > MAX_TIME_OFFSET_S:
            raise InputError(
                f"refinement: the camera-to-encoder time offset came out at "
                f"{delta['value_s']:.3g} s, beyond the prior bound ±{MAX_TIME_OFFSET_S:g} s: "
                "the image times and the joint stream are not on clocks this close; check "
                "their units and that the stream is this capture's")
    s = prob.unpack(x)
    # parameters, by eye, in natural units
    params: dict[str, dict[str, dict[str, Any]]] = {eye: {} for eye in EYES}
    params["head"] = {}
    for j, name in enumerate(prob.names[:prob.n_global]):
        group, _, pname = name.partition(".")
        if group not in params:
            group, pname = "head", name
        if parameter_unit(name) == "deg":
            # a small rotation about this axis (left perturbation): the refined rotation
            # itself is in the transform, reported whole
            entry = {"value": None, "std": float(np.degrees(std[j])), "unit": "deg",
                     "note": "std of a small rotation about this axis; the value is the "
                             "transform's rotation"}
        else:
            entry = {"value": float(p[j]), "std": float(std[j]),
                     "unit": parameter_unit(name)}
        params[group][pname] = entry
    for eye in EYES:
        uv = s[eye]["unit"]
        a = np.array([uv["tilt_axis_x"], uv["tilt_axis_y"], 1.0])
        a /= np.linalg.norm(a)
        # derived: non-orthogonality (deg) and its std from tilt_axis_x
        key = "unit.tilt_axis_x"
        if key in params[eye]:
            ax = params[eye][key]["value"]
            dangle = 1.0 / (1.0 + ax * ax)       # d asin(ax/sqrt(1+ax²))/d ax (ay = 0)
            params[eye]["unit.axis_angle_deg"] = {
                "value": float(90.0 - np.degrees(np.arcsin(a[0]))),
                "std": float(np.degrees(dangle * params[eye][key]["std"])), "unit": "deg"}
        for dd in dropped:
            if dd["eye"] == eye and dd["parameter"] in dist_held:
                params[eye][dd["parameter"]] = {
                    "value": float(prob.dist_fixed[eye][prob.coef_names.index(dd["parameter"])]),
                    "std": None, "unit": "1", "held": dd["reason"]}
            elif dd["eye"] == eye:
                params[eye][f"unit.{dd['parameter']}"] = {"value": None, "std": None,
                                                          "reason": dd["reason"]}
        for n in hold:
            params[eye][f"unit.{n}"] = {"value": UNIT_DEFAULTS[n], "std": None, "unit": "1",
                                        "held": "nominal, not estimated (--scales)"}
    if delta and prob.time_col is None:
        why = [dd["reason"] for dd in dropped if dd["parameter"] == "time_offset"]
        params["head"]["time_offset"] = {
            "value": 0.0, "std": None, "unit": "s",
            "held": why[0] if why else "held at 0, not estimated (--time-offset hold)"}
    # per-image residuals
    images = []
    residuals: dict[str, list[np.ndarray]] = {eye: [] for eye in EYES}
    for i, name in enumerate(prob.img_name):
        keep = prob.mask[i]
        ri = r[i][keep]
        eye = EYES[prob.img_eye[i]]
        residuals[eye].append(ri)
        nrm = np.linalg.norm(ri, axis=1)
        images.append(ImageResidual(
            eye=eye, role="intrinsics" if prob.img_role[i] == 0 else "pose", name=name,
            rms=float(np.sqrt(np.mean(nrm ** 2))) if len(nrm) else float("nan"),
            max=float(nrm.max()) if len(nrm) else float("nan"),
            rejected=[int(k) for k in np.flatnonzero(~keep & prob.seen[i])]))
    rms_after = float(np.sqrt(np.mean(np.sum(rk.reshape(-1, 2) ** 2, axis=-1))))
    rms_role = {}
    for role, code in (("intrinsics", 0), ("pose", 1)):
        sel = prob.mask & (prob.img_role == code)[:, None]
        rms_role[role] = float(np.sqrt(np.mean(np.sum(r[sel] ** 2, axis=-1)))) \
            if sel.any() else float("nan")
    return RefinementResult(
        rms_by_role=rms_role, held=list(hold), rss=float(np.sum(rk ** 2)), dof=dof,
        kept=prob.mask.copy(),
        K={eye: np.array([[s[eye]["K"][0], 0, s[eye]["K"][2]], [0, s[eye]["K"][1],
                                                                 s[eye]["K"][3]], [0, 0, 1.0]])
           for eye in EYES},
        # the stored length of the dataset's dist_model (5 for the pinhole models but the
        # rational one's 8; the fisheye's 4)
        dist={eye: s[eye]["dist"][:DIST_MODELS[obs.dist_model][2]].copy() for eye in EYES},
        lens={eye: prob.lens for eye in EYES},
        T_cam_from_gaze={eye: s[eye]["T_cam_from_gaze"] for eye in EYES},
        unit={eye: unit_from_parameters(s[eye]["unit"]) for eye in EYES},
        T_ptuL_from_ptuR=s["T_ptuL_from_ptuR"], parameters=params,
        not_identifiable=dropped, rms_before=rms_before, rms_after=rms_after, sigma=sigma,
        images=images, n_corners=int(prob.seen.sum()),
        n_rejected=int((prob.seen & ~prob.mask).sum()),
        iterations=iterations, seconds=time.perf_counter() - t_start, gauge=GAUGE,
        residuals={eye: np.concatenate(v) if v else np.zeros((0, 2))
                   for eye, v in residuals.items()},
        covariance=cov, names=list(prob.names), values=p.copy(),
        identifiability=(free_all, dropped), time_offset=delta,
        frames_rejected=frames_rejected)


def _outlier_frames(prob: _Problem, r: np.ndarray, keep: np.ndarray
                    ) -> list[tuple[int, float, float]]:
    """The pose images whose RMS over their kept corners ``keep`` is an outlier among
    their eye's pose images by :func:`rasc.vision.camera.outlier_threshold` (the rule
    the intrinsics views are judged by): (image index, RMS px, threshold px) each."""
    from rasc.vision.camera import outlier_threshold

    out = []
    for ei in range(len(EYES)):
        imgs = [i for i in prob.pose_images[ei] if keep[i].any()]
        if len(imgs) < 4:
            continue
        rms = np.array([np.sqrt(np.mean(np.sum(r[i][keep[i]] ** 2, axis=-1))) for i in imgs])
        threshold = outlier_threshold(rms)
        out += [(int(i), float(v), float(threshold))
                for i, v in zip(imgs, rms, strict=True) if v > threshold]
    return out
