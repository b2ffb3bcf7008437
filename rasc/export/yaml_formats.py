"""A calibration as ROS camera_info YAML, OpenCV FileStorage YAML and a Kalibr camchain
(docs/topics/export.md). Each is written as text here and checked, in tests/export, by a
reader rasc did not write (PyYAML, ``cv2.FileStorage``).

* **camera_info** (ROS camera_calibration_parsers' YAML, what camera_info_manager
  loads), one per eye: intrinsics only. ``K``, the distortion ``D`` (``plumb_bob``:
  k1 k2 p1 p2 k3, 4 coefficients padded with k3 = 0; ``rational_polynomial``: OpenCV's
  8; ``equidistant``, ROS's name for a fisheye eye's ``cv2.fisheye`` model: k1 k2 k3 k4),
  ``R = I`` (the images are not rectified) and ``P = [K | 0]``. They hold at every
  gaze: an active head's pose goes in the URDF (``/tf``), not in camera_info.
* **OpenCV** FileStorage YAML: ``K1 D1 K2 D2``, each eye's lens model (``lens_model1``,
  ``lens_model2``: ``pinhole``, whose ``D`` is OpenCV's k1 k2 p1 p2 [k3 [k4 k5 k6]] for
  ``cv2.projectPoints``, or ``fisheye``, whose ``D`` is ``cv2.fisheye``'s k1 k2 k3 k4,
  1×4) and image size, the stereo
  extrinsics at one gaze as ``cv2.stereoCalibrate`` returns them (``R``, ``T`` map
  camera-1 (left) coordinates into camera 2 (right): x₂ = R x₁ + T; ``E``, ``F``), and
  what the gaze depends on: per eye the hand-eye ``T_cam_from_gaze``, the mount
  ``T_ptu_from_base``, the unit's parameters, and ``T_cam_from_base`` at that gaze.
* **Kalibr** camchain: ``cam0`` (left), ``cam1`` (right), each ``camera_model: pinhole``,
  ``intrinsics: [fu, fv, pu, pv]``, ``distortion_model: radtan`` with
  ``distortion_coeffs: [k1, k2, r1, r2]`` (a fisheye eye: ``equidistant`` with
  ``[k1, k2, k3, k4]``, Kalibr's pinhole-equi, the model of ``cv2.fisheye``),
  ``resolution: [width, height]``, ``rostopic``, ``cam_overlaps``;
  ``cam1.T_cn_cnm1``, Kalibr's transform from the previous camera to this one (it maps
  cam0 coordinates into cam1: ``T_cam1_from_cam0``) at one gaze. Kalibr's pinhole has
  no skew and radtan no k3: a calibration that needs them is refused.

Lengths are metres in every file (ROS, Kalibr; OpenCV's file says ``length_unit: m``).
"""

from __future__ import annotations

import numpy as np

from rasc.errors import InputError
from rasc.export._text import number, numbers
from rasc.geometry.frames import EYES
from rasc.geometry.transforms import invert_transform

#: ROS distortion model of a pinhole eye by the number of OpenCV coefficients
ROS_DISTORTION_MODELS = {0: "plumb_bob", 4: "plumb_bob", 5: "plumb_bob",
                         8: "rational_polynomial"}
#: ROS's (sensor_msgs/distortion_models.h) and Kalibr's name of the fisheye lens model
#: (cv2.fisheye's equidistant k1 k2 k3 k4)
EQUIDISTANT = "equidistant"
#: placeholder image topics of the Kalibr camchain (Kalibr reads them to find the images)
KALIBR_TOPICS = {"left": "/left/image_raw", "right": "/right/image_raw"}


def _matrix(rows: int, cols: int, data, indent: str = "  ") -> str:
    return (f"{indent}rows: {rows}\n{indent}cols: {cols}\n"
            f"{indent}data: [{numbers(data)}]\n")


