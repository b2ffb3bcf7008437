"""The paper's noise model, eq. 13–14 (rasc.handeye.noise, docs/METHOD.md §8)."""

import numpy as np
import pytest

from rasc.errors import InputError
from rasc.geometry.transforms import make_transform, matrix_from_rotvec, rotvec_from_matrix, skew
from rasc.handeye.noise import PAPER_LEVELS_RAD_MM, perturb_one_view, perturb_T_cam_from_world

N = 40_000
# Sample standard deviations of N normal draws have relative standard error
# 1/sqrt(2N) = 0.35 %; 2 % is ~6 standard errors: fails only if the model is wrong.
STD_RTOL = 0.02


def _poses(rng, shape):
    R = matrix_from_rotvec(rng.normal(size=shape + (3,)))
    return make_transform(R, rng.normal(size=shape + (3,)))


@pytest.mark.parametrize("variant", ["literal", "exponential"])
def test_statistics(variant):
    rng = np.random.default_rng(0)
    T = _poses(rng, (N // 8, 8))
    sigma_r, sigma_t = 0.03, 0.006
    out = perturb_T_cam_from_world(T, sigma_r, sigma_t, rng, variant=variant)
    D = np.swapaxes(T[..., :3, :3], -1, -2) @ out[..., :3, :3]     # I + [ω]× or exp([ω]×)
    if variant == "literal":
        np.testing.assert_allclose(D + np.swapaxes(D, -1, -2), 2 * np.eye(3) + 0 * D,
                                   atol=1e-12)                    # I + skew, exactly
        omega = np.stack([D[..., 2, 1], D[..., 0, 2], D[..., 1, 0]], axis=-1)
    else:
        omega = rotvec_from_matrix(D)
    dt = out[..., :3, 3] - T[..., :3, 3]
    for x, sigma in ((omega, sigma_r), (dt, sigma_t)):
        x = x.reshape(-1, 3)
        np.testing.assert_allclose(x.std(axis=0), sigma, rtol=STD_RTOL)
        # mean: standard error sigma/sqrt(N); 5 of them
        assert np.all(np.abs(x.mean(axis=0)) < 5 * sigma / np.sqrt(len(x)))
        # independent components: correlations within 5/sqrt(N)
        c = np.corrcoef(x.T)[np.triu_indices(3, 1)]
        assert np.all(np.abs(c) < 5 / np.sqrt(len(x)))
    np.testing.assert_array_equal(out[..., 3, :], T[..., 3, :])


def test_literal_is_not_a_rotation_exponential_is():
    rng = np.random.default_rng(1)
    T = _poses(rng, (200,))
    lit = perturb_T_cam_from_world(T, 0.04, 0.008, np.random.default_rng(5), "literal")
    exp = perturb_T_cam_from_world(T, 0.04, 0.008, np.random.default_rng(5), "exponential")
    orth = lambda A: np.abs(np.swapaxes(A, -1, -2) @ A - np.eye(3)).max(axis=(-1, -2))  # noqa: E731
    assert orth(exp[:, :3, :3]).max() < 1e-14
    # literal: RᵀR − I = [ω]×ᵀ[ω]× = |ω|² I − ωωᵀ, of order σ_r² = 1.6e-3
    assert np.median(orth(lit[:, :3, :3])) > 1e-4
    # same draws: identical translations, rotations differing at second order:
    # (I + Ω) − exp(Ω) = −Ω²/2 − Ω³/6 − …, and ‖Ω²‖_F = √2 |ω|²
    np.testing.assert_array_equal(lit[:, :3, 3], exp[:, :3, 3])
    omega = rotvec_from_matrix(np.swapaxes(T[:, :3, :3], 1, 2) @ exp[:, :3, :3])
    w = np.linalg.norm(omega, axis=1)
    diff = np.linalg.norm(lit[:, :3, :3] - exp[:, :3, :3], axis=(1, 2))
    ratio = diff / (w**2 / np.sqrt(2))
    # the next terms change the ratio by ≈ |ω|²/36 (measured max 0.0278 |ω|², the odd
    # terms being orthogonal to Ω²); bound |ω|²/18
    assert np.all(np.abs(ratio - 1) < w**2 / 18)


def test_literal_is_eq13_as_printed():
    rng = np.random.default_rng(2)
    T = _poses(rng, (3,))
    out = perturb_T_cam_from_world(T, 0.01, 0.002, np.random.default_rng(9))
    g = np.random.default_rng(9)
    w1, w2, w3 = g.normal(0, 0.01, (3, 3)).T                        # ω drawn first
    M = np.array([[np.ones(3), -w3, w2], [w3, np.ones(3), -w1], [-w2, w1, np.ones(3)]])
    M = np.moveaxis(M, -1, 0)                                       # the printed matrix
    np.testing.assert_allclose(out[:, :3, :3], T[:, :3, :3] @ M, atol=1e-15)
    np.testing.assert_allclose(out[:, :3, 3], T[:, :3, 3] + g.normal(0, 0.002, (3, 3)),
                               atol=1e-15)


def test_zero_noise_and_determinism_and_no_mutation():
    rng = np.random.default_rng(3)
    T = _poses(rng, (4, 9))
    before = T.copy()
    np.testing.assert_array_equal(perturb_T_cam_from_world(T, 0.0, 0.0, rng), T)
    a = perturb_T_cam_from_world(T, 0.02, 0.004, np.random.default_rng(42))
    b = perturb_T_cam_from_world(T, 0.02, 0.004, np.random.default_rng(42))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(T, before)
    assert a.shape == T.shape


def test_one_view_only():
    rng = np.random.default_rng(4)
    T = _poses(rng, (5, 9))                                         # 5 sets of 9 views
    out = perturb_one_view(T, 0, 0.03, 0.006, rng)
    changed = np.any(out != T, axis=(-1, -2))
    assert changed[:, 0].all() and not changed[:, 1:].any()
    # independent per set
    assert not np.allclose(out[0, 0] - T[0, 0], out[1, 0] - T[1, 0])
    out = perturb_one_view(T[0], -1, 0.03, 0.006, rng)
    assert np.any(out[8] != T[0, 8]) and np.all(out[:8] == T[0, :8])


def test_paper_levels():
    assert len(PAPER_LEVELS_RAD_MM) == 8
    assert PAPER_LEVELS_RAD_MM[5] == (0.030, 6.0)                   # E2's level
    np.testing.assert_allclose(np.diff(np.array(PAPER_LEVELS_RAD_MM), axis=0),
                               [[0.005, 1.0]] * 7)


def test_skew():
    v, x = np.random.default_rng(6).normal(size=(2, 3))
    np.testing.assert_allclose(skew(v) @ x, np.cross(v, x), atol=1e-15)


@pytest.mark.parametrize("call, fragment", [
    (lambda T, g: perturb_T_cam_from_world(T, -0.1, 0.0, g), "sigma_r"),
    (lambda T, g: perturb_T_cam_from_world(T, 0.1, np.nan, g), "sigma_t"),
    (lambda T, g: perturb_T_cam_from_world(T, "0.1", 0.0, g),
     '^sigma_r: expected a number, got "0.1"$'),
    (lambda T, g: perturb_T_cam_from_world(T, 0.1, 0.1, 0), "rng"),
    (lambda T, g: perturb_T_cam_from_world(T, 0.1, 0.1, g, "projected"), "variant"),
    (lambda T, g: perturb_T_cam_from_world(T[..., :3], 0.1, 0.1, g), "shape"),
    (lambda T, g: perturb_one_view(T, 9, 0.1, 0.1, g), "index"),
    (lambda T, g: perturb_one_view(T[0], 0, 0.1, 0.1, g), r"\(\.\.\., n, 4, 4\)"),
])
def test_bad_input(call, fragment):
    T = _poses(np.random.default_rng(7), (9,))
    with pytest.raises(InputError, match=fragment):
        call(T, np.random.default_rng(0))
