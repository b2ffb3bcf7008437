"""The whole-head calibration pipeline (``rasc calibrate``), docs/METHOD.md §3, §5, §7.

dataset → corner detection → intrinsics (dedicated views) → per-pose extrinsics with
the intrinsics fixed → hand-eye per eye (RASC by default) → base-to-ptu (loop closure
from simultaneous views, or measured mounts) → cyclopean base → one
:class:`rasc.head.model.HeadCalibration`, with every per-view figure and diagnostic.
The paper's unit model is checked against the pose views (:mod:`rasc.head.fit`); with
``model="general"`` the closed form then initialises the whole-head refinement
(:mod:`rasc.head.refine`), which estimates a general pan-tilt unit per eye.

Nothing here knows whether the images were rendered; when the dataset names a
ground-truth file, :func:`errors_against_truth` compares the result with it.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rasc import formats
from rasc.errors import InputError, RascError
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import PanTiltUnit, T_gaze_from_ptu, canonical_gauge
from rasc.geometry.lens import validate_K
from rasc.geometry.transforms import rotation_error_deg, validate_rigid_transform
from rasc.handeye.li import NO_HOME_POSE, has_home_pose, home_index
from rasc.head.base_to_ptu import (
    T_ptuL_from_ptuR_loop_closure,
    cyclopean_base,
    mount_errors,
    unit_side_warnings,
)
from rasc.head.model import EyeCalibration, HeadCalibration

# the options object and its validation (rasc.head.options, which the command line
# imports without numpy), re-exported here where calibrate_dataset takes them
from rasc.head.options import MODELS, SCALES_MODES, CalibrationOptions  # noqa: F401

FORMAT = formats.CALIBRATION.tag




@dataclass
class EyeResult:
    """Everything measured for one eye."""

    intrinsics: Any                    # rasc.vision.camera.IntrinsicsResult
    pose_files: list[str]
    pan_tilt: np.ndarray               # (n, 2) radians
    views: list[str]
    T_cam_from_world: np.ndarray       # (n, 4, 4)
    pose_rms: dict[str, float]
    not_found: dict[str, list[str]]
    handeye: Any                       # rasc.handeye.solver.HandEyeResult
    uncertainty: Any = None            # rasc.handeye.solver.HandEyeUncertainty
    warnings: list[str] = field(default_factory=list)   # for the user, one sentence each
    #: the detected corners (file → (N, 2), canonical order) the results came from, per
    #: role ("intrinsics", "pose"): kept so that refinement and experiments never detect
    #: again; not written to the JSON (which has per-image residual summaries instead)
    corners: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    #: a continuous capture: each pose image's time (camera clock, s; None without one)
    times: list[float | None] = field(default_factory=list)


@dataclass
class Calibration:
    head: HeadCalibration
    eyes: dict[str, EyeResult]
    base: dict[str, Any]
    options: CalibrationOptions
    timings: dict[str, float] = field(default_factory=dict)
    errors: dict[str, Any] | None = None
    warnings: list[str] = field(default_factory=list)   # for the user, one sentence each
    length_unit: str | None = None     # the dataset's (the unit of board.square_size)
    model_fit: dict[str, Any] | None = None     # eye → rasc.head.fit.EyeFit (paper model)
    refinement: Any = None             # rasc.head.refine.RefinementResult (model "general")
    #: model "general": the hand-eye method's closed form that seeded the refinement, per
    #: eye its T_cam_from_gaze and its distance from the refined one (``refinement.seed``)
    seed: dict[str, Any] | None = None
    #: a continuous capture's joint stream (rasc.vision.joint_stream.JointStream), or None
    joint_stream: Any = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        eyes = {}
        for eye, r in self.eyes.items():
            intr = r.intrinsics
            eyes[eye] = {
                "K": intr.K.tolist(), "dist": intr.dist.tolist(),
                "intrinsics_rms": intr.rms, "intrinsics_per_view_rms": intr.per_view_rms,
                "intrinsics_outliers": intr.outliers, "intrinsics_excluded": intr.excluded,
                "dist_model": intr.dist_model,
                **({"lens": intr.lens} if intr.lens != "pinhole" else {}),
                **({"lens_check": intr.lens_check} if intr.lens_check is not None else {}),
                "T_cam_from_gaze": r.handeye.T_cam_from_gaze.tolist(),
                "T_ptu_from_base": getattr(self.head, eye).T_ptu_from_base.tolist(),
                "quality": r.handeye.quality,
                "handeye_method": r.handeye.method,
                **({"handeye_home_view": r.views[home_index(
                    T_gaze_from_ptu(r.pan_tilt[:, 0], r.pan_tilt[:, 1]))]}
                   if r.handeye.method == "li" else {}),
                "handeye_diagnostics": r.handeye.diagnostics.to_dict(),
                "handeye_uncertainty": (None if r.uncertainty is None
                                        else r.uncertainty.to_dict()),
                "pose_views": [{"file": f, "view": v, "pan_deg": float(np.degrees(pt[0])),
                                "tilt_deg": float(np.degrees(pt[1])), "rms": r.pose_rms[f],
                                "T_cam_from_world": T.tolist()}
                               for f, v, pt, T in zip(r.pose_files, r.views, r.pan_tilt,
                                                      r.T_cam_from_world, strict=True)],
                "not_found": r.not_found,
            }
        out = {"format": FORMAT,
               "length_unit": self.length_unit or "that of the dataset's board.square_size",
               "head": self.head.to_dict(), "eyes": eyes,
               "base_to_ptu": self.base,
               "options": self.options.to_dict(),
               "warnings": list(self.warnings),
               "timings_s": self.timings}
        if self.model_fit is not None:
            out["paper_model_fit"] = {eye: f.to_dict() for eye, f in self.model_fit.items()}
        if self.refinement is not None:
            out["refinement"] = self.refinement.to_dict()
            for im in out["refinement"]["images"]:   # an image the refinement rejected
                if not all(np.isfinite(im[k]) for k in ("rms", "max")):   # whole: marked
                    im.update(rms=None, max=None, all_rejected=True)
            if self.seed is not None:
                out["refinement"]["seed"] = self.seed
        if self.errors is not None:
            out["errors_against_truth"] = self.errors
        return out


def format_length(value: float, unit: str | None) -> str:
    """A length for a person: millimetres when the dataset is in metres, else its unit."""
    if unit == "m":
        return f"{1000 * value:.3f} mm"
    return f"{value:.4g} {unit or '(unit of board.square_size)'}"


class _Timer:
    def __init__(self) -> None:
        self.timings: dict[str, float] = {}

    def add(self, stage: str, seconds: float) -> None:
        self.timings[stage] = self.timings.get(stage, 0.0) + seconds


def _where(dataset, entry) -> str:
    return f"{dataset.manifest_path}: images[{entry.index}] ({entry.file})"


def calibrate_eye(dataset, eye: str, options: CalibrationOptions,
                  timer: _Timer | None = None,
                  log: Callable[[str], None] = lambda s: None,
                  size: tuple[int, int] | None = None) -> EyeResult:
    """Detection → intrinsics → extrinsics → hand-eye for one eye of ``dataset``.

    ``size``: the eye's (width, height) when already known from ``dataset.validate()``
    (otherwise every image header is read again). Every error names the manifest and the
    eye (and the image, when there is one).
    """
    from rasc.handeye.advice import check_motions_match, solution_warnings, translation_warnings
    from rasc.handeye.methods import jackknife_uncertainty
    from rasc.handeye.robust_calibrate import closed_form
    from rasc.vision.camera import calibrate_intrinsics, estimate_extrinsics

    timer = timer or _Timer()
    board = dataset.board
    size = dataset.image_size(eye) if size is None else size
    t0 = time.perf_counter()
    det_i = dataset.detect(eye, "intrinsics", method=options.detector,
                           min_corners=options.min_corners, log=log)
    det_p = dataset.detect(eye, "pose", method=options.detector, board_seen=True,
                           min_corners=options.min_corners, log=log)
    timer.add("detection", time.perf_counter() - t0)
    for kind, det in (("intrinsics", det_i), ("pose", det_p)):
        if det.not_found and not getattr(board, "partial_views", False):
            log(f"{eye}: board not found in {len(det.not_found)} {kind} image(s), left out: "
                + ", ".join(det.not_found))
    t0 = time.perf_counter()
    try:
        intr = calibrate_intrinsics(det_i.corners, board, size, dist_model=options.dist_model,
                                    exclude_outliers=options.exclude_outliers)
    except RascError as exc:
        raise type(exc)(f"{dataset.manifest_path}: {eye} intrinsics images: {exc}") from None
    timer.add("intrinsics", time.perf_counter() - t0)
    if intr.outliers:
        log(f"{eye}: intrinsics outlier views (RMS > {intr.outlier_threshold:.3f} px): "
            + ", ".join(intr.outliers))
    t0 = time.perf_counter()
    files = list(det_p.corners)
    T_cw, rms = [], {}
    for f in files:
        try:
            T, r = estimate_extrinsics(det_p.corners[f], board, intr.K, intr.dist,
                                       lens=intr.lens)
        except RascError as exc:
            raise type(exc)(f"{_where(dataset, det_p.entries[f])}: {exc}") from None
        T_cw.append(T)
        rms[f] = r
    T_cw = np.array(T_cw)
    pan_tilt = np.array([[det_p.entries[f].pan, det_p.entries[f].tilt] for f in files])
    views = [det_p.entries[f].view for f in files]
    timer.add("extrinsics", time.perf_counter() - t0)
    t0 = time.perf_counter()
    T_gp = T_gaze_from_ptu(pan_tilt[:, 0], pan_tilt[:, 1])
    try:
        # the same angles read in the other unit, for the message
        other = "rad" if dataset.angle_unit == "deg" else "deg"
        k = 180.0 / np.pi if other == "rad" else np.pi / 180.0
        T_other = T_gaze_from_ptu(k * pan_tilt[:, 0], k * pan_tilt[:, 1])
        check_motions_match(T_cw, T_gp, other_unit=(other, T_other))
    except InputError as exc:
        raise InputError(f"{dataset.manifest_path}: {eye} pose images: {exc}") from None
    try:  # RASC, or rasc-robust when the data ask for it (robust_calibrate)
        closed = closed_form(options.method, T_cw, T_gp, names=files)
    except InputError:
        raise
    except RascError as exc:  # DegenerateDataError, SolverFailure: name the eye
        raise type(exc)(f"{dataset.manifest_path}: {eye} eye: {exc}") from None
    he = closed.result
    uncertainty = jackknife_uncertainty(
        he.method if he.method == "rasc-robust" else options.method, T_cw, T_gp, he)
    warnings = [f"{eye} eye: {note}" for note in closed.notes]
    if options.method == "li" and not has_home_pose(T_gp):
        warnings.append(f"{eye} eye: {NO_HOME_POSE}; add a pose view at (0, 0)")
    # the translation check on the positions the closed form used: the ones rasc-robust
    # left out are named once, in its note, not warned again here
    used = list(getattr(he, "inliers", ()) or range(len(files)))
    warnings += [f"{eye} eye: {w}" for w in
                 solution_warnings(he, uncertainty=uncertainty, pan_tilt=True)
                 + translation_warnings(T_cw[used], T_gp[used], he.T_cam_from_gaze,
                                        names=[files[i] for i in used])]
    timer.add("hand-eye", time.perf_counter() - t0)
    return EyeResult(times=[det_p.entries[f].time for f in files],
                     intrinsics=intr, pose_files=files, pan_tilt=pan_tilt, views=views,
                     T_cam_from_world=T_cw, pose_rms=rms,
                     not_found={"intrinsics": det_i.not_found, "pose": det_p.not_found},
                     handeye=he, uncertainty=uncertainty, warnings=warnings,
                     corners={"intrinsics": det_i.corners, "pose": det_p.corners})


def _loop_closure(eyes: dict[str, EyeResult]):
    """Eq. 11–12 over the views both eyes saw, or None when fewer than one."""
    L, R = eyes["left"], eyes["right"]
    common = [v for v in L.views if v in set(R.views)]
    if not common:
        return None, common
    iL = [L.views.index(v) for v in common]
    iR = [R.views.index(v) for v in common]
    T, spread = T_ptuL_from_ptuR_loop_closure(
        L.T_cam_from_world[iL], R.T_cam_from_world[iR],
        L.handeye.T_cam_from_gaze, R.handeye.T_cam_from_gaze,
        pan_tilt_left=L.pan_tilt[iL], pan_tilt_right=R.pan_tilt[iR])
    return (T, spread), common


#: Measured mounts and loop closure disagree "too much" beyond these: the paper's loop
#: closure was 2-3° and ~1 cm off on a real head, its measured mounts < 1° and 2-3 mm.
MOUNTS_WARN_ROTATION_DEG = 3.0
MOUNTS_WARN_TRANSLATION_FRACTION = 0.1     # of the baseline
#: a baseline this many times longer or shorter than loop closure's is another unit
MOUNTS_UNIT_RATIO = 3.0


def _compare_mounts(T_measured: np.ndarray, T_loop: np.ndarray,
                    warnings: list[str] | None, against: str = "loop closure") -> dict[str, float]:
    """Measured mounts against ``against`` (loop closure, or the whole-head refinement):
    refuse another length unit, warn into ``warnings`` (None: record only) on a large
    disagreement (either may be wrong), return the differences for the output."""
    b_measured = float(np.linalg.norm(T_measured[:3, 3]))
    b_loop = float(np.linalg.norm(T_loop[:3, 3]))
    if b_loop > 0 and not (1 / MOUNTS_UNIT_RATIO <= b_measured / b_loop <= MOUNTS_UNIT_RATIO):
        raise InputError(f"the measured mounts (T_ptuL_from_ptuR) put the units "
                         f"{b_measured:.4g} apart but {against} measures {b_loop:.4g} (in the unit "
                         "of board.square_size): give its translation in that unit")
    rot = float(rotation_error_deg(T_measured[:3, :3], T_loop[:3, :3]))
    trans = float(np.linalg.norm(T_measured[:3, 3] - T_loop[:3, 3]))
    if warnings is not None and (rot > MOUNTS_WARN_ROTATION_DEG
                                 or trans > MOUNTS_WARN_TRANSLATION_FRACTION * b_loop):
        warnings.append(f"the measured mounts and {against} differ by {rot:.2g}° and "
                        f"{trans:.3g} (baseline {b_loop:.3g}): one of them is wrong; check "
                        "the mounts' frames (T_ptuL_from_ptuR: the right unit's frame in the "
                        "left one) and the hand-eye warnings")
    return {"rotation_deg": rot, "translation": trans, "baseline_measured": b_measured,
            "baseline_loop_closure": b_loop}


def calibrate_dataset(dataset, options: CalibrationOptions | None = None,
                      log: Callable[[str], None] = lambda s: None) -> Calibration:
    """Calibrate the whole head from a :class:`rasc.vision.dataset.Dataset`.

    ``options`` (:class:`CalibrationOptions`, validated here before any image is read):
    by default the general model, as ``rasc calibrate``. Every warning for the user (the
    hand-eye's, the model fit's, the mounts', the refinement's) is computed here and
    carried in ``Calibration.warnings``, once each.
    """
    options = (options or CalibrationOptions()).validate()
    timer = _Timer()
    sizes = dataset.validate()  # reads every image header once
    # a ground truth that cannot be read is refused now, not after the whole calibration
    truth = None if dataset.ground_truth is None else dataset.load_ground_truth()
    if truth is not None:           # ... and so is one that is valid JSON of the wrong shape
        check_ground_truth(truth, str(dataset.ground_truth))
    eyes = {}
    for eye in EYES:
        if eye not in sizes:
            raise InputError(f"{dataset.manifest_path}: no images of the {eye} eye")
        log(f"{eye}: detecting, calibrating")
        eyes[eye] = calibrate_eye(dataset, eye, options, timer, log, size=sizes[eye])
    t0 = time.perf_counter()
    loop, common = _loop_closure(eyes)
    base: dict[str, Any] = {"simultaneous_views": common}
    if loop is not None:
        T_loop, spread = loop
        base["loop_closure"] = {"T_ptuL_from_ptuR": T_loop.tolist(),
                                "spread": spread.to_dict()}
    warnings = [w for eye in EYES for w in eyes[eye].warnings]
    if options.T_ptuL_from_ptuR_measured is not None:
        T_pLpR = validate_rigid_transform(options.T_ptuL_from_ptuR_measured,
                                          name="measured T_ptuL_from_ptuR")
        base["source"] = "measured mounts"
        if loop is not None:
            # warned here under the paper model only: the general model's own estimate is
            # compared after the refinement (one warning, naming what disagrees)
            base["measured_vs_loop_closure"] = _compare_mounts(
                T_pLpR, loop[0], warnings if options.model == "paper" else None)
    elif loop is not None:
        T_pLpR = loop[0]
        base["source"] = "loop closure"
    else:
        raise InputError(f"{dataset.manifest_path}: no view id is shared by a left and a "
                         "right pose image, so loop closure has nothing to close; give "
                         "simultaneous views or the measured mounts (T_ptuL_from_ptuR_measured)")
    base["T_ptuL_from_ptuR"] = np.asarray(T_pLpR).tolist()
    T_pb = dict(zip(EYES, cyclopean_base(T_pLpR), strict=True))
    warnings += unit_side_warnings(T_pb["left"], T_pb["right"])
    timer.add("base-to-ptu", time.perf_counter() - t0)
    head = HeadCalibration(**{
        eye: EyeCalibration(K=eyes[eye].intrinsics.K, dist=eyes[eye].intrinsics.dist,
                            T_cam_from_gaze=eyes[eye].handeye.T_cam_from_gaze,
                            T_ptu_from_base=T_pb[eye], image_size=sizes[eye],
                            lens=eyes[eye].intrinsics.lens)
        for eye in EYES})
    cal = Calibration(head=head, eyes=eyes, base=base, options=options,
                      timings=timer.timings, warnings=warnings,
                      length_unit=dataset.length_unit, joint_stream=dataset.joint_stream)
    return _finish(cal, dataset, options, timer, log, sizes, truth=truth)


#: "auto" estimates the encoder scales when holding them at 1 costs more than the noise
#: explains: F = [(RSS_held − RSS_estimated) / 4] / [RSS_estimated / dof] (four extra
#: parameters, two per eye) above this. Under scales of exactly 1, F ~ F(4, ~6000): its
#: 99.99th percentile is ~6. Measured on projected corners with 0.03 px noise: exact
#: scales F = 0.4-1.3; a pan scale of 1.01 F ≈ 190 (held, it would put 10 mm into the
#: hand-eye); 1.001 or a tilt scale of 1.001 F = 1.6-4.7, below what ±8° views resolve
#: (the estimate's own std is ~5e-4 there).
SCALES_F_ESTIMATE = 10.0


def _scales_F(held, estimated) -> float:
    """The F statistic of :data:`SCALES_F_ESTIMATE` of two fits of the same corners
    (``auto`` fits the held scales on the corners the estimate kept): always a number,
    ``inf`` when the estimate fits exactly and holding does not."""
    if held.kept is None or estimated.kept is None or \
            not np.array_equal(held.kept, estimated.kept):
        raise RuntimeError("the scales' F test needs both fits on one corner set")
    extra = max(held.dof - estimated.dof, 1)
    gain = max(held.rss - estimated.rss, 0.0) / extra
    noise = estimated.rss / max(estimated.dof, 1)
    if noise <= 0.0:
        return 0.0 if gain <= 0.0 else float("inf")
    return float(gain / noise)


def _scales_test(obs, estimate_first: bool, time_offset: bool = False
                 ) -> tuple[Any, Any, float]:
    """(held, estimated, F) of :data:`SCALES_F_ESTIMATE`'s test, both fits on one corner
    set: the first (scales estimated for ``auto``, held for ``hold``) from the closed form
    with its own corner rejection, the second started there on exactly the corners it
    kept, rejecting none. ``time_offset``: both estimate δ (a continuous capture)."""
    from rasc.head.refine import refine_head

    first = refine_head(obs, estimate_scales=estimate_first, time_offset=time_offset)
    second = refine_head(obs, estimate_scales=not estimate_first, start=first,
                         reject_k=float("inf"), time_offset=time_offset)
    held, estimated = (second, first) if estimate_first else (first, second)
    return held, estimated, _scales_F(held, estimated)


def scales_hold_warning(F: float, estimated) -> str:
    """The warning when ``--scales hold`` is contradicted by the corners (F above
    :data:`SCALES_F_ESTIMATE`); ``estimated``: the fit with the scales free."""
    found = ", ".join(f"{eye} {name} {estimated.parameters[eye][f'unit.{name}']['value']:.5g}"
                      for eye in EYES for name in ("pan_scale", "tilt_scale")
                      if f"unit.{name}" in estimated.parameters[eye]
                      and estimated.parameters[eye][f"unit.{name}"].get("value") is not None)
    return (f"the encoder scales were held at 1 (--scales hold) but the corners reject 1 "
            f"(F = {F:.3g} against {SCALES_F_ESTIMATE:g}; estimated: {found}): a held scale "
            "error goes into the hand-eye and the unit's axes, beyond their standard "
            "deviations; calibrate with --scales auto or estimate")


#: After refinement, pose-view RMS above this multiple of the intrinsics views' RMS is
#: warned (readings that are not the images', a unit the model cannot express).
#: Measured on the default renders: 1.6-2.0 (the pose views' board is farther, its
#: corners a little noisier); on projected corners with equal noise: 1.0-1.2.
POSE_RMS_WARN_RATIO = 4.0


def _finish(cal: Calibration, dataset, options: CalibrationOptions, timer: _Timer,
            log: Callable[[str], None], sizes: dict, model_fit=None,
            truth: dict | None = None) -> Calibration:
    """The last steps of a calibration (closed form or refined): the model-fit check and
    the refinement (:func:`_check_and_refine`), the stage timings, and the errors against
    the dataset's ground truth when it has one (``truth``: that document, already read)."""
    _check_and_refine(cal, dataset, options, timer, log, sizes, model_fit)
    cal.warnings = list(dict.fromkeys(cal.warnings))    # each warning once
    cal.timings = dict(timer.timings)
    if dataset.ground_truth is not None:
        cal.errors = errors_against_truth(
            cal, dataset.load_ground_truth() if truth is None else truth,
            where=str(dataset.ground_truth))
    return cal


