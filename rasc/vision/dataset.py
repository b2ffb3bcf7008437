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
     "ground_truth": "ground_truth.json",                             (optional)
     "joint_stream": "joints.csv"}                                    (optional)

``role`` "intrinsics": a view of the board for calibrating the eye's intrinsics (the
pan-tilt angles do not matter); "pose": a view at a commanded pan-tilt position (pan,
tilt required), for hand-eye; ``view`` groups the left and right images taken at the same
time of the same board placement (loop closure). Every problem is reported as one
:class:`~rasc.errors.InputError` line naming the manifest, the image index and file, and
the field. Images are read lazily; :meth:`Dataset.validate` reads their headers.

A head that never stops (docs/topics/continuous.md): an image may carry its ``time``
(seconds on the camera clock, mid-exposure), and ``joint_stream`` names the timestamped
readings (:mod:`rasc.vision.joint_stream`, read with the manifest into
:attr:`Dataset.joint_stream`); the pose images' pan, tilt are then the stream at the
image's time, without any camera-to-encoder offset.

:class:`Dataset` is rasc's one notion of a calibration dataset: the target, the image
entries with their pan-tilt readings and, besides a folder's files, images held in
memory (:meth:`Dataset.in_memory`, what the renderer makes) or corners given instead of
detected (:meth:`Dataset.with_corners`, the projected corners of
:func:`rasc.sim.synthetic.corner_dataset`), and the scene's truth when rasc made it.
:func:`load_dataset` is the one reader of the folder, :func:`write_dataset` the one
writer (images, ``manifest.json``, ``ground_truth.json``).

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
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

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
#: the ground truth's file name in a dataset folder rasc writes
GROUND_TRUTH = "ground_truth.json"
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
    time: float | None = None    # camera clock, seconds, mid-exposure (continuous capture)


@dataclass
class Detections:
    """Corners found in a group of images: ``corners`` file → (N, 2) canonical order,
    ``not_found`` files without the board, ``entries`` file → :class:`ImageEntry`."""

    corners: dict[str, np.ndarray]
    not_found: list[str]
    entries: dict[str, ImageEntry]


#: where a dataset held in memory says it is in messages (it has no folder)
IN_MEMORY = Path("<in memory>")


