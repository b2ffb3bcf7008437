"""Whole-head refinement: every detected corner of every image, both eyes, jointly.

docs/METHOD.md §10, "Whole-head refinement". The closed form (RASC per eye, eq. 4–10,
and loop closure, eq. 11–12) is the initial guess; this module minimises the
reprojection error of every corner in every image — both eyes, the intrinsics views and
the pose views — over

* per eye: the intrinsics fx, fy, cx, cy, the distortion of the dataset's model
  (``k1k2``: k1, k2; ``opencv5``: k1 k2 p1 p2 k3; ``none``: nothing), ``T_cam_from_gaze``
  (6) and the identifiable parameters of its general pan-tilt unit
  (:class:`rasc.geometry.kinematics.PanTiltUnit`: the encoder scales, the axis angle and
  the common-normal distance);
* per head: ``T_ptuL_from_ptuR`` (6);
* per intrinsics view: its board pose ``T_cam_from_world`` (6);
* for the pose views: one board pose ``T_ptuL_from_world`` (6) shared by every pose
  image of both eyes. The target stays put while the units move, as hand-eye (eq. 4–7)
  and loop closure (eq. 11–12) already assume; sharing it ties the eyes together and
  determines ``T_ptuL_from_ptuR``. (A board pose per view, free, would let each view
  absorb the kinematics: the hand-eye would then be seen only through the other eye.)

A corner of eye e at encoder readings (φ_r, τ_r) is predicted by eq. 1–2 with the
general unit, distortion and K::

    T_cam_from_world = T_cam_from_gaze · unit.T_gaze_from_ptu(φ_r, τ_r)
                       · T_ptu_from_ptuL · T_ptuL_from_world

(``T_ptu_from_ptuL`` = I for the left eye, ``T_ptuL_from_ptuR⁻¹`` for the right).

**Gauge.** The data fix camera poses only; the frames are fixed by convention
(:func:`rasc.geometry.kinematics.canonical_gauge`): each unit's ptu frame has x along its
pan axis, its origin at the foot of the common normal on the pan axis, the tilt axis in
its x–z plane at pan reading 0 (so ``tilt_axis = (cos α, 0, sin α)``,
``tilt_point = (0, d, 0)``) and zero encoder offsets; the left ptu frame is the frame
every pose view's board pose is expressed in; the base is the cyclopean frame of
``T_ptuL_from_ptuR`` (docs/METHOD.md §5). The paper's unit is this gauge with α = 90°,
d = 0 and unit scales.

**Identifiability.** Nine candidate unit parameters per eye are tested on the Jacobian at
the initial guess, in the order of :data:`UNIT_PARAMETERS`: a candidate whose column lies
within :data:`IDENTIFIABILITY_SINE` (sine of the angle, columns normalised) of the span
of the columns already kept cannot be determined by the corners; it is named, held at
its gauge value and returned as ``None`` with the reason, never as a number. With free
mounts this always removes the encoder offsets, the tilt point along the pan and the
tilt axis, and the turn of the tilt axis about the pan axis (docs/METHOD.md §10).

**Uncertainty.** σ² (JᵀJ)⁻¹ at the optimum, with J analytic where the Levenberg–Marquardt
Jacobian is and by central differences elsewhere (see Solver), and σ² the
residual sum of squares over (m − n): the standard deviation of every estimated
parameter, valid for independent corner noise of equal variance.

**Solver.** Levenberg–Marquardt on the dense normal equations (a few hundred
parameters: a Cholesky solve of milliseconds). Its Jacobian (:meth:`_Problem.jacobian_lm`)
follows the block structure — a corner depends only on its eye's intrinsics and
kinematics, the mounts (right eye) and its own board pose: the intrinsics and every board
pose analytically (projection with distortion and K, the board's rotation through SO(3)'s
left Jacobian; within 1e-7 of central differences, tests/test_refine_jacobian.py), the
kinematic parameters by differences on their own images only (forward in the iterations,
central for the identifiability test and the covariance). That halved the forward
Jacobian's time (57 → 26 ms on the default synthetic head) and cut E7's run per case by
about a third. The difference columns that move the same images are evaluated together
(:meth:`_Problem._residuals_batch`: one projection for all of them, and the rotations and
unit motions a column leaves unchanged reused, :meth:`_Problem._cached`), with the same
numbers bit for bit: a refinement of the default dataset took 0.52 s of CPU instead of
0.70 s. :func:`_levenberg_marquardt` says why not
:func:`scipy.optimize.least_squares`, which was tried first.

**Robustness.** The soft-L1 loss with ``f_scale`` three times the corner noise (estimated
from the closed form's intrinsics RMS); after the fit, corners whose residual exceeds
both :data:`REJECT_K` robust standard deviations (1.4826 MAD) and
:data:`REJECT_FLOOR_PX` in either coordinate are rejected, reported per image, and the
fit is repeated once without them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import PanTiltUnit
from rasc.geometry.transforms import invert_transform, make_transform

#: Candidate unit parameters per eye, in the order they are admitted (observable ones
#: first): a later candidate is tested against the span of those kept before it.
#: tilt_axis_x / tilt_axis_y: the x and y components of the (unnormalised) tilt axis
#: (x, y, 1) — x sets the axis angle, y turns the axis about the pan axis;
#: tilt_point_*: the point q on the tilt axis.
UNIT_PARAMETERS = ("pan_scale", "tilt_scale", "tilt_axis_x", "tilt_point_y",
                   "tilt_point_x", "tilt_point_z", "tilt_axis_y", "pan_offset", "tilt_offset")

#: Why each parameter is not identifiable when the Jacobian says so (docs/METHOD.md §10).
REASONS = {
    "pan_offset": "a pan encoder offset turns the unit's frame about its pan axis, which the "
                  "mount (T_ptuL_from_ptuR) and the board poses absorb; it needs a measured "
                  "mount or a known home",
    "tilt_offset": "a tilt encoder offset turns the gaze frame about the tilt axis, which "
                   "T_cam_from_gaze absorbs; it needs a known home",
    "tilt_point_x": "moving the tilt axis along the pan axis commutes with the pan rotation "
                    "and is absorbed by T_cam_from_gaze and the mount",
    "tilt_point_z": "moving the point along the tilt axis changes nothing",
    "tilt_axis_y": "turning the tilt axis about the pan axis is absorbed by T_cam_from_gaze "
                   "and the mount",
    "pan_scale": "the pan readings do not vary enough to fix the pan scale",
    "tilt_scale": "the tilt readings do not vary enough to fix the tilt scale",
    "tilt_axis_x": "the motions cannot separate the axis angle from the hand-eye rotation",
    "tilt_point_y": "the motions cannot separate the axis distance from the hand-eye "
                    "translation",
}

#: A Jacobian column (normalised) within this sine of the span of the others is not
#: determined by the data. Exact gauge directions measure ≤ 1e-9 here (central
#: differences, round-off); the weakest observable unit parameter on the default dataset
#: (the pan scale from ±8° pans) measures ~1e-2. The threshold sits between, at 1e-6.
IDENTIFIABILITY_SINE = 1e-6

#: Reject corners farther than this many robust standard deviations (either coordinate)
#: and farther than REJECT_FLOOR_PX: below a tenth of a pixel a residual is the
#: detector's ordinary error (rendered corners have σ ≈ 0.01 px with heavier tails than
#: a Gaussian: 5σ alone rejected 5 % of them), not a gross error.
REJECT_K = 5.0
REJECT_FLOOR_PX = 0.1

DIST_PARAMS = {"k1k2": (0, 1), "opencv5": (0, 1, 2, 3, 4), "none": ()}
DIST_NAMES = ("k1", "k2", "p1", "p2", "k3")


# ----------------------------------------------------------------------------- inputs

@dataclass
class EyeObservations:
    """One eye's corners and closed-form initial values.

    Attributes
    ----------
    K : (3, 3); dist : (5,) k1 k2 p1 p2 k3; image_size : (width, height)
    intrinsics : dict name → corners (N, 2): the intrinsics views used
    T_cam_from_world_intrinsics : dict name → (4, 4): their initial board poses
    pose : dict file → corners (N, 2): the pose views
    pan_tilt : dict file → (pan, tilt) encoder readings in radians
    view : dict file → view id (the simultaneous board placement)
    T_cam_from_world_pose : dict file → (4, 4): per-pose extrinsics (initial values)
    T_cam_from_gaze : (4, 4) initial hand-eye (RASC)
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


