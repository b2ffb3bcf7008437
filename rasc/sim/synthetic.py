"""A stereo head as projected corners: no rendering, exact truth, seeded pixel noise.

For testing and measuring calibration code where rendering would only add time: the
board's corners are projected through a known head (intrinsics, distortion,
``T_cam_from_gaze``, a general :class:`~rasc.geometry.kinematics.PanTiltUnit`,
``T_ptu_from_base``), and Gaussian noise of ``noise_px`` (per coordinate) is added. The
geometry follows the default rendered dataset (``rasc render``): a 9×6 board of 5 cm
squares, 1280×960 cameras with fx ≈ 1150 px, units 0.3 m apart, 20 intrinsics views per
eye placed as :func:`rasc.sim.render.intrinsics_board_poses` places them, the paper's nine
pan-tilt positions with the board facing the head 1 m ahead.

:func:`corner_dataset` returns rasc's one dataset class,
:class:`rasc.vision.dataset.Dataset`, holding the corners instead of images
(:meth:`~rasc.vision.dataset.Dataset.with_corners`) and the head as its ``truth``, so the
whole pipeline runs on it unchanged. ``CornerDataset``, the class it used to return, is
that class under its old name (deprecated).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rasc.geometry import lens
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import IDEAL, PAPER_POSES_DEG, PanTiltUnit
from rasc.geometry.transforms import invert_transform, make_transform, matrix_from_rotvec
from rasc.sim.render import intrinsics_board_poses, wide_lens
from rasc.sim.scene import T_base_from_world_facing
from rasc.vision.board import MIN_VIEW_CORNERS, Board
from rasc.vision.dataset import Dataset, ImageEntry

IMAGE_SIZE = (1280, 960)
BOARD = Board((9, 6), 0.05)
#: camera axes in gaze axes when looking straight ahead: cam x = −gaze z (right),
#: cam y = −gaze x (down), cam z = gaze y (forward)
R_CAM_FROM_GAZE_NOMINAL = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


@dataclass
class SyntheticHead:
    """The true head. Lengths in metres, angles in radians."""

    K: dict[str, np.ndarray]
    dist: dict[str, np.ndarray]
    T_cam_from_gaze: dict[str, np.ndarray]
    T_ptu_from_base: dict[str, np.ndarray]
    unit: dict[str, PanTiltUnit]
    #: eye → lens model (:data:`rasc.geometry.lens.LENS_MODELS`); None: pinhole for both
    lens: dict[str, str] | None = None

    def lens_model(self, eye: str) -> str:
        """The eye's lens model (``"pinhole"`` unless :attr:`lens` names another)."""
        return "pinhole" if self.lens is None else self.lens[eye]

    def T_cam_from_base(self, eye: str, pan: float, tilt: float) -> np.ndarray:
        """The camera's pose in the base frame at readings (pan, tilt), radians (eq. 1–2)."""
        return (self.T_cam_from_gaze[eye] @ self.unit[eye].T_gaze_from_ptu(pan, tilt)
                @ self.T_ptu_from_base[eye])

    def T_ptuL_from_ptuR(self) -> np.ndarray:
        """The right unit's frame in the left unit's frame (the true mounts)."""
        return self.T_ptu_from_base["left"] @ invert_transform(self.T_ptu_from_base["right"])


def default_head(unit: PanTiltUnit | dict[str, PanTiltUnit] = IDEAL,
                 dist=(-0.05, 0.02, 0.0, 0.0, 0.0)) -> SyntheticHead:
    """A head like the simulated one (hand-eye off nominal by ~2° and a few cm)."""
    units = unit if isinstance(unit, dict) else {eye: unit for eye in EYES}
    K = {"left": np.array([[1152.0, 0, 636.0], [0, 1148.5, 483.75], [0, 0, 1]]),
         "right": np.array([[1149.0, 0, 641.5], [0, 1151.0, 478.0], [0, 0, 1]])}
    T_cg = {"left": make_transform(matrix_from_rotvec([0.02, -0.015, 0.03])
                                   @ R_CAM_FROM_GAZE_NOMINAL, [0.022, 0.047, -0.036]),
            "right": make_transform(matrix_from_rotvec([-0.01, 0.025, -0.02])
                                    @ R_CAM_FROM_GAZE_NOMINAL, [-0.018, 0.052, -0.041])}
    T_pb = {"left": make_transform(matrix_from_rotvec([0.0046, 0.0091, -0.0082]),
                                   [-0.0014, 0.0007, -0.15]),
            "right": make_transform(matrix_from_rotvec([-0.0046, -0.0091, 0.0082]),
                                    [0.0014, -0.0007, 0.15])}
    return SyntheticHead(K=K, dist={eye: np.asarray(dist, float) for eye in EYES},
                         T_cam_from_gaze=T_cg, T_ptu_from_base=T_pb, unit=units)


