"""What ``rasc import`` needs to know about a recording: topics, joints, board, thresholds.

From a small TOML file (read with :mod:`tomllib`) and/or options (options win)::

    stamp = "header"                  # "header" (sensor time, default) or "bag" (receive time)

    [board]
    inner_corners = [9, 6]
    square_size = 0.05
    length_unit = "m"                 # optional: the unit of square_size

    [topics]                          # the image topics of each eye
    left = "/left/image_raw"
    right = "/right/image_raw"

    [joints]                          # where the pan and tilt readings are
    angle_unit = "rad"                # of the readings (ROS: rad)
    left = {topic = "/joint_states", pan = "left_pan", tilt = "left_tilt"}
    right = {topic = "/joint_states", pan = "right_pan", tilt = "right_tilt"}

    [still]                           # a capture is a still moment of every joint
    threshold = 0.002                 # max spread of each reading, in angle_unit
    min_duration_s = 0.5              # for at least this long
    tolerance_s = 0.5                 # image stamp to the moment's middle, at most

    [intrinsics]
    interval_s = 1.0                  # of an intrinsics recording: one image per eye per s

One topic per unit is the same table with a topic per eye (``left = {topic =
"/left_ptu/joint_states", pan = "pan", tilt = "tilt"}``). Every problem is one
:class:`~rasc.errors.InputError` line naming the file and the key.
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from rasc.errors import InputError
from rasc.geometry.frames import EYES

#: default still threshold: 0.1 degree. A pan-tilt unit at rest reads within one encoder
#: tick (0.013 deg for a FLIR PTU-D46, 0.088 deg for a Dynamixel servo); moving at a
#: slow 1 deg/s it leaves 0.1 deg in 0.1 s, far under the default 0.5 s still time.
DEFAULT_THRESHOLD_DEG = 0.1
DEFAULT_MIN_DURATION_S = 0.5
DEFAULT_TOLERANCE_S = 0.5
DEFAULT_INTERVAL_S = 1.0
#: a change of the offset between a topic's header stamps and its receive times larger
#: than this is a clock jump (a sim-time reset, an NTP step): transport latency varies by
#: milliseconds, not seconds
CLOCK_JUMP_S = 1.0
STAMPS = ("header", "bag")

_KEYS = {"": {"stamp", "board", "topics", "joints", "still", "intrinsics"},
         "board": {"inner_corners", "square_size", "length_unit"},
         "topics": set(EYES),
         "joints": {"angle_unit", *EYES},
         "still": {"threshold", "min_duration_s", "tolerance_s"},
         "intrinsics": {"interval_s"}}


@dataclass(frozen=True)
class JointSource:
    """Where one unit's readings are: a sensor_msgs/JointState topic and two joint names."""

    topic: str
    pan: str
    tilt: str


@dataclass(frozen=True)
class ImportConfig:
    """What ``rasc import`` needs to know of a recording: topics, joints, thresholds, angle
    unit and board (options or a TOML file)."""
    board: dict[str, Any] | None = None          # {"inner_corners": [nx, ny], "square_size"}
    length_unit: str | None = None
    topics: dict[str, str] = field(default_factory=dict)
    joints: dict[str, JointSource] = field(default_factory=dict)
    angle_unit: str = "rad"
    threshold: float | None = None               # in angle_unit; None: 0.1 deg
    min_duration_s: float = DEFAULT_MIN_DURATION_S
    tolerance_s: float = DEFAULT_TOLERANCE_S
    interval_s: float = DEFAULT_INTERVAL_S
    stamp: str = "header"
    source: str = "options"                      # where it was read from, for messages

    @property
    def threshold_value(self) -> float:
        """The still threshold in :attr:`angle_unit`."""
        if self.threshold is not None:
            return self.threshold
        return DEFAULT_THRESHOLD_DEG if self.angle_unit == "deg" \
            else math.radians(DEFAULT_THRESHOLD_DEG)

    def require(self, *, joints: bool) -> None:
        """Refuse a configuration that lacks what the import needs (one line)."""
        where = self.source
        if self.board is None:
            raise InputError(f"{where}: no board: give [board] inner_corners and square_size "
                             "(or --board NXxNY --square-size S)")
        for eye in EYES:
            if eye not in self.topics:
                raise InputError(f"{where}: no image topic for the {eye} eye ([topics] {eye} "
                                 f"or --{eye}-topic)")
            if joints and eye not in self.joints:
                raise InputError(f"{where}: no pan/tilt readings for the {eye} eye ([joints] "
                                 f"{eye} = {{topic, pan, tilt}} or --{eye}-joints "
                                 "TOPIC:PAN,TILT)")

    def to_dict(self) -> dict[str, Any]:
        """For the manifest's provenance."""
        return {"topics": dict(self.topics),
                "joints": {e: {"topic": j.topic, "pan": j.pan, "tilt": j.tilt}
                           for e, j in self.joints.items()},
                "angle_unit": self.angle_unit, "stamp": self.stamp,
                "still": {"threshold": self.threshold_value,
                          "min_duration_s": self.min_duration_s,
                          "tolerance_s": self.tolerance_s},
                "intrinsics_interval_s": self.interval_s}


