"""The solver's fast paths (rasc.handeye._kernels): the quaternions of non-orthogonal
matrices, the cond(CᵀC) bound, chunked batches, and the one-solve path against the general
path, bit for bit. Their agreement with the paper's equations written plainly
(rasc.handeye.paper) is tests/handeye/test_kernels_vs_paper.py.
"""

from __future__ import annotations

import copy
import dataclasses
import pickle

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rasc.handeye import _kernels, paper, solver
from rasc.handeye.noise import perturb_T_cam_from_world
from rasc.handeye.solver import solve_rasc, solve_rasc_batch

from nominal_rig import PAPER, pan_tilt, random_rigid, rig


def scene(kind: str, seed: int):
    rng = np.random.default_rng(seed)
    if kind == "pan-tilt":
        X, Y = rig(rng)
        T_gp = PAPER
    else:
        X, Y = random_rigid(rng, 2)
        T_gp = random_rigid(rng, 7, max_angle=1.0)
    return X @ T_gp @ Y, T_gp, rng


@pytest.mark.parametrize("sigma", [1e-6, 1e-3, 2e-2, 4e-2])
def test_quaternions_of_many_non_orthogonal_matrices(sigma):
    """The power iteration to the nearest rotation's quaternion (K^p e_k, p from each
    matrix's own max |RᵀR − I|) gives the SVD polar factor's quaternion, up to sign and
    scale, to 1e-13 (round-off of the power iteration and of scipy's conversion, a few
    ulp each); every matrix's quaternion is the one it gets alone, to the bit."""
    rng = np.random.default_rng(7)
    R = Rotation.random(600, random_state=8).as_matrix() + rng.normal(0, sigma, (600, 3, 3))
    R[::7] = Rotation.random(86, random_state=9).as_matrix()     # rigid ones among them
    err = np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max(axis=(1, 2))
    assert 1e-14 < err.max() < 1 / 3
    want = Rotation.from_matrix(np.stack([paper.nearest_rotation(r) for r in R])).as_quat()
    q = _kernels._quaternions(R, err)
    for k in (0, 1, 7, 599):
        np.testing.assert_array_equal(_kernels._quaternions(R[k:k + 1])[0], q[k])
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    q *= np.sign((q * want).sum(axis=1))[:, None]
    np.testing.assert_allclose(q, want, atol=1e-13, rtol=0)


def test_cond_bound_never_passes_an_ill_conditioned_CtC():
    """``_cond_CtC_surely_ok`` may say "not certain" but never "fine" when cond(CᵀC) >
    MAX_COND_CTC; it does say "fine" up to cond = MAX_COND_CTC / 10 (its bound is at
    most 9× the condition number)."""
    rng = np.random.default_rng(9)
    Q = Rotation.random(2000, random_state=10).as_matrix()
    cond = 10 ** rng.uniform(0, 8, 2000)
    lam = np.stack([np.ones(2000), 10 ** rng.uniform(0, 1, 2000) * np.sqrt(cond), cond], 1)
    lam[:, 1] = np.minimum(lam[:, 1], cond)
    A = (Q * lam[:, None, :]) @ np.swapaxes(Q, 1, 2) * 10 ** rng.uniform(-3, 3, (2000, 1, 1))
    for k in range(2000):
        ok = _kernels._cond_CtC_surely_ok(A[k:k + 1])
        if cond[k] > solver.MAX_COND_CTC:
            assert not ok, cond[k]
        if cond[k] < solver.MAX_COND_CTC / 10:
            assert ok, cond[k]


def test_chunked_batch_names_an_ill_conditioned_sample():
    """A sample whose motions turn about one axis, in a batch large enough to be chunked,
    raises the same error as its single solve, naming the sample."""
    T_true, T_gp, rng = scene("pan-tilt", 5)
    S = 500
    T_cw = perturb_T_cam_from_world(np.broadcast_to(T_true, (S, 9, 4, 4)), 0.01, 0.002, rng,
                                    variant="exponential")
    T_gp_all = np.repeat(T_gp[None], S, 0)
    pan_only = pan_tilt([(a, 0.0) for a in np.linspace(-8, 8, 9)])
    T_gp_all[321] = pan_only
    T_cw[321] = T_true[0] @ np.linalg.inv(T_gp[0]) @ pan_only     # X pan_only Y
    with pytest.raises(solver.DegenerateDataError, match=r"\(sample 321\)") as exc:
        solve_rasc_batch(T_cw, T_gp_all)
    with pytest.raises(solver.DegenerateDataError) as one:
        solve_rasc(T_cw[321], pan_only)
    assert str(exc.value).replace(" (sample 321)", "") == str(one.value)


# ------------------------------------------------- the one-solve path (_solve_one)

