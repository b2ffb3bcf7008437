"""The lens models (rasc.geometry.lens.LENS_MODELS) against OpenCV's own implementations,
their inverses and their analytic Jacobians against finite differences.

Tolerances: OpenCV and numpy evaluate the same polynomials in double precision, so the
pixels agree to round-off (1e-9 px allows for the differing order of operations at 1000 px);
the round trips are Newton solves converged to 1e-12 in normalised units (≈1e-9 px at
f = 1000 px); central differences with h = 1e-7 carry an error of order h² ≈ 1e-14 plus
round-off ε/h ≈ 1e-9, hence 1e-7 on derivatives of order one.
"""

import cv2
import numpy as np
import pytest

from rasc.errors import InputError
from rasc.geometry import lens

K = np.array([[400.0, 0.0, 640.0], [0.0, 410.0, 480.0], [0.0, 0.0, 1.0]])
FISHEYE = np.array([0.05, -0.02, 0.004, -0.0005])          # a real 180° lens's order of size
RATIONAL = np.array([0.3, -0.1, 0.001, -0.002, 0.02, 0.25, -0.05, 0.01])


def _rays(n, max_deg, seed):
    rng = np.random.default_rng(seed)
    th = rng.uniform(0.0, np.radians(max_deg), n)
    ph = rng.uniform(0.0, 2.0 * np.pi, n)
    d = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=1)
    return d * rng.uniform(0.5, 3.0, (n, 1))


def _ideal(p):
    return (K @ (p / p[:, 2:]).T).T[:, :2]


def test_fisheye_matches_opencv_to_80_degrees_off_axis():
    p = _rays(2000, 80.0, seed=1)        # a 160° field of view
    uv = lens.project_points(p, K, FISHEYE, model="fisheye")
    ref, _ = cv2.fisheye.projectPoints(p[None], np.zeros(3), np.zeros(3), K, FISHEYE)
    assert np.abs(uv - ref[0]).max() < 1e-9


def test_rational_matches_opencv():
    p = _rays(2000, 45.0, seed=2)
    uv = lens.project_points(p, K, RATIONAL)
    ref, _ = cv2.projectPoints(p, np.zeros(3), np.zeros(3), K, RATIONAL)
    assert np.abs(uv - ref[:, 0]).max() < 1e-9


@pytest.mark.parametrize("model, dist, max_deg", [("fisheye", FISHEYE, 80.0),
                                                  ("pinhole", RATIONAL, 45.0)])
def test_round_trip_recovers_the_ideal_pixels(model, dist, max_deg):
    p = _rays(2000, max_deg, seed=3)
    uv = lens.project_points(p, K, dist, model=model)
    back = lens.undistort_pixels(uv, K, dist, model=model)
    # ideal pixels reach thousands of px at 80° (tan 80° · 400 ≈ 2300): relative 1e-12
    assert np.abs(back - _ideal(p)).max() < 1e-12 * np.abs(_ideal(p)).max() + 1e-9


def test_fisheye_refuses_a_pixel_beyond_90_degrees():
    # the image corner of a 400 px focal length sees 1.98 rad off axis: beyond 90°
    with pytest.raises(InputError, match="outside the region"):
        lens.undistort_pixels(np.array([[0.0, 0.0]]), K, np.zeros(4), model="fisheye")


@pytest.mark.parametrize("model, dist, half", [("fisheye", FISHEYE, 1.5),
                                               ("pinhole", RATIONAL, 0.9)])
