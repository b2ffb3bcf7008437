"""What ``rasc import`` needs to know about a recording: topics, joints, board, thresholds.

From a small TOML file (read with :mod:`tomllib`) and/or options (options win)::

    stamp = "header"                  # "header" (sensor time, default) or "bag" (receive time)

    [board]                           # the target: a chessboard ...
    inner_corners = [9, 6]
    square_size = 0.05
    length_unit = "m"                 # optional: the unit of the target's lengths

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

``[board]`` holds any target as a dataset manifest's ``board`` object names it
(:func:`rasc.vision.board.board_from_dict`): a chessboard as above, ``type =
"charuco"`` with ``squares``, ``square_size``, ``marker_size`` (``dictionary``,
``legacy_pattern``), ``type = "aprilgrid"`` with ``tags``, ``tag_size`` (``tag_spacing``,
``family``), or Kalibr's fields (``target_type = "aprilgrid"``, ``tagCols``, ...). In its
place, ``target = "SPEC"`` (top level) takes the form ``rasc render --target`` reads
(:func:`rasc.vision.board.parse_target`): ``charuco:12x9,0.06,0.045``,
``aprilgrid:7x5,0.08,0.3``, or a Kalibr target yaml / JSON board file, a relative path
read from the configuration file's folder.

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

#: the keys of each table (``[board]``'s are the target's, checked by its reader)
_KEYS = {"": {"stamp", "board", "target", "topics", "joints", "still", "intrinsics"},
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
    unit and target (options or a TOML file). ``board``: the target, as the manifest's
    ``board`` object names it (any target :func:`rasc.vision.board.board_from_dict`
    reads, e.g. ``{"inner_corners": [9, 6], "square_size": 0.05}`` or ``{"type":
    "charuco", ...}``), or a target object (:class:`rasc.vision.board.CharucoBoard`, ...)."""
    board: Any = None                            # a board object (dict) or a target
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
        self.target()
        for eye in EYES:
            if eye not in self.topics:
                raise InputError(f"{where}: no image topic for the {eye} eye ([topics] {eye} "
                                 f"or --{eye}-topic)")
            if joints and eye not in self.joints:
                raise InputError(f"{where}: no pan/tilt readings for the {eye} eye ([joints] "
                                 f"{eye} = {{topic, pan, tilt}} or --{eye}-joints "
                                 "TOPIC:PAN,TILT)")

    def target(self):
        """The target (:data:`rasc.vision.board.Target`) of :attr:`board`, checked by the
        one reader of targets (:func:`rasc.vision.board.board_from_dict`); refused in one
        line naming :attr:`source` when there is none or it is not a target."""
        from rasc.vision.board import board_from_dict

        if self.board is None:
            raise InputError(f"{self.source}: no target: give [board] (e.g. inner_corners "
                             "and square_size) or target = \"SPEC\" (or --board NXxNY "
                             "--square-size S, or --target SPEC)")
        if hasattr(self.board, "to_dict") and hasattr(self.board, "object_points"):
            return self.board
        return board_from_dict(self.board, f"{self.source}: board")

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
    """A ``[board]`` table (without ``length_unit``): any target's board object, read by
    :func:`rasc.vision.board.board_from_dict` (the manifest's reader), as its manifest
    dict."""
    from rasc.vision.board import board_from_dict

    return board_from_dict(value, where).to_dict()


def parse_target_key(value, where: str, folder: Path):
    """``target = "SPEC"``: :func:`rasc.vision.board.parse_target`'s forms, a relative
    file path read from ``folder`` (the configuration file's); the target's manifest
    dict."""
    from rasc.vision.board import TARGET_TYPES, parse_target

    text = _text(value, where).strip()
    kind, sep, _ = text.partition(":")
    if not (sep and kind in TARGET_TYPES) and not Path(text).is_absolute():
        if not (folder / text).is_file():
            raise InputError(f"{where} {text!r}: no such file beside the configuration (in "
                             f"{folder}); expected chessboard:NXxNY,SQUARE, charuco:SXxSY,"
                             "SQUARE,MARKER[,...], aprilgrid:COLSxROWS,TAGSIZE[,...], a "
                             "Kalibr target yaml or a JSON board file")
        text = str(folder / text)
    return parse_target(text, where).to_dict()


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
    if "board" in data and "target" in data:
        raise InputError(f"{where}: [board] and target both name the target: give one")
    if "board" in data:
        if not isinstance(data["board"], dict):
            raise InputError(f"{where}: [board] must be a table")
        board = dict(data["board"])
        if "length_unit" in board:
            cfg["length_unit"] = _text(board.pop("length_unit"), f"{where}: board.length_unit")
        cfg["board"] = parse_board(board, f"{where}: board")
    if "target" in data:
        cfg["board"] = parse_target_key(data["target"], f"{where}: target", path.parent)
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
