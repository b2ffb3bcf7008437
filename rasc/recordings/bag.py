"""ROS 1 and ROS 2 bags (SQLite3, MCAP) read with ``rosbags`` (no ROS install).

Two passes. :func:`scan` reads every message of the named topics once: the header stamps
of the images (parsed from the first bytes of the serialized message, without
deserializing the pixels) and the named joints' readings (sensor_msgs/JointState,
deserialized), and checks the clocks. :func:`read_images` then reads back only the
images a capture uses, by their receive time, and decodes them (:func:`decode_image`).

Every problem is one :class:`~rasc.errors.InputError` naming the bag, the topic and,
where there is one, the message's position in its topic.
"""

from __future__ import annotations

import contextlib
import os
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rasc.errors import InputError
from rasc.recordings.config import CLOCK_JUMP_S, ImportConfig

IMAGE = "sensor_msgs/msg/Image"
COMPRESSED = "sensor_msgs/msg/CompressedImage"
JOINT_STATE = "sensor_msgs/msg/JointState"

#: raw encodings read (sensor_msgs/image_encodings): name → (dtype, channels, conversion
#: to what is written: None keeps the pixels, else an OpenCV colour conversion code name)
RAW_ENCODINGS = {
    "mono8": ("u1", 1, None), "8UC1": ("u1", 1, None),
    "mono16": ("u2", 1, None), "16UC1": ("u2", 1, None),
    "bgr8": ("u1", 3, None), "8UC3": ("u1", 3, None), "rgb8": ("u1", 3, "COLOR_RGB2BGR"),
    "bgra8": ("u1", 4, "COLOR_BGRA2BGR"), "rgba8": ("u1", 4, "COLOR_RGBA2BGR"),
    "bayer_rggb8": ("u1", 1, "COLOR_BayerRG2BGR"), "bayer_bggr8": ("u1", 1, "COLOR_BayerBG2BGR"),
    "bayer_gbrg8": ("u1", 1, "COLOR_BayerGB2BGR"), "bayer_grbg8": ("u1", 1, "COLOR_BayerGR2BGR"),
}
#: compressed formats read: the file extension the bytes are kept under
COMPRESSED_FORMATS = {"jpeg": ".jpg", "jpg": ".jpg", "png": ".png"}


def bag_format(path: Path) -> str:
    """"rosbag1", "rosbag2 (sqlite3)" or "rosbag2 (mcap)" by the files; InputError else."""
    if path.is_file() and path.suffix == ".bag":
        return "rosbag1"
    if path.is_dir() and (path / "metadata.yaml").is_file():
        if any(path.glob("*.mcap")):
            return "rosbag2 (mcap)"
        return "rosbag2 (sqlite3)"
    if not path.exists():
        raise InputError(f"{path}: no such bag")
    raise InputError(f"{path}: not a bag (a ROS 1 bag is a .bag file; a ROS 2 bag is a "
                     "folder with metadata.yaml and .db3 or .mcap files)")


def bag_bytes(path: Path) -> int:
    """The size of the bag's files."""
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def _corrupt(path: Path, exc: BaseException) -> InputError:
    why = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return InputError(f"{path}: cannot read the bag (truncated or corrupt? a ROS 1 bag whose "
                      f"recording was cut off needs 'rosbag reindex'): {why}")


