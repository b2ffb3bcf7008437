"""Recordings → a ``rasc-dataset/1`` folder (:func:`import_bag`, :func:`import_image_folder`).

The manifest is written by :func:`rasc.vision.dataset.write_manifest` (the one writer of
the format); each image carries where it came from (``source``: topic, header stamp,
receive time; a pose image also the still moment it was taken in), and the manifest's
``provenance`` names the recordings (path, format, size), the topics, joints, thresholds
and the rasc version. The folder is built under a temporary name beside ``out`` and
renamed into place at the end (:func:`building`): a refused recording leaves nothing.
"""

from __future__ import annotations

import contextlib
import csv
import os
import shutil
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import numpy as np

from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.io import finite_number
from rasc.recordings.bag import BagScan, decode_image, read_images, scan
from rasc.recordings.config import ImportConfig
from rasc.recordings.still import common_still, longest_run_ns, nearest
from rasc.vision.dataset import MIN_POSE_VIEWS, write_manifest


@dataclass(frozen=True)
class Capture:
    """One still moment: its view name, the moment (first, last reading, ns), the angles
    per eye (median of the readings in the moment, in the config's angle unit) and per
    eye the index of the chosen image in its topic's stamps."""

    view: str
    still: tuple[int, int]
    angles: dict[str, tuple[float, float]]
    image: dict[str, int]


@dataclass
class ImportResult:
    """What an import wrote: the folder, the counts, the warnings, the bytes of the
    recordings read and the time it took."""

    out: Path
    n_pose: int
    n_intrinsics: int
    warnings: list[str] = field(default_factory=list)
    bytes_read: int = 0
    seconds: float = 0.0


def plan_captures(sc: BagScan, cfg: ImportConfig) -> tuple[list[Capture], list[str]]:
    """The captures of a scanned bag: the common still moments of the four joints, each
    with the image of each eye nearest its middle, inside it and within
    ``cfg.tolerance_s``; still moments without such an image are skipped (warned). Raises
    when there is no still moment, or fewer than MIN_POSE_VIEWS captures."""
    thr = cfg.threshold_value
    min_ns = int(round(cfg.min_duration_s * 1e9))
    series = [sc.joints[(eye, axis)] for eye in EYES for axis in ("pan", "tilt")]
    moments = common_still(series, thr, min_ns)
    where = f"{sc.path}"
    if not moments:
        longest = {f"{eye} {axis}": longest_run_ns(*sc.joints[(eye, axis)], thr)
                   for eye in EYES for axis in ("pan", "tilt")}
        worst = min(longest, key=longest.get)
        raise InputError(f"{where}: no still moment: the joints never stayed within "
                         f"{thr:g} {cfg.angle_unit} for {cfg.min_duration_s:g} s together "
                         f"(the {worst} reading: at most {longest[worst] / 1e9:.3g} s); "
                         "raise still.threshold or lower still.min_duration_s")
    stamps = {}
    order = {}
    for eye in EYES:
        t = sc.images[eye].times(cfg.stamp)
        order[eye] = np.argsort(t, kind="stable")
        stamps[eye] = t[order[eye]]
    tol = int(round(cfg.tolerance_s * 1e9))
    captures: list[Capture] = []
    warnings: list[str] = []
    for a, b in moments:
        mid = (a + b) // 2
        chosen = {}
        for eye in EYES:
            k = nearest(stamps[eye], mid, a, b, tol)
            if k is None:
                warnings.append(f"{where}: still moment {(a - moments[0][0]) / 1e9:.3f}-"
                                f"{(b - moments[0][0]) / 1e9:.3f} s (from the first) has no "
                                f"{eye} image within it and {cfg.tolerance_s:g} s of its "
                                "middle: skipped")
                break
            chosen[eye] = int(order[eye][k])
        else:
            angles = {}
            for eye in EYES:
                vals = []
                for axis in ("pan", "tilt"):
                    t, v = sc.joints[(eye, axis)]
                    sel = (t >= a) & (t <= b)
                    vals.append(float(np.median(v[sel])))
                angles[eye] = (vals[0], vals[1])
            captures.append(Capture(view=f"{len(captures):02d}", still=(a, b), angles=angles,
                                    image=chosen))
    if len(captures) < MIN_POSE_VIEWS:
        raise InputError(f"{where}: {len(captures)} still moment(s) with images of both eyes "
                         f"({len(moments)} still moments in all); hand-eye needs at least "
                         f"{MIN_POSE_VIEWS} at positions that turn about two different axes")
    return captures, warnings


