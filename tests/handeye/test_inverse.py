"""rasc-inverse (rasc/handeye/inverse.py): RASC's rotation, the translation of the
inverse formulation ``(I − R_B) t_Y = t_B − R_Y t_A`` with the exact unit rotation as
design matrix. Proven on synthetic truth: exact without noise, and under the paper's
pose noise (eq. 13–14) free of the bias eq. 7 has along the viewing direction."""

from __future__ import annotations

import numpy as np
import pytest

from rasc.errors import DegenerateDataError
from rasc.geometry.kinematics import PAPER_POSES_DEG
from rasc.geometry.transforms import make_transform, matrix_from_rotvec
from rasc.handeye.inverse import solve_rasc_inverse
from rasc.handeye.methods import solve
from rasc.handeye.noise import PAPER_LEVELS_RAD_MM, perturb_T_cam_from_world
from rasc.handeye.solver import solve_rasc

from nominal_rig import PAPER
from nominal_rig import rig as draw_rig

#: the board's position in the ptu frame (m): these tests' truth since they were written
BOARD = (-0.15, 1.0, 0.05)


def rig(seed=3):
    """A camera looking forward a few cm off the unit's centre, the board 1 m ahead."""
    X, Y = draw_rig(np.random.default_rng(seed), BOARD)
    return X, Y, PAPER


@pytest.mark.parametrize("seed", range(5))
def test_exact_without_noise(seed):
    """Pan-tilt motions (t_B = 0) and general motions of an arm (t_B ≠ 0): the truth to
    1e-9 (round-off of 4×4 products and a 3×3 solve is ~1e-15; 1e-9 leaves room for the
    conditioning of eq. 8's M, cond ~1e4 for ±8°)."""
    X, Y, T_gp = rig(seed)
    res = solve_rasc_inverse(X @ T_gp @ Y, T_gp)
    np.testing.assert_allclose(res.T_cam_from_gaze, X, atol=1e-9)
    assert res.method == "rasc-inverse" and res.quality < 1e-9
    rng = np.random.default_rng(100 + seed)
    T_arm = np.array([make_transform(matrix_from_rotvec(rng.normal(0, 0.4, 3)),
                                     rng.uniform(-0.3, 0.3, 3)) for _ in range(12)])
    res = solve("rasc-inverse", X @ T_arm @ Y, T_arm)
    np.testing.assert_allclose(res.T_cam_from_gaze, X, atol=1e-9)


def test_rotation_and_quality_are_rascs():
    X, Y, T_gp = rig()
    T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.01, 0.002, np.random.default_rng(0),
                                    variant="literal")
    a = solve_rasc(T_cw, T_gp, check_rigid=False)
    b = solve_rasc_inverse(T_cw, T_gp, check_rigid=False)
    np.testing.assert_array_equal(b.T_cam_from_gaze[:3, :3], a.T_cam_from_gaze[:3, :3])
    assert b.quality == a.quality
    assert b.diagnostics.n_pairs_used == a.diagnostics.n_pairs_used == 72


def test_degenerate_motions_are_refused():
    X, Y, T_gp = rig()
    pan_only = [k for k, (_, tilt) in enumerate(PAPER_POSES_DEG) if tilt == 0]
    with pytest.raises(DegenerateDataError):
        solve_rasc_inverse((X @ T_gp @ Y)[pan_only], T_gp[pan_only])


def _errors(level: int, n_samples: int, variant: str):
    """Translation error vectors (mm) of rasc and rasc-inverse on the same samples."""
    X, Y, T_gp = rig()
    sigma_r, sigma_t_mm = PAPER_LEVELS_RAD_MM[level - 1]
    out = {"rasc": [], "rasc-inverse": []}
    for s in range(n_samples):
        T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, sigma_r, sigma_t_mm / 1000,
                                        np.random.default_rng([level, s]), variant=variant)
        for m in out:
            T = solve(m, T_cw, T_gp, check_rigid=False).T_cam_from_gaze
            out[m].append(1000.0 * (T[:3, 3] - X[:3, 3]))
    return {m: np.array(v) for m, v in out.items()}, (X @ Y)[:3, 3]


