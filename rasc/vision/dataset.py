"""The dataset format (docs/CONTRACTS.md): a folder with ``manifest.json`` and its images.

::

    {"format": "rasc-dataset/1",
     "board": {"inner_corners": [9, 6], "square_size": 0.05},        (a chessboard, or
              {"type": "charuco", "squares": [12, 9], "square_size": 0.06,
               "marker_size": 0.045, "dictionary": "DICT_5X5_100",
               "legacy_pattern": false}                               a ChArUco board)
     "length_unit": "m",                      (optional: the unit of square_size, echoed)
     "angle_unit": "deg",                                             ("deg" | "rad")
     "images": [
       {"file": "intrinsics/left_000.png", "eye": "left", "role": "intrinsics"},
       {"file": "poses/left_00.png", "eye": "left", "role": "pose",
        "pan": 0.0, "tilt": 0.0, "view": "00"}, ...],
     "ground_truth": "ground_truth.json"}                             (optional)

``role`` "intrinsics": a view of the board for calibrating the eye's intrinsics (the
pan-tilt angles do not matter); "pose": a view at a commanded pan-tilt position (pan,
tilt required), for hand-eye; ``view`` groups the left and right images taken at the same
time of the same board placement (loop closure). Every problem is reported as one
:class:`~rasc.errors.InputError` line naming the manifest, the image index and file, and
the field. Images are read lazily; :meth:`Dataset.validate` reads their headers.

Only reading and detecting need OpenCV (:mod:`rasc.vision.camera`, imported when an image
is first read): the manifest itself is parsed and written with the standard library.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import stat
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import numpy as np

from rasc import formats
from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.io import finite_number, read_json_document, to_jsonable, write_json_atomic
from rasc.vision.board import (
    MIN_INTRINSICS_VIEWS,
    MIN_VIEW_CORNERS,
    Board,
    CharucoBoard,
    board_from_dict,
)

FORMAT = formats.DATASET.tag
MANIFEST = "manifest.json"
ROLES = ("intrinsics", "pose")
ANGLE_UNITS = ("deg", "rad")
#: hand-eye needs at least three positions (two independent relative rotations, docs/METHOD.md §3)
MIN_POSE_VIEWS = 3
#: if the board is found in fewer than this fraction of an eye's images, the board
#: geometry in the manifest is the likely culprit rather than the images
MIN_FOUND_FRACTION = 0.5


@dataclass(frozen=True)
class ImageEntry:
    """One image of the manifest. ``pan``, ``tilt`` in radians (None for intrinsics views)."""

    index: int
    file: str
    path: Path
    eye: str
    role: str
    pan: float | None = None
    tilt: float | None = None
    view: str | None = None


@dataclass
class Detections:
    """Corners found in a group of images: ``corners`` file → (N, 2) canonical order,
    ``not_found`` files without the board, ``entries`` file → :class:`ImageEntry`."""

    corners: dict[str, np.ndarray]
    not_found: list[str]
    entries: dict[str, ImageEntry]


@dataclass
class Dataset:
    """A dataset folder read by :func:`load_dataset`: the board, the angle unit and the
    images with their pan/tilt readings (the format in the module docstring)."""
    root: Path
    manifest_path: Path
    board: Board | CharucoBoard              # the target (rasc.vision.board)
    angle_unit: str
    images: tuple[ImageEntry, ...]
    ground_truth: Path | None = None
    length_unit: str | None = None           # the unit of board.square_size, if stated

    def select(self, eye: str | None = None, role: str | None = None) -> list[ImageEntry]:
        """Images of one eye and/or role, in manifest order."""
        if eye is not None and eye not in EYES:
            raise InputError(f"{self.manifest_path}: unknown eye {eye!r} (use left or right)")
        if role is not None and role not in ROLES:
            raise InputError(f"{self.manifest_path}: unknown role {role!r} "
                             "(use intrinsics or pose)")
        return [e for e in self.images
                if (eye is None or e.eye == eye) and (role is None or e.role == role)]

    def validate(self, decode: bool = False) -> dict[str, tuple[int, int]]:
        """Read every image's header (``decode=True``: the whole image) and check that
        the images of each eye share one size. Returns eye → (width, height)."""
        sizes: dict[str, tuple[int, int]] = {}
        first: dict[str, str] = {}
        for e in self.images:
            size = self._size(e, decode)
            if e.eye not in sizes:
                sizes[e.eye], first[e.eye] = size, e.file
            elif size != sizes[e.eye]:
                a, b = sizes[e.eye], size
                raise InputError(
                    f"{self.manifest_path}: images[{e.index}] ({e.file}) is {b[0]}x{b[1]} but "
                    f"{first[e.eye]} is {a[0]}x{a[1]}: all {e.eye} images must have one size")
        return sizes

    def image_size(self, eye: str) -> tuple[int, int]:
        """(width, height) of an eye's images (checked equal across them)."""
        sizes = self.validate()
        if eye not in sizes:
            raise InputError(f"{self.manifest_path}: no images of the {eye} eye")
        return sizes[eye]

    def read(self, entry: ImageEntry) -> np.ndarray:
        """The image as 8-bit grey (H, W); errors name the manifest index and file."""
        from rasc.vision.camera import read_image

        try:
            return read_image(entry.path)
        except InputError as exc:
            raise InputError(f"{self.manifest_path}: images[{entry.index}] ({entry.file}): "
                             f"{_problem(exc, entry.path)}") from None

    def _size(self, entry: ImageEntry, decode: bool) -> tuple[int, int]:
        if decode:
            h, w = self.read(entry).shape
            return w, h
        from rasc.vision.camera import image_size as read_image_size

        try:
            return read_image_size(entry.path)
        except InputError as exc:
            raise InputError(f"{self.manifest_path}: images[{entry.index}] ({entry.file}): "
                             f"{_problem(exc, entry.path)}") from None

    def detect(self, eye: str, role: str, method: str = "classic",
               order_by: str | None = "colour", min_found: int | None = None,
               board_seen: bool = False, min_corners: int = MIN_VIEW_CORNERS,
               log=None) -> Detections:
        """Detect the board in every image of ``eye`` and ``role``: the one detection path
        of a dataset (the pipeline keeps what it returns).

        A target seen in part (ChArUco) keeps every image with at least ``min_corners``
        corners (NaN rows for the others, :func:`rasc.vision.camera.detect_charuco`); an
        image with fewer is left out like one without the board, and ``log`` (a callable
        taking one line), when given, is told so once per image. Such a target is refused
        only when fewer than ``min_found`` images remain (never for the fraction found:
        wide motions leave the board by design).

        Raises :class:`InputError` when there are no such images, when the board is missing
        from most images (the manifest's ``inner_corners`` is the likely error, unless
        ``board_seen``: other images of this eye already showed the board, so these images
        are the problem) or when fewer than ``min_found`` images show it (default:
        :data:`~rasc.vision.board.MIN_INTRINSICS_VIEWS` for intrinsics,
        :data:`MIN_POSE_VIEWS` for poses).

        An image file whose bytes were detected before in this process, with the same
        board, ``method`` and ``order_by``, is not detected again: see
        :data:`DETECTIONS_KEPT`.
        """
        from rasc.vision.camera import detect_corners

        entries = self.select(eye, role)
        if min_found is None:
            min_found = MIN_INTRINSICS_VIEWS if role == "intrinsics" else MIN_POSE_VIEWS
        where = f"{self.manifest_path}: {eye} {role} images"
        if role == "pose" and len(entries) < min_found:
            raise InputError(f"{where}: {len(entries) or 'none'} in the manifest; hand-eye needs "
                             f"at least {min_found} images with role 'pose' (pan, tilt, "
                             "view) at positions that turn about two different axes")
        if not entries:
            raise InputError(f"{self.manifest_path}: no {role} images of the {eye} eye (role "
                             f"'{role}': views of the board moved in front of the fixed camera)")
        corners: dict[str, np.ndarray] = {}
        not_found: list[str] = []
        partial = getattr(self.board, "partial_views", False)
        for e in entries:
            digest = _content_digest(e.path)
            key = (None if digest is None
                   else (digest, self.board.inner_corners, method, order_by) if not partial
                   else (digest, self.board, method, min_corners))
            found, c = _remembered(key)
            if not found:
                c = detect_corners(self.read(e), self.board, method=method, order_by=order_by,
                                   min_corners=min_corners)
                # kept only if the file still holds the bytes it held before it was read
                if key is not None and _content_digest(e.path) == digest:
                    _remember(key, c)
            if c is None:
                not_found.append(e.file)
                if partial and log is not None:
                    at = "" if e.pan is None else \
                        f" (pan {math.degrees(e.pan):.4g}, tilt {math.degrees(e.tilt):.4g} deg)"
                    log(f"{eye} {role} image {e.file}{at}: fewer than {min_corners} "
                        "corners of the target seen, skipped")
            else:
                corners[e.file] = c
        nx, ny = self.board.inner_corners
        if partial:
            if len(corners) < min_found:
                task = "intrinsics need" if role == "intrinsics" else "hand-eye needs"
                raise InputError(
                    f"{where}: {self.board.describe()} seen with at least {min_corners} "
                    f"corners in {len(corners)} of {len(entries)}; {task} at least "
                    f"{min_found} {need_text(role)}")
            return Detections(corners=corners, not_found=not_found,
                              entries={e.file: e for e in entries})
        need = ("views with the board tilted 20-45 degrees about different axes"
                if role == "intrinsics" else
                "pan-tilt positions with rotations about two different axes")
        if board_seen and len(corners) < min_found:
            other = "pose" if role == "intrinsics" else "intrinsics"
            task = "intrinsics need" if role == "intrinsics" else "hand-eye needs"
            raise InputError(
                f"{where}: board {nx}x{ny} found in {len(corners)} of {len(entries)} (first "
                f"without: {not_found[0]}) though the {other} images show it; {task} at "
                f"least {min_found} {need}, each with the whole board in view")
        if len(corners) < MIN_FOUND_FRACTION * len(entries):
            raise InputError(
                f"{where}: board {nx}x{ny} not found in {len(not_found)} of {len(entries)} "
                f"(first: {not_found[0]}): "
                + ("check those images (the whole board in view, sharp, evenly lit), then "
                   if corners else "")
                + f"check board.inner_corners (inner corners, not squares: a board of "
                f"{nx + 1}x{ny + 1} squares has {nx}x{ny})")
        if len(corners) < min_found:
            raise InputError(
                f"{where}: board found in {len(corners)} of {len(entries)} images; need at "
                f"least {min_found} {need}")
        return Detections(corners=corners, not_found=not_found,
                          entries={e.file: e for e in entries})

    def load_ground_truth(self) -> dict:
        """The optional ground-truth JSON (written by the simulation), as a dict."""
        if self.ground_truth is None:
            raise InputError(f"{self.manifest_path}: no ground_truth file named in the manifest")
        return _read_json(self.ground_truth, "ground truth")

    def to_manifest(self) -> dict:
        """The manifest dict this dataset was read from (angles in its own unit)."""
        return _manifest_dict(self.board, [_entry_dict(e, self.angle_unit) for e in self.images],
                              self.angle_unit,
                              None if self.ground_truth is None
                              else self.ground_truth.relative_to(self.root).as_posix(),
                              self.length_unit)


