"""OpenCV's hand-eye solvers behind the project's interface, for comparison (docs/METHOD.md §3).

``cv2.calibrateHandEye(R_gripper2base, t_gripper2base, R_target2cam, t_target2cam,
method)`` returns ``cam2gripper``, solving ``Hg_ij X = X Hc_ij`` with
``Hg_ij = inv(Hg_j) Hg_i`` and ``Hc_ij = Hc_j inv(Hc_i)`` over the pairs i < j. Mapped to
this project's frames::

    gripper2base = inv(T_gaze_from_ptu)    (T_base_from_gripper)
    target2cam   = T_cam_from_world
    T_cam_from_gaze = inv(cam2gripper)

Called with the roles swapped — ``solve_rasc(T_gaze_from_ptu, T_cam_from_world,
pairs="half")`` — RASC builds exactly OpenCV's PARK equations (its pair (j, i) is
OpenCV's (i, j)) and returns cam2gripper itself; the tests hold the two equal to 1e-9.
RASC's own orientation (solving for T_cam_from_gaze directly) gives the exact inverse
rotation and a translation that differs under noise by the different weighting of
eq. 7's residuals.

cv2 is imported inside the functions: the mathematics never needs it. Also here: the
reader of Tabb's robot-world-hand-eye dataset that OpenCV uses in its own tests.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from rasc.errors import InputError, SolverFailure
from rasc.geometry.transforms import invert_transform, make_transform
from rasc.handeye.solver import MIN_PAIR_ROTATION_RAD, HandEyeResult, diagnose, quality_eq10

#: method name → the name of OpenCV's constant (looked up when cv2 is imported)
CV_METHODS = {"park": "CALIB_HAND_EYE_PARK", "tsai": "CALIB_HAND_EYE_TSAI",
              "horaud": "CALIB_HAND_EYE_HORAUD", "andreff": "CALIB_HAND_EYE_ANDREFF",
              "daniilidis": "CALIB_HAND_EYE_DANIILIDIS"}

#: The rotation OpenCV returns must be orthonormal to this (its solvers return exact
#: rotations to ~1e-15; anything worse is a failed solve, not a result).
ROTATION_ATOL = 1e-6


def calibrate_hand_eye_cv(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                          method: str = "park") -> np.ndarray:
    """``cv2.calibrateHandEye`` on our inputs → ``T_gripper_from_cam`` (cam2gripper), (4, 4).

    No validation beyond the method name; NaN or non-rotation output raises
    :class:`SolverFailure`.
    """
    import cv2

    if method not in CV_METHODS:
        raise InputError(f"method: expected one of {tuple(CV_METHODS)}, got {method!r}")
    if not hasattr(cv2, "calibrateHandEye"):
        raise SolverFailure(f"this OpenCV ({cv2.__version__}) has no calibrateHandEye "
                            "(the 5.0 wheels lack it); install opencv-python-headless<5")
    T_base_from_gripper = invert_transform(np.asarray(T_gaze_from_ptu, dtype=float))
    T_cw = np.asarray(T_cam_from_world, dtype=float)
    log = cv2.utils.logging
    level = log.getLogLevel()
    log.setLogLevel(log.LOG_LEVEL_SILENT)  # failures are reported by SolverFailure below
    try:
        R, t = cv2.calibrateHandEye(
            list(T_base_from_gripper[:, :3, :3]), list(T_base_from_gripper[:, :3, 3]),
            list(T_cw[:, :3, :3]), list(T_cw[:, :3, 3]),
            method=getattr(cv2, CV_METHODS[method]))
    except cv2.error as exc:
        raise SolverFailure(f"OpenCV's {method.upper()} hand-eye solver failed "
                            f"({_cv_reason(exc)}); try method 'rasc'") from None
    finally:
        log.setLogLevel(level)
    R, t = np.asarray(R, dtype=float), np.asarray(t, dtype=float).reshape(-1)
    if R.shape == (3, 3) and np.array_equal(R, np.eye(3)) and not np.any(t):
        # Tsai's way of failing: it logs "not enough informative motions" and returns
        # exactly the identity, which no real data produces
        raise SolverFailure(f"OpenCV's {method.upper()} hand-eye solver found too few "
                            "informative motions (it returned the identity); include "
                            "larger rotations or try method 'rasc'")
    ok = (R.shape == (3, 3) and t.shape == (3,) and np.all(np.isfinite(R))
          and np.all(np.isfinite(t)))
    if ok:
        ok = (np.abs(R.T @ R - np.eye(3)).max() < ROTATION_ATOL
              and abs(np.linalg.det(R) - 1.0) < ROTATION_ATOL)
    if not ok:
        raise SolverFailure(f"OpenCV's {method.upper()} hand-eye solver returned no valid "
                            f"rotation (R = {np.round(R, 6).tolist()}); try method 'rasc'")
    return make_transform(R, t)


def _cv_reason(exc: Exception) -> str:
    """OpenCV's reason from a cv2.error, without its source path and function:
    "OpenCV(4.14.0) /io/.../calibration_handeye.cpp:549: error: (-7:Iterations do not
    converge) Rotation normalization issue: determinant(R) is null in function
    'normalizeRotation'" → "Iterations do not converge: Rotation normalization issue:
    determinant(R) is null"."""
    text = " ".join(str(exc).split())
    m = re.search(r"error: \(-?\d+:([^)]*)\) (.*?)(?: in function '[^']*')?$", text)
    return f"{m.group(1)}: {m.group(2)}" if m else text


