"""rasc.handeye.methods.solve_many: S pose sets with one method, each set's result (or
exception) exactly what its own ``methods.solve`` gives — the study engine scores its
samples through it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rasc.errors import DegenerateDataError, InputError
from rasc.handeye import methods
from rasc.handeye.methods import solve, solve_many
from rasc.handeye.noise import perturb_T_cam_from_world

from nominal_rig import PAPER, pan_tilt, rig


def noisy_sets(seed: int, S: int, variant: str) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X, Y = rig(rng)
    return perturb_T_cam_from_world(np.broadcast_to(X @ PAPER @ Y, (S, 9, 4, 4)), 0.02,
                                    0.004, rng, variant=variant)


def assert_same(got, want) -> None:
    """The same result to the bit (transform, quality, diagnostics), or the same
    exception class and message."""
    if isinstance(want, Exception):
        assert type(got) is type(want) and str(got) == str(want)
        return
    np.testing.assert_array_equal(got.T_cam_from_gaze, want.T_cam_from_gaze)
    assert got.quality == want.quality
    assert got.method == want.method and got.diagnostics == want.diagnostics


def solve_or_error(*args, **options):
    try:
        return solve(*args, **options)
    except Exception as exc:  # noqa: BLE001 -- compared with what solve_many returns
        return exc


def degenerate_members(T_cw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-set unit poses with set 3 pan-only (its axis check fails), set 8 holding a NaN
    (InputError) and set 11 not rigid (InputError unless check_rigid=False)."""
    S = len(T_cw)
    T_cw = T_cw.copy()
    T_gp = np.repeat(PAPER[None], S, 0)
    T_gp[3] = pan_tilt([(a, 0.0) for a in np.linspace(-8, 8, 9)])
    T_cw[8, 4, 1, 2] = np.nan
    T_cw[11, 0, :3, :3] *= 1.01
    return T_cw, T_gp


@pytest.mark.parametrize("variant", ["exponential", "literal"])
@pytest.mark.parametrize("method", ["rasc", "li", "rasc-inverse"])
def test_each_set_is_its_own_solve(method, variant):
    T_cw = noisy_sets(1, 17, variant)
    options = {} if variant == "exponential" else {"check_rigid": False}
    got = solve_many(method, T_cw, PAPER, **options)
    assert len(got) == len(T_cw)
    for s in range(len(T_cw)):
        assert_same(got[s], solve_or_error(method, T_cw[s], PAPER, **options))


@pytest.mark.parametrize("check_rigid", [True, False])
def test_degenerate_and_invalid_sets_fail_alone(check_rigid):
    """A pan-only set, a NaN and a non-rigid matrix among 16 sets: each gets the exception
    of its own solve (class and message, no "(sample k)"), every other set its result."""
    T_cw, T_gp = degenerate_members(noisy_sets(2, 16, "exponential"))
    got = solve_many("rasc", T_cw, T_gp, check_rigid=check_rigid, pairs="half")
    kinds = {3: DegenerateDataError, 8: InputError, 11: InputError if check_rigid else None}
    for s in range(16):
        want = solve_or_error("rasc", T_cw[s], T_gp[s], check_rigid=check_rigid, pairs="half")
        assert_same(got[s], want)
        assert type(got[s]) is (kinds.get(s) or methods.HandEyeResult)


def test_plugins_and_unknown_options_go_set_by_set():
    """A plugin (wrapped: validation, eq. 10 and diagnostics by the library) and an
    option the batch does not take are solved set by set, with the same outcome."""
    T_cw = noisy_sets(3, 5, "exponential")

    def plugin(T_cam_from_world, T_gaze_from_ptu, scale=1.0):
        return methods.solve_rasc(T_cam_from_world, T_gaze_from_ptu).T_cam_from_gaze

    got = solve_many(plugin, T_cw, PAPER, scale=2.0)
    for s in range(5):
        assert_same(got[s], solve_or_error(plugin, T_cw[s], PAPER, scale=2.0))
    bad = solve_many("rasc", T_cw, PAPER, home=0)        # solve_rasc takes no home
    assert all(isinstance(e, TypeError) for e in bad)
    with pytest.raises(InputError, match="unknown"):
        solve_many("no-such-method", T_cw, PAPER)


@settings(max_examples=20, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), S=st.integers(1, 30),
       bad=st.lists(st.tuples(st.integers(0, 29), st.sampled_from(["pan-only", "nan",
                                                                     "not rigid", "few"])),
                    max_size=4),
       variant=st.sampled_from(["exponential", "literal"]))
def test_any_batch_with_degenerate_members_gives_each_set_its_own_outcome(seed, S, bad,
                                                                          variant):
    """Random batch sizes and noisy pose sets, with degenerate or invalid members at
    random places (pan-only motion, a NaN, a non-rigid matrix, motions too small to use):
    every set's outcome is its own solve's, to the bit or to the message."""
    T_cw = noisy_sets(seed, S, variant)
    T_gp = np.repeat(PAPER[None], S, 0)
    for k, kind in bad:
        k %= S
        if kind == "pan-only":
            T_gp[k] = pan_tilt([(a, 0.0) for a in np.linspace(-8, 8, 9)])
        elif kind == "nan":
            T_cw[k, k % 9, 0, 3] = np.nan
        elif kind == "not rigid":
            T_cw[k, 0, :3, :3] *= 1.01
        else:                                   # all motions below MIN_PAIR_ROTATION_RAD
            T_gp[k] = pan_tilt([(1e-3 * a, 1e-3 * (a % 2)) for a in range(9)])
    options = {"check_rigid": variant == "exponential"}
    got = solve_many("rasc", T_cw, T_gp, **options)
    for s in range(S):
        assert_same(got[s], solve_or_error("rasc", T_cw[s], T_gp[s], **options))
