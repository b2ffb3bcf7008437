"""Advice on hand-eye data and solutions: what a user should be told, apart from the solver.

The solver (:mod:`rasc.handeye.solver`) returns a number or raises; this module words what
the data and the number suggest: motions that do not match the camera's (a unit mix-up),
target poses behind the camera, and warnings on a returned solution (quality, axis
spread, estimated error, a camera looking backwards). ``rasc handeye`` and
``rasc calibrate`` print these one line each.
"""

from __future__ import annotations

import math

import numpy as np

from rasc.errors import InputError
from rasc.handeye._kernels import _fmt_axis
from rasc.handeye.solver import (
    MIN_PAIR_ROTATION_RAD,
    WEAK_AXIS_SPREAD,
    HandEyeResult,
    HandEyeUncertainty,
    pair_rotvecs,
)

#: The paper (section 3.2) found solutions with quality (eq. 10) above 1 unusable.
QUALITY_UNUSABLE = 1.0

#: Warn when the estimated rotation error (jackknife) exceeds this: at 2 m, 1° moves a
#: point seen through the calibrated camera by 35 mm; the paper's Table 1 std is 9-54 mm.
MAX_ROTATION_UNCERTAINTY_DEG = 1.0

#: Motions that do not match: the median over pairs of angle(B_ij) / angle(A_ij) must lie
#: within this factor of 1. The two angles are equal for consistent data whatever X is
#: (A = X B X⁻¹ is a conjugation), so the test needs no solution. Degrees read as radians
#: make the ratio 57 (or, wrapped past π, anything above ~10 for motions of a few
#: degrees); radians read as degrees 1/57. Noise moves it little: at the paper's largest
#: level (σ_r = 0.04 rad, literal eq. 13, ±8° motions) it stays within 0.69–1.12 over
#: 200 samples (tests/handeye/test_handeye.py); 3 leaves room for smaller motions and worse data
#: (±2° motions at that noise: 0.37–0.85).
MAX_MOTION_ANGLE_RATIO = 3.0


def motion_angle_ratio(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray) -> float:
    """Median over pairs i > j of ``angle(B_ij) / angle(A_ij)``: 1 for consistent data.

    Pairs where either rotation is below ``MIN_PAIR_ROTATION_RAD`` are left out; NaN when
    none is left. Accepts slightly non-orthogonal rotations (nearest rotation taken).
    """
    R = np.asarray(T_cam_from_world, dtype=float)[..., :3, :3]
    Q = np.asarray(T_gaze_from_ptu, dtype=float)[..., :3, :3]
    i, j = np.tril_indices(R.shape[0], -1)
    a = np.linalg.norm(pair_rotvecs(R, i, j), axis=-1)
    b = np.linalg.norm(pair_rotvecs(Q, i, j), axis=-1)
    ok = (a >= MIN_PAIR_ROTATION_RAD) & (b >= MIN_PAIR_ROTATION_RAD)
    return float(np.median(b[ok] / a[ok])) if ok.any() else math.nan


def check_motions_match(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *,
                        other_unit: tuple[str, np.ndarray] | None = None) -> None:
    """Raise :class:`InputError` when the unit's motions and the camera's do not match.

    ``other_unit``: for motions read from pan/tilt angles, ``(name, T_gaze_from_ptu)``
    with the same angles read in the other unit ("deg" or "rad"); when those match, the
    message says to change the unit, otherwise it calls the data inconsistent.
    """
    ratio = motion_angle_ratio(T_cam_from_world, T_gaze_from_ptu)
    if _motions_match(ratio):
        return
    what = (f"the unit's motions turn {ratio:.3g}× as far as the camera's (median over "
            "pairs; the two angles are equal for consistent data)")
    if other_unit is not None:
        name, T_other = other_unit
        alt = motion_angle_ratio(T_cam_from_world, T_other)
        if _motions_match(alt):
            raise InputError(f"{what}: read as {name} the angles match ({alt:.3g}×); "
                             f"set angle_unit to '{name}'")
    raise InputError(f"{what}: the data are inconsistent; check that each "
                     "T_cam_from_world is the target's pose in the camera (not its inverse), "
                     "belongs to the motion beside it, and that the angles' unit is right")