def camera_info_distortion(dist: np.ndarray, lens: str = "pinhole"
                           ) -> tuple[str, np.ndarray]:
    """(distortion_model, D) of ROS for a pinhole eye's OpenCV coefficients (0, 4, 5 or 8
    of them) or a fisheye eye's (``equidistant``, k1 k2 k3 k4; none: four zeros)."""
    dist = np.asarray(dist, dtype=float)
    if lens == "fisheye":
        return EQUIDISTANT, dist if dist.size else np.zeros(4)
    model = ROS_DISTORTION_MODELS[dist.size]
    if model == "plumb_bob":
        dist = np.concatenate([dist, np.zeros(5 - dist.size)])
    return model, dist


def to_camera_info(eye, camera_name: str) -> str:
    """ROS camera_info YAML of one :class:`rasc.head.model.EyeCalibration` (module
    docstring)."""
    model, D = camera_info_distortion(eye.dist, eye.lens)
    P = np.hstack([eye.K, np.zeros((3, 1))])
    width, height = eye.image_size
    return (f"image_width: {width}\nimage_height: {height}\ncamera_name: {camera_name}\n"
            f"camera_matrix:\n{_matrix(3, 3, eye.K)}distortion_model: {model}\n"
            f"distortion_coefficients:\n{_matrix(1, D.size, D)}"
            f"rectification_matrix:\n{_matrix(3, 3, np.eye(3))}"
            f"projection_matrix:\n{_matrix(3, 4, P)}")


def stereo_extrinsics(head, gaze) -> dict[str, np.ndarray]:
    """At readings ``gaze`` = (pan_left, tilt_left, pan_right, tilt_right), radians: each
    eye's ``T_cam_from_base`` and ``T_cam2_from_cam1`` (the right camera from the left)."""
    T = {eye: getattr(head, eye).T_cam_from_base(*angles)
         for eye, angles in zip(EYES, (gaze[:2], gaze[2:]), strict=True)}
    return {"left": T["left"], "right": T["right"],
            "T_cam2_from_cam1": T["right"] @ invert_transform(T["left"])}


def _scaled(T: np.ndarray, metres: float) -> np.ndarray:
    T = np.array(T, dtype=float)
    T[:3, 3] *= metres
    return T


def _cv_matrix(name: str, M) -> str:
    M = np.atleast_2d(np.asarray(M, dtype=float))
    return (f"{name}: !!opencv-matrix\n   rows: {M.shape[0]}\n   cols: {M.shape[1]}\n"
            f"   dt: d\n   data: [ {numbers(M)} ]\n")


def _skew(t: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])


def to_opencv(head, gaze=(0.0, 0.0, 0.0, 0.0), *, metres_per_unit: float = 1.0) -> str:
    """OpenCV FileStorage YAML of a :class:`rasc.head.model.HeadCalibration` at readings
    ``gaze`` (radians; module docstring)."""
    ext = stereo_extrinsics(head, gaze)
    T21 = _scaled(ext["T_cam2_from_cam1"], metres_per_unit)
    R, t = T21[:3, :3], T21[:3, 3]
    E = _skew(t) @ R
    F = np.linalg.inv(head.right.K).T @ E @ np.linalg.inv(head.left.K)
    text = ("%YAML:1.0\n---\n"
            "# written by rasc export (format opencv): camera 1 is the left eye, camera 2 "
            "the right.\n# R, T, E, F as cv2.stereoCalibrate returns them (x2 = R x1 + T) "
            "at the pan-tilt readings 'gaze'\n# (pan_left, tilt_left, pan_right, tilt_right, "
            "radians); lengths in metres.\n# lens_model1/2: pinhole (D: OpenCV's k1 k2 p1 "
            "p2 [k3 [k4 k5 k6]], cv2.projectPoints) or fisheye\n# (D: cv2.fisheye's k1 k2 "
            "k3 k4, cv2.fisheye.projectPoints).\n")
    text += f"length_unit: m\ngaze: [ {numbers(gaze)} ]\n"
    for k, name in enumerate(EYES, start=1):
        eye = getattr(head, name)
        # no distortion: OpenCV's five zeros (the fisheye's four)
        dist = eye.dist if eye.dist.size else np.zeros(4 if eye.lens == "fisheye" else 5)
        text += _cv_matrix(f"K{k}", eye.K) + _cv_matrix(f"D{k}", dist.reshape(1, -1))
        text += f"lens_model{k}: {eye.lens}\n"
        text += f"image_size{k}: [ {eye.image_size[0]}, {eye.image_size[1]} ]\n"
    text += _cv_matrix("R", R) + _cv_matrix("T", t.reshape(3, 1))
    text += _cv_matrix("E", E) + _cv_matrix("F", F)
    for k, name in enumerate(EYES, start=1):
        eye = getattr(head, name)
        text += _cv_matrix(f"T_cam_from_gaze{k}", _scaled(eye.T_cam_from_gaze, metres_per_unit))
        text += _cv_matrix(f"T_ptu_from_base{k}",
                           _scaled(eye.T_ptu_from_base, metres_per_unit))
        text += _cv_matrix(f"T_cam_from_base{k}", _scaled(ext[name], metres_per_unit))
        u = eye.unit
        text += _cv_matrix(f"pan_axis{k}", np.reshape(u.pan_axis, (3, 1)))
        text += _cv_matrix(f"tilt_axis{k}", np.reshape(u.tilt_axis, (3, 1)))
        text += _cv_matrix(f"tilt_point{k}",
                           np.reshape(u.tilt_point, (3, 1)) * metres_per_unit)
        for field in ("pan_offset", "tilt_offset", "pan_scale", "tilt_scale"):
            text += f"{field}{k}: {number(getattr(u, field))}\n"
    return text