def _check_and_refine(cal: Calibration, dataset, options: CalibrationOptions, timer: _Timer,
                      log: Callable[[str], None], sizes, model_fit=None) -> None:
    """The paper model's fit check (always; ``model_fit``, when given, is that check
    already made on the same closed-form calibration) and, for ``model="general"``, the
    whole-head refinement, which replaces ``cal.head`` and the base's
    ``T_ptuL_from_ptuR``."""
    from rasc.head.fit import calibration_fit, misfit_warning
    from rasc.head.refine import observations_from_calibration, refine_head

    if model_fit is None:
        t0 = time.perf_counter()
        model_fit = calibration_fit(cal, dataset.board.object_points())
        timer.add("model-fit check", time.perf_counter() - t0)
    cal.model_fit = model_fit
    if options.model == "paper":
        w = misfit_warning(cal.model_fit)
        if w is not None:
            cal.warnings.append(w)
        _lens_warnings(cal)
        return
    log("whole-head refinement (model general)")
    t0 = time.perf_counter()
    try:
        obs = observations_from_calibration(cal, dataset.board)
    except InputError as exc:       # a pose image's time against the joint stream
        raise InputError(f"{dataset.manifest_path}: {exc}") from None
    delta = _time_offset_wanted(obs, options, dataset)
    try:
        if options.scales_mode == "auto":
            # one corner set for both fits: the scales estimated (the larger model) with
            # its own rejection, from the closed form; then held, started there, on exactly
            # the corners it kept and rejecting none. (Held first, its rejection took the
            # corners that a wrong scale distorts, and the estimate never saw them again.)
            res_h, res_e, F = _scales_test(obs, estimate_first=True, time_offset=delta)
            res = res_e if F > SCALES_F_ESTIMATE else res_h
            res.scales = {"mode": "auto", "F": F, "threshold_F": SCALES_F_ESTIMATE,
                          "estimated": res is res_e}
            log(f"encoder scales {'estimated' if res is res_e else 'held at 1'} "
                f"(F = {F:.3g} against {SCALES_F_ESTIMATE:g})")
        elif options.scales_mode == "hold":
            # held by choice; the same F test as auto says whether the corners contradict
            # the choice (a warning, and the report's verdict): the scales estimated from
            # the held fit, on exactly its corners
            res, res_e, F = _scales_test(obs, estimate_first=False, time_offset=delta)
            res.scales = {"mode": "hold", "F": F, "threshold_F": SCALES_F_ESTIMATE,
                          "estimated": False}
            if F > SCALES_F_ESTIMATE:
                cal.warnings.append(scales_hold_warning(F, res_e))
        else:
            res = refine_head(obs, estimate_scales=True, time_offset=delta)
            res.scales = {"mode": "estimate", "estimated": True}
    except RascError as exc:
        raise type(exc)(f"{dataset.manifest_path}: {exc}") from None
    timer.add("refinement", time.perf_counter() - t0)
    cal.refinement = res
    _lens_warnings(cal)
    cal.seed = {"method": options.method,
                "what": "the method's closed form (eq. 3 units) seeded the refinement; "
                        "distance from the refined hand-eye in the gauge both share"}
    for eye in EYES:
        closed = cal.eyes[eye].handeye.T_cam_from_gaze
        cal.seed[eye] = {"T_cam_from_gaze": closed.tolist(),
                         "quality": float(cal.eyes[eye].handeye.quality),
                         "vs_refined": transform_error(closed, res.T_cam_from_gaze[eye])}
    _time_offset_outcome(cal, res, options, dataset, log)
    if res.time_offset and res.time_offset["estimated"]:
        # the fit check above read the pose readings at δ = 0, off by speed × δ on a
        # continuous capture: made again at the estimated δ, as the refinement read them
        t0 = time.perf_counter()
        cal.model_fit = calibration_fit(cal, dataset.board.object_points(),
                                        time_offset=res.time_offset["value_s"])
        timer.add("model-fit check", time.perf_counter() - t0)
    log(f"hand-eye method {options.method}: its closed form seeded the refinement ("
        + ", ".join(f"{eye} {cal.seed[eye]['vs_refined']['rotation_deg']:.3g} deg, "
                    f"{format_length(cal.seed[eye]['vs_refined']['translation'], cal.length_unit)}"
                    " from the refined "
                    "hand-eye" for eye in EYES) + ")")
    dropped = {(f["eye"], f["file"]) for f in res.frames_rejected}   # warned on their own
    gone = [im for im in res.images if not np.isfinite(im.rms)
            and (im.eye, im.name) not in dropped]
    if gone:
        cal.warnings.append(
            f"the whole-head refinement rejected every corner of {len(gone)} image(s) ("
            + ", ".join(f"{im.eye} {im.name}" for im in gone[:4])
            + (", ..." if len(gone) > 4 else "") + "): they do not fit the head the other "
            "images show; check that each pose image's pan/tilt reading is its own and the "
            "manifest's angle_unit; they are marked all_rejected in refinement.images")
    ratio = res.rms_by_role["pose"] / res.rms_by_role["intrinsics"]
    if ratio > POSE_RMS_WARN_RATIO:
        cal.warnings.append(
            f"after the whole-head refinement the pose views fit {ratio:.3g} times worse than "
            f"the intrinsics views ({res.rms_by_role['pose']:.3g} px against "
            f"{res.rms_by_role['intrinsics']:.3g} px RMS): check that the pan/tilt readings "
            "are those of the images")
    T_pLpR = res.T_ptuL_from_ptuR
    if options.T_ptuL_from_ptuR_measured is not None:
        cal.base["measured_vs_refinement"] = _compare_mounts(
            validate_rigid_transform(options.T_ptuL_from_ptuR_measured,
                                     name="measured T_ptuL_from_ptuR"), T_pLpR, cal.warnings,
            against="the whole-head refinement")
    cal.base["refinement"] = {"T_ptuL_from_ptuR": T_pLpR.tolist()}
    cal.base["T_ptuL_from_ptuR"] = T_pLpR.tolist()
    cal.base["source"] = "whole-head refinement (initialised by " + cal.base["source"] + ")"
    T_pb = dict(zip(EYES, cyclopean_base(T_pLpR), strict=True))
    cal.head = HeadCalibration(**{
        eye: EyeCalibration(K=res.K[eye], dist=res.dist[eye],
                            T_cam_from_gaze=res.T_cam_from_gaze[eye],
                            T_ptu_from_base=T_pb[eye], image_size=sizes[eye],
                            unit=res.unit[eye], std=_eye_std(res, eye),
                            lens=res.lens[eye])
        for eye in EYES})


