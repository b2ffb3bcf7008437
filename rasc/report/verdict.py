"""Is this calibration usable? One verdict — usable, check or unusable — with its reason.

:func:`verdict` reads a calibration document (``rasc-calibration/1``, what ``rasc
calibrate`` writes) and, when the images were at hand, the corner coverage of each eye
(:func:`rasc.report.data.coverage`) and how well the images fit the calibration. Each
rule below is a :class:`Check`; the verdict is the worst level among the checks that
fail, and its reason the first such check's message (:meth:`Verdict.warnings`: the
other failed checks' messages). The thresholds:

* :data:`UNUSABLE_RMS_PX` (1 px): the reprojection RMS over every corner (the whole-head
  refinement's; the closed form's intrinsics RMS for ``--model paper``). Chessboard
  corners are found to 0.02–0.3 px on sharp images; an RMS above a pixel means corners
  the model cannot explain (a wrong board size, motion blur, mismatched angles).
* :data:`CHECK_RMS_PX` (0.5 px): above this, worth a look (OpenCV's and Kalibr's
  documentation call sub-half-pixel RMS a good calibration).
* :data:`CHECK_POSE_RATIO` (4, the pipeline's warning): pose views fitting this many times
  worse than intrinsics views — the pan/tilt readings may not be the images'.
* :data:`CHECK_MISFIT_F` (5, :data:`rasc.head.fit.MISFIT_F_WARN`): with ``--model paper``,
  an eye whose pose views the paper's unit does not explain (:func:`rasc.head.fit.is_misfit`:
  F above 5 and the one-board fit's excess RMS above half the per-view RMS; the general
  model answers that misfit, so there it is shown, not judged).
* the lens model (:func:`rasc.vision.camera.is_wrong_lens`): an eye whose intrinsics
  views another lens model (the fisheye against a pinhole model, or the reverse) fits
  better than the corners' noise explains (an F test above 10) by a practical amount
  (10 % of its RMS) — a fisheye calibrated as a pinhole, or a pinhole as a fisheye.
* :data:`CHECK_REJECTED_FRACTION` (5 %): corners the refinement rejected as outliers; a
  few are glints, many mean bad detections or a moving board.
* :data:`CHECK_FOCAL_REL_STD` (1 %): the relative standard deviation of a focal length;
  good intrinsics views give ~0.1 %.
* the encoder scales held at 1 (``--scales hold``) where the corners reject 1: the F
  test of ``--scales auto`` (:data:`rasc.head.pipeline.SCALES_F_ESTIMATE`, 10) above its
  threshold (a held scale error goes into the hand-eye and the unit's axes).
* :data:`UNIT_PARAMETERS_NEEDED`: a unit parameter the motions could not determine that a
  well-spread set of positions determines (the encoder scales aside, which are held by
  choice) — the positions do not turn about two different axes enough.
* :data:`CHECK_COVERAGE` (50 %): the fraction of an 8×6 grid of image cells the
  intrinsics corners touch; less leaves the lens's edges extrapolated.
* :data:`CHECK_IMAGES_RATIO` (3): with images, the reprojection RMS of their views of
  one role (:meth:`rasc.report.data.ReportData.rms_by_role`) against the calibration's
  own for that role (the refinement's ``rms_by_role_px``; for ``--model paper``, which
  records no RMS of its pose views through the head, the worse eye's intrinsics RMS for
  the intrinsics views only), taken at least :data:`IMAGES_FLOOR_PX`: above
  this ratio the images do not fit the calibration (another head's images, or the head
  changed since). ``check``; ``unusable`` when their RMS is also above
  :data:`UNUSABLE_RMS_PX`.
* non-finite numbers or standard deviations anywhere in the parameters: unusable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

UNUSABLE_RMS_PX = 1.0
CHECK_RMS_PX = 0.5
CHECK_POSE_RATIO = 4.0
CHECK_MISFIT_F = 5.0
CHECK_REJECTED_FRACTION = 0.05
CHECK_FOCAL_REL_STD = 0.01
CHECK_COVERAGE = 0.5
CHECK_IMAGES_RATIO = 3.0
#: the least calibration RMS the images' RMS is compared with (px): corners found again
#: by the same detector differ by a few hundredths of a pixel, so against a noise-free
#: render's 0.01 px a ratio would flag nothing but that
IMAGES_FLOOR_PX = 0.05
#: unit parameters a good set of positions determines (rasc.head.refine.UNIT_PARAMETERS,
#: the always-gauge ones and the held scales left out)
UNIT_PARAMETERS_NEEDED = ("tilt_axis_x", "tilt_point_y")

LEVELS = ("usable", "check", "unusable")


@dataclass(frozen=True)
class Check:
    """One rule: its name, the value seen, the threshold, the level it gives when it
    fails, whether it passed and the message."""

    name: str
    value: float | None
    threshold: float | None
    level: str
    passed: bool
    message: str


@dataclass(frozen=True)
class Verdict:
    """The report's one-line verdict: ``level`` (usable, check or unusable) and its ``reason``."""
    level: str                        # "usable" | "check" | "unusable"
    reason: str
    checks: list[Check] = field(default_factory=list)

    def line(self) -> str:
        """The verdict as printed: ``LEVEL: reason``."""
        return f"{self.level.upper()}: {self.reason}"

    def warnings(self) -> list[str]:
        """The messages of the failed checks other than the one the verdict gives as its
        reason (each worth a line of its own), worst level first."""
        failed = [c for c in self.checks if not c.passed and c.message != self.reason]
        return [c.message for c in sorted(failed, key=lambda c: -LEVELS.index(c.level))]


