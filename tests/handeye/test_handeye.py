"""RASC gaze-to-camera solver (rasc.handeye.solver, docs/METHOD.md §3): truth chosen, data
generated, truth
recovered; the all-ordered-pairs definition; invariances; degeneracy; the batched form."""

import json
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu
from rasc.geometry.transforms import (
    invert_transform,
    make_transform,
    matrix_from_rotvec,
    project_to_rotation,
    rotation_angle,
    rotation_error_deg,
    rotvec_from_matrix,
)
from rasc.handeye import paper
from rasc.handeye._kernels import _det_closed_form, _polar_rotation
from rasc.handeye.advice import check_motions_match, motion_angle_ratio, solution_warnings
from rasc.handeye.noise import perturb_T_cam_from_world
from rasc.handeye.solver import (
    MIN_AXIS_SPREAD,
    WEAK_AXIS_SPREAD,
    HandEyeDiagnostics,
    HandEyeResult,
    diagnose,
    pair_rotvecs,
    quality_eq10,
    solve_rasc,
    solve_rasc_batch,
)

from nominal_rig import PAPER, pan_tilt, random_rigid, rig

# Noise-free tolerance, 1e-9 (the brief's): every result is a few hundred double
# operations from exact data; measured errors are 1e-15..1e-14, and the worst
# conditioning here (cond(MᵀM) = 2.4e4 for the nine ±8° poses, i.e. ~150 on M) keeps
# them below 1e-12. Translations are in metres (a few cm) or arm units (~1).
EXACT = 1e-9


def grid(half_deg, k):
    a = np.linspace(-half_deg, half_deg, k)
    return [(p, t) for p in a for t in a]


def assert_close_transform(T, T_ref, atol):
    np.testing.assert_allclose(T[:3, :3], T_ref[:3, :3], atol=atol, rtol=0)
    np.testing.assert_allclose(T[:3, 3], T_ref[:3, 3], atol=atol, rtol=0)


# ------------------------------------------------------------------ recovery


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("poses", [
    PAPER_POSES_DEG,                                   # the paper's nine ±8° poses
    grid(1.0, 3),                                      # tiny motions
    grid(5.0, 4),
    grid(30.0, 4),
    [(-60.0, -10.0), (0.0, 0.0), (45.0, 30.0), (10.0, -40.0)],
])
def test_noise_free_pan_tilt_recovery(seed, poses):
    rng = np.random.default_rng(seed)
    X, Y = rig(rng)
    T_gp = pan_tilt(poses)
    res = solve_rasc(X @ T_gp @ Y, T_gp)
    assert isinstance(res, HandEyeResult) and res.method == "rasc"
    assert_close_transform(res.T_cam_from_gaze, X, EXACT)
    assert res.quality < 1e-12  # eq. 10 on exact data: round-off only (measured ~1e-15)


@pytest.mark.parametrize("seed", [3, 4, 5, 6])
def test_noise_free_general_rigid_recovery(seed):
    """A robot arm: the unit (gripper) translates too; X rotates by up to 180°."""
    rng = np.random.default_rng(seed)
    X = random_rigid(rng, 1)[0]
    Y = random_rigid(rng, 1, t_scale=2.0)[0]
    T_gp = random_rigid(rng, 12, max_angle=np.radians(90))
    res = solve_rasc(X @ T_gp @ Y, T_gp)
    assert_close_transform(res.T_cam_from_gaze, X, EXACT)


def test_recovery_with_half_turns():
    """Relative motions of exactly 180° and a hand-eye rotation near 180°: the logs are
    robust there (no division by sin φ)."""
    rng = np.random.default_rng(7)
    X = make_transform(matrix_from_rotvec(np.array([1.0, 2.0, 2.0]) / 3 * (np.pi - 1e-7)),
                       [0.1, -0.2, 0.3])
    Y = random_rigid(rng, 1)[0]
    half_x = make_transform(matrix_from_rotvec([np.pi, 0, 0]), [0.5, 0, 0])
    half_y = make_transform(matrix_from_rotvec([0, np.pi, 0]), [0, 0.5, 0])
    T_gp = np.array([np.eye(4), half_x, half_y, half_x @ half_y,
                     random_rigid(rng, 1, max_angle=1.0)[0]])
    angles = rotation_angle(T_gp[1:3, :3, :3])
    assert np.all(np.abs(angles - np.pi) < 1e-15)
    res = solve_rasc(X @ T_gp @ Y, T_gp)
    assert_close_transform(res.T_cam_from_gaze, X, EXACT)


# ------------------------------------------------------- definition and pairs