def _lens_warnings(cal: Calibration) -> None:
    """The wrong-lens check of each eye (:func:`rasc.vision.camera.wrong_lens_warning`),
    first among ``cal.warnings``. With the whole-head refinement, the chosen model's RMS
    is the better of the closed-form intrinsics' and the refinement's over the eye's
    intrinsics views (``lens_check["refined_rms_px"]``): OpenCV's calibrator can stop in
    a local minimum the refinement leaves (measured: the rational model on a 170°
    fisheye, 2.9 px from cv2.calibrateCamera, 0.14 px refined)."""
    from rasc.vision.camera import wrong_lens_warning

    found = []
    for eye in EYES:
        check = cal.eyes[eye].intrinsics.lens_check
        if check is None:
            continue
        if cal.refinement is not None:
            r = [im.rms for im in cal.refinement.images
                 if im.eye == eye and im.role == "intrinsics" and np.isfinite(im.rms)]
            if r:
                # the RMS over the views (each view's RMS over the same corner count)
                check["refined_rms_px"] = float(np.sqrt(np.mean(np.square(r))))
        w = wrong_lens_warning(check)
        if w is not None:
            found.append(f"{eye} eye: {w}")
    cal.warnings[:0] = [w for w in found if w not in cal.warnings]


def _time_offset_wanted(obs, options: CalibrationOptions, dataset) -> bool:
    """Whether the refinement estimates the time offset δ: "auto" when the dataset is a
    continuous capture (pose images with times and a joint stream), "estimate" always (a
    dataset without a stream is refused, one line), "hold" never."""
    mode = options.time_offset_mode
    if mode == "estimate" and not obs.has_stream:
        raise InputError(f"{dataset.manifest_path}: the time offset cannot be estimated "
                         "(time_offset estimate): the dataset has no joint stream with "
                         "every pose image's time (the manifest's joint_stream and each "
                         "pose image's time); import it with rasc import --continuous")
    return mode != "hold" and obs.has_stream


