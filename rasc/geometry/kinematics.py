"""Pan-tilt kinematics, eq. 3 of the paper (docs/METHOD.md §2).

    R_gaze_from_ptu(φ, τ) = Rz(τ) · Rx(−φ),   t_gaze_from_ptu = 0

φ is pan, τ is tilt, in radians. The ptu frame is x = up, y = forward, z = left: the pan
joint turns about the ptu x axis (vertical), the tilt joint about the panned z axis by
−τ, so positive pan turns the line of sight (+y) to the left and positive tilt raises it.

:class:`PanTiltUnit` is the general unit of docs/METHOD.md §10 (axes that need not meet
or be orthogonal, encoder offsets and scales) as a product of exponentials; its defaults
(:data:`IDEAL`) are eq. 3. :func:`canonical_gauge` picks the one representative of the
units that give identical camera poses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.transforms import (
    invert_transform,
    make_transform,
    matrix_from_rotvec,
    rotation_angle,
    rotvec_from_matrix,
    validate_rigid_transform,
)
from rasc.io import finite_number


def R_gaze_from_ptu(pan: np.ndarray | float, tilt: np.ndarray | float) -> np.ndarray:
    """Eq. 3. ``pan``, ``tilt`` in radians, broadcast together → (..., 3, 3)."""
    pan, tilt = np.broadcast_arrays(np.asarray(pan, dtype=float), np.asarray(tilt, dtype=float))
    cp, sp = np.cos(pan), np.sin(pan)
    ct, st = np.cos(tilt), np.sin(tilt)
    R = np.empty(pan.shape + (3, 3))
    R[..., 0, 0] = ct
    R[..., 0, 1] = -st * cp
    R[..., 0, 2] = -st * sp
    R[..., 1, 0] = st
    R[..., 1, 1] = ct * cp
    R[..., 1, 2] = ct * sp
    R[..., 2, 0] = 0.0
    R[..., 2, 1] = -sp
    R[..., 2, 2] = cp
    return R


def T_gaze_from_ptu(pan: np.ndarray | float, tilt: np.ndarray | float) -> np.ndarray:
    """Eq. 3 as 4×4 transforms (pure rotation about the unit's centre) → (..., 4, 4)."""
    R = R_gaze_from_ptu(pan, tilt)
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., 3, 3] = 1.0
    return T


#: The paper's nine positions (pan, tilt) in degrees (docs/METHOD.md §9, E1), home first.
PAPER_POSES_DEG = (
    (0.0, 0.0),
    (8.0, 8.0), (8.0, 0.0), (8.0, -8.0),
    (0.0, 8.0), (0.0, -8.0),
    (-8.0, 8.0), (-8.0, 0.0), (-8.0, -8.0),
)


# --------------------------------------------------------------------------------------
# The general unit (docs/METHOD.md §10)
# --------------------------------------------------------------------------------------

_VECTOR_FIELDS = ("pan_axis", "tilt_axis", "tilt_point")
_SCALAR_FIELDS = ("pan_offset", "tilt_offset", "pan_scale", "tilt_scale")

#: Below this sine of the angle between the pan and the tilt axis the unit cannot aim
#: (the two joints turn about nearly the same line) and the common normal is undefined.
#: 1e-6 rad is far below any built unit (a 1° error is 1.7e-2) and far above round-off.
_PARALLEL_SINE = 1e-6