@pytest.mark.parametrize("pairs", ["all", "half"])
@pytest.mark.parametrize("unit", ["pan-tilt", "arm"])
def test_equals_plain_all_pairs_definition_under_noise(pairs, unit):
    """The vectorised solver (quaternion logs, polar factor, separable normal equations)
    equals the paper's plain loop over ordered pairs (rasc.handeye.paper). 1e-12: both are
    exact formulas of the same numbers; measured differences 1e-15..1e-14."""
    rng = np.random.default_rng(11)
    if unit == "pan-tilt":
        X, Y = rig(rng)
        T_gp = pan_tilt(grid(10.0, 3))
    else:
        X, Y = random_rigid(rng, 2)
        T_gp = random_rigid(rng, 10, max_angle=1.0)
    T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.01, 0.005, rng, variant="exponential")
    res = solve_rasc(T_cw, T_gp, pairs=pairs)
    ref = paper.solve(T_cw, T_gp, pairs=pairs).T_cam_from_gaze
    assert_close_transform(res.T_cam_from_gaze, ref, 1e-12)


def test_literal_noise_translation_step_is_eq7_as_printed():
    """With the paper's literal (non-rotation) matrices, eq. 7 is solved with R_A = R_i R_jᵀ
    and t_A = t_i − R_A t_j exactly as given: compare with the stacked least squares for
    the same R_X. 1e-12 as above."""
    X, Y = rig(np.random.default_rng(12))
    T_gp = PAPER
    T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.04, 0.008, np.random.default_rng(112),
                                    variant="literal")
    with pytest.raises(InputError, match=r"T_cam_from_world\[0\].*check_rigid=False"):
        solve_rasc(T_cw, T_gp)
    res = solve_rasc(T_cw, T_gp, check_rigid=False)
    ref = paper.solve(T_cw, T_gp, R_X=res.T_cam_from_gaze[:3, :3]).T_cam_from_gaze
    np.testing.assert_allclose(res.T_cam_from_gaze[:3, 3], ref[:3, 3], atol=1e-12, rtol=0)
    # The same draws as rotations (exponential variant) give nearly the same solution:
    # the variants differ at second order in σ_r. At the paper's largest level (0.04 rad,
    # 8 mm) measured 0.02–0.035° and 0.04–0.27 mm (5 seeds) against errors from the truth
    # of 6–12° and 100–240 mm; bounds 0.2° and 2 mm.
    T_exp = perturb_T_cam_from_world(X @ T_gp @ Y, 0.04, 0.008, np.random.default_rng(112),
                                     variant="exponential")
    other = solve_rasc(T_exp, T_gp).T_cam_from_gaze
    R_lit = res.T_cam_from_gaze[:3, :3]
    assert np.degrees(rotation_angle(R_lit.T @ other[:3, :3])) < 0.2
    assert np.linalg.norm(res.T_cam_from_gaze[:3, 3] - other[:3, 3]) < 0.002
    assert np.degrees(rotation_angle(R_lit.T @ X[:3, :3])) > 1.0  # noise dominates


def test_all_pairs_equal_half_pairs_for_pure_rotation_unit_but_not_for_an_arm():
    """For a pan-tilt unit (t_B = 0) pair (j, i) repeats the equation of pair (i, j):
    "all" = "half" (1e-12, round-off). For a translating unit under noise they differ by
    the rotation residual times t_B (measured 1.6e-2 here at translations ~1; > 1e-6
    asserted)."""
    rng = np.random.default_rng(13)
    X, Y = rig(rng)
    T_cw = perturb_T_cam_from_world(X @ PAPER @ Y, 0.01, 0.002, rng, variant="exponential")
    a = solve_rasc(T_cw, PAPER, pairs="all").T_cam_from_gaze
    b = solve_rasc(T_cw, PAPER, pairs="half").T_cam_from_gaze
    assert_close_transform(a, b, 1e-12)
    X, Y = random_rigid(rng, 2)
    T_gp = random_rigid(rng, 10, max_angle=1.0)
    T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.01, 0.005, rng, variant="exponential")
    a = solve_rasc(T_cw, T_gp, pairs="all").T_cam_from_gaze
    b = solve_rasc(T_cw, T_gp, pairs="half").T_cam_from_gaze
    np.testing.assert_allclose(a[:3, :3], b[:3, :3], atol=1e-12)  # M_all = 2 M_half
    assert np.linalg.norm(a[:3, 3] - b[:3, 3]) > 1e-6