def _time_offset_outcome(cal: Calibration, res, options: CalibrationOptions, dataset,
                         log: Callable[[str], None]) -> None:
    """Record and word the time offset's outcome (``res.time_offset``) and the pose
    frames the refinement dropped as outliers (warnings naming them)."""
    d = res.time_offset
    if d:
        d["mode"] = options.time_offset_mode
        if d["estimated"]:
            # the closed form's warnings judge the readings at δ = 0, which the refinement
            # replaced (a jackknife "too noisy" for readings off by speed × δ): kept with
            # the seed, not warned
            stale = [w for eye in EYES for w in cal.eyes[eye].warnings]
            if stale and cal.seed is not None:
                cal.seed["closed_form_warnings"] = stale
                cal.warnings = [w for w in cal.warnings if w not in stale]
            ms, std_ms = 1000 * d["value_s"], 1000 * d["std_s"]
            # σ to two significant digits, δ to the same place (at least 3 decimals)
            places = 3 if not std_ms > 0 else max(3, 1 - math.floor(math.log10(std_ms)))
            log(f"time offset δ (encoder clock − camera clock) {ms:.{places}f} ± "
                f"{std_ms:.{places}f} ms")
        elif d["tested"]:
            why = res.parameters["head"]["time_offset"].get("held", "")
            if options.time_offset_mode == "estimate":
                raise InputError(f"{dataset.manifest_path}: the time offset cannot be "
                                 f"estimated (time_offset estimate): {why}")
            cal.warnings.append(f"the time offset between the camera and encoder clocks was "
                                f"not estimated, held at 0: {why}")
    if res.frames_rejected:
        names = [f"{f['eye']} {f['file']} ({f['rms_px']:.3g} px)" for f in res.frames_rejected]
        cal.warnings.append(
            f"the whole-head refinement dropped {len(names)} pose frame(s) that fit as "
            f"outliers (RMS above {res.frames_rejected[0]['threshold_px']:.3g} px, the "
            "per-view rule of the intrinsics): " + ", ".join(names[:6])
            + (", ..." if len(names) > 6 else "") + "; motion blur or a frame time that is "
            "not the image's; they are listed in refinement.frames_rejected")