def _number(value, where: str, positive: bool = True) -> float:
    """The one number check (:func:`rasc.io.finite_number`), and above 0 if ``positive``."""
    from rasc.io import finite_number, shown

    x = finite_number(value, where)
    if positive and x <= 0:
        raise InputError(f"{where}: must be a positive number, got {shown(value)}")
    return x


def _text(value, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"{where}: must be a non-empty string, got {value!r}")
    return value


def parse_joint_source(value, where: str) -> JointSource:
    """``{topic, pan, tilt}`` (TOML) or ``"TOPIC:PAN,TILT"`` (an option)."""
    if isinstance(value, str):
        topic, sep, names = value.rpartition(":")
        parts = names.split(",")
        if not sep or not topic or len(parts) != 2 or not all(p.strip() for p in parts):
            raise InputError(f"{where}: expected TOPIC:PAN,TILT (e.g. "
                             f"/joint_states:left_pan,left_tilt), got {value!r}")
        return JointSource(topic, parts[0].strip(), parts[1].strip())
    if not isinstance(value, dict):
        raise InputError(f"{where}: expected a table {{topic, pan, tilt}}, got {value!r}")
    extra = set(value) - {"topic", "pan", "tilt"}
    if extra:
        raise InputError(f"{where}: unknown key {sorted(extra)[0]!r} (keys: topic, pan, tilt)")
    for k in ("topic", "pan", "tilt"):
        if k not in value:
            raise InputError(f"{where}: missing key {k!r}")
    return JointSource(*(_text(value[k], f"{where}.{k}") for k in ("topic", "pan", "tilt")))


def parse_board(value, where: str) -> dict[str, Any]:
    """``{inner_corners, square_size}`` checked by :class:`rasc.vision.board.Board`."""
    from rasc.vision.board import Board

    ic = value.get("inner_corners")
    if not isinstance(ic, list) or len(ic) != 2 or \
            not all(isinstance(v, int) and not isinstance(v, bool) for v in ic):
        raise InputError(f"{where}.inner_corners: must be two integers [nx, ny], got {ic!r}")
    if "square_size" not in value:
        raise InputError(f"{where}: missing key 'square_size'")
    try:
        return Board(tuple(ic), value["square_size"]).to_dict()
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def load_config(path: str | os.PathLike) -> ImportConfig:
    """An :class:`ImportConfig` from a TOML file (module docstring)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: no such configuration file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    where = str(path)
    for section, keys in _KEYS.items():
        table = data if section == "" else data.get(section, {})
        if section and not isinstance(table, dict):
            raise InputError(f"{where}: [{section}] must be a table")
        extra = set(table) - keys
        if extra:
            name = sorted(extra)[0]
            raise InputError(f"{where}: unknown key {(section + '.' if section else '')}"
                             f"{name} (allowed: {', '.join(sorted(keys))})")
    cfg: dict[str, Any] = {"source": where}
    if "stamp" in data:
        cfg["stamp"] = data["stamp"]
    if "board" in data:
        cfg["board"] = parse_board(data["board"], f"{where}: board")
        if "length_unit" in data["board"]:
            cfg["length_unit"] = _text(data["board"]["length_unit"],
                                       f"{where}: board.length_unit")
    if "topics" in data:
        cfg["topics"] = {e: _text(v, f"{where}: topics.{e}") for e, v in data["topics"].items()}
    j = data.get("joints", {})
    if "angle_unit" in j:
        cfg["angle_unit"] = j["angle_unit"]
    cfg["joints"] = {e: parse_joint_source(j[e], f"{where}: joints.{e}") for e in EYES if e in j}
    s = data.get("still", {})
    if "threshold" in s:
        cfg["threshold"] = _number(s["threshold"], f"{where}: still.threshold")
    for key in ("min_duration_s", "tolerance_s"):
        if key in s:
            cfg[key] = _number(s[key], f"{where}: still.{key}")
    if "interval_s" in data.get("intrinsics", {}):
        cfg["interval_s"] = _number(data["intrinsics"]["interval_s"],
                                    f"{where}: intrinsics.interval_s", positive=False)
    return checked(ImportConfig(**cfg))


def checked(cfg: ImportConfig) -> ImportConfig:
    """The enumerated fields checked (after options are merged in)."""
    if cfg.angle_unit not in ("deg", "rad"):
        raise InputError(f"{cfg.source}: angle_unit must be 'deg' or 'rad', "
                         f"got {cfg.angle_unit!r}")
    if cfg.stamp not in STAMPS:
        raise InputError(f"{cfg.source}: stamp must be 'header' or 'bag', got {cfg.stamp!r}")
    if cfg.interval_s < 0:
        raise InputError(f"{cfg.source}: intrinsics interval_s must be 0 or more")
    return cfg


def merged(cfg: ImportConfig, **options) -> ImportConfig:
    """``cfg`` with the options that were given (not None) in place of its values;
    ``topics`` and ``joints`` merge per eye."""
    given = {k: v for k, v in options.items() if v is not None}
    if "topics" in given:
        given["topics"] = {**cfg.topics, **given["topics"]}
    if "joints" in given:
        given["joints"] = {**cfg.joints, **given["joints"]}
    if given and cfg.source != "options":
        given["source"] = f"{cfg.source} and the options"
    return checked(replace(cfg, **given))