def test_pair_logs_match_rotvec_from_matrix():
    """Quaternion-product logs equal rasc.geometry.transforms.rotvec_from_matrix of R_i R_jᵀ,
    including relative angles near 0 and exactly/near π. 1e-12: both are accurate to a
    few ulp of the angle."""
    rng = np.random.default_rng(14)
    R = matrix_from_rotvec(rng.normal(size=(20, 3)))
    base = R[0]
    axis = np.array([0.6, 0.0, 0.8])
    special = [base @ matrix_from_rotvec(axis * a).T for a in (0.0, 1e-12, 1e-7, np.pi - 1e-6,
                                                               np.pi - 1e-9, np.pi)]
    R = np.concatenate([R, special])
    n = len(R)
    i, j = np.nonzero(~np.eye(n, dtype=bool))
    got = pair_rotvecs(R, i, j)
    want = rotvec_from_matrix(R[i] @ np.swapaxes(R[j], 1, 2))
    # at π the axis sign is a convention: compare angles, and rotations
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), np.linalg.norm(want, axis=1),
                               atol=1e-12)
    np.testing.assert_allclose(matrix_from_rotvec(got), matrix_from_rotvec(want), atol=1e-12)
    away = np.linalg.norm(want, axis=1) < np.pi - 1e-3
    np.testing.assert_allclose(got[away], want[away], atol=1e-12)


def test_pair_logs_of_non_orthogonal_matrices_are_those_of_their_nearest_rotations():
    """Literal eq. 13 noise leaves R_cw non-orthogonal: each view stands for its nearest
    rotation (SVD polar factor, computed here by rasc.geometry.transforms), up to
    max |RᵀR − I| = 1/3. 1e-12: both sides are exact to a few ulp of the angle."""
    rng = np.random.default_rng(24)
    for sigma in (1e-7, 1e-3, 2e-2, 5e-2):
        R = matrix_from_rotvec(rng.normal(size=(12, 3))) + rng.normal(0, sigma, (12, 3, 3))
        err = np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max(axis=(1, 2))
        R = R[err < 1 / 3]
        P = project_to_rotation(R)
        i, j = np.nonzero(~np.eye(len(R), dtype=bool))
        want = rotvec_from_matrix(P[i] @ np.swapaxes(P[j], 1, 2))
        np.testing.assert_allclose(pair_rotvecs(R, i, j), want, atol=1e-12)


def test_polar_factor_is_the_nearest_rotation_also_for_det_below_zero_and_rank_two():
    """Eq. 9's R_X = V diag(1, 1, sign det(V Uᵀ)) Uᵀ from M = U Σ Vᵀ, by plain
    np.linalg.svd one matrix at a time, for a batch that mixes det M > 0, det M < 0 and
    rank 2: the batched call gives every matrix its own answer, a rotation (det +1).
    1e-12: both are accurate to cond(M)·1e-16 (cond up to 1e3 here)."""
    rng = np.random.default_rng(25)
    M = rng.normal(size=(200, 3, 3)) * np.geomspace(1, 1e-3, 3)   # cond up to ~1e3
    M[:20] *= -1.0                                                 # det M < 0
    M[20:25, 2] = M[20:25, 0] + M[20:25, 1]                        # rank 2
    got, _ = _polar_rotation(M)
    for k in range(len(M)):
        U, _, Vt = np.linalg.svd(M[k])
        D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
        np.testing.assert_allclose(got[k], Vt.T @ D @ U.T, atol=1e-12)
        np.testing.assert_array_equal(_polar_rotation(M[k:k + 1])[0][0], got[k])
    np.testing.assert_allclose(np.linalg.det(got), 1.0, atol=1e-12)


def test_cofactor_determinant_equals_lapack():
    """The validation's determinant for many matrices (cofactors) is LAPACK's LU one to
    round-off: entries of order 1, so 1e-13 absolute is ~500 ulp of margin."""
    rng = np.random.default_rng(31)
    A = rng.normal(size=(3000, 3, 3))
    A[:5] = random_rigid(rng, 5)[:, :3, :3]
    np.testing.assert_allclose(_det_closed_form(A), np.linalg.det(A), rtol=0, atol=1e-13)
    np.testing.assert_allclose(_det_closed_form(A.reshape(30, 100, 3, 3)),
                               np.linalg.det(A).reshape(30, 100), rtol=0, atol=1e-13)


def test_scratch_buffers_leave_no_trace_between_solves_and_threads():
    """The solver reuses per-thread scratch arrays: solves of other sizes in between, or
    in other threads at the same time, leave every result bit-identical."""
    from concurrent.futures import ThreadPoolExecutor

    rng = np.random.default_rng(32)
    cases = []
    for n in (9, 30, 5, 88):
        X, Y = rig(rng)
        T_gp = pan_tilt(np.column_stack([rng.uniform(-20, 20, n), rng.uniform(-15, 15, n)]))
        T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.01, 0.002, rng, variant="exponential")
        cases.append((T_cw, T_gp))

    def run(case):
        r = solve_rasc(*case)
        return r.T_cam_from_gaze, r.quality, r.diagnostics

    first = [run(c) for c in cases]
    with ThreadPoolExecutor(4) as pool:
        again = list(pool.map(run, cases * 8))
    for k, got in enumerate(again + [run(c) for c in reversed(cases)][::-1]):
        want = first[k % len(cases)]
        np.testing.assert_array_equal(got[0], want[0])
        assert got[1] == want[1] and got[2] == want[2]


