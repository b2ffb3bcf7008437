"""The speed kernels of RASC's solver: private, pinned against the paper's equations.

:mod:`rasc.handeye.paper` writes eq. 6–10 plainly, one ordered pair at a time; this
module computes the same numbers fast (tests/handeye/test_kernels_vs_paper.py checks
them against it). The public entry points are in :mod:`rasc.handeye.solver`.

Sums over pairs. CᵀC and Cᵀd (eq. 7) are 3×3 / 3 sums, and because ``R_A = R_i R_jᵀ`` is
bilinear in the views every sum over pairs is a contraction with the n×n pair-weight
matrix (no 3K×3 matrix, no loop over pairs). Eq. 9's ``R_X = (MᵀM)^(-1/2) Mᵀ`` is computed
as the polar factor of ``Mᵀ`` (``M = U Σ Vᵀ`` → ``R_X = V Uᵀ``), the same matrix whenever
MᵀM is non-singular, also defined when M has rank 2, and forced to det +1.

Logarithms: ``log(R_i R_jᵀ)`` is taken as ``log(q_i ⊗ q_j*)`` from each view's quaternion
(Shepperd's, as scipy's), with the atan2 form of the quaternion log — robust at angle 0
and π, equal to :func:`rasc.geometry.transforms.rotvec_from_matrix` of the pair matrix
for rotations (tested to 1e-12). A half turn's log has no sign of its own; the sign of
each half-turn α is taken to agree with the other pairs' R_X (:func:`_align_half_turns`).

Speed. For nine views the solve is about a hundred numpy calls on arrays of a few dozen
numbers, so it is their count that costs: both inputs are validated in one pass and their
logs taken in one pass, no scipy Rotation objects are made, the sums over views are
matrix products in a component-major layout (:func:`_stacked`), one eigen-decomposition
serves the axis-spread check, cond(CᵀC) and the diagnostics, and every n²-sized step is
one matrix product or elementwise pass. LAPACK is called through np.linalg (no private
numpy module), and the large n²-sized temporaries live in per-thread scratch arrays
(:func:`_scratch`): allocated afresh, each costs page faults whenever the allocator has
returned the memory in between (376 per 88-view solve).

One code path for every batch size. A single solve is a batch of one sample, and batches
go through in blocks of ``_CHUNK_FLOATS`` numbers, each block by the same code, whose
every step treats a sample on its own: its own decisions (orthogonal to round-off or
not, how many power steps per view, half turns), one LAPACK call per matrix, products
per sample of fixed shape (never one BLAS product whose size, and so whose kernels and
summation order, depends on the number of samples: measured to change last bits), and
reductions along per-sample axes. So ``solve_rasc_batch(T)[k]``,
``solve_rasc_batch(T[k:k+1])`` and ``solve_rasc(T[k])`` are the same bits
(tests/handeye/test_solver_batch.py). The batched form, which returns no diagnostics, bounds
cond(CᵀC) without eigenvalues where it can (:func:`_cond_CtC_surely_ok`).
A single solve of up to ``_ONE_MAX_VIEWS`` views in the common case (rigid to round-off,
every pair used, no half turn) takes :func:`_solve_one`: the same operations on the same
operands and shapes without the general path's bookkeeping, so the same bits again (for
nine views 72 calls of C functions and 30 of Python functions instead of 107 and 59,
counted by ``sys.setprofile``, array operators not counted); anything else it leaves to
the general path. Timings, against OpenCV's PARK in the same run:
``benchmarks/bench_handeye.py`` (figures in the README).

Literal (non-orthogonal) input: see :mod:`rasc.handeye.solver`.
"""

from __future__ import annotations

import functools
import math
from typing import Any, NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

from rasc.errors import InputError
from rasc.handeye._checks import (  # noqa: F401  (validate_poses: solver's public name)
    _check_cond_CtC,
    _check_positions,
    _check_rotation_axes,
    _cond_CtC_surely_ok,
    _fmt_axis,
    _unit_axis,
    _validate_inputs,
    validate_poses,
)
from rasc.handeye._linalg import (  # noqa: F401  (_det_closed_form: for the tests)
    _CHUNK_FLOATS,
    _EYE3,
    _LAST_ROW,
    _det,
    _det_closed_form,
    _eigh,
    _gram,
    _max,
    _min,
    _read_only,
    _row_offsets,
    _scratch,
    _solve_spd,
    _stacked,
    _sum,
    _svd,
    _swap,
)
from rasc.handeye.result import (
    MAX_COND_CTC,
    MIN_AXIS_SPREAD,
    PAIRS,
    HandEyeDiagnostics,
    HandEyeResult,
    _Deferred,
)

# --------------------------------------------------------------------------- input

# ---------------------------------------------------------------------- pair logs

