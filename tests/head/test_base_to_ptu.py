"""Base-to-ptu calibration: loop closure (eq. 11–12), measured mounts, cyclopean base."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.kinematics import T_gaze_from_ptu
from rasc.geometry.transforms import (
    invert_transform,
    make_transform,
    matrix_from_rotvec,
    project_to_rotation,
    rotation_angle,
    rotation_error_deg,
    rotvec_from_matrix,
)
from rasc.head.base_to_ptu import (
    T_ptuL_from_ptuR_from_mounts,
    T_ptuL_from_ptuR_loop_closure,
    T_ptuL_from_ptuR_per_view,
    cyclopean_base,
    mount_errors,
    perturb_mounts,
)

from nominal_rig import R_CAM_FROM_GAZE_NOMINAL


def _truth(rng):
    """A plausible head: 0.3 m baseline along −z, 1.5° between the mounts, cameras a few
    cm and 1–3° off nominal."""
    axis = rng.normal(size=3)
    T_LR = T_ptuL_from_ptuR_from_mounts(
        [0.0, 0.0, -0.3] + rng.normal(0, 0.005, 3), np.radians(1.5) * axis / np.linalg.norm(axis))
    T_cg = [make_transform(R_CAM_FROM_GAZE_NOMINAL @ matrix_from_rotvec(rng.normal(0, 0.03, 3)),
                           rng.uniform(-0.05, 0.05, 3)) for _ in range(2)]
    return T_LR, T_cg


def _views(rng, T_LR, T_cg, m, T_LR_per_view=None):
    """m simultaneous views of a board ~1.5–2 m ahead, each eye at its own pan/tilt.

    ``T_LR_per_view`` (m, 4, 4), if given, replaces the true mount in each view (to make
    views whose loop closures are known)."""
    T_pb_L, T_pb_R = cyclopean_base(T_LR)
    pan_tilt = rng.uniform(np.radians(-10), np.radians(10), (2, m, 2))
    T_bw = make_transform(Rotation.random(m, random_state=rng).as_matrix(),
                          np.c_[rng.uniform(-0.3, 0.3, m), rng.uniform(1.5, 2.0, m),
                                rng.uniform(-0.3, 0.3, m)])
    T_gp_L = T_gaze_from_ptu(pan_tilt[0, :, 0], pan_tilt[0, :, 1])
    T_gp_R = T_gaze_from_ptu(pan_tilt[1, :, 0], pan_tilt[1, :, 1])
    T_cw_R = T_cg[1] @ T_gp_R @ T_pb_R @ T_bw
    if T_LR_per_view is None:
        T_cw_L = T_cg[0] @ T_gp_L @ T_pb_L @ T_bw
    else:  # left ptu placed by each view's own mount: T_ptuL_from_world = T_LR_k T_ptuR_from_world
        T_cw_L = T_cg[0] @ T_gp_L @ T_LR_per_view @ T_pb_R @ T_bw
    return T_cw_L, T_cw_R, pan_tilt


def _solve(T_cw_L, T_cw_R, T_cg, pan_tilt):
    return T_ptuL_from_ptuR_loop_closure(T_cw_L, T_cw_R, T_cg[0], T_cg[1],
                                         pan_tilt_left=pan_tilt[0], pan_tilt_right=pan_tilt[1])


def _noisy(T, rng, sigma_r, sigma_t):
    """Exponential-form eq. 13–14 noise on each T_cam_from_world."""
    R = T[:, :3, :3] @ matrix_from_rotvec(rng.normal(0, sigma_r, (len(T), 3)))
    return make_transform(R, T[:, :3, 3] + rng.normal(0, sigma_t, (len(T), 3)))


# -- loop closure ------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(5))
def test_loop_closure_noise_free_exact(seed):
    rng = np.random.default_rng(seed)
    T_LR, T_cg = _truth(rng)
    T_cw_L, T_cw_R, pan_tilt = _views(rng, T_LR, T_cg, 8)
    T, spread = _solve(T_cw_L, T_cw_R, T_cg, pan_tilt)
    # 1e-12: a chain of eight rigid transforms with metre-sized translations; round-off
    # ~1e-15 per product (measured worst 1.2e-15). A wrong inverse or order is off by cm.
    np.testing.assert_allclose(T, T_LR, rtol=0, atol=1e-12)
    assert spread.n_views == 8
    assert spread.rotation_deg.max() < 1e-9 and spread.translation.max() < 1e-12
    # The same with the motions given as transforms.
    T_gp_L = T_gaze_from_ptu(pan_tilt[0, :, 0], pan_tilt[0, :, 1])
    T_gp_R = T_gaze_from_ptu(pan_tilt[1, :, 0], pan_tilt[1, :, 1])
    T2, _ = T_ptuL_from_ptuR_loop_closure(T_cw_L, T_cw_R, T_cg[0], T_cg[1],
                                          T_gaze_from_ptu_left=T_gp_L,
                                          T_gaze_from_ptu_right=T_gp_R)
    np.testing.assert_allclose(T2, T_LR, rtol=0, atol=1e-12)


def test_loop_closure_home_pose_broadcast():
    # Both units at pan = tilt = 0 in every view: one (4, 4) motion serves all views.
    rng = np.random.default_rng(5)
    T_LR, T_cg = _truth(rng)
    T_pb_L, T_pb_R = cyclopean_base(T_LR)
    T_bw = make_transform(Rotation.random(3, random_state=rng).as_matrix(),
                          [[0.0, 1.7, 0.0], [0.2, 1.5, 0.1], [-0.1, 2.0, 0.2]])
    T_cw_L = T_cg[0] @ T_pb_L @ T_bw
    T_cw_R = T_cg[1] @ T_pb_R @ T_bw
    T, _ = T_ptuL_from_ptuR_loop_closure(T_cw_L, T_cw_R, T_cg[0], T_cg[1],
                                         T_gaze_from_ptu_left=np.eye(4),
                                         T_gaze_from_ptu_right=np.eye(4))
    np.testing.assert_allclose(T, T_LR, rtol=0, atol=1e-12)  # as above


def test_each_view_is_equation_12():
    rng = np.random.default_rng(7)
    T_LR, T_cg = _truth(rng)
    T_cw_L, T_cw_R, pan_tilt = _views(rng, T_LR, T_cg, 4)
    T_cw_L = _noisy(T_cw_L, rng, 0.01, 0.002)  # so that views differ
    per_view = T_ptuL_from_ptuR_per_view(T_cw_L, T_cw_R, T_cg[0], T_cg[1],
                                         pan_tilt_left=pan_tilt[0], pan_tilt_right=pan_tilt[1])
    inv = np.linalg.inv
    for k in range(4):
        # Eq. 12 exactly as printed, with general matrix inverses.
        T_pg_L = inv(T_gaze_from_ptu(*pan_tilt[0, k]))
        T_pg_R = inv(T_gaze_from_ptu(*pan_tilt[1, k]))
        want = (T_pg_L @ inv(T_cg[0]) @ T_cw_L[k]) @ inv(T_pg_R @ inv(T_cg[1]) @ T_cw_R[k])
        np.testing.assert_allclose(per_view[k], want, rtol=0, atol=1e-12)  # round-off


def test_averaging_beats_a_single_view():
    # Noise on every T_cam_from_world (0.01 rad, 2 mm): the mean of 20 views should be
    # ~√20 ≈ 4.5× closer than a single view (measured: single view 1.34°, 34 mm; mean
    # 0.26°, 6.2 mm, i.e. 0.19×). Asked: 2× on average over 10 heads.
    single_r, single_t, mean_r, mean_t = [], [], [], []
    for seed in range(10):
        rng = np.random.default_rng(100 + seed)
        T_LR, T_cg = _truth(rng)
        T_cw_L, T_cw_R, pan_tilt = _views(rng, T_LR, T_cg, 20)
        T_cw_L, T_cw_R = _noisy(T_cw_L, rng, 0.01, 0.002), _noisy(T_cw_R, rng, 0.01, 0.002)
        per_view = T_ptuL_from_ptuR_per_view(T_cw_L, T_cw_R, T_cg[0], T_cg[1],
                                             pan_tilt_left=pan_tilt[0],
                                             pan_tilt_right=pan_tilt[1])
        T, _ = _solve(T_cw_L, T_cw_R, T_cg, pan_tilt)
        single_r += list(rotation_error_deg(per_view[:, :3, :3], T_LR[:3, :3]))
        single_t += list(np.linalg.norm(per_view[:, :3, 3] - T_LR[:3, 3], axis=1))
        err = mount_errors(T, T_LR)
        mean_r.append(err.rotation_deg)
        mean_t.append(err.translation)
    assert np.mean(mean_r) < 0.5 * np.mean(single_r)
    assert np.mean(mean_t) < 0.5 * np.mean(single_t)


def test_rotation_mean_is_the_chordal_mean_and_a_rotation():
    rng = np.random.default_rng(8)
    T_LR, T_cg = _truth(rng)
    T_cw_L, T_cw_R, pan_tilt = _views(rng, T_LR, T_cg, 10)
    T_cw_L = _noisy(T_cw_L, rng, 0.05, 0.01)
    per_view = T_ptuL_from_ptuR_per_view(T_cw_L, T_cw_R, T_cg[0], T_cg[1],
                                         pan_tilt_left=pan_tilt[0], pan_tilt_right=pan_tilt[1])
    T, _ = _solve(T_cw_L, T_cw_R, T_cg, pan_tilt)
    R = T[:3, :3]
    # The chordal L2 mean minimises Σ‖R − R_k‖_F²; its closed form is the rotation nearest
    # to the element-wise mean (SVD projection). 1e-9: two different algorithms
    # (quaternion eigenvector vs SVD), each exact to round-off.
    elementwise = per_view[:, :3, :3].mean(axis=0)
    np.testing.assert_allclose(R, project_to_rotation(elementwise), rtol=0, atol=1e-9)
    np.testing.assert_allclose(R.T @ R, np.eye(3), rtol=0, atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    # The element-wise mean of noisy rotations is not a rotation (shrunk columns).
    assert np.max(np.abs(elementwise.T @ elementwise - np.eye(3))) > 1e-4
    np.testing.assert_allclose(T[:3, 3], per_view[:, :3, 3].mean(axis=0), rtol=0, atol=1e-15)


def test_spread_is_each_views_deviation():
    # Two views built so their loop closures are the truth turned by ±θ about one axis and
    # moved by ±δ: the mean is the truth and both deviations are exactly θ and δ.
    rng = np.random.default_rng(9)
    T_LR, T_cg = _truth(rng)
    theta, delta = np.radians(2.0), 0.01
    a = np.array([0.6, 0.0, 0.8])
    e = np.array([0.0, 1.0, 0.0])
    T_k = np.stack([make_transform(T_LR[:3, :3] @ matrix_from_rotvec(s * theta * a),
                                   T_LR[:3, 3] + s * delta * e) for s in (1.0, -1.0)])
    T_cw_L, T_cw_R, pan_tilt = _views(rng, T_LR, T_cg, 2, T_LR_per_view=T_k)
    T, spread = _solve(T_cw_L, T_cw_R, T_cg, pan_tilt)
    np.testing.assert_allclose(T, T_LR, rtol=0, atol=1e-12)
    # 1e-9 deg / 1e-12 m: round-off through the chain and the angle extraction.
    np.testing.assert_allclose(spread.rotation_deg, [2.0, 2.0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(spread.translation, [delta, delta], rtol=0, atol=1e-12)
    d = spread.to_dict()
    assert d["n_views"] == 2 and d["rotation_deg_max"] == pytest.approx(2.0, abs=1e-9)


def test_mismatched_views_are_degenerate():
    rng = np.random.default_rng(10)
    T_LR, T_cg = _truth(rng)
    T_k = np.stack([T_LR, T_LR, T_LR @ make_transform(matrix_from_rotvec([0, 0, 2.5]), [0] * 3)])
    T_cw_L, T_cw_R, pan_tilt = _views(rng, T_LR, T_cg, 3, T_LR_per_view=T_k)
    with pytest.raises(DegenerateDataError, match="view 2 is .* deg from the mean"):
        _solve(T_cw_L, T_cw_R, T_cg, pan_tilt)


def test_bad_loop_closure_inputs():
    rng = np.random.default_rng(11)
    T_LR, T_cg = _truth(rng)
    T_cw_L, T_cw_R, pan_tilt = _views(rng, T_LR, T_cg, 3)
    with pytest.raises(InputError, match=r"T_cam_from_world_right: expected shape \(3, 4, 4\)"):
        _solve(T_cw_L, T_cw_R[:2], T_cg, pan_tilt)
    bad = T_cw_R.copy()
    bad[1, 0, 0] *= 1.1
    with pytest.raises(InputError, match=r"T_cam_from_world_right\[1\]: .*not orthonormal"):
        _solve(T_cw_L, bad, T_cg, pan_tilt)
    with pytest.raises(InputError, match="give exactly one of"):
        T_ptuL_from_ptuR_loop_closure(T_cw_L, T_cw_R, T_cg[0], T_cg[1],
                                      pan_tilt_left=pan_tilt[0])
    with pytest.raises(InputError, match=r"pan_tilt_right: expected shape \(3, 2\)"):
        T_ptuL_from_ptuR_loop_closure(T_cw_L, T_cw_R, T_cg[0], T_cg[1],
                                      pan_tilt_left=pan_tilt[0], pan_tilt_right=pan_tilt[1, :2])
    with pytest.raises(InputError, match="no views"):
        _solve(T_cw_L[:0], T_cw_R[:0], T_cg, pan_tilt[:, :0])


# -- measured mounts ---------------------------------------------------------------------

def test_mounts_from_baseline_and_rotation():
    T = T_ptuL_from_ptuR_from_mounts([0.0, 0.0, -0.3])
    np.testing.assert_array_equal(T, make_transform(np.eye(3), [0.0, 0.0, -0.3]))
    w = np.radians([0.5, -0.3, 0.2])
    T = T_ptuL_from_ptuR_from_mounts([0.01, 0.0, -0.3], w)
    np.testing.assert_allclose(rotvec_from_matrix(T[:3, :3]), w, rtol=0, atol=1e-15)
    with pytest.raises(InputError, match="t_ptuL_from_ptuR: expected 3 finite numbers"):
        T_ptuL_from_ptuR_from_mounts([0.0, 0.3])


@pytest.mark.parametrize("angle_deg, dist", [(0.8, 0.0025), (0.5, 0.002), (0.0, 0.003),
                                             (1.0, 0.0)])
def test_perturbed_mounts_have_the_stated_error(angle_deg, dist):
    rng = np.random.default_rng(12)
    T_LR, _ = _truth(rng)
    T_meas = perturb_mounts(T_LR, angle_deg, dist, rng=3)
    err = mount_errors(T_meas, T_LR)
    # 1e-9 deg, 1e-15 m: exact by construction up to round-off.
    assert err.rotation_deg == pytest.approx(angle_deg, abs=1e-9)
    assert err.translation == pytest.approx(dist, abs=1e-15)
    assert abs(err.baseline_length) <= dist + 1e-15
    np.testing.assert_array_equal(T_meas, perturb_mounts(T_LR, angle_deg, dist, rng=3))
    if angle_deg and dist:
        assert not np.allclose(T_meas, perturb_mounts(T_LR, angle_deg, dist, rng=4))
        assert np.allclose(T_meas, perturb_mounts(T_LR, angle_deg, dist,
                                                  rng=np.random.default_rng(3)))


def test_mount_errors_baseline_length_is_signed():
    T_true = make_transform(np.eye(3), [0.0, 0.0, -0.3])
    T_est = make_transform(matrix_from_rotvec([np.radians(2.0), 0, 0]), [0.0, 0.0, -0.303])
    err = mount_errors(T_est, T_true)
    assert err.rotation_deg == pytest.approx(2.0, abs=1e-12)
    assert err.translation == pytest.approx(0.003, abs=1e-15)
    assert err.baseline_length == pytest.approx(0.003, abs=1e-15)
    assert mount_errors(T_true, T_est).baseline_length == pytest.approx(-0.003, abs=1e-15)
    with pytest.raises(InputError, match="perturb_mounts: errors must be >= 0"):
        perturb_mounts(T_true, -1.0, 0.001, rng=0)


# -- cyclopean base ----------------------------------------------------------------------

def _cases():
    rng = np.random.default_rng(13)
    out = [make_transform(np.eye(3), [0.0, 0.0, -0.3]),
           make_transform(matrix_from_rotvec([1e-9, 0, 0]), [0.0, 0.0, -0.3]),
           make_transform(matrix_from_rotvec(np.radians(179.0) * np.array([0.0, 0.6, 0.8])),
                          [0.1, 0.2, -0.3])]
    for _ in range(5):
        out.append(make_transform(Rotation.random(random_state=rng).as_matrix(),
                                  rng.normal(size=3)))
    return out


@pytest.mark.parametrize("T_LR", _cases())
def test_cyclopean_base(T_LR):
    T_pb_L, T_pb_R = cyclopean_base(T_LR)
    # Consistent with the mount: T_ptuL_from_base · T_base_from_ptuR = T_ptuL_from_ptuR.
    # 1e-12: a few products of unit-size rotations and translations ≤ 2.
    np.testing.assert_allclose(T_pb_L @ invert_transform(T_pb_R), T_LR, rtol=0, atol=1e-12)
    T_bp_L, T_bp_R = invert_transform(T_pb_L), invert_transform(T_pb_R)
    # The ptu origins sit at equal and opposite positions in base coordinates ...
    np.testing.assert_allclose(T_bp_L[:3, 3], -T_bp_R[:3, 3], rtol=0, atol=1e-12)
    # ... so the base origin is the midpoint of the two unit centres (seen from ptuL).
    np.testing.assert_allclose(T_pb_L[:3, 3], T_LR[:3, 3] / 2, rtol=0, atol=1e-12)
    # Orientation: the geodesic midpoint, R_base_from_ptuL = exp(−v/2), R_base_from_ptuR
    # = exp(+v/2), each half the angle between the units.
    v = rotvec_from_matrix(T_LR[:3, :3])
    np.testing.assert_allclose(T_bp_L[:3, :3], matrix_from_rotvec(-v / 2), rtol=0, atol=1e-12)
    np.testing.assert_allclose(T_bp_R[:3, :3], matrix_from_rotvec(v / 2), rtol=0, atol=1e-12)
    half = rotation_angle(T_LR[:3, :3]) / 2
    assert rotation_angle(T_bp_L[:3, :3]) == pytest.approx(half, abs=1e-12)
    assert rotation_angle(T_bp_R[:3, :3]) == pytest.approx(half, abs=1e-12)


def test_cyclopean_base_refuses_a_half_turn():
    T = make_transform(matrix_from_rotvec([0.0, np.pi, 0.0]), [0.0, 0.0, -0.3])
    with pytest.raises(DegenerateDataError, match="180 deg"):
        cyclopean_base(T)
    with pytest.raises(InputError, match="T_ptuL_from_ptuR: expected a 4x4"):
        cyclopean_base(np.eye(3))