def test_quality_is_eq10():
    rng = np.random.default_rng(15)
    X, Y = rig(rng)
    T_cw = perturb_T_cam_from_world(X @ PAPER @ Y, 0.02, 0.004, rng, variant="literal")
    res = solve_rasc(T_cw, PAPER, check_rigid=False)
    RX = res.T_cam_from_gaze[:3, :3]
    norms = [np.linalg.norm(RX @ PAPER[i, :3, :3] @ PAPER[j, :3, :3].T @ RX.T
                            - T_cw[i, :3, :3] @ T_cw[j, :3, :3].T)
             for i in range(9) for j in range(9) if i != j]
    # 1e-13: the same sums in another order
    assert abs(res.quality - np.mean(norms)) < 1e-13
    assert 0.01 < res.quality < 1.0  # noisy but usable (paper: above 1 unusable)


def test_diagnostics_for_the_nine_poses():
    rng = np.random.default_rng(16)
    X, Y = rig(rng)
    d = solve_rasc(X @ PAPER @ Y, PAPER).diagnostics
    assert (d.n_positions, d.n_pairs, d.n_pairs_used) == (9, 72, 72)
    angles = [np.degrees(rotation_angle(PAPER[i, :3, :3] @ PAPER[j, :3, :3].T))
              for i in range(9) for j in range(9) if i != j]
    assert abs(d.min_rotation_deg - min(angles)) < 1e-9
    assert abs(d.max_rotation_deg - max(angles)) < 1e-9
    assert abs(d.min_rotation_deg - 8.0) < 1e-9
    assert 1.0 <= d.cond_CtC < 3.0       # measured 1.99: two well-spread axes
    assert d.cond_MtM > 1e3              # measured 2.4e4: weak third axis, harmless
    json.dumps(solve_rasc(X @ PAPER @ Y, PAPER).to_dict(), allow_nan=False)


def test_to_dict_is_json_ready_with_infinite_condition():
    d = HandEyeDiagnostics(3, 6, 6, math.inf, 2.0, 1.0, 2.0, 1.0, (1.0, 0.0, 0.0))
    assert d.to_dict()["cond_MtM"] is None
    assert d.to_dict()["dominant_axis"] == [1.0, 0.0, 0.0]
    r = HandEyeResult(np.eye(4), 0.5, "rasc", d)
    assert json.loads(json.dumps(r.to_dict(), allow_nan=False))["T_cam_from_gaze"][3] == \
        [0.0, 0.0, 0.0, 1.0]


def test_tiny_motions_are_left_out():
    """A repeated position adds pairs with no rotation: counted, not used, harmless."""
    rng = np.random.default_rng(17)
    X, Y = rig(rng)
    T_gp = np.concatenate([PAPER, PAPER[3:4]])
    res = solve_rasc(X @ T_gp @ Y, T_gp)
    assert res.diagnostics.n_pairs == 90 and res.diagnostics.n_pairs_used == 88
    assert res.diagnostics.min_rotation_deg < 1e-6
    assert_close_transform(res.T_cam_from_gaze, X, EXACT)


# ----------------------------------------------------------------- invariances


def _noisy_arm(seed, n=8):
    rng = np.random.default_rng(seed)
    X, Y = random_rigid(rng, 2)
    T_gp = random_rigid(rng, n, max_angle=1.2)
    T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 0.01, 0.01, rng, variant="exponential")
    return rng, T_cw, T_gp


# Invariances hold exactly in exact arithmetic; 1e-10 allows the round-off of sums taken
# in another order on data of unit scale (measured ≤ 1e-14).
@settings(max_examples=25, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1))
def test_property_order_of_positions(seed):
    rng, T_cw, T_gp = _noisy_arm(seed)
    perm = rng.permutation(len(T_cw))
    a = solve_rasc(T_cw, T_gp).T_cam_from_gaze
    b = solve_rasc(T_cw[perm], T_gp[perm]).T_cam_from_gaze
    assert_close_transform(a, b, 1e-10)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1))
def test_property_change_of_world_frame(seed):
    rng, T_cw, T_gp = _noisy_arm(seed)
    T_world_from_world2 = random_rigid(rng, 1, t_scale=3.0)[0]
    a = solve_rasc(T_cw, T_gp)
    b = solve_rasc(T_cw @ T_world_from_world2, T_gp)
    assert_close_transform(a.T_cam_from_gaze, b.T_cam_from_gaze, 1e-10)
    assert abs(a.quality - b.quality) < 1e-12


