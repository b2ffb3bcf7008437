"""The closed form of ``rasc calibrate``: RASC, or ``rasc-robust`` when the data ask for it.

:func:`closed_form` solves with the chosen method; for "rasc" (the paper's method, the
default), when the consistency checks of :mod:`rasc.handeye.advice` flag the solution
(:func:`contamination`), it runs ``rasc-robust`` (:mod:`rasc.handeye.robust`) and keeps
its result when it rejects positions, with a note naming them, so that the whole-head
refinement starts from the inliers. Apart from :mod:`rasc.handeye.robust` because it
resolves methods by name (:mod:`rasc.handeye.methods`, which registers ``rasc-robust``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rasc.errors import DegenerateDataError
from rasc.handeye.advice import QUALITY_UNUSABLE, translation_warnings
from rasc.handeye.methods import solve
from rasc.handeye.robust import solve_rasc_robust
from rasc.handeye.solver import HandEyeResult


@dataclass
class ClosedForm:
    """What :func:`closed_form` decided: the result and the notes for the user."""

    result: HandEyeResult
    notes: list[str] = field(default_factory=list)


def contamination(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                  result: HandEyeResult) -> list[str]:
    """The consistency checks of :mod:`rasc.handeye.advice` that flag ``result``: a
    quality (eq. 10) above the paper's limit and translations that contradict each other
    (:func:`~rasc.handeye.advice.translation_warnings`). Empty: nothing flagged."""
    out = []
    if result.quality > QUALITY_UNUSABLE:
        out.append(f"quality {result.quality:.3g} > {QUALITY_UNUSABLE:g}")
    if translation_warnings(T_cam_from_world, T_gaze_from_ptu, result.T_cam_from_gaze,
                            scale_check=False):
        out.append("the translations contradict each other")
    return out


def closed_form(method: str, T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                names: list[str] | None = None) -> ClosedForm:
    """The closed form of ``rasc calibrate``: ``method`` (any name
    :func:`rasc.handeye.methods.get_method` resolves); for "rasc" (the paper's method, the
    default), when :func:`contamination` flags its solution, ``rasc-robust`` instead —
    kept when it rejects some position, with a note naming them and why, so that the
    whole-head refinement starts from the inliers. A name the user chose other than
    "rasc" is used as it is."""
    result = solve(method, T_cam_from_world, T_gaze_from_ptu)
    if method != "rasc":
        return ClosedForm(result)
    flagged = contamination(T_cam_from_world, T_gaze_from_ptu, result)
    if not flagged:
        return ClosedForm(result)
    try:
        robust = solve_rasc_robust(T_cam_from_world, T_gaze_from_ptu)
    except DegenerateDataError as exc:
        return ClosedForm(result, [f"the data look contaminated ({'; '.join(flagged)}) but "
                                   f"rasc-robust could not separate the bad positions "
                                   f"({exc}); the closed form uses every position"])
    if not robust.rejected:
        return ClosedForm(result)
    names = names or [f"positions[{k}]" for k in range(len(T_cam_from_world))]
    which = "; ".join(f"{names[r.index]} ({r.reason})" for r in robust.rejected)
    return ClosedForm(robust, [
        f"the closed form's data look contaminated ({'; '.join(flagged)}): rasc-robust "
        f"rejected {len(robust.rejected)} of {len(names)} positions: {which}; the closed "
        f"form (and any refinement) starts from the {len(robust.inliers)} others"])