@contextlib.contextmanager
def open_bag(path: Path) -> Iterator:
    """rosbags' AnyReader, opened; its errors (and a truncated file's) as one line."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise InputError(f"{path}: reading bags needs the rosbags library: pip install "
                         "'rasc[ros]'") from None

    bag_format(path)
    store = get_typestore(Stores.ROS2_HUMBLE)
    try:
        reader = AnyReader([path], default_typestore=store)
        reader.open()
    except (KeyboardInterrupt, InputError):
        raise
    except Exception as exc:      # rosbags' errors, sqlite3, struct, EOF, YAML: all "corrupt"
        raise _corrupt(path, exc) from None
    try:
        yield reader
    finally:
        with contextlib.suppress(Exception):
            reader.close()


def messages(reader, path: Path, connections, start=None, stop=None) -> Iterator:
    """reader.messages(...), with a read error (a truncated chunk) as one line."""
    it = reader.messages(connections=connections, start=start, stop=stop)
    while True:
        try:
            item = next(it)
        except StopIteration:
            return
        except KeyboardInterrupt:
            raise
        except Exception as exc:
            raise _corrupt(path, exc) from None
        yield item


def header_stamp(raw: bytes | memoryview, ros2: bool) -> int:
    """The header stamp (ns) of a serialized message that starts with std_msgs/Header
    (Image, CompressedImage, JointState): ROS 1 ``seq u32, sec u32, nsec u32``; CDR a
    4-byte encapsulation header (byte 1: 1 little-endian, 0 big-endian), ``sec i32,
    nanosec u32``."""
    if ros2:
        order = "<" if raw[1] == 1 else ">"
        sec, nsec = struct.unpack_from(order + "iI", raw, 4)
    else:
        _, sec, nsec = struct.unpack_from("<III", raw, 0)
    return sec * 1_000_000_000 + nsec


@dataclass
class TopicTimes:
    """One topic's messages: header stamps and receive times (ns), in reading order."""

    topic: str
    msgtype: str
    stamps: list[int] = field(default_factory=list)
    received: list[int] = field(default_factory=list)

    def times(self, stamp: str) -> np.ndarray:
        """The topic's message times in nanoseconds: header stamps (``stamp='header'``) or
        receive times."""
        return np.array(self.stamps if stamp == "header" else self.received, dtype=np.int64)


@dataclass
class BagScan:
    """What :func:`scan` found: per eye its image topic's times, per eye and joint
    (pan, tilt) the readings' times and values, the bag's size and format."""

    path: Path
    format: str
    size_bytes: int
    images: dict[str, TopicTimes]
    joints: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]
    joint_topics: dict[str, TopicTimes]
    seconds: float = 0.0


def _connections(reader, path: Path, topic: str, types: tuple[str, ...], what: str):
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        have = sorted({c.topic for c in reader.connections})
        raise InputError(f"{path}: no topic {topic!r} ({what}); the bag has: "
                         + (", ".join(have) if have else "no topics"))
    bad = [c.msgtype for c in conns if c.msgtype not in types]
    if bad:
        raise InputError(f"{path}: topic {topic} is {bad[0]}, expected "
                         + " or ".join(types) + f" ({what})")
    return conns