def test_jacobians_match_central_differences(model, dist, half):
    rng = np.random.default_rng(4)
    x, y = rng.uniform(-half, half, 200), rng.uniform(-half, half, 200)
    x[0], y[0] = 1e-9, -2e-9                  # the fisheye's series branch at the centre
    xd, yd, jac, by = lens.distortion_jacobians(x, y, dist, model)
    h = 1e-7
    for k, (a, b) in enumerate(((h, 0.0), (0.0, h))):
        plus = lens.distortion_jacobians(x + a, y + b, dist, model)
        minus = lens.distortion_jacobians(x - a, y - b, dist, model)
        assert np.abs((plus[0] - minus[0]) / (2 * h) - jac[k]).max() < 1e-7
        assert np.abs((plus[1] - minus[1]) / (2 * h) - jac[2 + k]).max() < 1e-7
    for i, name in enumerate(lens.LENS_MODELS[model]):
        dp, dm = dist.astype(float).copy(), dist.astype(float).copy()
        dp[i] += h
        dm[i] -= h
        plus = lens.distortion_jacobians(x, y, dp, model)
        minus = lens.distortion_jacobians(x, y, dm, model)
        assert np.abs((plus[0] - minus[0]) / (2 * h) - by[name][0]).max() < 1e-7
        assert np.abs((plus[1] - minus[1]) / (2 * h) - by[name][1]).max() < 1e-7
    assert np.allclose(np.stack([xd, yd], 1),
                       lens.distort_normalized(np.stack([x, y], 1), dist, model=model))


def test_wrong_model_or_coefficient_count_is_one_line():
    with pytest.raises(InputError, match="unknown lens model 'kb'"):
        lens.project_points(np.array([[0.0, 0.0, 1.0]]), K, FISHEYE, model="kb")
    with pytest.raises(InputError, match="0 or 4 coefficients for a fisheye"):
        lens.validate_dist([0.1, 0.0, 0.0, 0.0, 0.0], model="fisheye")


def test_fisheye_remap_puts_corners_where_the_model_projects():
    # the remap's inverse agrees with the projection: pixel → ideal pixel → re-projected
    size = (160, 120)
    k = np.array([[60.0, 0.0, 80.0], [0.0, 60.0, 60.0], [0.0, 0.0, 1.0]])
    mx, my = lens.distortion_remap(k, FISHEYE, size, model="fisheye")
    ok = mx >= 0
    vv, uu = np.nonzero(ok)
    ideal = np.stack([mx[ok], my[ok]], axis=1).astype(float)
    p = np.c_[(ideal - k[:2, 2]) / [k[0, 0], k[1, 1]], np.ones(len(ideal))]
    uv = lens.project_points(p, k, FISHEYE, model="fisheye")
    # float32 maps: ideal pixels of up to a few hundred px, 2^-24 relative → < 1e-3 px
    assert np.abs(uv - np.stack([uu, vv], axis=1)).max() < 2e-3


def test_a_fisheye_eye_projects_triangulates_and_round_trips_its_file():
    from rasc.head.model import EyeCalibration, HeadCalibration
    from rasc.sim.synthetic import default_head

    truth = default_head()
    k = np.array([[300.0, 0.0, 640.0], [0.0, 300.0, 480.0], [0.0, 0.0, 1.0]])
    eyes = {e: EyeCalibration(K=k, dist=FISHEYE, T_cam_from_gaze=truth.T_cam_from_gaze[e],
                              T_ptu_from_base=truth.T_ptu_from_base[e],
                              image_size=(1280, 960), lens="fisheye") for e in ("left", "right")}
    head = HeadCalibration(**eyes)
    back = HeadCalibration.from_dict(head.to_dict())
    assert back.left.lens == "fisheye" and head.to_dict()["left"]["lens"] == "fisheye"
    rng = np.random.default_rng(5)
    # points ahead of both eyes, up to ~50° off the left eye's axis
    c = rng.uniform([-0.8, -0.6, 0.9], [0.8, 0.6, 1.5], (50, 3))
    T = np.linalg.inv(back.left.T_cam_from_base(0.0, 0.0))
    p = c @ T[:3, :3].T + T[:3, 3]
    uvl, uvr = back.project(p, 0.0, 0.0, 0.0, 0.0)
    q = back.triangulate(uvl, uvr, 0.0, 0.0, 0.0, 0.0)
    assert np.abs(q - p).max() < 1e-9
    with pytest.raises(InputError, match="left.lens: unknown lens model"):
        HeadCalibration.from_dict({**head.to_dict(), "left": {**head.to_dict()["left"],
                                                              "lens": "omni"}})
