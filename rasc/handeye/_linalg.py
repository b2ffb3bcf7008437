"""Primitives of the hand-eye kernels (private): LAPACK through np.linalg, reductions,
per-thread scratch buffers, the component-major layout. Shared by
:mod:`rasc.handeye._checks` and :mod:`rasc.handeye._kernels`."""

from __future__ import annotations

import functools
import math
import threading

import numpy as np

_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])
_EYE3 = np.eye(3)
#: Reductions as ufunc methods: the same numbers as ``a.sum()`` / ``a.max()`` /
#: ``a.min()``, without the ndarray methods' Python wrapper (≈0.5 µs a call).
_sum, _max, _min = np.add.reduce, np.maximum.reduce, np.minimum.reduce


#: Per-thread scratch arrays for the largest temporaries that never leave their function
#: (all pairs' quaternion products, eq. 10's residual blocks). A fresh array of a few
#: hundred kB per call is mapped and page-faulted in anew each time the allocator has
#: trimmed the heap (measured: 376 page faults per 88-pose solve); reusing one does not.
#: Arrays above ``_SCRATCH_MAX_FLOATS`` are allocated as usual (no memory is held).
_SCRATCH = threading.local()
_SCRATCH_MAX_FLOATS = 1 << 18
#: ... and below this size too: small arrays come from the allocator's pools, without
#: page faults, and faster than the look-up of a thread's buffer.
_SCRATCH_MIN_FLOATS = 1 << 12


def _scratch(slot: int, shape: tuple[int, ...]) -> np.ndarray:
    """An uninitialised float array of ``shape``: this thread's buffer ``slot`` (0–4).

    Slot 4 holds the one-block solve's pair translations (:func:`_solve`); slots 0–3
    temporaries that die in the function that takes them."""
    size = math.prod(shape)
    if size > _SCRATCH_MAX_FLOATS or size < _SCRATCH_MIN_FLOATS:
        return np.empty(shape)
    bufs = getattr(_SCRATCH, "bufs", None)
    if bufs is None:
        bufs = _SCRATCH.bufs = [np.empty(0)] * 5
    if bufs[slot].size < size:
        bufs[slot] = np.empty(size)
    return bufs[slot][:size].reshape(shape)


@functools.lru_cache(maxsize=64)
def _row_offsets(m: int) -> np.ndarray:
    """``0, 4, ..., 4(m − 1)``: the first row of each of m stacked 4×4 blocks."""
    return _read_only(np.arange(0, 4 * m, 4))


def _read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


#: LAPACK through numpy's public np.linalg only (eigh, svd, solve, det: one LAPACK call
#: per matrix of a stack, the same routines and so the same numbers as numpy's private
#: gufuncs, which are not called). Its per-call set-up (type checks, an errstate context)
#: costs 5–7 µs a call for a 3×3 on an idle machine, more under load: a nine-view solve
#: measured 50–75 µs slower than with the gufuncs at load 6 (benchmarks/bench_handeye.py
#: against the base commit). Non-convergence raises LinAlgError.
_eigh = np.linalg.eigh
_svd = np.linalg.svd
_det = np.linalg.det


def _solve_spd(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.solve`` for (..., 3, 3) and (..., 3): one LU per matrix."""
    return np.linalg.solve(A, b[..., None])[..., 0]


def _swap(a: np.ndarray) -> np.ndarray:
    return a.swapaxes(-1, -2)


def _gram(R: np.ndarray) -> np.ndarray:
    """RᵀR of (..., 3, 3) matrices, elementwise (one product, then the three terms added
    in order): per matrix the same bits however many there are, and for many small
    matrices faster than one BLAS call per matrix."""
    P = R[..., :, :, None] * R[..., :, None, :]                   # R_ij R_ik at [i, j, k]
    G = np.add(P[..., 0, :, :], P[..., 1, :, :])
    G += P[..., 2, :, :]
    return G


def _stacked(R: np.ndarray) -> np.ndarray:
    """R (S, n, 3, 3) → (S, 3n, 3), rows ordered (component i, view a): ``R_a[i, :]``.

    Component-major: every sum over views below is then a matrix product or a reduction
    over a leading axis, the fast kinds.
    """
    S, n = R.shape[:2]
    return R.transpose(0, 2, 1, 3).reshape(S, 3 * n, 3)


def _det_closed_form(R: np.ndarray) -> np.ndarray:
    """det of (..., 3, 3) by cofactors: for many matrices several times faster than one
    LU per matrix (LAPACK); equal to it to round-off (used only for the yes/no checks of
    :func:`_fast_checks`, whose failures are re-examined by :func:`validate_poses`)."""
    r0, r1, r2 = R[..., 0, :], R[..., 1, :], R[..., 2, :]
    c0 = r1[..., 1] * r2[..., 2] - r1[..., 2] * r2[..., 1]
    c1 = r1[..., 2] * r2[..., 0] - r1[..., 0] * r2[..., 2]
    c2 = r1[..., 0] * r2[..., 1] - r1[..., 1] * r2[..., 0]
    c0 *= r0[..., 0]
    c1 *= r0[..., 1]
    c2 *= r0[..., 2]
    c0 += c1
    c0 += c2
    return c0


#: Samples per block of the batched solve: keeps every temporary (S·9n² floats) near
#: 2 MB, inside the cache, whatever S.
_CHUNK_FLOATS = 1 << 18