@dataclass
class Dataset:
    """A calibration dataset: the target, the angle unit and the images with their
    pan/tilt readings (the format in the module docstring), read from a folder by
    :func:`load_dataset` or made in memory.

    Besides the folder's files, a dataset may hold:

    pixels : file → 8-bit grey image (H, W), the images in memory (the renderer's,
        :meth:`in_memory`); read from there instead of the files, detected alike.
    corners : file → (N, 2) corners given instead of detected (projected corners,
        :meth:`with_corners`; None: the target is not seen in that image); ``sizes`` then
        gives each eye's image size.
    truth : the scene's truth when rasc made the dataset: the renderer's ground-truth
        document (a dict, what ``ground_truth.json`` holds) or, for projected corners,
        the :class:`rasc.sim.synthetic.SyntheticHead`.
    options, key : the :class:`rasc.sim.render.RenderOptions` it was rendered with and
        the dataset service's cache key, when it came through the service
        (:func:`rasc.testing.render_cached`).
    """
    root: Path
    manifest_path: Path
    board: Board | CharucoBoard              # the target (rasc.vision.board)
    angle_unit: str
    images: tuple[ImageEntry, ...]
    ground_truth: Path | None = None
    length_unit: str | None = None           # the unit of board.square_size, if stated
    pixels: dict[str, np.ndarray] | None = field(default=None, repr=False, compare=False)
    corners: dict[str, np.ndarray | None] | None = field(default=None, repr=False,
                                                         compare=False)
    sizes: dict[str, tuple[int, int]] | None = None
    truth: Any = field(default=None, repr=False, compare=False)
    options: Any = None
    key: str | None = None
    #: the manifest dict it was read from or made of (written back as it was)
    manifest: dict | None = field(default=None, repr=False, compare=False)
    #: the timestamped joint readings (:class:`rasc.vision.joint_stream.JointStream`) of a
    #: continuous capture, when the manifest names them (``"joint_stream"``)
    joint_stream: Any = field(default=None, repr=False, compare=False)

    # ------------------------------------------------------------- constructors

    @classmethod
    def in_memory(cls, board, images: list[dict], pixels: dict[str, np.ndarray], *,
                  angle_unit: str = "deg", length_unit: str | None = "m",
                  truth: dict | None = None, where: str | os.PathLike = IN_MEMORY,
                  joint_stream=None) -> Dataset:
        """A dataset whose images are arrays (file → (H, W) uint8), e.g. rendered:
        ``images`` are manifest entries (pan, tilt in ``angle_unit``), checked as a
        manifest's are; ``truth`` the ground-truth document, if any; ``joint_stream``
        the timestamped readings of a continuous capture
        (:class:`rasc.vision.joint_stream.JointStream`), if any. ``where`` names it in
        messages. :func:`write_dataset` writes it as a folder."""
        from rasc.vision.joint_stream import JOINTS

        obj = _manifest_dict(board, [dict(im) for im in images], angle_unit,
                             None if truth is None else GROUND_TRUTH, length_unit,
                             None if joint_stream is None else JOINTS)
        obj = json.loads(json.dumps(obj, default=to_jsonable))
        root = Path(where)
        ds = parse_manifest(obj, root, where=str(root / MANIFEST), check_files=False)
        for e in ds.images:
            image = pixels.get(e.file)
            if image is None:
                raise InputError(f"{root}: no image in memory for {e.file}")
            if not (isinstance(image, np.ndarray) and image.ndim == 2
                    and image.dtype == np.uint8 and image.size):
                raise InputError(f"{root}: images[{e.index}] ({e.file}): expected an 8-bit "
                                 "grey image (a 2-D uint8 array), got "
                                 f"{getattr(image, 'dtype', type(image).__name__)} of shape "
                                 f"{getattr(image, 'shape', '?')}")
        ds.pixels = dict(pixels)
        ds.truth = truth
        ds.joint_stream = joint_stream
        return ds

    @classmethod
    def with_corners(cls, board, entries: list[ImageEntry],
                     corners: dict[str, np.ndarray | None], sizes: dict[str, tuple[int, int]],
                     *, truth: Any = None, where: str | os.PathLike = "<given corners>",
                     length_unit: str | None = "m") -> Dataset:
        """A dataset of corners given instead of detected (file → (N, 2), None: not
        seen), with no images: ``sizes`` gives each eye's image size."""
        root = Path(where)
        return cls(root=root, manifest_path=root, board=board, angle_unit="deg",
                   images=tuple(entries), length_unit=length_unit, corners=dict(corners),
                   sizes=dict(sizes), truth=truth)

    # ------------------------------------------------------------------- truth

    @property
    def path(self) -> Path:
        """The dataset folder (``root``)."""
        return self.root

    def load(self) -> Dataset:
        """This dataset (what ``rasc.testing``'s rendered datasets returned by ``load()``)."""
        return self

    def _truth_document(self) -> dict:
        if isinstance(self.truth, dict):
            return self.truth
        if self.ground_truth is not None:
            return self.load_ground_truth()
        raise InputError(f"{self.manifest_path}: no ground truth (not rendered by rasc)")

    def T_cam_from_gaze(self, eye: str) -> np.ndarray:
        """The TRUE hand-eye transform of ``eye`` ("left" or "right"), (4, 4), metres,
        from the scene's truth."""
        if self.truth is not None and not isinstance(self.truth, dict):
            return np.array(self.truth.T_cam_from_gaze[eye], dtype=float)
        return np.array(self._truth_document()[eye]["T_cam_from_gaze"], dtype=float)

    def pose_views(self, eye: str) -> tuple[np.ndarray, np.ndarray]:
        """The pose views' TRUE poses of ``eye``, in view order: ``T_cam_from_world``
        (n, 4, 4) from the renderer and ``T_gaze_from_ptu`` (n, 4, 4) from the recorded
        pan/tilt by eq. 3 — hand-eye input without detection error (add your own noise,
        e.g. :func:`rasc.handeye.noise.perturb_T_cam_from_world`)."""
        from rasc.geometry.kinematics import T_gaze_from_ptu

        gt = self._truth_document()
        views = sorted((name, v) for name, v in gt["views"].items()
                       if name.startswith(f"poses/{eye}_"))
        T_cw = np.array([v["T_cam_from_world"] for _, v in views], dtype=float)
        pan_tilt = np.radians([[v["pan"], v["tilt"]] for _, v in views])
        return T_cw, T_gaze_from_ptu(pan_tilt[:, 0], pan_tilt[:, 1])

    # ------------------------------------------------------------------ images

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
        if self.corners is not None:       # given corners: no images to read
            return dict(self.sizes or {})
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
        if self.pixels is not None:
            return self.pixels[entry.file]
        if self.corners is not None:
            raise InputError(f"{self.manifest_path}: images[{entry.index}] ({entry.file}): "
                             "a dataset of given corners has no images")
        from rasc.vision.camera import read_image

        try:
            return read_image(entry.path)
        except InputError as exc:
            raise InputError(f"{self.manifest_path}: images[{entry.index}] ({entry.file}): "
                             f"{_problem(exc, entry.path)}") from None

    def _size(self, entry: ImageEntry, decode: bool) -> tuple[int, int]:
        if decode or self.pixels is not None:
            h, w = self.read(entry).shape
            return w, h
        from rasc.vision.camera import image_size as read_image_size

        try:
            return read_image_size(entry.path)
        except InputError as exc:
            raise InputError(f"{self.manifest_path}: images[{entry.index}] ({entry.file}): "
                             f"{_problem(exc, entry.path)}") from None

    def _corners_of(self, e: ImageEntry, method: str, order_by: str | None,
                    min_corners: int) -> np.ndarray | None:
        """The corners of one image: given, or detected (from the file or the array in
        memory; kept per content, see :data:`DETECTIONS_KEPT`)."""
        from rasc.vision.camera import detect_corners

        partial = getattr(self.board, "partial_views", False)
        if self.corners is not None:
            c = self.corners.get(e.file)
            if c is None:
                return None
            c = np.array(c, dtype=float)
            if partial and int(np.isfinite(c[:, 0]).sum()) < min_corners:
                return None
            return c
        image = None
        if self.pixels is not None:
            image = self.pixels[e.file]
            digest = _array_digest(image)
        else:
            digest = _content_digest(e.path)
        key = (None if digest is None
               else (digest, self.board.inner_corners, method, order_by) if not partial
               else (digest, self.board, method, min_corners))
        found, c = _remembered(key)
        if not found:
            c = detect_corners(self.read(e) if image is None else image, self.board,
                               method=method, order_by=order_by, min_corners=min_corners)
            # kept only if the file still holds the bytes it held before it was read
            if key is not None and (image is not None or _content_digest(e.path) == digest):
                _remember(key, c)
        return c

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
            c = self._corners_of(e, method, order_by, min_corners)
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
        """The optional ground-truth JSON (written by the simulation), as a dict (the
        document in memory when the dataset holds one)."""
        if isinstance(self.truth, dict):
            return self.truth
        if self.ground_truth is None:
            raise InputError(f"{self.manifest_path}: no ground_truth file named in the manifest")
        return _read_json(self.ground_truth, "ground truth")

    def to_manifest(self) -> dict:
        """The manifest dict this dataset was read from (angles in its own unit)."""
        if self.manifest is not None:
            return json.loads(json.dumps(self.manifest))
        return _manifest_dict(self.board, [_entry_dict(e, self.angle_unit) for e in self.images],
                              self.angle_unit,
                              None if self.ground_truth is None
                              else self.ground_truth.relative_to(self.root).as_posix(),
                              self.length_unit,
                              None if self.joint_stream is None else "joints.csv")


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