def plan_intrinsics(sc: BagScan, cfg: ImportConfig) -> dict[str, list[int]]:
    """Per eye, the images of an intrinsics recording kept: the first, then each at least
    ``cfg.interval_s`` after the one kept before (0: every image)."""
    out = {}
    step = int(round(cfg.interval_s * 1e9))
    for eye in EYES:
        t = sc.images[eye].times(cfg.stamp)
        keep, last = [], None
        for k in np.argsort(t, kind="stable"):
            if last is None or t[k] - last >= step:
                keep.append(int(k))
                last = t[k]
        out[eye] = keep
    return out


@dataclass
class ContinuousPlan:
    """What :func:`plan_continuous` keeps of a moving head's recording: per eye the
    topic indices of its images and their times (s from ``origin_ns``, the stamp clock
    the config names), each eye's joint stream (seconds from ``origin_ns``, radians),
    the view of each image (the left and right images nearest in time share one)."""

    images: dict[str, list[int]]
    times: dict[str, list[float]]
    views: dict[str, list[str]]
    stream: object                       # rasc.vision.joint_stream.JointStream
    origin_ns: int
    warnings: list[str] = field(default_factory=list)


def continuous_stream(sc: BagScan, cfg: ImportConfig, origin_ns: int):
    """The joint stream of a scanned bag (:class:`rasc.vision.joint_stream.JointStream`):
    per eye its pan and tilt readings (which must come in the same messages), times in
    seconds from ``origin_ns``, angles in radians. Refused in one line naming the bag and
    topic: a reading at the time of the one before it, or pan and tilt apart."""
    from rasc.vision.joint_stream import JointStream

    k = 1.0 if cfg.angle_unit == "rad" else np.pi / 180.0
    arrays = {}
    for eye in EYES:
        (tp, pan), (tt, tilt) = sc.joints[(eye, "pan")], sc.joints[(eye, "tilt")]
        topic = cfg.joints[eye].topic
        if len(tp) != len(tt) or np.any(tp != tt):
            raise InputError(f"{sc.path}: {topic}: the {eye} pan and tilt readings are not "
                             "in the same messages; --continuous needs both in each")
        same = np.flatnonzero(np.diff(tp) <= 0)
        if len(same):
            raise InputError(f"{sc.path}: {topic}: {eye} reading {int(same[0]) + 1} has the "
                             "time of the one before it (a joint stream's times must "
                             "increase; --stamp bag uses the receive times)")
        arrays[eye] = ((tp - origin_ns) / 1e9, k * pan, k * tilt)
    return JointStream.from_arrays(arrays, f"{sc.path}: joint stream")


def plan_continuous(sc: BagScan, cfg: ImportConfig) -> ContinuousPlan:
    """A head that never stops (``rasc import --continuous``): every image of each eye
    inside its joint stream's span is kept with its time; the images outside it have no
    readings and are left out (warned). The left and right images nearest in time (within
    ``cfg.tolerance_s``) share a view id (loop closure pairs them). Refused when an eye
    keeps fewer than MIN_POSE_VIEWS images."""
    origin = min(int(sc.joints[(eye, "pan")][0][0]) for eye in EYES)
    stream = continuous_stream(sc, cfg, origin)
    images, times, warnings = {}, {}, []
    for eye in EYES:
        t = (sc.images[eye].times(cfg.stamp) - origin) / 1e9
        lo, hi = stream[eye].time[0], stream[eye].time[-1]
        order = np.argsort(t, kind="stable")
        inside = [int(k) for k in order if lo <= t[k] <= hi]
        left_out = len(t) - len(inside)
        if left_out:
            warnings.append(f"{sc.path}: {left_out} {eye} image(s) outside the joint "
                            f"stream ({lo:.3f} to {hi:.3f} s from its first reading) have no "
                            "readings: left out")
        if len(inside) < MIN_POSE_VIEWS:
            raise InputError(f"{sc.path}: {len(inside)} {eye} image(s) within the joint "
                             f"stream; a calibration needs at least {MIN_POSE_VIEWS}")
        images[eye], times[eye] = inside, [float(t[k]) for k in inside]
    # views: each left image, and the right image nearest it (within the tolerance)
    views = {eye: [f"{eye[0]}{n:04d}" for n in range(len(images[eye]))] for eye in EYES}
    tr = np.array(times["right"])
    for n, tl in enumerate(times["left"]):
        m = int(np.argmin(np.abs(tr - tl)))
        if abs(tr[m] - tl) <= cfg.tolerance_s and views["right"][m].startswith("r"):
            views["left"][n] = views["right"][m] = f"{n:04d}"
    return ContinuousPlan(images=images, times=times, views=views, stream=stream,
                          origin_ns=origin, warnings=warnings)


