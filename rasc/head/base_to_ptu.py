"""Base-to-ptu calibration, docs/METHOD.md §5 (paper section 3.3, eq. 11–12).

Loop closure. When both cameras see the same target at the same time (one *view*), the
target closes a loop through the two units (eq. 12)::

    T_ptuL_from_ptuR = (T_ptuL_from_gazeL T_gazeL_from_camL T_camL_from_world)
                     · (T_ptuR_from_gazeR T_gazeR_from_camR T_camR_from_world)⁻¹

Each view gives one estimate; :func:`T_ptuL_from_ptuR_loop_closure` averages them (rotation:
chordal L2 mean, ``scipy`` ``Rotation.mean``; translation: arithmetic mean) and reports
how far each view lies from the mean.

Measured mounts. The paper prefers measuring the mounts (< 1°, 2–3 mm):
:func:`T_ptuL_from_ptuR_from_mounts` builds the transform from a measured baseline and
small rotation; :func:`perturb_mounts` turns ground truth into such a measurement for the
simulation.

Cyclopean base (docs/CONTRACTS.md): :func:`cyclopean_base` places the base frame midway
between the two units, oriented at the geodesic midpoint of their orientations, so the
two ptu origins sit at equal and opposite positions in base coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from rasc.errors import DegenerateDataError, InputError

# the cyclopean base is geometry (rasc.sim places its truth in it too): re-exported here
from rasc.geometry.kinematics import HALF_TURN_MARGIN_RAD, cyclopean_base  # noqa: F401
from rasc.geometry.kinematics import T_gaze_from_ptu as _T_gaze_from_ptu
from rasc.geometry.transforms import (
    invert_transform,
    make_transform,
    matrix_from_rotvec,
    validate_rigid_transform,
)
from rasc.geometry.transforms import rotation_error_deg as _angle_deg

#: A view further than this from the mean rotation is not noise but a mismatched pair of
#: views: real loop closures agree within a few degrees (the paper: 2–3°), and averaging
#: rotations this far apart no longer describes one rigid pair of mounts.
MAX_VIEW_DEVIATION_DEG = 90.0


@dataclass(frozen=True)
class LoopClosureSpread:
    """How far each view's loop closure lies from the average.

    Attributes
    ----------
    rotation_deg : ndarray, shape (m,)
        Geodesic angle between each view's rotation and the mean rotation, degrees.
    translation : ndarray, shape (m,)
        Distance between each view's translation and the mean translation (input unit).
    """

    rotation_deg: np.ndarray
    translation: np.ndarray

    @property
    def n_views(self) -> int:
        """The number of views the loop closure averaged."""
        return int(self.rotation_deg.size)

    def to_dict(self) -> dict:
        """JSON-ready dict: each view's disagreement and their largest and RMS values."""
        return {
            "n_views": self.n_views,
            "rotation_deg": self.rotation_deg.tolist(),
            "translation": self.translation.tolist(),
            "rotation_deg_max": float(self.rotation_deg.max()),
            "rotation_deg_rms": float(np.sqrt(np.mean(self.rotation_deg ** 2))),
            "translation_max": float(self.translation.max()),
            "translation_rms": float(np.sqrt(np.mean(self.translation ** 2))),
        }


def _stack(T, m: int | None, name: str) -> np.ndarray:
    """Validate a stack of rigid transforms (m, 4, 4); a single (4, 4) is broadcast."""
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: not a numeric array") from None
    if T.shape == (4, 4) and m is not None:
        validate_rigid_transform(T, name=name)
        return np.broadcast_to(T, (m, 4, 4))
    if T.ndim != 3 or T.shape[1:] != (4, 4) or (m is not None and T.shape[0] != m):
        want = "(m, 4, 4)" if m is None else f"({m}, 4, 4) or (4, 4)"
        raise InputError(f"{name}: expected shape {want}, got {T.shape}")
    for k in range(T.shape[0]):
        validate_rigid_transform(T[k], name=f"{name}[{k}]")
    return T


def _motion(T_gaze_from_ptu, pan_tilt, m: int, eye: str) -> np.ndarray:
    if (T_gaze_from_ptu is None) == (pan_tilt is None):
        raise InputError(
            f"{eye}: give exactly one of T_gaze_from_ptu_{eye} and pan_tilt_{eye}")
    if T_gaze_from_ptu is not None:
        return _stack(T_gaze_from_ptu, m, f"T_gaze_from_ptu_{eye}")
    try:
        pt = np.asarray(pan_tilt, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"pan_tilt_{eye}: not a numeric array") from None
    if pt.shape != (m, 2):
        raise InputError(f"pan_tilt_{eye}: expected shape ({m}, 2) (pan, tilt in radians), "
                         f"got {pt.shape}")
    if not np.all(np.isfinite(pt)):
        raise InputError(f"pan_tilt_{eye}: contains NaN or infinity")
    return _T_gaze_from_ptu(pt[:, 0], pt[:, 1])