def _kalibr_camera(name: str, eye) -> str:
    K = eye.K
    if K[0, 1] != 0.0:
        raise InputError(f"{name}.K: skew {K[0, 1]:g} px: Kalibr's pinhole model "
                         "[fu, fv, pu, pv] has none; export --format opencv or camera-info")
    dist = np.concatenate([eye.dist, np.zeros(max(0, 4 - eye.dist.size))])
    model = EQUIDISTANT if eye.lens == "fisheye" else "radtan"  # pinhole-equi: cv2.fisheye's
    extra = dist[4:]
    if np.any(extra != 0.0):
        raise InputError(f"{name}.dist: k3..k6 = {numbers(extra)} are not all 0: Kalibr's "
                         "radtan model has four coefficients (k1 k2 r1 r2); export --format "
                         "opencv or camera-info")
    return (f"  camera_model: pinhole\n"
            f"  intrinsics: [{numbers([K[0, 0], K[1, 1], K[0, 2], K[1, 2]])}]\n"
            f"  distortion_model: {model}\n  distortion_coeffs: [{numbers(dist[:4])}]\n"
            f"  resolution: [{eye.image_size[0]}, {eye.image_size[1]}]\n"
            f"  rostopic: {KALIBR_TOPICS[name]}\n")


def to_kalibr(head, gaze=(0.0, 0.0, 0.0, 0.0), *, metres_per_unit: float = 1.0) -> str:
    """Kalibr camchain YAML of a :class:`rasc.head.model.HeadCalibration` at readings
    ``gaze`` (radians; module docstring). Raises InputError for skew or k3..k6 ≠ 0."""
    cams = {name: _kalibr_camera(name, getattr(head, name)) for name in EYES}
    T10 = _scaled(stereo_extrinsics(head, gaze)["T_cam2_from_cam1"], metres_per_unit)
    rows = "".join(f"  - [{numbers(row)}]\n" for row in T10)
    return ("# written by rasc export (format kalibr): cam0 is the left eye, cam1 the right;\n"
            "# T_cn_cnm1 maps cam0 coordinates into cam1 (metres), at the pan-tilt readings\n"
            f"# (pan_left, tilt_left, pan_right, tilt_right) = ({numbers(gaze)}) rad.\n"
            f"cam0:\n{cams['left']}  cam_overlaps: [1]\n"
            f"cam1:\n  T_cn_cnm1:\n{rows}{cams['right']}  cam_overlaps: [0]\n")
