"""Gaze-to-camera ("hand-eye") calibration by RASC: docs/METHOD.md §3, paper section 3.2, eq. 6–10.

Solves ``A X = X B`` for ``X = T_cam_from_gaze`` (the paper's ``T_cg``) from the target's
pose ``T_cam_from_world`` (``T_cw``) and the unit's motion ``T_gaze_from_ptu`` (``T_gp``,
eq. 3; for a robot arm the gripper's pose ``T_gripper_from_base``) at n positions. For
every ordered pair i ≠ j::

    A_ij = T_cw^i (T_cw^j)^-1:  R_A = R_cw^i (R_cw^j)^T,  t_A = t_cw^i − R_A t_cw^j
    B_ij = T_gp^i (T_gp^j)^-1   (likewise)

Rotation (eq. 6, 8, 9; Park & Martin): ``α = log R_A``, ``β = log R_B``, ``α = R_X β``;
``M = Σ β αᵀ`` and ``R_X = (MᵀM)^(-1/2) Mᵀ``, computed as the polar factor of ``Mᵀ``
(``M = U Σ Vᵀ`` → ``R_X = V Uᵀ``), which is the same matrix whenever MᵀM is
non-singular, also exists when M has rank 2 (two rotation axes fix a rotation) and is
forced to det +1 (``V diag(1, 1, ±1) Uᵀ``) should noise flip the sign of det M.

Translation (eq. 7 generalised to a unit that also translates): ``(I − R_A) t_X =
t_A − R_X t_B``; least squares ``t_X = (CᵀC)^-1 Cᵀd`` (erratum,
docs/METHOD.md §3: not ^-1/2). CᵀC and
Cᵀd are 3×3 / 3 sums, and because ``R_A = R_i R_jᵀ`` is bilinear in the views every sum
over pairs is a contraction with the n×n pair-weight matrix (O(n²) scalars; no 3K×3
matrix, no loop over pairs).

Quality (eq. 10): the mean over all i ≠ j of ``‖R_X R_B R_Xᵀ − R_A‖_F``; above 1 the
paper found solutions unusable.

Logarithms: ``log(R_i R_jᵀ)`` is taken as ``log(q_i ⊗ q_j*)`` from each view's quaternion
(scipy), with the atan2 form of the quaternion log — robust at angle 0 and π, equal to
:func:`rasc.geometry.transforms.rotvec_from_matrix` of the pair matrix for rotations (tested to
1e-12). Calling that helper on each of the 3828 pairs of 88 views costs 2.2 ms per side
alone, more than the whole solve may take (goal: 20× faster than OpenCV's 28 ms;
measured 1.05 ms against 26 ms, benchmarks/bench_handeye.py). For the same reason no
step builds an n²×9 array: temporaries of ~0.5 MB cost ~250 page faults per call here.

Literal noise. The paper's eq. 13 noise leaves ``R_cw`` slightly non-orthogonal. Such
input is accepted with ``check_rigid=False`` (the default ``True`` rejects anything not
rigid within :data:`rasc.geometry.transforms.RIGID_ATOL`): the rotation step then uses each view's
nearest rotation (polar factor), the translation step and eq. 10 use the matrices as
given (``R_A = R_i R_jᵀ``, ``t_A = t_i − R_A t_j`` exactly as eq. 7 prints them).
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.transforms import RIGID_ATOL, make_transform, validate_rigid_transform

#: A relative unit rotation smaller than this (radians) is "unusable": its axis is not
#: defined to better than the measurement noise (≈1e-3 rad for a good camera
#: calibration), and it adds nothing to eq. 8 or eq. 7. Such pairs are left out of the
#: sums; they are counted in ``n_pairs`` but not in ``n_pairs_used``.
MIN_PAIR_ROTATION_RAD = 1e-3

#: Rotation axes "all parallel": with ``G = Σ β βᵀ`` over the used pairs (eigenvalues
#: λ1 ≥ λ2 ≥ λ3), the axis spread is λ2/λ1: 0 for pan-only or tilt-only data, 1.00 for
#: the paper's nine ±8° poses (measured). Only λ2 matters: two axes fix a rotation, so a
#: small λ3 (2.4e4 = cond(MᵀM) for the nine poses, where the third axis comes only from
#: pan-tilt coupling) is harmless. For the same camera noise the rotation about, and the
#: translation along, the dominant axis are amplified by about 1/√spread relative to
#: well-spread motions. Measured (``tests/test_handeye.py``'s near-pan-only sweep: pan
#: ±8°, tilt ±a, the README example's noise of 0.03° / 0.5 mm, 30 seeds): a = 0.1°, 0.5°,
#: 2°, 8° gives spread 1.6e-4, 3.9e-3, 6.2e-2, 1.0 and median errors 4.9°, 0.94°,
#: 0.25°, 0.13° / 84, 20, 6.0, 2.6 mm. Below ``MIN_AXIS_SPREAD`` the data are rejected
#: (the weak axis carries less than 3 % of the motion: errors ≳ 15× those of
#: well-spread motions, degrees and centimetres at ordinary calibration noise); below
#: ``WEAK_AXIS_SPREAD`` the solution is returned with a warning (≳ 4×).
MIN_AXIS_SPREAD = 1e-3
WEAK_AXIS_SPREAD = 1e-2

#: Translation ill-conditioned: reject when cond(CᵀC) > 1e4, i.e. σ_max/σ_min of C above
#: 100, so 1 mm of error in the camera translations can move t_X by 0.1 m along the weak
#: direction. For small angles CᵀC ≈ tr(G) I − G, so this is the same axis-spread
#: criterion seen from the camera side; the paper's nine poses give 1.99 (measured).
MAX_COND_CTC = 1e4

#: Which ordered pairs enter the sums: "all" i ≠ j (docs/METHOD.md §3, the default) or "half",
#: each unordered pair once as A_ij with i > j, which is the pair set and orientation of
#: OpenCV's calibrateHandEye (its Hg_ij = inv(Hg_j) Hg_i, i < j). For a pure-rotation
#: unit both give the same solution; for a unit that also translates they differ under
#: noise, because the equation of pair (j, i) is not the equation of pair (i, j) once
#: R_A ≠ R_X R_B R_Xᵀ.
PAIRS = ("all", "half")


@dataclass(frozen=True)
class HandEyeDiagnostics:
    """What the data could determine (docs/METHOD.md §3).

    n_positions : number of views n.
    n_pairs : pairs the method's definition uses (``n(n−1)`` ordered pairs for RASC).
    n_pairs_used : those whose unit rotation is at least ``MIN_PAIR_ROTATION_RAD``.
    cond_MtM : cond(MᵀM) = (σ1/σ3)² of eq. 9's M. Large values are harmless while σ2
        is not small (see ``MIN_AXIS_SPREAD``); ``inf`` when M has rank 2.
    cond_CtC : cond(CᵀC) of eq. 7's normal equations.
    min_rotation_deg, max_rotation_deg : smallest and largest rotation angle of the
        unit's motions B_ij among the method's pairs (all i ≠ j for RASC), degrees.
    axis_spread : λ2/λ1 of ``Σ β βᵀ`` over the used pairs (see ``MIN_AXIS_SPREAD``):
        1 for motions well spread over two axes, 0 for motions about one axis.
    dominant_axis : the unit-frame axis the motions turn about most (λ1's eigenvector).
    """

    n_positions: int
    n_pairs: int
    n_pairs_used: int
    cond_MtM: float
    cond_CtC: float
    min_rotation_deg: float
    max_rotation_deg: float
    axis_spread: float
    dominant_axis: tuple[float, float, float]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict; infinite condition numbers become ``None``."""
        return {k: (list(v) if isinstance(v, tuple)
                    else v if not isinstance(v, float) or math.isfinite(v) else None)
                for k, v in asdict(self).items()}


@dataclass(frozen=True)
class HandEyeResult:
    """A hand-eye solution.

    T_cam_from_gaze : (4, 4) the paper's ``T_cg`` (for a robot arm: T_cam_from_gripper).
    quality : eq. 10, mean over i ≠ j of ‖R_X R_B R_Xᵀ − R_A‖_F (never NaN).
    method : "rasc", "li", "opencv-park", ...
    diagnostics : :class:`HandEyeDiagnostics`.
    """

    T_cam_from_gaze: np.ndarray
    quality: float
    method: str
    diagnostics: HandEyeDiagnostics

    def __post_init__(self):
        _freeze(self, "T_cam_from_gaze")

    def to_dict(self) -> dict[str, Any]:
        return {"method": self.method,
                "T_cam_from_gaze": np.asarray(self.T_cam_from_gaze).tolist(),
                "quality": float(self.quality),
                "diagnostics": self.diagnostics.to_dict()}


@dataclass(frozen=True)
class HandEyeUncertainty:
    """The estimated error of a solution (:func:`rasc.handeye.methods.jackknife_uncertainty`).

    rotation_deg : jackknife standard error of the rotation, degrees (None: no estimate).
    translation : the same for the translation, in the input's length unit (or None).
    n_subsets : solves it took (the positions, each left out once).
    reason : why there is no estimate, else None.
    """

    rotation_deg: float | None
    translation: float | None
    n_subsets: int
    reason: str | None

    def to_dict(self) -> dict[str, Any]:
        return {"method": "jackknife over positions (each left out once)",
                "rotation_deg": self.rotation_deg, "translation": self.translation,
                **({"reason": self.reason} if self.reason else {})}


@dataclass(frozen=True)
class HandEyeBatchResult:
    """S solutions at once: ``T_cam_from_gaze`` (S, 4, 4), ``quality`` (S,) (eq. 10)."""

    T_cam_from_gaze: np.ndarray
    quality: np.ndarray

    def __post_init__(self):
        _freeze(self, "T_cam_from_gaze")
        _freeze(self, "quality")


def _freeze(obj: Any, field: str) -> None:
    """Store a read-only float copy of an array field of a frozen dataclass."""
    a = np.array(getattr(obj, field), dtype=float)
    a.flags.writeable = False
    object.__setattr__(obj, field, a)


# --------------------------------------------------------------------------- input

def _index_str(idx: tuple[int, ...]) -> str:
    return ", ".join(str(int(i)) for i in idx)


def validate_poses(T: Any, name: str, *, batch: bool = False,
                   check_rigid: bool = True) -> np.ndarray:
    """Check an array of 4×4 transforms, (n, 4, 4) or with ``batch`` (S, n, 4, 4).

    Always: shape, finite, last row ``0 0 0 1``, rotation block with det > 0. With
    ``check_rigid`` also orthonormal with det +1 within ``RIGID_ATOL``. Raises
    :class:`InputError` naming ``name[index]``.
    """
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not a numeric array of 4x4 transforms") from None
    want = "(S, n, 4, 4)" if batch else "(n, 4, 4)"
    if T.ndim != (4 if batch else 3) or T.shape[-2:] != (4, 4):
        raise InputError(f"{name}: expected shape {want}, got {T.shape}")

    def first(bad: np.ndarray) -> tuple[tuple[int, ...], str]:
        k = tuple(int(x) for x in np.argwhere(bad)[0])
        return k, f"{name}[{_index_str(k)}]"

    # Each check is one reduction; the offending index is looked for only on failure.
    if not np.isfinite(T).all():
        raise InputError(f"{first(~np.isfinite(T).all(axis=(-1, -2)))[1]}: contains NaN "
                         "or infinity")
    last = np.abs(T[..., 3, :] - [0.0, 0.0, 0.0, 1.0])
    if last.size and last.max() > RIGID_ATOL:
        k, where = first(last.max(axis=-1) > RIGID_ATOL)
        raise InputError(f"{where}: last row is {T[k][3].tolist()}, expected [0, 0, 0, 1]")
    R = T[..., :3, :3]
    det = np.linalg.det(R)
    if not (det > 0).all():
        k, where = first(~(det > 0))
        raise InputError(f"{where}: rotation block has determinant {det[k]:.6g}; a pose "
                         "needs a rotation (det +1)")
    if check_rigid:
        err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3))
        if err.size and max(err.max(), np.abs(det - 1.0).max()) > RIGID_ATOL:
            bad = (err.max(axis=(-1, -2)) > RIGID_ATOL) | (np.abs(det - 1.0) > RIGID_ATOL)
            k, where = first(bad)
            try:
                validate_rigid_transform(T[k], name=where)
            except InputError as exc:
                raise InputError(f"{exc} (pass check_rigid=False to accept the paper's "
                                 "literal eq. 13 noise)") from None
    return T