def general(T_cw, T_gp, **kw):
    """solve_rasc by the general path alone (a batch of one through _solve)."""
    saved = solver._one_case
    solver._one_case = lambda *args: False
    try:
        return solve_rasc(T_cw, T_gp, **kw)
    finally:
        solver._one_case = saved


def same_result(a, b) -> None:
    """Bit for bit: the transform, eq. 10's quality and every diagnostic."""
    np.testing.assert_array_equal(a.T_cam_from_gaze, b.T_cam_from_gaze)
    assert a.quality == b.quality
    assert a.diagnostics == b.diagnostics
    assert a.method == b.method == "rasc"


@pytest.mark.parametrize("kind", ["pan-tilt", "arm"])
@pytest.mark.parametrize("n", [3, 5, 9, 17, _kernels._ONE_MAX_VIEWS])
@pytest.mark.parametrize("pairs", ["all", "half"])
def test_one_solve_path_has_the_general_paths_bits(kind, n, pairs):
    """On rigid data (the common case) solve_rasc takes _solve_one, and its result is the
    general path's to the bit: transform, quality, diagnostics. Five noise draws each,
    with the default and with no minimum pair rotation."""
    rng = np.random.default_rng(11 + n)
    if kind == "pan-tilt":
        X, Y = rig(rng)
        T_gp = pan_tilt(rng.uniform(-10, 10, (n, 2)))
    else:
        X, Y = random_rigid(rng, 2)
        T_gp = random_rigid(rng, n, max_angle=1.0)
    for _ in range(5):
        T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.01, 0.002, rng, variant="exponential")
        for kw in ({"pairs": pairs}, {"pairs": pairs, "min_rotation_rad": 0.0}):
            taken = _kernels._solve_one(T_cw, T_gp, _kernels._pairs(n, pairs, None),
                                      kw.get("min_rotation_rad", solver.MIN_PAIR_ROTATION_RAD))
            assert taken is not None                 # the test covers the fast path
            same_result(taken, general(T_cw, T_gp, **kw))
            same_result(solve_rasc(T_cw, T_gp, **kw), taken)


def _one_declines(T_cw, T_gp, **kw) -> bool:
    pair = _kernels._pairs(len(T_cw), kw.get("pairs", "all"), None)
    return _kernels._solve_one(np.asarray(T_cw, float), np.asarray(T_gp, float), pair,
                             kw.get("min_rotation_rad", solver.MIN_PAIR_ROTATION_RAD)) is None


def test_one_solve_path_leaves_the_uncommon_cases_to_the_general_path():
    """Data that are not the common case make _solve_one decline (None), and solve_rasc
    then returns the general path's result: literal (non-orthogonal) noise, a rotation
    off by 2e-14 (rigid within RIGID_ATOL, not to round-off), a repeated pose (a pair
    below min_rotation_rad), a half turn of the unit, a last row holding −0.0."""
    rng = np.random.default_rng(12)
    X, Y = rig(rng)
    T_true = X @ PAPER @ Y
    literal = perturb_T_cam_from_world(T_true, 0.01, 0.002, rng, variant="literal")
    off = perturb_T_cam_from_world(T_true, 0.01, 0.002, rng, variant="exponential")
    off[4, 0, 0] += 2e-14
    T_gp_rep = PAPER.copy()
    T_gp_rep[5] = T_gp_rep[2]
    rep = perturb_T_cam_from_world(X @ T_gp_rep @ Y, 0.01, 0.002, rng, variant="exponential")
    Xa, Ya = random_rigid(rng, 2)
    T_arm = random_rigid(rng, 6, max_angle=1.0)
    T_arm[3] = T_arm[0] @ make_half_turn()
    arm = perturb_T_cam_from_world(Xa @ T_arm @ Ya, 0.01, 0.002, rng, variant="exponential")
    negzero = perturb_T_cam_from_world(T_true, 0.01, 0.002, rng, variant="exponential")
    negzero[2, 3, 0] = -0.0            # equal to 0.0, but not its bits: the general path
    cases = [(literal, PAPER, {"check_rigid": False}), (off, PAPER, {}),
             (rep, T_gp_rep, {}), (arm, T_arm, {}), (negzero, PAPER, {})]
    for T_cw, T_gp, kw in cases:
        assert _one_declines(T_cw, T_gp)
        same_result(solve_rasc(T_cw, T_gp, **kw), general(T_cw, T_gp, **kw))
    assert solve_rasc(rep, T_gp_rep).diagnostics.n_pairs_used == 70     # (2, 5), (5, 2) out


