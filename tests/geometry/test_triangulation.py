"""Linear triangulation, eq. 15–19 with the a34 erratum (rasc.geometry.triangulation)."""

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.triangulation import triangulate


def _look_at(centre, target, rng):
    """R_cam_from_world of a camera at ``centre`` looking at ``target`` (OpenCV axes),
    rolled by a random angle about its axis."""
    z = target - centre
    z /= np.linalg.norm(z)
    x = np.cross(z, rng.normal(size=3))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z])  # rows: camera axes in world


def _random_camera(rng, centre, target):
    f = rng.uniform(500, 2000)
    K = np.array([[f, rng.uniform(-2, 2), rng.uniform(300, 700)],
                  [0, f * rng.uniform(0.95, 1.05), rng.uniform(200, 500)], [0, 0, 1]])
    R = _look_at(centre, target, rng)
    return K @ np.c_[R, -R @ centre]


def _random_rig(rng):
    """Two cameras 0.1–0.5 m apart, 1–4 m from a 1 m box of points around ``target``."""
    target = rng.uniform(-1, 1, 3)
    distance = rng.uniform(1.0, 4.0)
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    mid = target - distance * direction
    side = np.cross(direction, rng.normal(size=3))
    side *= rng.uniform(0.05, 0.25) / np.linalg.norm(side)
    return _random_camera(rng, mid - side, target), _random_camera(rng, mid + side, target), target


def _project(P, p):
    """Ideal projection with P (3,4) or (N,3,4) of points p (N,3): eq. 16–18 with a34."""
    ph = np.c_[p, np.ones(len(p))]
    q = np.einsum("...ij,...j->...i", P, ph)
    return q[:, :2] / q[:, 2:]


def _rel_err(p_est, p):
    return np.max(np.linalg.norm(p_est - p, axis=1) / np.linalg.norm(p, axis=1).clip(1.0))


@pytest.mark.parametrize("method", ["ls", "tls"])
def test_noise_free_exact_recovery_shared_projections(method):
    rng = np.random.default_rng(10)
    for _ in range(20):
        P_l, P_r, target = _random_rig(rng)
        p = target + rng.uniform(-0.5, 0.5, (3000, 3))
        got = triangulate(P_l, P_r, _project(P_l, p), _project(P_r, p), method)
        # 1e-9 relative: the 4×3 systems have condition numbers ≤ 50 here (measured), so
        # the normal equations (condition ≤ 2500) lose ≲ 1e-12; measured worst 3e-13 (ls),
        # 3e-14 (tls). A wrong row, sign or a14 gives errors of order 1e-2 or more.
        assert _rel_err(got, p) < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("method", ["ls", "tls"])
def test_noise_free_exact_recovery_per_point_projections(method):
    rng = np.random.default_rng(11)
    n = 2000
    rigs = [_random_rig(rng) for _ in range(n)]
    P_l = np.stack([r[0] for r in rigs])
    P_r = np.stack([r[1] for r in rigs])
    p = np.stack([r[2] for r in rigs]) + rng.uniform(-0.5, 0.5, (n, 3))
    uv_l, uv_r = _project(P_l, p), _project(P_r, p)
    assert _rel_err(triangulate(P_l, P_r, uv_l, uv_r, method), p) < 1e-9  # as above
    # One eye shared, the other per point.
    P_shared = P_l[0]
    uv_s = _project(P_shared, p)
    assert _rel_err(triangulate(P_shared, P_r, uv_s, uv_r, method), p) < 1e-9


