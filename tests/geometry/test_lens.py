"""OpenCV's distortion model in numpy (rasc.geometry.lens) against OpenCV itself."""

import cv2
import numpy as np
import pytest

from rasc.errors import InputError
from rasc.geometry import lens

K = np.array([[1000.0, 0.0, 639.5], [0.0, 1010.0, 479.5], [0.0, 0.0, 1.0]])
SIZE = (1280, 960)

#: Realistic lenses, one per accepted length (k1 k2 p1 p2 [k3 [k4 k5 k6]]). The 4- and
#: 5-coefficient ones are like OpenCV's sample camera (k1 ≈ −0.28); the 8-coefficient one is
#: a rational fit of a wide lens. Each moves the 1280×960 image corners by 4–40 %.
DISTS = {
    "none": [],
    "k4": [-0.28, 0.07, 0.001, -0.0005],
    "k5": [-0.4, 0.2, 0.0005, 0.001, -0.05],
    "pincushion": [0.1, -0.05, 0.002, 0.001, 0.01],
    "rational": [2.0, 1.0, 0.001, 0.001, 0.1, 2.3, 1.5, 0.2],
}


def _points_in_view(rng, n=2000, depth=(0.5, 5.0)):
    """Camera-frame points whose ideal projection fills the 1280×960 image."""
    z = rng.uniform(*depth, n)
    x = rng.uniform(-0.64, 0.64, n) * z
    y = rng.uniform(-0.475, 0.475, n) * z
    return np.stack([x, y, z], axis=1)