def make_half_turn() -> np.ndarray:
    """A half turn about a tilted axis (4, 4)."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.pi * np.array([0.6, 0.0, 0.8])).as_matrix()
    return T


@pytest.mark.parametrize("case", ["nan", "inf", "last row", "reflection", "pan only",
                                  "too few", "not rigid"])
def test_one_solve_path_refuses_as_the_general_path_does(case):
    """Bad or degenerate input: _solve_one declines and solve_rasc raises the general
    path's error, word for word."""
    rng = np.random.default_rng(13)
    X, Y = rig(rng)
    T_gp = PAPER.copy()
    T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.01, 0.002, rng, variant="exponential")
    if case == "nan":
        T_cw[3, 1, 3] = np.nan
    elif case == "inf":
        T_gp[2, 0, 3] = np.inf
    elif case == "last row":
        T_cw[1, 3, 0] = 0.5
    elif case == "reflection":
        T_cw[6, :3, 2] *= -1.0
    elif case == "pan only":
        T_gp = pan_tilt([(a, 0.0) for a in np.linspace(-8, 8, 9)])
        T_cw = X @ T_gp @ Y
    elif case == "too few":
        T_cw, T_gp = T_cw[:2], T_gp[:2]
    else:
        T_cw[0, :3, :3] *= 1.01
    if len(T_cw) >= 3:
        assert _one_declines(T_cw, T_gp)
    with pytest.raises((solver.InputError, solver.DegenerateDataError)) as fast:
        solve_rasc(T_cw, T_gp)
    with pytest.raises(type(fast.value)) as slow:
        general(T_cw, T_gp)
    assert str(fast.value) == str(slow.value)


def test_one_solve_path_only_for_its_arguments():
    """Lists, float32, more than _ONE_MAX_VIEWS views, a bad pairs or min_rotation_rad:
    the general path (which converts, or names the problem); lists give the same bits."""
    rng = np.random.default_rng(14)
    X, Y = rig(rng)
    T_cw = perturb_T_cam_from_world(X @ PAPER @ Y, 0.01, 0.002, rng, variant="exponential")
    assert solver._one_case(T_cw, PAPER, "all", 1e-3)
    assert solver._one_case(T_cw, PAPER, "half", 0)
    assert solver._one_case(T_cw, PAPER, "all", np.radians(0.1))       # np.float64
    assert not solver._one_case(T_cw, PAPER, "all", True)
    assert not solver._one_case(T_cw.tolist(), PAPER, "all", 1e-3)
    assert not solver._one_case(T_cw.astype(np.float32), PAPER, "all", 1e-3)
    assert not solver._one_case(T_cw, PAPER, "some", 1e-3)
    assert not solver._one_case(T_cw, PAPER, np.array(["all", "half"]), 1e-3)
    assert not solver._one_case(T_cw, PAPER, "all", -1.0)
    assert not solver._one_case(T_cw, PAPER, "all", float("nan"))
    assert not solver._one_case(T_cw, PAPER, "all", "1e-3")
    many = np.repeat(T_cw, 4, axis=0)[: _kernels._ONE_MAX_VIEWS + 1]
    assert not solver._one_case(many, many, "all", 1e-3)
    same_result(solve_rasc(T_cw.tolist(), PAPER.tolist()), solve_rasc(T_cw, PAPER))
    with pytest.raises(solver.InputError, match="pairs: expected one of"):
        solve_rasc(T_cw, PAPER, pairs="some")
    with pytest.raises(solver.InputError, match="min_rotation_rad"):
        solve_rasc(T_cw, PAPER, min_rotation_rad=-1.0)
    with pytest.raises(solver.InputError,
                       match='^min_rotation_rad: expected a number, got "1e-3"$'):
        solve_rasc(T_cw, PAPER, min_rotation_rad="1e-3")


def test_deferred_quality_and_diagnostics_are_those_of_the_solve():
    """The one-solve path leaves eq. 10's quality and the diagnostics to be computed when
    first read. They are the general path's bits even when the caller has since
    overwritten the input arrays (the solver keeps its own copies), and pickles, deep
    copies and dataclasses.replace carry the values, not the deferral."""
    rng = np.random.default_rng(15)
    X, Y = rig(rng)
    T_gp = PAPER.copy()
    T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.01, 0.002, rng, variant="exponential")
    expected = general(T_cw.copy(), T_gp.copy())
    results = [solve_rasc(T_cw, T_gp) for _ in range(4)]
    T_cw[:] = np.eye(4)
    T_gp[:, :3, :3] = T_gp[:, :3, :3][::-1]
    blob = pickle.dumps(results[1])
    assert b"_Deferred" not in blob
    for result in (results[0], pickle.loads(blob), copy.deepcopy(results[2]),
                   dataclasses.replace(results[3], method="rasc")):
        same_result(result, expected)
    with pytest.raises(dataclasses.FrozenInstanceError):
        results[0].quality = 0.0
    with pytest.raises(TypeError, match="quality"):           # still no default
        solver.HandEyeResult(T_cam_from_gaze=np.eye(4), method="m",
                             diagnostics=expected.diagnostics)