@dataclass
class HeadObservations:
    """Both eyes' observations, the board's corners in its own frame (N, 3) and the
    initial ``T_ptuL_from_ptuR`` (loop closure)."""

    board_points: np.ndarray
    eyes: dict[str, EyeObservations]
    T_ptuL_from_ptuR: np.ndarray
    dist_model: str = "k1k2"


def observations_from_calibration(cal, board) -> HeadObservations:
    """The refinement's input from a closed-form :class:`rasc.head.pipeline.Calibration`
    (which keeps its detected corners)."""
    eyes = {}
    for eye in EYES:
        r = cal.eyes[eye]
        intr = r.intrinsics
        used = list(intr.T_cam_from_world)
        eyes[eye] = EyeObservations(
            K=intr.K, dist=_dist5(intr.dist), image_size=tuple(intr.image_size),
            intrinsics={n: r.corners["intrinsics"][n] for n in used},
            T_cam_from_world_intrinsics=dict(intr.T_cam_from_world),
            pose={f: r.corners["pose"][f] for f in r.pose_files},
            pan_tilt={f: (float(pt[0]), float(pt[1]))
                      for f, pt in zip(r.pose_files, r.pan_tilt, strict=True)},
            view=dict(zip(r.pose_files, r.views, strict=True)),
            T_cam_from_world_pose=dict(zip(r.pose_files, r.T_cam_from_world, strict=True)),
            T_cam_from_gaze=r.handeye.T_cam_from_gaze)
    T_loop = cal.base.get("loop_closure", {}).get("T_ptuL_from_ptuR", cal.base["T_ptuL_from_ptuR"])
    return HeadObservations(board_points=board.object_points(), eyes=eyes,
                            T_ptuL_from_ptuR=np.asarray(T_loop, float),
                            dist_model=cal.options.dist_model)


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

    def std(self, eye: str) -> dict[str, float | None]:
        """Name → standard deviation of one eye's parameters (None: not identifiable)."""
        return {k: v["std"] for k, v in self.parameters[eye].items()}

    def to_dict(self) -> dict:
        return {"gauge": self.gauge,
                "rms_before_px": self.rms_before, "rms_after_px": self.rms_after,
                "sigma_px": self.sigma, "corners": self.n_corners,
                "rms_by_role_px": self.rms_by_role, "held_at_nominal": self.held,
                "scales": self.scales,
                "rejected_corners": self.n_rejected, "iterations": self.iterations,
                "parameters": self.parameters,
                "not_identifiable": self.not_identifiable,
                "T_ptuL_from_ptuR": self.T_ptuL_from_ptuR.tolist(),
                "images": [im.to_dict() for im in self.images]}


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


