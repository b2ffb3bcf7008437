"""The calibrated head model (rasc.head.model): eq. 1–2 chain, projection, triangulation, JSON."""

import copy
import json

import cv2
import numpy as np
import pytest

from rasc.errors import InputError
from rasc.geometry.kinematics import T_gaze_from_ptu
from rasc.geometry.transforms import rotvec_from_matrix
from rasc.head.model import EyeCalibration, HeadCalibration

from nominal_rig import HEAD_IMAGE_SIZE as SIZE
from nominal_rig import plausible_head

_head = plausible_head


def _scene(rng, n):
    """Points ~1.5–2 m ahead of the base (x up, y forward, z left), each seen by each eye
    at its own angles (±5°)."""
    p = np.c_[rng.uniform(-0.3, 0.3, n), rng.uniform(1.5, 2.0, n), rng.uniform(-0.3, 0.3, n)]
    angles = rng.uniform(np.radians(-5), np.radians(5), (4, n))
    return p, angles


def _inside(uv):
    return np.all((uv >= -0.5) & (uv <= np.array(SIZE) - 0.5))


def test_T_cam_from_base_is_the_eq_1_2_chain():
    head, _ = _head()
    eye = head.left
    T = eye.T_cam_from_base(0.1, -0.05)
    want = eye.T_cam_from_gaze @ T_gaze_from_ptu(0.1, -0.05) @ eye.T_ptu_from_base
    np.testing.assert_allclose(T, want, rtol=0, atol=1e-15)
    rng = np.random.default_rng(1)
    pan, tilt = rng.uniform(-0.5, 0.5, (2, 5, 7))
    Tb = eye.T_cam_from_base(pan, tilt)
    assert Tb.shape == (5, 7, 4, 4)
    for i, j in [(0, 0), (4, 6), (2, 3)]:
        np.testing.assert_allclose(Tb[i, j], eye.T_cam_from_base(pan[i, j], tilt[i, j]),
                                   rtol=0, atol=1e-15)  # same arithmetic, batched
    assert eye.T_cam_from_base(pan[0], 0.0).shape == (7, 4, 4)  # broadcast
    P = eye.projection_matrix(pan, tilt)
    assert P.shape == (5, 7, 3, 4)
    np.testing.assert_allclose(P[1, 2], eye.K @ np.eye(3, 4) @ Tb[1, 2], rtol=0, atol=1e-12)


def test_project_matches_opencv():
    head, _ = _head()
    rng = np.random.default_rng(2)
    p, angles = _scene(rng, 300)
    for eye, (pan, tilt) in ((head.left, angles[:2]), (head.right, angles[2:])):
        uv = eye.project(p, pan, tilt)
        assert _inside(uv)
        want = np.empty_like(uv)
        for k in range(len(p)):  # OpenCV, one pose per point
            T = eye.T_cam_from_base(pan[k], tilt[k])
            want[k] = cv2.projectPoints(p[k:k + 1], rotvec_from_matrix(T[:3, :3]), T[:3, 3],
                                        eye.K, eye.dist)[0].reshape(2)
        # 1e-8 px: OpenCV goes through a rotation vector (Rodrigues) and back, ~1e-15
        # relative on 2 m points, ×1000 px focal length (measured ≤ 8e-13 px).
        np.testing.assert_allclose(uv, want, rtol=0, atol=1e-8)
        uv0 = eye.project(p, 0.01, -0.02)  # one pose for all points
        T = eye.T_cam_from_base(0.01, -0.02)
        want0 = cv2.projectPoints(p, rotvec_from_matrix(T[:3, :3]), T[:3, 3], eye.K,
                                  eye.dist)[0].reshape(-1, 2)
        np.testing.assert_allclose(uv0, want0, rtol=0, atol=1e-8)


@pytest.mark.parametrize("method", ["ls", "tls"])
def test_round_trip_per_point_angles_with_distortion(method):
    head, _ = _head(3)
    rng = np.random.default_rng(4)
    p, angles = _scene(rng, 5000)
    uv_l, uv_r = head.project(p, *angles)
    assert _inside(uv_l) and _inside(uv_r)
    got = head.triangulate(uv_l, uv_r, *angles, method=method)
    # 1e-9 relative: undistortion is exact to 1e-12 normalised (1e-9 px), and the 4×3
    # systems are well conditioned (2 m depth, 0.3 m baseline): measured ≤ 5e-15.
    rel = np.linalg.norm(got - p, axis=1) / np.linalg.norm(p, axis=1)
    assert rel.max() < 1e-9


def test_ignoring_distortion_would_fail():
    # The round trip above has teeth: triangulating the distorted pixels as if ideal
    # misses (measured: median 9 mm, worst 14 cm; the lens moves pixels by up to 10 px).
    head, _ = _head(3)
    rng = np.random.default_rng(4)
    p, angles = _scene(rng, 500)
    uv_l, uv_r = head.project(p, *angles)
    no_lens = HeadCalibration(*(EyeCalibration(e.K, [], e.T_cam_from_gaze, e.T_ptu_from_base,
                                               e.image_size) for e in (head.left, head.right)))
    got = no_lens.triangulate(uv_l, uv_r, *angles)
    assert np.median(np.linalg.norm(got - p, axis=1)) > 1e-3


