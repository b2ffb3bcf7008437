"""Images → the pixel points ``rasc triangulate`` reads (``rasc detect``).

Each pair of simultaneous pose images (a left and a right image with the same ``view``
in a dataset, or two image files given with their angles) is detected with the dataset's
detection path (:meth:`rasc.vision.dataset.Dataset.read` and
:func:`rasc.vision.detect.detect_corners`, the detector and canonical corner order the
calibration uses), and every board corner found in both images becomes one matched point:
``u_left, v_left, u_right, v_right`` (measured, distorted pixels), the four angles of the
pair in the dataset's angle unit, and a ``label`` ``<view>:<corner index>``.

Every image's detection status (its corner count, or "board not found") is kept: as
``#`` comment lines at the top of the CSV (the points reader skips them) and in
:attr:`PixelPoints.status`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rasc import formats
from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.vision.board import Board, board_from_dict, read_target_file
from rasc.vision.dataset import Dataset, ImageEntry, _parse_board

FORMAT = formats.PIXEL_POINTS.tag
#: the columns, in the order ``rasc triangulate`` documents them
COLUMNS = ("u_left", "v_left", "u_right", "v_right",
           "pan_left", "tilt_left", "pan_right", "tilt_right", "label")


@dataclass(frozen=True)
class ImageStatus:
    """One image's detection: ``corners`` found (None: the board was not found)."""

    eye: str
    file: str
    view: str
    corners: int | None

    def line(self) -> str:
        """The image's detection status as one line (a comment line of the points CSV)."""
        what = f"{self.corners} corners" if self.corners is not None else "board not found"
        return f"{self.eye} {self.file} (view {self.view}): {what}"


@dataclass
class PixelPoints:
    """Matched pixel points of the views whose board both eyes saw."""

    angle_unit: str
    rows: list[tuple] = field(default_factory=list)
    status: list[ImageStatus] = field(default_factory=list)
    views_used: list[str] = field(default_factory=list)
    views_left_out: list[str] = field(default_factory=list)

    def warnings(self) -> list[str]:
        """One sentence for the user when some images showed no board."""
        missing = [s for s in self.status if s.corners is None]
        if not missing:
            return []
        return [f"board not found in {len(missing)} of {len(self.status)} image(s) (first: "
                f"{missing[0].file}); view(s) {', '.join(self.views_left_out)} left out"]

    def to_csv(self) -> str:
        """The CSV ``rasc triangulate`` reads, with the status as comment lines."""
        lines = [f"# {FORMAT}: matched board corners; pan and tilt in {self.angle_unit} "
                 f"(rasc triangulate ... --angle-unit {self.angle_unit})"]
        lines += [f"# {s.line()}" for s in self.status]
        lines.append(",".join(COLUMNS))
        for row in self.rows:
            lines.append(",".join(_cell(v) for v in row))
        return "\n".join(lines) + "\n"


def _cell(value) -> str:
    if isinstance(value, str):
        return value
    return repr(float(value))       # shortest text that reads back to the same double


def _angle(radians: float, unit: str) -> float:
    value = math.degrees(radians) if unit == "deg" else radians
    return float(f"{value:.12g}")   # 8.0 deg, not 7.999999999999999