def _motions_match(ratio: float) -> bool:
    return not math.isfinite(ratio) or 1.0 / MAX_MOTION_ANGLE_RATIO <= ratio \
        <= MAX_MOTION_ANGLE_RATIO


def input_warnings(T_cam_from_world: np.ndarray,
                   T_gaze_from_ptu: np.ndarray | None = None) -> list[str]:
    """What looks wrong in the target poses themselves, one sentence each: the target's
    origin (a corner of the board, which the camera sees) behind most cameras, as when
    T_world_from_cam is given for T_cam_from_world (a solver still returns an answer).

    With ``T_gaze_from_ptu``: no such sentence when the translations fit a solution with
    an unknown scale far better (:func:`rasc.handeye.scale.scale_warning`): poses from
    visual odometry or SfM have a world frame of their own, not a board in front of the
    camera, and :func:`translation_warnings` names that cause instead."""
    z = np.asarray(T_cam_from_world, dtype=float)[:, 2, 3]
    behind = np.flatnonzero(z <= 0)
    if 2 * behind.size > z.size and T_gaze_from_ptu is not None \
            and _scale_explains(T_cam_from_world, T_gaze_from_ptu):
        return []
    if 2 * behind.size > z.size:
        return [f"{behind.size} of {z.size} poses put the target's origin behind the camera "
                f"(T_cam_from_world[{int(behind[0])}] has z = {z[behind[0]]:.3g}); a "
                "camera sees its target in front (z > 0): are these T_world_from_cam?"]
    return []


#: Translation consistency: for consistent data the target's pose in the unit's (ptu)
#: frame, ``inv(T_gaze_from_ptu_k) · inv(T_cam_from_gaze) · T_cam_from_world_k``, is the
#: same at every position (the board stays put while the unit moves). Warn when its
#: translation scatters by more than this fraction of the target distance (the median
#: ``||t_cam_from_world||``). Pose noise moves it by about the rotation noise times the
#: distance: at the paper's largest level (σ_r = 0.02 rad, 1.1°) 2-4 % of it; one
#: position's translation in millimetres among metres moves it about 1000-fold (a
#: translation of the answer near a kilometre).
MAX_TRANSLATION_SCATTER = 0.1

#: A position whose target distance is this many times larger or smaller than the median
#: is named as the likely culprit (another length unit).
UNIT_RATIO = 3.0


def unit_suspect(T_cam_from_world: np.ndarray) -> tuple[int, float] | None:
    """The position whose target distance (``‖t_cam_from_world‖``) is furthest from the
    median, with its ratio to the median, when that is :data:`UNIT_RATIO` times off (a
    translation in another length unit), else None."""
    with np.errstate(all="ignore"):
        distance = np.linalg.norm(np.asarray(T_cam_from_world, dtype=float)[:, :3, 3], axis=1)
        median = float(np.median(distance))
        if not (np.isfinite(median) and median > 0):
            return None
        ratio = distance / median
        k = int(np.argmax(np.abs(np.log(np.where(ratio > 0, ratio, np.inf)))))
    if ratio[k] > UNIT_RATIO or ratio[k] < 1 / UNIT_RATIO:
        return k, float(ratio[k])
    return None


def _scale_explains(T_cam_from_world, T_gaze_from_ptu, R_cam_from_gaze=None) -> str | None:
    """The unknown-scale sentence when the translations fit a scaled solution far better
    (:func:`rasc.handeye.scale.scale_warning`; R_cam_from_gaze from RASC when not given),
    else None."""
    from rasc.errors import RascError
    from rasc.handeye.scale import scale_warning
    from rasc.handeye.solver import solve_rasc

    if R_cam_from_gaze is None:
        try:
            R_cam_from_gaze = solve_rasc(T_cam_from_world, T_gaze_from_ptu,
                                         check_rigid=False).T_cam_from_gaze[:3, :3]
        except RascError:
            return None
    return scale_warning(T_cam_from_world, T_gaze_from_ptu, R_cam_from_gaze)