@pytest.mark.parametrize("variant", ["exponential", "literal"])
def test_lower_translation_error_than_rasc_under_the_papers_noise(variant):
    """Nine ±8° poses, the paper's levels 4 and 8 (σ_r 0.02 / 0.04 rad, σ_t 4 / 8 mm),
    200 seeded samples each. Measured (this rig, 200 samples): mean translation error
    rasc-inverse / rasc = 0.84 at level 4 and 0.73 at level 8 (both variants; OpenCV's
    Park and Horaud give the same figures as rasc-inverse, 41 / 88 mm). Bounds 0.93 and
    0.85 sit between those and 1 with room for the sampling error of a paired ratio
    (~2 % at 200 samples)."""
    for level, bound in ((4, 0.93), (8, 0.85)):
        err, _ = _errors(level, 200, variant)
        mean = {m: float(np.linalg.norm(e, axis=1).mean()) for m, e in err.items()}
        assert mean["rasc-inverse"] / mean["rasc"] < bound, (level, mean)


def test_eq7_is_biased_along_the_viewing_direction_and_the_inverse_is_not():
    """The mechanism: the noise of R_A sits in eq. 7's design matrix (I − R_A) and, times
    the board distance, in t_A, so eq. 7's solution is biased by ~2 σ_r² |t| / θ² along
    the viewing direction (≈ 55 mm at level 8 with the mean θ² of the nine poses' 72
    pairs, 0.058 rad², and |t| = 1 m: an order of magnitude, the pairs are not
    independent). Measured over 300 samples: RASC's mean error vector 89 mm,
    0.99 of it along the board's direction; rasc-inverse's 4.9 mm, within the sampling
    error of a mean of 300 errors of ~100 mm RMS (≈ 6 mm per component)."""
    err, t_board = _errors(8, 300, "exponential")
    view = t_board / np.linalg.norm(t_board)
    bias = {m: e.mean(axis=0) for m, e in err.items()}
    assert bias["rasc"] @ view > 60.0
    assert np.linalg.norm(bias["rasc-inverse"]) < 15.0


# ------------------------------------------------------------------ rasc-views

@pytest.mark.parametrize("seed", range(5))
def test_views_exact_without_noise(seed):
    """Pan-tilt motions and an arm's general motions: the truth to 1e-9 (as above)."""
    X, Y, T_gp = rig(seed)
    res = solve("rasc-views", X @ T_gp @ Y, T_gp)
    np.testing.assert_allclose(res.T_cam_from_gaze, X, atol=1e-9)
    assert res.method == "rasc-views" and res.quality < 1e-9
    rng = np.random.default_rng(100 + seed)
    T_arm = np.array([make_transform(matrix_from_rotvec(rng.normal(0, 0.4, 3)),
                                     rng.uniform(-0.3, 0.3, 3)) for _ in range(12)])
    np.testing.assert_allclose(solve("rasc-views", X @ T_arm @ Y, T_arm).T_cam_from_gaze, X,
                               atol=1e-9)


def test_views_translation_recovers_the_target_too():
    from rasc.handeye.inverse import views_translation

    X, Y, T_gp = rig()
    tX, tZ, cond = views_translation(X @ T_gp @ Y, T_gp, X[:3, :3])
    np.testing.assert_allclose(tX, X[:3, 3], atol=1e-12)
    np.testing.assert_allclose(tZ, Y[:3, 3], atol=1e-12)
    assert 1.0 <= cond < 1e3


def test_views_degenerate_motions_are_refused():
    X, Y, T_gp = rig()
    pan_only = [k for k, (_, tilt) in enumerate(PAPER_POSES_DEG) if tilt == 0]
    with pytest.raises(DegenerateDataError):
        solve("rasc-views", (X @ T_gp @ Y)[pan_only], T_gp[pan_only])