def pixel_points(dataset: Dataset, detector: str = "saddle",
                 log=lambda s: None) -> PixelPoints:
    """Detect the board in every pose image of ``dataset`` and match the corners of each
    view both eyes saw (module docstring). ``detector`` as in
    :class:`rasc.head.options.CalibrationOptions`. Raises :class:`InputError` when no
    view has the board in both images (the error lists what was found)."""
    from rasc.vision.camera import detect_corners

    views: dict[str, dict[str, ImageEntry]] = {}
    for e in dataset.select(role="pose"):
        views.setdefault(e.view, {})[e.eye] = e
    if not views:
        raise InputError(f"{dataset.manifest_path}: no pose images (role 'pose' with pan, "
                         "tilt and view): nothing to match")
    out = PixelPoints(angle_unit=dataset.angle_unit)
    for view, pair in views.items():
        found = {}
        for eye in EYES:
            e = pair.get(eye)
            if e is None:
                continue
            c = detect_corners(dataset.read(e), dataset.board, method=detector,
                               order_by="colour")
            # a target seen in part (ChArUco, AprilGrid) marks corners not seen with NaN
            status = ImageStatus(eye, e.file, view,
                                 None if c is None else int(np.isfinite(c[:, 0]).sum()))
            out.status.append(status)
            log(status.line())
            if c is not None:
                found[eye] = c
        if len(found) < 2:
            out.views_left_out.append(view)
            continue
        out.views_used.append(view)
        L, R = pair["left"], pair["right"]
        angles = [_angle(a, dataset.angle_unit) for a in (L.pan, L.tilt, R.pan, R.tilt)]
        both = np.flatnonzero(np.isfinite(found["left"][:, 0]) & np.isfinite(found["right"][:, 0]))
        for k in both:
            out.rows.append((*found["left"][k], *found["right"][k], *angles, f"{view}:{k}"))
    if not out.rows:
        seen = "; ".join(s.line() for s in out.status[:4])
        raise InputError(f"{dataset.manifest_path}: no view has the board in both its left "
                         f"and right image ({seen}{'; ...' if len(out.status) > 4 else ''})")
    return out


_BOARD = re.compile(r"^\s*(\d+)\s*[xX]\s*(\d+)\s*$")


def parse_board(text: str) -> Board:
    """``--board``: ``NXxNY`` inner corners (``9x6``); a JSON file holding the board
    object alone, as a manifest's ``board`` field is written (``{"inner_corners": [9, 6],
    "square_size": 0.05}``, or any target's, e.g. ``{"type": "aprilgrid", ...}``:
    :func:`rasc.vision.board.read_target_file`), or a dataset manifest (its ``board``,
    read as :func:`rasc.vision.dataset.load_dataset` reads it); or a Kalibr target
    yaml."""
    m = _BOARD.match(text)
    if m:
        return Board((int(m.group(1)), int(m.group(2))), 1.0)
    if text.lower().endswith((".yaml", ".yml")):     # Kalibr's target description
        return read_target_file(text)
    from rasc.io import read_json_document

    obj = read_json_document(text, "board description")
    if "board" in obj:                               # a dataset manifest
        return _parse_board(obj, text)
    return board_from_dict(obj, text)                # the board object alone, any target


def pairs_dataset(board: Board, pairs: list[tuple[str, str, str]], angle_unit: str) -> Dataset:
    """A dataset of loose image files: each pair ``(LEFT, RIGHT, "PAN_L,TILT_L,PAN_R,
    TILT_R")``, angles in ``angle_unit``. Files are named as given; view ``k`` is the k-th
    pair. Errors name ``--pair`` and its position."""
    scale = math.pi / 180.0 if angle_unit == "deg" else 1.0
    images = []
    for k, (left, right, angles) in enumerate(pairs):
        where = f"--pair {k + 1} ({left} {right} {angles})"
        parts = angles.split(",")
        try:
            values = [float(p) for p in parts]
        except ValueError:
            values = []
        if len(values) != 4 or not all(math.isfinite(v) for v in values):
            raise InputError(f"{where}: angles must be four numbers PAN_L,TILT_L,PAN_R,TILT_R "
                             f"in {angle_unit}")
        if any(abs(v * scale) > 2 * math.pi for v in values):
            raise InputError(f"{where}: an angle is more than a full turn: is --angle-unit "
                             f"{angle_unit} right?")
        for eye, file, pan, tilt in (("left", left, *values[:2]), ("right", right, *values[2:])):
            if not Path(file).is_file():
                raise InputError(f"{where}: {file}: image file does not exist")
            images.append(ImageEntry(index=len(images), file=file, path=Path(file), eye=eye,
                                     role="pose", pan=pan * scale, tilt=tilt * scale,
                                     view=str(k + 1)))
    return Dataset(root=Path("."), manifest_path=Path("--pair"), board=board,
                   angle_unit=angle_unit, images=tuple(images))


def as_array(points: PixelPoints) -> np.ndarray:
    """The rows' numbers, (N, 8): u_left, v_left, u_right, v_right, four angles."""
    return np.array([row[:8] for row in points.rows], dtype=float).reshape(-1, 8)