class _Problem:
    """Parameter layout, residuals and Jacobian structure of one refinement."""

    def __init__(self, obs: HeadObservations, unit_free: dict[str, list[str]]):
        self.obs = obs
        self.dist_idx = DIST_PARAMS[obs.dist_model]
        P = obs.board_points
        # length scale for translations: the median camera-to-board distance
        depths = [T[2, 3] for e in obs.eyes.values()
                  for T in (*e.T_cam_from_world_intrinsics.values(),
                            *e.T_cam_from_world_pose.values())]
        L = float(np.median(depths))
        self.length_scale = L
        names, scales, x0 = [], [], []

        def add(name, value, scale):
            names.append(name)
            scales.append(scale)
            x0.append(value)

        self.eye_cols: dict[str, dict[str, int]] = {}
        for eye in EYES:
            e = obs.eyes[eye]
            start = len(names)
            for k, n in enumerate(("fx", "fy", "cx", "cy")):
                add(f"{eye}.{n}", (e.K[0, 0], e.K[1, 1], e.K[0, 2], e.K[1, 2])[k], 100.0)
            for i in self.dist_idx:
                add(f"{eye}.{DIST_NAMES[i]}", e.dist[i], 1.0)
            n_intr = len(names) - start
            for k in range(3):
                add(f"{eye}.T_cam_from_gaze.rot{'xyz'[k]}", 0.0, 0.1)
            for k in range(3):
                add(f"{eye}.T_cam_from_gaze.t{'xyz'[k]}", e.T_cam_from_gaze[k, 3], 0.1 * L)
            for n in unit_free[eye]:
                s = 0.1 * L if n.startswith("tilt_point") else (1.0 if n.endswith("scale")
                                                                 else 0.1)
                add(f"{eye}.unit.{n}", UNIT_DEFAULTS[n], s)
            self.eye_cols[eye] = {"start": start, "n_intr": n_intr, "stop": len(names)}
        self.head_start = len(names)
        for k in range(3):
            add(f"T_ptuL_from_ptuR.rot{'xyz'[k]}", 0.0, 0.1)
        for k in range(3):
            add(f"T_ptuL_from_ptuR.t{'xyz'[k]}", obs.T_ptuL_from_ptuR[k, 3], 0.1 * L)
        self.n_global = len(names)
        # board poses: rotation as a perturbation exp(w)·R0, translation absolute
        pose_R0, pose_t0, pose_names = [], [], []
        for eye in EYES:
            for n, T in obs.eyes[eye].T_cam_from_world_intrinsics.items():
                pose_names.append(f"{eye}:{n}")
                pose_R0.append(T[:3, :3])
                pose_t0.append(T[:3, 3])
        # one board pose for every pose view: the target stays put while the units move,
        # as hand-eye (eq. 4-7) and loop closure (eq. 11-12) assume; initial value from the
        # first pose image (left eye if any), with the ideal unit
        T_pLpR = obs.T_ptuL_from_ptuR
        T = None
        for eye in EYES:
            e = obs.eyes[eye]
            if not e.pose:
                continue
            f = next(iter(e.pose))
            R, t = _unit_motion(UNIT_DEFAULTS, np.array([e.pan_tilt[f][0]]),
                                np.array([e.pan_tilt[f][1]]))
            T = invert_transform(make_transform(R[0], t[0])) \
                @ invert_transform(e.T_cam_from_gaze) @ e.T_cam_from_world_pose[f]
            if eye == "right":
                T = T_pLpR @ T
            break
        if T is None:
            raise InputError("refinement: no pose images")
        pose_names.append("pose views")
        pose_R0.append(T[:3, :3])
        pose_t0.append(T[:3, 3])
        self.pose_names = pose_names
        self.pose_R0 = np.array(pose_R0)
        n_poses = len(pose_names)
        for i, pn in enumerate(pose_names):
            for k in range(3):
                add(f"board[{pn}].rot{'xyz'[k]}", 0.0, 0.1)
            for k in range(3):
                add(f"board[{pn}].t{'xyz'[k]}", pose_t0[i][k], 0.1 * L)
        self.names = names
        self.scale = np.array(scales)
        self.p0 = np.array(x0)
        self.n_poses = n_poses
        self.R0_cg = {eye: obs.eyes[eye].T_cam_from_gaze[:3, :3] for eye in EYES}
        self.R0_pLpR = T_pLpR[:3, :3]
        self.unit_free = unit_free
        # images
        img_eye, img_role, img_name, img_pose, pan, tilt, corners = [], [], [], [], [], [], []
        pose_view_index = len(pose_names) - 1
        for ei, eye in enumerate(EYES):
            e = obs.eyes[eye]
            for n, c in e.intrinsics.items():
                img_eye.append(ei)
                img_role.append(0)
                img_name.append(n)
                img_pose.append(pose_names.index(f"{eye}:{n}"))
                pan.append(0.0)
                tilt.append(0.0)
                corners.append(c)
            for f, c in e.pose.items():
                img_eye.append(ei)
                img_role.append(1)
                img_name.append(f)
                img_pose.append(pose_view_index)
                pan.append(e.pan_tilt[f][0])
                tilt.append(e.pan_tilt[f][1])
                corners.append(c)
        self.img_eye = np.array(img_eye)
        self.img_role = np.array(img_role)
        self.img_name = img_name
        self.img_pose = np.array(img_pose)
        self.pan, self.tilt = np.array(pan), np.array(tilt)
        self.corners = np.array(corners, dtype=float)          # (n_img, N, 2)
        self.P = np.asarray(P, float)
        # a partial view (ChArUco) marks the corners it does not show with NaN rows: they
        # are never part of the fit (``seen``); ``mask`` is the seen corners still kept
        self.seen = np.all(np.isfinite(self.corners), axis=-1)
        if not self.seen.all():
            self.corners[~self.seen] = 0.0
        self.mask = self.seen.copy()
        self.pose_images = {ei: np.flatnonzero((self.img_eye == ei) & (self.img_role == 1))
                            for ei in range(2)}
        # results of pure functions of a few parameters (rotations, unit motions), by the
        # bytes of their arguments: a Jacobian column changes one parameter, so most of
        # its chain is the same numbers as the last one's (see _cached)
        self._memo: dict[tuple, Any] = {}

    def _cached(self, fn, *args: np.ndarray) -> Any:
        """``fn(*args)`` (arrays), computed once for the same argument bytes (exact: the
        same input bits give the same output bits). Its arrays are made read-only: a
        caller that wrote into one would change the next call's result."""
        key = (fn, *((a.shape, a.tobytes()) for a in args))
        hit = self._memo.get(key)
        if hit is None:
            if len(self._memo) >= 256:                # a few iterations' worth
                self._memo.clear()
            hit = self._memo[key] = fn(*args)
            for a in hit if isinstance(hit, tuple) else (hit,):
                a.flags.writeable = False
        return hit

    # ---- parameters -----------------------------------------------------------------

    def unpack(self, x: np.ndarray, poses: np.ndarray | None = None) -> dict[str, Any]:
        """Parameters by name; board poses only for the indices ``poses`` (default all),
        as ``pose_R``/``pose_t`` in that order."""
        p = self.p0 + self.scale * x
        out: dict[str, Any] = {}
        for eye in EYES:
            c = self.eye_cols[eye]
            i = c["start"]
            fx, fy, cx, cy = p[i:i + 4]
            d = np.zeros(5)
            for k, j in enumerate(self.dist_idx):
                d[j] = p[i + 4 + k]
            j = i + c["n_intr"]
            R = self._cached(_rodrigues_batch, p[j:j + 3][None])[0] @ self.R0_cg[eye]
            T_cg = make_transform(R, p[j + 3:j + 6])
            u = dict(UNIT_DEFAULTS)
            for k, n in enumerate(self.unit_free[eye]):
                u[n] = p[j + 6 + k]
            out[eye] = {"K": (fx, fy, cx, cy), "dist": d, "T_cam_from_gaze": T_cg, "unit": u}
        h = self.head_start
        R = self._cached(_rodrigues_batch, p[h:h + 3][None])[0] @ self.R0_pLpR
        out["T_ptuL_from_ptuR"] = make_transform(R, p[h + 3:h + 6])
        b = p[self.n_global:].reshape(self.n_poses, 6)
        poses = np.arange(self.n_poses) if poses is None else poses
        out["pose_R"] = self._cached(_rodrigues_batch, b[poses, :3]) @ self.pose_R0[poses]
        out["pose_t"] = b[poses, 3:].copy()
        return out

    # ---- prediction -----------------------------------------------------------------

    def predict(self, x: np.ndarray, sel: np.ndarray | None = None) -> np.ndarray:
        """Predicted pixels (n_img, N, 2), or (len(sel), N, 2) for the images ``sel``."""
        sel = np.arange(len(self.img_eye)) if sel is None else sel
        return self._project(x, sel, self._chain(x, sel))[0]

    def _chain(self, x: np.ndarray, sel: np.ndarray) -> dict[str, Any]:
        """The kinematic chain of the images ``sel``: ``R`` (n, 3, 3), ``t`` (n, 3) of
        ``T_cam_from_board`` (eq. 1-2 with the general unit), ``RA`` (n, 3, 3) the rotation
        of the chain in front of the board pose (I for an intrinsics view), ``Rb``
        (n, 3, 3) the board pose's rotation and ``w`` (n, 3) its rotation vector, ``s``
        the unpacked parameters."""
        img_eye, img_role = self.img_eye[sel], self.img_role[sel]
        poses, img_pose = np.unique(self.img_pose[sel], return_inverse=True)
        s = self.unpack(x, poses)
        R = s["pose_R"][img_pose]
        t = s["pose_t"][img_pose]
        Rb = R.copy()
        RA_all = np.broadcast_to(np.eye(3), R.shape).copy()
        T_pRpL = None
        for ei, eye in enumerate(EYES):
            idx = np.flatnonzero((img_eye == ei) & (img_role == 1))
            if len(idx) == 0:
                continue
            u = s[eye]["unit"]
            Rg, tg = self._cached(_unit_motion_of, np.array([u[n] for n in UNIT_DEFAULTS]),
                                  self.pan[sel[idx]], self.tilt[sel[idx]])
            T_cg = s[eye]["T_cam_from_gaze"]
            if eye == "left":
                M = np.eye(4)
            else:
                T_pRpL = invert_transform(s["T_ptuL_from_ptuR"]) if T_pRpL is None else T_pRpL
                M = T_pRpL
            # chain A = T_cg · T_gp · M, then A · T_board
            RA = T_cg[:3, :3] @ Rg @ M[:3, :3]
            tA = (T_cg[:3, :3] @ (Rg @ M[:3, 3] + tg)[..., None])[..., 0] + T_cg[:3, 3]
            t[idx] = np.einsum("nij,nj->ni", RA, t[idx]) + tA
            R[idx] = RA @ R[idx]
            RA_all[idx] = RA
        b = (self.p0 + self.scale * x)[self.n_global:].reshape(self.n_poses, 6)
        return {"R": R, "t": t, "RA": RA_all, "Rb": Rb, "w": b[poses, :3][img_pose],
                "s": s, "img_eye": img_eye,
                "Kp": np.array([s[eye]["K"] for eye in EYES])[img_eye],      # (n, 4)
                "D": np.array([s[eye]["dist"] for eye in EYES])[img_eye]}    # (n, 5)

    def _project(self, x: np.ndarray, sel: np.ndarray, ch: dict[str, Any],
                 derivatives: bool = False):
        """Pixels (n, N, 2) of the chain ``ch`` of the images ``sel`` (eq. 1-2 with
        distortion and K; without ``derivatives`` only ``ch``'s ``R``, ``t``, ``Kp`` and
        ``D`` are used, as :meth:`_residuals_batch` passes them); with ``derivatives``
        also the analytic derivatives (each (n, N, 2, k)) of the pixels with respect to
        the camera-frame point (k = 3), to the eye's intrinsics in the layout of
        :attr:`names` (fx fy cx cy, then the distortion terms of the dataset's model) and
        to the image's board pose (k = 6: its rotation vector w, ``R = exp(w) R0``, then
        its translation), in natural units."""
        R, t = ch["R"], ch["t"]
        pc = np.einsum("nij,kj->nki", R, self.P) + t[:, None, :]
        x_, y_ = pc[..., 0] / pc[..., 2], pc[..., 1] / pc[..., 2]
        Kp, D = ch["Kp"], ch["D"]                                   # (n, 4), (n, 5)
        k1, k2, p1, p2, k3 = (D[:, i:i + 1] for i in range(5))
        r2 = x_ * x_ + y_ * y_
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        xd = x_ * radial + 2.0 * p1 * x_ * y_ + p2 * (r2 + 2.0 * x_ * x_)
        yd = y_ * radial + p1 * (r2 + 2.0 * y_ * y_) + 2.0 * p2 * x_ * y_
        fx, fy = Kp[:, 0:1], Kp[:, 1:2]
        u = fx * xd + Kp[:, 2:3]
        v = fy * yd + Kp[:, 3:4]
        uv = np.stack([u, v], axis=-1)
        if not derivatives:
            return uv, None
        # d(u, v)/d(x_, y_): the distortion's Jacobian scaled by fx, fy
        drad = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)            # d radial / d r2
        xy = x_ * y_
        dxd_dx = radial + 2.0 * x_ * x_ * drad + 2.0 * p1 * y_ + 6.0 * p2 * x_
        dyd_dy = radial + 2.0 * y_ * y_ * drad + 6.0 * p1 * y_ + 2.0 * p2 * x_
        cross = 2.0 * xy * drad + 2.0 * p1 * x_ + 2.0 * p2 * y_  # dxd/dy_ = dyd/dx_
        iz = 1.0 / pc[..., 2]
        # d(x_, y_)/d pc = [[1/Z, 0, -x_/Z], [0, 1/Z, -y_/Z]]
        J = np.empty(pc.shape[:2] + (2, 3))
        J[..., 0, 0] = fx * dxd_dx * iz
        J[..., 0, 1] = fx * cross * iz
        J[..., 0, 2] = -(J[..., 0, 0] * x_ + J[..., 0, 1] * y_)
        J[..., 1, 0] = fy * cross * iz
        J[..., 1, 1] = fy * dyd_dy * iz
        J[..., 1, 2] = -(J[..., 1, 0] * x_ + J[..., 1, 1] * y_)
        # intrinsics: fx fy cx cy, then k1 k2 p1 p2 k3 as the model has them
        full = {"k1": (fx * x_ * r2, fy * y_ * r2),
                "k2": (fx * x_ * r2 ** 2, fy * y_ * r2 ** 2),
                "p1": (fx * 2.0 * xy, fy * (r2 + 2.0 * y_ * y_)),
                "p2": (fx * (r2 + 2.0 * x_ * x_), fy * 2.0 * xy),
                "k3": (fx * x_ * r2 ** 3, fy * y_ * r2 ** 3)}
        zero, one = np.zeros_like(x_), np.ones_like(x_)
        cols = [(xd, zero), (zero, yd), (one, zero), (zero, one)]
        cols += [full[DIST_NAMES[i]] for i in self.dist_idx]
        d_intr = np.stack([np.stack(c, axis=-1) for c in cols], axis=-1)
        # board pose: q = exp(w) R0 P + t_b, pc = RA q + tA; a change dw of the rotation
        # vector turns q by J_l(w) dw (J_l: SO(3)'s left Jacobian), so
        # d pc / d w = -RA [Rb P]x J_l(w), d pc / d t_b = RA
        q = np.einsum("nij,kj->nki", ch["Rb"], self.P)          # (n, N, 3), without t_b
        Jl = _left_jacobian(ch["w"])                              # (n, 3, 3)
        neg_skew = np.zeros(q.shape + (3,))
        neg_skew[..., 0, 1], neg_skew[..., 0, 2] = q[..., 2], -q[..., 1]
        neg_skew[..., 1, 0], neg_skew[..., 1, 2] = -q[..., 2], q[..., 0]
        neg_skew[..., 2, 0], neg_skew[..., 2, 1] = q[..., 1], -q[..., 0]
        JRA = np.einsum("nkab,nbc->nkac", J, ch["RA"])            # d uv / d q
        d_board = np.concatenate(
            [np.einsum("nkab,nkbc,ncd->nkad", JRA, neg_skew, Jl), JRA], axis=-1)
        return uv, {"point": J, "intrinsics": d_intr, "board": d_board}

    def residuals_of(self, x: np.ndarray, sel: np.ndarray) -> np.ndarray:
        """Residuals of the images ``sel`` (ascending), kept corners, flattened."""
        return (self.predict(x, sel) - self.corners[sel])[self.mask[sel]].ravel()

    def _residuals_batch(self, xs: list[np.ndarray], sel: np.ndarray) -> list[np.ndarray]:
        """:meth:`residuals_of` of the images ``sel`` at each parameter vector of ``xs``:
        each chain as :meth:`_chain` builds it, then the pixels of all of them in one
        :meth:`_project`. Its arithmetic is elementwise (and a per-image einsum), so every
        number is the one a call per vector gives, bit for bit (the refined calibration
        JSON, byte for byte), for a fraction of the calls: the differences of the
        Jacobian's kinematic columns, about half of a refinement's time before."""
        chains = [self._chain(x, sel) for x in xs]
        batch = {k: np.concatenate([ch[k] for ch in chains]) for k in ("R", "t", "Kp", "D")}
        uv = self._project(None, sel, batch)[0]
        uv = uv.reshape((len(xs), len(sel)) + uv.shape[1:])
        want, keep = self.corners[sel], self.mask[sel]
        return [(u - want)[keep].ravel() for u in uv]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return (self.predict(x) - self.corners)[self.mask].ravel()

    def all_residuals(self, x: np.ndarray) -> np.ndarray:
        """(n_img, N, 2), rejected corners included."""
        return self.predict(x) - self.corners

    # ---- Jacobian -------------------------------------------------------------------

    def column_images(self) -> list[np.ndarray]:
        """For every parameter, the images whose corners it moves."""
        cols = []
        for ei, eye in enumerate(EYES):
            c = self.eye_cols[eye]
            all_e = np.flatnonzero(self.img_eye == ei)
            cols += [all_e] * c["n_intr"]
            cols += [self.pose_images[ei]] * (c["stop"] - c["start"] - c["n_intr"])
        cols += [self.pose_images[1]] * 6
        for i in range(self.n_poses):
            cols += [np.flatnonzero(self.img_pose == i)] * 6
        return cols

    def _rows_of_images(self) -> list[np.ndarray]:
        counts = self.mask.sum(axis=1) * 2
        ends = np.cumsum(counts)
        return [np.arange(e - c, e) for c, e in zip(counts, ends, strict=True)]

    def jacobian(self, x: np.ndarray, h: float = 1e-5, central: bool = True,
                 r0: np.ndarray | None = None, analytic: bool = True) -> sp.csr_matrix:
        """The Jacobian of :meth:`residuals` with respect to ``x`` (sparse, (2M, n)).

        ``analytic`` (default): the intrinsics and board-pose columns analytically, the
        kinematic ones by differences (:meth:`jacobian_lm`). Otherwise finite differences
        over the block structure: one evaluation (pair, when ``central``) per global
        parameter, on the images it moves only, and one per board-pose coordinate for all
        boards at once (their corners are disjoint). Central: truncation error ~h² (1e-10
        relative), for the identifiability test and the covariance; forward (with ``r0``,
        the residuals at x): for the iterations."""
        if analytic:
            return self.jacobian_lm(x, self.residuals(x) if r0 is None and not central
                                    else r0, h=h, central=central)
        rows_of = self._rows_of_images()
        n = len(self.names)
        col_imgs = self.column_images()
        groups = [[j] for j in range(self.n_global)]
        for k in range(6):
            groups.append([self.n_global + 6 * i + k for i in range(self.n_poses)])
        if not central and r0 is None:
            r0 = self.residuals(x)
        data_r, data_c, data_v = [], [], []
        for g in groups:
            imgs = np.unique(np.concatenate([col_imgs[j] for j in g]))
            if len(imgs) == 0:
                continue
            rows = np.concatenate([rows_of[i] for i in imgs])
            dx = np.zeros(n)
            dx[g] = h
            if central:
                d = (self.residuals_of(x + dx, imgs) - self.residuals_of(x - dx, imgs)) / (2 * h)
            else:
                d = (self.residuals_of(x + dx, imgs) - r0[rows]) / h
            local = np.full(rows.max() + 1 if len(rows) else 0, -1)
            local[rows] = np.arange(len(rows))
            for j in g:
                r = np.concatenate([rows_of[i] for i in col_imgs[j]]) if len(col_imgs[j]) \
                    else np.zeros(0, int)
                data_r.append(r)
                data_c.append(np.full(len(r), j))
                data_v.append(d[local[r]])
        m = int(self.mask.sum()) * 2
        return sp.csr_matrix((np.concatenate(data_v),
                              (np.concatenate(data_r), np.concatenate(data_c))), shape=(m, n))


    def jacobian_lm(self, x: np.ndarray, r0: np.ndarray | None, h: float = 1e-6,
                    central: bool = False) -> sp.csr_matrix:
        """The Jacobian with the intrinsics and every board pose analytically
        (:meth:`_project`: projection with distortion and K, chained through the board's
        rotation by SO(3)'s left Jacobian), the kinematic parameters (hand-eye, unit,
        mounts) by differences on their own images as in :meth:`jacobian`: forward from
        ``r0`` (the residuals at ``x``; the iterations) or ``central`` (the
        identifiability test, the covariance). The same matrix as ``jacobian(...,
        analytic=False)`` up to the differences' error (tests/test_refine_jacobian.py)."""
        n_img = len(self.img_eye)
        everything = np.arange(n_img)
        _, d = self._project(x, everything, self._chain(x, everything), derivatives=True)
        mask = self.mask
        rows_of = self._rows_of_images()
        n = len(self.names)
        data_r, data_c, data_v = [], [], []
        # analytic blocks: rows in residual order (image, kept corner, u/v)
        row_img = np.repeat(np.arange(n_img), mask.sum(axis=1) * 2)
        intr = d["intrinsics"][mask].reshape(-1, d["intrinsics"].shape[-1])   # (2M, ni)
        board = d["board"][mask].reshape(-1, 6)                              # (2M, 6)
        all_rows = np.arange(len(row_img))
        for ei, eye in enumerate(EYES):
            c = self.eye_cols[eye]
            rows = all_rows[self.img_eye[row_img] == ei]
            for k in range(c["n_intr"]):
                j = c["start"] + k
                data_r.append(rows)
                data_c.append(np.full(len(rows), j))
                data_v.append(intr[rows, k] * self.scale[j])
        pose_of_row = self.img_pose[row_img]
        for k in range(6):
            cols = self.n_global + 6 * pose_of_row + k
            data_r.append(all_rows)
            data_c.append(cols)
            data_v.append(board[:, k] * self.scale[cols])
        # forward differences: the kinematic globals, each on the images it moves; the
        # columns that move the same images evaluated together (_residuals_batch)
        col_imgs = self.column_images()
        intr_cols = {self.eye_cols[eye]["start"] + k for eye in EYES
                     for k in range(self.eye_cols[eye]["n_intr"])}
        kinematic = [j for j in range(self.n_global)
                     if j not in intr_cols and len(col_imgs[j])]
        by_images: dict[bytes, list[int]] = {}
        for j in kinematic:
            by_images.setdefault(col_imgs[j].tobytes(), []).append(j)
        columns = {}                              # j -> (the rows it moves, its values)
        for cols in by_images.values():
            imgs = col_imgs[cols[0]]
            rows = np.concatenate([rows_of[i] for i in imgs])
            xs = []
            for j in cols:
                dx = np.zeros(n)
                dx[j] = h
                xs += [x + dx, x - dx] if central else [x + dx]
            res = self._residuals_batch(xs, imgs)
            for k, j in enumerate(cols):
                columns[j] = (rows, (res[2 * k] - res[2 * k + 1]) / (2 * h) if central
                              else (res[k] - r0[rows]) / h)
        for j in kinematic:                       # in column order, as before
            rows, values = columns[j]
            data_r.append(rows)
            data_c.append(np.full(len(rows), j))
            data_v.append(values)
        m = int(mask.sum()) * 2
        return sp.csr_matrix((np.concatenate(data_v),
                              (np.concatenate(data_r), np.concatenate(data_c))), shape=(m, n))


