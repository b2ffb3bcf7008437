"""Continuous motion in the bench: a head that never stops (docs/topics/continuous.md).

The pieces a continuous capture is made of, each plain numpy (no MuJoCo here):

* :class:`Trajectory`: the plan's pan-tilt positions joined by minimum-jerk motions
  (zero rate and acceleration at each position) whose peak joint speed is the given
  angular speed, with an optional dwell at each position (default 0: it never stops).
* the cameras' clock: :func:`frame_times` (mid-exposure stamps of the frames a camera
  running at ``frame_rate`` takes over the motion), :func:`kept_frames` (every k-th, at
  most ``max_frames``), :func:`exposure_plan` and :func:`expose` (an exposure as the mean
  of sub-frames along the motion: motion blur; with a rolling shutter each row exposed
  at its own time);
* the encoders' clock: :func:`sample_joint_stream`, the readings at ``joint_rate`` with
  their stamps on the encoder clock, offset by δ and jittered.

**Clock convention** (shared with the calibration): the trajectory's time is the camera
clock; **encoder clock = camera clock + δ** (``clock_offset``), so the true readings at
an image stamped ``t_cam`` are the joint stream at ``t_cam + δ``
(:mod:`rasc.vision.joint_stream`). An image's stamp is the mid-exposure time of its
middle row (with a global shutter, of every row).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rasc.errors import InputError
from rasc.geometry.frames import EYES

#: the peak of the minimum-jerk profile's rate, ds/dx at x = 1/2 of
#: s(x) = 10x³ − 15x⁴ + 6x⁵: a motion of D radians in T seconds peaks at 1.875·D/T
MIN_JERK_PEAK = 1.875
#: the continuous capture's defaults (RenderOptions' fields of the same names)
DEFAULT_FRAME_RATE = 30.0        # Hz
DEFAULT_EXPOSURE = 0.010         # s
DEFAULT_JOINT_RATE = 200.0       # Hz
DEFAULT_SUBFRAMES = 8
DEFAULT_MAX_FRAMES = 40          # per eye
#: the joint stream covers the motion and this long before and after it (plus |δ|):
#: the head waits at its first and last position
STREAM_MARGIN_S = 0.25
#: the jitter of a joint stamp is a Gaussian truncated at this fraction of the stream's
#: period, so the stamps stay in order
JITTER_TRUNCATION = 0.45


def _min_jerk(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """s(x) and ds/dx of the minimum-jerk profile on [0, 1]."""
    x2 = x * x
    return x2 * x * (10 - 15 * x + 6 * x2), 30 * x2 * (1 - 2 * x + x2)


@dataclass(frozen=True, eq=False)
class Trajectory:
    """The head's motion: planned positions joined by minimum-jerk motions.

    Parameters
    ----------
    positions : array-like, shape (n, 2) or (n, 2, 2)
        The plan's (pan, tilt) readings in radians, the same for both eyes, or per eye
        (``positions[k, e]`` for eye ``EYES[e]``).
    speed_deg_s : float
        The peak joint speed of each motion, deg/s: the norm of (pan rate, tilt rate) of
        the eye that moves farther, reached half-way; every eye moves in step.
    dwell : float
        Seconds held at each position (default 0: the head passes through each position
        at rest for an instant and never stops).
    """

    positions: np.ndarray
    speed_deg_s: float
    dwell: float = 0.0
    #: arrival time at each position (n,) and the length of the motion into it (n,)
    arrivals: np.ndarray = field(init=False, repr=False, compare=False)
    motions: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        p = np.asarray(self.positions, dtype=float)
        if p.ndim == 2:
            p = np.repeat(p[:, None, :], len(EYES), axis=1)
        if p.ndim != 3 or p.shape[1:] != (len(EYES), 2) or len(p) < 1:
            raise InputError(f"positions: expected shape (n, 2) or (n, 2, 2), got "
                             f"{np.shape(self.positions)}")
        if not np.all(np.isfinite(p)):
            raise InputError("positions: must be finite numbers (radians)")
        if not (math.isfinite(self.speed_deg_s) and self.speed_deg_s > 0):
            raise InputError(f"speed_deg_s must be a positive number, got {self.speed_deg_s!r}")
        if not (math.isfinite(self.dwell) and self.dwell >= 0):
            raise InputError(f"dwell must be a number of seconds >= 0, got {self.dwell!r}")
        speed = math.radians(self.speed_deg_s)
        step = np.linalg.norm(np.diff(p, axis=0), axis=2).max(axis=1) if len(p) > 1 \
            else np.zeros(0)
        motions = np.concatenate([[0.0], MIN_JERK_PEAK * step / speed])
        arrivals = np.cumsum(motions + np.r_[0.0, np.full(len(p) - 1, self.dwell)])
        object.__setattr__(self, "positions", p)
        object.__setattr__(self, "motions", motions)
        object.__setattr__(self, "arrivals", arrivals)

    @property
    def duration(self) -> float:
        """Seconds from the start (at the first position) to the end of the last dwell."""
        return float(self.arrivals[-1] + self.dwell)

    def _locate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For times ``t``: the position moved into (index k ≥ 1), the phase x in [0, 1]
        of that motion (1 once arrived) and the motion's length."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        k = np.clip(np.searchsorted(self.arrivals, t, side="left"), 1,
                    max(len(self.arrivals) - 1, 1))
        if len(self.arrivals) == 1:
            return k, np.ones_like(t), np.zeros_like(t)
        T = self.motions[k]
        start = self.arrivals[k] - T
        with np.errstate(invalid="ignore", divide="ignore"):
            x = np.where(T > 0, np.clip((t - start) / np.where(T > 0, T, 1.0), 0.0, 1.0), 1.0)
        return k, x, T

    def angles(self, t, eye: str | None = None) -> np.ndarray:
        """(pan, tilt) readings, radians, at times ``t`` (seconds, any shape; clamped to
        [0, duration]: the head waits at its first and last position): shape
        ``t.shape + (2, 2)`` (eye in ``EYES`` order, then pan, tilt), or ``t.shape + (2,)``
        for one ``eye``."""
        k, x, _ = self._locate(t)
        s, _ = _min_jerk(x)
        if len(self.positions) == 1:
            out = np.broadcast_to(self.positions[0], np.shape(t) + (len(EYES), 2)).copy()
        else:
            a, b = self.positions[k - 1], self.positions[k]
            out = a + (b - a) * s[..., None, None]
        return out if eye is None else out[..., EYES.index(eye), :]

    def velocity(self, t, eye: str | None = None) -> np.ndarray:
        """d(pan, tilt)/dt, rad/s, at times ``t``: shapes as :meth:`angles` (zero outside
        [0, duration] and at each planned position)."""
        t_arr = np.asarray(t, dtype=float)
        k, x, T = self._locate(t_arr)
        _, ds = _min_jerk(x)
        if len(self.positions) == 1:
            out = np.zeros(np.shape(t) + (len(EYES), 2))
        else:
            inside = (t_arr > 0) & (t_arr < self.duration) & (T > 0)
            rate = np.where(inside, ds / np.where(T > 0, T, 1.0), 0.0)
            out = (self.positions[k] - self.positions[k - 1]) * rate[..., None, None]
        return out if eye is None else out[..., EYES.index(eye), :]


# ------------------------------------------------------------------------ the cameras

def frame_times(duration: float, frame_rate: float, exposure: float,
                readout: float = 0.0) -> np.ndarray:
    """The mid-exposure stamps (s, camera clock) of the frames a camera running at
    ``frame_rate`` takes while the head moves: the first frame's exposure (of its first
    row, with a rolling shutter's ``readout`` = (rows − 1) · line time) starts at 0 and
    the last one's (of its last row) ends by ``duration``."""
    half = 0.5 * (exposure + readout)
    n = int(math.floor((duration - 2 * half) * frame_rate + 1e-9)) + 1
    return half + np.arange(max(n, 0)) / frame_rate


