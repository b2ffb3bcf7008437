"""The one outlier policy of ``rasc calibrate`` and ``rasc handeye``: RASC, or ``rasc-robust``
when the data ask for it.

:func:`closed_form` solves with the chosen method; for "rasc" (the paper's method, the
default of both commands and of :class:`rasc.head.options.CalibrationOptions`), when the
consistency checks of :mod:`rasc.handeye.advice` flag the solution
(:func:`contamination`), it runs ``rasc-robust`` (:mod:`rasc.handeye.robust`) and keeps
its result when it rejects positions, with a note naming them, so that the whole-head
refinement (``rasc calibrate``) or ``--refine`` (``rasc handeye``) starts from the
inliers. Any other method name is used as it is, in both commands. ``rasc calibrate``
(:func:`rasc.head.pipeline.calibrate_eye`) and ``rasc handeye``
(:mod:`rasc.commands.handeye`) both call :func:`closed_form` and print its notes as
warnings, so the same poses give the same choice and the same sentence through either
door. Apart from :mod:`rasc.handeye.robust` because it resolves methods by name
(:mod:`rasc.handeye.methods`, which registers ``rasc-robust``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rasc.errors import DegenerateDataError
from rasc.handeye.advice import QUALITY_UNUSABLE, translation_warnings, unit_suspect
from rasc.handeye.methods import Method, solve
from rasc.handeye.robust import NAME as ROBUST
from rasc.handeye.robust import solve_rasc_robust
from rasc.handeye.scale import scale_warning
from rasc.handeye.solver import HandEyeResult

#: The method name whose solution the policy checks and may replace (the default of
#: both commands).
SWITCHED = "rasc"

#: Options of "rasc" that rasc-robust takes too (the others stay with RASC).
_SHARED_OPTIONS = ("check_rigid", "min_rotation_rad")


@dataclass
class ClosedForm:
    """What :func:`closed_form` decided: the result and the notes for the user (one
    sentence each, printed as warnings by both commands)."""

    result: HandEyeResult
    notes: list[str] = field(default_factory=list)

    @property
    def method(self) -> str:
        """The method whose result this is ("rasc-robust" when the policy switched)."""
        return self.result.method

    @property
    def switched(self) -> bool:
        """True when rasc-robust's result replaced the method asked for."""
        return bool(getattr(self.result, "replaces", ""))


def contamination(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                  result: HandEyeResult, names: list[str] | None = None) -> list[str]:
    """The consistency checks of :mod:`rasc.handeye.advice` that flag ``result``: a
    quality (eq. 10) above the paper's limit and translations that contradict each other
    (:func:`~rasc.handeye.advice.translation_warnings`; with the position whose target
    distance is :data:`~rasc.handeye.advice.UNIT_RATIO` times off the median named, as
    ``names[k]``: a translation in another length unit?), unless a common scale of the
    camera translations explains them (:func:`rasc.handeye.scale.scale_warning`: poses
    without metric scale are not bad positions, and the translation warning names that
    cause). Empty: nothing flagged."""
    out = []
    if result.quality > QUALITY_UNUSABLE:
        out.append(f"quality {result.quality:.3g} > {QUALITY_UNUSABLE:g}")
    X = np.asarray(result.T_cam_from_gaze, dtype=float)
    if translation_warnings(T_cam_from_world, T_gaze_from_ptu, X, scale_check=False) \
            and scale_warning(T_cam_from_world, T_gaze_from_ptu, X[:3, :3]) is None:
        suspect = unit_suspect(T_cam_from_world)
        if suspect is None:
            out.append("the translations contradict each other")
        else:
            k, ratio = suspect
            name = names[k] if names else f"positions[{k}]"
            out.append(f"the translations contradict each other; {name}: the target is "
                       f"{ratio:.3g}× as far from the camera as at the median position, a "
                       "translation in another length unit?")
    return out


def _name(method: str | Method | Callable[..., Any]) -> str | None:
    return method if isinstance(method, str) else getattr(method, "name", None)


def closed_form(method: str | Method | Callable[..., Any], T_cam_from_world: np.ndarray,
                T_gaze_from_ptu: np.ndarray, names: list[str] | None = None,
                **options) -> ClosedForm:
    """The closed form of ``rasc calibrate`` and ``rasc handeye``: ``method`` (anything
    :func:`rasc.handeye.methods.get_method` resolves, called with ``options``); for
    "rasc" (the paper's method, the default), when :func:`contamination` flags its
    solution, ``rasc-robust`` instead — kept when it rejects some position, with a note
    naming them and why (``names[k]`` for position k, default ``positions[k]``), so that
    any refinement starts from the inliers. The kept result's ``replaces`` is "rasc" and
    its ``flagged`` what flagged RASC's. Any other method is used as it is."""
    result = solve(method, T_cam_from_world, T_gaze_from_ptu, **options)
    if _name(method) != SWITCHED:
        return ClosedForm(result)
    names = names or [f"positions[{k}]" for k in range(len(T_cam_from_world))]
    flagged = contamination(T_cam_from_world, T_gaze_from_ptu, result, names)
    if not flagged:
        return ClosedForm(result)
    shared = {k: v for k, v in options.items() if k in _SHARED_OPTIONS}
    try:
        robust = solve_rasc_robust(T_cam_from_world, T_gaze_from_ptu, **shared)
    except DegenerateDataError as exc:
        return ClosedForm(result, [f"the data look contaminated ({'; '.join(flagged)}) but "
                                   f"{ROBUST} could not separate the bad positions "
                                   f"({exc}); the closed form uses every position"])
    if not robust.rejected:
        return ClosedForm(result)
    which = "; ".join(f"{names[r.index]} ({r.reason})" for r in robust.rejected)
    robust = dataclasses.replace(robust, replaces=SWITCHED, flagged=tuple(flagged))
    return ClosedForm(robust, [
        f"the closed form's data look contaminated ({'; '.join(flagged)}): {ROBUST} "
        f"rejected {len(robust.rejected)} of {len(names)} positions: {which}; the closed "
        f"form (and any refinement) starts from the {len(robust.inliers)} others"])