@contextlib.contextmanager
def building(out: str | os.PathLike) -> Iterator[Path]:
    """A temporary folder beside ``out`` to build it in; renamed to ``out`` when the block
    ends without error, removed otherwise (:func:`rasc.io.folder_built_atomically`).
    ``out`` must not exist, or be an empty folder."""
    from rasc.io import folder_built_atomically

    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError(f"{out}: exists and is not an empty folder; an import never "
                         "replaces files: name a new folder")
    with folder_built_atomically(out) as tmp:
        yield tmp


def _write_image(folder: Path, rel: str, pixels, ext: str) -> str:
    import cv2

    rel = rel + ext
    path = folder / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(pixels, bytes):
        path.write_bytes(pixels)
    elif not cv2.imwrite(str(path), pixels, [cv2.IMWRITE_PNG_COMPRESSION, 1]):
        raise InputError(f"{path}: cannot write the image")
    return rel


def _recording(sc: BagScan) -> dict:
    return {"path": str(sc.path), "format": sc.format, "size_bytes": sc.size_bytes}


class _OneSize:
    """The images of each eye must share one size: checked image by image as the import
    writes them, each refusal naming the recording's message or CSV line (``where``) of
    the image and of the first of its eye, never the temporary folder."""

    def __init__(self) -> None:
        self.first: dict[str, tuple[tuple[int, int], str]] = {}

    def add(self, eye: str, file: Path, where: str,
            pixels: np.ndarray | None = None) -> None:
        """Check the image at ``file`` (its header; ``pixels``: its array, when at hand)."""
        from rasc.vision.dataset import _problem
        from rasc.vision.images import image_size

        if pixels is not None:
            size = (int(pixels.shape[1]), int(pixels.shape[0]))
        else:
            try:
                size = image_size(file)
            except InputError as exc:
                raise InputError(f"{where}: {_problem(exc, file)}") from None
        if eye not in self.first:
            self.first[eye] = (size, where)
        elif size != self.first[eye][0]:
            (w0, h0), first = self.first[eye]
            raise InputError(f"{where}: the {eye} image is {size[0]}x{size[1]} but the first "
                             f"{eye} image ({first}) is {w0}x{h0}: all {eye} images must have "
                             "one size")


def _final_check(tmp: Path, board, images: list[dict], wheres: list[str], **manifest) -> None:
    """Write the manifest into ``tmp`` and read the dataset back (one size per eye, every
    image readable). A refusal names the image's source (``wheres[k]``: the bag's topic
    and message, the CSV's line) in place of ``images[k]`` of the temporary folder's
    manifest, which is removed with the folder."""
    import re

    from rasc.vision.dataset import load_dataset

    try:
        write_manifest(tmp, board, images, **manifest)
        load_dataset(tmp).validate()
    except InputError as exc:
        msg = str(exc)
        m = re.match(rf"{re.escape(str(tmp))}\S*: images\[(\d+)\](?: \([^)]*\))?: ", msg)
        if m:
            msg = f"{wheres[int(m.group(1))]}: {msg[m.end():]}"
        msg = re.sub(r"images\[(\d+)\]", lambda g: wheres[int(g.group(1))]
                     if int(g.group(1)) < len(wheres) else g.group(0), msg)
        msg = msg.replace(f"{tmp}{os.sep}manifest.json", "the imported manifest")
        raise InputError(msg.replace(str(tmp), "the imported dataset")) from None


