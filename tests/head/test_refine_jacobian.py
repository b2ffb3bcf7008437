"""The refinement's Levenberg–Marquardt Jacobian (rasc.head.refine.jacobian, ``jacobian_lm``):
its analytic columns (intrinsics with either distortion model, every board pose) against
central differences, on a synthetic head (rasc.sim.synthetic) away from and at the
initial guess, and the refinement it drives against the truth."""

from __future__ import annotations

import numpy as np
import pytest

from rasc.geometry.kinematics import PanTiltUnit
from rasc.head import refine as rf
from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
from rasc.head.refine import problem as problem_module
from rasc.sim.synthetic import corner_dataset, default_head

#: 30 mm between the axes and 0.5° non-orthogonal (the unit columns are non-trivial)
UNIT = PanTiltUnit(tilt_axis=(np.sin(np.radians(0.5)), 0.0, np.cos(np.radians(0.5))),
                   tilt_point=(0.0, 0.03, 0.0))

#: Central differences with h = 1e-5 (scaled units) err by ~h² (truncation) plus
#: ~1e-16 · |residual| / h (round-off): 1e-9 of a column's largest entry, measured; an
#: analytic column is accepted within 1e-7 of it (100x margin), while a wrong term (a
#: sign, a missing factor, a transposed chain) is wrong by O(1).
ANALYTIC_RTOL = 1e-7
#: forward differences (h = 1e-6) err by ~h · |f''| / 2: 1e-7 of a column, measured
FORWARD_RTOL = 1e-5


def _problem(dist_model: str, dist=(-0.05, 0.02, 0.0, 0.0, 0.0)):
    head = default_head(UNIT, dist=dist)
    ds = corner_dataset(head, seed=3, noise_px=0.02)
    cal = calibrate_dataset(ds, CalibrationOptions(dist_model=dist_model, model="paper"))
    obs = rf.observations_from_calibration(cal, ds.board)
    free, _ = rf._identifiable(obs)
    return rf._Problem(obs, free)


@pytest.fixture(scope="module", params=["k1k2", "opencv5"])
def problem(request):
    dist = ((-0.05, 0.02, 0.0, 0.0, 0.0) if request.param == "k1k2"
            else (-0.05, 0.02, 4e-4, -3e-4, 0.005))
    return _problem(request.param, dist)


def _columns(prob, names_of):
    return [j for j, n in enumerate(prob.names) if names_of(n)]


def _analytic(name: str) -> bool:
    return name.startswith("board[") or name.split(".")[-1] in rf.DIST_NAMES + (
        "fx", "fy", "cx", "cy")


@pytest.mark.parametrize("at", ["initial", "perturbed"])
def test_analytic_columns_match_central_differences(problem, at):
    rng = np.random.default_rng(7)
    n = len(problem.names)
    # perturbed: 0.02 scaled units everywhere (2 px of focal length, ~1° of every
    # rotation, board rotation vectors away from 0 so the left Jacobian is not I)
    x = np.zeros(n) if at == "initial" else 0.02 * rng.standard_normal(n)
    r0 = problem.residuals(x)
    Ja_s = problem.jacobian_lm(x, r0)
    Jc_s = problem.jacobian(x, h=1e-5, central=True, analytic=False)
    Ja, Jc = Ja_s.toarray(), Jc_s.toarray()
    assert Ja.shape == Jc.shape
    an = _columns(problem, _analytic)
    fd = [j for j in range(n) if j not in set(an)]
    assert len(an) > 6 * problem.n_poses and len(fd) >= 18
    dist_cols = [problem.names[j] for j in an if problem.names[j].split(".")[-1]
                 in rf.DIST_NAMES]
    assert len(dist_cols) == 2 * len(rf.DIST_PARAMS[problem.obs.dist_model])
    colmax = np.abs(Jc).max(axis=0)
    assert np.all(colmax > 0)
    err = np.abs(Ja - Jc).max(axis=0) / colmax
    worst = int(np.argmax(np.where(np.isin(np.arange(n), an), err, 0)))
    assert err[an].max() < ANALYTIC_RTOL, problem.names[worst]
    assert err[fd].max() < FORWARD_RTOL
    # the same block structure: a corner depends on its own board pose and eye only
    def pattern(J):
        c = J.tocoo()
        return set(zip(c.row.tolist(), c.col.tolist(), strict=True))
    assert pattern(Ja_s) == pattern(Jc_s)
    # central differences on the kinematic columns (the identifiability test and the
    # covariance use this one): within the central differences' own error of the pure
    # finite-difference Jacobian
    Jm = problem.jacobian(x, h=1e-5, central=True).toarray()
    assert (np.abs(Jm - Jc).max(axis=0) / colmax).max() < ANALYTIC_RTOL
    assert np.array_equal(Jm[:, fd], Jc[:, fd])