def _num(x) -> float | None:
    return float(x) if isinstance(x, (int, float)) and not isinstance(x, bool) else None


def _finite_parameters(ref: dict) -> str | None:
    for group, params in (ref.get("parameters") or {}).items():
        for name, p in params.items():
            for key in ("value", "std"):
                v = p.get(key) if isinstance(p, dict) else None
                if isinstance(v, (int, float)) and not math.isfinite(v):
                    return f"{group} {name} {key}"
    return None


def _own_rms(doc: dict, ref: dict | None) -> dict[str, float]:
    """The calibration's own reprojection RMS per role (px), as far as it says."""
    if ref is not None:
        by_role = ref.get("rms_by_role_px") or {}
        out = {r: _num(by_role.get(r)) for r in ("intrinsics", "pose")}
    else:       # the paper model records no RMS of its pose views through the head
        eyes = [e for e in (doc.get("eyes") or {}).values() if isinstance(e, dict)]
        out = {"intrinsics": max((x for x in (_num(e.get("intrinsics_rms")) for e in eyes)
                                  if x is not None), default=None)}
    return {r: v for r, v in out.items() if v is not None and math.isfinite(v)}


def verdict(doc: dict[str, Any], coverage: dict[str, float] | None = None,
            images_rms: dict[str, float] | None = None) -> Verdict:
    """The verdict on a calibration document (module docstring). ``coverage``: per eye
    the fraction of image cells its intrinsics corners touch (None: not judged);
    ``images_rms``: per role (``intrinsics``, ``pose``) the reprojection RMS (px) of the
    images the report was given, under this calibration (None: not judged)."""
    checks: list[Check] = []
    ref = doc.get("refinement") if isinstance(doc.get("refinement"), dict) else None
    model = (doc.get("options") or {}).get("model", "paper" if ref is None else "general")

    bad = _finite_parameters(ref) if ref else None
    checks.append(Check("finite", None, None, "unusable", bad is None,
                        f"{bad} is not a finite number: the refinement did not converge"
                        if bad else "every parameter and standard deviation is finite"))
    if ref is not None:
        rms = _num(ref.get("rms_after_px"))
        what = "whole-head reprojection RMS"
    else:
        eyes = doc.get("eyes") or {}
        vals = [_num(e.get("intrinsics_rms")) for e in eyes.values() if isinstance(e, dict)]
        vals = [v for v in vals if v is not None]
        rms = max(vals) if vals else None
        what = "intrinsics reprojection RMS (worse eye)"
    if rms is not None:
        checks.append(Check("rms", rms, UNUSABLE_RMS_PX, "unusable", rms <= UNUSABLE_RMS_PX,
                            f"{what} {rms:.3g} px is above {UNUSABLE_RMS_PX:g} px: the model "
                            "does not explain the corners (board size, blur, angles?)"))
        checks.append(Check("rms_check", rms, CHECK_RMS_PX, "check", rms <= CHECK_RMS_PX,
                            f"{what} {rms:.3g} px is above {CHECK_RMS_PX:g} px"))
    own = _own_rms(doc, ref)
    for role, got in (images_rms or {}).items():
        if role not in own or got is None:
            continue
        ratio = got / max(own[role], IMAGES_FLOOR_PX)
        level = "unusable" if got > UNUSABLE_RMS_PX else "check"
        checks.append(Check(f"images.{role}", ratio, CHECK_IMAGES_RATIO, level,
                            math.isfinite(ratio) and ratio <= CHECK_IMAGES_RATIO,
                            f"the images do not fit the calibration: their {role} views "
                            f"reproject at {got:.3g} px against its own {own[role]:.3g} px "
                            f"({ratio:.3g} times "
                            + ("that" if own[role] >= IMAGES_FLOOR_PX else
                               f"the {IMAGES_FLOOR_PX:g} px floor")
                            + "; another head's images, or the head changed since it was "
                            "calibrated?)"))
    if ref is not None:
        by_role = ref.get("rms_by_role_px") or {}
        pi, pp = _num(by_role.get("intrinsics")), _num(by_role.get("pose"))
        if pi and pp is not None:
            ratio = pp / pi
            checks.append(Check("pose_ratio", ratio, CHECK_POSE_RATIO, "check",
                                ratio <= CHECK_POSE_RATIO,
                                f"the pose views fit {ratio:.3g} times worse than the "
                                "intrinsics views: are the pan/tilt readings those of the "
                                "images?"))
        n, rej = _num(ref.get("corners")), _num(ref.get("rejected_corners"))
        if n:
            frac = (rej or 0.0) / n
            checks.append(Check("rejected", frac, CHECK_REJECTED_FRACTION, "check",
                                frac <= CHECK_REJECTED_FRACTION,
                                f"{100 * frac:.1f} % of the corners were rejected as outliers"))
        for eye in ("left", "right"):
            params = (ref.get("parameters") or {}).get(eye) or {}
            for f in ("fx", "fy"):
                p = params.get(f) or {}
                v, s = _num(p.get("value")), _num(p.get("std"))
                if v and s is not None:
                    rel = s / abs(v)
                    checks.append(Check(f"{eye}.{f}_std", rel, CHECK_FOCAL_REL_STD, "check",
                                        rel <= CHECK_FOCAL_REL_STD,
                                        f"the {eye} {f} is uncertain by {100 * rel:.2g} % "
                                        "(more intrinsics views, tilted 20-45 deg)"))
        sc = ref.get("scales") if isinstance(ref.get("scales"), dict) else {}
        f_stat, f_max = _num(sc.get("F")), _num(sc.get("threshold_F"))
        if f_stat is not None and f_max is not None and sc.get("estimated") is False:
            checks.append(Check("scales", f_stat, f_max, "check", f_stat <= f_max,
                                f"the encoder scales were held at 1 but the corners reject 1 "
                                f"(F = {f_stat:.3g} against {f_max:g}): calibrate with --scales "
                                "auto or estimate"))
        missing = [f"{d.get('eye')} {d.get('parameter')}" for d in ref.get("not_identifiable")
                   or [] if d.get("parameter") in UNIT_PARAMETERS_NEEDED]
        checks.append(Check("unit", float(len(missing)), 0.0, "check", not missing,
                            "the motions did not determine " + ", ".join(missing)
                            + " (positions turning about both axes, by more)"
                            if missing else "the unit's parameters are determined"))
    fits = doc.get("paper_model_fit") or {}
    if model == "paper":
        from rasc.head.fit import is_misfit

        for eye, fit in fits.items():
            F = _num((fit or {}).get("F"))
            if F is not None:
                checks.append(Check(f"{eye}.misfit", F, CHECK_MISFIT_F, "check",
                                    not is_misfit(F, _num(fit.get("rms_model_px")),
                                                  _num(fit.get("rms_free_px"))),
                                    f"the paper's unit does not explain the {eye} pose views "
                                    f"(F = {F:.3g}): calibrate with --model general"))
    for eye, e in (doc.get("eyes") or {}).items():
        lc = e.get("lens_check") if isinstance(e, dict) else None
        if isinstance(lc, dict) and _num(lc.get("alternative_rms_px")) is not None \
                and _num(lc.get("rms_px")) is not None:
            from rasc.vision.camera import is_wrong_lens, lens_check_F, lens_check_rms

            rms_lc, alt_lc = lens_check_rms(lc), _num(lc.get("alternative_rms_px"))
            checks.append(Check(f"{eye}.lens", rms_lc, alt_lc, "check",
                                not is_wrong_lens(rms_lc, alt_lc, lens_check_F(lc, rms_lc)),
                                f"the {eye} lens model {lc.get('dist_model')!r} fits the "
                                f"intrinsics views to {rms_lc:.3g} px where "
                                f"{lc.get('alternative')!r} fits them to {alt_lc:.3g} px: "
                                f"calibrate with --dist-model {lc.get('alternative')}"))
    for eye, c in (coverage or {}).items():
        checks.append(Check(f"{eye}.coverage", c, CHECK_COVERAGE, "check", c >= CHECK_COVERAGE,
                            f"the {eye} intrinsics corners touch {100 * c:.0f} % of the image "
                            "(the lens's edges are extrapolated: show the board in the "
                            "corners)"))
    failed = [c for c in checks if not c.passed]
    for level in ("unusable", "check"):
        first = next((c for c in failed if c.level == level), None)
        if first is not None:
            return Verdict(level, first.message, checks)
    rms_text = f"reprojection RMS {rms:.3g} px, " if rms is not None else ""
    return Verdict("usable", f"{rms_text}every check passed ({len(checks)})", checks)