def _array_digest(image: np.ndarray) -> bytes:
    """SHA-256 of an image in memory: its shape, type and pixels."""
    a = np.ascontiguousarray(image)
    h = hashlib.sha256(f"{a.shape} {a.dtype.str}\0".encode())
    h.update(a.data)
    return h.digest()


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
    if b.get("type", "chessboard") != "chessboard" or "target_type" in b:   # or Kalibr's
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
        pan = tilt = time = None
        if "time" in im:
            time = finite_number(im["time"], f"{here}: field 'time'")
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
                                  pan=pan, tilt=tilt, view=view, time=time))
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
    stream = None
    if obj.get("joint_stream") is not None:
        from rasc.vision.joint_stream import read_joint_stream

        js_path = root / _relative_file(obj["joint_stream"], where, "joint_stream")
        if check_files:
            if not os.path.lexists(js_path):
                raise InputError(f"{where}: field 'joint_stream': file does not exist "
                                 f"({js_path})")
            stream = read_joint_stream(js_path)
    return Dataset(root=root, manifest_path=Path(where), board=board,
                   angle_unit=angle_unit or "deg", images=images, ground_truth=gt_path,
                   length_unit=length_unit, manifest=obj, joint_stream=stream)


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
    if e.time is not None:
        d["time"] = e.time
    return d


def _manifest_dict(board: Board | dict, images: list[dict], angle_unit: str,
                   ground_truth: str | None, length_unit: str | None = None,
                   joint_stream: str | None = None) -> dict:
    obj = {"format": FORMAT, "board": board.to_dict() if hasattr(board, "to_dict") else board,
           **({} if length_unit is None else {"length_unit": length_unit}),
           "angle_unit": angle_unit, "images": images}
    if ground_truth is not None:
        obj["ground_truth"] = ground_truth
    if joint_stream is not None:     # absent without one: the manifests of before
        obj["joint_stream"] = joint_stream
    return obj