@pytest.mark.parametrize("name", DISTS)
def test_project_points_matches_opencv(name):
    rng = np.random.default_rng(0)
    p_cam = _points_in_view(rng)
    dist = DISTS[name]
    uv_cv, _ = cv2.projectPoints(p_cam, np.zeros(3), np.zeros(3), K, np.array(dist, float))
    # 1e-9 px: both evaluate the same polynomial in double precision; measured difference
    # ≤ 5e-13 px (rounding order). Any mistake in the model (p1/p2 swapped, a wrong power)
    # moves pixels by ≥ 1e-3 px with these coefficients.
    np.testing.assert_allclose(lens.project_points(p_cam, K, dist), uv_cv.reshape(-1, 2),
                               rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", DISTS)
def test_distort_normalized_matches_opencv(name):
    rng = np.random.default_rng(1)
    xy = rng.uniform(-0.8, 0.8, (1000, 2))
    p = np.c_[xy, np.ones(len(xy))]
    dist = DISTS[name]
    xy_cv, _ = cv2.projectPoints(p, np.zeros(3), np.zeros(3), np.eye(3), np.array(dist, float))
    # 1e-13 in normalised units: same arithmetic, measured ≤ 4e-16.
    np.testing.assert_allclose(lens.distort_normalized(xy, dist), xy_cv.reshape(-1, 2),
                               rtol=0, atol=1e-13)


@pytest.mark.parametrize("name", DISTS)
def test_undistort_normalized_converges_to_1e12(name):
    rng = np.random.default_rng(2)
    dist = DISTS[name]
    # Distorted points covering the whole image, corners included.
    uv = np.c_[rng.uniform(-0.5, SIZE[0] - 0.5, 3000), rng.uniform(-0.5, SIZE[1] - 0.5, 3000)]
    uv[:4] = [[-0.5, -0.5], [SIZE[0] - 0.5, -0.5], [-0.5, SIZE[1] - 0.5],
              [SIZE[0] - 0.5, SIZE[1] - 0.5]]
    xy_d = np.c_[(uv[:, 0] - K[0, 2]) / K[0, 0], (uv[:, 1] - K[1, 2]) / K[1, 1]]
    xy = lens.undistort_normalized(xy_d, dist)
    # The contract: distorting the answer gives the input back to 1e-12 (normalised units).
    np.testing.assert_allclose(lens.distort_normalized(xy, dist), xy_d, rtol=0, atol=1e-12)
    # And the other way: ideal → distorted → ideal. 1e-12: Newton's answer is exact to
    # round-off; the Jacobian of these lenses is well conditioned inside the image.
    np.testing.assert_allclose(lens.undistort_normalized(lens.distort_normalized(xy, dist),
                                                         dist), xy, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", DISTS)
def test_undistort_pixels_matches_opencv_iterated(name):
    rng = np.random.default_rng(3)
    dist = DISTS[name]
    p_cam = _points_in_view(rng, depth=(1.0, 3.0))
    uv = lens.project_points(p_cam, K, dist)
    ideal = lens.project_points(p_cam, K, None)
    ours = lens.undistort_pixels(uv, K, dist)
    # Against the truth: 1e-9 px (1e-12 normalised × 1000 px focal length).
    np.testing.assert_allclose(ours, ideal, rtol=0, atol=1e-9)
    # Against OpenCV run to convergence (its fixed-point iteration, up to 1000 steps,
    # stopping at 1e-14 reprojection error): measured agreement ≤ 5e-13 px; 1e-8 px
    # leaves room for its stopping rule.
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 1000, 1e-14)
    uv_cv = cv2.undistortPointsIter(uv.reshape(-1, 1, 2), K, np.array(dist, float), None, K,
                                    crit).reshape(-1, 2)
    np.testing.assert_allclose(ours, uv_cv, rtol=0, atol=1e-8)


def test_opencv_default_undistort_is_not_converged():
    # Why this module does its own inverse: cv2.undistortPoints stops after 5 fixed-point
    # iterations. With the k1 = −0.4 lens it is off by a tenth of a pixel or more at the
    # image edges (measured 0.18–0.25 px), while ours is exact to 1e-9 px.
    rng = np.random.default_rng(4)
    dist = DISTS["k5"]
    p_cam = _points_in_view(rng)
    uv = lens.project_points(p_cam, K, dist)
    ideal = lens.project_points(p_cam, K, None)
    uv_cv = cv2.undistortPoints(uv.reshape(-1, 1, 2), K, np.array(dist, float), None,
                                K).reshape(-1, 2)
    assert np.abs(uv_cv - ideal).max() > 0.05
    assert np.abs(lens.undistort_pixels(uv, K, dist) - ideal).max() < 1e-9


def test_no_distortion_is_identity_and_zeros_equal_none():
    rng = np.random.default_rng(5)
    xy = rng.uniform(-1, 1, (100, 2))
    np.testing.assert_array_equal(lens.distort_normalized(xy, None), xy)
    np.testing.assert_array_equal(lens.distort_normalized(xy, np.zeros(8)), xy)
    np.testing.assert_array_equal(lens.undistort_normalized(xy, [0.0, 0.0, 0.0, 0.0]), xy)
    p = _points_in_view(rng, 50)
    np.testing.assert_array_equal(lens.project_points(p, K, []),
                                  lens.project_points(p, K, np.zeros(5)))


def test_skewed_K_is_inverted_consistently():
    Ks = K.copy()
    Ks[0, 1] = 3.0  # OpenCV has no skew; ours uses K and K⁻¹ consistently
    rng = np.random.default_rng(6)
    p = _points_in_view(rng, 200)
    uv = lens.project_points(p, Ks, DISTS["k4"])
    # 1e-9 px: round trip through Newton at 1e-12 normalised.
    np.testing.assert_allclose(lens.undistort_pixels(uv, Ks, DISTS["k4"]),
                               lens.project_points(p, Ks, None), rtol=0, atol=1e-9)


def test_point_behind_camera_is_refused_by_index():
    p = np.array([[0.0, 0.0, 1.0], [0.1, 0.2, 2.0], [0.0, 0.0, -1.0], [0.0, 0.0, 0.0]])
    with pytest.raises(InputError, match=r"point 2 is at or behind the camera.*2 such points"):
        lens.project_points(p, K, DISTS["k4"])


def test_non_invertible_point_is_refused():
    # k1 = −0.4, k3 = −0.05: r·radial(r²) peaks at r_d ≈ 0.854 (r ≈ 1.36); a distorted
    # point at r_d = 1.0 has no ideal pre-image, Newton cannot converge.
    xy_d = np.array([[0.1, 0.1], [1.0, 0.0], [0.2, 0.0]])
    with pytest.raises(InputError, match=r"point 1 .*not converge"):
        lens.undistort_normalized(xy_d, DISTS["k5"])


@pytest.mark.parametrize("dist, fragment", [
    ([0.1, 0.2, 0.3], "expected 0, 4, 5 or 8 coefficients"),
    ([0.1] * 12, "got 12"),
    ([np.nan, 0, 0, 0], "NaN"),
    ("abc", "not a numeric"),
])
def test_bad_coefficients(dist, fragment):
    with pytest.raises(InputError, match=fragment):
        lens.distort_normalized(np.zeros((1, 2)), dist)


@pytest.mark.parametrize("bad, fragment", [
    (np.eye(2), "3x3"),
    (np.array([[1000.0, 0, 320], [0, 1000, 240], [0, 0, 2]]), "last row"),
    (np.array([[-1000.0, 0, 320], [0, 1000, 240], [0, 0, 1]]), "positive"),
])
def test_bad_K(bad, fragment):
    with pytest.raises(InputError, match=f"K: .*{fragment}"):
        lens.project_points(np.array([[0.0, 0.0, 1.0]]), bad, None)


def test_bad_points_shape_and_nan():
    with pytest.raises(InputError, match=r"uv: expected shape \(N, 2\)"):
        lens.undistort_pixels(np.zeros((3, 3)), K, None)
    with pytest.raises(InputError, match=r"p_cam\[1\]: contains NaN"):
        lens.project_points(np.array([[0, 0, 1.0], [np.nan, 0, 1]]), K, None)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["k4", "rational", "pincushion"])