def _check_positions(n: int, n_unit: int) -> None:
    if n != n_unit:
        raise InputError(f"T_cam_from_world has {n} positions but T_gaze_from_ptu has "
                         f"{n_unit}: one unit pose per camera view is needed")
    if n < 3:
        raise DegenerateDataError(
            f"only {n} positions: the hand-eye transform needs at least 3 positions "
            "(2 motions about different axes); add positions that combine pan and tilt")


# ---------------------------------------------------------------------- pair logs

def _nearest_rotations(R: np.ndarray) -> np.ndarray:
    """Polar factor of each (nearly orthogonal) 3×3 in R (N, 3, 3), by Newton–Schulz.

    ``R ← R (3I − RᵀR) / 2`` converges quadratically to the polar factor (the same
    matrix as scipy's Procrustes projection; a rotation, as det R > 0 is validated)
    when every singular value lies in (0, √3); an element-wise ``|RᵀR − I| < 1/3``
    guarantees that (spectral norm < 1). An error of 1e-2 (literal eq. 13 noise at 4σ)
    is at round-off (< 1e-14) after 4 steps; rotations exact to round-off cost one
    product. Anything else (only possible with ``check_rigid=False``) goes through
    scipy's SVD projection.
    """
    eye, P = np.eye(3), R
    for step in range(6):
        G = np.swapaxes(P, -1, -2) @ P
        err = np.abs(G - eye).max()
        if err < 1e-14:
            return P
        if step == 0 and not err < 1.0 / 3.0:
            break
        P = P @ (1.5 * eye - 0.5 * G)
    return Rotation.from_matrix(R).as_matrix()


