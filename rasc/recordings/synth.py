"""Recordings of known content, written with ``rosbags``' writers: ROS 1 bags, ROS 2 bags
(SQLite3, MCAP), from a rendered dataset and its known angles.

For tests, benchmarks and the documentation's examples: :func:`write_recording` plays a
``rasc-dataset/1`` folder back as a robot would record it. The head moves from one pose
view to the next (joint readings interpolated linearly, at ``joint_rate_hz``), rests for
``still_s`` at each (readings exactly the view's angles), and both cameras publish at
``image_rate_hz`` throughout: the view's rendered image while the head rests, a flat grey
frame (no board) while it moves, so an importer that picks an image from a motion
gets no corners. Header stamps are the scene time; the bag's receive time lags by
:data:`LATENCY_NS`. :func:`write_intrinsics_recording` writes the intrinsics views, one
every ``interval_s`` per eye, without joint states.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rasc.errors import InputError

#: start of every written recording: 2023-11-14 22:13:20 UTC, in ns (a plausible clock)
T0_NS = 1_700_000_000 * 10**9
#: the bag's receive time lags each header stamp by this (transport latency)
LATENCY_NS = 2_000_000
#: the right camera's stamps lag the left's by this (unsynchronised stereo)
RIGHT_LAG_NS = 3_000_000

KINDS = ("ros1", "ros2-sqlite3", "ros2-mcap")
ENCODINGS = ("mono8", "bgr8", "rgb8", "mono16", "jpeg", "png")
TOPICS = {"left": "/left/image_raw", "right": "/right/image_raw"}
JOINT_TOPIC = "/joint_states"
JOINT_NAMES = {"left": ("left_pan", "left_tilt"), "right": ("right_pan", "right_tilt")}
UNIT_TOPICS = {"left": "/left_ptu/joint_states", "right": "/right_ptu/joint_states"}


@dataclass(frozen=True)
class Played:
    """What :func:`write_recording` wrote: the bag path, the number of captures it holds
    and the pose views in the order played (view name → (pan_l, tilt_l, pan_r, tilt_r),
    radians)."""

    path: Path
    views: dict[str, tuple[float, float, float, float]]


def _typestore(kind: str):
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)


class _BagWriter:
    """One writer interface over rosbags' ROS 1 and ROS 2 writers."""

    def __init__(self, path: Path, kind: str):
        if kind not in KINDS:
            raise InputError(f"kind: expected one of {', '.join(KINDS)}, got {kind!r}")
        self.kind = kind
        self.store = _typestore(kind)
        if kind == "ros1":
            from rosbags.rosbag1 import Writer

            self.writer = Writer(path)
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer

            plugin = StoragePlugin.MCAP if kind == "ros2-mcap" else StoragePlugin.SQLITE3
            self.writer = Writer(path, version=9, storage_plugin=plugin)
        self.writer.open()
        self.connections: dict[str, object] = {}
        self.seq = 0

    def connection(self, topic: str, msgtype: str):
        if topic not in self.connections:
            self.connections[topic] = self.writer.add_connection(topic, msgtype,
                                                                 typestore=self.store)
        return self.connections[topic]

    def header(self, stamp_ns: int, frame_id: str):
        T = self.store.types
        stamp = T["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9,
                                                 nanosec=stamp_ns % 10**9)
        self.seq += 1
        if self.kind == "ros1":
            return T["std_msgs/msg/Header"](seq=self.seq, stamp=stamp, frame_id=frame_id)
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)

    def write(self, topic: str, msgtype: str, msg, time_ns: int) -> None:
        conn = self.connection(topic, msgtype)
        data = (self.store.serialize_ros1(msg, msgtype) if self.kind == "ros1"
                else self.store.serialize_cdr(msg, msgtype))
        self.writer.write(conn, time_ns, data)

    def close(self) -> None:
        self.writer.close()


def image_message(w: _BagWriter, grey: np.ndarray, encoding: str, stamp_ns: int, frame: str):
    """A sensor_msgs/Image (raw encodings) or sensor_msgs/CompressedImage (jpeg, png) of
    an 8-bit grey image; returns (msgtype, message)."""
    import cv2

    T = w.store.types
    header = w.header(stamp_ns, frame)
    if encoding in ("jpeg", "png"):
        ok, buf = cv2.imencode(".jpg" if encoding == "jpeg" else ".png", grey,
                               [cv2.IMWRITE_JPEG_QUALITY, 95] if encoding == "jpeg" else [])
        assert ok
        return "sensor_msgs/msg/CompressedImage", T["sensor_msgs/msg/CompressedImage"](
            header=header, format=encoding, data=np.frombuffer(buf.tobytes(), np.uint8))
    if encoding == "mono8":
        data, step = grey, grey.shape[1]
    elif encoding in ("bgr8", "rgb8"):
        data, step = np.repeat(grey[:, :, None], 3, axis=2), 3 * grey.shape[1]
    elif encoding == "mono16":
        # 8-bit values in the high byte: what OpenCV reads back as 8-bit grey
        data, step = (grey.astype(np.uint16) * 256).astype(">u2"), 2 * grey.shape[1]
    else:
        raise InputError(f"encoding: expected one of {', '.join(ENCODINGS)}, got {encoding!r}")
    h, wd = grey.shape
    return "sensor_msgs/msg/Image", T["sensor_msgs/msg/Image"](
        header=header, height=h, width=wd, encoding=encoding,
        is_bigendian=1 if encoding == "mono16" else 0, step=step,
        data=np.frombuffer(np.ascontiguousarray(data).tobytes(), np.uint8))


