"""The refinement's inputs, results and kinematic model: the corners and initial values
(:class:`HeadObservations`), the result (:class:`RefinementResult`), the general unit's
parameters and motion (docs/METHOD.md §10). See :mod:`rasc.head.refine`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import PanTiltUnit
from rasc.geometry.lens import DIST_MODELS, LENS_MODELS

#: Candidate unit parameters per eye, in the order they are admitted (observable ones
#: first): a later candidate is tested against the span of those kept before it.
#: tilt_axis_x / tilt_axis_y: the x and y components of the (unnormalised) tilt axis
#: (x, y, 1) — x sets the axis angle, y turns the axis about the pan axis;
#: tilt_point_*: the point q on the tilt axis.
UNIT_PARAMETERS = ("pan_scale", "tilt_scale", "tilt_axis_x", "tilt_point_y",
                   "tilt_point_x", "tilt_point_z", "tilt_axis_y", "pan_offset", "tilt_offset")


#: dist_model → the distortion coefficients the refinement estimates (by name, of the
#: model's lens: :data:`rasc.geometry.lens.DIST_MODELS`, the one table)
DIST_PARAMS = {name: est for name, (_, est, _) in DIST_MODELS.items()}
#: every distortion coefficient's name, of any lens model (pinhole k1-k6 p1 p2; the
#: fisheye's are k1-k4)
DIST_NAMES = LENS_MODELS["pinhole"]

#: The unit of every refined parameter, by its name within its group (an eye's, or the
#: head's ``T_ptuL_from_ptuR``): "length" is the dataset's length unit (that of
#: board.square_size), "deg" a small rotation's std about an axis (``rot*``), "1" a
#: pure number. The one table the result, the calibration file and the report read;
#: a name missing here is a programming error (:func:`parameter_unit` raises).
PARAMETER_UNITS = {
    **{n: "px" for n in ("fx", "fy", "cx", "cy")},
    **{n: "1" for n in DIST_NAMES},
    **{f"{T}.rot{a}": "deg" for T in ("T_cam_from_gaze", "T_ptuL_from_ptuR") for a in "xyz"},
    **{f"{T}.t{a}": "length" for T in ("T_cam_from_gaze", "T_ptuL_from_ptuR") for a in "xyz"},
    "unit.pan_scale": "1", "unit.tilt_scale": "1",
    # the x and y components of the unnormalised tilt axis (x, y, 1): pure numbers (tan of
    # the axis's tilt towards the pan axis, and about it)
    "unit.tilt_axis_x": "1", "unit.tilt_axis_y": "1",
    "unit.tilt_point_x": "length", "unit.tilt_point_y": "length", "unit.tilt_point_z": "length",
    "unit.pan_offset": "rad", "unit.tilt_offset": "rad",
    # the camera-to-encoder time offset of a continuous capture (rasc.head.refine.timing)
    "time_offset": "s",
}


def parameter_unit(name: str) -> str:
    """The unit of the refined parameter ``name`` (``"left.unit.tilt_scale"``,
    ``"T_ptuL_from_ptuR.tx"`` or the bare ``"unit.tilt_scale"``) from
    :data:`PARAMETER_UNITS`."""
    group, _, rest = name.partition(".")
    if group in EYES:
        name = rest
    try:
        return PARAMETER_UNITS[name]
    except KeyError:
        raise KeyError(f"refined parameter {name!r} has no unit in PARAMETER_UNITS") from None


# ----------------------------------------------------------------------------- inputs

@dataclass
class EyeObservations:
    """One eye's corners and closed-form initial values.

    Attributes
    ----------
    K : (3, 3); dist : (k,) the coefficients of the dataset's lens model (pinhole:
    OpenCV's order, missing ones zero; fisheye: k1 k2 k3 k4); image_size : (width, height)
    intrinsics : dict name → corners (N, 2): the intrinsics views used
    T_cam_from_world_intrinsics : dict name → (4, 4): their initial board poses
    pose : dict file → corners (N, 2): the pose views
    pan_tilt : dict file → (pan, tilt) encoder readings in radians
    view : dict file → view id (the simultaneous board placement)
    T_cam_from_world_pose : dict file → (4, 4): per-pose extrinsics (initial values)
    T_cam_from_gaze : (4, 4) initial hand-eye (RASC)
    pose_time : dict file → the pose image's time (camera clock, s, mid-exposure) of a
        continuous capture; empty otherwise
    """

    K: np.ndarray
    dist: np.ndarray
    image_size: tuple[int, int]
    intrinsics: dict[str, np.ndarray]
    T_cam_from_world_intrinsics: dict[str, np.ndarray]
    pose: dict[str, np.ndarray]
    pan_tilt: dict[str, tuple[float, float]]
    view: dict[str, str]
    T_cam_from_world_pose: dict[str, np.ndarray]
    T_cam_from_gaze: np.ndarray
    pose_time: dict[str, float] = field(default_factory=dict)


@dataclass
class HeadObservations:
    """Both eyes' observations, the board's corners in its own frame (N, 3) and the
    initial ``T_ptuL_from_ptuR`` (loop closure); ``streams``: a continuous capture's
    joint stream per eye (:class:`rasc.head.refine.timing.JointStream`, encoder clock),
    with every pose image's ``pose_time``, or None."""

    board_points: np.ndarray
    eyes: dict[str, EyeObservations]
    T_ptuL_from_ptuR: np.ndarray
    dist_model: str = "k1k2"
    streams: dict[str, Any] | None = None

    @property
    def has_stream(self) -> bool:
        """Whether the pose images have times and a joint stream (δ can be estimated)."""
        return self.streams is not None and all(
            self.eyes[eye].pose_time.keys() >= self.eyes[eye].pose.keys() for eye in EYES)