def T_ptuL_from_ptuR_per_view(T_cam_from_world_left, T_cam_from_world_right,
                              T_cam_from_gaze_left, T_cam_from_gaze_right, *,
                              T_gaze_from_ptu_left=None, T_gaze_from_ptu_right=None,
                              pan_tilt_left=None, pan_tilt_right=None) -> np.ndarray:
    """Eq. 12 for every simultaneous view → (m, 4, 4). Arguments as
    :func:`T_ptuL_from_ptuR_loop_closure`."""
    T_cw_L = _stack(T_cam_from_world_left, None, "T_cam_from_world_left")
    m = T_cw_L.shape[0]
    if m == 0:
        raise InputError("T_cam_from_world_left: no views; loop closure needs at least one "
                         "view of the target seen by both cameras at the same time")
    T_cw_R = _stack(T_cam_from_world_right, m, "T_cam_from_world_right")
    T_cg_L = validate_rigid_transform(T_cam_from_gaze_left, name="T_cam_from_gaze_left")
    T_cg_R = validate_rigid_transform(T_cam_from_gaze_right, name="T_cam_from_gaze_right")
    T_gp_L = _motion(T_gaze_from_ptu_left, pan_tilt_left, m, "left")
    T_gp_R = _motion(T_gaze_from_ptu_right, pan_tilt_right, m, "right")
    # Eq. 12: T_ptu_from_world for each eye, then left ∘ right⁻¹.
    T_ptuL_from_world = invert_transform(T_gp_L) @ invert_transform(T_cg_L) @ T_cw_L
    T_ptuR_from_world = invert_transform(T_gp_R) @ invert_transform(T_cg_R) @ T_cw_R
    return T_ptuL_from_world @ invert_transform(T_ptuR_from_world)


def T_ptuL_from_ptuR_loop_closure(T_cam_from_world_left, T_cam_from_world_right,
                                  T_cam_from_gaze_left, T_cam_from_gaze_right, *,
                                  T_gaze_from_ptu_left=None, T_gaze_from_ptu_right=None,
                                  pan_tilt_left=None, pan_tilt_right=None):
    """Right ptu frame in the left one from simultaneous views (eq. 11–12), averaged.

    Parameters
    ----------
    T_cam_from_world_left, T_cam_from_world_right : array-like, shape (m, 4, 4)
        Target pose in each camera for each of the m simultaneous views (row k of both
        is the same target placement seen at the same time).
    T_cam_from_gaze_left, T_cam_from_gaze_right : array-like, shape (4, 4)
        Hand-eye transform of each eye (section 3.2).
    T_gaze_from_ptu_left, T_gaze_from_ptu_right : array-like, shape (m, 4, 4) or (4, 4)
        Each unit's motion at each view (eq. 3); or instead
    pan_tilt_left, pan_tilt_right : array-like, shape (m, 2)
        (pan, tilt) in radians at each view, turned into eq. 3.

    Returns
    -------
    T_ptuL_from_ptuR : ndarray, shape (4, 4)
        Rotation: chordal L2 mean of the views' rotations (the rotation nearest, in the
        Frobenius norm, to their element-wise mean); translation: arithmetic mean.
    spread : LoopClosureSpread
        Each view's deviation from that mean.

    Raises
    ------
    InputError
        Malformed input, naming the argument and view index.
    DegenerateDataError
        Views whose rotations differ by more than 90° from the mean: they cannot be
        loops through the same pair of mounts (mismatched left/right views).
    """
    T = T_ptuL_from_ptuR_per_view(
        T_cam_from_world_left, T_cam_from_world_right, T_cam_from_gaze_left,
        T_cam_from_gaze_right, T_gaze_from_ptu_left=T_gaze_from_ptu_left,
        T_gaze_from_ptu_right=T_gaze_from_ptu_right, pan_tilt_left=pan_tilt_left,
        pan_tilt_right=pan_tilt_right)
    R_mean = Rotation.from_matrix(T[:, :3, :3]).mean().as_matrix()
    t_mean = T[:, :3, 3].mean(axis=0)
    spread = LoopClosureSpread(
        rotation_deg=_angle_deg(R_mean, T[:, :3, :3]),
        translation=np.linalg.norm(T[:, :3, 3] - t_mean, axis=1))
    worst = int(np.argmax(spread.rotation_deg))
    if spread.rotation_deg[worst] > MAX_VIEW_DEVIATION_DEG:
        raise DegenerateDataError(
            f"loop closure: view {worst} is {spread.rotation_deg[worst]:.1f} deg from the "
            f"mean rotation: the views do not describe one pair of mounts; check that each "
            f"left view is paired with the right view taken at the same time")
    return make_transform(R_mean, t_mean), spread


