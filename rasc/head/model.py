"""The calibrated stereo head: pan/tilt angles and image points → base coordinates.

One eye (docs/METHOD.md §1, eq. 1–2)::

    T_cam_from_base(pan, tilt) = T_cam_from_gaze @ unit.T_gaze_from_ptu(pan, tilt) @ T_ptu_from_base

``unit`` is the eye's :class:`rasc.geometry.kinematics.PanTiltUnit` (docs/METHOD.md §10):
the paper's eq. 3 unless the calibration estimated a general one (``rasc calibrate
--model general``). The eye's projection matrix::

    P(pan, tilt) = K [I|0] T_cam_from_base(pan, tilt)

The head triangulates (docs/METHOD.md §6): undistort both eyes' pixels
(:mod:`rasc.geometry.lens`), then
solve eq. 19 (:mod:`rasc.geometry.triangulation`) with each point's own angles. It is stored as a
JSON-ready dict (:meth:`HeadCalibration.to_dict`), format ``rasc-head/1``, lengths in the
unit the calibration used (metres in this project)::

    {"format": "rasc-head/1",
     "left":  {"K": 3x3, "dist": [k1, k2, p1, p2, ...], "T_cam_from_gaze": 4x4,
               "T_ptu_from_base": 4x4, "image_size": [width, height],
               "lens": "fisheye",                 (optional: the lens model; "pinhole" if absent)
               "unit": {...},                     (optional: PanTiltUnit.to_dict(); ideal if absent)
               "std": {...}},                     (optional: per-parameter standard deviations)
     "right": {...}}

``std`` (written by the whole-head refinement, read back as-is and not used for
computing) maps a parameter name to its standard deviation, or to ``null`` for a
parameter the data could not determine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rasc import formats
from rasc.errors import InputError
from rasc.geometry import lens, triangulation
from rasc.geometry.kinematics import IDEAL, PanTiltUnit
from rasc.geometry.transforms import invert_transform, validate_rigid_transform

FORMAT = formats.HEAD.tag
EYE_FIELDS = ("K", "dist", "T_cam_from_gaze", "T_ptu_from_base", "image_size")
OPTIONAL_EYE_FIELDS = ("lens", "unit", "std")


def _image_size(size, name: str) -> tuple[int, int]:
    ok = (isinstance(size, list | tuple | np.ndarray) and len(size) == 2
          and all(isinstance(s, int | np.integer) and not isinstance(s, bool) and s > 0
                  for s in size))
    if not ok:
        raise InputError(f"{name}: expected [width, height], two positive integers, "
                         f"got {size!r}")
    return int(size[0]), int(size[1])


#: Largest |angle| the Python API accepts, radians (one full turn). A value beyond it
#: cannot be an angle in radians of a pan-tilt joint (400 is degrees; so is 8.0, unless
#: the unit turns more than a full turn, which none of the heads this models does).
#: Degrees up to 6.28 cannot be told from radians by their value; the commands therefore
#: require ``--angle-unit``.
MAX_ABS_ANGLE_RAD = 2.0 * np.pi


def _angles(a, name: str) -> np.ndarray:
    """Joint angles in radians, as a float array; refused (InputError, one line) when not
    numeric, not finite, or beyond one turn (|angle| > 2π, :data:`MAX_ABS_ANGLE_RAD`)."""
    if isinstance(a, str | bytes | bool | np.bool_) or (
            isinstance(a, np.ndarray) and a.dtype.kind in "bSU"):
        raise InputError(f"{name}: expected numbers (radians), got {str(a)[:60]!r}")
    try:
        a = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not numeric") from None
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name}: contains NaN or infinity")
    big = np.abs(a) > MAX_ABS_ANGLE_RAD
    if np.any(big):
        value = float(a[big].flat[0])
        where = "" if a.ndim == 0 else f"[{', '.join(map(str, np.argwhere(big)[0]))}]"
        raise InputError(
            f"{name}{where} = {value:g}: beyond ±2π, so not an angle in radians; if it is "
            f"in degrees, pass np.radians({value:g}) = {np.radians(value):.6g}")
    return a


@dataclass(frozen=True, eq=False)
class EyeCalibration:
    """One eye's calibration.

    Attributes
    ----------
    K : ndarray, shape (3, 3)
        Intrinsics (pixels).
    dist : ndarray, shape (k,)
        The lens model's coefficients: pinhole, OpenCV's ``k1 k2 p1 p2 [k3 [k4 k5 k6]]``
        (k in {0, 4, 5, 8}; 8 is the rational model); fisheye, ``k1 k2 k3 k4``.
    T_cam_from_gaze : ndarray, shape (4, 4)
        Hand-eye transform (the paper's ``T_cg``).
    T_ptu_from_base : ndarray, shape (4, 4)
        Mount of this eye's unit on the base (``T_pb``).
    image_size : (int, int)
        (width, height) in pixels.
    unit : PanTiltUnit
        The eye's pan-tilt unit (default: the paper's, eq. 3).
    std : dict or None
        Standard deviations of the estimated parameters (name → number, or None for a
        parameter the data could not determine); informative only.
    lens : str
        The lens model (:data:`rasc.geometry.lens.LENS_MODELS`): ``"pinhole"`` (default)
        or ``"fisheye"`` (OpenCV's equidistant model, ``cv2.fisheye``).
    """

    K: np.ndarray
    dist: np.ndarray
    T_cam_from_gaze: np.ndarray
    T_ptu_from_base: np.ndarray
    image_size: tuple[int, int]
    unit: PanTiltUnit = IDEAL
    std: dict | None = None
    lens: str = "pinhole"

    def __post_init__(self):
        self._check("eye")

    def _check(self, where: str) -> None:
        set_ = object.__setattr__
        set_(self, "K", lens.validate_K(self.K, name=f"{where}.K"))
        lens.check_model(self.lens, name=f"{where}.lens")
        set_(self, "dist", lens.validate_dist(self.dist, name=f"{where}.dist",
                                              model=self.lens))
        for field in ("T_cam_from_gaze", "T_ptu_from_base"):
            set_(self, field, validate_rigid_transform(getattr(self, field),
                                                       name=f"{where}.{field}"))
        set_(self, "image_size", _image_size(self.image_size, f"{where}.image_size"))
        if not isinstance(self.unit, PanTiltUnit):
            raise InputError(f"{where}.unit: expected a PanTiltUnit, "
                             f"got {type(self.unit).__name__}")
        if self.std is not None and not isinstance(self.std, dict):
            raise InputError(f"{where}.std: expected an object of standard deviations, "
                             f"got {type(self.std).__name__}")

    def T_cam_from_base(self, pan, tilt) -> np.ndarray:
        """Eq. 1–2 at encoder readings (radians, broadcast together) → (..., 4, 4), through
        the eye's unit (eq. 3 for the ideal one)."""
        pan, tilt = _angles(pan, "pan"), _angles(tilt, "tilt")
        return self.T_cam_from_gaze @ self.unit.T_gaze_from_ptu(pan, tilt) @ self.T_ptu_from_base

    def projection_matrix(self, pan, tilt) -> np.ndarray:
        """``K [I|0] T_cam_from_base(pan, tilt)`` → (..., 3, 4), ideal (undistorted) pixels."""
        return self.K @ self.T_cam_from_base(pan, tilt)[..., :3, :]

    def project(self, p_base: np.ndarray, pan, tilt) -> np.ndarray:
        """Pixels (with distortion) of points ``p_base`` (N, 3) at angles → uv (N, 2).

        ``pan``, ``tilt``: scalars (one pose for all points) or shape (N,) (one per point).
        Raises :class:`InputError` for a point at or behind the camera.
        """
        p_base = lens.as_points(p_base, "p_base", 3)
        T = self.T_cam_from_base(pan, tilt)
        if T.shape not in ((4, 4), (p_base.shape[0], 4, 4)):
            raise InputError(f"pan, tilt: expected scalars or shape ({p_base.shape[0]},), "
                             f"got {T.shape[:-2]}")
        p_cam = np.einsum("...ij,...j->...i", T[..., :3, :3], p_base) + T[..., :3, 3]
        return lens.project_points(p_cam, self.K, self.dist, model=self.lens)

    def undistort(self, uv: np.ndarray) -> np.ndarray:
        """Distorted pixels (N, 2) → ideal pixels (N, 2)
        (:func:`rasc.geometry.lens.undistort_pixels`)."""
        return lens.undistort_pixels(uv, self.K, self.dist, model=self.lens)

    def to_dict(self) -> dict:
        """JSON-ready dict; ``unit`` only when it is not the ideal one, ``std`` when known."""
        out = {"K": self.K.tolist(), "dist": self.dist.tolist(),
               "T_cam_from_gaze": self.T_cam_from_gaze.tolist(),
               "T_ptu_from_base": self.T_ptu_from_base.tolist(),
               "image_size": list(self.image_size)}
        if self.lens != "pinhole":
            out["lens"] = self.lens
        if not self.unit.is_ideal:
            out["unit"] = self.unit.to_dict()
        if self.std is not None:
            out["std"] = self.std
        return out

    @classmethod
    def from_dict(cls, d, where: str = "eye") -> EyeCalibration:
        """Inverse of :meth:`to_dict`; errors name the field as ``<where>.<field>``."""
        if not isinstance(d, dict):
            raise InputError(f"{where}: expected an object with fields {list(EYE_FIELDS)}")
        missing = [f for f in EYE_FIELDS if f not in d]
        if missing:
            raise InputError(f"{where}.{missing[0]}: missing")
        unknown = sorted(set(d) - set(EYE_FIELDS) - set(OPTIONAL_EYE_FIELDS))
        if unknown:
            raise InputError(f"{where}.{unknown[0]}: unknown field (expected "
                             f"{list(EYE_FIELDS)}, optional {list(OPTIONAL_EYE_FIELDS)})")
        for f in ("K", "dist", "T_cam_from_gaze", "T_ptu_from_base"):
            if not isinstance(d[f], list):
                raise InputError(f"{where}.{f}: expected a list of numbers, "
                                 f"got {type(d[f]).__name__}")
        eye = object.__new__(cls)
        for f in EYE_FIELDS:
            object.__setattr__(eye, f, d[f])
        unit = IDEAL if "unit" not in d else PanTiltUnit.from_dict(d["unit"], f"{where}.unit")
        object.__setattr__(eye, "unit", unit)
        object.__setattr__(eye, "std", d.get("std"))
        object.__setattr__(eye, "lens", d.get("lens", "pinhole"))
        eye._check(where)
        return eye


@dataclass(frozen=True, eq=False)
class HeadCalibration:
    """Both eyes; maps pan/tilt angles and image points to base coordinates (docs/METHOD.md §6)."""

    left: EyeCalibration
    right: EyeCalibration

    def __post_init__(self):
        for name in ("left", "right"):
            if not isinstance(getattr(self, name), EyeCalibration):
                raise InputError(f"{name}: expected an EyeCalibration")

    def T_ptuL_from_ptuR(self) -> np.ndarray:
        """The right unit's frame in the left one (4, 4), as the two mounts imply."""
        return self.left.T_ptu_from_base @ invert_transform(self.right.T_ptu_from_base)

    def project(self, p_base: np.ndarray, pan_left, tilt_left, pan_right, tilt_right):
        """Both eyes' distorted pixels of ``p_base`` (N, 3) → (uv_left, uv_right), (N, 2) each."""
        return (self.left.project(p_base, pan_left, tilt_left),
                self.right.project(p_base, pan_right, tilt_right))

    def triangulate(self, uv_left, uv_right, pan_left, tilt_left, pan_right, tilt_right,
                    method: str = "ls", **kwargs) -> np.ndarray:
        """Base coordinates of matched image points (eq. 15–19 after undistortion).

        Parameters
        ----------
        uv_left, uv_right : array-like, shape (N, 2)
            Measured (distorted) pixels of the same N points in each eye.
        pan_left, tilt_left, pan_right, tilt_right : float or array-like, shape (N,)
            Each eye's angles in radians: one pose for all points, or one per point.
        method : {"ls", "tls"}
        **kwargs
            ``min_parallax_deg``, ``on_degenerate``: see
            :func:`rasc.geometry.triangulation.triangulate`.

        Returns
        -------
        p_base : ndarray, shape (N, 3)
        """
        uv = {}
        P = {}
        for name, eye, pts, pan, tilt in (("left", self.left, uv_left, pan_left, tilt_left),
                                          ("right", self.right, uv_right, pan_right,
                                           tilt_right)):
            try:
                uv[name] = eye.undistort(pts)
            except InputError as exc:
                raise InputError(f"{name}: {exc}") from None
            P[name] = eye.projection_matrix(pan, tilt)
            n = uv[name].shape[0]
            if P[name].shape not in ((3, 4), (n, 3, 4)):
                raise InputError(f"pan_{name}, tilt_{name}: expected scalars or shape ({n},), "
                                 f"got {P[name].shape[:-2]}")
        return triangulation.triangulate(P["left"], P["right"], uv["left"], uv["right"],
                                         method, **kwargs)

    def to_dict(self) -> dict:
        """JSON-ready dict (lists and numbers only), format ``rasc-head/1``."""
        return {"format": FORMAT, "left": self.left.to_dict(), "right": self.right.to_dict()}

    @classmethod
    def from_dict(cls, d, source: str | None = None) -> HeadCalibration:
        """Inverse of :meth:`to_dict`, validating every field.

        ``source`` (e.g. a file name) prefixes error messages:
        ``head.json: left.T_cam_from_gaze: rotation part is not orthonormal (...)``.
        """
        try:
            if not isinstance(d, dict):
                raise InputError(f"expected an object with format {FORMAT!r}, "
                                 f"got {type(d).__name__}")
            if d.get("format") != FORMAT:
                raise InputError(f"format: expected {FORMAT!r}, got {d.get('format')!r}")
            unknown = sorted(set(d) - {"format", "left", "right"})
            if unknown:
                raise InputError(f"{unknown[0]}: unknown field (expected format, left, right)")
            eyes = {}
            for name in ("left", "right"):
                if name not in d:
                    raise InputError(f"{name}: missing")
                eyes[name] = EyeCalibration.from_dict(d[name], where=name)
        except InputError as exc:
            if source is None:
                raise
            raise InputError(f"{source}: {exc}") from None
        return cls(eyes["left"], eyes["right"])

    @classmethod
    def from_truth(cls, truth: dict) -> HeadCalibration:
        """The true head of a ground truth (``rasc render``'s ``ground_truth.json``, or
        :meth:`rasc.sim.scene.StereoHeadSim.ground_truth`): per eye its K, dist, hand-eye,
        mount, image size and unit, in the calibration's gauge and base as the renderer
        writes them, so that it compares with a calibration as it is."""
        return cls(**{eye: EyeCalibration(
            K=np.asarray(truth[eye]["K"], float), dist=np.asarray(truth[eye]["dist"], float),
            T_cam_from_gaze=np.asarray(truth[eye]["T_cam_from_gaze"], float),
            T_ptu_from_base=np.asarray(truth[eye]["T_ptu_from_base"], float),
            image_size=tuple(truth[eye]["image_size"]),
            lens=truth[eye].get("lens", "pinhole"),
            unit=(PanTiltUnit.from_dict(truth[eye]["unit"]) if "unit" in truth[eye]
                  else IDEAL)) for eye in ("left", "right")})

