"""The batched RASC solve does not depend on the batch (issue 9).

``solve_rasc_batch(T)[k]``, ``solve_rasc_batch(T[k:k+1])`` and ``solve_rasc(T[k])`` are
the same bits (transform and eq. 10 quality) for every k, whatever the batch's size and
composition: a single solve is a block of one sample of the same code, and every step of
a block treats each sample on its own (rasc/handeye/_kernels.py, ``_solve``). Exact
equality is the claim, so the tests compare with ``==``, no tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rasc.errors import DegenerateDataError, InputError
from rasc.handeye import _kernels
from rasc.handeye.noise import perturb_T_cam_from_world
from rasc.handeye.solver import solve_rasc, solve_rasc_batch, solve_rasc_each

from nominal_rig import PAPER, pan_tilt, random_rigid, rig


def pose_sets(seed: int, S: int, kind: str, variant: str, sigma: float):
    """S noisy pose sets of one scene: T_cw (S, n, 4, 4) and the unit's T_gp, shared
    (n, 4, 4) for the pan-tilt head, one per set (S, n, 4, 4) for the arm."""
    rng = np.random.default_rng(seed)
    if kind == "pan-tilt":
        X, Y = rig(rng)
        T_gp = PAPER
        T_true = np.broadcast_to(X @ T_gp @ Y, (S, 9, 4, 4))
    else:
        n = int(rng.integers(3, 12))
        X, Y = random_rigid(rng, 2)
        T_gp = np.stack([random_rigid(rng, n, max_angle=1.0) for _ in range(S)])
        T_true = X @ T_gp @ Y
    T_cw = perturb_T_cam_from_world(T_true, sigma, sigma / 5, rng, variant=variant)
    return T_cw, T_gp


def assert_same_bits(batch, k: int, T: np.ndarray, quality: float) -> None:
    np.testing.assert_array_equal(batch.T_cam_from_gaze[k], T)
    assert batch.quality[k] == quality


@settings(max_examples=30, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), S=st.integers(1, 40),
       kind=st.sampled_from(["pan-tilt", "arm"]),
       variant=st.sampled_from(["exponential", "literal"]),
       pairs=st.sampled_from(["all", "half"]), sigma=st.sampled_from([0.0, 1e-3, 0.02]))
def test_each_sample_has_the_same_bits_alone_in_any_batch_and_as_a_single_solve(
        seed, S, kind, variant, pairs, sigma):
    T_cw, T_gp = pose_sets(seed, S, kind, variant, sigma)
    shared = T_gp.ndim == 3
    opts = {"pairs": pairs, "check_rigid": variant == "exponential"}
    out = solve_rasc_batch(T_cw, T_gp, **opts)
    order = np.random.default_rng(seed).permutation(S)[: max(1, S // 2)]
    other = solve_rasc_batch(T_cw[order], T_gp if shared else T_gp[order], **opts)
    for pos, k in enumerate(order):                  # another composition and order
        assert_same_bits(other, pos, out.T_cam_from_gaze[k], out.quality[k])
    for k in range(S):
        unit = T_gp if shared else T_gp[k]
        alone = solve_rasc_batch(T_cw[k:k + 1], unit if shared else unit[None], **opts)
        assert_same_bits(alone, 0, out.T_cam_from_gaze[k], out.quality[k])
        one = solve_rasc(T_cw[k], unit, **opts)
        assert_same_bits(out, k, one.T_cam_from_gaze, one.quality)


@pytest.mark.parametrize("variant", ["exponential", "literal"])
def test_chunked_batch_has_the_single_solves_bits_across_blocks(variant):
    """S = 800 exceeds two blocks of ``_CHUNK_FLOATS`` (359 nine-view samples): samples at
    and around the block boundaries, per-set unit poses, rigid input checked (the
    validation's RᵀR is not handed over for batches this size: each block measures
    its own), and the full results with diagnostics of solve_rasc_each."""
    S = 800
    chunk = _kernels._CHUNK_FLOATS // (9 * 81)
    assert 2 * chunk < S
    T_cw, T_gp = pose_sets(11, S, "pan-tilt", variant, 0.01)
    T_gp_each = np.repeat(T_gp[None], S, 0)
    opts = {"check_rigid": variant == "exponential"}
    out = solve_rasc_batch(T_cw, T_gp_each, **opts)
    shared = solve_rasc_batch(T_cw, T_gp, **opts)
    each = solve_rasc_each(T_cw[chunk - 2:chunk + 3], T_gp, **opts)
    for k in (0, 1, chunk - 1, chunk, chunk + 1, 2 * chunk, S - 1):
        one = solve_rasc(T_cw[k], T_gp, **opts)
        assert_same_bits(out, k, one.T_cam_from_gaze, one.quality)
        assert_same_bits(shared, k, one.T_cam_from_gaze, one.quality)
    for pos, k in enumerate(range(chunk - 2, chunk + 3)):
        one = solve_rasc(T_cw[k], T_gp, **opts)
        np.testing.assert_array_equal(each[pos].T_cam_from_gaze, one.T_cam_from_gaze)
        assert each[pos].quality == one.quality
        assert each[pos].diagnostics == one.diagnostics


def test_a_degenerate_member_fails_the_whole_batch_naming_it():
    """The batch API's documented behaviour: one degenerate sample (pan-only motion, so
    its axis check fails) makes the call raise, naming the sample, with the message of
    its own solve; the other samples are unaffected when solved without it."""
    S = 12
    T_cw, T_gp = pose_sets(5, S, "pan-tilt", "exponential", 0.01)
    T_gp_each = np.repeat(T_gp[None], S, 0)
    pan_only = pan_tilt([(a, 0.0) for a in np.linspace(-8, 8, 9)])
    T_gp_each[7] = pan_only
    with pytest.raises(DegenerateDataError, match=r"\(sample 7\)") as exc:
        solve_rasc_batch(T_cw, T_gp_each)
    with pytest.raises(DegenerateDataError) as one:
        solve_rasc(T_cw[7], pan_only)
    assert str(exc.value).replace(" (sample 7)", "") == str(one.value)
    keep = np.arange(S) != 7
    rest = solve_rasc_batch(T_cw[keep], T_gp_each[keep])
    for pos, k in enumerate(np.flatnonzero(keep)):
        single = solve_rasc(T_cw[k], T_gp)
        assert_same_bits(rest, pos, single.T_cam_from_gaze, single.quality)
    T_cw[3, 2, 0, 0] = np.nan                                   # invalid input: InputError
    with pytest.raises(InputError, match=r"T_cam_from_world\[3, 2\]"):
        solve_rasc_batch(T_cw, T_gp)