def refine_calibration(cal: Calibration, dataset,
                       log: Callable[[str], None] = lambda s: None,
                       **overrides) -> Calibration:
    """A closed-form (``model="paper"``) calibration refined with the general model, as
    ``calibrate_dataset(dataset, options with model="general")`` would give, without
    detecting or solving the closed form again. ``cal`` is left unchanged; ``overrides``
    change :class:`CalibrationOptions` fields (e.g. ``scales="hold"``)."""
    import copy

    options = dataclasses.replace(cal.options, model="general", **overrides).validate()
    out = Calibration(head=cal.head, eyes=cal.eyes, base=copy.deepcopy(cal.base),
                      options=options, warnings=list(cal.warnings),
                      length_unit=cal.length_unit, joint_stream=cal.joint_stream)
    # the paper model's misfit warning is answered by the refinement: drop it
    from rasc.head.fit import REMEDY
    from rasc.vision.camera import WRONG_LENS_REMEDY
    out.warnings = [w for w in out.warnings if not w.endswith(REMEDY)
                    and WRONG_LENS_REMEDY not in w
                    and not w.startswith("the measured mounts and loop closure")]
    timer = _Timer()
    timer.timings = dict(cal.timings)
    if cal.model_fit is None:         # (a calibration read back without its check)
        timer.timings.pop("model-fit check", None)
    sizes = {eye: getattr(cal.head, eye).image_size for eye in EYES}
    # the fit check depends only on the closed form (cal.head, cal.eyes), which ``out``
    # shares: cal's own check is reused, not made again
    return _finish(out, dataset, options, timer, log, sizes, cal.model_fit)