def joint_message(w: _BagWriter, names, values, stamp_ns: int):
    """A ``sensor_msgs/JointState`` message for the bag writer ``w``: joint ``names`` at
    ``values`` stamped ``stamp_ns``."""
    T = w.store.types
    return T["sensor_msgs/msg/JointState"](
        header=w.header(stamp_ns, ""), name=list(names),
        position=np.asarray(values, float), velocity=np.zeros(0), effort=np.zeros(0))


def _pose_views(dataset) -> dict[str, dict[str, tuple[str, float, float]]]:
    views: dict[str, dict[str, tuple[str, float, float]]] = {}
    for e in dataset.select(role="pose"):
        views.setdefault(e.view, {})[e.eye] = (str(e.path), e.pan, e.tilt)
    bad = [v for v, d in views.items() if set(d) != {"left", "right"}]
    if bad:
        raise InputError(f"{dataset.manifest_path}: view {bad[0]!r} lacks an eye")
    return dict(sorted(views.items()))


def write_recording(dataset, path: str | os.PathLike, *, kind: str = "ros1",
                    encoding: str = "mono8", joint_rate_hz: float = 100.0,
                    image_rate_hz: float = 5.0, still_s: float = 1.0, move_s: float = 0.6,
                    per_unit: bool = False, angle_unit: str = "rad",
                    positions: int | None = None) -> Played:
    """Play the pose views of ``dataset`` (a :class:`rasc.vision.dataset.Dataset`) into a
    new bag at ``path`` (a ``.bag`` file for ROS 1, a folder for ROS 2).

    ``per_unit``: each unit's readings on its own topic (:data:`UNIT_TOPICS`, joints
    ``pan``, ``tilt``), else all four on :data:`JOINT_TOPIC` (:data:`JOINT_NAMES`).
    ``angle_unit``: the unit of the readings written. ``positions``: how many positions
    to play, the views in turn (default: each view once; more make a larger bag for
    benchmarks, the played names then count the positions)."""
    import cv2

    path = Path(path)
    scale = 1.0 if angle_unit == "rad" else 180.0 / math.pi
    views = _pose_views(dataset)
    images = {v: {eye: cv2.imread(d[eye][0], cv2.IMREAD_GRAYSCALE) for eye in d}
              for v, d in views.items()}
    h, wd = next(iter(images.values()))["left"].shape
    blank = np.full((h, wd), 128, np.uint8)
    w = _BagWriter(path, kind)
    dt_j = int(round(1e9 / joint_rate_hz))
    dt_i = int(round(1e9 / image_rate_hz))
    t = T0_NS
    prev = None
    played: dict[str, tuple[float, float, float, float]] = {}
    try:
        names = list(views)
        for p in range(positions or len(names)):
            for name, d in ((names[p % len(names)], views[names[p % len(names)]]),):
                q = np.array([d["left"][1], d["left"][2], d["right"][1], d["right"][2]])
                segments = [(prev if prev is not None else q, q, move_s, None),
                            (q, q, still_s, name)]
                for q0, q1, dur, view in segments:
                    # (receive time, order, topic, type, message), written in time order
                    out: list[tuple] = []
                    n_j = max(int(round(dur * joint_rate_hz)), 1)
                    for k in range(n_j):
                        ts = t + k * dt_j
                        qk = (q0 + (q1 - q0) * (k / n_j)) if view is None else q1
                        out += _joints(w, qk * scale, ts, per_unit, len(out))
                    n_i = max(int(round(dur * image_rate_hz)), 1)
                    for k in range(n_i):
                        ts = t + k * dt_i + dt_i // 2
                        for eye, lag in (("left", 0), ("right", RIGHT_LAG_NS)):
                            img = blank if view is None else images[view][eye]
                            mt, msg = image_message(w, img, encoding, ts + lag, f"{eye}_camera")
                            out.append((ts + lag + LATENCY_NS, len(out), TOPICS[eye], mt, msg))
                    for time_ns, _, topic, mt, msg in sorted(out, key=lambda m: m[:2]):
                        w.write(topic, mt, msg, time_ns)
                    t += n_j * dt_j
                played[f"{p:03d}:{name}" if positions else name] = tuple(float(x) for x in q)
                prev = q
    finally:
        w.close()
    return Played(path=path, views=played)