def _quaternion_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Constant tables of the quaternion maths, [x, y, z, w] (scipy's order).

    ``QMAT`` (9, 16), ``QOFF`` (16,): for a rotation R (row-major, 9), ``R @ QMAT + QOFF``
    is the 4×4 matrix ``4 q qᵀ`` written with R's entries (Shepperd):
    ``4x² = 1 + R00 − R11 − R22``, ``4xw = R21 − R12``, ... Row k is ``4 q_k q``; the
    row with the largest diagonal entry (``q_k² ≥ 1/4``) normalised is q.
    ``QPROD`` (16, 4): ``(a ⊗ b).reshape(16) @ QPROD = a ⊗ b*`` (Hamilton product with
    the conjugate): vector ``w_b v_a − w_a v_b − v_a × v_b``, scalar ``w_a w_b + v_a·v_b``.
    """
    # rows x, y, z, w; columns x, y, z, w; each entry a sum of ±R[r, c] (and ±1)
    terms = {(0, 0): ([(0, 0, 1), (1, 1, -1), (2, 2, -1)], 1.0),
             (1, 1): ([(0, 0, -1), (1, 1, 1), (2, 2, -1)], 1.0),
             (2, 2): ([(0, 0, -1), (1, 1, -1), (2, 2, 1)], 1.0),
             (3, 3): ([(0, 0, 1), (1, 1, 1), (2, 2, 1)], 1.0),
             (0, 1): ([(0, 1, 1), (1, 0, 1)], 0.0), (0, 2): ([(0, 2, 1), (2, 0, 1)], 0.0),
             (1, 2): ([(1, 2, 1), (2, 1, 1)], 0.0), (0, 3): ([(2, 1, 1), (1, 2, -1)], 0.0),
             (1, 3): ([(0, 2, 1), (2, 0, -1)], 0.0), (2, 3): ([(1, 0, 1), (0, 1, -1)], 0.0)}
    qmat, qoff = np.zeros((9, 4, 4)), np.zeros((4, 4))
    for (a, b), (entries, const) in terms.items():
        for r, c, sign in entries:
            qmat[3 * r + c, a, b] = qmat[3 * r + c, b, a] = sign
        qoff[a, b] = qoff[b, a] = const
    qprod = np.zeros((4, 4, 4))
    for a in range(4):
        for b in range(4):
            ea, eb = np.eye(4)[a], np.eye(4)[b]
            qprod[a, b, :3] = eb[3] * ea[:3] - ea[3] * eb[:3] - np.cross(ea[:3], eb[:3])
            qprod[a, b, 3] = ea[3] * eb[3] + ea[:3] @ eb[:3]
    return qmat.reshape(9, 16), qoff.reshape(16), qprod.reshape(16, 4)


_QMAT, _QOFF, _QPROD = _quaternion_tables()
#: (4, 16): ``q_a @ _QLEFT`` is the 4×4 matrix ``[c, b]`` with ``(q_a ⊗ q_b*)[c] = Σ_b
#: [c, b] q_b[b]``.
_QLEFT = np.ascontiguousarray(_QPROD.reshape(4, 4, 4).transpose(0, 2, 1)).reshape(4, 16)


def _quaternions(R: np.ndarray, err: np.ndarray | None = None,
                 emax: float | None = None) -> np.ndarray:
    """(..., 3, 3) → quaternions (..., 4), scalar last (scipy's convention), NOT unit.

    ``K = R @ _QMAT + _QOFF`` is ``4 q qᵀ`` for a rotation; Shepperd's quaternion (as in
    scipy, without creating Rotation objects, whose overhead dominates for nine views) is
    its row with the largest diagonal entry, ``4 q_k q``. It is returned unnormalised
    (norm 2 to 4): :func:`_pair_logs` depends on direction only.

    A matrix that is not orthogonal to round-off (its ``err`` = max |RᵀR − I| ≥ 1e-14;
    ``err`` (...) per matrix, from the validation, or measured here) stands for its
    nearest rotation, the polar factor, whose quaternion is the dominant eigenvector of
    the same K (Bar-Itzhack 2000, "New method for extracting the quaternion from a
    rotation matrix"): its other eigenvalues are at most 0.62·err times the largest
    (measured over 12,000 random matrices with err up to 1/3), so ``K^p e_k`` with
    ``err^p < 1e-17 / 4`` is at round-off from that eigenvector (p ≤ 64, entries below
    4^64: no overflow). Each matrix takes its own p − 1 products with a vector from
    Shepperd's row e_k, whatever the other matrices are: every quaternion depends on its
    own matrix alone (so the batched solve's results do not depend on the batch).
    ``emax``: the largest err if known.
    Matrices with err ≥ 1/3 (only possible with ``check_rigid=False``) are first
    projected by scipy's SVD.
    """
    m = R.size // 9
    flat = R.reshape(m, 3, 3)
    if err is None:
        err = (_max(np.abs(_gram(flat) - _EYE3).reshape(m, 9), axis=1) if m
               else np.zeros(0))
    err = np.reshape(err, m)
    if emax is None:
        emax = float(_max(err)) if m else 0.0
    if not emax < 1.0 / 3.0:
        far = ~(err < 1.0 / 3.0)
        flat = flat.copy()
        flat[far] = Rotation.from_matrix(flat[far]).as_matrix()
        err = np.where(far, 0.0, err)
        emax = float(_max(err))
    # one (n × 9)(9 × 16) product per leading index (a single (m × 9) product would let
    # BLAS choose its kernels by m, i.e. by the batch size)
    lead = R.shape[0] if R.ndim > 3 else 1
    K4 = (flat.reshape(lead, m // lead, 9) @ _QMAT).reshape(m, 16)
    K4 += _QOFF                                                  # (m, 16): 4 q qᵀ
    k = K4[:, ::5].argmax(axis=1)                                # the diagonal 4 q_k²
    k += _row_offsets(m)
    v = K4.reshape(4 * m, 4)[k]                                  # 4 q_k q, |q_k| ≥ 1/2
    if emax >= 1e-14:
        # K^p e_k with p = ⌈log(4e17) / −log err⌉ per matrix (none for rigid ones)
        bad = np.flatnonzero(err >= 1e-14)
        steps = (np.ceil(math.log(4e17) / -np.log(err[bad])) - 1.0).astype(np.intp)
        order = np.argsort(-steps, kind="stable")             # most steps first: then
        bad, steps = bad[order], steps[order]                 # each step is on a prefix
        K, u = K4.reshape(m, 4, 4)[bad], v[bad]
        ascending = steps[::-1]
        for step in range(int(steps[0])):
            c = len(steps) - int(np.searchsorted(ascending, step, side="right"))
            u[:c] = np.einsum("mij,mj->mi", K[:c], u[:c])     # matrices with steps > step
        v[bad] = u
    return v.reshape(R.shape[:-2] + (4,))


def _pair_logs(q: np.ndarray, i: np.ndarray, j: np.ndarray,
               take: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``log(R_i R_jᵀ)`` from quaternions q (..., n, 4) for index arrays i, j (K,).

    Returns the rotation vectors, components first (..., 3, K), and their angles
    (..., K). Through ``q_i ⊗ q_j*`` and ``2 atan2(|v|, w) v/|v|`` with ``w ≥ 0``:
    accurate at angle 0 (no division by sin) and at π (no division by cos), and the
    same for any positive multiple of ``q_i ⊗ q_j*`` (q need not be unit). The
    products for all n² pairs are one (4n × 4) by (4 × n) product per sample (row
    (a, c) holds the left-multiplication matrix of q_a, conjugate folded in), from which
    the K pairs are taken.
    """
    lead, n = q.shape[:-2], q.shape[-2]
    L = (q @ _QLEFT).reshape(lead + (4 * n, 4))                  # [(a, c), b]
    P = np.matmul(L, _swap(q), out=_scratch(0, lead + (4 * n, n)))
    P = P.reshape(lead + (4 * n * n,))                           # c of q_a ⊗ q_b* at (a, c, b)
    P = P.take(_pair_take(n, i, j) if take is None else take, axis=-1)   # (..., 4, K)
    v, w = P[..., :3, :], P[..., 3, :]
    s2 = _sum(v * v, axis=-2)
    s = np.sqrt(s2)
    angle = np.arctan2(s, np.abs(w))
    angle *= 2.0
    # q and −q are one rotation: w ≥ 0 (angle ≤ π), i.e. the sign of w goes to the result.
    # s = 0 only with v = 0 (angle 0): any finite scale gives the exact 0.
    v *= np.copysign(angle / np.maximum(s, 1e-300), w)[..., None, :]
    return v, angle


def _pair_take(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Flat indices (4, K) of component c of pair (i_k, j_k) in :func:`_pair_logs`' P."""
    return (i * (4 * n) + j)[None, :] + (n * np.arange(4))[:, None]


def pair_rotvecs(R: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``log(R_i R_jᵀ)`` for index arrays i, j (K,): rotations (..., n, 3, 3) → (..., K, 3).

    Equal to :func:`rasc.geometry.transforms.rotvec_from_matrix` of ``R_i R_jᵀ`` for rotations
    (the angle in [0, π]); non-orthogonal input is first replaced by its nearest
    rotation, view by view.
    """
    q = _quaternions(np.asarray(R, dtype=float))
    return _swap(_pair_logs(q, np.asarray(i), np.asarray(j))[0])


class _Pairs(NamedTuple):
    """A method's pair set for n views (cached by :func:`_pairs`; arrays read-only)."""

    i: np.ndarray          # (K,) unordered pairs (i, j), i > j
    j: np.ndarray
    use_ij: np.ndarray     # (K,) bool: the method uses the ordered pair (i, j)
    use_ji: np.ndarray     # (K,) bool: ... and (j, i)
    ij: np.ndarray         # (K,) flat index i·n + j of (i, j) in an n×n matrix
    ji: np.ndarray
    used: np.ndarray       # (K,) use_ij | use_ji
    take: np.ndarray       # (4, K) for :func:`_pair_logs`
    n_pairs: int           # ordered pairs the method uses
    W_all: np.ndarray      # (1, n, n) the weights when every used pair rotates enough
    wk_all: np.ndarray     # (1, K) w_ij + w_ji then


@functools.lru_cache(maxsize=64)
def _pairs(n: int, pairs: str, home: int | None) -> _Pairs:
    """The unordered pairs (i, j), i > j, and which ordered pairs the method uses."""
    if home is None and pairs not in PAIRS:
        raise InputError(f"pairs: expected one of {PAIRS}, got {pairs!r}")
    i, j = np.tril_indices(n, -1)
    if home is not None:                       # Li: each view k against home, A_k,home
        use_ij, use_ji = j == home, i == home
    else:
        use_ij = np.ones(i.shape, dtype=bool)
        use_ji = use_ij if pairs == "all" else np.zeros(i.shape, dtype=bool)
    W_all = np.zeros((1, n * n))
    W_all[:, i * n + j] = use_ij
    W_all[:, j * n + i] = use_ji
    arrays = (i, j, use_ij, use_ji, i * n + j, j * n + i, use_ij | use_ji, _pair_take(n, i, j))
    for a in (*arrays, W_all):
        a.flags.writeable = False
    return _Pairs(*arrays, n_pairs=int(use_ij.sum() + use_ji.sum()),
                  W_all=W_all.reshape(1, n, n), wk_all=_read_only((use_ij + use_ji * 1.0)[None]))


# ------------------------------------------------------------------- the analysis

def _weights(theta: np.ndarray, pair: _Pairs, n: int,
             min_rotation_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Pair weights ∈ {0, 1}: used by the method and unit rotation ``theta`` large enough.

    theta (Su, K) is the unit's rotation angle for the pairs (i, j), i > j. Returns the
    ordered weights W (Su, n, n) and, per unordered pair, ``w_ij + w_ji`` (Su, K).
    """
    if _min(theta, None) >= min_rotation_rad:    # the usual case: the method's pair set
        Su = theta.shape[0]
        if Su == 1:
            return pair.W_all, pair.wk_all
        return (np.broadcast_to(pair.W_all, (Su, n, n)),
                np.broadcast_to(pair.wk_all, theta.shape))
    ok = theta >= min_rotation_rad
    w_ij, w_ji = ok & pair.use_ij, ok & pair.use_ji
    W = np.zeros((theta.shape[0], n * n))
    W[:, pair.ij] = w_ij
    W[:, pair.ji] = w_ji
    return W.reshape(-1, n, n), w_ij + w_ji.astype(float)


def _pair_translations(R: np.ndarray, Rs: np.ndarray, t: np.ndarray,
                       out: np.ndarray | None = None) -> np.ndarray:
    """``t_A = t_a − R_a R_bᵀ t_b`` for every ordered pair (a, b): (S, 3, n, n) [i, a, b].

    R (S, n, 3, 3), Rs = :func:`_stacked` (R), t (S, n, 3); ``R_a (R_bᵀ t_b)`` for all
    pairs is one (3n × 3) by (3 × n) product. ``out``: (S, 3n, n) to hold the result.
    """
    S, n = t.shape[:2]
    r = (_swap(R) @ t[..., None])[..., 0]                          # R_bᵀ t_b  (S, n, 3)
    tA = np.matmul(Rs, _swap(r), out=out).reshape(S, 3, n, n)
    return np.subtract(_swap(t)[..., None], tA, out=tA)


class _Camera(NamedTuple):
    """One block of samples' camera side: R (S, n, 3, 3), Rs = :func:`_stacked` (R),
    tA (S, 3, n, n) from :func:`_pair_translations`, CtC (S, 3, 3)."""

    R: np.ndarray
    Rs: np.ndarray
    tA: np.ndarray
    CtC: np.ndarray


def _camera(T: np.ndarray, G: np.ndarray | None, W: np.ndarray, exact: np.ndarray | bool,
            Rs: np.ndarray | None = None, tA: np.ndarray | None = None) -> _Camera:
    """The camera side of eq. 7 for T (S, n, 4, 4), with G = RᵀR per view if known.

    ``CᵀC = Σ w_ab (I − R_A)ᵀ (I − R_A) = Σw I − Σ w R_A − (Σ w R_A)ᵀ + Σ w R_AᵀR_A`` with
    ``R_A = R_a R_bᵀ``, ``Σ w R_A = Σ_a R_a (Σ_b w_ab R_b)ᵀ`` and ``Σ w R_AᵀR_A =
    Σ_b R_b (Σ_a w_ab G_a) R_bᵀ`` (R_AᵀR_A is not taken to be I: literal eq. 13 noise is
    not orthogonal). W (Su, n, n) are the ordered pair weights ``w_ab``. ``exact`` (S,)
    bool (or True for all): every R of the sample is orthogonal to round-off
    (max |RᵀR − I| < 1e-14), so ``Σ w R_AᵀR_A = Σw I``.
    Rs = :func:`_stacked` (R) and tA = :func:`_pair_translations` if already known.
    """
    R = T[..., :3, :3]
    S, n = R.shape[:2]
    Rs = _stacked(R) if Rs is None else Rs
    Rs3 = Rs.reshape(S, 3, 3 * n)                                 # [i, (a, k)]
    V = _left_matmul(W, Rs.reshape(S * 3, n, 3)).reshape(S, 3, n, 3)   # Σ_b w_ab R_b
    sum_RA = Rs3 @ _swap(V.reshape(S, 3, 3 * n))
    w_sum = _sum(W.reshape(-1, n * n), axis=1)[:, None, None]
    if exact is True or exact.all():
        CtC = (2.0 * w_sum) * _EYE3 - sum_RA - _swap(sum_RA)
    else:
        G = _gram(R) if G is None else G
        H = _left_matmul(_swap(W), G.reshape(S, n, 9)).reshape(S, n, 3, 3)   # Σ_a w_ab G_a
        sum_RAtRA = _stacked(R @ H).reshape(S, 3, 3 * n) @ _swap(Rs3)
        CtC = w_sum * _EYE3 - sum_RA - _swap(sum_RA) + sum_RAtRA
        if exact.any():                 # each sample by its own rule, whatever the batch
            CtC[exact] = ((2.0 * w_sum) * _EYE3 - sum_RA - _swap(sum_RA))[exact]
    tA = _pair_translations(R, Rs, T[..., :3, 3]) if tA is None else tA
    return _Camera(R, Rs, tA, CtC)


def _left_matmul(W: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``W @ X`` for W (Su, n, n) and X (m, n, k) with m a multiple of Su: W's sample s
    times X's blocks s·m/Su ... (s+1)·m/Su − 1, one (n × n)(n × k) product per block.
    (Not one (n × n)(n × m·k) product for a shared W: BLAS's summation order there
    depends on m, i.e. on the batch size; measured.)"""
    m, n, k = X.shape
    Su = W.shape[0]
    return (W[:, None] @ X.reshape(Su, m // Su, n, k)).reshape(m, n, k)


def _Ctd(W: np.ndarray, cam: _Camera, tB: np.ndarray, RX: np.ndarray) -> np.ndarray:
    """Eq. 7's ``Cᵀd = Σ w_ab (I − R_A)ᵀ d_ab`` (S, 3), ``d_ab = t_A − R_X t_B``.

    ``= Σ w_ab d_ab − Σ_b R_b f_b`` with ``f_b = Σ_a R_aᵀ w_ab d_ab``: with d stacked as
    [(i, a), b], ``f`` for all b is one (3 × 3n)(3n × n) product with Rs; tB (S or Su,
    3, n, n) as tA.
    """
    Rs = cam.Rs
    S, n3 = Rs.shape[:2]
    n = n3 // 3
    # the n²-sized temporaries go to scratch buffers (see _scratch)
    d = np.matmul(RX, tB.reshape(-1, 3, n * n), out=_scratch(0, (S, 3, n * n)))
    d = np.subtract(cam.tA.reshape(S, 3, n * n), d, out=d)       # d_ab at [i, (a, b)]
    d *= W.reshape(-1, 1, n * n)                                  # w_ab d_ab
    f_t = _swap(d.reshape(S, n3, n)) @ Rs                         # [b, k] = f_b[k]
    return _sum(d, axis=2) - (Rs.reshape(S, 3, n3) @ f_t.reshape(S, n3, 1))[..., 0]


def _quality(Rs: np.ndarray, Qs: np.ndarray, RX: np.ndarray) -> np.ndarray:
    """Eq. 10 from Rs, Qs = :func:`_stacked` (R), (Q): see :func:`quality_eq10`."""
    S = Rs.shape[0]
    n = Rs.shape[1] // 3
    Ys = (RX @ Qs.reshape(-1, 3, 3 * n)).reshape(S, 3 * n, 3)   # Y_a = R_X Q_a, stacked
    Z = np.concatenate([Ys, Rs], axis=-1)                         # (S, 3n, 6)
    E = np.matmul(Z, _swap(Z * _SIGNS), out=_scratch(1, (S, 3 * n, 3 * n)))   # Y Yᵀ − R Rᵀ
    E *= E
    # ‖block (a, b)‖² by explicit additions ((e0 + e1) + e2), faster than a reduction
    # over these short axes
    E = E.reshape(S, 3, n, 3, n)
    E1 = np.add(E[:, 0], E[:, 1], out=_scratch(2, (S, n, 3, n)))
    E1 += E[:, 2]
    fro = np.add(E1[:, :, 0], E1[:, :, 1])
    fro += E1[:, :, 2]
    np.sqrt(fro, out=fro)
    fro = fro.reshape(S, n * n)
    fro[:, :: n + 1] = 0.0                                        # i ≠ j only
    # a reduction per sample (not a matrix-vector product, whose summation order BLAS
    # may choose by the number of samples): the same bits in any batch
    return _sum(fro, axis=1) / (n * (n - 1))


_SIGNS = np.array([1.0, 1.0, 1.0, -1.0, -1.0, -1.0])


def quality_eq10(R: np.ndarray, Q: np.ndarray, RX: np.ndarray) -> np.ndarray:
    """Eq. 10: mean over i ≠ j of ‖R_X Q_i Q_jᵀ R_Xᵀ − R_i R_jᵀ‖_F.

    R (S, n, 3, 3) camera rotations ``R_cw`` (literal matrices allowed); Q (S or 1, n,
    3, 3) unit rotations ``R_gp``; RX (S, 3, 3) a rotation → (S,).

    With ``Y_i = R_X Q_i``, every pair's residual ``Y_i Y_jᵀ − R_i R_jᵀ`` is a 3×3 block of
    ``[Y R] [Y −R]ᵀ`` (Y and R stacked to 3n×3): one product for all pairs, each entry a
    six-term dot product of the given matrices, so it is accurate to round-off (1e-16)
    whatever the size of the residual.
    """
    R, Q, RX = (np.asarray(a, dtype=float) for a in (R, Q, RX))
    return _quality(_stacked(R), _stacked(Q), RX)


def _polar_rotation(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 9: R_X = (MᵀM)^(-1/2) Mᵀ as the polar factor V Uᵀ (det forced to +1).

    M (S, 3, 3) → R_X (S, 3, 3) and the singular values of M (S, 3)."""
    U, sv, Vt = _svd(M)
    RX = _swap(U @ Vt)                                            # V Uᵀ
    if len(M) == 1:                     # one sample: the sign of det by hand is cheaper
        (a, b, c), (d, e, f), (g, h, k) = RX[0].tolist()
        flip = [a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g) < 0]
        any_flip = flip[0]
    else:
        flip = _det(RX) < 0
        any_flip = flip.any()
    if any_flip:                                                  # V diag(1, 1, −1) Uᵀ
        Vt = Vt.copy()
        Vt[flip, 2] *= -1.0
        RX = _swap(U @ Vt)
    return RX, sv


#: A relative rotation within this of π (radians) is a half turn: the sign of its log is
#: not determined by the rotation (log R and −log R are both valid).
_HALF_TURN_TOL = 1e-6


def _align_half_turns(alpha: np.ndarray, theta_A: np.ndarray, beta: np.ndarray,
                      theta_B: np.ndarray, bw: np.ndarray, theta_max: float) -> np.ndarray:
    """Choose the signs of half-turn logs so that ``α = R_X β`` holds for them too.

    alpha (S, 3, K), beta and bw = w β (Su, 3, K), angles (S or Su, K). A pair whose
    motion is a half turn (within ``_HALF_TURN_TOL`` of π) has α and β each defined up to
    sign only; with mismatched signs its term of eq. 9 enters M as ``−β βᵀ R_Xᵀ``. Its α
    is flipped where it points away from ``R_X0 β``, with R_X0 from the other pairs (all
    pairs if fewer than two others are usable). Without half turns (``theta_max``, the
    largest of all angles, below π − ``_HALF_TURN_TOL``) α is returned as is.
    """
    if theta_max <= np.pi - _HALF_TURN_TOL:
        return alpha
    near = (theta_A > np.pi - _HALF_TURN_TOL) | (theta_B > np.pi - _HALF_TURN_TOL)
    others = bw * ~near[:, None, :]
    enough = ((others != 0).any(axis=1).sum(axis=1) >= 2)[:, None, None]
    RX0, _ = _polar_rotation(np.where(enough, others, bw) @ _swap(alpha))
    flip = near & ((alpha * (RX0 @ beta)).sum(axis=1) < 0)
    return np.where(flip[:, None, :], -alpha, alpha)


def _solve(T_cw: np.ndarray, T_gp: np.ndarray, T_all: np.ndarray | None, pair: _Pairs,
           min_rotation_rad: float, checked: tuple = (None, None, None),
           diagnostics: bool = True) -> dict:
    """Core, batched: T_cw (S, n, 4, 4), T_gp (Sq, n, 4, 4), Sq ∈ {1, S}, T_all their
    concatenation (or None), pairs from :func:`_pairs`, ``checked`` = (G, err) of T_all
    from the validation (or Nones).

    Blocks of up to ``_CHUNK_FLOATS`` numbers go through :func:`_solve_block` in turn
    (a single solve is one block of one sample). Every step of a block treats each
    sample on its own — its own decisions (orthogonal to round-off or not, how many
    power steps, half turns), per-sample LAPACK calls, products and reductions whose
    summation order does not depend on how many samples there are — so a sample's
    result has the same bits whatever batch it is solved in, alone or with others
    (tests/handeye/test_solver_batch.py). A degenerate sample raises (naming it); the first
    block that holds one raises first.
    """
    S, n = T_cw.shape[:2]
    Sq = T_gp.shape[0]
    chunk = max(1, _CHUNK_FLOATS // (9 * n * n))
    if chunk >= S:
        if T_all is None:
            T_all = np.concatenate([T_cw, T_gp])
        return _solve_block(T_all, *checked, S, pair, min_rotation_rad, S, 0, diagnostics)
    parts = []
    for c0 in range(0, S, chunk):
        c = slice(c0, c0 + chunk)
        T_block = np.concatenate([T_cw[c], T_gp[c] if Sq > 1 else T_gp])
        parts.append(_solve_block(T_block, None, None, None, len(T_cw[c]), pair,
                                  min_rotation_rad, S, c0, diagnostics))
    per_sample = _PER_SAMPLE + (_PER_UNIT if Sq > 1 else ())
    return {k: (np.concatenate([p[k] for p in parts])
                if k in per_sample and parts[0][k] is not None else parts[0][k])
            for k in parts[0]}


#: The keys of :func:`_solve_block`'s result that hold one entry per sample, and those
#: that hold one per unit pose set (one in all, or one per sample).
_PER_SAMPLE = ("RX", "tX", "quality", "sv", "cond_CtC")
_PER_UNIT = ("W", "wk", "theta", "axis_spread", "dominant_axis")


def _solve_block(T_all: np.ndarray, G_all: np.ndarray | None, err: np.ndarray | None,
                 emax: float | None, S: int, pair: _Pairs, min_rotation_rad: float,
                 S_total: int, offset: int, diagnostics: bool = True) -> dict:
    """One block: T_all (S + Sq, n, 4, 4) = S camera pose sets then Sq ∈ {1, S} unit
    pose sets; G_all = RᵀR (S + Sq, n, 3, 3), err (S + Sq, n) = max |RᵀR − I| per view
    and emax its largest, if known. Samples are named ``offset + s`` of ``S_total`` in
    errors. Without ``diagnostics`` (the batched result, which has none) cond(CᵀC) is
    bounded without eigenvalues where it can be (:func:`_cond_CtC_surely_ok`); the
    solution is the same either way (t_X by one LU solve per sample).

    Logs are taken once per unordered pair (i > j): ``α_ji = −α_ij`` and
    ``β_ji = −β_ij``, so ``β_ji α_jiᵀ = β_ij α_ijᵀ`` and pair (j, i) adds the same term
    to M; its weight is added to that of (i, j). Both sides share each call: one
    quaternion pass, one pass of pair translations, one eigen-decomposition (of
    ``Σ w β βᵀ`` for the axis check and of CᵀC for its condition). The unit's axis check
    comes before the camera's condition check.
    """
    n = T_all.shape[1]
    Sq = T_all.shape[0] - S
    R_all = T_all[..., :3, :3]
    if G_all is None:
        G_all = _gram(R_all)
        err = _max(np.abs(G_all - _EYE3).reshape(-1, n, 9), axis=2)
        emax = float(_max(err, None))
    logs, angle = _pair_logs(_quaternions(R_all, err, emax), pair.i, pair.j, pair.take)
    alpha, beta, theta, theta_cam = logs[:S], logs[S:], angle[S:], angle[:S]
    W, wk = _weights(theta, pair, n, min_rotation_rad)
    bw = beta * wk[:, None, :]                                    # (Sq, 3, K)
    G_unit = bw @ _swap(beta)                                     # Σ w β βᵀ
    Rs_all = _stacked(R_all)
    t_all = _pair_translations(R_all, Rs_all, T_all[..., :3, 3],          # lives to the end
                               _scratch(4, (S + Sq, 3 * n, n)))
    Qs, tB = Rs_all[S:], t_all[S:]
    # (S,) the samples orthogonal to round-off (all of them: True)
    exact = True if emax < 1e-14 else _max(err[:S], axis=1) < 1e-14
    cam = _camera(T_all[:S], G_all[:S], W, exact, Rs_all[:S], t_all[:S])
    if diagnostics:
        lam, vec = _eigh(np.concatenate([G_unit, cam.CtC]))
        eig_unit = lam[:Sq], vec[:Sq]
    else:
        eig_unit = _eigh(G_unit)
    spread, axis = _check_rotation_axes(eig_unit, wk, min_rotation_rad, S_total, offset,
                                        wk is pair.wk_all)
    if diagnostics:
        cond = _check_cond_CtC((lam[Sq:], vec[Sq:]), S_total, offset)
    else:
        cond = None
        if not _cond_CtC_surely_ok(cam.CtC):     # some sample may be ill-conditioned
            lam = np.linalg.eigvalsh(cam.CtC)
            if not (lam[:, 2] <= MAX_COND_CTC * lam[:, 0]).all():   # name the weak axis
                _check_cond_CtC(_eigh(cam.CtC), S_total, offset)
    a = _align_half_turns(alpha, theta_cam, beta, theta, bw, _max(angle, None))
    RX, sv = _polar_rotation(bw @ _swap(a))                       # eq. 9: M = Σ w β αᵀ
    tX = _solve_spd(cam.CtC, _Ctd(W, cam, tB, RX))                # t_X = (CᵀC)⁻¹ Cᵀd
    return {"RX": RX, "tX": tX, "quality": _quality(cam.Rs, Qs, RX), "W": W, "wk": wk,
            "theta": theta, "sv": sv, "cond_CtC": cond, "axis_spread": spread,
            "dominant_axis": axis}


def _diagnostics(out: dict, n: int, pair: _Pairs, s: int = 0) -> HandEyeDiagnostics:
    """Sample ``s``'s diagnostics from :func:`_solve`'s result (or, deferred, from the
    same quantities of :func:`_solve_one`)."""
    u = s if len(out["theta"]) > 1 else 0                        # the sample's unit
    s1, _, s3 = out["sv"][s].tolist()
    theta = out["theta"][u]
    if pair.n_pairs != 2 * len(theta):
        theta = theta[pair.used]
    deg = 180.0 / math.pi
    return HandEyeDiagnostics(
        n_positions=n, n_pairs=pair.n_pairs,
        n_pairs_used=pair.n_pairs if out["wk"] is pair.wk_all else int(_sum(out["wk"][u])),
        cond_MtM=(s1 / s3) ** 2 if s3 > 0 else math.inf, cond_CtC=float(out["cond_CtC"][s]),
        min_rotation_deg=float(_min(theta, None)) * deg,
        max_rotation_deg=float(_max(theta, None)) * deg,
        axis_spread=float(out["axis_spread"][u]),
        dominant_axis=_unit_axis(out["dominant_axis"][u]))


def _result(out: dict, n: int, pair: _Pairs, s: int = 0) -> HandEyeResult:
    """Sample ``s`` of :func:`_solve`'s result as a :class:`HandEyeResult`."""
    T = np.zeros((4, 4))
    T[:3, :3] = out["RX"][s]
    T[:3, 3] = out["tX"][s]
    T[3, 3] = 1.0
    return HandEyeResult(T_cam_from_gaze=T, quality=float(out["quality"][s]), method="rasc",
                         diagnostics=_diagnostics(out, n, pair, s))


# ------------------------------------------------------------- the one-solve path

#: :func:`_solve_one` takes data as rigid to round-off when max |RᵀR − I| computed by
#: BLAS is below this. The general path decides by the same quantity computed
#: elementwise (:func:`_gram`), below 1e-14. Each entry is a sum of three products of
#: numbers ≤ 1, within about 5e-16 of its exact value by either computation (three
#: roundings of products, two of sums, of at most 1.1e-16 each), so the two differ by at
#: most about 1e-15: below 5e-15 both certainly decide "rigid to round-off", and near
#: 1e-14 the general path decides alone.
_ONE_EXACT = 5e-15
#: :func:`_solve_one` serves up to this many views: there the count of numpy calls is
#: what costs. Beyond, the general path, whose large temporaries live in scratch
#: buffers, is as fast, and data with pairs left out (repeated poses) are common.
_ONE_MAX_VIEWS = 32


def _solve_one(A: np.ndarray, B: np.ndarray, pair: _Pairs,
               min_rotation_rad: float) -> HandEyeResult | None:
    """One solve in the common case, in fewer numpy calls: the same numbers, to the bit,
    as :func:`_solve` on a batch of one (tests/handeye/test_solver_paths.py).

    A = T_cam_from_world, B = T_gaze_from_ptu, float64 ndarrays (n, 4, 4), n ≤
    ``_ONE_MAX_VIEWS``. The common case: finite, last rows exactly ``0 0 0 1``, every
    rotation proper and orthogonal to round-off (``_ONE_EXACT``); every pair of the
    method rotating at least ``min_rotation_rad`` (all weights 1), no half turn, axis
    spread and cond(CᵀC) within bounds, det M > 0. Each operation below is the one
    :func:`_solve_block` runs for a batch of one on such data, on the same operands in
    the same shapes and layouts (products go to BLAS with the same sizes, reductions run
    along the same axes), so every float is the same. Left out is what such data do not
    need: per-view rigidity errors, the power steps and the non-rigid CᵀC, weights, half
    turns, blocks and bookkeeping. Returns None when the data are not the common case:
    the general path then decides, and raises where it must.
    """
    n = A.shape[0]
    T_all = np.empty((2, n, 4, 4))
    T_all[0] = A
    T_all[1] = B
    R_all = T_all[..., :3, :3]
    if not (math.isfinite(_sum(T_all, None))                   # no NaN, no infinity
            and T_all[..., 3, :].tobytes() == _LAST_ROW_BYTES * (2 * n)   # −0.0: declined
            and _max(np.abs(_swap(R_all) @ R_all - _EYE3), None) < _ONE_EXACT
            and _min(_det_closed_form(R_all), None) > 0):      # rigid: det = ±1, its sign
        return None
    # quaternions (_quaternions: Shepperd's row, no power steps)
    K4 = (R_all.reshape(2, n, 9) @ _QMAT).reshape(2 * n, 16)
    K4 += _QOFF
    k = K4[:, ::5].argmax(axis=1)
    k += _row_offsets(2 * n)
    q = K4.reshape(8 * n, 4)[k].reshape(2, n, 4)
    # pair logs, camera (row 0) and unit (row 1) (_pair_logs)
    P = np.matmul((q @ _QLEFT).reshape(2, 4 * n, 4), _swap(q))
    P = P.reshape(2, 4 * n * n).take(pair.take, axis=-1)          # (2, 4, K)
    v, w = P[:, :3, :], P[:, 3, :]
    s = np.sqrt(_sum(v * v, axis=-2))
    angle = np.arctan2(s, np.abs(w))
    angle *= 2.0
    theta_min = float(_min(angle[1]))
    cam_max, theta_max = _max(angle, axis=1).tolist()
    if not (theta_min >= min_rotation_rad and cam_max <= np.pi - _HALF_TURN_TOL
            and theta_max <= np.pi - _HALF_TURN_TOL):             # _weights, half turns
        return None
    v *= np.copysign(angle / np.maximum(s, 1e-300), w)[:, None, :]
    alpha, beta = v[:1], v[1:]
    W = pair.W_all
    bw = beta * pair.wk_all[:, None, :]
    # eq. 7's camera side (_pair_translations; _camera for rotations exact to round-off)
    Rs_all = _stacked(R_all)
    t = T_all[..., :3, 3]
    tA = np.matmul(Rs_all, _swap((_swap(R_all) @ t[..., None])[..., 0])).reshape(2, 3, n, n)
    np.subtract(_swap(t)[..., None], tA, out=tA)
    Rs = Rs_all[:1]
    V = (W[:, None] @ Rs.reshape(1, 3, n, 3)).reshape(1, 3, 3 * n)
    sum_RA = Rs.reshape(1, 3, 3 * n) @ _swap(V)
    GC = np.empty((2, 3, 3))                                       # [Σ w β βᵀ, CᵀC]
    np.matmul(bw, _swap(beta), out=GC[:1])
    CtC = np.subtract((2.0 * pair.n_pairs) * _EYE3, sum_RA, out=GC[1:])   # Σw = n_pairs
    CtC -= _swap(sum_RA)
    # one eigen-decomposition for the axis spread and cond(CᵀC) (_check_rotation_axes,
    # _check_cond_CtC); NaN fails the comparisons (the general path then raises)
    lam, vec = _eigh(GC)
    (l0u, l1, l2), (l0, l1c, l2c) = lam.tolist()
    cond = l2c / l0 if l0 > 0 else math.inf
    if not (l1 / l2 >= MIN_AXIS_SPREAD and cond <= MAX_COND_CTC
            and math.isfinite(l0u + l1 + l2 + l0 + l1c + l2c)):
        return None
    # eq. 9 (_polar_rotation)
    U, sv, Vt = _svd(bw @ _swap(alpha))
    s1, s2, s3 = sv[0].tolist()
    RX = _swap(U @ Vt)
    (a, b, c), (d, e, f), (g, h, i) = rows = RX[0].tolist()
    if not (a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) >= 0
            and math.isfinite(s1 + s2 + s3)):
        return None
    # eq. 7 (_Ctd, _solve_spd); eq. 10 (_quality) when the result's quality is first read
    t0, t1, t2 = _solve_spd(CtC, _Ctd(W, _Camera(None, Rs, tA[:1], CtC), tA[1:], RX))[0].tolist()
    if not math.isfinite(t0 + t1 + t2):
        return None
    return HandEyeResult(
        T_cam_from_gaze=np.array([rows[0] + [t0], rows[1] + [t1], rows[2] + [t2],
                                  [0.0, 0.0, 0.0, 1.0]]),
        quality=_Deferred(_quality_one, Rs, Rs_all[1:], RX), method="rasc",
        diagnostics=_Deferred(_diagnostics_one, n, pair, angle, sv, cond, l1 / l2, vec))


def _quality_one(Rs: np.ndarray, Qs: np.ndarray, RX: np.ndarray) -> float:
    """Eq. 10 of one solve (:func:`_quality`), deferred by :func:`_solve_one`."""
    return float(_quality(Rs, Qs, RX)[0])


def _diagnostics_one(n: int, pair: _Pairs, angle: np.ndarray, sv: np.ndarray, cond: float,
                     spread: float, vec: np.ndarray) -> HandEyeDiagnostics:
    """:func:`_diagnostics` of :func:`_solve_one`'s quantities (deferred by it: the
    arguments are collected in the solve, the result's fields only when read)."""
    return _diagnostics({"theta": angle[1:], "sv": sv, "wk": pair.wk_all,
                         "cond_CtC": [cond], "axis_spread": [spread],
                         "dominant_axis": vec[:1, :, 2]}, n, pair)


def _one_case(T_cam_from_world: Any, T_gaze_from_ptu: Any, pairs: Any,
              min_rotation_rad: Any) -> bool:
    """The arguments :func:`_solve_one` may take (anything else: the general path, whose
    checks name the problem)."""
    A, B = T_cam_from_world, T_gaze_from_ptu
    return (type(A) is np.ndarray and type(B) is np.ndarray
            and A.dtype == _F64 == B.dtype
            and A.ndim == 3 and A.shape == B.shape and 3 <= A.shape[0] <= _ONE_MAX_VIEWS
            and A.shape[1:] == (4, 4) and type(pairs) is str and pairs in PAIRS
            and (isinstance(min_rotation_rad, float) or type(min_rotation_rad) is int)
            and 0 <= min_rotation_rad < math.inf)


_F64 = np.dtype(np.float64)
_LAST_ROW_BYTES = _LAST_ROW.tobytes()
