"""The paper's noise model on target poses, eq. 13–14 (docs/METHOD.md §8).

Every ``T_cam_from_world`` (``T_cw``) is perturbed on the right, i.e. in the target's
(world) frame::

    literal:      R' = R (I + [ω]×)        exactly as printed; not a rotation (eq. 13)
    exponential:  R' = R exp([ω]×)         the same ω, projected onto SO(3)
    both:         t' = t + (t1, t2, t3)                                      (eq. 14)

with ``ω_i ~ N(0, σ_r²)`` and ``t_i ~ N(0, σ_t²)``. The two variants draw the same
numbers in the same order, so for one seed they differ only by ``R([ω]×²/2 + …)``,
second order in σ_r. ``[ω]×`` is the skew matrix ``[[0, −ω3, ω2], [ω3, 0, −ω1],
[−ω2, ω1, 0]]``. Literal matrices are not rigid: pass ``check_rigid=False`` to the
solvers. The generator is always passed in (``np.random.default_rng(seed)``).
"""

from __future__ import annotations

import numpy as np

from rasc.errors import InputError
from rasc.geometry.transforms import matrix_from_rotvec, skew
from rasc.io import finite_number

VARIANTS = ("literal", "exponential")

#: The paper's eight levels (σ_r rad, σ_t mm), docs/METHOD.md §8; 30 samples each.
PAPER_LEVELS_RAD_MM = ((0.005, 1.0), (0.010, 2.0), (0.015, 3.0), (0.020, 4.0),
                       (0.025, 5.0), (0.030, 6.0), (0.035, 7.0), (0.040, 8.0))


def _check(T: np.ndarray, sigma_r: float, sigma_t: float, rng, variant: str) -> np.ndarray:
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        raise InputError("T: not a numeric array of 4x4 transforms") from None
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise InputError(f"T: expected shape (..., 4, 4), got {T.shape}")
    for name, value in (("sigma_r", sigma_r), ("sigma_t", sigma_t)):
        if finite_number(value, name) < 0:
            raise InputError(f"{name}: expected a finite standard deviation >= 0, got {value!r}")
    if not isinstance(rng, np.random.Generator):
        raise InputError("rng: expected a numpy Generator, e.g. np.random.default_rng(seed)")
    if variant not in VARIANTS:
        raise InputError(f"variant: expected one of {VARIANTS}, got {variant!r}")
    return T


def _perturb(T: np.ndarray, omega: np.ndarray, dt: np.ndarray, variant: str) -> np.ndarray:
    # literal: eq. 13 as printed; exponential: the same ω as a rotation
    factor = np.eye(3) + skew(omega) if variant == "literal" else matrix_from_rotvec(omega)
    out = T.copy()
    out[..., :3, :3] = T[..., :3, :3] @ factor
    out[..., :3, 3] = T[..., :3, 3] + dt                               # eq. 14
    return out


def perturb_T_cam_from_world(T: np.ndarray, sigma_r: float, sigma_t: float,
                             rng: np.random.Generator,
                             variant: str = "literal") -> np.ndarray:
    """Eq. 13–14 noise on every transform.

    Parameters
    ----------
    T : array-like, shape (..., 4, 4)
        ``T_cam_from_world`` for any leading shape (e.g. (S, n, 4, 4) for S samples).
    sigma_r : float
        Standard deviation of each ω_i, radians.
    sigma_t : float
        Standard deviation of each translation component, in T's length unit (metres
        in the simulation: the paper's 6 mm is 0.006).
    rng : numpy.random.Generator
        Draws ω (shape (..., 3)) first, then t (shape (..., 3)).
    variant : {"literal", "exponential"}
        See the module docstring.

    Returns
    -------
    numpy.ndarray, shape (..., 4, 4)
        A new array; the input is not modified.
    """
    T = _check(T, sigma_r, sigma_t, rng, variant)
    omega = rng.normal(0.0, sigma_r, T.shape[:-2] + (3,))
    dt = rng.normal(0.0, sigma_t, T.shape[:-2] + (3,))
    return _perturb(T, omega, dt, variant)


def perturb_one_view(T: np.ndarray, index: int, sigma_r: float, sigma_t: float,
                     rng: np.random.Generator, variant: str = "literal") -> np.ndarray:
    """Eq. 13–14 noise on view ``index`` only (experiment E2: the home view).

    Parameters
    ----------
    T : array-like, shape (..., n, 4, 4)
        One pose set, or S sets (S, n, 4, 4); view ``index`` of each set is perturbed
        (independently per set), all other views are returned unchanged.
    index : int
        The view, 0 ≤ index < n (negative indices count from the end).
    sigma_r, sigma_t, rng, variant : as :func:`perturb_T_cam_from_world`.
    """
    T = _check(T, sigma_r, sigma_t, rng, variant)
    if T.ndim < 3:
        raise InputError(f"T: expected shape (..., n, 4, 4), got {T.shape}")
    n = T.shape[-3]
    if not (isinstance(index, int | np.integer) and -n <= index < n):
        raise InputError(f"index: expected a view index in 0..{n - 1}, got {index!r}")
    out = T.copy()
    out[..., index, :, :] = perturb_T_cam_from_world(T[..., index, :, :], sigma_r, sigma_t,
                                                     rng, variant)
    return out