def write_manifest(path: str | os.PathLike, board: Board | dict, images: list[dict], *,
                   angle_unit: str = "deg", ground_truth: str | None = None,
                   length_unit: str | None = None, check_files: bool = True,
                   provenance: dict | None = None, joint_stream: str | None = None) -> Path:
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
    joint_stream : file name of the joint stream (``joints.csv``), relative to the folder
    """
    path = Path(path)
    manifest = path if path.suffix == ".json" else path / MANIFEST
    if hasattr(board, "to_dict"):  # rasc.vision.camera.Board, or rasc.sim.scene.Board (same dict)
        board = board.to_dict()
    obj = _manifest_dict(board, [dict(im) if isinstance(im, dict) else im for im in images],
                         angle_unit, ground_truth, length_unit, joint_stream)
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


def write_dataset(dataset: Dataset, out: str | os.PathLike, *, atomic: bool = True,
                  flag: str = "--out") -> Path:
    """Write ``dataset`` as a dataset folder ``out`` (the one writer of the format): its
    images as 8-bit grey PNG (from memory, or copied from its files), ``manifest.json``
    and, when it holds the scene's truth document, ``ground_truth.json``. ``atomic``:
    built in a temporary folder beside ``out`` and renamed into place
    (:func:`rasc.io.folder_built_atomically`: ``out`` must be absent or empty; ``flag``
    names it in messages); else written into ``out`` (absent or empty) directly. Returns
    the manifest's path. A dataset of given corners has no images and cannot be written.
    """
    out = Path(out)
    if dataset.corners is not None:
        raise InputError(f"{dataset.manifest_path}: a dataset of given corners has no "
                         "images to write")
    if atomic:
        from rasc.io import folder_built_atomically

        with folder_built_atomically(out, flag=flag) as tmp:
            _write_files(dataset, tmp)
        return out / MANIFEST
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: output folder exists as a file")
    if out.exists() and any(out.iterdir()):
        raise InputError(f"{out}: output folder exists and is not empty")
    return _write_files(dataset, out)


def _write_files(dataset: Dataset, out: Path) -> Path:
    import shutil

    for e in dataset.images:
        if dataset.pixels is not None:
            write_dataset_image(out, e.file, dataset.pixels[e.file])
        else:
            (out / e.file).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(e.path, out / e.file)
    truth = dataset.truth if isinstance(dataset.truth, dict) else (
        None if dataset.ground_truth is None else dataset.load_ground_truth())
    obj = dataset.to_manifest()
    return write_dataset_index(out, obj["board"], obj["images"], truth,
                               angle_unit=dataset.angle_unit, length_unit=dataset.length_unit,
                               provenance=obj.get("provenance"),
                               joint_stream=dataset.joint_stream)


def write_dataset_image(out: Path, file: str, image: np.ndarray) -> None:
    """One image of a dataset folder being written (:func:`write_dataset`'s part for a
    writer that streams its images, as :func:`rasc.sim.render.render_dataset` does):
    8-bit grey PNG at ``out / file``."""
    from rasc.vision.camera import write_image

    (out / file).parent.mkdir(parents=True, exist_ok=True)
    write_image(out / file, image)


def write_dataset_index(out: Path, board, images: list[dict], truth: dict | None, *,
                        angle_unit: str = "deg", length_unit: str | None = "m",
                        provenance: dict | None = None, joint_stream=None) -> Path:
    """The last part of :func:`write_dataset`, once the images are in ``out``:
    ``ground_truth.json`` (when ``truth`` is given), ``joints.csv`` (when ``joint_stream``,
    a :class:`rasc.vision.joint_stream.JointStream`, is given) and ``manifest.json``
    (validated against the files). Returns the manifest's path."""
    from rasc.io import write_text_atomic
    from rasc.vision.joint_stream import JOINTS, format_joint_stream

    if truth is not None:
        write_json_atomic(out / GROUND_TRUTH, truth)
    if joint_stream is not None:
        write_text_atomic(out / JOINTS, format_joint_stream(joint_stream))
    return write_manifest(out, board, images, angle_unit=angle_unit,
                          ground_truth=None if truth is None else GROUND_TRUTH,
                          length_unit=length_unit, provenance=provenance,
                          joint_stream=None if joint_stream is None else JOINTS)