def test_erratum_a34_not_a14():
    # Eq. 17–18 as printed divide by a31 x + a32 y + a33 z + a14. Solving that version
    # on data from a real camera (where p14 ≠ p34) misses the points by centimetres to
    # metres; the a34 version used here is exact. This test fails if a14 is used.
    rng = np.random.default_rng(12)
    P_l, P_r, target = _random_rig(rng)
    p = target + rng.uniform(-0.5, 0.5, (500, 3))
    uv_l, uv_r = _project(P_l, p), _project(P_r, p)
    assert abs(P_l[0, 3] - P_l[2, 3]) > 1.0  # the two candidates really differ

    def rows_printed(P, uv):  # (u p3 − p1)·x = p14 − u p14: the paper's typo
        u, v = uv[:, :1], uv[:, 1:]
        A = np.stack([u * P[2, :3] - P[0, :3], v * P[2, :3] - P[1, :3]], axis=1)
        b = np.stack([P[0, 3] - u[:, 0] * P[0, 3], P[1, 3] - v[:, 0] * P[0, 3]], axis=1)
        return A, b

    A_l, b_l = rows_printed(P_l, uv_l)
    A_r, b_r = rows_printed(P_r, uv_r)
    A, b = np.concatenate([A_l, A_r], axis=1), np.concatenate([b_l, b_r], axis=1)
    wrong = np.stack([np.linalg.lstsq(A[k], b[k], rcond=None)[0] for k in range(len(p))])
    assert np.median(np.linalg.norm(wrong - p, axis=1)) > 0.01
    for method in ("ls", "tls"):
        assert _rel_err(triangulate(P_l, P_r, uv_l, uv_r, method), p) < 1e-9


def _noisy_points(seed: int, n: int, sigma_px: float):
    """A random rig and n points within 0.5 m of its target, seen by both cameras with
    Gaussian pixel noise of ``sigma_px``: ``(P_l, P_r, p, uv_l, uv_r)``."""
    rng = np.random.default_rng(seed)
    P_l, P_r, target = _random_rig(rng)
    p = target + rng.uniform(-0.5, 0.5, (n, 3))
    uv_l = _project(P_l, p) + rng.normal(0, sigma_px, (n, 2))
    uv_r = _project(P_r, p) + rng.normal(0, sigma_px, (n, 2))
    return P_l, P_r, p, uv_l, uv_r


def test_ls_equals_per_point_lstsq_with_noise():
    P_l, P_r, p, uv_l, uv_r = _noisy_points(13, 200, 0.5)
    got = triangulate(P_l, P_r, uv_l, uv_r, "ls")
    want = []
    for k in range(len(p)):  # eq. 19 written out, one point at a time, solved by lstsq
        A, b = [], []
        for P, (u, v) in ((P_r, uv_r[k]), (P_l, uv_l[k])):
            A += [u * P[2, :3] - P[0, :3], v * P[2, :3] - P[1, :3]]
            b += [P[0, 3] - u * P[2, 3], P[1, 3] - v * P[2, 3]]
        want.append(np.linalg.lstsq(np.array(A), np.array(b), rcond=None)[0])
    # 1e-9 relative: normal equations vs SVD on systems with condition ≤ 50.
    assert _rel_err(got, np.array(want)) < 1e-9
    assert _rel_err(got, p) > 1e-6  # the noise is real: LS is not just returning the truth


def test_tls_equals_opencv_triangulate_points_with_noise():
    # OpenCV's triangulatePoints takes the smallest right singular vector of the same
    # 4×4 homogeneous system, so on noisy data it must agree with method="tls"
    # (and not with "ls", which weights the noise differently).
    P_l, P_r, p, uv_l, uv_r = _noisy_points(14, 1000, 1.0)
    h = cv2.triangulatePoints(P_l, P_r, uv_l.T.copy(), uv_r.T.copy())
    p_cv = (h[:3] / h[3]).T
    tls = triangulate(P_l, P_r, uv_l, uv_r, "tls")
    ls = triangulate(P_l, P_r, uv_l, uv_r, "ls")
    # 1e-8 relative: two double-precision SVDs of the same matrix (measured 2e-14);
    # "ls" differs from OpenCV by 1e-2 relative on this data.
    assert _rel_err(tls, p_cv) < 1e-8
    assert _rel_err(ls, p_cv) > 1e-7


def _parallel_rig():
    K = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    P_l = K @ np.c_[np.eye(3), [0.1, 0, 0]]   # centre (−0.1, 0, 0)
    P_r = K @ np.c_[np.eye(3), [-0.1, 0, 0]]  # centre (+0.1, 0, 0), same orientation
    return K, P_l, P_r


