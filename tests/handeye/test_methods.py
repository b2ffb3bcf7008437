"""rasc.handeye.methods.jackknife_uncertainty: the estimated error of a solution, checked against
the real error of many seeded noisy calibrations; and the warnings built on it and on the
camera's viewing direction (rasc.handeye.solver.solution_warnings)."""

import numpy as np
import pytest

from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu
from rasc.geometry.transforms import rotation_error_deg
from rasc.handeye.advice import input_warnings, solution_warnings
from rasc.handeye.methods import jackknife_uncertainty, solve
from rasc.handeye.noise import perturb_T_cam_from_world
from rasc.handeye.solver import solve_rasc

from nominal_rig import rig as draw_rig

#: the board's position in the ptu frame (m): these tests' truth since they were written
BOARD = (-0.15, 1.0, 0.05)


def rig(seed=3):
    return draw_rig(np.random.default_rng(seed), BOARD)


def grid(half_deg):
    a = (-half_deg, 0.0, half_deg)
    p = np.radians([(x, y) for x in a for y in a])
    return T_gaze_from_ptu(p[:, 0], p[:, 1])


@pytest.mark.slow
@pytest.mark.parametrize("half_deg, sigma_r, sigma_t", [(8.0, 0.005, 0.001),
                                                        (2.0, 0.0005, 0.0005),
                                                        (20.0, 0.0005, 0.0005)])
def test_jackknife_matches_the_real_error(half_deg, sigma_r, sigma_t):
    """Over 100 seeded calibrations (nine positions, eq. 13-14 noise, exponential form)
    the RMS of the jackknife estimate is close to the RMS of the real error: measured
    1.08-1.25× it for these and other settings with 200 samples (slightly conservative).
    Bounds 0.9 and 1.5: 100 samples leave about 7 % of sampling error on each RMS, and an
    estimator that ignored the correlation between pairs (or the motion range) would be
    off by a factor of 2 or more."""
    X, Y = rig()
    T_gp = grid(half_deg)
    err_r, err_t, est_r, est_t = [], [], [], []
    for seed in range(100):
        T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, sigma_r, sigma_t,
                                        np.random.default_rng(seed), variant="exponential")
        res = solve_rasc(T_cw, T_gp)
        unc = jackknife_uncertainty("rasc", T_cw, T_gp, res)
        assert unc.n_subsets == 9 and unc.reason is None
        err_r.append(rotation_error_deg(res.T_cam_from_gaze[:3, :3], X[:3, :3]))
        err_t.append(np.linalg.norm(res.T_cam_from_gaze[:3, 3] - X[:3, 3]))
        est_r.append(unc.rotation_deg)
        est_t.append(unc.translation)
    rms = lambda v: float(np.sqrt(np.mean(np.square(v))))  # noqa: E731
    assert 0.9 < rms(est_r) / rms(err_r) < 1.5
    assert 0.9 < rms(est_t) / rms(err_t) < 1.5


def test_no_estimate_without_enough_positions():
    X, Y = rig()
    three = grid(8.0)[[4, 5, 7]]                          # (0, 0), (0, 8), (8, 0)
    res = solve_rasc(X @ three @ Y, three)
    unc = jackknife_uncertainty("rasc", X @ three @ Y, three, res)
    assert unc.rotation_deg is None and "only 3 positions" in unc.reason
    # four positions, but without the only tilted one the motions are pan-only
    p = np.radians([(0, 0), (8, 0), (-8, 0), (0, 8)])
    four = T_gaze_from_ptu(p[:, 0], p[:, 1])
    res = solve_rasc(X @ four @ Y, four)
    unc = jackknife_uncertainty("rasc", X @ four @ Y, four, res)
    assert unc.rotation_deg is None
    assert unc.reason.startswith("without position 3 the data cannot be solved")
    (w,) = solution_warnings(res, uncertainty=unc)
    assert w.startswith("no error estimate: without position 3")
    assert unc.to_dict()["rotation_deg"] is None


def test_li_home_follows_its_position():
    """Li with an explicit home: each subset keeps the same home view (shifted index);
    noise-free, every subset recovers the truth and the estimate is zero."""
    X, Y = rig()
    T_gp = grid(8.0)
    res = solve("li", X @ T_gp @ Y, T_gp, home=6)
    unc = jackknife_uncertainty("li", X @ T_gp @ Y, T_gp, res, home=6)
    assert unc.n_subsets == 9 and unc.rotation_deg < 1e-9 and unc.translation < 1e-9


def test_large_estimated_error_is_warned():
    X, Y = rig()
    T_gp = grid(8.0)
    T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.02, 0.004, np.random.default_rng(0),
                                    variant="exponential")
    res = solve_rasc(T_cw, T_gp)
    unc = jackknife_uncertainty("rasc", T_cw, T_gp, res)
    assert unc.rotation_deg > 1.0
    (w,) = solution_warnings(res, uncertainty=unc)
    assert w.startswith(f"estimated error (jackknife over positions) "
                        f"{unc.rotation_deg:.2g}° in rotation")
    # the paper's nine poses with a good camera calibration: no warning
    T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.0005, 0.0005, np.random.default_rng(0),
                                    variant="exponential")
    res = solve_rasc(T_cw, T_gp)
    assert solution_warnings(res, uncertainty=jackknife_uncertainty("rasc", T_cw, T_gp, res),
                             pan_tilt=True) == []


@pytest.mark.parametrize("mistake", ["pan reversed", "tilt reversed", "pan and tilt swapped"])
def test_reversed_conventions_are_warned(mistake):
    """Each mistake still gives a solution (the reversed pan even an exact one: it
    conjugates every motion by a half-turn about the tilt axis), but one whose camera
    looks backwards along the gaze frame: warned with pan_tilt=True only."""
    X, Y = rig()
    pt = np.radians(np.array(PAPER_POSES_DEG, dtype=float))
    T_cw = X @ T_gaze_from_ptu(pt[:, 0], pt[:, 1]) @ Y
    pan, tilt = pt[:, 0], pt[:, 1]
    if mistake == "pan reversed":
        pan = -pan
    elif mistake == "tilt reversed":
        tilt = -tilt
    else:
        pan, tilt = tilt, pan
    T_gp = T_gaze_from_ptu(pan, tilt)
    res = solve_rasc(T_cw, T_gp)
    assert res.T_cam_from_gaze[2, 1] < 0                 # optical axis · gaze forward
    warnings = solution_warnings(res, pan_tilt=True)
    assert any(w.startswith("the camera's optical axis points backwards in the gaze frame")
               for w in warnings), warnings
    assert not any("backwards" in w for w in solution_warnings(res))
    # the right conventions: the camera looks forward, no such warning
    right = solve_rasc(X @ T_gaze_from_ptu(pt[:, 0], pt[:, 1]) @ Y,
                       T_gaze_from_ptu(pt[:, 0], pt[:, 1]))
    assert right.T_cam_from_gaze[2, 1] > 0.99
    assert solution_warnings(right, pan_tilt=True) == []


def test_inverted_poses_are_warned():
    """T_world_from_cam given for T_cam_from_world: the board (world +z into the board)
    sees the camera at negative z. Whether the solution then looks backwards depends on
    the geometry, so the poses themselves are checked."""
    X, Y = rig()
    T_gp = grid(8.0)
    T_cw = X @ T_gp @ Y
    assert input_warnings(T_cw) == []
    (w,) = input_warnings(np.linalg.inv(T_cw))
    assert w.startswith("9 of 9 poses put the target's origin behind the camera "
                        "(T_cam_from_world[0] has z = -")
    assert w.endswith("are these T_world_from_cam?")