# ----------------------------------------------------------------------------- identifiability

def _identifiable(obs: HeadObservations, hold: tuple[str, ...] = ()
                  ) -> tuple[dict[str, list[str]], list[dict[str, Any]]]:
    """Decide, from the Jacobian at the initial guess, which unit parameters the corners
    determine (see the module docstring); ``hold``: candidates not estimated at all.
    Raises :class:`DegenerateDataError` when the basic parameters (intrinsics, hand-eye,
    mounts, board poses) are not determined."""
    candidates = [n for n in UNIT_PARAMETERS if n not in hold]
    full = {eye: list(candidates) for eye in EYES}
    prob = _Problem(obs, full)
    J = prob.jacobian(np.zeros(len(prob.names)))
    d = np.sqrt(np.asarray(J.multiply(J).sum(axis=0)).ravel())
    unit_cols = {}
    for eye in EYES:
        c = prob.eye_cols[eye]
        first = c["start"] + c["n_intr"] + 6
        for k, n in enumerate(candidates):
            unit_cols[(eye, n)] = first + k
    for j in range(len(prob.names)):
        if d[j] == 0 and j not in set(unit_cols.values()):
            raise DegenerateDataError(f"refinement: parameter {prob.names[j]} moves no corner")
    Jn = (J @ sp.diags(1.0 / np.where(d > 0, d, 1.0))).tocsc()
    # The intrinsics views' board poses act on their own image's rows only: project each
    # image's rows onto the complement of its six pose columns (a 2N x 6 QR each), which
    # leaves the angles between the remaining columns and the span of all the others
    # unchanged; then one QR of the global columns (intrinsics, hand-eye, mounts, the pose
    # views' board pose) — no dense QR of the whole Jacobian, and no squared condition
    # number as with JᵀJ.
    glob = list(range(prob.n_global)) + list(range(len(prob.names) - 6, len(prob.names)))
    G = Jn[:, glob].toarray()
    rows_of = prob._rows_of_images()
    for i in np.flatnonzero(prob.img_role == 0):
        k = prob.n_global + 6 * int(prob.img_pose[i])
        rows = rows_of[i]
        B = Jn[rows][:, k:k + 6].toarray()
        Qi, Ri = np.linalg.qr(B)
        if np.abs(np.diag(Ri)).min() < IDENTIFIABILITY_SINE:
            raise DegenerateDataError(f"refinement: the board pose of intrinsics view "
                                      f"{prob.img_name[i]} is not determined by its corners")
        G[rows] -= Qi @ (Qi.T @ G[rows])
    col = {j: m for m, j in enumerate(glob)}
    base = [col[j] for j in glob if j not in set(unit_cols.values())]
    Q, Rq = np.linalg.qr(G[:, base])
    rdiag = np.abs(np.diag(Rq))
    if rdiag.min() < IDENTIFIABILITY_SINE:
        j = glob[base[int(np.argmin(rdiag))]]
        raise DegenerateDataError(
            f"refinement: the corners cannot determine {prob.names[j]} (and the parameters "
            "it trades with); add pose views that turn about both axes and intrinsics "
            "views tilted 20-45 degrees")
    free: dict[str, list[str]] = {eye: [] for eye in EYES}
    dropped = []
    for eye in EYES:
        for n in candidates:
            j = unit_cols[(eye, n)]
            v = G[:, col[j]]
            r = v - Q @ (Q.T @ v)
            r -= Q @ (Q.T @ r)                       # re-orthogonalise once
            sine = float(np.linalg.norm(r)) if d[j] > 0 else 0.0
            if sine < IDENTIFIABILITY_SINE:
                dropped.append({"eye": eye, "parameter": n, "reason": REASONS[n],
                                "sine": sine})
            else:
                Q = np.column_stack([Q, r / sine])
                free[eye].append(n)
    return free, dropped