def T_ptuL_from_ptuR_from_mounts(t_ptuL_from_ptuR, rotvec_ptuL_from_ptuR=None) -> np.ndarray:
    """A measured mount: right ptu frame in the left one (4, 4).

    Parameters
    ----------
    t_ptuL_from_ptuR : array-like, shape (3,)
        Position of the right unit's centre in the left unit's frame (the baseline).
    rotvec_ptuL_from_ptuR : array-like, shape (3,), optional
        Rotation of the right unit's frame in the left one, axis-angle in radians
        (zero when the mounts are parallel).
    """
    try:
        t = np.asarray(t_ptuL_from_ptuR, dtype=float)
        w = np.zeros(3) if rotvec_ptuL_from_ptuR is None else np.asarray(
            rotvec_ptuL_from_ptuR, dtype=float)
    except (TypeError, ValueError):
        raise InputError("mounts: baseline and rotation must be numeric 3-vectors") from None
    for name, a in (("t_ptuL_from_ptuR", t), ("rotvec_ptuL_from_ptuR", w)):
        if a.shape != (3,) or not np.all(np.isfinite(a)):
            raise InputError(f"{name}: expected 3 finite numbers, got {a.tolist()}")
    return make_transform(matrix_from_rotvec(w), t)


def perturb_mounts(T_ptuL_from_ptuR, rotation_error_deg: float, translation_error: float,
                   rng: np.random.Generator | int) -> np.ndarray:
    """Ground truth turned into a mount measurement with errors of the stated size.

    The rotation is turned by exactly ``rotation_error_deg`` about a uniformly random axis
    (``R' = R · exp(θ a)``) and the translation moved by exactly ``translation_error``
    in a uniformly random direction, so :func:`mount_errors` of the result against the
    truth returns the two numbers given. The paper's measured mounts: < 1°, 2–3 mm.

    Parameters
    ----------
    T_ptuL_from_ptuR : array-like, shape (4, 4)
    rotation_error_deg : float
    translation_error : float
        Same unit as the transform's translation.
    rng : numpy Generator or int seed
    """
    T = validate_rigid_transform(T_ptuL_from_ptuR, name="T_ptuL_from_ptuR")
    if not (rotation_error_deg >= 0.0 and translation_error >= 0.0):
        raise InputError(f"perturb_mounts: errors must be >= 0, got "
                         f"{rotation_error_deg}, {translation_error}")
    if rotation_error_deg >= 180.0:
        raise InputError(f"perturb_mounts: rotation error must be < 180 deg, "
                         f"got {rotation_error_deg}")
    rng = np.random.default_rng(rng)
    axis, direction = rng.normal(size=(2, 3))
    axis /= np.linalg.norm(axis)
    direction /= np.linalg.norm(direction)
    R = T[:3, :3] @ matrix_from_rotvec(np.radians(rotation_error_deg) * axis)
    return make_transform(R, T[:3, 3] + translation_error * direction)


@dataclass(frozen=True)
class MountError:
    """Error of an estimated ``T_ptuL_from_ptuR`` against the truth (E5).

    rotation_deg: geodesic angle between the rotations; translation: distance between the
    translations (input unit); baseline_length: difference of the baseline lengths,
    estimate minus truth (signed, input unit).
    """

    rotation_deg: float
    translation: float
    baseline_length: float

    def to_dict(self) -> dict:
        """JSON-ready dict: rotation (deg), translation and baseline length."""
        return {"rotation_deg": self.rotation_deg, "translation": self.translation,
                "baseline_length": self.baseline_length}


def mount_errors(T_est, T_true) -> MountError:
    """Rotation error (deg) and baseline errors of ``T_est`` against ``T_true`` (4, 4)."""
    T_est = validate_rigid_transform(T_est, name="T_est")
    T_true = validate_rigid_transform(T_true, name="T_true")
    return MountError(
        rotation_deg=float(_angle_deg(T_est[:3, :3], T_true[:3, :3])),
        translation=float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3])),
        baseline_length=float(np.linalg.norm(T_est[:3, 3]) - np.linalg.norm(T_true[:3, 3])))


def unit_side_warnings(T_ptu_from_base_left, T_ptu_from_base_right) -> list[str]:
    """The left unit must sit to the left of the right one: one sentence if not, else [].

    In the base and ptu frames +z points left (x up, y forward, z left; docs/CONTRACTS.md),
    so the left unit's origin has the larger base z. A calibration that puts it on the
    other side is self-consistent (each eye's hand-eye and loop closure still close) and
    so cannot be refused by any residual: the usual causes are left and right swapped in
    the manifest (``eye``), or measured mounts given as T_ptuR_from_ptuL.

    Parameters
    ----------
    T_ptu_from_base_left, T_ptu_from_base_right : array-like, shape (4, 4)
    """
    z_left = float(invert_transform(np.asarray(T_ptu_from_base_left, dtype=float))[2, 3])
    z_right = float(invert_transform(np.asarray(T_ptu_from_base_right, dtype=float))[2, 3])
    if z_left > z_right:
        return []
    return [f"the calibrated left unit sits {z_right - z_left:.3g} to the RIGHT of the right "
            "unit (base +z points left): are left and right swapped in the manifest's "
            "'eye' fields, or the mounts given as T_ptuR_from_ptuL?"]