def observations_from_calibration(cal, board) -> HeadObservations:
    """The refinement's input from a closed-form :class:`rasc.head.pipeline.Calibration`
    (which keeps its detected corners)."""
    eyes = {}
    for eye in EYES:
        r = cal.eyes[eye]
        intr = r.intrinsics
        used = list(intr.T_cam_from_world)
        eyes[eye] = EyeObservations(
            K=intr.K, dist=np.asarray(intr.dist, float).ravel().copy(),
            image_size=tuple(intr.image_size),
            intrinsics={n: r.corners["intrinsics"][n] for n in used},
            T_cam_from_world_intrinsics=dict(intr.T_cam_from_world),
            pose={f: r.corners["pose"][f] for f in r.pose_files},
            pan_tilt={f: (float(pt[0]), float(pt[1]))
                      for f, pt in zip(r.pose_files, r.pan_tilt, strict=True)},
            view=dict(zip(r.pose_files, r.views, strict=True)),
            T_cam_from_world_pose=dict(zip(r.pose_files, r.T_cam_from_world, strict=True)),
            T_cam_from_gaze=r.handeye.T_cam_from_gaze)
    T_loop = cal.base.get("loop_closure", {}).get("T_ptuL_from_ptuR", cal.base["T_ptuL_from_ptuR"])
    streams = None
    stream = getattr(cal, "joint_stream", None)
    if stream is not None:
        # a continuous capture: the pose images' times, and each eye's stream
        from rasc.head.refine.timing import check_image_times

        streams = {eye: stream[eye] for eye in EYES}
        for eye in EYES:
            r = cal.eyes[eye]
            times = dict(zip(r.pose_files, r.times, strict=True))
            check_image_times(times, streams[eye], eye)
            eyes[eye].pose_time = {f: float(t) for f, t in times.items()}
    return HeadObservations(board_points=board.object_points(), eyes=eyes,
                            T_ptuL_from_ptuR=np.asarray(T_loop, float),
                            dist_model=cal.options.dist_model, streams=streams)


def _dist5(dist) -> np.ndarray:
    d = np.zeros(5)
    dist = np.asarray(dist, float).ravel()[:5]
    d[:len(dist)] = dist
    return d


# ----------------------------------------------------------------------------- results

@dataclass
class ImageResidual:
    """Residuals of one image after the fit: RMS and max (px) over its kept corners,
    and the indices of its rejected corners."""

    eye: str
    role: str
    name: str
    rms: float
    max: float
    rejected: list[int]

    def to_dict(self) -> dict:
        return {"eye": self.eye, "role": self.role, "file": self.name, "rms": self.rms,
                "max": self.max, "rejected_corners": self.rejected}