def need_text(role: str) -> str:
    """What a dataset needs more of for a ``role`` (``intrinsics`` or ``pose``), in words for
    messages."""
    return ("views with the board tilted 20-45 degrees about different axes"
            if role == "intrinsics" else
            "pan-tilt positions with rotations about two different axes")


# ------------------------------------------------------------------ detections kept

#: :meth:`Dataset.detect` keeps, per process, what it found in each image file, keyed by
#: the file's content (SHA-256 of its bytes), the board's inner corners, the detector and
#: the order rule: detection is a deterministic function of these (rasc runs OpenCV's
#: detection on one thread), so the same bytes give the same corners, wherever the file
#: lies. Calibrating a dataset again (other options, a copy of it, the same images in
#: another manifest) detects only the images it has not seen. A result is kept only when
#: the file's bytes are the same after it was read as before; files of another kind
#: (devices, pipes) or larger than :data:`DETECTIONS_KEPT_MAX_BYTES` are never kept. At
#: most :data:`DETECTIONS_KEPT` results (least recently used dropped first, about 1 kB
#: each for a 9x6 board). :func:`forget_detections` empties it.
DETECTIONS_KEPT = 4096
DETECTIONS_KEPT_MAX_BYTES = 64 << 20
_kept: OrderedDict[tuple, np.ndarray | None] = OrderedDict()
_kept_lock = threading.Lock()