def scan(path: str | os.PathLike, cfg: ImportConfig, *, joints: bool = True,
         bar=None) -> BagScan:
    """Pass 1 (module docstring): stamps of the images, the joints' readings, clock checks.
    ``bar``: a progress bar (:func:`rasc.progress.progress`), counting the messages."""
    import time

    path = Path(path)
    t0 = time.perf_counter()
    fmt = bag_format(path)
    with open_bag(path) as reader:
        ros2 = reader.is2
        conn_of: dict[int, tuple[str, str]] = {}      # connection id → (kind, topic)
        image_times: dict[str, TopicTimes] = {}
        conns = []
        for eye, topic in cfg.topics.items():
            cs = _connections(reader, path, topic, (IMAGE, COMPRESSED), f"{eye} images")
            image_times[eye] = TopicTimes(topic, cs[0].msgtype)
            for c in cs:
                conn_of[id(c)] = ("image", topic)
            conns += cs
        joint_times: dict[str, TopicTimes] = {}
        if joints:
            for eye, src in cfg.joints.items():
                if src.topic in joint_times:
                    continue
                cs = _connections(reader, path, src.topic, (JOINT_STATE,), f"{eye} pan/tilt")
                joint_times[src.topic] = TopicTimes(src.topic, JOINT_STATE)
                for c in cs:
                    conn_of[id(c)] = ("joints", src.topic)
                conns += cs
        # readings per (topic, joint name)
        wanted: dict[str, set[str]] = {}
        for src in (cfg.joints.values() if joints else ()):
            wanted.setdefault(src.topic, set()).update((src.pan, src.tilt))
        readings: dict[tuple[str, str], tuple[list[int], list[float]]] = {
            (t, n): ([], []) for t, names in wanted.items() for n in names}
        names_seen: dict[str, set[str]] = {t: set() for t in wanted}
        topic_of_image = {tt.topic: tt for tt in image_times.values()}
        if bar is not None:
            bar.total = sum(getattr(c, "msgcount", 0) for c in conns) or None
            bar.refresh()
        for conn, received, raw in messages(reader, path, conns):
            kind, topic = conn_of[id(conn)]
            if kind == "image":
                tt = topic_of_image[topic]
                try:
                    stamp = header_stamp(raw, ros2)
                except struct.error:
                    raise InputError(f"{path}: {topic} message {len(tt.stamps)}: too short "
                                     "for a header (truncated?)") from None
                tt.stamps.append(stamp)
                tt.received.append(received)
            else:
                tt = joint_times[topic]
                try:
                    msg = reader.deserialize(raw, conn.msgtype)
                except KeyboardInterrupt:
                    raise
                except Exception as exc:
                    raise InputError(f"{path}: {topic} message {len(tt.stamps)}: cannot "
                                     f"deserialize ({exc})") from None
                stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
                t = stamp if cfg.stamp == "header" else received
                tt.stamps.append(stamp)
                tt.received.append(received)
                names = list(msg.name)
                names_seen[topic].update(names)
                pos = np.asarray(msg.position, dtype=float)
                for n in wanted[topic]:
                    if n in names:
                        k = names.index(n)
                        if k >= len(pos):
                            raise InputError(f"{path}: {topic} message {len(tt.stamps) - 1}: "
                                             f"joint {n!r} has no position")
                        readings[(topic, n)][0].append(t)
                        readings[(topic, n)][1].append(float(pos[k]))
            if bar is not None:
                bar.update(1)
    for tt in [*image_times.values(), *joint_times.values()]:
        check_clock(path, tt, cfg.stamp)
    if cfg.stamp == "header":
        check_clocks_agree(path, [*image_times.values(), *joint_times.values()])
    joint_values: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    for eye, src in (cfg.joints.items() if joints else ()):
        for axis, name in (("pan", src.pan), ("tilt", src.tilt)):
            t, v = readings[(src.topic, name)]
            if not t:
                seen = sorted(names_seen[src.topic])
                raise InputError(f"{path}: {src.topic}: no joint {name!r} ({eye} {axis}); "
                                 "its messages name: " + (", ".join(seen) or "no joints"))
            t = np.array(t, dtype=np.int64)
            order = np.argsort(t, kind="stable")
            joint_values[(eye, axis)] = (t[order], np.array(v)[order])
    return BagScan(path=path, format=fmt, size_bytes=bag_bytes(path), images=image_times,
                   joints=joint_values, joint_topics=joint_times,
                   seconds=time.perf_counter() - t0)


def check_clock(path: Path, tt: TopicTimes, stamp: str) -> None:
    """Refuse a topic without messages; when the header stamps are used (``stamp ==
    "header"``), one whose header stamps are all zero or jump against its receive times
    by more than :data:`~rasc.recordings.config.CLOCK_JUMP_S` between consecutive
    messages."""
    if not tt.stamps:
        raise InputError(f"{path}: topic {tt.topic} has no messages")
    s = np.array(tt.stamps, dtype=np.int64)
    r = np.array(tt.received, dtype=np.int64)
    if stamp == "bag":
        return      # header stamps unused; receive times are in reading order
    if not np.any(s):
        raise InputError(f"{path}: {tt.topic}: every header stamp is zero; import with "
                         "stamp = \"bag\" (--stamp bag) to use the receive times")
    offset = r - s
    if len(offset) > 1:
        step = np.abs(np.diff(offset))
        k = int(np.argmax(step))
        if step[k] > CLOCK_JUMP_S * 1e9:
            raise InputError(
                f"{path}: {tt.topic} message {k + 1}: clock jump: its header stamp moved "
                f"{(s[k + 1] - s[k]) / 1e9:+.3f} s from the message before while the "
                f"receive time moved {(r[k + 1] - r[k]) / 1e9:+.3f} s (more than "
                f"{CLOCK_JUMP_S:g} s apart: a clock reset or step); split the bag there")