@settings(max_examples=25, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1), st.floats(1e-3, 1e3))
def test_property_scaling_of_translations(seed, scale):
    """Changing the unit of length (m → mm: ×1000) scales t_X and nothing else."""
    _, T_cw, T_gp = _noisy_arm(seed)
    S = np.diag([scale, scale, scale, 1.0])
    a = solve_rasc(T_cw, T_gp).T_cam_from_gaze
    b = solve_rasc(S @ T_cw @ np.linalg.inv(S), S @ T_gp @ np.linalg.inv(S)).T_cam_from_gaze
    np.testing.assert_allclose(b[:3, :3], a[:3, :3], atol=1e-10)
    np.testing.assert_allclose(b[:3, 3], scale * a[:3, 3], atol=1e-10 * scale, rtol=0)


def test_world_change_invariance_pan_tilt():
    rng = np.random.default_rng(18)
    X, Y = rig(rng)
    T_cw = perturb_T_cam_from_world(X @ PAPER @ Y, 0.01, 0.002, rng, variant="exponential")
    W = random_rigid(rng, 1)[0]
    a = solve_rasc(T_cw, PAPER).T_cam_from_gaze
    b = solve_rasc(T_cw @ W, PAPER).T_cam_from_gaze
    assert_close_transform(a, b, 1e-12)


# ------------------------------------------------------------------- batch


@pytest.mark.parametrize("shared", [True, False])
def test_batch_equals_single_solves(shared):
    rng = np.random.default_rng(19)
    X, Y = rig(rng)
    S = 6
    T_gp = PAPER if shared else np.stack([pan_tilt(grid(8.0 + s, 3)) for s in range(S)])
    T_true = X @ T_gp @ Y if not shared else np.broadcast_to(X @ PAPER @ Y, (S, 9, 4, 4))
    T_cw = perturb_T_cam_from_world(T_true, 0.02, 0.004, rng, variant="literal")
    out = solve_rasc_batch(T_cw, T_gp, check_rigid=False)
    assert out.T_cam_from_gaze.shape == (S, 4, 4) and out.quality.shape == (S,)
    for s in range(S):
        one = solve_rasc(T_cw[s], T_gp if shared else T_gp[s], check_rigid=False)
        # 1e-12: identical arithmetic, batched
        assert_close_transform(out.T_cam_from_gaze[s], one.T_cam_from_gaze, 1e-12)
        assert abs(out.quality[s] - one.quality) < 1e-12


def test_batch_of_no_samples_is_an_input_error():
    with pytest.raises(InputError, match=r"T_cam_from_world: no samples"):
        solve_rasc_batch(np.zeros((0, 9, 4, 4)), PAPER)


def test_batch_names_the_degenerate_sample():
    rng = np.random.default_rng(20)
    X, Y = rig(rng)
    T_gp = np.stack([PAPER, PAPER, pan_tilt([(p, 0.0) for p in (-8, 0, 8, 4)] + [(0, 0)] * 5)])
    with pytest.raises(DegenerateDataError, match=r"\(sample 2\)"):
        solve_rasc_batch(X @ T_gp @ Y, T_gp)


# -------------------------------------------------------------- degeneracy


def _data(poses):
    X, Y = rig(np.random.default_rng(21))
    T_gp = pan_tilt(poses)
    return X @ T_gp @ Y, T_gp


@pytest.mark.parametrize("poses, axis", [
    ([(-8.0, 0.0), (0.0, 0.0), (8.0, 0.0), (4.0, 0.0)], r"\[1\.000, 0\.000, 0\.000\]"),  # pan
    ([(0.0, -8.0), (0.0, 0.0), (0.0, 8.0)], r"\[0\.000, 0\.000, 1\.000\]"),               # tilt
    ([(10.0, -8.0), (10.0, 0.0), (10.0, 8.0)], r"\[0\.000, 0\.000, 1\.000\]"),            # tilt
])
def test_single_axis_motion_is_degenerate(poses, axis):
    T_cw, T_gp = _data(poses)
    for solve in (solve_rasc, lambda a, b: solve_rasc_batch(a[None], b)):
        with pytest.raises(DegenerateDataError, match="pan-only or tilt-only") as exc:
            solve(T_cw, T_gp)
        msg = str(exc.value)
        assert "\n" not in msg and "add positions with tilt" in msg
        assert "translation along" in msg
        assert re.search(axis, msg)


def test_nearly_single_axis_motion_is_degenerate():
    """Pan ±10° with a 0.001° tilt wobble: axis spread λ2/λ1 ≈ 1e-8 < 1e-3."""
    T_cw, T_gp = _data([(-10.0, 0.0), (0.0, 0.001), (10.0, 0.0), (5.0, -0.001)])
    with pytest.raises(DegenerateDataError, match="axis spread"):
        solve_rasc(T_cw, T_gp)