def kept_frames(n: int, max_frames: int) -> np.ndarray:
    """The frames kept of ``n`` taken: every k-th from the first, k the smallest integer
    that keeps at most ``max_frames`` (all of them when ``n <= max_frames``)."""
    k = max(1, math.ceil(n / max_frames))
    return np.arange(0, n, k)


def exposure_plan(t_mid: float, exposure: float, subframes: int, line_time: float = 0.0,
                  rows: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """How an exposure is rendered: ``(times, start)``.

    The renders are taken at ``times`` (J,), the middles of a grid of cells of
    h = exposure / subframes; row r's exposure is centred at
    ``t_mid + (r − (rows − 1)/2) · line_time`` (the image's stamp ``t_mid`` is its middle
    row's mid-exposure) and covers cells ``start[r]`` to ``start[r] + subframes`` (in
    cell units, from the first row's exposure start). :func:`expose` weights each render
    by the share of its cell inside the row's exposure, so every row's mean time is its
    own exactly. With a global shutter (line_time 0) every row averages the same
    ``subframes`` renders; a rolling shutter takes ``subframes`` + readout / h (+1)
    renders. The error this makes: each cell is seen at its middle instant (the blur is
    a weighted sum of sharp images, not a continuous smear), and a row whose exposure
    starts inside a cell blends the two renders at its ends, which a continuous exposure
    would have seen part of: a time error of at most h/2 at those ends (none at the
    row's centre).
    """
    S = int(subframes)
    h = exposure / S
    readout = (rows - 1) * line_time
    t0 = t_mid - 0.5 * readout - 0.5 * exposure       # the first row's exposure starts
    start = np.arange(rows) * (line_time / h)
    J = int(math.ceil(start[-1] + S - 1e-9))
    return t0 + (np.arange(J) + 0.5) * h, start


def expose(render_at, times: np.ndarray, start: np.ndarray, subframes: int) -> np.ndarray:
    """The exposure of :func:`exposure_plan`'s ``(times, start)``: ``render_at(t)`` gives
    the sharp image (H, W) at time ``t``; returns the float image (H, W), row r the mean
    of the renders over cells ``start[r]`` … ``start[r] + subframes``, each weighted by
    its cell's share inside that span. Renders one image per time, holding one sum."""
    S = int(subframes)
    acc = None
    for j, t in enumerate(times):
        w = np.clip(np.minimum(j + 1.0, start + S) - np.maximum(float(j), start), 0.0, 1.0)
        rows = np.flatnonzero(w > 1e-12)
        if not len(rows):
            continue
        lo, hi = int(rows[0]), int(rows[-1]) + 1
        image = np.asarray(render_at(float(t)), dtype=float)
        if acc is None:
            acc = np.zeros_like(image)
        if hi - lo == len(w) and np.all(w == 1.0):
            acc += image
        else:
            acc[lo:hi] += w[lo:hi, None] * image[lo:hi]
    return acc / S


# ----------------------------------------------------------------------- the encoders

def sample_joint_stream(trajectory: Trajectory, joint_rate: float, clock_offset: float,
                        clock_jitter: float, rng: np.random.Generator,
                        margin: float = STREAM_MARGIN_S):
    """The readings an encoder stream publishes while the head follows ``trajectory``:
    samples at ``joint_rate`` Hz from ``margin + |δ|`` before the motion to as long after
    it, each stamped on the encoder clock (its true time + ``clock_offset`` δ + a Gaussian
    jitter of σ ``clock_jitter``, truncated at JITTER_TRUNCATION of the period, one stamp
    for both eyes' readings of a sample). Returns a
    :class:`rasc.vision.joint_stream.JointStream`; draws from ``rng`` only when
    ``clock_jitter`` > 0."""
    from rasc.vision.joint_stream import JointStream

    period = 1.0 / joint_rate
    pad = margin + abs(clock_offset)
    n = int(math.ceil((trajectory.duration + 2 * pad) * joint_rate)) + 1
    true_t = -pad + np.arange(n) * period
    stamps = true_t + clock_offset
    if clock_jitter > 0:
        cap = JITTER_TRUNCATION * period
        stamps = stamps + np.clip(rng.normal(0.0, clock_jitter, n), -cap, cap)
    readings = trajectory.angles(true_t)
    return JointStream.from_arrays(
        {eye: (stamps, readings[:, e, 0], readings[:, e, 1]) for e, eye in enumerate(EYES)})