def test_distortion_remap_maps_are_the_inverse(name):
    dist = DISTS[name]
    map_x, map_y = lens.distortion_remap(K, dist, SIZE)
    assert map_x.shape == (SIZE[1], SIZE[0]) and map_x.dtype == np.float32
    # Every distorted pixel (u, v) maps to an ideal pixel whose distorted projection is (u, v).
    vv, uu = np.mgrid[0:SIZE[1]:37, 0:SIZE[0]:41]
    ideal = np.c_[map_x[vv, uu].ravel(), map_y[vv, uu].ravel()].astype(float)
    x = (ideal[:, 0] - K[0, 2]) / K[0, 0]
    y = (ideal[:, 1] - K[1, 2]) / K[1, 1]
    uv = lens.project_points(np.c_[x, y, np.ones_like(x)], K, dist)
    # 1e-3 px: the maps are float32 (spacing 1.2e-4 px at 1280) and the lens magnifies
    # round-off by at most its local scale (< 2 here).
    np.testing.assert_allclose(uv, np.c_[uu.ravel(), vv.ravel()], rtol=0, atol=1e-3)


@pytest.mark.slow
def test_distortion_remap_moves_a_blob_to_its_distorted_projection():
    dist = DISTS["k5"]
    map_x, map_y = lens.distortion_remap(K, dist, SIZE)
    rng = np.random.default_rng(7)
    vv, uu = np.mgrid[0:SIZE[1], 0:SIZE[0]].astype(float)
    p_cam = _points_in_view(rng, 8, depth=(2.0, 2.0)) * [0.8, 0.8, 1.0]
    ideal_uv = lens.project_points(p_cam, K, None)
    want = lens.project_points(p_cam, K, dist)
    sigma = 2.5  # px: a blob the lens hardly reshapes, wide enough for bilinear sampling
    for (ui, vi), (ud, vd) in zip(ideal_uv, want, strict=True):
        ideal = np.exp(-((uu - ui) ** 2 + (vv - vi) ** 2) / (2 * sigma ** 2)).astype(np.float32)
        warped = cv2.remap(ideal, map_x, map_y, cv2.INTER_LINEAR)
        win = (np.abs(uu - ud) < 15) & (np.abs(vv - vd) < 15)
        w = warped[win]
        got = np.array([(w * uu[win]).sum(), (w * vv[win]).sum()]) / w.sum()
        # 0.03 px: the centroid of a bilinearly resampled σ = 2.5 px Gaussian moves with
        # its sub-pixel phase, and the lens's curvature over the blob shifts it too
        # (measured worst 0.018 px on these points, 0.023 px with other lenses).
        np.testing.assert_allclose(got, [ud, vd], rtol=0, atol=0.03)
    # The test has teeth: the lens moves these points by up to ~40 px.
    assert np.hypot(*(want - ideal_uv).T).max() > 20.0


@pytest.mark.slow
def test_distortion_remap_flags_rays_outside_the_model():
    # k1 = −0.4, k3 = −0.05 folds at r_d ≈ 0.854: with f = 500 px the image corners
    # (r_d ≈ 1.6) have no pre-image and must map outside the ideal image.
    K_wide = np.array([[500.0, 0, 639.5], [0, 500.0, 479.5], [0, 0, 1]])
    map_x, map_y = lens.distortion_remap(K_wide, DISTS["k5"], SIZE)
    assert map_x[0, 0] == -1.0 and map_y[0, 0] == -1.0
    assert map_x[480, 640] == pytest.approx(640.0, abs=1e-3)  # the centre maps to itself


def test_validate_dist_accepts_opencv_shapes():
    # cv2.calibrateCamera returns dist as (1, 5); the model reads it as five coefficients.
    d = lens.validate_dist(np.array([DISTS["k5"]]))
    np.testing.assert_array_equal(d, DISTS["k5"])
    assert lens.validate_dist(None).shape == (0,)
    with pytest.raises(InputError, match="left.dist: expected 0, 4, 5 or 8"):
        lens.validate_dist([1.0, 2.0], name="left.dist")


def test_undistortion_in_blocks_has_the_one_pass_bits(monkeypatch):
    """_undistort iterates blocks of _UNDISTORT_BLOCK points; every point is its own Newton
    iteration, so the blocks give one pass's bits, the points that fail to converge
    (beyond the fold of a strong barrel lens) included."""
    rng = np.random.default_rng(21)
    xy = rng.uniform(-2.0, 2.0, (3 * lens._UNDISTORT_BLOCK + 17, 2))
    for dist in ([-0.2, 0.05, 0.001, -0.002, 0.0], [-1.0, 0.0, 0.0, 0.0]):
        d = lens._coefficients(dist)
        blocks = lens._undistort(xy[:, 0], xy[:, 1], d, lens.UNDISTORT_TOL,
                                 lens.UNDISTORT_MAX_ITER)
        monkeypatch.setattr(lens, "_UNDISTORT_BLOCK", len(xy))
        one = lens._undistort(xy[:, 0], xy[:, 1], d, lens.UNDISTORT_TOL,
                              lens.UNDISTORT_MAX_ITER)
        monkeypatch.undo()
        assert one[2].sum() > 0 and (dist[0] > -1 or not one[2].all())
        for a, b in zip(blocks, one, strict=True):
            np.testing.assert_array_equal(a, b)
