"""Bad positions on purpose: the corruptions ``rasc-robust`` is proven against.

Four kinds, each what a real capture produces (issue 22):

``rotation``      gross rotation: the target pose turned by ``ROTATION_DEG`` (a board
                  misdetected, e.g. its corners ordered from another corner),
                  ``R' = R exp(ω)``, ω of that angle about a random axis;
``translation``   gross translation: the target moved by ``TRANSLATION_RELATIVE`` of
                  its distance in a random direction (a wrong scale or depth);
``swap``          two positions' target poses exchanged (each logged beside the other's
                  motion); counts as two bad positions;
``angle``         a wrong angle reading: the unit's motion at that position turned by
                  ``ANGLE_DEG`` about its pan or tilt axis (an encoder read at the wrong
                  moment), i.e. ``T_gaze_from_ptu`` recomputed from pan + δ or tilt + δ
                  for a pan-tilt unit, or turned about a random axis of the unit's frame
                  for any other unit.

Every draw comes from the generator passed in (``np.random.default_rng(seed)``).
"""

from __future__ import annotations

import numpy as np

from rasc.errors import InputError
from rasc.geometry.kinematics import T_gaze_from_ptu as _T_gaze_from_ptu
from rasc.geometry.transforms import make_transform, matrix_from_rotvec

KINDS = ("rotation", "translation", "swap", "angle")

#: Gross-error magnitudes, drawn uniformly in these ranges (degrees, fraction of the
#: target distance): well above any calibration noise (≈0.1°, ≈1 mm at 1 m) and within
#: what the failures named in the module docstring produce.
ROTATION_DEG = (10.0, 45.0)
TRANSLATION_RELATIVE = (0.1, 0.5)
ANGLE_DEG = (3.0, 20.0)


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def corrupt(T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray, n_bad: int,
            rng: np.random.Generator, *, kinds: tuple[str, ...] = KINDS,
            pan_tilt_rad: np.ndarray | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """Corrupt ``n_bad`` distinct positions, cycling through ``kinds``.

    Parameters
    ----------
    T_cam_from_world, T_gaze_from_ptu : (n, 4, 4), not modified.
    n_bad : positions to corrupt (a swap corrupts two; an odd remainder falls to the
        next kind).
    rng : numpy Generator.
    kinds : the kinds to use, in turn (:data:`KINDS`).
    pan_tilt_rad : (n, 2) the angles behind a pan-tilt unit's motions (eq. 3); with it a
        wrong angle reading is a wrong pan or tilt.

    Returns
    -------
    T_cam_from_world, T_gaze_from_ptu : the corrupted copies;
    bad : (n,) bool, the corrupted positions;
    kind : (n,) list, the kind per position ("" when clean).
    """
    T_cw = np.array(T_cam_from_world, dtype=float)
    T_gp = np.array(T_gaze_from_ptu, dtype=float)
    n = len(T_cw)
    if not 0 <= n_bad <= n:
        raise InputError(f"n_bad: expected 0..{n}, got {n_bad}")
    for k in kinds:
        if k not in KINDS:
            raise InputError(f"kinds: {k!r} is not one of {KINDS}")
    order = rng.permutation(n)
    bad = np.zeros(n, bool)
    kind = [""] * n
    used, c = 0, 0
    distance = np.linalg.norm(T_cw[:, :3, 3], axis=1)
    while used < n_bad:
        k = kinds[c % len(kinds)]
        c += 1
        if k == "swap":
            if n_bad - used < 2:
                if len(kinds) == 1:
                    k = "rotation"
                else:
                    continue
            else:
                i, j = order[used], order[used + 1]
                T_cw[[i, j]] = T_cw[[j, i]]
                for p in (i, j):
                    bad[p], kind[p] = True, "swap"
                used += 2
                continue
        i = order[used]
        if k == "rotation":
            angle = np.radians(rng.uniform(*ROTATION_DEG))
            T_cw[i, :3, :3] = T_cw[i, :3, :3] @ matrix_from_rotvec(angle * _unit(rng))
        elif k == "translation":
            T_cw[i, :3, 3] += rng.uniform(*TRANSLATION_RELATIVE) * distance[i] * _unit(rng)
        elif k == "angle":
            delta = np.radians(rng.uniform(*ANGLE_DEG)) * rng.choice([-1.0, 1.0])
            if pan_tilt_rad is not None:
                pt = np.array(pan_tilt_rad[i], dtype=float)
                pt[int(rng.integers(2))] += delta
                T_gp[i] = _T_gaze_from_ptu(pt[0], pt[1])
            else:
                T_gp[i, :3, :3] = matrix_from_rotvec(delta * _unit(rng)) @ T_gp[i, :3, :3]
        bad[i], kind[i] = True, k
        used += 1
    return T_cw, T_gp, bad, kind


# ------------------------------------------------------------- synthetic truth

#: The true hand-eye and target of :func:`pan_tilt_poses` / :func:`arm_poses`: a camera
#: looking along gaze +y (as the simulated head's, ``rasc.sim.synthetic``) turned ~20°
#: off nominal and 3-6 cm off the unit's centre; the target 1 m ahead.
TRUE_T_CAM_FROM_GAZE = make_transform(
    matrix_from_rotvec([0.3, -0.2, 0.1]) @ np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0],
                                                     [0.0, 1.0, 0.0]]),
    [0.03, -0.05, 0.02])
TRUE_T_PTU_FROM_WORLD = make_transform(matrix_from_rotvec([0.1, 0.2, -0.1]),
                                       [-0.1, 1.0, 0.05])


def pan_tilt_poses(n: int, rng: np.random.Generator, *, amplitude_deg: float = 15.0
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n noise-free positions of a pan-tilt unit (eq. 3), pan and tilt uniform in
    ±amplitude_deg: ``(T_cam_from_world, T_gaze_from_ptu, pan_tilt_rad)`` with
    :data:`TRUE_T_CAM_FROM_GAZE` and :data:`TRUE_T_PTU_FROM_WORLD`."""
    pt = np.radians(rng.uniform(-amplitude_deg, amplitude_deg, (n, 2)))
    G = _T_gaze_from_ptu(pt[:, 0], pt[:, 1])
    return TRUE_T_CAM_FROM_GAZE @ G @ TRUE_T_PTU_FROM_WORLD, G, pt


def arm_poses(n: int, rng: np.random.Generator, *, cone_deg: float = 90.0,
              angle_deg: float = 30.0, reach: float = 0.2
              ) -> tuple[np.ndarray, np.ndarray]:
    """n noise-free positions of a robot arm (a unit that also translates): rotations of
    up to ±angle_deg about axes within ``cone_deg`` of the unit's z axis (a small cone is
    near-degenerate), translations N(0, reach²) per axis:
    ``(T_cam_from_world, T_gripper_from_base)``."""
    tilt = np.radians(cone_deg) * np.sqrt(rng.uniform(0.0, 1.0, n))
    azimuth = rng.uniform(0.0, 2 * np.pi, n)
    axis = np.column_stack([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth),
                            np.cos(tilt)])
    angle = np.radians(rng.uniform(-angle_deg, angle_deg, n))
    G = make_transform(matrix_from_rotvec(axis * angle[:, None]), rng.normal(0, reach, (n, 3)))
    return TRUE_T_CAM_FROM_GAZE @ G @ TRUE_T_PTU_FROM_WORLD, G
