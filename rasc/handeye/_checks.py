"""The hand-eye solver's checks (private): its inputs (:func:`validate_poses`, by the one
transform check :func:`rasc.geometry.transforms.validate_rigid_transform`, and the fast
yes/no pass of :func:`_validate_inputs`) and what the data can determine (two rotation axes,
``MIN_AXIS_SPREAD``; cond(CᵀC) within ``MAX_COND_CTC``), each refusal one line naming the
sample and the weak axis. Used by :mod:`rasc.handeye._kernels`."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.transforms import RIGID_ATOL, validate_rigid_transform
from rasc.handeye._linalg import (
    _CHUNK_FLOATS,
    _EYE3,
    _LAST_ROW,
    _det,
    _det_closed_form,
    _gram,
    _max,
    _min,
    _sum,
)
from rasc.handeye.result import MAX_COND_CTC, MIN_AXIS_SPREAD


def _index_str(idx: tuple[int, ...]) -> str:
    return ", ".join(str(int(i)) for i in idx)


def validate_poses(T: Any, name: str, *, batch: bool = False,
                   check_rigid: bool = True) -> np.ndarray:
    """Check an array of 4×4 transforms, (n, 4, 4) or with ``batch`` (S, n, 4, 4), by the
    one transform check, :func:`rasc.geometry.transforms.validate_rigid_transform`.

    Always: shape, finite, last row ``0 0 0 1``, rotation block with det > 0. With
    ``check_rigid`` also orthonormal with det +1 within ``RIGID_ATOL``. Raises
    :class:`InputError` naming ``name[index]``.
    """
    return validate_rigid_transform(
        T, name=name, stacked=2 if batch else 1, rigid=check_rigid,
        hint=" (pass check_rigid=False to accept the paper's literal eq. 13 noise)")


def _validate_inputs(T_cam_from_world: Any, T_gaze_from_ptu: Any, *, batch: bool,
                     check_rigid: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple]:
    """Validate both inputs as :func:`validate_poses` does, in one pass over both.

    Returns ``(T_cw, T_gp, T_all, (G, err))``: T_cw (S, n, 4, 4) (S = 1 unless ``batch``),
    T_gp (Sq, n, 4, 4) with Sq ∈ {1, S}, ``T_all`` their concatenation (S + Sq, n, 4, 4),
    ``G`` = RᵀR of every rotation block of T_all and ``err`` (S + Sq, n) = max |RᵀR − I| of
    each (both None when not measured: without ``check_rigid``, or for a batch too large to
    concatenate). The checks run once on the stacked arrays; only when one fails (or the
    arrays cannot be stacked) does :func:`validate_poses` run on each input in turn, so the
    error raised is the one it raises, for the first offending input and index. A batch of
    more than ``_CHUNK_FLOATS`` numbers is not copied into a concatenation: each input is
    checked on its own and ``T_all`` is None (:func:`_solve` concatenates block by block).
    """
    fast = None
    try:
        A = np.asarray(T_cam_from_world, dtype=float)
        B = np.asarray(T_gaze_from_ptu, dtype=float)
    except (TypeError, ValueError):
        A = B = None
    if (A is not None and A.ndim == (4 if batch else 3) and B.ndim in ((3, 4) if batch else (3,))
            and A.shape[-3:] == B.shape[-3:] and A.shape[-2:] == (4, 4) and A.size
            and (B.ndim == 3 or B.shape[0] == A.shape[0])):
        B4 = B if B.ndim == 4 else B[None]
        if batch and A.size > _CHUNK_FLOATS:
            if _fast_checks(A, check_rigid) is not None and \
                    _fast_checks(B4, check_rigid) is not None:
                return A, B4, None, (None, None, None)   # each block measures its own G
            fast = None
        else:
            T_all = np.concatenate([A if batch else A[None], B4])
            fast = _fast_checks(T_all, check_rigid)
    if fast is not None:
        S = A.shape[0] if batch else 1
        return T_all[:S], T_all[S:], T_all, fast
    # The slow path: the first failing check of the first input raises its own message.
    A = validate_poses(T_cam_from_world, "T_cam_from_world", batch=batch, check_rigid=check_rigid)
    shared = not batch or np.ndim(T_gaze_from_ptu) == 3
    B = validate_poses(T_gaze_from_ptu, "T_gaze_from_ptu", batch=not shared,
                       check_rigid=check_rigid)
    A = A if batch else A[None]
    B = B[None] if shared else B
    if batch and not shared and B.shape[0] != A.shape[0]:
        raise InputError(f"T_gaze_from_ptu has {B.shape[0]} samples, T_cam_from_world "
                         f"{A.shape[0]}")
    _check_positions(A.shape[1], B.shape[1])
    return A, B, np.concatenate([A, B]), (None, None, None)


def _fast_checks(T: np.ndarray, check_rigid: bool) -> tuple | None:
    """:func:`validate_poses`' checks as a yes/no on (m, n, 4, 4): None if any fails,
    else ``(G, err)`` as :func:`_validate_inputs` returns them."""
    # ufunc reductions rather than the ndarray methods, which add a Python wrapper
    if not math.isfinite(_sum(T, None)):          # a finite sum ⇔ no NaN and no infinity
        return None
    last = T[..., 3, :]
    if not np.logical_and.reduce(last == _LAST_ROW, axis=None) and \
            _max(np.abs(last - _LAST_ROW), None) > RIGID_ATOL:     # exact is the usual case
        return None
    R = T[..., :3, :3]
    det = _det(R) if R.size < 9 * 1024 else _det_closed_form(R)
    if not check_rigid:
        return (None, None, None) if _min(det, None) > 0 else None
    # |det − 1| ≤ RIGID_ATOL < 1 implies det > 0
    G = _gram(R)
    err = _max(np.abs(G - _EYE3).reshape(R.shape[:-2] + (9,)), axis=-1)    # per view
    emax = float(_max(err, None))
    if max(emax, float(_max(np.abs(det - 1.0), None))) > RIGID_ATOL:
        return None
    return G, err, emax


def _check_positions(n: int, n_unit: int) -> None:
    if n != n_unit:
        raise InputError(f"T_cam_from_world has {n} positions but T_gaze_from_ptu has "
                         f"{n_unit}: one unit pose per camera view is needed")
    if n < 3:
        raise DegenerateDataError(
            f"only {n} positions: the hand-eye transform needs at least 3 positions "
            "(2 motions about different axes); add positions that combine pan and tilt")


def _unit_axis(v: np.ndarray) -> tuple[float, float, float]:
    """An axis as a unit vector, its largest component positive (an eigenvector's sign
    is arbitrary)."""
    x, y, z = np.asarray(v, dtype=float).tolist()
    norm = math.sqrt(x * x + y * y + z * z)
    ax, ay, az = abs(x), abs(y), abs(z)           # the first of the largest, as max(key=abs)
    big = (x if ax >= az else z) if ax >= ay else (y if ay >= az else z)
    sign = -1.0 if big < 0 else 1.0
    return (sign * x / norm + 0.0, sign * y / norm + 0.0, sign * z / norm + 0.0)  # no -0.0


def _fmt_axis(v: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.3f}" for x in np.round(_unit_axis(v), 3) + 0.0) + "]"


def _where(S: int, s: int) -> str:
    return f" (sample {s})" if S > 1 else ""


def _check_rotation_axes(eig: tuple, wk: np.ndarray, min_rotation_rad: float,
                         S_total: int = 1, offset: int = 0,
                         all_pairs: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Raise unless ≥ 2 usable motions about non-parallel axes (``MIN_AXIS_SPREAD``).

    eig: eigenvalues (Su, 3) and vectors (Su, 3, 3) of ``G = Σ w β βᵀ``; wk (Su, K) pair
    weights (Su = 1: shared by all samples; else samples ``offset`` ... of ``S_total``).
    ``all_pairs``: wk is the method's whole pair set (at least 2 pairs for n ≥ 3).
    Returns the axis spread λ2/λ1 (Su,) and the dominant axis (Su, 3).
    """
    Su = wk.shape[0]
    if Su == 1:                                   # a unit shared by all samples
        S_total = 1
    usable = ([2] if all_pairs else np.count_nonzero(wk, axis=1) if Su > 1
              else [np.count_nonzero(wk)])
    if min(usable) < 2:
        usable = np.asarray(usable)
        s = int(np.argmax(usable < 2))
        raise DegenerateDataError(
            f"only {int(usable[s])} motion(s) of the unit rotate by at least "
            f"{min_rotation_rad:g} rad{_where(S_total, offset + s)}: the hand-eye transform "
            "needs at least 2 motions about different axes; move the unit between views (e.g. "
            "positions that combine pan and tilt)")
    lam, vec = eig
    if Su == 1:                                   # one sample: plain floats are cheaper
        _, l1, l2 = lam[0].tolist()
        spread = np.array([l1 / l2])
        bad = not l1 / l2 >= MIN_AXIS_SPREAD
    else:
        spread = lam[:, 1] / lam[:, 2]
        bad = not _min(spread) >= MIN_AXIS_SPREAD
    if bad:
        s = int(np.argmax(~(spread >= MIN_AXIS_SPREAD)))
        raise DegenerateDataError(
            f"rotation about, and translation along, the unit's rotation axis "
            f"{_fmt_axis(vec[s, :, 2])} (unit frame) cannot be determined"
            f"{_where(S_total, offset + s)}: "
            f"all motions turn about that one axis (axis spread λ2/λ1 = {spread[s]:.2g} < "
            f"{MIN_AXIS_SPREAD:g}: pan-only or tilt-only data, or the other joint moved "
            "too little); add positions with tilt (and pan), so the motions turn about at "
            "least two different axes")
    return spread, vec[:, :, 2]