@dataclass
class RefinementResult:
    """What :func:`refine_head` found.

    Attributes
    ----------
    K, dist, T_cam_from_gaze, unit : dict eye → refined value
    T_ptuL_from_ptuR : (4, 4)
    parameters : dict eye (or "head") → name → {"value": float | None, "std": float | None,
        "unit": str}; value and std None for a parameter the data cannot determine
    not_identifiable : list of {"eye", "parameter", "reason", "sine"}
    rms_before, rms_after : reprojection RMS (px, OpenCV's definition: sqrt of the mean
        squared 2-D residual) over every corner, at the initial guess and at the optimum
        (kept corners)
    sigma : noise per coordinate (px) from the residuals; images : per-image residuals
    residuals : dict eye → (M, 2) final residuals of its kept corners, for plots
    lens : dict eye → the lens model of ``dist`` (:data:`rasc.geometry.lens.LENS_MODELS`)
    covariance : (n, n) of the estimated parameters (natural units), names : their names
    """

    K: dict[str, np.ndarray]
    dist: dict[str, np.ndarray]
    T_cam_from_gaze: dict[str, np.ndarray]
    unit: dict[str, PanTiltUnit]
    T_ptuL_from_ptuR: np.ndarray
    parameters: dict[str, dict[str, dict[str, Any]]]
    not_identifiable: list[dict[str, Any]]
    rms_before: float
    rms_after: float
    sigma: float
    images: list[ImageResidual]
    n_corners: int
    n_rejected: int
    iterations: int
    seconds: float
    gauge: str
    residuals: dict[str, np.ndarray] = field(default_factory=dict)
    rms_by_role: dict[str, float] = field(default_factory=dict)
    held: list[str] = field(default_factory=list)
    rss: float = float("nan")          # residual sum of squares over the kept corners, px²
    dof: int = 0                       # residuals − estimated parameters
    kept: np.ndarray | None = None     # (n_img, N) mask of the kept corners
    scales: dict[str, Any] = field(default_factory=dict)   # how the scales were decided
    values: np.ndarray | None = None   # the estimated parameters (names), natural units
    identifiability: tuple | None = None   # (free, dropped) over all candidates
    covariance: np.ndarray | None = None
    names: list[str] = field(default_factory=list)
    lens: dict[str, str] = field(default_factory=lambda: {eye: "pinhole" for eye in EYES})
    #: the camera-to-encoder time offset of a continuous capture: {"mode", "estimated",
    #: "value_s", "std_s"} (empty without a joint stream)
    time_offset: dict[str, Any] = field(default_factory=dict)
    #: pose frames dropped whole as outliers (continuous captures): {"eye", "file",
    #: "rms_px", "threshold_px"} each
    frames_rejected: list[dict[str, Any]] = field(default_factory=list)

    def std(self, eye: str) -> dict[str, float | None]:
        """Name → standard deviation of one eye's parameters (None: not identifiable)."""
        return {k: v["std"] for k, v in self.parameters[eye].items()}

    def to_dict(self) -> dict:
        return {"gauge": self.gauge,
                "rms_before_px": self.rms_before, "rms_after_px": self.rms_after,
                "sigma_px": self.sigma, "corners": self.n_corners,
                "rms_by_role_px": self.rms_by_role, "held_at_nominal": self.held,
                "scales": self.scales,
                **({"time_offset": self.time_offset} if self.time_offset else {}),
                **({"frames_rejected": self.frames_rejected} if self.frames_rejected
                   else {}),
                "rejected_corners": self.n_rejected, "iterations": self.iterations,
                "parameters": self.parameters,
                "not_identifiable": self.not_identifiable,
                "T_ptuL_from_ptuR": self.T_ptuL_from_ptuR.tolist(),
                "images": [im.to_dict() for im in self.images],
                # the head's parameters' covariance, for rasc triangulate's sigmas
                **_covariance_entry(self)}


def _covariance_entry(res) -> dict:
    from rasc.head.uncertainty import covariance_document

    doc = covariance_document(res)
    return {} if doc is None else {"covariance": doc}


GAUGE = ("each unit's ptu frame: x along its pan axis, origin at the foot of the common "
         "normal on the pan axis, tilt axis in its x-z plane at pan reading 0, encoder "
         "offsets 0; board poses of pose views in the left ptu frame; base = cyclopean "
         "frame of T_ptuL_from_ptuR (docs/METHOD.md §5, §10)")


# ----------------------------------------------------------------------------- model