#: The fisheye head of :func:`fisheye_head`: focal length (px) and k1-k4 (cv2.fisheye).
#: f = 420 px on 1280×960: the image's half-width is 640/420 = 1.52 rad of θ_d, so the
#: field of view is about 170° across, 130° up-down (the lens's distortion included).
FISHEYE_FOCAL_PX = 420.0
FISHEYE_DIST = (0.02, -0.01, 0.003, -0.0005)


def fisheye_head(unit: PanTiltUnit | dict[str, PanTiltUnit] = IDEAL,
                 focal_px: float = FISHEYE_FOCAL_PX, dist=FISHEYE_DIST) -> SyntheticHead:
    """:func:`default_head` with a fisheye lens (OpenCV's equidistant model) on both eyes:
    focal length ``focal_px`` (default 420 px: about 170° × 130° on 1280×960),
    coefficients ``dist`` (k1 k2 k3 k4)."""
    head = default_head(unit)
    K = {eye: np.array([[focal_px, 0, k[0, 2]], [0, focal_px, k[1, 2]], [0, 0, 1]])
         for eye, k in head.K.items()}
    return SyntheticHead(K=K, dist={eye: np.asarray(dist, float) for eye in EYES},
                         T_cam_from_gaze=head.T_cam_from_gaze,
                         T_ptu_from_base=head.T_ptu_from_base, unit=head.unit,
                         lens={eye: "fisheye" for eye in EYES})


#: The wide rational lens of :func:`rational_head` (OpenCV's k1 k2 p1 p2 k3 k4 k5 k6) at
#: :data:`RATIONAL_FOCAL_PX`: the radial factor falls from 1 to 0.62 at 63° off axis,
#: about 130° across the image's diagonal. The rational model is meant for such lenses:
#: on a 60° lens its numerator and denominator trade (OpenCV's estimate ran to k2 ≈ 100
#: on the default head with k4-k6 added, and the refinement could not start from it).
RATIONAL_DIST = (0.5, 0.1, 2e-4, -1e-4, 0.0, 0.8, 0.2, 0.0)
RATIONAL_FOCAL_PX = 600.0


def rational_head(unit: PanTiltUnit | dict[str, PanTiltUnit] = IDEAL,
                  focal_px: float = RATIONAL_FOCAL_PX, dist=RATIONAL_DIST) -> SyntheticHead:
    """:func:`default_head` with a wide pinhole lens of OpenCV's rational model: focal
    length ``focal_px`` (default 600 px), coefficients ``dist`` (8)."""
    head = default_head(unit, dist=dist)
    for K in head.K.values():
        K[0, 0] = K[1, 1] = focal_px
    return head