def _cond_CtC_surely_ok(CtC: np.ndarray) -> bool:
    """True if every cond(CᵀC) (CtC (S, 3, 3), symmetric positive semi-definite) is
    certainly within ``MAX_COND_CTC``, without an eigen-decomposition.

    With eigenvalues λ0 ≤ λ1 ≤ λ2: λ2 ≤ tr = Σλ and λ1λ2 ≤ c2 = λ0λ1 + λ0λ2 + λ1λ2 (the
    sum of the principal 2×2 minors), so λ0 = det/(λ1λ2) ≥ det/c2 and cond = λ2/λ0 ≤
    tr·c2/det. The bound is at most 9× the condition number, so well-posed samples
    (cond ≈ 2 for the nine poses) pass by a wide margin; the 1 % slack covers round-off
    in tr, c2 and det. False means "not certain": the caller computes the eigenvalues.
    """
    a00, a11, a22 = CtC[:, 0, 0], CtC[:, 1, 1], CtC[:, 2, 2]
    a01, a02, a12 = CtC[:, 0, 1], CtC[:, 0, 2], CtC[:, 1, 2]
    tr = a00 + a11 + a22
    c2 = a00 * a11 + a00 * a22 + a11 * a22 - a01 * a01 - a02 * a02 - a12 * a12
    det = _det_closed_form(CtC)
    return bool(((tr * c2) <= (0.99 * MAX_COND_CTC) * det).all())


def _check_cond_CtC(eig: tuple, S_total: int, offset: int = 0) -> np.ndarray:
    """cond(CᵀC) (Sc,) from its eigenvalues (inf when singular); raises above
    ``MAX_COND_CTC`` naming the weak direction (the smallest eigenvalue's vector)."""
    lam, vec = eig
    if len(lam) == 1:                             # one sample: plain floats are cheaper
        l0, _, l2 = lam[0].tolist()
        cond = np.array([l2 / l0 if l0 > 0 else math.inf])
    else:
        cond = np.divide(lam[:, 2], lam[:, 0], out=np.full(len(lam), np.inf),
                         where=lam[:, 0] > 0)
    if not _max(cond) <= MAX_COND_CTC:
        s = int(np.argmax(~(cond <= MAX_COND_CTC)))
        raise DegenerateDataError(
            f"translation along {_fmt_axis(vec[s, :, 0])} (camera frame) is not determined"
            f"{_where(S_total, offset + s)}: cond(CᵀC) = {cond[s]:.3g} > {MAX_COND_CTC:g} (eq. "
            "7); the motions' rotation axes are nearly parallel; add positions that turn "
            "about a second axis (combine pan with tilt)")
    return cond


