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
from rasc.sim.render import intrinsics_board_poses
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
        if not partial:
            uv = lens.project_points(p_cam, head.K[eye], head.dist[eye])
            return uv + rng.normal(0.0, noise_px, uv.shape)
        # a target seen in part: the corners inside the image, NaN the rest
        front = p_cam[:, 2] > 0.05
        uv = np.full((len(P), 2), np.nan)
        if front.any():
            uv[front] = lens.project_points(p_cam[front], head.K[eye], head.dist[eye])
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
        for k, T_cw in enumerate(intrinsics_board_poses(rng, board, head.K[eye], IMAGE_SIZE,
                                                         n_intrinsics, head.dist[eye])):
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
            uv = lens.project_points(p_cam, head.K[eye], head.dist[eye])
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