def corner_dataset(head: SyntheticHead | None = None, *, seed: int = 0,
                   noise_px: float = 0.03, n_intrinsics: int = 20,
                   poses_deg=PAPER_POSES_DEG, target_distance: float = 1.0,
                   board: Board = BOARD, min_corners: int = MIN_VIEW_CORNERS) -> Dataset:
    """Project the board through ``head`` (default :func:`default_head`) with seeded
    noise N(0, noise_px²) on both coordinates of every corner: a
    :class:`rasc.vision.dataset.Dataset` of given corners (no images; ``sizes`` the
    cameras'), its ``truth`` the head (:class:`SyntheticHead`).

    A target seen in part (ChArUco, :class:`rasc.vision.board.CharucoBoard`) keeps the
    corners inside the image (NaN rows for the others, as detection gives them); a pose
    view with fewer than ``min_corners`` is left out (``not_found``).

    The intrinsics views' poses and the noise are drawn from
    ``np.random.default_rng(seed)``; the same seed gives the same corners.
    """
    head = head or default_head()
    rng = np.random.default_rng(seed)
    P = board.object_points()
    T_bw = T_base_from_world_facing(board, distance=target_distance)

    partial = getattr(board, "partial_views", False)

    def project(eye, T_cw):
        p_cam = P @ T_cw[:3, :3].T + T_cw[:3, 3]
        model = head.lens_model(eye)
        if not partial:
            uv = lens.project_points(p_cam, head.K[eye], head.dist[eye], model=model)
            return uv + rng.normal(0.0, noise_px, uv.shape)
        # a target seen in part: the corners inside the image, NaN the rest
        front = p_cam[:, 2] > 0.05
        uv = np.full((len(P), 2), np.nan)
        if front.any():
            uv[front] = lens.project_points(p_cam[front], head.K[eye], head.dist[eye],
                                            model=model)
        uv = uv + rng.normal(0.0, noise_px, uv.shape)
        w, h = IMAGE_SIZE
        with np.errstate(invalid="ignore"):
            out = ~front | np.any(~(uv >= 0), axis=1) | (uv[:, 0] > w - 1) | (uv[:, 1] > h - 1)
        uv[out] = np.nan
        if int((~out).sum()) < min_corners:
            return None
        return uv

    entries: list[ImageEntry] = []
    corners: dict[str, np.ndarray | None] = {}

    def add(file: str, uv, eye: str, role: str, **reading) -> None:
        corners[file] = uv
        entries.append(ImageEntry(index=len(entries), file=file, path=Path(file), eye=eye,
                                  role=role, **reading))

    for eye in EYES:
        placed = intrinsics_board_poses(rng, board, head.K[eye], IMAGE_SIZE, n_intrinsics,
                                        head.dist[eye], wide_lens(head.lens_model(eye)))
        for k, T_cw in enumerate(placed):
            add(f"intrinsics/{eye}_{k:03d}.png", project(eye, T_cw), eye, "intrinsics")
    for eye in EYES:
        for k, (pan_deg, tilt_deg) in enumerate(poses_deg):
            pan, tilt = np.radians(pan_deg), np.radians(tilt_deg)
            T_cw = head.T_cam_from_base(eye, pan, tilt) @ T_bw
            # a view with fewer than min_corners is not seen (None), as detection has it
            add(f"poses/{eye}_{k:02d}.png", project(eye, T_cw), eye, "pose",
                pan=float(pan), tilt=float(tilt), view=f"{k:02d}")
    return Dataset.with_corners(board, entries, corners, {eye: IMAGE_SIZE for eye in EYES},
                                truth=head, where="<synthetic corners>")


def continuous_corner_dataset(head: SyntheticHead | None = None, *, seed: int = 0,
                              noise_px: float = 0.03, n_intrinsics: int = 20,
                              poses_deg=PAPER_POSES_DEG, speed_deg_s: float = 20.0,
                              frame_rate: float = 10.0, clock_offset: float = 0.0,
                              joint_rate: float = 200.0, clock_jitter: float = 0.0,
                              target_distance: float = 1.0, board: Board = BOARD) -> Dataset:
    """A continuous capture as projected corners: the head never stops, moving through
    ``poses_deg`` by :class:`rasc.sim.motion.Trajectory` (minimum-jerk motions at a peak
    of ``speed_deg_s``), both cameras taking a frame every 1/``frame_rate`` s (stamped on
    the camera clock: the trajectory's time), the joint stream sampled at ``joint_rate``
    Hz on the encoder clock = camera clock + ``clock_offset`` δ (with ``clock_jitter``,
    :func:`rasc.sim.motion.sample_joint_stream`). Each pose image is projected at the
    head's true angles at its time; its ``pan``/``tilt`` are the stream at its time with
    δ = 0 (as the dataset format has them) and its ``time`` is its stamp; the dataset's
    ``joint_stream`` is the stream. Sharp frames (no blur: a corner is where the head is
    at mid-exposure). The intrinsics views are :func:`corner_dataset`'s.
    ``truth``: the head (δ is the caller's ``clock_offset``)."""
    import dataclasses

    from rasc.sim.motion import Trajectory, frame_times, sample_joint_stream

    head = head or default_head()
    still = corner_dataset(head, seed=seed, noise_px=noise_px, n_intrinsics=n_intrinsics,
                           poses_deg=(), board=board)
    rng = np.random.default_rng([seed, 1])
    traj = Trajectory(np.radians(np.asarray(poses_deg, float)), speed_deg_s)
    times = frame_times(traj.duration, frame_rate, 0.0)
    stream = sample_joint_stream(traj, joint_rate, clock_offset, clock_jitter, rng)
    P = board.object_points()
    T_bw = T_base_from_world_facing(board, distance=target_distance)
    entries = list(still.images)
    corners = dict(still.corners)
    for eye in EYES:
        true = traj.angles(times, eye)
        read = stream[eye].angles(times)
        for k, t in enumerate(times):
            T_cw = head.T_cam_from_base(eye, *true[k]) @ T_bw
            p_cam = P @ T_cw[:3, :3].T + T_cw[:3, 3]
            uv = lens.project_points(p_cam, head.K[eye], head.dist[eye],
                                     model=head.lens_model(eye))
            file = f"poses/{eye}_{k:04d}.png"
            corners[file] = uv + rng.normal(0.0, noise_px, uv.shape)
            entries.append(ImageEntry(index=len(entries), file=file, path=Path(file),
                                      eye=eye, role="pose", pan=float(read[k, 0]),
                                      tilt=float(read[k, 1]), view=f"{k:04d}",
                                      time=float(t)))
    ds = Dataset.with_corners(board, entries, corners, {eye: IMAGE_SIZE for eye in EYES},
                              truth=head, where="<synthetic continuous capture>")
    return dataclasses.replace(ds, joint_stream=stream)