# ----------------------------------------------------------------------------- the fit

def _soft_l1(r: np.ndarray, f: float) -> tuple[float, np.ndarray]:
    """Cost ½ f² Σ 2(√(1 + (r/f)²) − 1) and the IRLS weights 1/√(1 + (r/f)²)."""
    z = (r / f) ** 2
    s = np.sqrt(1.0 + z)
    return float(f * f * np.sum(s - 1.0)), 1.0 / s


def _levenberg_marquardt(prob: _Problem, x: np.ndarray, *, f_scale: float,
                         max_iter: int = 100) -> tuple[np.ndarray, int]:
    """Minimise the soft-L1 cost of ``prob``'s residuals from ``x``.

    Levenberg–Marquardt on the normal equations: each step solves the dense n × n system
    (JᵀWJ + λ·diag(JᵀWJ)) δ = −JᵀWr (W: iteratively reweighted soft-L1 weights) by
    Cholesky. n is a few hundred (six per board pose), so this direct solve takes
    milliseconds; scipy.optimize.least_squares' sparse path (trf + LSMR, tried first with
    the same jac_sparsity) needs hundreds of LSMR iterations per step on this
    ill-conditioned problem: 3.9-5 s on the default dataset against 2 s for the whole
    refinement here. Stops when the cost falls by less than 1e-9 relative or the step
    is below 1e-6 (scaled units). Returns (x, iterations).
    """
    from scipy.linalg import cho_factor, cho_solve

    # (called within one BLAS thread, see refine_head)
    r = prob.residuals(x)
    cost, w = _soft_l1(r, f_scale)
    lam = 1e-4
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007  (it is returned)
        J = prob.jacobian_lm(x, r, h=1e-6)
        sw = np.sqrt(w)
        Jw = sp.diags(sw) @ J
        H = (Jw.T @ Jw).toarray()
        g = Jw.T @ (sw * r)
        dH = np.diag(H).copy()
        dH[dH == 0] = 1.0
        improved = False
        while lam < 1e12:
            try:
                step = -cho_solve(cho_factor(H + lam * np.diag(dH)), g)
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            r_new = prob.residuals(x + step)
            cost_new, w_new = _soft_l1(r_new, f_scale)
            if np.isfinite(cost_new) and cost_new < cost:
                improved = True
                break
            lam *= 10.0
        if not improved:
            break
        x = x + step
        # converged: the cost falls by less than 1e-9 of itself, or no parameter moves by
        # more than 1e-6 of its scale (1e-4 px, 1e-7 rad, 1e-7 of the board distance):
        # both far below any standard deviation here
        done = (cost - cost_new) < 1e-9 * cost or np.max(np.abs(step)) < 1e-6
        r, cost, w = r_new, cost_new, w_new
        lam = max(lam / 10.0, 1e-12)
        if done:
            break
    return x, it