def _rodrigues_batch(w: np.ndarray) -> np.ndarray:
    """exp of rotation vectors (n, 3) → (n, 3, 3), exact at 0."""
    th = np.linalg.norm(w, axis=-1)
    small = th < 1e-8
    safe = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th ** 2 / 6.0, np.sin(th) / safe)
    b = np.where(small, 0.5 - th ** 2 / 24.0, (1.0 - np.cos(th)) / safe ** 2)
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -w[..., 2], w[..., 1]
    K[..., 1, 0], K[..., 1, 2] = w[..., 2], -w[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -w[..., 1], w[..., 0]
    return np.eye(3) + a[..., None, None] * K + b[..., None, None] * (K @ K)


def _left_jacobian(w: np.ndarray) -> np.ndarray:
    """SO(3)'s left Jacobian of rotation vectors (n, 3) → (n, 3, 3):
    ``exp(w + dw) = exp(J_l(w) dw) exp(w)`` to first order;
    ``J_l = I + (1 − cos θ)/θ² [w]x + (θ − sin θ)/θ³ [w]x²`` (series below 1e-4 rad)."""
    th = np.linalg.norm(w, axis=-1)
    small = th < 1e-4
    safe = np.where(small, 1.0, th)
    a = np.where(small, 0.5 - th ** 2 / 24.0, (1.0 - np.cos(th)) / safe ** 2)
    b = np.where(small, 1.0 / 6.0 - th ** 2 / 120.0, (th - np.sin(th)) / safe ** 3)
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -w[..., 2], w[..., 1]
    K[..., 1, 0], K[..., 1, 2] = w[..., 2], -w[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -w[..., 1], w[..., 0]
    return np.eye(3) + a[..., None, None] * K + b[..., None, None] * (K @ K)


def _axis_rotation(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotations about the unit ``axis`` (3,) by ``angle`` (n,) → (n, 3, 3)."""
    c, s = np.cos(angle)[:, None, None], np.sin(angle)[:, None, None]
    Kx = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                   [-axis[1], axis[0], 0.0]])
    return c * np.eye(3) + s * Kx + (1.0 - c) * np.outer(axis, axis)


def _unit_motion(u: dict[str, float], pan: np.ndarray, tilt: np.ndarray):
    """R (n, 3, 3), t (n, 3) of T_gaze_from_ptu for the refinement's unit parameters."""
    phi = u["pan_scale"] * pan + u["pan_offset"]
    tau = u["tilt_scale"] * tilt + u["tilt_offset"]
    a = np.array([u["tilt_axis_x"], u["tilt_axis_y"], 1.0])
    a /= np.linalg.norm(a)
    q = np.array([u["tilt_point_x"], u["tilt_point_y"], u["tilt_point_z"]])
    R_tilt = _axis_rotation(a, tau)
    R_pan = _axis_rotation(np.array([1.0, 0.0, 0.0]), -phi)
    return R_tilt @ R_pan, q - R_tilt @ q


UNIT_DEFAULTS = {"pan_scale": 1.0, "tilt_scale": 1.0, "tilt_axis_x": 0.0, "tilt_axis_y": 0.0,
                 "tilt_point_x": 0.0, "tilt_point_y": 0.0, "tilt_point_z": 0.0,
                 "pan_offset": 0.0, "tilt_offset": 0.0}


def _unit_motion_of(values: np.ndarray, pan: np.ndarray, tilt: np.ndarray):
    """:func:`_unit_motion` of the unit parameters ``values`` (9,), in the order of
    :data:`UNIT_DEFAULTS` (the same numbers)."""
    return _unit_motion(dict(zip(UNIT_DEFAULTS, values, strict=True)), pan, tilt)


def unit_from_parameters(u: dict[str, float]) -> PanTiltUnit:
    """The :class:`PanTiltUnit` of the refinement's parameters (same motion)."""
    a = np.array([u["tilt_axis_x"], u["tilt_axis_y"], 1.0])
    return PanTiltUnit(tilt_axis=tuple(a / np.linalg.norm(a)),
                       tilt_point=(u["tilt_point_x"], u["tilt_point_y"], u["tilt_point_z"]),
                       pan_offset=u["pan_offset"], tilt_offset=u["tilt_offset"],
                       pan_scale=u["pan_scale"], tilt_scale=u["tilt_scale"])