def test_round_trip_shared_angles():
    head, _ = _head(5)
    rng = np.random.default_rng(6)
    p, _ = _scene(rng, 2000)
    angles = (0.05, -0.03, -0.04, 0.02)
    uv_l, uv_r = head.project(p, *angles)
    got = head.triangulate(uv_l, uv_r, *angles)
    assert (np.linalg.norm(got - p, axis=1) / np.linalg.norm(p, axis=1)).max() < 1e-9  # as above


def test_mount_and_errors():
    head, T_LR = _head(7)
    np.testing.assert_allclose(head.T_ptuL_from_ptuR(), T_LR, rtol=0, atol=1e-12)
    with pytest.raises(InputError, match=r"point 0 is at or behind the camera"):
        head.left.project(np.array([[0.0, -2.0, 0.0]]), 0.0, 0.0)  # behind the head
    uv = np.array([[600.0, 400.0], [700.0, 500.0]])
    with pytest.raises(InputError, match=r"pan_right, tilt_right: expected scalars or shape"):
        head.triangulate(uv, uv, 0.0, 0.0, np.zeros(3), 0.0)
    # A lens that folds at r_d ≈ 0.854 (k1 = −0.4, k3 = −0.05): a pixel 1.2 focal lengths
    # from the centre has no ray; the error names the eye and the point.
    r = head.right
    folded = HeadCalibration(head.left, EyeCalibration(r.K, [-0.4, 0.2, 0.0, 0.0, -0.05],
                                                       r.T_cam_from_gaze, r.T_ptu_from_base,
                                                       r.image_size))
    far = r.K[:2, 2] + 1.2 * r.K[0, 0] * np.array([0.6, 0.8])
    with pytest.raises(InputError, match=r"right: undistort: point 1"):
        folded.triangulate(uv, np.array([[600.0, 400.0], far]), 0.0, 0.0, 0.0, 0.0)
    with pytest.raises(InputError, match="eye.K: focal lengths must be positive"):
        EyeCalibration(-np.eye(3) + np.diag([0, 0, 2]), [], np.eye(4), np.eye(4), SIZE)


def test_to_dict_from_dict_round_trip():
    head, _ = _head(8)
    d = head.to_dict()
    text = json.dumps(d, allow_nan=False)  # JSON-ready: lists, numbers, strings only
    back = HeadCalibration.from_dict(json.loads(text))
    assert back.to_dict() == d  # exact: floats survive JSON's repr round trip
    for a, b in ((head.left, back.left), (head.right, back.right)):
        for f in ("K", "dist", "T_cam_from_gaze", "T_ptu_from_base"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
        assert a.image_size == b.image_size
    rng = np.random.default_rng(9)
    p, angles = _scene(rng, 50)
    for a, b in zip(head.project(p, *angles), back.project(p, *angles), strict=True):
        np.testing.assert_array_equal(a, b)


def _set(path, value):
    def mutate(d):
        *keys, last = path
        for k in keys:
            d = d[k]
        if value is _DELETE:
            del d[last]
        elif callable(value):
            d[last] = value(d[last])
        else:
            d[last] = value
    return mutate


_DELETE = object()


def _scale(a, s):
    a = np.array(a)
    a[0, 0] *= s
    return a.tolist()


@pytest.mark.parametrize("mutate, message", [
    (_set(["left", "T_cam_from_gaze"], lambda T: _scale(T, 1.1)),
     r"^left\.T_cam_from_gaze: .*not orthonormal"),
    (_set(["right", "T_ptu_from_base", 3], [0, 0, 1, 1]), r"^right\.T_ptu_from_base: last row"),
    (_set(["right", "K"], [[1000, 0, 640], [0, 1000, 480]]), r"^right\.K: expected a 3x3"),
    (_set(["left", "K"], "abc"), r"^left\.K: expected a list of numbers, got str"),
    (_set(["left", "K", 2], [0, 0, 2]), r"^left\.K: not upper triangular"),
    (_set(["left", "dist"], [0.1, 0.2, 0.3]), r"^left\.dist: expected 0, 4, 5 or 8"),
    (_set(["left", "dist"], [0.1, "x", 0, 0]), r"^left\.dist: not a numeric"),
    (_set(["left", "image_size"], [1280]), r"^left\.image_size: expected \[width, height\]"),
    (_set(["left", "image_size"], [1280.5, 960]), r"^left\.image_size"),
    (_set(["right", "image_size"], [1280, -960]), r"^right\.image_size"),
    (_set(["right"], _DELETE), r"^right: missing"),
    (_set(["left", "K"], _DELETE), r"^left\.K: missing"),
    (_set(["left", "focal"], 1000), r"^left\.focal: unknown field"),
    (_set(["units"], "mm"), r"^units: unknown field"),
    (_set(["format"], "rasc-head/2"), r"^format: expected 'rasc-head/1'"),
    (_set(["left"], [1, 2]), r"^left: expected an object"),
])
def test_from_dict_names_the_bad_field(mutate, message):
    head, _ = _head(10)
    d = copy.deepcopy(head.to_dict())
    mutate(d)
    with pytest.raises(InputError, match=message):
        HeadCalibration.from_dict(d)
    with pytest.raises(InputError, match=r"^head\.json: " + message[1:]):
        HeadCalibration.from_dict(d, source="head.json")


def test_from_dict_rejects_non_dict():
    with pytest.raises(InputError, match="expected an object with format 'rasc-head/1'"):
        HeadCalibration.from_dict([1, 2, 3])
