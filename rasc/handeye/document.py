"""Read and validate the ``rasc handeye`` input document (``POSES.json``).

The document, ``rasc-handeye/1``::

    {
      "format": "rasc-handeye/1",          optional; if given, exactly this
      "angle_unit": "deg",                 optional: "deg" (default) or "rad"
      "length_unit": "m",                  optional, free text, echoed in the result
      "description": "...",                optional, free text
      "positions": [                       at least 3
        {"pan": 0.0, "tilt": 0.0, "T_cam_from_world": [[4 numbers], x4]},
        {"T_gaze_from_ptu": [[4 numbers], x4], "T_cam_from_world": [[...], x4]},
        ...
      ]
    }

Each position gives the target's pose ``T_cam_from_world`` (camera calibration's
extrinsics, translation in any one length unit) and the unit's motion, either as
``pan`` and ``tilt`` (converted through eq. 3, :func:`rasc.geometry.kinematics.T_gaze_from_ptu`)
or as a 4×4 rigid ``T_gaze_from_ptu`` (for a robot arm: the gripper's pose
``T_gripper_from_base``). A position may also carry a free-text ``label``. Nothing else
is accepted: an unknown key is an error, so a misspelt ``angle_units`` cannot silently
fall back to degrees.

Checks, each an :class:`~rasc.errors.InputError` naming the field (the loader prefixes
the file name): the reader's (:func:`rasc.io.read_json_document`: JSON syntax with line
and column, duplicate keys, depth, number sizes, NaN and Infinity), shapes (4×4 only; a 3×4
``[R|t]`` is refused with a hint), non-numeric entries (``true``, ``"1"``, ``null``),
rigidity (:func:`rasc.geometry.transforms.validate_rigid_transform`),
at least 3 positions, the angle unit (:func:`check_angle_unit`), and that the unit's
motions turn as far as the camera's (:func:`rasc.handeye.solver.check_motions_match`, which
catches a wrong angle unit that the values alone cannot show).

**Two timestamped streams** (a head that never stops): with a top-level ``unit_stream``,
the positions are the camera's stream and the unit's poses come from the unit's own::

    "positions": [                         the camera's stream, at least 3
      {"time": 0.0333, "T_cam_from_world": [[...], x4]},  ...
    ],
    "unit_stream": [                       the unit's stream, at least 4
      {"time": 0.0050, "pan": 1.25, "tilt": -0.5},       or "T_gaze_from_ptu": [[...]]
      ...
    ]

Each position then gives ``time`` (seconds, the camera's clock) and ``T_cam_from_world``,
and no motion; each ``unit_stream`` sample gives ``time`` (seconds, the unit's clock) and
the unit's pose as pan/tilt or ``T_gaze_from_ptu``. Within each stream the times must
increase; the two clocks may differ by an unknown offset, which ``rasc handeye``
estimates (:mod:`rasc.handeye.time_offset`: the unit's clock reads the camera's plus δ).
A ``time`` without a ``unit_stream`` is refused (it would change nothing). The unit's
motions are checked against the camera's once the streams are aligned.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from rasc import formats
from rasc.errors import InputError
from rasc.geometry.kinematics import T_gaze_from_ptu as T_gaze_from_ptu_eq3
from rasc.geometry.transforms import validate_rigid_transform
from rasc.io import finite_number, read_json_document
from rasc.io import shown as _shown

FORMAT = formats.HANDEYE.tag
ANGLE_UNITS = ("deg", "rad")
TOP_KEYS = ("format", "angle_unit", "length_unit", "description", "positions",
            "unit_stream")
POSITION_KEYS = ("pan", "tilt", "T_gaze_from_ptu", "T_cam_from_world", "label", "time")
UNIT_STREAM_KEYS = ("time", "pan", "tilt", "T_gaze_from_ptu")
MIN_POSITIONS = 3

#: A unit stream's fewest samples: a cubic spline through them needs 4.
MIN_UNIT_SAMPLES = 4

#: Rule (a) for ``angle_unit "deg"``: if the largest |pan| or |tilt| is above 0 but
#: below this many degrees, the angles are taken for radians. A pan-tilt set whose
#: largest motion is under 1° cannot calibrate a camera (at the paper's smallest noise,
#: 0.005 rad ≈ 0.29° per view, the motion would be barely above the noise), while
#: radians below 1 (57°) cover every practical pan-tilt calibration set (the paper's
#: ±8° is ±0.1396).
RADIANS_MAX_DEG = 1.0

#: Rule (b) for ``angle_unit "deg"`` (largest |angle| up to 2π): every nonzero angle,
#: read as radians, is a whole number of degrees within this many degrees (1.0472 is
#: 60.00014°). Degree values written with up to two decimals never trigger it (the
#: closest, 2.81, is 161.00114° read as radians; a test checks them all), and a noisy
#: reading triggers it by chance with probability ≈ 0.002 per distinct value. Radians
#: typed with only four decimals (error up to 0.003°) can slip through; rule (a)
#: still catches every radian set below 1.
RADIANS_ROUND_TOL_DEG = 1e-3


@dataclass(frozen=True)
class HandEyeInput:
    """A validated ``rasc-handeye/1`` document.

    Attributes
    ----------
    T_cam_from_world : ndarray, shape (n, 4, 4)
        Target pose at each position (translation in ``length_unit``).
    T_gaze_from_ptu : ndarray, shape (n, 4, 4)
        The unit's motion at each position (eq. 3 from pan/tilt, or as given).
    angle_unit : str
        ``"deg"`` or ``"rad"``, as the document said (default ``"deg"``).
    length_unit : str or None
        Free text from the document, or None.
    labels : tuple of (str or None), length n
    description : str or None
    from_angles : bool
        Every position (or unit-stream sample) gave pan/tilt (a pan-tilt unit, eq. 3),
        none a matrix.
    times : ndarray, shape (n,), or None
        With a unit stream: each position's ``time`` (the camera's clock, seconds).
    unit_times : ndarray, shape (m,), or None
        The unit stream's times (the unit's clock, seconds).
    unit_stream : ndarray, shape (m, 4, 4), or None
        The unit's pose at each of ``unit_times``. With a stream, ``T_gaze_from_ptu`` is
        the naive pairing, the unit pose whose time is nearest each position's (the
        clocks taken as one): :func:`rasc.handeye.time_offset.solve_streams` pairs them
        properly.
    """

    T_cam_from_world: np.ndarray
    T_gaze_from_ptu: np.ndarray
    angle_unit: str
    length_unit: str | None
    labels: tuple
    description: str | None
    from_angles: bool = False
    times: np.ndarray | None = None
    unit_times: np.ndarray | None = None
    unit_stream: np.ndarray | None = None

    @property
    def n_positions(self) -> int:
        """The number of pan-tilt positions (views) in the document."""
        return int(self.T_cam_from_world.shape[0])

    @property
    def is_stream(self) -> bool:
        """True for two timestamped streams (the document has a ``unit_stream``)."""
        return self.unit_stream is not None


def read_json(path: str | os.PathLike) -> Any:
    """Parse the POSES.json file by :func:`rasc.io.read_json_document`'s rules.

    Raises
    ------
    InputError
        Missing path, a folder, not a regular file, too large, unreadable, not UTF-8,
        malformed JSON (line and column), duplicate keys, too deep, integers too long,
        NaN, Infinity or numbers too large (with their JSON pointer). Messages start with
        the path.
    """
    return read_json_document(path, "POSES.json", top=None)


def _type_name(value: Any) -> str:
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean",
            type(None): "null"}.get(type(value), type(value).__name__)


def _matrix4(value: Any, name: str) -> np.ndarray:
    """A 4×4 rigid transform given as 4 rows of 4 numbers → ndarray (4, 4)."""
    if not isinstance(value, list) or not all(isinstance(row, list) for row in value):
        raise InputError(f"{name}: expected a 4x4 matrix (a list of 4 rows of 4 numbers), "
                         f"got {_type_name(value)}")
    lengths = {len(row) for row in value}
    if len(lengths) > 1:
        for i, row in enumerate(value):
            if len(row) != 4:
                raise InputError(f"{name}: row {i} has {len(row)} entries, expected 4")
    shape = f"{len(value)}x{lengths.pop() if lengths else 0}"
    if shape != "4x4":
        hint = "; add the last row [0, 0, 0, 1]" if shape == "3x4" else ""
        raise InputError(f"{name}: expected a 4x4 matrix, got {shape}{hint}")
    T = np.array([[finite_number(x, f"{name}[{i}][{j}]") for j, x in enumerate(row)]
                  for i, row in enumerate(value)])
    return validate_rigid_transform(T, name=name)


def check_angle_unit(angles: list[tuple[str, float]], angle_unit: str) -> None:
    """Refuse angles that look like the other unit.

    Parameters
    ----------
    angles : list of (field name, value)
        Every pan and tilt value as written in the document.
    angle_unit : {"deg", "rad"}

    Notes
    -----
    The rules: ``"rad"``: any |angle| > 2π looks like degrees.
    ``"deg"``: (a) the largest |angle| is above 0 and below :data:`RADIANS_MAX_DEG`;
    or (b) the largest |angle| is at most 2π and every nonzero angle, read as radians,
    is a whole number of degrees within :data:`RADIANS_ROUND_TOL_DEG`. Real degree data
    (integers like 8, or encoder readings like 7.9875) trigger neither. Not caught:
    degrees given as radians when all are within ±2π (e.g. ±3 meaning ±3°).
    """
    if not angles:
        return
    if angle_unit == "rad":
        for name, value in angles:
            if abs(value) > 2 * math.pi:
                raise InputError(f"{name} = {value:g} with angle_unit 'rad' looks like degrees; "
                                 "set angle_unit to 'deg'")
        return
    name_max, value_max = max(angles, key=lambda nv: abs(nv[1]))
    largest = abs(value_max)
    if 0.0 < largest < RADIANS_MAX_DEG:
        raise InputError(
            f"every |pan| and |tilt| is below {RADIANS_MAX_DEG:g} with angle_unit 'deg' "
            f"(largest {name_max} = {value_max:g}); they look like radians (motions under "
            f"{RADIANS_MAX_DEG:g} degree cannot calibrate); set angle_unit to 'rad'")
    nonzero = [(n, v) for n, v in angles if v != 0.0]
    if nonzero and largest <= 2 * math.pi:
        as_deg = np.degrees([v for _, v in nonzero])
        if np.all(np.abs(as_deg - np.round(as_deg)) <= RADIANS_ROUND_TOL_DEG):
            raise InputError(
                f"{name_max} = {value_max:g} with angle_unit 'deg' is {math.degrees(value_max):.4g}"
                f" degrees if read as radians, and every nonzero angle is a whole number of"
                f" degrees that way; they look like radians; set angle_unit to 'rad'")


def _motion(item: dict, where: str, angle_unit: str, angles: list[tuple[str, float]]
            ) -> tuple[np.ndarray, tuple[float, float] | None]:
    """The unit's motion of a position or unit-stream sample: (T_gaze_from_ptu,
    (pan, tilt) as written or None)."""
    has_angles = "pan" in item or "tilt" in item
    if has_angles and "T_gaze_from_ptu" in item:
        raise InputError(f"{where}: has both pan/tilt and T_gaze_from_ptu; give one of them")
    if not has_angles and "T_gaze_from_ptu" not in item:
        raise InputError(f"{where}: missing the unit's motion; give pan and tilt, "
                         "or T_gaze_from_ptu")
    if not has_angles:
        return _matrix4(item["T_gaze_from_ptu"], f"{where}.T_gaze_from_ptu"), None
    for key, other in (("pan", "tilt"), ("tilt", "pan")):
        if key not in item:
            raise InputError(f"{where}: {other!r} given without {key!r}")
    pan = finite_number(item["pan"], f"{where}.pan")
    tilt = finite_number(item["tilt"], f"{where}.tilt")
    for key, value in (("pan", pan), ("tilt", tilt)):   # radians: check_angle_unit
        if angle_unit == "deg" and abs(value) > 360.0:
            raise InputError(f"{where}.{key} = {value:g} deg is more than a full turn")
    angles += [(f"{where}.pan", pan), (f"{where}.tilt", tilt)]
    return _eq3(pan, tilt, angle_unit), (pan, tilt)


def _time(item: dict, where: str, previous: float | None, previous_where: str) -> float:
    """A sample's ``time`` (seconds), after the previous sample's."""
    if "time" not in item:
        raise InputError(f"{where}: missing 'time' (seconds; every pose of a stream is "
                         "stamped)")
    t = finite_number(item["time"], f"{where}.time")
    if previous is not None and not t > previous:
        raise InputError(f"{where}.time = {t:.9g} is not after {previous_where}.time = "
                         f"{previous:.9g}: a stream's times must increase")
    return t


def _position(item: Any, k: int, angle_unit: str, angles: list[tuple[str, float]],
              stream: bool = False
              ) -> tuple[np.ndarray, np.ndarray | None, str | None,
                         tuple[float, float] | None]:
    """(T_cam_from_world, T_gaze_from_ptu, label, (pan, tilt) as written or None); with
    ``stream`` (the document has a unit_stream) a position gives no motion
    (T_gaze_from_ptu None)."""
    where = f"positions[{k}]"
    if not isinstance(item, dict):
        what = ("T_cam_from_world and time" if stream else
                "T_cam_from_world and pan/tilt or T_gaze_from_ptu")
        raise InputError(f"{where}: expected an object with {what}, got {_type_name(item)}")
    unknown = [key for key in item if key not in POSITION_KEYS]
    if unknown:
        raise InputError(f"{where}: unknown key {unknown[0]!r}; allowed: "
                         + ", ".join(POSITION_KEYS))
    if "T_cam_from_world" not in item:
        raise InputError(f"{where}: missing T_cam_from_world (the target's pose from "
                         "camera calibration)")
    if stream:
        motion = [key for key in ("pan", "tilt", "T_gaze_from_ptu") if key in item]
        if motion:
            raise InputError(f"{where}: has {motion[0]} but the document has a unit_stream: "
                             "a position then gives only time and T_cam_from_world (the "
                             "unit's poses come from the stream)")
        T_gp, written = None, None
    else:
        if "time" in item:
            raise InputError(f"{where}.time: a time is only read with a unit_stream (the "
                             "unit's timestamped poses); without one each position pairs "
                             "a camera pose with the motion beside it")
        T_gp, written = _motion(item, where, angle_unit, angles)
    T_cw = _matrix4(item["T_cam_from_world"], f"{where}.T_cam_from_world")
    label = item.get("label")
    if label is not None and not isinstance(label, str):
        raise InputError(f"{where}.label: expected a string, got {_type_name(label)}")
    return T_cw, T_gp, label, written


def _unit_stream(doc: dict, angle_unit: str, angles: list[tuple[str, float]]
                 ) -> tuple[np.ndarray, np.ndarray, bool]:
    """(times (m,), T_gaze_from_ptu (m, 4, 4), every sample from pan/tilt)."""
    stream = doc["unit_stream"]
    if not isinstance(stream, list):
        raise InputError(f"unit_stream: expected a list, got {_type_name(stream)}")
    if len(stream) < MIN_UNIT_SAMPLES:
        raise InputError(f"unit_stream: need at least {MIN_UNIT_SAMPLES} timestamped unit "
                         f"poses to interpolate, got {len(stream)}")
    times, poses, from_angles = [], [], True
    for j, item in enumerate(stream):
        where = f"unit_stream[{j}]"
        if not isinstance(item, dict):
            raise InputError(f"{where}: expected an object with time and pan/tilt or "
                             f"T_gaze_from_ptu, got {_type_name(item)}")
        unknown = [key for key in item if key not in UNIT_STREAM_KEYS]
        if unknown:
            raise InputError(f"{where}: unknown key {unknown[0]!r}; allowed: "
                             + ", ".join(UNIT_STREAM_KEYS))
        times.append(_time(item, where, times[-1] if times else None,
                           f"unit_stream[{j - 1}]"))
        T, written = _motion(item, where, angle_unit, angles)
        poses.append(T)
        from_angles &= written is not None
    return np.array(times), np.stack(poses), from_angles


def _eq3(pan: float, tilt: float, angle_unit: str) -> np.ndarray:
    if angle_unit == "deg":
        pan, tilt = math.radians(pan), math.radians(tilt)
    return T_gaze_from_ptu_eq3(pan, tilt)  # eq. 3


def _optional_text(doc: dict, key: str) -> str | None:
    value = doc.get(key)
    if value is not None and not isinstance(value, str):
        raise InputError(f"{key}: expected a string, got {_type_name(value)}")
    return value


def parse_handeye_document(doc: Any) -> HandEyeInput:
    """Validate a parsed ``rasc-handeye/1`` document (see the module docstring).

    Raises
    ------
    InputError
        With a message naming the field, e.g. ``positions[3].T_cam_from_world: ...``.
    """
    if not isinstance(doc, dict):
        raise InputError(f"top level must be a JSON object with a 'positions' list, "
                         f"got {_type_name(doc)}")
    unknown = [key for key in doc if key not in TOP_KEYS]
    if unknown:
        raise InputError(f"unknown top-level key {unknown[0]!r}; allowed: " + ", ".join(TOP_KEYS))
    if "format" in doc and doc["format"] != FORMAT:
        raise InputError(f"format = {_shown(doc['format'])}: expected {FORMAT!r}")
    angle_unit = doc.get("angle_unit", "deg")
    if angle_unit not in ANGLE_UNITS:
        raise InputError(f"angle_unit = {_shown(angle_unit)}: expected 'deg' or 'rad'")
    length_unit = _optional_text(doc, "length_unit")
    description = _optional_text(doc, "description")
    if "positions" not in doc:
        raise InputError("missing 'positions' (a list of at least 3 positions)")
    positions = doc["positions"]
    if not isinstance(positions, list):
        raise InputError(f"positions: expected a list, got {_type_name(positions)}")
    if len(positions) < MIN_POSITIONS:
        raise InputError(f"positions: need at least {MIN_POSITIONS} positions (two motions "
                         f"about different axes), got {len(positions)}")
    angles: list[tuple[str, float]] = []
    stream = "unit_stream" in doc
    parsed = [_position(item, k, angle_unit, angles, stream)
              for k, item in enumerate(positions)]
    if stream:
        return _stream_input(doc, positions, parsed, angle_unit, angles, length_unit,
                             description)
    check_angle_unit(angles, angle_unit)
    T_cw, T_gp = np.stack([p[0] for p in parsed]), np.stack([p[1] for p in parsed])
    from rasc.handeye.advice import check_motions_match  # scipy: not needed to build the parser

    other = "rad" if angle_unit == "deg" else "deg"
    T_other = np.stack([p[1] if p[3] is None else _eq3(*p[3], other) for p in parsed])
    check_motions_match(T_cw, T_gp, other_unit=(other, T_other) if angles else None)
    return HandEyeInput(
        T_cam_from_world=T_cw,
        T_gaze_from_ptu=T_gp,
        angle_unit=angle_unit,
        length_unit=length_unit,
        labels=tuple(p[2] for p in parsed),
        description=description,
        from_angles=all(p[3] is not None for p in parsed),
    )


def _stream_input(doc: dict, positions: list, parsed: list, angle_unit: str,
                  angles: list[tuple[str, float]], length_unit: str | None,
                  description: str | None) -> HandEyeInput:
    """A document with a ``unit_stream``: the positions' times, the stream (the motions
    are checked against the camera's once the streams are aligned, by
    :func:`rasc.handeye.time_offset.solve_streams`)."""
    times: list[float] = []
    for k, item in enumerate(positions):
        times.append(_time(item, f"positions[{k}]", times[-1] if times else None,
                           f"positions[{k - 1}]"))
    unit_times, unit_poses, from_angles = _unit_stream(doc, angle_unit, angles)
    check_angle_unit(angles, angle_unit)
    from rasc.handeye.time_offset import nearest_pairs  # scipy: not needed to build the parser

    t = np.array(times)
    return HandEyeInput(
        T_cam_from_world=np.stack([p[0] for p in parsed]),
        T_gaze_from_ptu=nearest_pairs(t, unit_times, unit_poses),
        angle_unit=angle_unit,
        length_unit=length_unit,
        labels=tuple(p[2] for p in parsed),
        description=description,
        from_angles=from_angles,
        times=t, unit_times=unit_times, unit_stream=unit_poses,
    )


def load_handeye_input(path: str | os.PathLike) -> HandEyeInput:
    """Read and validate ``path``; every error message starts with the path."""
    doc = read_json(path)
    try:
        return parse_handeye_document(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
