"""Gaze-to-camera ("hand-eye") calibration by RASC: docs/METHOD.md §3, paper section 3.2, eq. 6–10.

Solves ``A X = X B`` for ``X = T_cam_from_gaze`` (the paper's ``T_cg``) from the target's
pose ``T_cam_from_world`` (``T_cw``) and the unit's motion ``T_gaze_from_ptu`` (``T_gp``,
eq. 3; for a robot arm the gripper's pose ``T_gripper_from_base``) at n positions. For
every ordered pair i ≠ j::

    A_ij = T_cw^i (T_cw^j)^-1:  R_A = R_cw^i (R_cw^j)^T,  t_A = t_cw^i − R_A t_cw^j
    B_ij = T_gp^i (T_gp^j)^-1   (likewise)

Rotation (eq. 6, 8, 9; Park & Martin): ``α = log R_A``, ``β = log R_B``, ``α = R_X β``;
``M = Σ β αᵀ`` and ``R_X = (MᵀM)^(-1/2) Mᵀ``. Translation (eq. 7 generalised to a unit
that also translates): ``(I − R_A) t_X = t_A − R_X t_B``; least squares
``t_X = (CᵀC)^-1 Cᵀd`` (erratum, docs/METHOD.md §3: not ^-1/2). Quality (eq. 10): the
mean over all i ≠ j of ``‖R_X R_B R_Xᵀ − R_A‖_F``; above 1 the paper found solutions
unusable.

Where to read what:

- :mod:`rasc.handeye.paper` — eq. 6–10 written plainly, one pair at a time: the
  reference, and what the tests hold the solver to.
- :mod:`rasc.handeye._kernels` — the speed work (quaternion pair logs, sums over pairs
  as matrix products, one code path for every batch size, the one-solve fast path),
  private; the same numbers as the reference to round-off (tests/handeye/).
- :mod:`rasc.handeye.result` — the thresholds (``MIN_PAIR_ROTATION_RAD``,
  ``MIN_AXIS_SPREAD``, ``MAX_COND_CTC``, ...) and the result types.
- this module — the entry points: :func:`solve_rasc`, :func:`solve_rasc_batch`,
  :func:`solve_rasc_each`, :func:`diagnose`; and, re-exported, every name it had before
  the split (:func:`validate_poses`, :func:`quality_eq10`, :func:`pair_rotvecs`, the
  result types and thresholds).

Literal noise. The paper's eq. 13 noise leaves ``R_cw`` slightly non-orthogonal. Such
input is accepted with ``check_rigid=False`` (the default ``True`` rejects anything not
rigid within :data:`rasc.geometry.transforms.RIGID_ATOL`): the rotation step then uses each view's
nearest rotation (polar factor), the translation step and eq. 10 use the matrices as
given (``R_A = R_i R_jᵀ``, ``t_A = t_i − R_A t_j`` exactly as eq. 7 prints them).
"""

from __future__ import annotations

import numpy as np

from rasc.errors import DegenerateDataError, InputError  # noqa: F401  (re-exported)
from rasc.geometry.transforms import make_transform
from rasc.handeye._kernels import (  # noqa: F401  (pair_rotvecs, quality_eq10, validate_poses re-exported)
    _check_positions,
    _diagnostics,
    _one_case,
    _pairs,
    _result,
    _solve,
    _solve_one,
    _validate_inputs,
    pair_rotvecs,
    quality_eq10,
    validate_poses,
)
from rasc.handeye.result import (  # noqa: F401  (re-exported)
    MAX_COND_CTC,
    MIN_AXIS_SPREAD,
    MIN_PAIR_ROTATION_RAD,
    PAIRS,
    WEAK_AXIS_SPREAD,
    HandEyeBatchResult,
    HandEyeDiagnostics,
    HandEyeResult,
    HandEyeUncertainty,
)
from rasc.io import finite_number

__all__ = ["MAX_COND_CTC", "MIN_AXIS_SPREAD", "MIN_PAIR_ROTATION_RAD", "PAIRS",
           "WEAK_AXIS_SPREAD", "HandEyeBatchResult", "HandEyeDiagnostics", "HandEyeResult",
           "HandEyeUncertainty", "diagnose", "pair_rotvecs", "quality_eq10", "solve_rasc",
           "solve_rasc_batch", "solve_rasc_each", "validate_poses"]

# ------------------------------------------------------------------------ public

def solve_rasc(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *,
               pairs: str = "all", min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
               check_rigid: bool = True) -> HandEyeResult:
    """RASC gaze-to-camera calibration (docs/METHOD.md §3, eq. 6–10).

    Parameters
    ----------
    T_cam_from_world : array-like, shape (n, 4, 4)
        Target pose in the camera at each position (camera calibration), ``T_cw``.
    T_gaze_from_ptu : array-like, shape (n, 4, 4)
        The unit's motion at each position, ``T_gp`` (eq. 3, pure rotation for a
        pan-tilt unit); for a robot arm ``T_gripper_from_base``.
    pairs : {"all", "half"}
        "all" ordered pairs i ≠ j (docs/METHOD.md §3); "half" = OpenCV's pair set (see ``PAIRS``).
    min_rotation_rad : float
        Pairs whose unit rotation is smaller are left out (``MIN_PAIR_ROTATION_RAD``).
    check_rigid : bool
        Reject non-rigid input; ``False`` accepts the paper's literal eq. 13 noise.

    Returns
    -------
    HandEyeResult
        ``T_cam_from_gaze`` (4, 4) (for a robot arm: ``T_cam_from_gripper``), method
        "rasc". Raises :class:`DegenerateDataError` when the data cannot determine it.
    """
    if _one_case(T_cam_from_world, T_gaze_from_ptu, pairs, min_rotation_rad):
        res = _solve_one(T_cam_from_world, T_gaze_from_ptu,
                         _pairs(len(T_cam_from_world), pairs, None), min_rotation_rad)
        if res is not None:
            return res
    T_cw, T_gp, T_all, checked = _validate_inputs(T_cam_from_world, T_gaze_from_ptu,
                                                  batch=False, check_rigid=check_rigid)
    n = T_cw.shape[1]
    _check_positions(n, T_gp.shape[1])
    _check_min_rotation(min_rotation_rad)
    pair = _pairs(n, pairs, None)
    return _result(_solve(T_cw, T_gp, T_all, pair, min_rotation_rad, checked), n, pair)