def test_parallel_rays_are_degenerate():
    K, P_l, P_r = _parallel_rig()
    uv = np.array([[300.0, 200.0], [320.0, 240.0]])
    # Same pixel in two parallel cameras: parallel rays, a point at infinity.
    with pytest.raises(DegenerateDataError, match=r"point 0 \(and 1 others\).*parallel rays"):
        triangulate(P_l, P_r, uv, uv)
    with pytest.raises(DegenerateDataError):
        triangulate(P_l, P_r, uv, uv, "tls")


def test_zero_baseline_is_degenerate_even_with_noise():
    rng = np.random.default_rng(15)
    K = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    R_r = Rotation.from_rotvec([0.0, 0.1, 0.0]).as_matrix()
    P_l = K @ np.c_[np.eye(3), np.zeros(3)]
    P_r = K @ np.c_[R_r, np.zeros(3)]  # same centre, turned by 5.7°
    p = rng.uniform(-0.3, 0.3, (50, 3)) + [0, 0, 2]
    uv_l, uv_r = _project(P_l, p), _project(P_r, p)
    for method in ("ls", "tls"):
        with pytest.raises(DegenerateDataError):
            triangulate(P_l, P_r, uv_l, uv_r, method)
        # With noise the rays no longer coincide and meet at the common centre: still
        # degenerate (the centres subtend no angle there), never a number.
        with pytest.raises(DegenerateDataError):
            triangulate(P_l, P_r, uv_l + rng.normal(0, 0.5, uv_l.shape), uv_r, method)


@pytest.mark.parametrize("method", ["ls", "tls"])
def test_on_degenerate_nan_flags_only_the_bad_points(method):
    K, P_l, P_r = _parallel_rig()
    rng = np.random.default_rng(16)
    p = rng.uniform(-0.5, 0.5, (100, 3)) + [0, 0, 2]
    uv_l, uv_r = _project(P_l, p), _project(P_r, p)
    bad = [3, 50, 99]
    uv_r[bad] = uv_l[bad]  # these rows now describe parallel rays
    got = triangulate(P_l, P_r, uv_l, uv_r, method, on_degenerate="nan")
    assert np.all(np.isnan(got[bad]))
    good = np.setdiff1d(np.arange(100), bad)
    assert _rel_err(got[good], p[good]) < 1e-9


def test_parallax_threshold():
    # Baseline 0.2 m: a point on the axis at depth z subtends 2·atan(0.1 / z).
    K, P_l, P_r = _parallel_rig()
    for depth, ok in ((5000.0, True), (20000.0, False)):  # 2.3e-3° and 5.7e-4°
        p = np.array([[0.0, 0.0, depth]])
        uv_l, uv_r = _project(P_l, p), _project(P_r, p)
        if ok:
            # 1e-6 relative at 5 km: the system's conditioning grows like depth/baseline.
            assert _rel_err(triangulate(P_l, P_r, uv_l, uv_r), p) < 1e-6
        else:
            with pytest.raises(DegenerateDataError):
                triangulate(P_l, P_r, uv_l, uv_r)
            # A lower threshold accepts it.
            got = triangulate(P_l, P_r, uv_l, uv_r, min_parallax_deg=1e-4)
            assert _rel_err(got, p) < 1e-6


def test_bad_inputs():
    K, P_l, P_r = _parallel_rig()
    uv = np.array([[300.0, 200.0], [320.0, 240.0]])
    with pytest.raises(InputError, match="method"):
        triangulate(P_l, P_r, uv, uv + 10, "svd")
    with pytest.raises(InputError, match=r"uv_right: 1 points, uv_left has 2"):
        triangulate(P_l, P_r, uv, uv[:1])
    with pytest.raises(InputError, match=r"P_left: expected shape \(3, 4\) or \(2, 3, 4\)"):
        triangulate(np.stack([P_l] * 3), P_r, uv, uv + 10)
    with pytest.raises(InputError, match=r"P_right\[0\]: left 3x3 block is singular"):
        triangulate(P_l, np.zeros((3, 4)), uv, uv + 10)
    with pytest.raises(InputError, match=r"uv_left\[1\]: contains NaN"):
        triangulate(P_l, P_r, np.array([[1.0, 2.0], [np.nan, 1.0]]), uv)