def forget_detections() -> None:
    """Empty the detections :meth:`Dataset.detect` keeps (e.g. to time detection)."""
    with _kept_lock:
        _kept.clear()


def _content_digest(path: Path) -> bytes | None:
    """SHA-256 of a regular file of at most DETECTIONS_KEPT_MAX_BYTES; else None."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return None
        with open(path, "rb") as f:
            data = f.read(DETECTIONS_KEPT_MAX_BYTES + 1)
    except OSError:
        return None
    if len(data) > DETECTIONS_KEPT_MAX_BYTES:
        return None
    return hashlib.sha256(data).digest()


def _remembered(key: tuple | None) -> tuple[bool, np.ndarray | None]:
    """(True, a copy of the corners or None) when ``key`` was detected before."""
    if key is None:
        return False, None
    with _kept_lock:
        if key not in _kept:
            return False, None
        _kept.move_to_end(key)
        c = _kept[key]
    return True, None if c is None else c.copy()


def _remember(key: tuple, corners: np.ndarray | None) -> None:
    if corners is not None:
        corners = corners.copy()
        corners.flags.writeable = False
    with _kept_lock:
        _kept[key] = corners
        _kept.move_to_end(key)
        while len(_kept) > DETECTIONS_KEPT:
            _kept.popitem(last=False)


# ------------------------------------------------------------------------- reading

def _problem(exc: Exception, path: Path) -> str:
    """The message of ``exc`` without the leading ``<path>: ``."""
    msg = str(exc)
    prefix = f"{path}: "
    return msg[len(prefix):] if msg.startswith(prefix) else msg


def _read_json(path: Path, what: str = "manifest") -> dict:
    """A JSON object by :func:`rasc.io.read_json_document`'s rules (one reader for every
    input document: duplicate keys, depth, number sizes, NaN, non-regular files)."""
    return read_json_document(path, what)


def _relative_file(value, where: str, field: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"{where}: field {field!r} must be a non-empty file name, got {value!r}")
    p = PurePosixPath(value.replace("\\", "/"))
    if p.is_absolute() or ".." in p.parts:
        raise InputError(f"{where}: field {field!r} must be a path inside the dataset folder, "
                         f"got {value!r}")
    return p.as_posix()


def _parse_board(obj, where: str) -> Board | CharucoBoard:
    if "board" not in obj:
        raise InputError(f"{where}: missing field 'board' "
                         '(e.g. {"inner_corners": [9, 6], "square_size": 0.05})')
    b = obj["board"]
    if not isinstance(b, dict):
        raise InputError(f"{where}: field 'board' must be an object, got {type(b).__name__}")
    if b.get("type", "chessboard") != "chessboard":
        return board_from_dict(b, f"{where}: board")
    for key in ("inner_corners", "square_size"):
        if key not in b:
            raise InputError(f"{where}: board: missing field {key!r}")
    ic = b["inner_corners"]
    if not isinstance(ic, list) or len(ic) != 2 or \
            not all(isinstance(v, int) and not isinstance(v, bool) for v in ic):
        raise InputError(f"{where}: board: 'inner_corners' must be two integers [nx, ny], "
                         f"got {ic!r}")
    try:
        return Board(tuple(ic), b["square_size"])
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def _parse_images(obj, where: str, root: Path, angle_unit: str | None,
                  check_files: bool) -> tuple[ImageEntry, ...]:
    if "images" not in obj:
        raise InputError(f"{where}: missing field 'images'")
    images = obj["images"]
    if not isinstance(images, list) or not images:
        raise InputError(f"{where}: field 'images' must be a non-empty list")
    scale = math.pi / 180.0 if angle_unit == "deg" else 1.0
    entries: list[ImageEntry] = []
    seen_files: dict[str, int] = {}
    seen_views: dict[tuple[str, str], int] = {}
    for k, im in enumerate(images):
        here = f"{where}: images[{k}]"
        if not isinstance(im, dict):
            raise InputError(f"{here}: must be an object, got {type(im).__name__}")
        if "file" not in im:
            raise InputError(f"{here}: missing field 'file'")
        file = _relative_file(im["file"], here, "file")
        here = f"{where}: images[{k}] ({file})"
        for key in ("eye", "role"):
            if key not in im:
                raise InputError(f"{here}: missing field {key!r}")
        if file in seen_files:
            raise InputError(f"{here}: same file as images[{seen_files[file]}]")
        seen_files[file] = k
        eye, role = im["eye"], im["role"]
        if eye not in EYES:
            raise InputError(f"{here}: field 'eye' must be 'left' or 'right', got {eye!r}")
        if role not in ROLES:
            raise InputError(f"{here}: field 'role' must be 'intrinsics' or 'pose', got {role!r}")
        pan = tilt = None
        view = im.get("view")
        if view is not None:
            if isinstance(view, bool) or not isinstance(view, (str, int)) or str(view) == "":
                raise InputError(f"{here}: field 'view' must be a non-empty string, got {view!r}")
            view = str(view)
        if role == "pose":
            for key in ("pan", "tilt", "view"):
                if key not in im:
                    raise InputError(f"{here}: missing field {key!r} (required for role 'pose')")
            if angle_unit is None:
                raise InputError(f"{where}: missing field 'angle_unit' ('deg' or 'rad'), "
                                 "required when there are pose images")
            pan = finite_number(im["pan"], f"{here}: field 'pan'") * scale
            tilt = finite_number(im["tilt"], f"{here}: field 'tilt'") * scale
            for name, a in (("pan", pan), ("tilt", tilt)):
                if abs(a) > 2 * math.pi:
                    raise InputError(f"{here}: field {name!r} = {im[name]!r} {angle_unit} is "
                                     "more than a full turn: is angle_unit right?")
            key2 = (eye, view)
            if key2 in seen_views:
                raise InputError(f"{here}: a second {eye} pose image for view {view!r} "
                                 f"(first: images[{seen_views[key2]}])")
            seen_views[key2] = k
        path = root / file
        if check_files and not path.is_file():
            raise InputError(f"{here}: file does not exist ({path})")
        entries.append(ImageEntry(index=k, file=file, path=path, eye=eye, role=role,
                                  pan=pan, tilt=tilt, view=view))
    return tuple(entries)


def parse_manifest(obj: dict, root: str | os.PathLike, where: str = MANIFEST,
                   check_files: bool = True) -> Dataset:
    """Validate a manifest dict; ``root`` is the dataset folder (image paths are relative)."""
    root = Path(root)
    if not isinstance(obj, dict):
        raise InputError(f"{where}: expected a JSON object, got {type(obj).__name__}")
    if "format" not in obj:
        raise InputError(f"{where}: missing field 'format' (expected {FORMAT!r})")
    if obj["format"] != FORMAT:
        raise InputError(f"{where}: field 'format' is {obj['format']!r}, this reader "
                         f"understands {FORMAT!r}")
    board = _parse_board(obj, where)
    angle_unit = obj.get("angle_unit")
    if angle_unit is not None and angle_unit not in ANGLE_UNITS:
        raise InputError(f"{where}: field 'angle_unit' must be 'deg' or 'rad', "
                         f"got {angle_unit!r}")
    length_unit = obj.get("length_unit")
    if length_unit is not None and (not isinstance(length_unit, str) or not length_unit):
        raise InputError(f"{where}: field 'length_unit' must be a non-empty string (the unit "
                         f"of board.square_size, e.g. \"m\"), got {length_unit!r}")
    images = _parse_images(obj, where, root, angle_unit, check_files)
    gt = obj.get("ground_truth")
    gt_path = None
    if gt is not None:
        gt_path = root / _relative_file(gt, where, "ground_truth")
        if check_files and not os.path.lexists(gt_path):   # the reader words the rest
            raise InputError(f"{where}: field 'ground_truth': file does not exist ({gt_path})")
    return Dataset(root=root, manifest_path=Path(where), board=board,
                   angle_unit=angle_unit or "deg", images=images, ground_truth=gt_path,
                   length_unit=length_unit)


def load_dataset(path: str | os.PathLike) -> Dataset:
    """Read and validate a dataset folder (or its ``manifest.json``); images stay unread."""
    path = Path(path)
    if path.is_dir():
        manifest = path / MANIFEST
    elif path.name.endswith(".json") or path.is_file():
        manifest = path
    else:
        raise InputError(f"{path}: no such dataset folder")
    if not os.path.lexists(manifest):      # a folder, device, FIFO: the reader says which
        raise InputError(f"{manifest}: no manifest (a rasc dataset is a folder with "
                         f"{MANIFEST} and its images)")
    dataset = parse_manifest(_read_json(manifest), manifest.parent, where=str(manifest))
    if dataset.ground_truth is not None:   # a broken ground truth is found now, not at the end
        _read_json(dataset.ground_truth, "ground truth")
    return dataset


# ------------------------------------------------------------------------- writing

def _entry_dict(e: ImageEntry, angle_unit: str) -> dict:
    d = {"file": e.file, "eye": e.eye, "role": e.role}
    if e.view is not None:
        d["view"] = e.view
    if e.role == "pose":
        scale = 180.0 / math.pi if angle_unit == "deg" else 1.0
        d["pan"], d["tilt"] = e.pan * scale, e.tilt * scale
    return d


def _manifest_dict(board: Board | dict, images: list[dict], angle_unit: str,
                   ground_truth: str | None, length_unit: str | None = None) -> dict:
    obj = {"format": FORMAT, "board": board.to_dict() if hasattr(board, "to_dict") else board,
           **({} if length_unit is None else {"length_unit": length_unit}),
           "angle_unit": angle_unit, "images": images}
    if ground_truth is not None:
        obj["ground_truth"] = ground_truth
    return obj


def write_manifest(path: str | os.PathLike, board: Board | dict, images: list[dict], *,
                   angle_unit: str = "deg", ground_truth: str | None = None,
                   length_unit: str | None = None, check_files: bool = True,
                   provenance: dict | None = None) -> Path:
    """Validate and write ``manifest.json`` atomically; return its path.

    Parameters
    ----------
    path : the dataset folder (or the manifest file inside it)
    board : a Board (anything with ``to_dict()``) or
        {"inner_corners": [nx, ny], "square_size": s}
    images : list of image dicts exactly as in the manifest (file relative to the folder;
        pan, tilt in ``angle_unit``)
    ground_truth : file name of the ground-truth JSON, relative to the folder
    length_unit : the unit of the board's square_size (written when given)
    check_files : require the images (and ground truth) to exist already
    provenance : where the images came from (``rasc import``: recordings, topics,
        thresholds), written as the manifest's ``provenance`` object; readers ignore it
    """
    path = Path(path)
    manifest = path if path.suffix == ".json" else path / MANIFEST
    if hasattr(board, "to_dict"):  # rasc.vision.camera.Board, or rasc.sim.scene.Board (same dict)
        board = board.to_dict()
    obj = _manifest_dict(board, [dict(im) if isinstance(im, dict) else im for im in images],
                         angle_unit, ground_truth, length_unit)
    if provenance is not None:
        obj["provenance"] = provenance
    # json round trip: numpy scalars become numbers, and what is written is what is checked
    try:
        obj = json.loads(json.dumps(obj, default=to_jsonable))
    except TypeError as exc:  # a value that is not JSON data
        raise InputError(f"write_manifest: {exc}") from None
    parse_manifest(obj, manifest.parent, where=str(manifest), check_files=check_files)
    write_json_atomic(manifest, obj)
    return manifest