def _pan_with_small_tilt(tilt_deg):
    """Pan {−8, 0, 8}° × tilt {−a, 0, a}°: motions nearly about the pan axis alone."""
    return pan_tilt([(p, t) for p in (-8.0, 0.0, 8.0) for t in (-tilt_deg, 0.0, tilt_deg)])


def test_near_single_axis_sweep_justifies_the_thresholds():
    """The numbers in MIN_AXIS_SPREAD's comment: the error grows as the other joint's
    motion shrinks, about as 1/√spread. Noise as the handeye example's (0.03°, 0.5 mm,
    exponential eq. 13-14), 30 seeded samples per tilt range, one rig."""
    X, Y = rig(np.random.default_rng(3))
    spread, rot, trans = {}, {}, {}
    for a in (0.1, 0.5, 2.0, 8.0):
        T_gp = _pan_with_small_tilt(a)
        e = []
        for seed in range(30):
            T_cw = perturb_T_cam_from_world(X @ T_gp @ Y, 5e-4, 5e-4,
                                            np.random.default_rng(seed), variant="exponential")
            # the solver's own check is what is being justified: measure below it too
            r = _solve_unchecked(T_cw, T_gp)
            spread[a] = r.diagnostics.axis_spread
            e.append((rotation_error_deg(r.T_cam_from_gaze[:3, :3], X[:3, :3]),
                      1e3 * np.linalg.norm(r.T_cam_from_gaze[:3, 3] - X[:3, 3])))
        e = np.array(e)
        rot[a], trans[a] = np.median(e[:, 0]), np.median(e[:, 1])
    # spread λ2/λ1 depends on the motions only: the pan and tilt grids are alike but for
    # their size, so G's two eigenvalues are in the ratio (a/8)², to first order in the
    # angles (pan-tilt coupling moves it by 0.5 % at most here: bound 1.5 %)
    for a in (0.1, 0.5, 2.0, 8.0):
        assert spread[a] == pytest.approx((a / 8.0) ** 2, rel=0.015)
    assert spread[0.1] < MIN_AXIS_SPREAD < spread[0.5] < WEAK_AXIS_SPREAD < spread[2.0]
    # amplification relative to well-spread motions (measured here: rotation 38× and
    # 7.3× at a = 0.1° and 0.5°, translation 32× and 7.8×): bounds at half of that, so
    # the comment's "≳ 15×" below MIN_AXIS_SPREAD and "≳ 4×" below WEAK_AXIS_SPREAD hold
    assert rot[0.1] > 15 * rot[8.0] and trans[0.1] > 15 * trans[8.0]
    assert rot[0.5] > 3.5 * rot[8.0] and trans[0.5] > 3.5 * trans[8.0]
    assert rot[2.0] < rot[0.5] and trans[2.0] < trans[0.5]


def _solve_unchecked(T_cw, T_gp):
    """RASC with the axis-spread check off (restored afterwards, so no other test sees
    it)."""
    import rasc.handeye._checks as checks
    import rasc.handeye._kernels as kernels

    saved = checks.MIN_AXIS_SPREAD                # read by both paths' checks
    checks.MIN_AXIS_SPREAD = kernels.MIN_AXIS_SPREAD = 0.0
    try:
        return solve_rasc(T_cw, T_gp)
    finally:
        checks.MIN_AXIS_SPREAD = kernels.MIN_AXIS_SPREAD = saved


def test_nearly_pan_only_is_rejected_and_weak_spread_is_warned():
    X, Y = rig(np.random.default_rng(5))
    # tilt ±0.2°: spread 6.2e-4 < 1e-3 — rejected with the axis named (the pan axis is
    # the unit's x axis)
    T_gp = _pan_with_small_tilt(0.2)
    with pytest.raises(DegenerateDataError, match=r"axis \[1\.000, 0\.000, 0\.000\].*axis "
                                                  r"spread λ2/λ1 = 0\.00062 < 0\.001"):
        solve_rasc(X @ T_gp @ Y, T_gp)
    # tilt ±0.5°: solved (exactly, without noise), with one warning naming the axis
    T_gp = _pan_with_small_tilt(0.5)
    r = solve_rasc(X @ T_gp @ Y, T_gp)
    assert np.abs(r.T_cam_from_gaze - X).max() < EXACT
    assert r.diagnostics.dominant_axis == pytest.approx((1.0, 0.0, 0.0), abs=1e-6)
    w = solution_warnings(r)
    assert len(w) == 1 and "axis [1.000, 0.000, 0.000] (axis spread 0.0039 < 0.01)" in w[0]
    assert "errors about 16× those of well-spread motions" in w[0]
    # the paper's nine poses: no warning
    T_gp = _pan_with_small_tilt(8.0)
    assert solution_warnings(solve_rasc(X @ T_gp @ Y, T_gp)) == []