PEERS = ("rasc", "rasc-inverse", "li", "opencv-park", "opencv-tsai", "opencv-horaud")


def _mean_translation_errors(make_T_cw, n_samples, setup=None):
    """Mean translation error (m) per method over samples where every method succeeded;
    ``setup`` (X, Y, T_gp), default :func:`rig`."""
    from rasc.errors import RascError

    X, Y, T_gp = rig() if setup is None else setup
    errors = []
    for s in range(n_samples):
        T_cw = make_T_cw(X @ T_gp @ Y, np.random.default_rng(s))
        row = {}
        try:
            for m in (*PEERS, "rasc-views"):
                T = solve(m, T_cw, T_gp, check_rigid=False).T_cam_from_gaze
                row[m] = float(np.linalg.norm(T[:3, 3] - X[:3, 3]))
        except RascError:           # Park's occasional failure: the sample is left out
            continue
        errors.append(row)
    assert len(errors) >= 0.8 * n_samples
    return {m: float(np.mean([r[m] for r in errors])) for m in errors[0]}


@pytest.mark.slow
@pytest.mark.parametrize("level", [1, 4, 8])
def test_views_beat_every_method_under_the_papers_noise(level):
    """Eq. 13-14 noise perturbs each view's translation by σ_t only; every pair equation
    adds the rotation noise times the board distance (σ_r · 1 m = 5-40 mm). Measured
    (benchmarks/compare_inverse.py, 200 samples): rasc-views' mean translation error is
    0.45-0.53× the best other method's at every level, on synthetic and rendered poses.
    Bound 0.7 on 100 samples."""
    sigma_r, sigma_t_mm = PAPER_LEVELS_RAD_MM[level - 1]
    mean = _mean_translation_errors(
        lambda T, rng: perturb_T_cam_from_world(T, sigma_r, sigma_t_mm / 1000, rng,
                                                variant="exponential"), 100)
    assert mean["rasc-views"] < 0.7 * min(mean[m] for m in PEERS), mean


@pytest.mark.slow  # ~2 s
def test_views_beat_every_method_under_corner_noise():
    """Realistic pose errors instead of the paper's model: the board's 54 corners
    projected by a pinhole camera (f = 1000 px), 0.5 px Gaussian corner noise, the pose
    re-estimated by OpenCV (rasc.vision.camera.estimate_extrinsics) — rotation and
    translation errors now correlated, as in a real calibration. Measured here (60
    samples): rasc-views 3.6 mm, every other method 8.2-9.4 mm (on the rendered head's
    nine poses, benchmarks/compare_inverse.py: 3.0 mm against 5.9-6.4 mm); bound 0.7×
    the best other method."""
    from rasc.geometry.lens import project_points
    from rasc.vision.board import DEFAULT_BOARD
    from rasc.vision.camera import estimate_extrinsics

    K = np.array([[1000.0, 0.0, 640.0], [0.0, 1000.0, 480.0], [0.0, 0.0, 1.0]])
    dist = np.zeros(5)
    P = DEFAULT_BOARD.object_points()
    centre = P.mean(axis=0)

    def detect(T_cw_true, rng):
        out = []
        for T in T_cw_true:
            uv = project_points(P @ T[:3, :3].T + T[:3, 3], K, dist)
            out.append(estimate_extrinsics(uv + rng.normal(0, 0.5, uv.shape), DEFAULT_BOARD,
                                           K, dist)[0])
        return np.array(out)

    X, Y, T_gp = rig()
    # the board's centre, not its corner, 1 m ahead of the camera at home
    Y = Y.copy()
    Y[:3, 3] -= Y[:3, :3] @ centre
    mean = _mean_translation_errors(detect, 60, setup=(X, Y, T_gp))
    assert mean["rasc-views"] < 0.7 * min(mean[m] for m in PEERS), mean
