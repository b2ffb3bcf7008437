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


@dataclass(frozen=True)
class EyeStream:
    """One eye's readings: ``time`` (n,) seconds on the encoder clock, strictly
    increasing; ``pan``, ``tilt`` (n,) encoder readings in radians."""

    time: np.ndarray
    pan: np.ndarray
    tilt: np.ndarray
    source: str = "<in memory>"
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
        object.__setattr__(self, "_spline", CubicSpline(t, pt, axis=0))

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
