"""Timestamped pose streams with a known truth: a pan-tilt unit that never stops.

:func:`make_pose_streams` samples one smooth motion of a pan-tilt unit (eq. 3) twice, as
a real head records it: the unit's poses ``T_gaze_from_ptu`` at ``unit_rate`` (encoders,
100–1000 Hz) on the unit's clock, and the target's poses in the camera
``T_cam_from_world = X · T_gaze_from_ptu · Y`` at ``camera_rate`` (10–60 Hz) on the
camera's clock, with eq. 13–14 noise on the camera poses
(:func:`rasc.handeye.noise.perturb_T_cam_from_world`, exponential variant), the two
clocks ``time_offset`` apart and each stamp off its sample's true instant by Gaussian
``jitter``. ``X`` and ``Y`` are :data:`rasc.handeye.corruption.TRUE_T_CAM_FROM_GAZE` and
``TRUE_T_PTU_FROM_WORLD``.

The time offset's sign (the one :mod:`rasc.handeye.time_offset` estimates): **the unit's
clock reads the camera's plus δ**; the camera pose stamped t was taken when the unit's
clock read t + δ.

Motions (``motion``):

- ``"sines"``: pan and tilt each a sum of three sines of random frequency (0.1–0.6 Hz),
  phase and weight, scaled to ``amplitude_deg``: smooth, with a rotation speed that keeps
  changing (what the offset estimate needs);
- ``"circle"``: the gaze going round a cone (pan = A cos ωt, tilt = A sin ωt): a rotation
  speed that hardly changes, whose magnitude cannot time the streams;
- ``"periodic"``: a Lissajous figure (pan at 0.5 Hz, tilt at 1 Hz): a speed that changes
  but repeats every 2 s, so offsets 2 s apart look alike;
- ``"still"``: the unit at rest.

Every draw comes from ``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rasc import formats
from rasc.errors import InputError
from rasc.geometry.kinematics import T_gaze_from_ptu
from rasc.handeye.corruption import TRUE_T_CAM_FROM_GAZE, TRUE_T_PTU_FROM_WORLD
from rasc.handeye.noise import perturb_T_cam_from_world

MOTIONS = ("sines", "circle", "periodic", "still")


@dataclass(frozen=True)
class PoseStreams:
    """Two timestamped pose streams and their truth (module docstring).

    times : (n,) the camera poses' stamps, camera clock, seconds.
    T_cam_from_world : (n, 4, 4) the target's pose in the camera (noisy).
    unit_times : (m,) the unit poses' stamps, unit clock, seconds.
    T_gaze_from_ptu : (m, 4, 4) the unit's pose at each unit stamp (exact).
    pan_tilt_deg : (m, 2) the pan and tilt behind them (eq. 3), degrees.
    time_offset : δ, the unit's clock minus the camera's, seconds.
    T_cam_from_gaze, T_ptu_from_world : the truth (X and Y).
    """

    times: np.ndarray
    T_cam_from_world: np.ndarray
    unit_times: np.ndarray
    T_gaze_from_ptu: np.ndarray
    pan_tilt_deg: np.ndarray
    time_offset: float
    T_cam_from_gaze: np.ndarray
    T_ptu_from_world: np.ndarray

    def to_document(self, *, angles: bool = True) -> dict:
        """The streams as a ``rasc-handeye/1`` document (:mod:`rasc.handeye.document`):
        ``positions`` with ``time`` and ``T_cam_from_world``, and ``unit_stream`` with
        ``time`` and ``pan``/``tilt`` in degrees (``angles``) or ``T_gaze_from_ptu``."""
        unit = ([{"time": float(t), "pan": float(p), "tilt": float(q)}
                 for t, (p, q) in zip(self.unit_times, self.pan_tilt_deg, strict=True)]
                if angles else
                [{"time": float(t), "T_gaze_from_ptu": G.tolist()}
                 for t, G in zip(self.unit_times, self.T_gaze_from_ptu, strict=True)])
        return {"format": formats.HANDEYE.tag, "angle_unit": "deg", "length_unit": "m",
                "positions": [{"time": float(t), "T_cam_from_world": T.tolist()}
                              for t, T in zip(self.times, self.T_cam_from_world,
                                              strict=True)],
                "unit_stream": unit}


def _angles(motion: str, t: np.ndarray, amplitude: tuple[float, float],
            rng: np.random.Generator) -> np.ndarray:
    """(len(t), 2) pan and tilt in degrees at real times t."""
    if motion == "still":
        return np.tile(rng.uniform(-1.0, 1.0, 2) * amplitude, (len(t), 1))
    if motion == "circle":
        w = 2 * math.pi * 0.25
        return np.column_stack([amplitude[0] * np.cos(w * t), amplitude[1] * np.sin(w * t)])
    if motion == "periodic":
        w = 2 * math.pi * 0.5
        return np.column_stack([amplitude[0] * np.sin(w * t),
                                amplitude[1] * np.sin(2 * w * t + 0.7)])
    out = np.empty((len(t), 2))
    for j in range(2):
        f = rng.uniform(0.1, 0.6, 3)
        phase = rng.uniform(0.0, 2 * math.pi, 3)
        weight = rng.uniform(0.5, 1.0, 3)
        s = (weight * np.sin(2 * math.pi * f * t[:, None] + phase)).sum(axis=1)
        out[:, j] = amplitude[j] * s / weight.sum()
    return out


def make_pose_streams(seed: int = 0, *, duration: float = 20.0, unit_rate: float = 200.0,
                      camera_rate: float = 30.0, time_offset: float = 0.02,
                      jitter: float = 2e-4, sigma_r: float = 0.002, sigma_t: float = 0.001,
                      amplitude_deg: tuple[float, float] = (20.0, 12.0),
                      motion: str = "sines", camera_span: tuple[float, float] | None = None,
                      start: float = 0.0) -> PoseStreams:
    """Two pose streams of one smooth pan-tilt motion (module docstring).

    Parameters
    ----------
    seed : the generator's seed (motion, jitter, noise).
    duration : seconds of unit stream (real time 0 to ``duration``).
    unit_rate, camera_rate : samples per second of each stream.
    time_offset : δ in seconds (the unit's clock minus the camera's).
    jitter : standard deviation of each stamp's error, seconds (clipped at 0.4 of the
        stream's sampling interval, so that the stamps keep their order).
    sigma_r, sigma_t : eq. 13–14 noise of the camera poses (radians, metres).
    amplitude_deg : the pan and tilt amplitudes.
    motion : "sines", "circle", "periodic" or "still" (module docstring).
    camera_span : real-time interval the camera records (default: the unit's span less
        half a second at each end, so offsets of up to ±0.5 s keep every camera pose
        inside the unit stream).
    start : the camera clock's reading at real time 0 (a clock need not start at 0).
    """
    if motion not in MOTIONS:
        raise InputError(f"motion: expected one of {MOTIONS}, got {motion!r}")
    rng = np.random.default_rng(seed)
    lo, hi = camera_span if camera_span is not None else (0.5, duration - 0.5)
    tu = np.arange(0.0, duration + 1e-12, 1.0 / unit_rate)
    tc = np.arange(lo, hi + 1e-12, 1.0 / camera_rate)
    both = np.concatenate([tu, tc])
    angles = _angles(motion, both, amplitude_deg, rng)
    G_all = T_gaze_from_ptu(np.radians(angles[:, 0]), np.radians(angles[:, 1]))
    G_unit, G_cam = G_all[:len(tu)], G_all[len(tu):]
    T_cw = TRUE_T_CAM_FROM_GAZE @ G_cam @ TRUE_T_PTU_FROM_WORLD
    T_cw = perturb_T_cam_from_world(T_cw, sigma_r, sigma_t, rng, "exponential")
    # a stamp's error is clipped to 0.4 of the sampling interval: it never reorders a stream
    unit_stamps = start + tu + time_offset + np.clip(
        rng.normal(0.0, jitter, len(tu)), -0.4 / unit_rate, 0.4 / unit_rate)
    cam_stamps = start + tc + np.clip(rng.normal(0.0, jitter, len(tc)),
                                      -0.4 / camera_rate, 0.4 / camera_rate)
    return PoseStreams(times=cam_stamps, T_cam_from_world=T_cw, unit_times=unit_stamps,
                       T_gaze_from_ptu=G_unit, pan_tilt_deg=angles[:len(tu)],
                       time_offset=float(time_offset), T_cam_from_gaze=TRUE_T_CAM_FROM_GAZE,
                       T_ptu_from_world=TRUE_T_PTU_FROM_WORLD)