def _eye_std(res, eye: str) -> dict[str, float | None]:
    """The standard deviations stored with an eye (rasc-head/1 ``std``): every estimated
    parameter's, None for those the data cannot determine."""
    return {name: entry["std"] for name, entry in res.parameters[eye].items()}


def transform_error(T_est, T_true) -> dict[str, float]:
    """Rotation (deg) and translation (same unit as input) distance of two transforms."""
    T_est, T_true = np.asarray(T_est, float), np.asarray(T_true, float)
    return {"rotation_deg": float(rotation_error_deg(T_est[:3, :3], T_true[:3, :3])),
            "translation": float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3]))}


def check_ground_truth(truth: Any, where: str = "ground truth") -> None:
    """Refuse a ground truth that :func:`errors_against_truth` could not compare with,
    before any calibration work: every field it reads present, each K a camera matrix
    (:func:`rasc.geometry.lens.validate_K`) and each transform rigid
    (:func:`validate_rigid_transform`), in ``rasc render``'s layout. Raises
    :class:`InputError` naming ``where`` (the file) and the field."""
    if not isinstance(truth, dict):
        raise InputError(f"{where}: expected a JSON object")
    for eye in EYES:
        t = truth.get(eye)
        if not isinstance(t, dict):
            raise InputError(f"{where}: missing field {eye!r}" if t is None
                             else f"{where}: {eye}: expected an object")
        for key, check in (("K", validate_K), ("T_cam_from_gaze", _rigid),
                           ("T_ptu_from_base", _rigid)):
            if key not in t:
                raise InputError(f"{where}: missing field {eye}.{key}")
            check(t[key], f"{where}: {eye}.{key}")
        if "unit" in t:
            PanTiltUnit.from_dict(t["unit"], f"{where}: {eye}.unit")
    if "T_ptuL_from_ptuR" not in truth:
        raise InputError(f"{where}: missing field 'T_ptuL_from_ptuR'")
    _rigid(truth["T_ptuL_from_ptuR"], f"{where}: T_ptuL_from_ptuR")
    views = truth.get("views", {})
    if not isinstance(views, dict):
        raise InputError(f"{where}: views: expected an object")
    for name, view in views.items():
        if not isinstance(view, dict) or "T_cam_from_world" not in view:
            raise InputError(f"{where}: missing field views.{name}.T_cam_from_world")
        _rigid(view["T_cam_from_world"], f"{where}: views.{name}.T_cam_from_world")