def __getattr__(name: str):
    if name == "CornerDataset":
        warnings.warn("rasc.sim.synthetic.CornerDataset is deprecated: corner_dataset() "
                      "returns rasc.vision.Dataset (rasc.vision.dataset.Dataset), "
                      "holding the corners", DeprecationWarning, stacklevel=2)
        return Dataset
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# ------------------------------------------------------------------ painted images

def _sample_rays(K, dist, model: str, size: tuple[int, int], s: int):
    """The normalised rays (x, y) of the s×s samples of every pixel (centres at
    ``u − 1/2 + (k + 1/2)/s``), shape (h·s, w·s) each, and where the lens model defines
    them (``ok``). The fisheye's inverse is one-dimensional (θ from θ_d, increasing up to
    the model's fold): a fine table, then one Newton step; a pinhole lens by
    :func:`rasc.geometry.lens.distortion_remap`."""
    w, h = size
    K = np.asarray(K, float)
    Ks = np.array([[s * K[0, 0], s * K[0, 1], s * K[0, 2] + (s - 1) / 2],
                   [0.0, s * K[1, 1], s * K[1, 2] + (s - 1) / 2], [0, 0, 1.0]])
    if model != "fisheye":
        mx, my = lens.distortion_remap(Ks, dist, (w * s, h * s), model=model)
        ok = ~((mx == -1.0) & (my == -1.0))
        y = (my.astype(float) - Ks[1, 2]) / Ks[1, 1]
        x = (mx.astype(float) - Ks[0, 2] - Ks[0, 1] * y) / Ks[0, 0]
        return x, y, ok
    k = np.zeros(4) if dist is None or len(dist) == 0 else np.asarray(dist, float)
    vv, uu = np.mgrid[0:h * s, 0:w * s].astype(float)
    yd = (vv - Ks[1, 2]) / Ks[1, 1]
    xd = (uu - Ks[0, 2] - Ks[0, 1] * yd) / Ks[0, 0]
    rd = np.hypot(xd, yd)
    theta = np.linspace(0.0, lens.FISHEYE_MAX_THETA - 1e-3, 200001)
    t2 = theta * theta
    td = theta * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
    rising = np.flatnonzero(np.diff(td) <= 0)
    stop = rising[0] + 1 if rising.size else len(theta)
    th = np.interp(rd, td[:stop], theta[:stop])
    ok = rd < td[stop - 1]
    th2 = th * th
    f = th * (1 + th2 * (k[0] + th2 * (k[1] + th2 * (k[2] + th2 * k[3])))) - rd
    df = 1 + th2 * (3 * k[0] + th2 * (5 * k[1] + th2 * (7 * k[2] + th2 * 9 * k[3])))
    th = th - f / df
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(rd > 1e-12, np.tan(th) / np.where(rd > 0, rd, 1.0), 1.0)
    return xd * scale, yd * scale, ok