def import_bag(bag: str | os.PathLike, out: str | os.PathLike, cfg: ImportConfig, *,
               intrinsics: str | os.PathLike | None = None, quiet: bool = True,
               log: Callable[[str], None] = lambda s: None,
               continuous: bool = False) -> ImportResult:
    """Import the still moments of ``bag`` as pose views (and the images of the
    ``intrinsics`` recording as intrinsics views) into the new dataset folder ``out``.

    ``continuous``: a head that never stops (:func:`plan_continuous`): every image inside
    the joint stream is a pose view with its ``time``, its pan/tilt the stream at that
    time, and the stream is written as the dataset's ``joints.csv`` (the manifest's
    ``joint_stream``): ``rasc calibrate`` then estimates the clocks' offset."""
    from rasc import __version__
    from rasc.progress import progress

    t0 = time.perf_counter()
    cfg.require(joints=True)
    board = cfg.target()
    bag = Path(bag)
    jobs: list[tuple[BagScan, str, list[tuple[str, str, int, int]], list[dict]]] = []
    warnings: list[str] = []
    scans = []
    for path, role in ((bag, "pose"), *(((Path(intrinsics), "intrinsics"),)
                                        if intrinsics is not None else ())):
        with progress(desc=f"scan {path.name}", quiet=quiet, unit="msg") as bar:
            sc = scan(path, cfg, joints=role == "pose", bar=bar)
        scans.append(sc)
        wanted, entries = [], []
        if role == "pose" and continuous:
            plan = plan_continuous(sc, cfg)
            warnings += plan.warnings
            k_unit = 1.0 if cfg.angle_unit == "rad" else 180.0 / np.pi
            for eye in EYES:
                tt = sc.images[eye]
                read = k_unit * plan.stream[eye].angles(np.array(plan.times[eye]))
                for n, (k, t) in enumerate(zip(plan.images[eye], plan.times[eye],
                                               strict=True)):
                    wanted.append((f"{path}: {tt.topic} message {k}", tt.topic,
                                   tt.stamps[k], tt.received[k]))
                    entries.append({"file": f"poses/{eye}_{n:04d}", "eye": eye,
                                    "role": "pose", "pan": float(read[n, 0]),
                                    "tilt": float(read[n, 1]), "view": plan.views[eye][n],
                                    "time": t,
                                    "source": {"recording": len(scans) - 1, "topic": tt.topic,
                                               "stamp_ns": tt.stamps[k],
                                               "received_ns": tt.received[k]}})
            log(f"{path}: {len(plan.images['left'])} left and {len(plan.images['right'])} "
                "right images within the joint stream (continuous)")
        elif role == "pose":
            captures, w = plan_captures(sc, cfg)
            warnings += w
            log(f"{path}: {len(captures)} captures (still moments with images of both eyes)")
            for c in captures:
                for eye in EYES:
                    tt, k = sc.images[eye], c.image[eye]
                    wanted.append((f"{path}: {tt.topic} message {k}", tt.topic,
                                   tt.stamps[k], tt.received[k]))
                    entries.append({"file": f"poses/{eye}_{c.view}", "eye": eye, "role": "pose",
                                    "pan": c.angles[eye][0], "tilt": c.angles[eye][1],
                                    "view": c.view,
                                    "source": {"recording": len(scans) - 1, "topic": tt.topic,
                                               "stamp_ns": tt.stamps[k],
                                               "received_ns": tt.received[k],
                                               "still_ns": list(c.still)}})
        else:
            keep = plan_intrinsics(sc, cfg)
            for eye in EYES:
                tt = sc.images[eye]
                if len(keep[eye]) < 3:
                    raise InputError(f"{path}: {len(keep[eye])} {eye} image(s) at least "
                                     f"{cfg.interval_s:g} s apart; intrinsics need at least 3 "
                                     "views of the board (lower intrinsics.interval_s?)")
                for n, k in enumerate(keep[eye]):
                    wanted.append((f"{path}: {tt.topic} message {k}", tt.topic,
                                   tt.stamps[k], tt.received[k]))
                    entries.append({"file": f"intrinsics/{eye}_{n:03d}", "eye": eye,
                                    "role": "intrinsics",
                                    "source": {"recording": len(scans) - 1, "topic": tt.topic,
                                               "stamp_ns": tt.stamps[k],
                                               "received_ns": tt.received[k]}})
            log(f"{path}: {len(keep['left'])} left and {len(keep['right'])} right "
                "intrinsics images")
        jobs.append((sc, role, wanted, entries))
    placed: list[tuple[dict, str]] = []
    sizes = _OneSize()
    with building(out) as tmp:
        for sc, _role, wanted, entries in jobs:
            with progress(total=len(wanted), desc=f"images {sc.path.name}", quiet=quiet) as bar:
                for i, msg, msgtype in read_images(sc.path, wanted, progress=bar.update):
                    where = wanted[i][0]
                    pixels, ext = decode_image(msg, msgtype, where)
                    entries[i]["file"] = _write_image(tmp, entries[i]["file"], pixels, ext)
                    sizes.add(entries[i]["eye"], tmp / entries[i]["file"], where,
                              None if isinstance(pixels, bytes) else pixels)
            placed += [(e, w[0]) for e, w in zip(entries, wanted, strict=True)]
        # intrinsics first, as rasc render writes them
        placed.sort(key=lambda ew: (ew[0]["role"] != "intrinsics",))
        images = [e for e, _ in placed]
        provenance = {"tool": f"rasc import (rasc {__version__})",
                      "recordings": [_recording(sc) for sc in scans],
                      **cfg.to_dict()}
        stream_file = None
        if continuous:
            from rasc.vision.joint_stream import JOINTS, format_joint_stream

            (tmp / JOINTS).write_text(format_joint_stream(plan.stream), encoding="utf-8")
            stream_file = JOINTS
            provenance["continuous"] = {
                "time_origin_ns": plan.origin_ns,
                "times": f"seconds from time_origin_ns ({cfg.stamp} stamps); the joint "
                         "stream's on the encoder clock, the images' on the camera clock"}
        _final_check(tmp, board, images, [w for _, w in placed], angle_unit=cfg.angle_unit,
                     length_unit=cfg.length_unit, provenance=provenance,
                     joint_stream=stream_file)
    n_pose = sum(e["role"] == "pose" for e in images)
    return ImportResult(out=Path(out), n_pose=n_pose, n_intrinsics=len(images) - n_pose,
                        warnings=warnings, bytes_read=sum(sc.size_bytes for sc in scans),
                        seconds=time.perf_counter() - t0)