def test_motion_angle_ratio_is_one_under_noise_and_57_for_a_unit_mix_up():
    """MAX_MOTION_ANGLE_RATIO's comment: consistent data give a median ratio near 1 even
    at the paper's largest noise (σ_r = 0.04 rad, literal eq. 13) on ±8° motions
    (measured 0.69-1.12 over these 200 samples: bounds 0.6 and 1.4); angles read in the
    wrong unit give π/180 (or its inverse), far outside 1/3..3."""
    X, Y = rig(np.random.default_rng(3))
    T_gp = pan_tilt(PAPER_POSES_DEG)
    exact = X @ T_gp @ Y
    assert motion_angle_ratio(exact, T_gp) == pytest.approx(1.0, abs=1e-9)
    ratios = [motion_angle_ratio(perturb_T_cam_from_world(exact, 0.04, 0.008,
                                                          np.random.default_rng(s)), T_gp)
              for s in range(200)]
    assert min(ratios) > 0.6 and max(ratios) < 1.4
    check_motions_match(perturb_T_cam_from_world(exact, 0.04, 0.008,
                                                 np.random.default_rng(0)), T_gp)
    # ±2° written in radians (0.035) and read as degrees: the unit turns 57× too little
    small = [(p / 4, t / 4) for p, t in PAPER_POSES_DEG]
    T_small = pan_tilt(small)
    in_rad = T_gaze_from_ptu(*np.radians(np.radians(np.array(small))).T)
    assert motion_angle_ratio(X @ T_small @ Y, in_rad) == pytest.approx(np.pi / 180, rel=1e-3)
    # the same values read as radians (what they were) match: the message says so
    with pytest.raises(InputError, match=r"turn 0\.0175× .*read as rad the angles match "
                                         r"\(1×\); set angle_unit to 'rad'"):
        check_motions_match(X @ T_small @ Y, in_rad, other_unit=("rad", T_small))
    # no reading matches (here: camera poses inverted and noisy): inconsistent data
    with pytest.raises(InputError, match="the data are inconsistent; check that each "
                                         "T_cam_from_world is the target's pose"):
        check_motions_match(X @ T_small @ Y, in_rad, other_unit=("rad", in_rad))
    with pytest.raises(InputError, match="the data are inconsistent"):
        check_motions_match(X @ T_small @ Y, in_rad)


def test_ill_conditioned_translation_is_degenerate():
    """The unit turns about two axes but the camera's measured motions about one only
    (inconsistent data): CᵀC (eq. 7) is singular along that axis."""
    T_cw, _ = _data([(-8.0, 0.0), (0.0, 0.0), (8.0, 0.0), (4.0, 0.0)])
    _, T_gp = _data([(-8.0, 0.0), (0.0, 0.0), (0.0, 8.0), (4.0, 4.0)])
    with pytest.raises(DegenerateDataError, match=r"cond\(CᵀC\) = .* > 10000"):
        solve_rasc(T_cw, T_gp)


def test_fewer_than_three_positions():
    T_cw, T_gp = _data([(0.0, 0.0), (8.0, 8.0)])
    with pytest.raises(DegenerateDataError, match="only 2 positions.*at least 3"):
        solve_rasc(T_cw, T_gp)


def test_identical_poses():
    T_cw, T_gp = _data([(5.0, 5.0)] * 6)
    with pytest.raises(DegenerateDataError, match=r"only 0 motion\(s\).*move the unit"):
        solve_rasc(T_cw, T_gp)


def test_two_identical_positions_leave_one_motion():
    """Positions A, A, B: the usable pairs (A, B) twice are one motion, one axis."""
    T_cw, T_gp = _data([(0.0, 0.0), (0.0, 0.0), (8.0, 8.0)])
    with pytest.raises(DegenerateDataError, match="cannot be determined.*one axis"):
        solve_rasc(T_cw, T_gp)


def test_diagnose_checks_any_method_pairs():
    T_cw, T_gp = _data(PAPER_POSES_DEG)
    d, _, _ = diagnose(T_cw, T_gp, home=0)
    assert (d.n_pairs, d.n_pairs_used) == (8, 8)
    d, _, _ = diagnose(T_cw, T_gp, pairs="half")
    assert d.n_pairs == 36
    with pytest.raises(InputError, match="home"):
        diagnose(T_cw, T_gp, home=9)


# ------------------------------------------------------------------ inputs


