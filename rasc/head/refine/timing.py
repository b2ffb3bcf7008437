"""The joint stream of a head that keeps moving, and the camera-to-encoder time offset δ.

docs/topics/recordings.md, "Calibrating a continuous capture". Clock convention (shared
with :mod:`rasc.sim.motion` and the dataset format): encoder clock = camera clock + δ; the
true angles of an image stamped ``t`` (camera clock, mid-exposure) are the joint stream
interpolated at ``t + δ``. The refinement (:mod:`rasc.head.refine`) estimates δ as one
more global parameter, its derivative the stream's angular velocity at ``t + δ`` times
the pixels' derivatives with respect to the angles.

**Interpolation: a cubic spline** (:class:`scipy.interpolate.CubicSpline`, not-a-knot) per
angle, not linear. δ's derivative is the interpolant's velocity: a linear interpolant's
is piecewise constant, with a jump at every sample, so the cost has a kink wherever an
image time crosses a sample, and its position error, h²/8 · |acceleration|, is 1.2e-4 rad
(0.14 px at f = 1150 px) for a 100 Hz stream accelerating at 10 rad/s²; the spline's is
O(h⁴) (below 1e-7 rad there) and its velocity continuous. At 100–1000 Hz the samples are
1–10 ms apart, the offset to be found to 1 ms: the interpolant matters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rasc.errors import InputError

#: The prior bound on the offset: clocks further apart than this are a set-up error (a
#: stream of another run, seconds against milliseconds), not an offset to estimate; the
#: refinement refuses an estimate beyond it (one line).
MAX_TIME_OFFSET_S = 0.5
#: the fewest samples a stream needs for its spline
MIN_STREAM_SAMPLES = 4
#: The time offset's modes under the general model (``CalibrationOptions.time_offset``):
#: "auto" estimates δ when the dataset has image times and a joint stream (else there is
#: nothing to estimate), "estimate" requires them, "hold" keeps δ = 0.
TIME_OFFSET_MODES = ("auto", "estimate", "hold")


@dataclass
class JointStream:
    """One eye's joint readings on the encoder clock: ``time`` (n,) seconds, strictly
    increasing; ``pan``, ``tilt`` (n,) radians. ``where`` names its source in messages."""

    time: np.ndarray
    pan: np.ndarray
    tilt: np.ndarray
    where: str = "joint stream"

    def __post_init__(self) -> None:
        from scipy.interpolate import CubicSpline

        t = np.asarray(self.time, float).ravel()
        pan = np.asarray(self.pan, float).ravel()
        tilt = np.asarray(self.tilt, float).ravel()
        if not (len(t) == len(pan) == len(tilt)):
            raise InputError(f"{self.where}: time, pan and tilt differ in length "
                             f"({len(t)}, {len(pan)}, {len(tilt)})")
        if len(t) < MIN_STREAM_SAMPLES:
            raise InputError(f"{self.where}: {len(t)} sample(s); a joint stream needs at "
                             f"least {MIN_STREAM_SAMPLES}")
        bad = ~(np.isfinite(t) & np.isfinite(pan) & np.isfinite(tilt))
        if bad.any():
            raise InputError(f"{self.where}: sample {int(np.argmax(bad))} is not a finite "
                             "number")
        step = np.diff(t)
        if np.any(step <= 0):
            k = int(np.argmax(step <= 0)) + 1
            raise InputError(f"{self.where}: sample {k}: time {t[k]!r} does not increase "
                             f"(previous {t[k - 1]!r}); the stream must be in time order")
        self.time, self.pan, self.tilt = t, pan, tilt
        self._spline = CubicSpline(t, np.column_stack([pan, tilt]), axis=0)
        self._rate = self._spline.derivative()

    @property
    def span(self) -> tuple[float, float]:
        return float(self.time[0]), float(self.time[-1])

    def _clip(self, t) -> np.ndarray:
        return np.clip(np.asarray(t, float), self.time[0], self.time[-1])

    def angles(self, t) -> np.ndarray:
        """(pan, tilt) at encoder times ``t`` (n,) → (n, 2) radians; held at the ends
        outside the stream (the refinement's trial offsets may step past them)."""
        return self._spline(self._clip(t))

    def rates(self, t) -> np.ndarray:
        """d(pan, tilt)/dt at encoder times ``t`` → (n, 2) rad/s (0 outside the stream)."""
        t = np.asarray(t, float)
        inside = (t >= self.time[0]) & (t <= self.time[-1])
        return self._rate(self._clip(t)) * inside[:, None]

    def covers(self, t: float) -> bool:
        return bool(self.time[0] <= t <= self.time[-1])


def check_image_times(times: dict[str, float], stream: JointStream, eye: str) -> None:
    """Refuse a pose image whose time is not a finite number or lies outside its eye's
    stream (one line naming the image and the stream's span)."""
    t0, t1 = stream.span
    for f, t in times.items():
        if t is None or not np.isfinite(t):
            raise InputError(f"{eye} pose image {f}: no time; a continuous capture needs "
                             "every pose image's time")
        if not (t0 <= t <= t1):
            raise InputError(f"{eye} pose image {f}: time {t:.6g} s lies outside the "
                             f"{stream.where} ({t0:.6g} to {t1:.6g} s): the image has no "
                             "joint readings; check that both are on the clocks the dataset "
                             "says")
