"""The hand-eye solvers' vocabulary: their thresholds and the results they return.

Shared by the paper's equations (:mod:`rasc.handeye.paper`), the fast kernels
(:mod:`rasc.handeye._kernels`) and the public entry points (:mod:`rasc.handeye.solver`,
which re-exports every name here).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

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
#: well-spread motions. Measured (``tests/handeye/test_handeye.py``'s near-pan-only sweep: pan
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


class _Deferred:
    """A field value computed on its first read, ``fn(*args)`` (see :class:`_DeferredField`)."""

    __slots__ = ("fn", "args")

    def __init__(self, fn, *args):
        self.fn, self.args = fn, args


class _DeferredField:
    """A frozen dataclass field whose value may be given as a :class:`_Deferred`: it is
    computed on the first read and kept (the instance dict holds it under the field's
    own name, so pickles and ``vars()`` look as for a plain field once it is read)."""

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, obj, owner=None):
        if obj is None:           # the class form: no default (dataclass descriptor fields)
            raise AttributeError(self.name)
        v = obj.__dict__[self.name]
        if type(v) is _Deferred:
            v = obj.__dict__[self.name] = v.fn(*v.args)
        return v

    def __set__(self, obj, value):         # by the dataclass's __init__ (it is frozen)
        obj.__dict__[self.name] = value


@dataclass(frozen=True)
class HandEyeResult:
    """A hand-eye solution.

    T_cam_from_gaze : (4, 4) the paper's ``T_cg`` (for a robot arm: T_cam_from_gripper).
    quality : eq. 10, mean over i ≠ j of ‖R_X R_B R_Xᵀ − R_A‖_F (never NaN).
    method : "rasc", "li", "opencv-park", ...
    diagnostics : :class:`HandEyeDiagnostics`.

    :func:`solve_rasc` may leave ``quality`` and ``diagnostics`` to be computed when they
    are first read (about 50 µs of a 0.25 ms solve on nine views, which callers that want
    only the transform, such as the jackknife, then do not pay); the values are the same
    to the bit either way, and pickles and copies hold them computed.
    """

    T_cam_from_gaze: np.ndarray
    quality: float = _DeferredField()
    method: str
    diagnostics: HandEyeDiagnostics = _DeferredField()

    def __post_init__(self):
        _freeze(self, "T_cam_from_gaze")

    def __getstate__(self) -> dict[str, Any]:
        # pickles and copies hold the values, never the deferral
        return {**self.__dict__, "quality": self.quality, "diagnostics": self.diagnostics}

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