def _rodrigues(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotations by ``angle`` (...) about the unit ``axis`` (3,) → (..., 3, 3).

    Written as ``cos θ · I + sin θ · [a]× + (1 − cos θ) · a aᵀ`` so that for a coordinate
    axis every element is a single product (exactly eq. 3's cos/sin entries).
    """
    c, s = np.cos(angle), np.sin(angle)
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    aaT = np.outer(axis, axis)
    return (c[..., None, None] * np.eye(3) + s[..., None, None] * K
            + (1.0 - c)[..., None, None] * aaT)


def _as_vector(value, name: str, where: str) -> tuple[float, float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise InputError(f"{where}{name}: expected 3 numbers, got {value!r}")
    if len(value) != 3 or any(isinstance(v, (bool, str, bytes)) for v in value):
        raise InputError(f"{where}{name}: expected 3 numbers, got {value!r}")
    return tuple(_as_scalar(v, f"{name}[{k}]", where)   # type: ignore[return-value]
                 for k, v in enumerate(value))


def _as_scalar(value, name: str, where: str) -> float:
    return finite_number(value, f"{where}{name}") + 0.0      # + 0.0: no -0.0 in JSON


def _unit_vector(v: tuple[float, float, float], name: str, where: str):
    n = float(np.linalg.norm(v))
    if n < 1e-9:
        raise InputError(f"{where}{name}: axis must not be zero, got {list(v)}")
    if abs(n - 1.0) > 1e-12:
        v = tuple(float(x) / n for x in v)
    return v


@dataclass(frozen=True)
class PanTiltUnit:
    """A general pan-tilt unit: two revolute joints as a product of exponentials.

    docs/METHOD.md §10. Encoder readings ``pan``, ``tilt`` (radians) map to joint angles
    ``φ = pan_scale · pan + pan_offset``, ``τ = tilt_scale · tilt + tilt_offset``, and ::

        T_gaze_from_ptu(φ, τ) = [Trans(q) · Rot(ẑ', τ) · Trans(−q)] · Rot(x̂_p, −φ)

    with ``x̂_p = pan_axis`` (ptu frame, through the ptu origin), ``ẑ' = tilt_axis`` and
    ``q = tilt_point`` (a point on the tilt axis), both in the panned frame (the pan link's
    frame, which equals ptu at pan = 0). The defaults are the paper's ideal unit, eq. 3.
    Lengths are in the dataset's length unit (metres for the simulated head).

    Note the sign convention of eq. 3: ``tilt_axis`` is the axis about which the *ptu
    coordinates* turn into gaze coordinates (+z for the ideal unit); the mechanism (the
    gaze body relative to the pan link) turns by τ about −ẑ' (MuJoCo ``axis="0 0 -1"``).

    Attributes
    ----------
    pan_axis : tuple of 3 float
        Unit direction x̂_p of the pan axis in the ptu frame; default (1, 0, 0).
    tilt_axis : tuple of 3 float
        Unit direction ẑ' of the tilt axis in the panned frame; default (0, 0, 1).
    tilt_point : tuple of 3 float
        A point q on the tilt axis, panned frame; default (0, 0, 0).
    pan_offset, tilt_offset : float
        Encoder zero offsets o_φ, o_τ in radians; default 0.
    pan_scale, tilt_scale : float
        Encoder scales s_φ, s_τ (positive); default 1.

    Any axis given with a norm other than 1 is normalised. Parallel axes, a zero axis,
    non-positive scales and non-finite values raise :class:`rasc.errors.InputError`.
    """

    pan_axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    tilt_axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    tilt_point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    pan_offset: float = 0.0
    tilt_offset: float = 0.0
    pan_scale: float = 1.0
    tilt_scale: float = 1.0

    def __post_init__(self) -> None:
        where = "PanTiltUnit: "
        for name in _VECTOR_FIELDS:
            v = _as_vector(getattr(self, name), name, where)
            if name != "tilt_point":
                v = _unit_vector(v, name, where)
            object.__setattr__(self, name, v)
        for name in _SCALAR_FIELDS:
            object.__setattr__(self, name, _as_scalar(getattr(self, name), name, where))
        for name in ("pan_scale", "tilt_scale"):
            if getattr(self, name) <= 0.0:
                raise InputError(f"{where}{name}: must be positive, got {getattr(self, name)}")
        if self._axes_sine() < _PARALLEL_SINE:
            raise InputError(f"{where}pan_axis {list(self.pan_axis)} and tilt_axis "
                             f"{list(self.tilt_axis)} are parallel: the unit cannot aim")

    # ---- kinematics -------------------------------------------------------------------

    def angles(self, pan, tilt) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles (φ, τ) in radians from encoder readings, broadcast together."""
        pan, tilt = np.broadcast_arrays(np.asarray(pan, dtype=float),
                                        np.asarray(tilt, dtype=float))
        return self.pan_scale * pan + self.pan_offset, self.tilt_scale * tilt + self.tilt_offset

    def readings(self, phi, tau) -> tuple[np.ndarray, np.ndarray]:
        """Encoder readings from joint angles (φ, τ) in radians: the inverse of :meth:`angles`."""
        phi, tau = np.broadcast_arrays(np.asarray(phi, dtype=float), np.asarray(tau, dtype=float))
        return (phi - self.pan_offset) / self.pan_scale, (tau - self.tilt_offset) / self.tilt_scale

    def T_gaze_from_ptu(self, pan, tilt) -> np.ndarray:
        """The unit's motion at encoder readings ``pan``, ``tilt`` (radians; scalars or
        arrays, broadcast together) → (..., 4, 4). Equals eq. 3 for the ideal unit."""
        phi, tau = self.angles(pan, tilt)
        R_pan = _rodrigues(np.asarray(self.pan_axis), -phi)        # Rot(x̂_p, −φ)
        R_tilt = _rodrigues(np.asarray(self.tilt_axis), tau)       # Rot(ẑ', τ)
        q = np.asarray(self.tilt_point)
        T = np.zeros(phi.shape + (4, 4))
        T[..., :3, :3] = R_tilt @ R_pan
        T[..., :3, 3] = q - R_tilt @ q                              # Trans(q) R Trans(−q)
        T[..., 3, 3] = 1.0
        return T

    # ---- derived quantities -------------------------------------------------------------

    def _axes_sine(self) -> float:
        return float(np.linalg.norm(np.cross(self.pan_axis, self.tilt_axis)))

    @property
    def axis_angle_deg(self) -> float:
        """Angle between the pan and the tilt axis in degrees (90 for the ideal unit)."""
        return float(np.degrees(np.arctan2(self._axes_sine(),
                                           float(np.dot(self.pan_axis, self.tilt_axis)))))

    @property
    def common_normal(self) -> tuple[np.ndarray, np.ndarray]:
        """Feet of the common normal: (point on the pan axis, point on the tilt axis), each
        (3,), panned frame. Their distance is :attr:`axis_distance`."""
        p, z, q = (np.asarray(v) for v in (self.pan_axis, self.tilt_axis, self.tilt_point))
        b = float(p @ z)
        d, e = float(p @ -q), float(z @ -q)    # w0 = origin − q
        den = 1.0 - b * b
        t = (b * e - d) / den
        s = (e - b * d) / den
        return t * p, q + s * z

    @property
    def axis_distance(self) -> float:
        """Common-normal distance between the pan axis (through the ptu origin) and the tilt
        axis, in the dataset's length unit: the one observable offset (METHOD §10)."""
        n = np.cross(self.pan_axis, self.tilt_axis)
        return float(abs(np.asarray(self.tilt_point) @ n) / np.linalg.norm(n))

    @property
    def is_ideal(self) -> bool:
        """True when the unit is exactly the paper's (eq. 3)."""
        return self == IDEAL

    @classmethod
    def canonical(cls, axis_angle: float = np.pi / 2, axis_offset: float = 0.0,
                  pan_scale: float = 1.0, tilt_scale: float = 1.0) -> PanTiltUnit:
        """The unit in the canonical gauge (:func:`canonical_gauge`) from its four
        observable parameters: ``axis_angle`` α (radians) between the axes, the signed
        common-normal offset d (``tilt_point = (0, d, 0)``) and the two scales.
        ``canonical(π/2, 0, 1, 1)`` is :data:`IDEAL` to round-off (cos(π/2) = 6e-17)."""
        return cls(tilt_axis=(float(np.cos(axis_angle)), 0.0, float(np.sin(axis_angle))),
                   tilt_point=(0.0, float(axis_offset), 0.0), pan_scale=pan_scale,
                   tilt_scale=tilt_scale)

    @property
    def canonical_parameters(self) -> tuple[float, float, float, float]:
        """(α radians, d, s_φ, s_τ) of a unit in the canonical gauge, the inverse of
        :meth:`canonical`. Raises InputError for a unit in another gauge."""
        x, y, z = self.tilt_axis
        if (self.pan_axis != (1.0, 0.0, 0.0) or y != 0.0 or z <= 0.0
                or self.tilt_point[0] != 0.0 or self.tilt_point[2] != 0.0
                or self.pan_offset != 0.0 or self.tilt_offset != 0.0):
            raise InputError("PanTiltUnit: not in the canonical gauge; use canonical_gauge() "
                             "first")
        return float(np.arctan2(z, x)), self.tilt_point[1], self.pan_scale, self.tilt_scale

    # ---- serialisation ------------------------------------------------------------------

    def to_dict(self) -> dict:
        """JSON-ready dict: vectors as lists, angles in radians, lengths in the dataset's
        length unit. :meth:`from_dict` reads it back exactly."""
        out: dict = {name: [float(x) for x in getattr(self, name)] for name in _VECTOR_FIELDS}
        out.update({name: float(getattr(self, name)) for name in _SCALAR_FIELDS})
        return out

    @classmethod
    def from_dict(cls, data, where: str = "unit") -> PanTiltUnit:
        """Read :meth:`to_dict`'s output. Missing keys take the ideal unit's value; unknown
        keys, wrong types and non-finite values raise a one-line
        :class:`rasc.errors.InputError` naming ``where`` and the key."""
        if not isinstance(data, dict):
            raise InputError(f"{where}: expected a table of unit parameters, "
                             f"got {type(data).__name__}")
        known = _VECTOR_FIELDS + _SCALAR_FIELDS
        for key in data:
            if key not in known:
                raise InputError(f"{where}.{key}: unknown unit parameter "
                                 f"(known: {', '.join(known)})")
        kwargs: dict = {}
        for key, value in data.items():
            if key in _VECTOR_FIELDS:
                kwargs[key] = _as_vector(value, key, f"{where}.")
            else:
                kwargs[key] = _as_scalar(value, key, f"{where}.")
        try:
            return cls(**kwargs)
        except InputError as exc:
            raise InputError(f"{where}: {str(exc).removeprefix('PanTiltUnit: ')}") from None


#: The paper's unit (eq. 3).
IDEAL = PanTiltUnit()


def _translation(v: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = v
    return T


def _rotation(R: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    return T


def canonical_gauge(unit: PanTiltUnit, T_cam_from_gaze: np.ndarray,
                    T_ptu_from_base: np.ndarray) -> tuple[PanTiltUnit, np.ndarray, np.ndarray]:
    """Re-express one eye in the canonical gauge, leaving every camera pose unchanged.

    The data determine ``T_cam_from_base(pan, tilt) = T_cam_from_gaze ·
    unit.T_gaze_from_ptu(pan, tilt) · T_ptu_from_base`` only; several units with their
    hand-eye and mount give the same poses (docs/METHOD.md §10). The canonical
    representative, which ground truth and estimates share, has

    * ``pan_axis = (1, 0, 0)``: the ptu frame is turned so that x is the pan axis
      (absorbed by the mount and the hand-eye; the turn also brings the tilt axis into the
      x–z plane with a positive z component);
    * ``tilt_axis = (cos α, 0, sin α)``, α = :attr:`PanTiltUnit.axis_angle_deg`;
    * ``tilt_point = (0, d, 0)``: q is the foot of the common normal on the tilt axis and
      the foot on the pan axis is the ptu origin, so |d| = :attr:`PanTiltUnit.axis_distance`
      (shifts of q along the tilt axis change nothing; shifts along the pan axis go into
      the mount and the hand-eye);
    * ``pan_offset = tilt_offset = 0``: the pan offset goes into the mount
      (``Rot(x̂_p, −o_φ) · T_ptu_from_base``), the tilt offset into the hand-eye
      (``T_cam_from_gaze · [tilt screw by o_τ]``), so the gaze frame equals the ptu frame
      at readings (0, 0);
    * the scales unchanged (they are observable).

    Parameters
    ----------
    unit : PanTiltUnit
    T_cam_from_gaze, T_ptu_from_base : (4, 4) ndarray

    Returns
    -------
    (PanTiltUnit, (4, 4) ndarray, (4, 4) ndarray)
        The canonical unit, ``T_cam_from_gaze`` and ``T_ptu_from_base`` in its gauge; the
        product ``T_cam_from_base`` equals the input's for every reading to round-off.
    """
    T_cg = np.asarray(T_cam_from_gaze, dtype=float)
    T_pb = np.asarray(T_ptu_from_base, dtype=float)
    p, z, q = (np.asarray(v) for v in (unit.pan_axis, unit.tilt_axis, unit.tilt_point))
    # 1. encoder offsets: T_gp(φr, τr) = S(o_τ) · S(s τr) · Rot(p, −s φr) · Rot(p, −o_φ)
    S_offset = np.eye(4)
    R_off = _rodrigues(z, np.asarray(unit.tilt_offset))
    S_offset[:3, :3] = R_off
    S_offset[:3, 3] = q - R_off @ q
    T_cg = T_cg @ S_offset
    T_pb = _rotation(_rodrigues(p, np.asarray(-unit.pan_offset))) @ T_pb
    # 2. turn the ptu (and panned) frame: rows e1 = p, e2 = e3 × e1, e3 = z ⟂ p, normalised
    e3 = z - (p @ z) * p
    e3 /= np.linalg.norm(e3)
    R0 = np.stack([p, np.cross(e3, p), e3])
    T_cg = T_cg @ _rotation(R0.T)
    T_pb = _rotation(R0) @ T_pb
    z0, q0 = R0 @ z, R0 @ q
    c, s = float(z0[0]), float(z0[2])
    # 3. slide q along the tilt axis (no effect) and along the pan axis (absorbed):
    #    q0 = (α + β c, q_y, β s)  →  q = (0, q_y, 0); q + a·x̂ ⇒ T_cg·Trans(−a x̂), Trans(a x̂)·T_pb
    beta = float(q0[2]) / s
    alpha = float(q0[0]) - beta * c
    T_cg = T_cg @ _translation(np.array([alpha, 0.0, 0.0]))
    T_pb = _translation(np.array([-alpha, 0.0, 0.0])) @ T_pb
    canonical = PanTiltUnit(pan_axis=(1.0, 0.0, 0.0), tilt_axis=(c, 0.0, s),
                            tilt_point=(0.0, float(q0[1]), 0.0),
                            pan_scale=unit.pan_scale, tilt_scale=unit.tilt_scale)
    return canonical, T_cg, T_pb


#: Relative rotations closer than this to a half turn have no unique geodesic midpoint.
HALF_TURN_MARGIN_RAD = 1e-6


def cyclopean_base(T_ptuL_from_ptuR):
    """Place the base frame between the two units (docs/CONTRACTS.md).

    With ``v = log R_ptuL_from_ptuR`` and ``t = t_ptuL_from_ptuR``:
    ``R_base_from_ptuL = exp(−v/2)``, ``R_base_from_ptuR = exp(+v/2)`` (the geodesic
    midpoint), and the base origin is the midpoint ``t/2`` of the two unit centres, so
    the ptu origins in base are ``∓ R_base_from_ptuL t/2`` — equal and opposite.

    Parameters
    ----------
    T_ptuL_from_ptuR : array-like, shape (4, 4)

    Returns
    -------
    T_ptu_from_base_left, T_ptu_from_base_right : ndarray, shape (4, 4)
        With ``T_ptu_from_base_left @ inv(T_ptu_from_base_right) = T_ptuL_from_ptuR``.

    Raises
    ------
    DegenerateDataError
        The units are turned half a turn relative to each other: no unique midpoint.
    """
    T = validate_rigid_transform(T_ptuL_from_ptuR, name="T_ptuL_from_ptuR")
    if rotation_angle(T[:3, :3]) > np.pi - HALF_TURN_MARGIN_RAD:
        raise DegenerateDataError(
            "cyclopean_base: the two units are turned 180 deg relative to each other, so "
            "the midpoint orientation is not unique; check T_ptuL_from_ptuR (mounts facing "
            "the same way differ by a small rotation)")
    v = rotvec_from_matrix(T[:3, :3])
    R_base_from_ptuL = matrix_from_rotvec(-v / 2.0)
    t = T[:3, 3]
    T_base_from_ptuL = make_transform(R_base_from_ptuL, -R_base_from_ptuL @ t / 2.0)
    T_base_from_ptuR = T_base_from_ptuL @ T
    return invert_transform(T_base_from_ptuL), invert_transform(T_base_from_ptuR)
