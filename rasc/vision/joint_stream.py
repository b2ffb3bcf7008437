"""A joint stream: timestamped pan-tilt readings per eye, as a head that never stops
publishes them (``joints.csv`` in a dataset folder, docs/topics/continuous.md).

::

    time,eye,pan,tilt
    0.0123,left,0.00213,-0.13962
    0.0123,right,0.00213,-0.13962
    ...

``time`` in seconds on the ENCODER clock, ``pan``/``tilt`` encoder readings in radians;
per eye the times strictly increase (the eyes' rows may interleave). The clock
convention shared by the bench and the calibration: **encoder clock = camera clock + δ**,
so the readings at an image stamped ``t_cam`` (camera clock, mid-exposure) are the
stream at ``t_cam + δ``.

:func:`read_joint_stream` is the one reader, :func:`format_joint_stream` the one writer
(:mod:`rasc.vision.dataset` calls both for a dataset's ``"joint_stream"`` member). The
stream is interpolated by a cubic spline through the samples (not-a-knot,
:class:`scipy.interpolate.CubicSpline`): its rates are continuous, which a time offset's
estimate needs (its derivative is the angular rate), and its position error is far below
a linear interpolation's h²/8·|acceleration|.

**Timestamp jitter.** A driver samples its encoders at a constant rate but stamps each
sample when it handles it, a little late by a varying amount: a spline through the
stamps as they are passes exactly through every (stamp, reading) pair, so its angles
carry the jitter × the angular speed as noise (0.5 ms at 20°/s: 0.01°, 0.2 px). The
stream therefore tries **regular stamps** ``t0 + k·T``: the line fitted to the stamps
against their sample numbers k, a missing sample a skipped k (:func:`regular_stamps`),
and the line through the samples' places in the stream, for stamps that jitter by half
a period or more, where no number is certain (:func:`numbered_stamps`). It keeps the
smoother of the two where it makes the readings clearly smoother than the stamps as
given (:func:`roughness`: the readings between every other sample predicted from their
neighbours; :data:`SMOOTHER`): readings taken at a constant rate lie on a smooth curve
at their true times, and the regular stamps are those times up to a line's error. A
stream whose readings are smoothest at their own stamps (a variable rate, accurate
stamps of a jittery sampling, no motion) keeps them. ``EyeStream.stamps`` are the times
the interpolant uses, ``EyeStream.regularised`` says which, and
``EyeStream.timing_noise_s`` is the timing error left in the chosen stamps as the
roughness measures it (seconds, RMS: the readings' scatter about the curve along the
motion over their angular speed), and ``EyeStream.offset_std_s`` the σ of the regular
stamps' offset (their mean jitter shifts the whole stream, as a time offset would): the
refinement adds both to the time offset's σ (:mod:`rasc.head.refine.timing`).

Why not a smoothing spline (:func:`scipy.interpolate.make_smoothing_spline`, λ by GCV),
measured on the bench's streams (the paper's 9 positions at 20°/s, 100 and 200 Hz):
without jitter its angles at the frame times were 7e-5 to 1e-4° off the truth where the
spline through the samples is exact (1e-15°); with 0.1–1 ms of jitter only 2–4x closer
than that spline (the regular stamps: 9–220x, over 100–1000 Hz and 20 and 60°/s); and
it took 0.7–1.4 s per angle.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.io import finite_number, read_text_file

#: the file name of a dataset's joint stream (the manifest's ``"joint_stream"`` member)
JOINTS = "joints.csv"
HEADER = ("time", "eye", "pan", "tilt")
#: the largest joint stream read: ten minutes at 1 kHz for two eyes is about 60 MB
MAX_STREAM_BYTES = 256 * 2**20
#: the regular stamps replace the given ones when they make the readings at least this
#: many times smoother (:func:`roughness`); at equal roughness (no jitter) the stamps as
#: given stay, bit for bit
SMOOTHER = 2.0
#: the variance of a reading predicted from its neighbours by the every-other-sample
#: spline, in units of one reading's noise variance: 1 + Σw², w = (−1, 9, 9, −1)/16 the
#: cubic's weights on uniform samples (:func:`roughness`)
PREDICTION_VARIANCE = 1.0 + 2 * (150 ** 2 + 25 ** 2 + 3 ** 2) / 256 ** 2


def regular_stamps(t: np.ndarray) -> np.ndarray | None:
    """The stamps ``t`` (n,) as a constant-rate driver meant them: the least-squares line
    ``t0 + k·T`` through (k, t), k each sample's number (a missing sample skips one),
    found from the first 32 samples outwards (their phase on the median period, then
    the line through a quarter more each time) so that a stamp off by up to nearly half a
    period still gets its own k. None when the stamps are not those of a constant rate
    (two samples would share a k; fewer than 8 samples)."""
    n = len(t)
    if n < 8:
        return None
    T = float(np.median(np.diff(t)))
    m = min(32, n)
    # the first samples' phase on the period (their circular mean: a missing sample or a
    # late first stamp does not move it)
    phase = np.angle(np.mean(np.exp(2j * np.pi * (t[:m] - t[0]) / T)))
    a = float(t[0] + T * phase / (2 * np.pi))
    while True:
        a, T = _fit_line(t[:m], a, T)
        if a is None:
            return None
        if m == n:
            break
        m = min(m + m // 4, n)      # a quarter more: the line's error there is small
    for _ in range(2):              # the whole stream's line, its numbers again
        a, T = _fit_line(t, a, T)
        if a is None:
            return None
    k = np.round((t - a) / T)
    if T <= 0 or np.any(np.diff(k) < 1):
        return None
    fit = a + T * k
    return fit if np.all(np.diff(fit) > 0) else None


def numbered_stamps(t: np.ndarray) -> np.ndarray | None:
    """The stamps ``t`` (n,) as a constant-rate driver that missed no sample meant them:
    the least-squares line ``t0 + i·T`` through (i, t_i), i the sample's place in the
    stream. For stamps that jitter by half a period or more, where no sample's number is
    certain (:func:`regular_stamps` fails or misnumbers); a missing sample shows as a
    step in the residual, and the roughness test then keeps the stamps as given. None
    for fewer than 8 samples."""
    n = len(t)
    if n < 8:
        return None
    i = np.arange(n, dtype=float)
    A = np.column_stack([np.ones(n), i])
    (a, T), *_ = np.linalg.lstsq(A, t, rcond=None)
    return a + T * i if T > 0 else None


def _fit_line(t: np.ndarray, a: float, T: float) -> tuple[float | None, float]:
    """The line (a, T) through (k, t), k = round((t − a)/T) by the line given; samples
    that share their number with a neighbour (off by nearly half a period where the line
    is still rough) stay out of the fit. (None, T) when fewer than 4 are left or the
    period comes out ≤ 0."""
    k = np.round((t - a) / T)
    own = np.ones(len(t), bool)
    own[1:] &= np.diff(k) >= 1
    own[:-1] &= np.diff(k) >= 1
    if own.sum() < 4:
        return None, T
    A = np.column_stack([np.ones(own.sum()), k[own]])
    (a, T), *_ = np.linalg.lstsq(A, t[own], rcond=None)
    return (float(a), float(T)) if T > 0 else (None, T)


def roughness(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """How far the readings ``y`` (n, 2) at times ``t`` lie off a smooth curve: each odd
    sample predicted by the quintic spline through the even ones. Returns (RMS prediction
    error, rad; the timing error it means, s: the robust spread (1.4826 × the median
    absolute value) of the error along the motion over the angular speed, on the samples
    moving at over a quarter of the fastest, divided by √:data:`PREDICTION_VARIANCE`;
    0 for a stream that never moves). A smooth stream's error is the spline's own,
    O(h⁶); stamp jitter adds the speed × the jitter."""
    from scipy.interpolate import make_interp_spline

    if len(t) < 16:
        return 0.0, 0.0
    even, odd = slice(0, None, 2), slice(1, None, 2)
    sp = make_interp_spline(t[even], y[even], k=5, axis=0)
    e = sp(t[odd]) - y[odd]
    w = sp(t[odd], 1)
    speed = np.linalg.norm(w, axis=1)
    rms = float(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))
    moving = speed > 0.25 * speed.max() if speed.max() > 0 else np.zeros(len(speed), bool)
    if moving.sum() < 8:
        return rms, 0.0
    lag = np.sum(e[moving] * w[moving], axis=1) / speed[moving] ** 2
    return rms, float(1.4826 * np.median(np.abs(lag)) / np.sqrt(PREDICTION_VARIANCE))


@dataclass(frozen=True)
class EyeStream:
    """One eye's readings: ``time`` (n,) seconds on the encoder clock, strictly
    increasing; ``pan``, ``tilt`` (n,) encoder readings in radians."""

    time: np.ndarray
    pan: np.ndarray
    tilt: np.ndarray
    source: str = "<in memory>"
    #: the times the interpolant uses: ``time``, or its regular stamps (module docstring)
    stamps: np.ndarray = field(default=None, init=False, repr=False, compare=False)
    regularised: bool = field(default=False, init=False, repr=False, compare=False)
    #: the timing error (s, RMS) left in ``stamps`` as :func:`roughness` measures it
    timing_noise_s: float = field(default=0.0, init=False, repr=False, compare=False)
    #: regular stamps: the σ (s) of their line's offset, the stamps' RMS scatter about it
    #: over √n (their mean jitter: a shift of the whole stream, which is a time offset)
    offset_std_s: float = field(default=0.0, init=False, repr=False, compare=False)
    _spline: object = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        t = np.asarray(self.time, dtype=float)
        pt = np.column_stack([np.asarray(self.pan, float), np.asarray(self.tilt, float)])
        if t.ndim != 1 or len(t) < 2 or pt.shape != (len(t), 2):
            raise InputError(f"{self.source}: a joint stream needs at least 2 samples per eye "
                             f"with one time, pan and tilt each, got {len(t)}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(pt))):
            raise InputError(f"{self.source}: times and angles must be finite numbers")
        if np.any(np.diff(t) <= 0):
            k = int(np.argmax(np.diff(t) <= 0))
            raise InputError(f"{self.source}: sample {k + 1}: time {t[k + 1]!r} s does not "
                             f"follow {t[k]!r} s (times must increase)")
        from scipy.interpolate import CubicSpline

        object.__setattr__(self, "time", t)
        object.__setattr__(self, "pan", pt[:, 0].copy())
        object.__setattr__(self, "tilt", pt[:, 1].copy())
        r_given = roughness(t, pt)
        stamps, noise = t, r_given[1]
        fits = [(roughness(f, pt), f) for f in (regular_stamps(t), numbered_stamps(t))
                if f is not None]
        if fits:
            r_fit, fit = min(fits, key=lambda rf: rf[0][0])
            if SMOOTHER * r_fit[0] < r_given[0]:
                stamps, noise = fit, r_fit[1]
                object.__setattr__(self, "offset_std_s",
                                   float(np.sqrt(np.mean((t - fit) ** 2) / len(t))))
        object.__setattr__(self, "stamps", stamps)
        object.__setattr__(self, "regularised", stamps is not t)
        object.__setattr__(self, "timing_noise_s", noise)
        object.__setattr__(self, "_spline", CubicSpline(stamps, pt, axis=0))

    def _check(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        lo, hi = self.time[0], self.time[-1]
        bad = ~((t >= lo) & (t <= hi))
        if np.any(bad):
            first = float(np.ravel(t)[np.argmax(np.ravel(bad))])
            raise InputError(f"{self.source}: time {first:.6g} s is outside the stream "
                             f"[{lo:.6g}, {hi:.6g}] s (encoder clock)")
        return t

    def angles(self, t) -> np.ndarray:
        """(pan, tilt) radians at encoder-clock times ``t`` (any shape): shape
        ``t.shape + (2,)``. A time outside the stream raises :class:`InputError`."""
        return self._spline(self._check(t))

    def rates(self, t) -> np.ndarray:
        """d(pan, tilt)/dt, rad/s, at encoder-clock times ``t``: shape ``t.shape + (2,)``."""
        return self._spline(self._check(t), 1)


@dataclass(frozen=True)
class JointStream:
    """The readings of each eye (:class:`EyeStream`), ``stream["left"]``; ``source``
    names it in messages."""

    eyes: dict[str, EyeStream]
    source: str = "<in memory>"

    def __getitem__(self, eye: str) -> EyeStream:
        if eye not in self.eyes:
            raise InputError(f"{self.source}: no joint readings of the {eye} eye")
        return self.eyes[eye]

    def angles(self, eye: str, t) -> np.ndarray:
        """``self[eye].angles(t)``."""
        return self[eye].angles(t)

    def rates(self, eye: str, t) -> np.ndarray:
        """``self[eye].rates(t)``."""
        return self[eye].rates(t)

    @classmethod
    def from_arrays(cls, arrays: dict[str, tuple], source: str = "<in memory>"
                    ) -> JointStream:
        """From ``{eye: (time, pan, tilt)}`` arrays (seconds, radians)."""
        return cls({eye: EyeStream(*arrays[eye], source=f"{source} ({eye})")
                    for eye in EYES if eye in arrays}, source)


def angles_at(stream, t: np.ndarray) -> np.ndarray:
    """(pan, tilt) (n, 2) of one eye's stream (:class:`rasc.vision.joint_stream.EyeStream`)
    at encoder times ``t``, held at its ends outside it: the refinement's trial offsets
    may step past the first or last sample."""
    return stream.angles(np.clip(t, stream.time[0], stream.time[-1]))


def readings_at_offset(stream, times, pan_tilt: np.ndarray,
                       time_offset: float | None) -> np.ndarray:
    """The pose images' readings (pan, tilt) (n, 2), radians, as the refinement had them:
    one eye's joint stream at each image's time + δ (``time_offset``, the estimated
    offset) for a continuous capture; the readings as given (``pan_tilt``) where there is
    no estimate (None), no stream or no time. Every check after the refinement that
    judges the pose readings (the paper model's fit check, the report's residuals) reads
    them here, not at δ = 0 (also :mod:`rasc.head.refine.timing`'s)."""
    pan_tilt = np.asarray(pan_tilt, float).reshape(-1, 2)
    if time_offset is None or stream is None:
        return pan_tilt
    out = pan_tilt.copy()
    has = np.array([t is not None for t in times], bool)
    if has.any():
        t = np.array([t for t in times if t is not None], float)
        out[has] = angles_at(stream, t + time_offset)
    return out


def read_joint_stream(path: str | os.PathLike) -> JointStream:
    """Read ``joints.csv`` (the module docstring's format). Every problem is one
    :class:`InputError` line naming the file and line: a missing file, a wrong header,
    an unknown eye, a cell that is not a finite number, a time that does not increase
    (per eye)."""
    path = Path(path)
    text = read_text_file(path, "joint stream", MAX_STREAM_BYTES)
    lines = text.splitlines()
    if not lines or tuple(c.strip() for c in lines[0].split(",")) != HEADER:
        got = lines[0].strip() if lines else "nothing"
        raise InputError(f"{path}: line 1: expected the header {','.join(HEADER)}, got "
                         f"{got!r}")
    cols: dict[str, list[list[float]]] = {}
    last: dict[str, tuple[float, int]] = {}
    for n, line in enumerate(lines[1:], 2):
        if not line.strip():
            continue
        cells = line.split(",")
        where = f"{path}: line {n}"
        if len(cells) != 4:
            raise InputError(f"{where}: expected 4 cells (time,eye,pan,tilt), got {len(cells)}")
        eye = cells[1].strip()
        if eye not in EYES:
            raise InputError(f"{where}: eye must be 'left' or 'right', got {eye!r}")
        t, pan, tilt = (finite_number(cells[i], f"{where}: {HEADER[i]}", text=True)
                        for i in (0, 2, 3))
        for name, a in (("pan", pan), ("tilt", tilt)):
            if abs(a) > 2 * math.pi:
                raise InputError(f"{where}: {name} = {a:g} rad is more than a full turn (the "
                                 "stream is in radians)")
        if eye in last and t <= last[eye][0]:
            raise InputError(f"{where}: time {t!r} s does not follow the {eye} eye's "
                             f"{last[eye][0]!r} s on line {last[eye][1]} (times must increase "
                             "per eye)")
        last[eye] = (t, n)
        cols.setdefault(eye, []).append([t, pan, tilt])
    for eye, rows in cols.items():
        if len(rows) < 2:
            raise InputError(f"{path}: the {eye} eye has {len(rows)} reading; a joint stream "
                             "needs at least 2 per eye")
    if not cols:
        raise InputError(f"{path}: no readings after the header")
    return JointStream({eye: EyeStream(*np.array(rows).T, source=f"{path} ({eye})")
                        for eye, rows in ((e, cols[e]) for e in EYES if e in cols)},
                       str(path))


def format_joint_stream(stream: JointStream) -> str:
    """The CSV text of ``stream`` (:func:`read_joint_stream` reads it back exactly:
    ``repr`` of each float), rows in time order, left before right at equal times."""
    rows = [(float(t), k, eye, float(p), float(q)) for k, (eye, s) in
            enumerate(sorted(stream.eyes.items(), key=lambda i: EYES.index(i[0])))
            for t, p, q in zip(s.time, s.pan, s.tilt, strict=True)]
    rows.sort()
    return ",".join(HEADER) + "\n" + "".join(f"{t!r},{eye},{p!r},{q!r}\n"
                                            for t, _, eye, p, q in rows)