def _quaternions(R: np.ndarray) -> np.ndarray:
    """(..., 3, 3) → unit quaternions (..., 4), scalar last (scipy's convention)."""
    flat = _nearest_rotations(R.reshape(-1, 3, 3))
    return Rotation.from_matrix(flat, assume_valid=True).as_quat().reshape(R.shape[:-2] + (4,))


def _pair_logs(R: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``log(R_i R_jᵀ)`` for index arrays i, j (K,), components first: (..., 3, K).

    Through quaternions ``q_i ⊗ q_j*`` and ``2 atan2(|v|, w) v/|v|`` with ``w ≥ 0``:
    accurate at angle 0 (no division by sin) and at π (no division by cos).
    """
    q = _quaternions(R)                                          # (..., n, 4) [x y z w]
    lead, n = q.shape[:-2], q.shape[-2]
    x, y, z, w = np.moveaxis(q, -1, 0)
    nx, ny, nz = -x, -y, -z
    # Left-multiplication matrices L(q_a) r = q_a ⊗ r, as [a, c, d]; row c times the
    # conjugates [d, b] gives component c of q_a ⊗ q_b* for all a, b, one row at a time
    # (one n×n temporary, not 4n×n: large temporaries cost page faults).
    L = np.stack([w, nz, y, x, z, w, nx, y, ny, x, w, z, nx, ny, nz, w],
                 axis=-1).reshape(lead + (n, 4, 4))
    conj = np.swapaxes(q * np.array([-1.0, -1.0, -1.0, 1.0]), -1, -2)   # (..., 4, n)
    flat = i * n + j
    p = np.empty(lead + (4, len(flat)))
    for c in range(4):
        p[..., c, :] = np.take((L[..., c, :] @ conj).reshape(lead + (n * n,)), flat, axis=-1)
    v, w = p[..., :3, :], p[..., 3, :]
    s = np.sqrt(np.einsum("...ck,...ck->...k", v, v))
    # q and −q are one rotation: w ≥ 0 (angle ≤ π), i.e. the sign of w goes to the result.
    scale = np.divide(2.0 * np.arctan2(s, np.abs(w)), s, out=np.full_like(s, 2.0), where=s > 0)
    v *= np.copysign(scale, w)[..., None, :]
    return v


def pair_rotvecs(R: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``log(R_i R_jᵀ)`` for index arrays i, j (K,): rotations (..., n, 3, 3) → (..., K, 3).

    Equal to :func:`rasc.geometry.transforms.rotvec_from_matrix` of ``R_i R_jᵀ`` for rotations
    (the angle in [0, π]); non-orthogonal input is first replaced by its nearest
    rotation, view by view.
    """
    return np.swapaxes(_pair_logs(np.asarray(R, dtype=float), np.asarray(i), np.asarray(j)),
                       -1, -2)


@functools.lru_cache(maxsize=64)
def _pairs(n: int, pairs: str, home: int | None) -> tuple[np.ndarray, ...]:
    """Unordered pairs (i, j), i > j, as index arrays and, per pair, whether the method
    uses the ordered pair (i, j) and (j, i): ``(i, j, use_ij, use_ji, ij_flat, ji_flat)``.
    """
    if home is None and pairs not in PAIRS:
        raise InputError(f"pairs: expected one of {PAIRS}, got {pairs!r}")
    i, j = np.tril_indices(n, -1)
    if home is not None:                       # Li: each view k against home, A_k,home
        use_ij, use_ji = j == home, i == home
    else:
        use_ij = np.ones(i.shape, dtype=bool)
        use_ji = use_ij if pairs == "all" else np.zeros(i.shape, dtype=bool)
    out = (i, j, use_ij, use_ji, i * n + j, j * n + i)
    for a in out:
        a.flags.writeable = False
    return out


# ------------------------------------------------------------------- the analysis

def _unit_axis(v: np.ndarray) -> tuple[float, float, float]:
    """An axis as a unit vector, its largest component positive (an eigenvector's sign
    is arbitrary)."""
    v = np.asarray(v, dtype=float) / np.linalg.norm(v)
    v = -v if v[np.argmax(np.abs(v))] < 0 else v
    return tuple(float(x) + 0.0 for x in v)  # + 0.0: no -0.0


def _fmt_axis(v: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.3f}" for x in np.round(_unit_axis(v), 3) + 0.0) + "]"