def solve_opencv(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                 method: str = "park", *, min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
                 check_rigid: bool = True) -> HandEyeResult:
    """One of OpenCV's five hand-eye solvers, returning ``T_cam_from_gaze``.

    Parameters
    ----------
    T_cam_from_world, T_gaze_from_ptu : array-like, shape (n, 4, 4)
        As :func:`rasc.handeye.solver.solve_rasc` (validated and checked for degeneracy the
        same way, on OpenCV's pairs i < j, before OpenCV is called).
    method : {"park", "tsai", "horaud", "andreff", "daniilidis"}

    Returns
    -------
    HandEyeResult
        method ``"opencv-<method>"``; quality by eq. 10 over all pairs.
    """
    if method not in CV_METHODS:
        raise InputError(f"method: expected one of {tuple(CV_METHODS)}, got {method!r}")
    diagnostics, T_cw, T_gp = diagnose(T_cam_from_world, T_gaze_from_ptu, pairs="half",
                                       min_rotation_rad=min_rotation_rad,
                                       check_rigid=check_rigid)
    T = invert_transform(calibrate_hand_eye_cv(T_cw, T_gp, method))
    quality = float(quality_eq10(np.ascontiguousarray(T_cw[None, :, :3, :3]),
                                 np.ascontiguousarray(T_gp[None, :, :3, :3]),
                                 T[None, :3, :3])[0])
    return HandEyeResult(T_cam_from_gaze=T, quality=quality, method=f"opencv-{method}",
                         diagnostics=diagnostics)


def read_tabb_rwhe(folder: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tabb's robot-world-hand-eye data set 1 (as in OpenCV's opencv_extra test data).

    ``cali.txt``: a count, then per line ``image K(9) R(9) t(3) dist(5) dist2(3)``, the
    target's pose in the camera (millimetres). ``robot_cali.txt``: a count, then one
    4×4 per block, base→gripper, i.e. ``T_gripper_from_base``.
    ``transformations_rwhe_AA_RPI.txt``: Tabb's solution; its ``Z`` is cam←gripper,
    ``T_cam_from_gripper``.

    Returns
    -------
    (T_cam_from_world (n, 4, 4), T_gripper_from_base (n, 4, 4), Z (4, 4))
    """
    folder = Path(folder)

    def tokens(name: str) -> list[str]:
        try:
            return (folder / name).read_text().split()
        except OSError as exc:
            raise InputError(f"{folder / name}: cannot read: {exc.strerror or exc}") from None

    def numbers(name: str, words: list[str], where: str) -> np.ndarray:
        try:
            return np.array(words, dtype=float)
        except ValueError:
            raise InputError(f"{folder / name}: {where}: not a number in {words}") from None

    cali = tokens("cali.txt")
    n = int(numbers("cali.txt", cali[:1], "count")[0])
    if len(cali) != 1 + 30 * n:
        raise InputError(f"{folder / 'cali.txt'}: expected {n} lines of 30 fields, got "
                         f"{len(cali) - 1} fields")
    rows = [cali[1 + 30 * k: 1 + 30 * (k + 1)] for k in range(n)]
    T_cw = np.array([make_transform(numbers("cali.txt", r[10:19], f"line {k + 2}, R")
                                    .reshape(3, 3),
                                    numbers("cali.txt", r[19:22], f"line {k + 2}, t"))
                     for k, r in enumerate(rows)])
    robot = tokens("robot_cali.txt")
    m = int(numbers("robot_cali.txt", robot[:1], "count")[0])
    if m != n or len(robot) != 1 + 16 * m:
        raise InputError(f"{folder / 'robot_cali.txt'}: expected {n} 4x4 matrices, got "
                         f"{(len(robot) - 1) / 16:g}")
    T_gb = numbers("robot_cali.txt", robot[1:], "matrices").reshape(m, 4, 4)
    tr = tokens("transformations_rwhe_AA_RPI.txt")
    try:
        z = tr.index("Z")
    except ValueError:
        raise InputError(f"{folder / 'transformations_rwhe_AA_RPI.txt'}: no 'Z' block") from None
    Z = numbers("transformations_rwhe_AA_RPI.txt", tr[z + 2: z + 18], "Z").reshape(4, 4)
    return T_cw, T_gb, Z