def _rigid(value: Any, name: str) -> np.ndarray:
    return validate_rigid_transform(value, name=name)


def truth_in_calibration_gauge(truth: dict, where: str = "ground truth") -> dict[str, Any]:
    """A ground truth (``rasc render``'s layout) as a calibration states it: per eye
    ``(unit, T_cam_from_gaze, T_ptu_from_base)`` in the canonical gauge (METHOD §10; unit
    None when the truth names none, its transforms then as given), the mounts in the
    cyclopean base of those units, and ``"T_ptuL_from_ptuR"``. A truth written in another
    base frame (a model's base_link, as rasc render did before 0.3) is moved to the
    cyclopean base: only the units' relative pose is observed; where the base sits is the
    convention of docs/guide/concepts.md. Raises KeyError, TypeError or ValueError on a
    malformed truth (:func:`errors_against_truth` words them)."""
    out: dict[str, Any] = {}
    for eye in EYES:
        t = truth[eye]
        unit = None
        T_cg = np.asarray(t["T_cam_from_gaze"], float)
        T_pb = np.asarray(t["T_ptu_from_base"], float)
        if "unit" in t:
            unit, T_cg, T_pb = canonical_gauge(
                PanTiltUnit.from_dict(t["unit"], f"{where}: {eye}.unit"), T_cg, T_pb)
        out[eye] = (unit, T_cg, T_pb)
    T_pLpR = out["left"][2] @ np.linalg.inv(out["right"][2])
    for eye, T_pb in zip(EYES, cyclopean_base(T_pLpR), strict=True):
        out[eye] = (out[eye][0], out[eye][1], T_pb)
    out["T_ptuL_from_ptuR"] = T_pLpR
    return out