#: The unit parameters ``estimate_scales=False`` holds at their nominal value (1). The
#: paper's ±8° pose views fix an encoder scale to ~2e-4 (1σ, measured on renders), and
#: between two eyes verging at 1.7 m that uncertainty moves triangulated depth by
#: ~0.3 mm: on the default renders the triangulation mean error was 0.45-0.57 mm with the
#: scales estimated against 0.16-0.25 mm held (ideal head), 0.41-0.55 against
#: 0.22-0.34 mm (30 mm offset). But a scale error that is held hides in the hand-eye
#: almost without a trace (pan scale 1.01 held: 10 mm hand-eye error, pose-view RMS up by
#: only 17 %), so they are estimated unless the encoders are known to be exact.
SCALES = ("pan_scale", "tilt_scale")


def refine_head(obs: HeadObservations, *, sigma0: float | None = None,
                reject_k: float = REJECT_K, max_iter: int = 100,
                estimate_scales: bool = True,
                start: RefinementResult | None = None) -> RefinementResult:
    """Refine the whole head from its corners (see the module docstring).

    Parameters
    ----------
    obs : HeadObservations
        Corners and the closed form's initial values.
    sigma0 : float, optional
        Expected corner noise per coordinate (px) for the robust loss's scale; default
        from the intrinsics views' residuals at the initial guess.
    reject_k : float
        Rejection threshold in robust standard deviations.
    estimate_scales : bool
        Estimate the encoder scales (default); False holds them at 1 (:data:`SCALES`).
    start : RefinementResult, optional
        A refinement of the same observations to start from (its identifiability test,
        parameter values and kept corners are re-used).

    Returns
    -------
    RefinementResult

    Raises
    ------
    DegenerateDataError
        The corners cannot determine the basic parameters.
    """
    from threadpoolctl import threadpool_limits

    # One BLAS thread: the dense solves here are a few hundred wide, where waking a
    # second thread on a busy 2-core machine was measured to cost 0.3-0.5 s per solve
    # (against 1 ms on one thread).
    with threadpool_limits(1, user_api="blas"):
        return _refine_head(obs, sigma0=sigma0, reject_k=reject_k, max_iter=max_iter,
                            hold=() if estimate_scales else SCALES, start=start)