def translation_warnings(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                         T_cam_from_gaze: np.ndarray | HandEyeResult,
                         names: list[str] | None = None, *,
                         scale_check: bool = True) -> list[str]:
    """Translations that contradict each other (one sentence, or none).

    Parameters
    ----------
    T_cam_from_world, T_gaze_from_ptu : ndarray, shape (n, 4, 4)
    T_cam_from_gaze : ndarray, shape (4, 4), or a HandEyeResult
        The solution. A ``rasc-robust`` result
        (:class:`~rasc.handeye.robust.RobustHandEyeResult`) is checked on its inliers
        only: the positions it rejected are named by its own result. A result with a
        ``scale`` of the camera translations (``rasc-scale``, or its refinement) is
        checked on the camera translations multiplied by it: the translations it solved.
    names : how to name position k in the message (default ``positions[k]``)
    scale_check : when the translations scatter, first ask whether a common scale of the
        camera translations explains them (:func:`rasc.handeye.scale.scale_warning`):
        then that is the sentence.

    The target's translation in the unit's frame (fixed for consistent data, see
    :data:`MAX_TRANSLATION_SCATTER`) scatters by more than MAX_TRANSLATION_SCATTER of the
    target distance: the message names the position whose target distance is furthest
    from the median when it is :data:`UNIT_RATIO` times off (a length-unit mix-up),
    else calls the translations inconsistent.
    """
    T_cw = np.asarray(T_cam_from_world, dtype=float)
    T_gp = np.asarray(T_gaze_from_ptu, dtype=float)
    names = names or [f"positions[{k}]" for k in range(len(T_cw))]
    inliers = getattr(T_cam_from_gaze, "inliers", None)
    if inliers:
        keep = list(inliers)
        T_cw, T_gp, names = T_cw[keep], T_gp[keep], [names[k] for k in keep]
    s_cam = getattr(T_cam_from_gaze, "scale", None)
    if s_cam is not None and np.isfinite(s_cam) and s_cam > 0:
        T_cw = T_cw.copy()
        T_cw[:, :3, 3] *= s_cam
    if isinstance(T_cam_from_gaze, HandEyeResult):
        T_cam_from_gaze = T_cam_from_gaze.T_cam_from_gaze
    X = np.asarray(T_cam_from_gaze, dtype=float)
    with np.errstate(all="ignore"):
        distance = np.linalg.norm(T_cw[:, :3, 3], axis=1)
        scale = float(np.median(distance))
        if not (np.isfinite(scale) and scale > 0) or not np.all(np.isfinite(X)):
            return []
        T_gx = np.linalg.inv(X)
        T_pw = np.linalg.inv(T_gp) @ T_gx @ T_cw          # (n, 4, 4): constant if consistent
        t = T_pw[:, :3, 3]
        scatter = np.linalg.norm(t - np.median(t, axis=0), axis=1)
        worst = float(np.max(scatter))
        if np.isfinite(worst) and worst <= MAX_TRANSLATION_SCATTER * scale:
            return []
    scaled = _scale_explains(T_cw, T_gp, X[:3, :3]) if scale_check else None
    if scaled:
        return [scaled]
    advice = ("give every T_cam_from_world translation in one length unit, and check that "
              "each belongs to the motion beside it")
    suspect = unit_suspect(T_cw)
    if suspect is not None:
        k, ratio = suspect
        return [f"{names[k]}: the target is {ratio:.3g}× as far from the camera as at the "
                f"median position ({distance[k]:.3g} against {scale:.3g}): a translation in "
                f"another length unit? The solution's translation "
                f"({np.linalg.norm(X[:3, 3]):.3g}) is then wrong; {advice}"]
    return [f"the translations contradict each other: the target, fixed while the unit "
            f"moves, lands {worst:.3g} apart in the unit's frame (target distance "
            f"{scale:.3g}); the solution's translation is unreliable; {advice} (or solve "
            "with --method rasc-robust, which leaves out the positions the others "
            "contradict)"]