def errors_against_truth(cal: Calibration, truth: dict,
                         where: str = "ground truth") -> dict[str, Any]:
    """Errors of ``cal`` against a ground-truth dict (``rasc render``'s layout).

    Rotations in degrees, lengths in the dataset's ``length_unit`` (``cal.length_unit``;
    the unit of board.square_size when the manifest does not name it), pixels.
    ``where`` names the ground truth's source in error messages (its file).
    """
    unit = cal.length_unit or "unit of board.square_size"
    out: dict[str, Any] = {"units": f"degrees; {unit}; pixels"}
    try:
        gauge = truth_in_calibration_gauge(truth, where)
        for eye in EYES:
            est = getattr(cal.head, eye)
            K_t = np.asarray(truth[eye]["K"], float)
            _, T_cg_t, T_pb_t = gauge[eye]
            he = transform_error(est.T_cam_from_gaze, T_cg_t)
            pb = transform_error(est.T_ptu_from_base, T_pb_t)
            out[eye] = {
                "T_cam_from_gaze": he, "T_ptu_from_base": pb,
                "K": {"fx": float(est.K[0, 0] - K_t[0, 0]), "fy": float(est.K[1, 1] - K_t[1, 1]),
                      "cx": float(est.K[0, 2] - K_t[0, 2]), "cy": float(est.K[1, 2] - K_t[1, 2])},
            }
            views = truth.get("views", {})
            r = cal.eyes[eye]
            errs = [transform_error(T, views[f]["T_cam_from_world"])
                    for f, T in zip(r.pose_files, r.T_cam_from_world, strict=True) if f in views]
            if errs:
                out[eye]["pose_extrinsics_max"] = {
                    "rotation_deg": max(e["rotation_deg"] for e in errs),
                    "translation": max(e["translation"] for e in errs)}
        T_pLpR_true = gauge["T_ptuL_from_ptuR"]
        me = mount_errors(np.asarray(cal.base["T_ptuL_from_ptuR"], float), T_pLpR_true)
        out["T_ptuL_from_ptuR"] = {"rotation_deg": me.rotation_deg,
                                   "translation": me.translation,
                                   "baseline_length": me.baseline_length}
        if "loop_closure" in cal.base:
            ml = mount_errors(np.asarray(cal.base["loop_closure"]["T_ptuL_from_ptuR"], float),
                              T_pLpR_true)
            out["loop_closure"] = {"rotation_deg": ml.rotation_deg,
                                   "translation": ml.translation}
    except KeyError as exc:
        raise InputError(f"{where}: missing field {exc}") from None
    except (TypeError, ValueError, IndexError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{where}: malformed ground truth ({first})") from None
    return out
