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

**Stamp jitter** (:mod:`rasc.vision.joint_stream`, "Timestamp jitter"): the stream's
spline runs through its regular stamps where the given ones jitter about a constant
rate; what is left of the stamps' error, the regular stamps' common offset (their mean
jitter, indistinguishable from δ) and any timing noise of stamps kept as given, enters
δ's σ by :func:`stamp_covariance`.
"""

from __future__ import annotations

import numpy as np

from rasc.errors import InputError

# the stream read at trial offsets, and the pose readings at the estimated one, live with
# the stream, so that the checks outside the refinement (the paper-model fit, the report)
# read them without importing the refinement
from rasc.vision.joint_stream import angles_at, readings_at_offset  # noqa: F401

#: The prior bound on the offset: clocks further apart than this are a set-up error (a
#: stream of another run, seconds against milliseconds), not an offset to estimate; the
#: refinement refuses an estimate beyond it (one line).
MAX_TIME_OFFSET_S = 0.5


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


def stamp_covariance(prob, J, G_inv: np.ndarray) -> np.ndarray:
    """The parameters' covariance (the refinement's scaled units, like ``G_inv``, the
    inverse of JᵀJ) from the joint stream's stamps, which the corners' σ does not count
    (:mod:`rasc.vision.joint_stream`, "Timestamp jitter"):

    - the timing noise left in each eye's stamps (``EyeStream.timing_noise_s``, σ_τ)
      moves each pose frame's readings along the motion as an error of its own time: a
      frame time shifted by ε moves its residuals by ε × δ's column on its rows, so the
      estimate by −G⁻¹Jᵀ(that), summed over the frames with variance σ_τ² each;
    - the regular stamps' offset (``EyeStream.offset_std_s``: their mean jitter) shifts
      the whole stream, which only δ absorbs: its variance is added to δ's (the eyes'
      stamps are one driver's, so the larger of the two, not their mean).

    Zero for a stream whose stamps are exact (no jitter, or stamps as given that are
    smooth)."""
    import scipy.sparse as sp

    from rasc.geometry.frames import EYES

    out = np.zeros_like(G_inv)
    j = prob.time_col
    if j is None:
        return out
    scale = prob.scale[j]
    col = np.asarray(J[:, j].toarray()).ravel() / scale          # d residual / d time (s)
    rows_of = prob._rows_of_images()
    r_idx, c_idx, v_idx, var = [], [], [], []
    for ei, eye in enumerate(EYES):
        v = float(getattr(prob.streams[eye], "timing_noise_s", 0.0)) ** 2
        if v <= 0:
            continue
        for i in prob.pose_images[ei]:
            rows = rows_of[i]
            if len(rows):
                r_idx.append(rows)
                c_idx.append(np.full(len(rows), len(var)))
                v_idx.append(col[rows])
                var.append(v)
    if var:
        Jt = sp.csr_matrix((np.concatenate(v_idx), (np.concatenate(r_idx),
                                                    np.concatenate(c_idx))),
                           shape=(J.shape[0], len(var)))
        A = G_inv @ np.asarray((J.T @ Jt).toarray())
        out += (A * np.array(var)) @ A.T
    off = max(float(getattr(prob.streams[eye], "offset_std_s", 0.0)) for eye in EYES)
    out[j, j] += (off / scale) ** 2
    return out