def solve_rasc_batch(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *,
                     pairs: str = "all", min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
                     check_rigid: bool = True) -> HandEyeBatchResult:
    """S independent RASC solves at once (Monte-Carlo samples of one pose set).

    Parameters
    ----------
    T_cam_from_world : array-like, shape (S, n, 4, 4)
    T_gaze_from_ptu : array-like, shape (n, 4, 4) shared by all samples, or (S, n, 4, 4)
    pairs, min_rotation_rad, check_rigid : as :func:`solve_rasc`.

    Returns
    -------
    HandEyeBatchResult
        ``T_cam_from_gaze`` (S, 4, 4) and ``quality`` (S,), each bit for bit what
        :func:`solve_rasc` returns for that sample, whatever the other samples (a
        sample's numbers do not depend on the batch's size or composition). Any
        degenerate sample makes the whole call raise :class:`DegenerateDataError` naming
        it ("(sample k)"); :func:`rasc.handeye.methods.solve_many` instead gives each
        sample its own result or error.
    """
    T_cw, T_gp, T_all, checked = _validate_inputs(T_cam_from_world, T_gaze_from_ptu,
                                                  batch=True, check_rigid=check_rigid)
    if T_cw.shape[0] == 0:
        raise InputError(f"T_cam_from_world: no samples (shape {T_cw.shape})")
    _check_positions(T_cw.shape[1], T_gp.shape[1])
    _check_min_rotation(min_rotation_rad)
    out = _solve(T_cw, T_gp, T_all, _pairs(T_cw.shape[1], pairs, None), min_rotation_rad, checked,
                 diagnostics=False)
    return HandEyeBatchResult(T_cam_from_gaze=make_transform(out["RX"], out["tX"]),
                              quality=out["quality"])


def solve_rasc_each(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *,
                    pairs: str = "all", min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
                    check_rigid: bool = True) -> list[HandEyeResult]:
    """:func:`solve_rasc_batch` with each sample's full :class:`HandEyeResult` (with its
    diagnostics): the same objects, to the bit, as :func:`solve_rasc` on each sample.
    Raises like :func:`solve_rasc_batch` (any degenerate sample, named);
    :func:`rasc.handeye.methods.solve_many` gives each sample its own result or error."""
    T_cw, T_gp, T_all, checked = _validate_inputs(T_cam_from_world, T_gaze_from_ptu,
                                                  batch=True, check_rigid=check_rigid)
    S, n = T_cw.shape[:2]
    if S == 0:
        raise InputError(f"T_cam_from_world: no samples (shape {T_cw.shape})")
    _check_positions(n, T_gp.shape[1])
    _check_min_rotation(min_rotation_rad)
    pair = _pairs(n, pairs, None)
    out = _solve(T_cw, T_gp, T_all, pair, min_rotation_rad, checked)
    return [_result(out, n, pair, s) for s in range(S)]


def _check_min_rotation(min_rotation_rad: float) -> None:
    if finite_number(min_rotation_rad, "min_rotation_rad") < 0:
        raise InputError(f"min_rotation_rad: expected a finite value >= 0, "
                         f"got {min_rotation_rad!r}")


def diagnose(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, *,
             pairs: str = "all", home: int | None = None,
             min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
             check_rigid: bool = True) -> tuple[HandEyeDiagnostics, np.ndarray, np.ndarray]:
    """Validate, check degeneracy and measure conditioning for any hand-eye method.

    ``home`` selects Li's pairs (each view against the home view) instead of ``pairs``.
    Returns ``(diagnostics, T_cam_from_world, T_gaze_from_ptu)`` as float arrays; the
    ``cond_*`` values are those of RASC's equations on the selected pairs. Raises
    :class:`DegenerateDataError` / :class:`InputError` like :func:`solve_rasc`.
    """
    T_cw, T_gp, T_all, checked = _validate_inputs(T_cam_from_world, T_gaze_from_ptu,
                                                  batch=False, check_rigid=check_rigid)
    n = T_cw.shape[1]
    _check_positions(n, T_gp.shape[1])
    _check_min_rotation(min_rotation_rad)
    if home is not None and not (isinstance(home, int | np.integer) and 0 <= home < n):
        raise InputError(f"home: expected a position index in 0..{n - 1}, got {home!r}")
    pair = _pairs(n, pairs, None if home is None else int(home))
    out = _solve(T_cw, T_gp, T_all, pair, min_rotation_rad, checked)
    return _diagnostics(out, n, pair), T_cw[0], T_gp[0]
