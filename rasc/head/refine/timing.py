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

import numpy as np

from rasc.errors import InputError

#: The prior bound on the offset: clocks further apart than this are a set-up error (a
#: stream of another run, seconds against milliseconds), not an offset to estimate; the
#: refinement refuses an estimate beyond it (one line).
MAX_TIME_OFFSET_S = 0.5


def angles_at(stream, t: np.ndarray) -> np.ndarray:
    """(pan, tilt) (n, 2) of one eye's stream (:class:`rasc.vision.joint_stream.EyeStream`)
    at encoder times ``t``, held at its ends outside it: the refinement's trial offsets
    may step past the first or last sample."""
    return stream.angles(np.clip(t, stream.time[0], stream.time[-1]))


def rates_at(stream, t: np.ndarray) -> np.ndarray:
    """d(pan, tilt)/dt (n, 2) rad/s of :func:`angles_at` (0 outside the stream)."""
    inside = (t >= stream.time[0]) & (t <= stream.time[-1])
    return stream.rates(np.clip(t, stream.time[0], stream.time[-1])) * inside[:, None]


def check_image_times(times: dict[str, float], stream, eye: str) -> None:
    """Refuse a pose image whose time is not a finite number or lies outside its eye's
    stream (one line naming the image and the stream's span)."""
    t0, t1 = float(stream.time[0]), float(stream.time[-1])
    for f, t in times.items():
        if t is None or not np.isfinite(t):
            raise InputError(f"{eye} pose image {f}: no time; a continuous capture needs "
                             "every pose image's time")
        if not (t0 <= t <= t1):
            raise InputError(f"{eye} pose image {f}: time {t:.6g} s lies outside the "
                             f"{stream.source} ({t0:.6g} to {t1:.6g} s): the image has no "
                             "joint readings; check that both are on the clocks the dataset "
                             "says")
