"""Shared by the exporters: numbers as text that every reader parses back exactly, the
calibration's lengths in metres, and a rotation as URDF's roll-pitch-yaw."""

from __future__ import annotations

import math

import numpy as np

from rasc.errors import InputError


def number(x: float) -> str:
    """A float as the shortest text that reads back to the same double (``repr``), spelt
    so that YAML 1.1 readers (PyYAML), yaml-cpp and OpenCV's FileStorage all take it for
    a float: a mantissa with a point (``1.0e-05``, not ``1e-05``, which PyYAML reads as a
    string), never ``-0.0``."""
    x = float(x) + 0.0
    if not math.isfinite(x):                 # every calibration field is checked finite
        raise InputError(f"cannot export the non-finite number {x}")
    text = repr(x)
    if "e" in text:
        mantissa, exponent = text.split("e")
        if "." not in mantissa:
            mantissa += ".0"
        text = f"{mantissa}e{exponent}"
    return text


def numbers(values, sep: str = ", ") -> str:
    return sep.join(number(v) for v in np.asarray(values, dtype=float).ravel())


def metres_per_unit(length_unit: str | None) -> float:
    """Metres per length unit of a calibration (``length_unit`` of its file; None, as a
    bare ``rasc-head/1`` has it, is taken as metres, the unit rasc renders in). ROS
    (REP 103) and Kalibr want metres; a unit rasc cannot convert is refused."""
    from rasc.study.spec import LENGTH_UNITS_M  # the one table of convertible units

    unit = "m" if length_unit is None else length_unit
    if unit not in LENGTH_UNITS_M:
        raise InputError(f"length_unit {unit!r}: the exports are written in metres and "
                         f"convert only {', '.join(LENGTH_UNITS_M)}")
    return LENGTH_UNITS_M[unit]


def rpy(R: np.ndarray) -> tuple[float, float, float]:
    """URDF's roll, pitch, yaw of a rotation: ``R = Rz(yaw) · Ry(pitch) · Rx(roll)``
    (fixed axes x, y, z), pitch in [−π/2, π/2]. At pitch ±π/2 (gimbal lock: only
    roll ∓ yaw is defined; the REP 103 base sits exactly there) yaw is taken first and
    pitch and roll from what it leaves, so that ``R`` is reproduced to round-off there too."""
    R = np.asarray(R, dtype=float)
    yaw = math.atan2(R[1, 0], R[0, 0]) if math.hypot(R[1, 0], R[0, 0]) > 1e-15 else 0.0
    c, s = math.cos(yaw), math.sin(yaw)
    rest = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ R   # Ry(pitch) · Rx(roll)
    return (math.atan2(-rest[1, 2], rest[1, 1]), math.atan2(-rest[2, 0], rest[0, 0]), yaw)