def board_image(board: Board, T_cam_from_world: np.ndarray, rays, supersample: int = 2,
                K=None, dist=None, model: str = "pinhole") -> np.ndarray:
    """A chessboard painted through a lens: grey uint8 (h, w), the board's squares
    (the one between corners (0, 0) and (1, 1) black), its white quiet zone, a mid-grey
    background; each pixel the mean of its ``supersample``² samples (``rays``:
    :func:`_sample_rays`). Exact geometry for any lens model, no rendering: for
    testing the image door (detection, ``rasc calibrate``) where MuJoCo is not needed.
    With ``K`` and ``dist`` (the lens ``model``'s) only the pixels around the board's
    projected outline are painted (the rest is background), which is faster."""
    x_all, y_all, ok_all = rays
    s = supersample
    H, W = x_all.shape[0] // s, x_all.shape[1] // s
    out = np.full((H, W), 128.0)
    R, t = T_cam_from_world[:3, :3], T_cam_from_world[:3, 3]
    u0, u1, v0, v1 = 0, W, 0, H
    q0, r0, q1, r1 = board.quiet_box()
    if K is not None:
        e = np.linspace(0.0, 1.0, 33)
        edge = np.concatenate([np.stack([q0 + (q1 - q0) * e, np.full_like(e, r0)], 1),
                               np.stack([q0 + (q1 - q0) * e, np.full_like(e, r1)], 1),
                               np.stack([np.full_like(e, q0), r0 + (r1 - r0) * e], 1),
                               np.stack([np.full_like(e, q1), r0 + (r1 - r0) * e], 1)])
        p = np.c_[edge, np.zeros(len(edge))] @ R.T + t
        if np.all(p[:, 2] > 1e-3):
            uv = lens.project_points(p, K, dist, model=model)
            u0, v0 = (max(0, int(np.floor(c)) - 3) for c in uv.min(axis=0))
            u1 = min(W, int(np.ceil(uv[:, 0].max())) + 4)
            v1 = min(H, int(np.ceil(uv[:, 1].max())) + 4)
            if u1 <= u0 or v1 <= v0:
                return out.astype(np.uint8)
    win = np.s_[v0 * s:v1 * s, u0 * s:u1 * s]
    x, y, ok = x_all[win], y_all[win], ok_all[win]
    n = R[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = (n @ t) / (n[0] * x + n[1] * y + n[2])
    hit = ok & np.isfinite(lam) & (lam > 0)
    lam = np.where(hit, lam, 0.0)
    # the point on the board plane, in the board's frame: q = Rᵀ(λ d − t)
    px, py, pz = lam * x - t[0], lam * y - t[1], lam - t[2]
    a = R[0, 0] * px + R[1, 0] * py + R[2, 0] * pz
    b = R[0, 1] * px + R[1, 1] * py + R[2, 1] * pz
    sq = board.square_size
    x0, y0, x1, y1 = board.face()
    i, j = np.floor(a / sq), np.floor(b / sq)
    value = np.full(a.shape, 128.0)
    quiet = hit & (a >= q0) & (a < q1) & (b >= r0) & (b < r1)
    value[quiet] = 235.0
    face = hit & (a >= x0) & (a < x1) & (b >= y0) & (b < y1)
    value[face & ((i + j) % 2 == 0)] = 20.0
    h, w = value.shape[0] // s, value.shape[1] // s
    out[v0:v1, u0:u1] = value.reshape(h, s, w, s).mean(axis=(1, 3))
    return np.clip(np.round(out), 0, 255).astype(np.uint8)


def image_dataset(head: SyntheticHead | None = None, *, seed: int = 0,
                  n_intrinsics: int = 20, poses_deg=PAPER_POSES_DEG,
                  target_distance: float = 1.0, board: Board = BOARD,
                  supersample: int = 2) -> Dataset:
    """:func:`corner_dataset`'s views painted as images (:func:`board_image`) through
    each eye's lens: a :class:`rasc.vision.dataset.Dataset` of images in memory
    (:func:`rasc.vision.dataset.write_dataset` writes it as a folder for ``rasc
    calibrate``), the board poses those of ``corner_dataset`` with the same seed; its
    ``truth`` is the head."""
    head = head or default_head()
    corners = corner_dataset(head, seed=seed, noise_px=0.0, n_intrinsics=n_intrinsics,
                             poses_deg=poses_deg, target_distance=target_distance,
                             board=board)
    rng = np.random.default_rng(seed)
    T_bw = T_base_from_world_facing(board, distance=target_distance)
    poses: dict[str, np.ndarray] = {}
    for eye in EYES:
        placed = intrinsics_board_poses(rng, board, head.K[eye], IMAGE_SIZE, n_intrinsics,
                                        head.dist[eye], wide_lens(head.lens_model(eye)))
        for k, T_cw in enumerate(placed):
            poses[f"intrinsics/{eye}_{k:03d}.png"] = T_cw
    images, pixels = [], {}
    for e in corners.images:
        if e.role == "pose":
            poses[e.file] = head.T_cam_from_base(e.eye, e.pan, e.tilt) @ T_bw
    rays = {eye: _sample_rays(head.K[eye], head.dist[eye], head.lens_model(eye), IMAGE_SIZE,
                              supersample) for eye in EYES}
    for e in corners.images:
        pixels[e.file] = board_image(board, poses[e.file], rays[e.eye], supersample,
                                     head.K[e.eye], head.dist[e.eye], head.lens_model(e.eye))
        entry = {"file": e.file, "eye": e.eye, "role": e.role}
        if e.role == "pose":
            entry.update(pan=float(np.degrees(e.pan)), tilt=float(np.degrees(e.tilt)),
                         view=e.view)
        images.append(entry)
    ds = Dataset.in_memory(board, images, pixels, angle_unit="deg")
    ds.truth = head
    return ds