# ------------------------------------------------------------------ image folder + CSV

CSV_COLUMNS = ("file", "eye", "pan", "tilt", "view", "role", "time")


def import_image_folder(folder: str | os.PathLike, csv_path: str | os.PathLike,
                        out: str | os.PathLike, cfg: ImportConfig,
                        joints: str | os.PathLike | None = None) -> ImportResult:
    """A folder of images and a CSV of angles → a dataset folder (images copied).

    CSV (header line; ``file`` and ``eye`` required): ``file`` relative to ``folder``,
    ``eye`` left/right, ``pan``, ``tilt`` (in ``cfg.angle_unit``; both empty for an
    intrinsics view), optional ``view`` (default: the k-th pose row of each eye is view
    k) and ``role`` (default: pose when there are angles, else intrinsics).

    ``joints``: a continuous capture (``rasc import --continuous``): the joint stream, a
    CSV ``time,eye,pan,tilt`` (encoder clock, s; radians: the dataset's ``joints.csv``,
    read by :func:`rasc.vision.joint_stream.read_joint_stream`), and the images' CSV gives
    each pose image's ``time`` (camera clock, s, mid-exposure) instead of its angles: a
    row with a time is a pose image, its pan/tilt the stream at that time."""
    from rasc import __version__

    t0 = time.perf_counter()
    board = cfg.target()
    folder, csv_path = Path(folder), Path(csv_path)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such folder")
    try:
        text = csv_path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"{csv_path}: no such CSV file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{csv_path}: cannot read: {exc}") from None
    rows = list(csv.reader(text.splitlines()))
    if not rows:
        raise InputError(f"{csv_path}: empty (expected a header line: file,eye,pan,tilt)")
    header = [h.strip() for h in rows[0]]
    unknown = [h for h in header if h not in CSV_COLUMNS]
    if unknown:
        raise InputError(f"{csv_path}: line 1: unknown column {unknown[0]!r} (columns: "
                         + ", ".join(CSV_COLUMNS) + ")")
    for need in ("file", "eye"):
        if need not in header:
            raise InputError(f"{csv_path}: line 1: missing column {need!r}")
    stream = None
    if joints is not None:
        from rasc.vision.joint_stream import read_joint_stream

        stream = read_joint_stream(joints)
        if "time" not in header:
            raise InputError(f"{csv_path}: line 1: missing column 'time' (--continuous: "
                             "each pose image's time on the camera clock, s)")
    elif "time" in header:
        raise InputError(f"{csv_path}: line 1: a 'time' column is for a continuous capture: "
                         "give its joint stream with --joints (and --continuous)")
    col = {h: i for i, h in enumerate(header)}
    images: list[dict] = []
    count = {eye: 0 for eye in EYES}
    sources, wheres = [], []
    sizes = _OneSize()
    for lineno, row in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in row):
            continue
        where = f"{csv_path}: line {lineno}"
        if len(row) != len(header):
            raise InputError(f"{where}: {len(row)} fields, the header has {len(header)}")
        get = {h: row[i].strip() for h, i in col.items()}
        rel = PurePosixPath(get["file"].replace("\\", "/"))
        if not get["file"] or rel.is_absolute() or ".." in rel.parts:
            raise InputError(f"{where}: file {get['file']!r} must be a path inside {folder}")
        src = folder / rel
        if not src.is_file():
            raise InputError(f"{where}: file {get['file']!r} does not exist in {folder}")
        eye = get["eye"]
        if eye not in EYES:
            raise InputError(f"{where}: eye must be 'left' or 'right', got {eye!r}")
        angles = [get.get("pan", ""), get.get("tilt", "")]
        t = None
        if stream is not None and get.get("time"):
            t = finite_number(get["time"], f"{where}: time", text=True)
            if any(angles):
                raise InputError(f"{where}: a pose image of a continuous capture has a time, "
                                 "not angles (they come from the joint stream)")
            es = stream[eye]
            if not es.time[0] <= t <= es.time[-1]:
                raise InputError(f"{where}: time {t:g} s lies outside the {eye} joint "
                                 f"stream ({es.time[0]:g} to {es.time[-1]:g} s): no readings")
            k_unit = 1.0 if cfg.angle_unit == "rad" else 180.0 / np.pi
            angles = [repr(float(k_unit * a)) for a in es.angles(np.array([t]))[0]]
        role = get.get("role") or ("pose" if any(angles) else "intrinsics")
        if role not in ("pose", "intrinsics"):
            raise InputError(f"{where}: role must be 'pose' or 'intrinsics', got {role!r}")
        entry = {"file": "", "eye": eye, "role": role,
                 "source": {"file": str(src), "line": lineno}}
        if role == "pose":
            values = []
            for name, v in zip(("pan", "tilt"), angles, strict=True):
                values.append(finite_number(v, f"{where}: {name}", text=True))
            entry["pan"], entry["tilt"] = values
            entry["view"] = get.get("view") or f"{count[eye]:02d}"
            count[eye] += 1
            if t is not None:
                entry["time"] = t
        n = sum(e["eye"] == eye and e["role"] == role for e in images)
        entry["file"] = (f"{'poses' if role == 'pose' else 'intrinsics'}/{eye}_"
                         f"{n:03d}{src.suffix.lower()}")
        sizes.add(eye, src, f"{where} ({get['file']})")
        sources.append(src)
        wheres.append(f"{where} ({get['file']})")
        images.append(entry)
    if not images:
        raise InputError(f"{csv_path}: no rows after the header")
    with building(out) as tmp:
        for entry, src in zip(images, sources, strict=True):
            dst = tmp / entry["file"]
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, dst)
        stream_file = None
        if stream is not None:
            from rasc.vision.joint_stream import JOINTS, format_joint_stream

            (tmp / JOINTS).write_text(format_joint_stream(stream), encoding="utf-8")
            stream_file = JOINTS
        _final_check(tmp, board, images, wheres, angle_unit=cfg.angle_unit,
                     length_unit=cfg.length_unit, joint_stream=stream_file,
                     provenance={"tool": f"rasc import (rasc {__version__})",
                                 "recordings": [{"path": str(folder), "format": "images + CSV",
                                                 "csv": str(csv_path),
                                                 **({"joints": str(joints)}
                                                    if joints is not None else {})}]})
    n_pose = sum(e["role"] == "pose" for e in images)
    return ImportResult(out=Path(out), n_pose=n_pose, n_intrinsics=len(images) - n_pose,
                        bytes_read=sum(s.stat().st_size for s in sources),
                        seconds=time.perf_counter() - t0)