def _joints(w: _BagWriter, q: np.ndarray, ts: int, per_unit: bool, order: int) -> list:
    mt = "sensor_msgs/msg/JointState"
    if per_unit:
        return [(ts + LATENCY_NS, order + k, UNIT_TOPICS[eye], mt,
                 joint_message(w, ("pan", "tilt"), q[2 * k:2 * k + 2], ts))
                for k, eye in enumerate(("left", "right"))]
    return [(ts + LATENCY_NS, order, JOINT_TOPIC, mt,
             joint_message(w, (*JOINT_NAMES["left"], *JOINT_NAMES["right"]), q, ts))]


def write_continuous_recording(dataset, path: str | os.PathLike, *, kind: str = "ros1",
                               encoding: str = "mono8", per_unit: bool = False) -> Path:
    """A head that never stops, played into a new bag: ``dataset`` is a continuous capture
    (pose images with times and a joint stream, as ``rasc render`` makes it with
    ``motion_speed_deg_s``): every joint reading of its stream at its encoder-clock stamp
    and every pose image at its camera-clock time, both stamped ``T0_NS`` + their time (so
    the dataset's clock offset δ is the bag's), received :data:`LATENCY_NS` later.
    ``per_unit``: each unit's readings on its own topic (:data:`UNIT_TOPICS`), else one
    message of all four joints per sample (the eyes' samples must share their stamps)."""
    import cv2

    path = Path(path)
    stream = dataset.joint_stream
    if stream is None:
        raise InputError(f"{dataset.manifest_path}: no joint stream (not a continuous capture)")
    mt = "sensor_msgs/msg/JointState"
    w = _BagWriter(path, kind)
    out: list[tuple] = []
    try:
        left, right = stream["left"], stream["right"]
        if per_unit:
            for eye, s in (("left", left), ("right", right)):
                for t, p, q in zip(s.time, s.pan, s.tilt, strict=True):
                    ts = T0_NS + int(round(t * 1e9))
                    out.append((ts + LATENCY_NS, len(out), UNIT_TOPICS[eye], mt,
                                joint_message(w, ("pan", "tilt"), np.array([p, q]), ts)))
        else:
            if not np.array_equal(left.time, right.time):
                raise InputError(f"{dataset.manifest_path}: the eyes' joint samples have "
                                 "their own stamps: play them with per_unit=True")
            for k, t in enumerate(left.time):
                ts = T0_NS + int(round(t * 1e9))
                q = np.array([left.pan[k], left.tilt[k], right.pan[k], right.tilt[k]])
                out.append((ts + LATENCY_NS, len(out), JOINT_TOPIC, mt,
                            joint_message(w, (*JOINT_NAMES["left"], *JOINT_NAMES["right"]),
                                          q, ts)))
        for e in dataset.select(role="pose"):
            ts = T0_NS + int(round(e.time * 1e9))
            img = cv2.imread(str(e.path), cv2.IMREAD_GRAYSCALE)
            mtype, msg = image_message(w, img, encoding, ts, f"{e.eye}_camera")
            out.append((ts + LATENCY_NS, len(out), TOPICS[e.eye], mtype, msg))
        for time_ns, _, topic, mtype, msg in sorted(out, key=lambda m: m[:2]):
            w.write(topic, mtype, msg, time_ns)
    finally:
        w.close()
    return path


def write_intrinsics_recording(dataset, path: str | os.PathLike, *, kind: str = "ros1",
                               encoding: str = "mono8", interval_s: float = 1.0) -> Path:
    """The intrinsics views of ``dataset`` into a new bag, one image per eye every
    ``interval_s`` (left and right at the same moments), no joint states."""
    import cv2

    path = Path(path)
    w = _BagWriter(path, kind)
    entries = {eye: dataset.select(eye=eye, role="intrinsics") for eye in ("left", "right")}
    try:
        for k in range(max(len(v) for v in entries.values())):
            for eye, lag in (("left", 0), ("right", RIGHT_LAG_NS)):
                if k >= len(entries[eye]):
                    continue
                ts = T0_NS + int(round(k * interval_s * 1e9)) + lag
                img = cv2.imread(str(entries[eye][k].path), cv2.IMREAD_GRAYSCALE)
                mt, msg = image_message(w, img, encoding, ts, f"{eye}_camera")
                w.write(TOPICS[eye], mt, msg, ts + LATENCY_NS)
    finally:
        w.close()
    return path