def solution_warnings(result: HandEyeResult, *,
                      uncertainty: HandEyeUncertainty | None = None,
                      pan_tilt: bool = False) -> list[str]:
    """What a user should be told about a solution that is returned: one sentence each.

    - quality (eq. 10) above ``QUALITY_UNUSABLE`` (the paper's rule);
    - motions that turn mostly about one axis (axis spread below ``WEAK_AXIS_SPREAD``);
    - an estimated rotation error above ``MAX_ROTATION_UNCERTAINTY_DEG``, or none to be
      had (``uncertainty``, from :func:`rasc.handeye.methods.jackknife_uncertainty`);
    - with ``pan_tilt`` (motions from pan/tilt angles, eq. 3): a camera whose optical axis
      points backwards in the gaze frame (gaze +y is forward). A pan or tilt turning the
      other way than eq. 3 assumes, pan and tilt swapped, or T_world_from_cam given for
      T_cam_from_world all give such a solution, often with a good quality: a reversed
      pan conjugates every motion by a half-turn, so the data stay consistent and the
      answer is the truth turned by 180°.
    """
    out = []
    rejected = getattr(result, "rejected", ())
    # rasc-robust (rasc.handeye.robust): which positions it left out, unless the outlier
    # policy chose it (rasc.handeye.robust_calibrate.closed_form), whose note names them
    if rejected and not getattr(result, "replaces", ""):
        out.append(f"{len(rejected)} position(s) rejected as inconsistent with the others "
                   "and left out: " + "; ".join(f"positions[{r.index}] ({r.reason})"
                                                for r in rejected))
    if result.quality > QUALITY_UNUSABLE:
        out.append(f"quality {result.quality:.3g} > {QUALITY_UNUSABLE:g}; the paper found "
                   "such solutions unusable")
    d = result.diagnostics
    if d.axis_spread < WEAK_AXIS_SPREAD:
        out.append(f"the motions turn mostly about the unit's axis "
                   f"{_fmt_axis(d.dominant_axis)} (axis spread {d.axis_spread:.2g} "
                   f"< {WEAK_AXIS_SPREAD:g}): rotation about it and translation along it "
                   f"are weakly determined, errors about {1 / math.sqrt(d.axis_spread):.0f}× "
                   "those of well-spread motions; add positions that move the other joint "
                   "further")
    if uncertainty is not None:
        if uncertainty.rotation_deg is None:
            out.append(f"no error estimate: {uncertainty.reason}")
        elif uncertainty.rotation_deg > MAX_ROTATION_UNCERTAINTY_DEG:
            out.append(f"estimated error (jackknife over positions) "
                       f"{uncertainty.rotation_deg:.2g}° in rotation and "
                       f"{uncertainty.translation:.3g} in translation (the input's length "
                       "unit), "
                       f"above {MAX_ROTATION_UNCERTAINTY_DEG:g}°: the poses are too noisy "
                       "for these motions; add positions with larger pan and tilt, or "
                       "improve the camera calibration")
    if pan_tilt:
        forward = float(np.asarray(result.T_cam_from_gaze)[2, 1])  # cam +z · gaze +y
        if forward < 0:
            out.append(f"the camera's optical axis points backwards in the gaze frame "
                       f"(its component along gaze +y, forward, is {forward:.2f}): pan or "
                       "tilt probably turns the other way than eq. 3 assumes (positive pan "
                       "looks left, positive tilt up), pan and tilt are swapped, or the "
                       "poses are T_world_from_cam instead of T_cam_from_world")
    return out