@pytest.mark.parametrize("mutate, fragment", [
    (lambda a, b: (a[:5], b), "5 positions but T_gaze_from_ptu has 9"),
    (lambda a, b: (a[:, :3], b), r"expected shape \(n, 4, 4\)"),
    (lambda a, b: (np.where(np.arange(9)[:, None, None] == 4, np.nan, a), b),
     r"T_cam_from_world\[4\]: contains NaN"),
    (lambda a, b: (a, b @ np.where(np.arange(9)[:, None, None] == 2,
                                   np.diag([1.0, 1.01, 1.0, 1.0]), np.eye(4))),
     r"T_gaze_from_ptu\[2\].*orthonormal.*check_rigid=False"),
    (lambda a, b: (a @ np.diag([1.0, 1.0, -1.0, 1.0]), b), r"T_cam_from_world\[0\].*determinant"),
    (lambda a, b: (a, "nonsense"), "T_gaze_from_ptu: not a numeric array"),
    (lambda a, b: (a, b[:, :, :3]), r"T_gaze_from_ptu: expected shape \(n, 4, 4\)"),
    (lambda a, b: (a, b + np.where(np.arange(9)[:, None, None] == 7, 1e-3, 0.0) *
                   np.eye(4)[3]), r"T_gaze_from_ptu\[7\]: last row"),
])
def test_bad_input(mutate, fragment):
    T_cw, T_gp = _data(PAPER_POSES_DEG)
    with pytest.raises(InputError, match=fragment):
        solve_rasc(*mutate(T_cw, T_gp))


def test_bad_options():
    T_cw, T_gp = _data(PAPER_POSES_DEG)
    with pytest.raises(InputError, match="pairs"):
        solve_rasc(T_cw, T_gp, pairs="some")
    with pytest.raises(InputError, match="min_rotation_rad"):
        solve_rasc(T_cw, T_gp, min_rotation_rad=-1.0)
    with pytest.raises(InputError, match="samples"):
        solve_rasc_batch(np.stack([T_cw] * 3), np.stack([T_gp] * 2))


def test_methods_table():
    from rasc.handeye import methods

    assert set(methods.METHODS) == {"rasc", "rasc-inverse", "rasc-views", "rasc-robust",
                                    "rasc-scale", "li", "opencv-park",
                                    "opencv-tsai", "opencv-horaud", "opencv-andreff",
                                    "opencv-daniilidis"}
    T_cw, T_gp = _data(PAPER_POSES_DEG)
    a = methods.solve("rasc", T_cw, T_gp, pairs="half")
    assert a.method == "rasc" and a.diagnostics.n_pairs == 36
    with pytest.raises(InputError, match="method"):
        methods.solve("magic", T_cw, T_gp)


def test_quality_helper_shape():
    R = matrix_from_rotvec(np.random.default_rng(22).normal(size=(2, 5, 3)))
    q = quality_eq10(R, R[:1], np.broadcast_to(np.eye(3), (2, 3, 3)))
    assert q.shape == (2,) and q[0] < 1e-14 and q[1] > 0.1


def test_inverse_relation_of_the_two_orientations():
    """Solving with the slots swapped gives the inverse rotation exactly (the polar
    factor of M is the transpose of that of Mᵀ); 1e-12: round-off."""
    rng, T_cw, T_gp = _noisy_arm(23)
    a = solve_rasc(T_cw, T_gp).T_cam_from_gaze
    b = solve_rasc(T_gp, T_cw).T_cam_from_gaze
    np.testing.assert_allclose(b[:3, :3], a[:3, :3].T, atol=1e-12)
    d = np.linalg.norm(invert_transform(b)[:3, 3] - a[:3, 3])
    assert 1e-9 < d < 0.1  # translations differ slightly under noise (measured 1.0e-2)


def test_far_from_orthogonal_input_without_rigidity_check():
    """check_rigid=False and a rotation block scaled by 2 (Newton–Schulz diverges): the
    rotation step falls back to the SVD projection, so a scaled view is read as its
    rotation — the scale then only disturbs eq. 7 and eq. 10. Exact data otherwise:
    the rotation is still recovered (1e-9)."""
    rng = np.random.default_rng(24)
    X, Y = rig(rng)
    T_cw = X @ PAPER @ Y
    T_cw[3, :3, :3] *= 2.0
    res = solve_rasc(T_cw, PAPER, check_rigid=False)
    np.testing.assert_allclose(res.T_cam_from_gaze[:3, :3], X[:3, :3], atol=1e-9)
    assert res.quality > 0.1


def test_results_are_immutable():
    T_cw, T_gp = _data(PAPER_POSES_DEG)
    res = solve_rasc(T_cw, T_gp)
    with pytest.raises(ValueError):
        res.T_cam_from_gaze[0, 0] = 1.0
    with pytest.raises(AttributeError):
        res.quality = 0.0
    out = solve_rasc_batch(T_cw[None], T_gp)
    with pytest.raises(ValueError):
        out.quality[0] = 0.0