def test_batched_difference_columns_are_the_one_call_numbers(problem):
    """jacobian_lm evaluates the kinematic columns that move the same images together
    (_residuals_batch, with unchanged rotations reused): every forward-difference column
    must be bit for bit the one of its own residuals_of call, so that the refinement
    gives the same bytes as one call per column did (central: the array_equal above)."""
    rng = np.random.default_rng(11)
    n = len(problem.names)
    x = 0.02 * rng.standard_normal(n)
    h = 1e-6
    r0 = problem.residuals(x)
    J = problem.jacobian_lm(x, r0, h=h).toarray()
    rows_of, col_imgs = problem._rows_of_images(), problem.column_images()
    fd = [j for j in range(problem.n_global) if not _analytic(problem.names[j])]
    assert len(fd) >= 18
    for j in fd:
        rows = np.concatenate([rows_of[i] for i in col_imgs[j]])
        dx = np.zeros(n)
        dx[j] = h
        one = (problem.residuals_of(x + dx, col_imgs[j]) - r0[rows]) / h
        assert np.array_equal(J[rows, j], one), problem.names[j]
        assert not J[np.setdiff1d(np.arange(len(r0)), rows), j].any()
    # the reuse remembers nothing that changes the next Jacobian: the same again
    assert np.array_equal(problem.jacobian_lm(x, r0, h=h).toarray(), J)


def test_a_wrong_derivative_would_be_seen(problem):
    """The comparison above can fail: a board rotation taken with the wrong sign of its
    left Jacobian (the first-order exp(w) for w = 0 only) is off at the perturbed point."""
    rng = np.random.default_rng(7)
    x = 0.02 * rng.standard_normal(len(problem.names))
    Jc = problem.jacobian(x, h=1e-5, central=True, analytic=False).toarray()
    saved = problem_module._left_jacobian              # where the projection reads it
    try:
        problem_module._left_jacobian = lambda w: np.broadcast_to(np.eye(3), w.shape + (3,))
        Ja = problem.jacobian_lm(x, problem.residuals(x)).toarray()
    finally:
        problem_module._left_jacobian = saved
    rot = _columns(problem, lambda n: n.startswith("board[") and ".rot" in n)
    err = np.abs(Ja - Jc)[:, rot].max(axis=0) / np.abs(Jc)[:, rot].max(axis=0)
    assert err.max() > 100 * ANALYTIC_RTOL


def test_refinement_with_it_recovers_the_unit():
    """Exact corners (no noise): the refinement driven by this Jacobian lands on the
    true axis distance and angle to round-off-level accuracy."""
    ds = corner_dataset(default_head(UNIT), seed=0, noise_px=0.0)
    cal = calibrate_dataset(ds, CalibrationOptions(model="general", scales="hold"))
    for eye in ("left", "right"):
        p = cal.refinement.parameters[eye]
        assert abs(p["unit.tilt_point_y"]["value"] - 0.03) < 1e-6        # 1 µm of 30 mm
        assert abs(p["unit.axis_angle_deg"]["value"] - 89.5) < 1e-5      # of 0.5°
