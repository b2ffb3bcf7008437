"""The solver's speed kernels against the paper's equations written plainly.

:mod:`rasc.handeye.paper` is eq. 6–10 one ordered pair at a time (scipy's logs, a stacked
least squares); :mod:`rasc.handeye._kernels` computes the same quantities by quaternion
pair logs, contractions with the pair-weight matrix and one code path per batch. They are
not the same bits: each sums in its own order, so they agree to round-off, amplified by
the conditioning of the two linear steps. Measured over 400 draws (pan-tilt units with
3–11 random positions, robot arms with 3–29, the paper's nine poses; rigid and literal
eq. 13 noise; both pair sets; drawn by :func:`draw` below), in units of ε = 2.2e-16:

* rotation, max |ΔR| ≤ 4.6 · cond(M) · ε   → asserted ≤ 32 · cond(M) · ε
* translation, max |Δt| ≤ 48 · cond(CᵀC) · ε · max(1, |t_cw|) → asserted ≤ 512 · ...
* quality (eq. 10), |Δq| ≤ 0.6 ε             → asserted ≤ 8 ε

(cond(M) = √cond(MᵀM) from the diagnostics.) The margins (×7, ×10, ×13) leave room for
another BLAS; a wrong equation, pair, sign or weight moves the results by the noise level
(1e-3 and more), eleven orders above these bounds.
"""

from __future__ import annotations

import numpy as np
import pytest

from rasc.errors import DegenerateDataError
from rasc.handeye import paper
from rasc.handeye.noise import perturb_T_cam_from_world
from rasc.handeye.solver import solve_rasc, solve_rasc_batch

from nominal_rig import PAPER, pan_tilt, random_rigid, rig

EPS = np.finfo(float).eps


def draw(kind: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Truth chosen, data generated: ``(X @ T_gp @ Y, T_gp)`` for a unit of ``kind``."""
    if kind == "pan-tilt":
        X, Y = rig(rng)
        T_gp = pan_tilt(rng.uniform(-10, 10, (int(rng.integers(3, 12)), 2)))
    elif kind == "arm":
        X, Y = random_rigid(rng, 2)
        T_gp = random_rigid(rng, int(rng.integers(3, 30)), max_angle=1.0)
    else:
        X, Y = rig(rng)
        T_gp = PAPER
    return X @ T_gp @ Y, T_gp


def assert_round_off(res, ref: paper.Solution, T_cw: np.ndarray) -> None:
    d = res.diagnostics
    T, T_ref = res.T_cam_from_gaze, ref.T_cam_from_gaze
    scale = max(1.0, float(np.abs(T_cw[:, :3, 3]).max()))
    assert np.abs(T[:3, :3] - T_ref[:3, :3]).max() <= 32 * np.sqrt(d.cond_MtM) * EPS
    assert np.abs(T[:3, 3] - T_ref[:3, 3]).max() <= 512 * d.cond_CtC * EPS * scale
    assert abs(res.quality - ref.quality) <= 8 * EPS
    np.testing.assert_array_equal(T[3], [0.0, 0.0, 0.0, 1.0])


@pytest.mark.parametrize("kind", ["pan-tilt", "arm", "paper"])
@pytest.mark.parametrize("variant", ["exponential", "literal"])
@pytest.mark.parametrize("pairs", ["all", "half"])
def test_kernels_equal_the_paper_to_round_off(kind, variant, pairs):
    rng = np.random.default_rng(["pan-tilt", "arm", "paper"].index(kind) * 10
                                + (variant == "literal") * 2 + (pairs == "half"))
    for _ in range(4):
        T_true, T_gp = draw(kind, rng)
        T_cw = perturb_T_cam_from_world(T_true, 0.02, 0.004, rng, variant=variant)
        res = solve_rasc(T_cw, T_gp, pairs=pairs, check_rigid=variant == "exponential")
        assert_round_off(res, paper.solve(T_cw, T_gp, pairs=pairs), T_cw)


def test_batched_kernels_equal_the_paper_sample_by_sample():
    """S = 400 literal nine-view samples, more than one block of the batched path."""
    rng = np.random.default_rng(4)
    X, Y = rig(rng)
    T_cw = perturb_T_cam_from_world(np.broadcast_to(X @ PAPER @ Y, (400, 9, 4, 4)), 0.03, 0.004,
                                    rng, variant="literal")
    out = solve_rasc_batch(T_cw, PAPER, check_rigid=False)
    for s in (0, 1, 137, 398, 399):
        one = solve_rasc(T_cw[s], PAPER, check_rigid=False)
        np.testing.assert_array_equal(out.T_cam_from_gaze[s], one.T_cam_from_gaze)
        assert_round_off(one, paper.solve(T_cw[s], PAPER), T_cw[s])


@pytest.mark.parametrize("seed", [0, 1])
def test_the_paper_recovers_the_truth(seed):
    """Noise-free data: the reference itself recovers the chosen X (1e-9: a few hundred
    double operations from exact data, measured ~1e-15) with eq. 10's quality at
    round-off, for the paper's poses and for an arm."""
    rng = np.random.default_rng(seed)
    X, Y = rig(rng)
    ref = paper.solve(X @ PAPER @ Y, PAPER)
    np.testing.assert_allclose(ref.T_cam_from_gaze, X, atol=1e-9, rtol=0)
    assert ref.quality < 1e-12
    X, Y = random_rigid(rng, 2)
    T_gp = random_rigid(rng, 8, max_angle=2.0)
    np.testing.assert_allclose(paper.solve(X @ T_gp @ Y, T_gp).T_cam_from_gaze, X,
                               atol=1e-9, rtol=0)


def test_the_paper_refuses_motions_about_one_axis():
    """Pan-only motions: eq. 7's CᵀC is singular along the pan axis; no number."""
    X, Y = rig(np.random.default_rng(5))
    T_gp = pan_tilt([(a, 0.0) for a in np.linspace(-8, 8, 9)])
    with pytest.raises(DegenerateDataError, match="eq. 7"):
        paper.solve(X @ T_gp @ Y, T_gp)