def _refine_head(obs: HeadObservations, *, sigma0, reject_k, max_iter,
                 hold: tuple[str, ...], start: RefinementResult | None = None
                 ) -> RefinementResult:
    t_start = time.perf_counter()
    if obs.dist_model not in DIST_PARAMS:
        raise InputError(f"refinement: unknown dist_model {obs.dist_model!r}")
    if start is not None and start.identifiability is not None:
        # the same data: the null directions are the same; only the held ones differ
        free_all, dropped = start.identifiability
    else:
        free_all, dropped = _identifiable(obs, ())
    free = {eye: [n for n in names if n not in hold] for eye, names in free_all.items()}
    prob = _Problem(obs, free)
    x0 = np.zeros(len(prob.names))
    r0 = prob.all_residuals(x0)
    if prob.seen.all():
        rms_before = float(np.sqrt(np.mean(np.sum(r0 ** 2, axis=-1))))
        intr = r0[prob.img_role == 0]
    else:                        # partial views: only the corners they show
        rms_before = float(np.sqrt(np.mean(np.sum(r0[prob.seen] ** 2, axis=-1))))
        intr = r0[prob.seen & (prob.img_role == 0)[:, None]]
    if sigma0 is None:
        sigma0 = float(np.sqrt(np.mean(intr ** 2))) if intr.size else 0.1
    sigma0 = max(sigma0, 1e-3)
    iterations = 0
    x = x0.copy()
    if start is not None:
        # warm start from another refinement of the same observations (same initial
        # rotations, so every parameter, perturbations included, carries over by name)
        known = dict(zip(start.names, start.values, strict=True))
        for j, name in enumerate(prob.names):
            if name in known:
                x[j] = (known[name] - prob.p0[j]) / prob.scale[j]
        if start.kept is not None:
            prob.mask &= start.kept
    for _ in range(2):   # fit; reject; refit once without the rejected corners
        x, nit = _levenberg_marquardt(prob, x, f_scale=3.0 * sigma0, max_iter=max_iter)
        iterations += nit
        r = prob.all_residuals(x)
        kept_r = r[prob.mask]
        sig = 1.4826 * float(np.median(np.abs(kept_r - np.median(kept_r, axis=0))))
        bad = np.any(np.abs(r) > max(reject_k * sig, REJECT_FLOOR_PX), axis=-1) & prob.mask
        if not bad.any():
            break
        prob.mask &= ~bad
    # uncertainty: σ² (JᵀJ)⁻¹, J by central differences, plain least squares at the optimum
    r = prob.all_residuals(x)
    rk = r[prob.mask]
    m, n = rk.size, len(prob.names)
    dof = int(m - n)
    sigma = float(np.sqrt(np.sum(rk ** 2) / max(m - n, 1)))
    J = prob.jacobian(x)
    G = (J.T @ J).toarray()
    D = np.sqrt(np.diag(G))
    cov_x = np.linalg.inv(G / np.outer(D, D)) / np.outer(D, D) * sigma ** 2
    cov = cov_x * np.outer(prob.scale, prob.scale)
    std = np.sqrt(np.diag(cov))
    p = prob.p0 + prob.scale * x
    s = prob.unpack(x)
    # parameters, by eye, in natural units
    params: dict[str, dict[str, dict[str, Any]]] = {eye: {} for eye in EYES}
    params["head"] = {}
    unit_of = {"fx": "px", "fy": "px", "cx": "px", "cy": "px"}
    for j, name in enumerate(prob.names[:prob.n_global]):
        group, _, pname = name.partition(".")
        if group not in params:
            group, pname = "head", name
        if ".rot" in pname:
            # a small rotation about this axis (left perturbation): the refined rotation
            # itself is in the transform, reported whole
            entry = {"value": None, "std": float(np.degrees(std[j])), "unit": "deg",
                     "note": "std of a small rotation about this axis; the value is the "
                             "transform's rotation"}
        else:
            u = unit_of.get(pname, "length" if (".t" in pname or "tilt_point" in pname)
                            else ("rad" if pname.startswith("unit.") and
                                  ("axis" in pname or "offset" in pname) else "1"))
            entry = {"value": float(p[j]), "std": float(std[j]), "unit": u}
        params[group][pname] = entry
    for eye in EYES:
        uv = s[eye]["unit"]
        a = np.array([uv["tilt_axis_x"], uv["tilt_axis_y"], 1.0])
        a /= np.linalg.norm(a)
        # derived: non-orthogonality (deg) and its std from tilt_axis_x
        key = "unit.tilt_axis_x"
        if key in params[eye]:
            ax = params[eye][key]["value"]
            dangle = 1.0 / (1.0 + ax * ax)       # d asin(ax/sqrt(1+ax²))/d ax (ay = 0)
            params[eye]["unit.axis_angle_deg"] = {
                "value": float(90.0 - np.degrees(np.arcsin(a[0]))),
                "std": float(np.degrees(dangle * params[eye][key]["std"])), "unit": "deg"}
        for dd in dropped:
            if dd["eye"] == eye:
                params[eye][f"unit.{dd['parameter']}"] = {"value": None, "std": None,
                                                          "reason": dd["reason"]}
        for n in hold:
            params[eye][f"unit.{n}"] = {"value": UNIT_DEFAULTS[n], "std": None, "unit": "1",
                                        "held": "nominal, not estimated (--scales)"}
    # per-image residuals
    images = []
    residuals: dict[str, list[np.ndarray]] = {eye: [] for eye in EYES}
    for i, name in enumerate(prob.img_name):
        keep = prob.mask[i]
        ri = r[i][keep]
        eye = EYES[prob.img_eye[i]]
        residuals[eye].append(ri)
        nrm = np.linalg.norm(ri, axis=1)
        images.append(ImageResidual(
            eye=eye, role="intrinsics" if prob.img_role[i] == 0 else "pose", name=name,
            rms=float(np.sqrt(np.mean(nrm ** 2))) if len(nrm) else float("nan"),
            max=float(nrm.max()) if len(nrm) else float("nan"),
            rejected=[int(k) for k in np.flatnonzero(~keep & prob.seen[i])]))
    rms_after = float(np.sqrt(np.mean(np.sum(rk.reshape(-1, 2) ** 2, axis=-1))))
    rms_role = {}
    for role, code in (("intrinsics", 0), ("pose", 1)):
        sel = prob.mask & (prob.img_role == code)[:, None]
        rms_role[role] = float(np.sqrt(np.mean(np.sum(r[sel] ** 2, axis=-1)))) \
            if sel.any() else float("nan")
    return RefinementResult(
        rms_by_role=rms_role, held=list(hold), rss=float(np.sum(rk ** 2)), dof=dof,
        kept=prob.mask.copy(),
        K={eye: np.array([[s[eye]["K"][0], 0, s[eye]["K"][2]], [0, s[eye]["K"][1],
                                                                 s[eye]["K"][3]], [0, 0, 1.0]])
           for eye in EYES},
        dist={eye: s[eye]["dist"] for eye in EYES},
        T_cam_from_gaze={eye: s[eye]["T_cam_from_gaze"] for eye in EYES},
        unit={eye: unit_from_parameters(s[eye]["unit"]) for eye in EYES},
        T_ptuL_from_ptuR=s["T_ptuL_from_ptuR"], parameters=params,
        not_identifiable=dropped, rms_before=rms_before, rms_after=rms_after, sigma=sigma,
        images=images, n_corners=int(prob.seen.sum()),
        n_rejected=int((prob.seen & ~prob.mask).sum()),
        iterations=iterations, seconds=time.perf_counter() - t_start, gauge=GAUGE,
        residuals={eye: np.concatenate(v) if v else np.zeros((0, 2))
                   for eye, v in residuals.items()},
        covariance=cov, names=list(prob.names), values=p.copy(),
        identifiability=(free_all, dropped))


__all__ = ["EyeObservations", "HeadObservations", "RefinementResult", "refine_head",
           "observations_from_calibration", "unit_from_parameters", "UNIT_PARAMETERS",
           "IDENTIFIABILITY_SINE", "REJECT_K", "GAUGE"]