def _where(S: int, s: int) -> str:
    return f" (sample {s})" if S > 1 else ""


def _weights(theta: np.ndarray, pair: tuple, n: int,
             min_rotation_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Pair weights ∈ {0, 1}: used by the method and unit rotation ``theta`` large enough.

    theta (Su, K) is the unit's rotation angle for the pairs (i, j), i > j. Returns the
    ordered weights W (Su, n, n) and, per unordered pair, ``w_ij + w_ji`` (Su, K).
    """
    _, _, use_ij, use_ji, ij, ji = pair
    ok = theta >= min_rotation_rad
    w_ij, w_ji = (ok & use_ij).astype(float), (ok & use_ji).astype(float)
    W = np.zeros((theta.shape[0], n * n))
    W[:, ij] = w_ij
    W[:, ji] = w_ji
    return W.reshape(-1, n, n), w_ij + w_ji


def _check_rotation_axes(wk: np.ndarray, beta: np.ndarray,
                         min_rotation_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Raise unless ≥ 2 usable motions about non-parallel axes (``MIN_AXIS_SPREAD``).

    wk (Su, K) pair weights, beta (Su, 3, K) the unit's rotation vectors. Returns the
    axis spread λ2/λ1 (Su,) and the dominant axis (Su, 3).
    """
    Su = wk.shape[0]
    usable = (wk > 0).sum(axis=1)
    for s in np.flatnonzero(usable < 2):
        raise DegenerateDataError(
            f"only {int(usable[s])} motion(s) of the unit rotate by at least "
            f"{min_rotation_rad:g} rad{_where(Su, s)}: the hand-eye transform needs at "
            "least 2 motions about different axes; move the unit between views (e.g. "
            "positions that combine pan and tilt)")
    G = (beta * wk[:, None, :]) @ _swap(beta)
    lam, vec = np.linalg.eigh(G)
    spread = lam[:, 1] / lam[:, 2]
    for s in np.flatnonzero(spread < MIN_AXIS_SPREAD):
        raise DegenerateDataError(
            f"rotation about, and translation along, the unit's rotation axis "
            f"{_fmt_axis(vec[s, :, 2])} (unit frame) cannot be determined{_where(Su, s)}: "
            f"all motions turn about that one axis (axis spread λ2/λ1 = {spread[s]:.2g} < "
            f"{MIN_AXIS_SPREAD:g}: pan-only or tilt-only data, or the other joint moved "
            "too little); add positions with tilt (and pan), so the motions turn about at "
            "least two different axes")
    return spread, vec[:, :, 2]


def _cond_CtC(CtC: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lam, vec = np.linalg.eigh(CtC)
    with np.errstate(divide="ignore"):
        cond = np.where(lam[:, 0] > 0, lam[:, 2] / np.where(lam[:, 0] > 0, lam[:, 0], 1),
                        np.inf)
    return cond, vec[:, :, 0]


def _check_cond_CtC(cond: np.ndarray, weak: np.ndarray) -> None:
    S = cond.shape[0]
    for s in np.flatnonzero(~(cond <= MAX_COND_CTC)):
        raise DegenerateDataError(
            f"translation along {_fmt_axis(weak[s])} (camera frame) is not determined"
            f"{_where(S, s)}: cond(CᵀC) = {cond[s]:.3g} > {MAX_COND_CTC:g} (eq. 7); the "
            "motions' rotation axes are nearly parallel; add positions that turn about a "
            "second axis (combine pan with tilt)")


def _swap(a: np.ndarray) -> np.ndarray:
    return np.swapaxes(a, -1, -2)


def _normal_equations(W, R, t, Q, u, RX):
    """Eq. 7 normal equations ``CᵀC`` (S, 3, 3) and ``Cᵀd`` (S, 3), summed over pairs.

    With ``R_A = R_i R_jᵀ``, ``t_A = t_i − R_A t_j``, ``R_B = Q_i Q_jᵀ``,
    ``t_B = u_i − R_B u_j`` and weights ``w_ij``::

        CᵀC = Σ w_ij (I − R_A)ᵀ (I − R_A)
        Cᵀd = Σ w_ij (I − R_A)ᵀ (t_A − R_X t_B)

    Every term is bilinear in views i and j, so each sum is a contraction with W.
    """
    S, n = R.shape[:2]
    W = np.broadcast_to(W, (S, n, n))
    Wt = _swap(W)
    flat = lambda a: a.reshape(S, n, -1)  # noqa: E731
    Rt = _swap(R)
    G = Rt @ R                                                   # R_iᵀ R_i (I if rigid)
    V = (W @ flat(R)).reshape(S, n, 3, 3)                        # Σ_j w_ij R_j
    sum_RA = np.einsum("sikm,silm->skl", R, V)                   # Σ w_ij R_i R_jᵀ
    H = (Wt @ flat(G)).reshape(S, n, 3, 3)                       # Σ_i w_ij G_i
    sum_RAtRA = (R @ H @ Rt).sum(axis=1)                         # Σ w_ij R_Aᵀ R_A
    CtC = W.sum(axis=(1, 2))[:, None, None] * np.eye(3) - sum_RA - _swap(sum_RA) + sum_RAtRA

    # d_ij = p_i − R_i r_j + R_X Q_i s_j with p = t − R_X u, r = Rᵀ t, s = Qᵀ u.
    mv = lambda A, x: (A @ x[..., None])[..., 0]  # noqa: E731
    p = t - mv(RX[:, None], u)
    r = mv(Rt, t)
    s = mv(_swap(Q), u)
    sum_d = (np.einsum("si,sik->sk", W.sum(axis=2), p)
             - np.einsum("sikl,sil->sk", R, W @ r)
             + mv(RX, np.einsum("sikl,sil->sk", np.broadcast_to(Q, R.shape),
                                np.broadcast_to(W @ s, t.shape))))
    # Σ w_ij R_j R_iᵀ d_ij = Σ_j R_j (Σ_i w_ij R_iᵀ p_i − H_j r_j + (Σ_i w_ij Z_i) s_j)
    Z = Rt @ RX[:, None] @ Q                                      # R_iᵀ R_X Q_i
    Zs = (Wt @ flat(Z)).reshape(S, n, 3, 3)
    inner = Wt @ mv(Rt, p) - mv(H, r) + mv(Zs, np.broadcast_to(s, t.shape))
    Ctd = sum_d - np.einsum("sjkl,sjl->sk", R, inner)
    return CtC, Ctd


def quality_eq10(R: np.ndarray, Q: np.ndarray, RX: np.ndarray) -> np.ndarray:
    """Eq. 10: mean over i ≠ j of ‖R_X Q_i Q_jᵀ R_Xᵀ − R_i R_jᵀ‖_F.

    R (S, n, 3, 3) camera rotations ``R_cw`` (literal matrices allowed); Q (S or 1, n,
    3, 3) unit rotations ``R_gp``; RX (S, 3, 3) a rotation → (S,).

    With ``Y_i = R_X Q_i``, any rotation C and ``F_i = Y_i − R_i C``, the pair residual
    is ``E_ij = Y_i Y_jᵀ − R_i R_jᵀ = P_i N_jᵀ`` with ``P_i = [R_i C, F_i]`` and
    ``N_j = [F_j, Y_j]`` (3×6), so ``‖E_ij‖² = ⟨P_iᵀP_i, N_jᵀN_j⟩``: one n×36 by 36×n
    product for all pairs. C is the rotation nearest to ``Σ R_iᵀ Y_i`` (for consistent
    data every ``R_iᵀ Y_i`` is the same rotation), which keeps F of the size of the
    residuals, so every term is of the size of ‖E‖² and nothing cancels.
    """
    S, n = R.shape[:2]
    Y = np.broadcast_to(RX[:, None] @ Q, R.shape)
    U, _, Vt = np.linalg.svd((_swap(R) @ Y).sum(axis=1))
    C = U @ Vt                                     # orthogonal (a reflection would do too)
    RC = R @ C[:, None]
    F = Y - RC
    P = np.concatenate([RC, F], axis=-1)                          # (S, n, 3, 6)
    N = np.concatenate([F, Y], axis=-1)
    Pg = (_swap(P) @ P).reshape(S, n, 36)
    Ng = (_swap(N) @ N).reshape(S, n, 36)
    fro = np.sqrt(np.maximum(Pg @ _swap(Ng), 0.0))                # (S, n, n)
    return (fro.sum(axis=(1, 2)) - np.trace(fro, axis1=1, axis2=2)) / (n * (n - 1))


def _split(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.ascontiguousarray(T[..., :3, :3]), np.ascontiguousarray(T[..., :3, 3])


def _polar_rotation(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 9: R_X = (MᵀM)^(-1/2) Mᵀ as the polar factor V Uᵀ (det forced to +1)."""
    U, sv, Vt = np.linalg.svd(M)
    V = _swap(Vt)
    d = np.sign(np.linalg.det(V @ _swap(U)))
    d = np.where(d == 0, 1.0, d)
    RX = (V * np.stack([np.ones_like(d), np.ones_like(d), d], axis=-1)[:, None, :]) @ _swap(U)
    return RX, sv


def _solve(T_cw: np.ndarray, T_gp: np.ndarray, pair: tuple, min_rotation_rad: float):
    """Core, batched: T_cw (S, n, 4, 4), T_gp (S or 1, n, 4, 4), pairs from :func:`_pairs`.

    Logs are taken once per unordered pair (i > j): ``α_ji = −α_ij`` and
    ``β_ji = −β_ij``, so ``β_ji α_jiᵀ = β_ij α_ijᵀ`` and pair (j, i) adds the same term
    to M; its weight is added to that of (i, j).
    """
    R, t = _split(T_cw)
    Q, u = _split(T_gp)
    S, n = R.shape[:2]
    i, j = pair[:2]
    beta = _pair_logs(Q, i, j)                                    # (Su, 3, K)
    theta = np.sqrt((beta * beta).sum(axis=1))
    W, wk = _weights(theta, pair, n, min_rotation_rad)
    spread, axis = _check_rotation_axes(wk, beta, min_rotation_rad)
    alpha = _pair_logs(R, i, j)                                   # (S, 3, K)
    M = (beta * wk[:, None, :]) @ _swap(alpha)                    # eq. 9: Σ β αᵀ
    RX, sv = _polar_rotation(M)
    CtC, Ctd = _normal_equations(W, R, t, Q, u, RX)
    cond, weak = _cond_CtC(CtC)
    _check_cond_CtC(cond, weak)
    tX = np.linalg.solve(CtC, Ctd[..., None])[..., 0]
    quality = quality_eq10(R, Q, RX)
    return {"RX": RX, "tX": tX, "quality": quality, "W": W, "theta": theta, "sv": sv,
            "cond_CtC": cond, "axis_spread": spread, "dominant_axis": axis}


def _diagnostics(out: dict, n: int, pair: tuple) -> HandEyeDiagnostics:
    sv = out["sv"][0]
    with np.errstate(divide="ignore"):
        cond_MtM = float((sv[0] / sv[2]) ** 2) if sv[2] > 0 else math.inf
    theta = np.degrees(out["theta"][0][pair[2] | pair[3]])     # the method's motions
    return HandEyeDiagnostics(
        n_positions=n, n_pairs=int(pair[2].sum() + pair[3].sum()),
        n_pairs_used=int(out["W"][0].sum()),
        cond_MtM=cond_MtM, cond_CtC=float(out["cond_CtC"][0]),
        min_rotation_deg=float(theta.min()), max_rotation_deg=float(theta.max()),
        axis_spread=float(out["axis_spread"][0]),
        dominant_axis=_unit_axis(out["dominant_axis"][0]))


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
    T_cw = validate_poses(T_cam_from_world, "T_cam_from_world", check_rigid=check_rigid)
    T_gp = validate_poses(T_gaze_from_ptu, "T_gaze_from_ptu", check_rigid=check_rigid)
    n = T_cw.shape[0]
    _check_positions(n, T_gp.shape[0])
    _check_min_rotation(min_rotation_rad)
    pair = _pairs(n, pairs, None)
    out = _solve(T_cw[None], T_gp[None], pair, min_rotation_rad)
    T = make_transform(out["RX"][0], out["tX"][0])
    return HandEyeResult(T_cam_from_gaze=T, quality=float(out["quality"][0]), method="rasc",
                         diagnostics=_diagnostics(out, n, pair))


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
        ``T_cam_from_gaze`` (S, 4, 4) and ``quality`` (S,), each equal to what
        :func:`solve_rasc` returns for that sample. Any degenerate sample raises
        :class:`DegenerateDataError` naming it.
    """
    T_cw = validate_poses(T_cam_from_world, "T_cam_from_world", batch=True,
                          check_rigid=check_rigid)
    shared = np.ndim(T_gaze_from_ptu) == 3
    T_gp = validate_poses(T_gaze_from_ptu, "T_gaze_from_ptu", batch=not shared,
                          check_rigid=check_rigid)
    T_gp = T_gp[None] if shared else T_gp
    S, n = T_cw.shape[:2]
    if not shared and T_gp.shape[0] != S:
        raise InputError(f"T_gaze_from_ptu has {T_gp.shape[0]} samples, T_cam_from_world {S}")
    _check_positions(n, T_gp.shape[1])
    _check_min_rotation(min_rotation_rad)
    out = _solve(T_cw, T_gp, _pairs(n, pairs, None), min_rotation_rad)
    return HandEyeBatchResult(T_cam_from_gaze=make_transform(out["RX"], out["tX"]),
                              quality=out["quality"])


def _check_min_rotation(min_rotation_rad: float) -> None:
    if not (np.isfinite(min_rotation_rad) and min_rotation_rad >= 0):
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
    T_cw = validate_poses(T_cam_from_world, "T_cam_from_world", check_rigid=check_rigid)
    T_gp = validate_poses(T_gaze_from_ptu, "T_gaze_from_ptu", check_rigid=check_rigid)
    n = T_cw.shape[0]
    _check_positions(n, T_gp.shape[0])
    _check_min_rotation(min_rotation_rad)
    if home is not None and not (isinstance(home, int | np.integer) and 0 <= home < n):
        raise InputError(f"home: expected a position index in 0..{n - 1}, got {home!r}")
    pair = _pairs(n, pairs, None if home is None else int(home))
    out = _solve(T_cw[None], T_gp[None], pair, min_rotation_rad)
    return _diagnostics(out, n, pair), T_cw, T_gp