def check_clocks_agree(path: Path, topics: list[TopicTimes]) -> None:
    """Refuse header stamps of different topics from clocks more than CLOCK_JUMP_S apart
    (median offset to the receive times): images and readings could not be paired."""
    med = {tt.topic: float(np.median(np.array(tt.received, np.int64)
                                     - np.array(tt.stamps, np.int64))) for tt in topics}
    lo, hi = min(med, key=med.get), max(med, key=med.get)
    if med[hi] - med[lo] > CLOCK_JUMP_S * 1e9:
        raise InputError(f"{path}: the header stamps of {lo} and {hi} come from clocks "
                         f"{(med[hi] - med[lo]) / 1e9:.3g} s apart (against the receive "
                         "times): unsynchronised clocks; import with stamp = \"bag\" "
                         "(--stamp bag)")


def decode_image(msg, msgtype: str, where: str) -> tuple[np.ndarray | bytes, str]:
    """A deserialized image message → (pixels to write as PNG, ".png") for a raw image,
    or (the compressed bytes as they are, ".jpg"/".png") for a compressed one (checked
    to decode). Unknown encodings and short data are one line naming ``where``."""
    import cv2

    from rasc.io import native_stderr_captured

    if msgtype == COMPRESSED:
        fmt = str(msg.format).lower()
        ext = next((e for k, e in COMPRESSED_FORMATS.items() if k in fmt.replace(";", " ")
                    .split()), None)
        if ext is None or "compresseddepth" in fmt:
            raise InputError(f"{where}: compressed format {msg.format!r} is not read "
                             "(jpeg or png)")
        data = bytes(np.asarray(msg.data, dtype=np.uint8))
        # OpenCV's and libpng's own lines on descriptor 2 (a corrupt PNG's "IHDR chunk
        # shall be first") are kept from the user: this line is the message
        with native_stderr_captured():
            try:
                grey = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_GRAYSCALE)
            except cv2.error:
                grey = None
        if grey is None:
            raise InputError(f"{where}: the {ext[1:]} data does not decode (corrupt)")
        return data, ext
    enc = str(msg.encoding)
    if enc not in RAW_ENCODINGS:
        raise InputError(f"{where}: unknown image encoding {enc!r} (read: "
                         + ", ".join(RAW_ENCODINGS) + ")")
    dtype, ch, conv = RAW_ENCODINGS[enc]
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    itemsize = np.dtype(dtype).itemsize
    if h <= 0 or w <= 0 or step < w * ch * itemsize:
        raise InputError(f"{where}: {w}x{h} image with step {step}: not a valid {enc} image")
    data = np.asarray(msg.data, dtype=np.uint8)
    if data.size < h * step:
        raise InputError(f"{where}: {enc} {w}x{h} needs {h * step} bytes, the message has "
                         f"{data.size} (truncated)")
    rows = data[:h * step].reshape(h, step)[:, :w * ch * itemsize]
    order = ">" if getattr(msg, "is_bigendian", 0) else "<"
    px = np.ascontiguousarray(rows).view(order + dtype).reshape((h, w, ch) if ch > 1
                                                                else (h, w))
    px = px.astype(np.dtype(dtype).newbyteorder("="), copy=False)
    if conv is not None:
        px = cv2.cvtColor(px, getattr(cv2, conv))
    return px, ".png"


def read_images(path: Path, wanted: list[tuple[str, str, int, int]], *,
                progress=None) -> Iterator[tuple[int, object, str]]:
    """Pass 2: for each (where, topic, stamp, received) of ``wanted``, the deserialized
    message and its type, read by its receive time; yields (index in wanted, message,
    msgtype)."""
    with open_bag(path) as reader:
        ros2 = reader.is2
        by_topic: dict[str, list] = {}
        for c in reader.connections:
            by_topic.setdefault(c.topic, []).append(c)
        for i, (where, topic, stamp, received) in enumerate(wanted):
            found = None
            for conn, _, raw in messages(reader, path, by_topic[topic], start=received,
                                         stop=received + 1):
                if header_stamp(raw, ros2) == stamp:
                    found = (conn, raw)
                    break
            if found is None:
                raise InputError(f"{where}: the message read in the first pass is gone "
                                 "(the bag changed while it was read?)")
            try:
                msg = reader.deserialize(found[1], found[0].msgtype)
            except KeyboardInterrupt:
                raise
            except Exception as exc:
                raise InputError(f"{where}: cannot deserialize ({exc})") from None
            yield i, msg, found[0].msgtype
            if progress is not None:
                progress(1)
