"""Calibration targets ("world" frame w, docs/CONTRACTS.md): the chessboard and ChArUco,
shared by the camera pipeline, the dataset format and the simulation. numpy only (OpenCV
is imported only to draw or describe a ChArUco board).

Corner (i, j), i fastest, sits at (i·s, j·s, 0); +z points into the board; the square
bounded by corners (0,0), (1,0), (0,1), (1,1) is black.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rasc.errors import InputError

#: At least this many views for intrinsics (Zhang's method: two homography constraints per
#: view, five intrinsic parameters plus distortion).
MIN_INTRINSICS_VIEWS = 3


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _is_integral(v) -> bool:
    return _is_number(v) and np.isfinite(v) and float(v) == int(v)


#: square sizes accepted, in any length unit: a 1 mm square is 1e-3 in metres and a
#: 100 mm square is 1e5 in micrometres; 1e50 made OpenCV's extrinsics fail (measured)
SQUARE_SIZE_RANGE = (1e-6, 1e6)


class _CornerGrid:
    """The grid of inner corners both targets share (the chessboard's, and a ChArUco
    board's by id): a subclass gives ``inner_corners`` (nx, ny) and ``square_size``."""

    @property
    def nx(self) -> int:
        """Inner corners along the board's x (first) direction."""
        return self.inner_corners[0]

    @property
    def ny(self) -> int:
        """Inner corners along the board's y (second) direction."""
        return self.inner_corners[1]

    @property
    def n_corners(self) -> int:
        """The number of inner corners, ``nx * ny``."""
        return self.nx * self.ny

    def object_points(self) -> np.ndarray:
        """Corners in the board frame, (N, 3): corner (i, j), id j·nx + i, at
        (i·s, j·s, 0), i fastest."""
        j, i = np.mgrid[0:self.ny, 0:self.nx]
        P = np.zeros((self.n_corners, 3))
        P[:, 0] = i.ravel() * self.square_size
        P[:, 1] = j.ravel() * self.square_size
        return P


@dataclass(frozen=True)
class Board(_CornerGrid):
    """A chessboard target: ``inner_corners`` (nx, ny), ``square_size`` (any length unit).

    nx + ny must be odd: only then does a 180° turn of the board swap the colours of its
    squares, so that the image fixes which end is corner (0, 0).
    """

    inner_corners: tuple[int, int]
    square_size: float

    type = "chessboard"
    #: a chessboard is found whole or not at all
    partial_views = False

    def __post_init__(self):
        ic = self.inner_corners
        ok = (isinstance(ic, (tuple, list, np.ndarray)) and len(ic) == 2
              and all(_is_integral(v) for v in ic))
        if not ok:
            raise InputError(f"board: inner_corners must be two integers, got {ic!r}")
        nx, ny = (int(v) for v in ic)
        if nx < 2 or ny < 2:
            raise InputError(
                f"board: inner_corners must be two integers >= 2, got {self.inner_corners!r}")
        if (nx + ny) % 2 == 0:
            raise InputError(
                f"board: inner_corners {nx}x{ny} has nx + ny even: a 180° turn maps such a board "
                "onto itself colour for colour, so its corner order (the board frame) cannot be "
                "read from an image; use one odd and one even count, e.g. 9x6")
        s = self.square_size
        if not _is_number(s) or not np.isfinite(s) or s <= 0:
            raise InputError(f"board: square_size must be a positive number, got {s!r}")
        if not SQUARE_SIZE_RANGE[0] <= s <= SQUARE_SIZE_RANGE[1]:
            raise InputError(f"board: square_size {s:g} is outside [{SQUARE_SIZE_RANGE[0]:g}, "
                             f"{SQUARE_SIZE_RANGE[1]:g}]: no printed square is that size in "
                             "any length unit (OpenCV's pose solver fails on such scales)")
        object.__setattr__(self, "inner_corners", (nx, ny))
        object.__setattr__(self, "square_size", float(s))

    def to_dict(self) -> dict:
        """JSON-ready dict: ``inner_corners`` [nx, ny] and ``square_size``."""
        return {"inner_corners": [self.nx, self.ny], "square_size": self.square_size}

    def describe(self) -> str:
        """The board in words, for messages and reports."""
        return f"chessboard {self.nx}x{self.ny} inner corners of {self.square_size:g}"


DEFAULT_BOARD = Board((9, 6), 0.05)


# ----------------------------------------------------------------------------- ChArUco

#: OpenCV's predefined ArUco dictionaries a ChArUco target may name (cv2.aruco.DICT_*);
#: checked against the marker count when the board is built.
CHARUCO_DICTIONARIES = tuple(
    f"DICT_{b}X{b}_{n}" for b in (4, 5, 6, 7) for n in (50, 100, 250, 1000)) + (
    "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10",
    "DICT_APRILTAG_36h11", "DICT_ARUCO_MIP_36h12")

#: The fewest corners a partial view must show to be used: a planar pose has 6 degrees of
#: freedom and intrinsics add 2 constraints per view (Zhang), so 4 corners determine a
#: view at best exactly; 8 (16 residuals) leaves redundancy to see a bad corner. Chessboard
#: views are always whole (nx·ny corners) or not found.
MIN_VIEW_CORNERS = 8

#: Kinds of target a manifest's ``board`` may name (its ``type`` field; absent = chessboard).
TARGET_TYPES = ("chessboard", "charuco")


@dataclass(frozen=True)
class CharucoBoard(_CornerGrid):
    """A ChArUco target (OpenCV's ``cv2.aruco.CharucoBoard``): a chessboard of
    ``squares`` (sx, sy) squares of ``square_size`` whose white squares carry ArUco
    markers of ``marker_size`` (same length unit) from ``dictionary``.

    Its corners are the chessboard's inner corners, (sx − 1)·(sy − 1) of them, each
    identified by OpenCV's id k = j·(sx − 1) + i; corner id k sits at (i·s, j·s, 0) in the
    board frame, exactly as corner (i, j) of a :class:`Board` with ``inner_corners``
    (sx − 1, sy − 1) (OpenCV's board frame moved by one square; +z into the board; the
    square between corners 0, 1, sx − 1 and sx is black). Views may show any subset of the
    corners: a detection is an (N, 2) array with NaN rows for the corners not seen.
    ``legacy_pattern``: the layout of OpenCV before 4.6.0 for boards with an even number
    of rows (``CharucoBoard.setLegacyPattern``).
    """

    squares: tuple[int, int]
    square_size: float
    marker_size: float
    dictionary: str = "DICT_5X5_100"
    legacy_pattern: bool = False

    type = "charuco"
    #: corners are identified by id: a view may show any subset
    partial_views = True

    def __post_init__(self):
        sq = self.squares
        ok = (isinstance(sq, (tuple, list, np.ndarray)) and len(sq) == 2
              and all(_is_integral(v) for v in sq))
        if not ok:
            raise InputError(f"board: squares must be two integers, got {sq!r}")
        sx, sy = (int(v) for v in sq)
        if sx < 3 or sy < 3:
            raise InputError(f"board: squares must be two integers >= 3, got {sq!r}")
        s = self.square_size
        if not _is_number(s) or not np.isfinite(s) or s <= 0:
            raise InputError(f"board: square_size must be a positive number, got {s!r}")
        if not SQUARE_SIZE_RANGE[0] <= s <= SQUARE_SIZE_RANGE[1]:
            raise InputError(f"board: square_size {s:g} is outside [{SQUARE_SIZE_RANGE[0]:g}, "
                             f"{SQUARE_SIZE_RANGE[1]:g}]")
        m = self.marker_size
        if not _is_number(m) or not np.isfinite(m) or not 0 < m < s:
            raise InputError(f"board: marker_size must be a positive number below square_size "
                             f"{s:g}, got {m!r}")
        if self.dictionary not in CHARUCO_DICTIONARIES:
            raise InputError(f"board: unknown dictionary {self.dictionary!r} (use one of "
                             f"OpenCV's, e.g. DICT_5X5_100, DICT_4X4_250, DICT_APRILTAG_36h11)")
        if not isinstance(self.legacy_pattern, (bool, np.bool_)):
            raise InputError(f"board: legacy_pattern must be true or false, got "
                             f"{self.legacy_pattern!r}")
        size = _DICTIONARY_SIZES.get(self.dictionary)
        need = (sx * sy) // 2
        if size is not None and need > size:
            raise InputError(f"board: {sx}x{sy} squares need {need} markers but "
                             f"{self.dictionary} has {size}; use a larger dictionary")
        object.__setattr__(self, "squares", (sx, sy))
        object.__setattr__(self, "square_size", float(s))
        object.__setattr__(self, "marker_size", float(m))
        object.__setattr__(self, "legacy_pattern", bool(self.legacy_pattern))

    @property
    def inner_corners(self) -> tuple[int, int]:
        """(nx, ny): the inner (chessboard) corners, one fewer than the squares each way."""
        return self.squares[0] - 1, self.squares[1] - 1

    def to_dict(self) -> dict:
        """The board as a dataset manifest names it (``board.type = "charuco"``)."""
        return {"type": "charuco", "squares": [self.squares[0], self.squares[1]],
                "square_size": self.square_size, "marker_size": self.marker_size,
                "dictionary": self.dictionary, "legacy_pattern": self.legacy_pattern}

    def describe(self) -> str:
        """The board in words, for messages and reports."""
        sx, sy = self.squares
        return (f"ChArUco {sx}x{sy} squares of {self.square_size:g}, markers "
                f"{self.marker_size:g} ({self.dictionary})")

    def cv_board(self):
        """The ``cv2.aruco.CharucoBoard`` of this description."""
        import cv2

        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        b = cv2.aruco.CharucoBoard(self.squares, self.square_size, self.marker_size, d)
        b.setLegacyPattern(self.legacy_pattern)
        return b

    def texture(self, px_per_square: int = 120) -> np.ndarray:
        """The printed pattern, grey uint8 (sy·p, sx·p), row 0 at the board's y = −s edge,
        column 0 at its x = −s edge (``CharucoBoard.generateImage``, no margin)."""
        sx, sy = self.squares
        p = int(px_per_square)
        return self.cv_board().generateImage((sx * p, sy * p), marginSize=0, borderBits=1)


#: markers in each predefined dictionary (its name's last number; the others listed)
_DICTIONARY_SIZES = {name: int(name.rsplit("_", 1)[1]) for name in CHARUCO_DICTIONARIES
                     if name.rsplit("_", 1)[1].isdigit()}
_DICTIONARY_SIZES.update({"DICT_ARUCO_ORIGINAL": 1024, "DICT_APRILTAG_16h5": 30,
                          "DICT_APRILTAG_25h9": 35, "DICT_APRILTAG_36h10": 2320,
                          "DICT_APRILTAG_36h11": 587, "DICT_ARUCO_MIP_36h12": 250})


Target = Board | CharucoBoard


def board_from_dict(b, where: str = "board") -> Target:
    """A target from its manifest dict (``type`` absent or "chessboard": a :class:`Board`,
    {"inner_corners": [nx, ny], "square_size": s}; "charuco": a :class:`CharucoBoard`).
    Raises :class:`InputError` naming ``where`` and the field."""
    if not isinstance(b, dict):
        raise InputError(f"{where}: must be an object, got {type(b).__name__}")
    kind = b.get("type", "chessboard")
    if kind not in TARGET_TYPES:
        raise InputError(f"{where}: field 'type' must be one of {', '.join(TARGET_TYPES)}, "
                         f"got {kind!r}")
    if kind == "chessboard":
        fields = ("inner_corners", "square_size")
    else:
        fields = ("squares", "square_size", "marker_size")
    for key in fields:
        if key not in b:
            raise InputError(f"{where}: missing field {key!r}")
    allowed = set(fields) | {"type"} | ({"dictionary", "legacy_pattern"}
                                        if kind == "charuco" else set())
    extra = sorted(set(b) - allowed)
    if extra:
        raise InputError(f"{where}: unknown field {extra[0]!r} for a {kind} target")
    pair = "inner_corners" if kind == "chessboard" else "squares"
    ic = b[pair]
    if not isinstance(ic, (list, tuple)) or len(ic) != 2 or \
            not all(isinstance(v, int) and not isinstance(v, bool) for v in ic):
        raise InputError(f"{where}: {pair!r} must be two integers, got {ic!r}")
    try:
        if kind == "chessboard":
            return Board(tuple(ic), b["square_size"])
        return CharucoBoard(tuple(ic), b["square_size"], b["marker_size"],
                            b.get("dictionary", "DICT_5X5_100"),
                            b.get("legacy_pattern", False))
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def parse_target(text: str) -> Target:
    """A target from the command line: ``chessboard:NXxNY,SQUARE`` (inner corners),
    ``charuco:SXxSY,SQUARE,MARKER[,DICTIONARY][,legacy]`` (squares), or the path of a JSON
    file holding the manifest's ``board`` object. Lengths in metres."""
    import os

    text = text.strip()
    kind, sep, rest = text.partition(":")
    if sep and kind in TARGET_TYPES:
        parts = [p.strip() for p in rest.split(",") if p.strip()]
        try:
            pair = [int(v) for v in parts[0].lower().split("x")]
            if len(pair) != 2:
                raise ValueError
            if kind == "chessboard":
                if len(parts) != 2:
                    raise ValueError
                return Board(tuple(pair), float(parts[1]))
            if len(parts) < 3 or len(parts) > 5:
                raise ValueError
            extra = parts[3:]
            legacy = "legacy" in extra
            names = [p for p in extra if p != "legacy"]
            if len(names) > 1:
                raise ValueError
            return CharucoBoard(tuple(pair), float(parts[1]), float(parts[2]),
                                names[0] if names else "DICT_5X5_100", legacy)
        except InputError as exc:
            raise InputError(f"--target {text!r}: {exc}") from None
        except (ValueError, IndexError):
            form = ("chessboard:NXxNY,SQUARE (e.g. chessboard:9x6,0.05)" if kind == "chessboard"
                    else "charuco:SXxSY,SQUARE,MARKER[,DICTIONARY][,legacy] (e.g. "
                         "charuco:12x9,0.06,0.045,DICT_5X5_100)")
            raise InputError(f"--target {text!r}: expected {form}") from None
    if os.path.isfile(text):
        from rasc.io import read_json_document

        return board_from_dict(read_json_document(text, "target"), f"{text}")
    raise InputError(f"--target {text!r}: expected chessboard:NXxNY,SQUARE, "
                     "charuco:SXxSY,SQUARE,MARKER[,DICTIONARY][,legacy] or a JSON file")


def seen_mask(corners: np.ndarray) -> np.ndarray:
    """(N,) True where a detection (N, 2) has the corner (NaN rows: not seen)."""
    return np.all(np.isfinite(np.asarray(corners, float)), axis=-1)


def spans_plane(points: np.ndarray) -> bool:
    """Whether board points (M, 2 or 3) are not all on one line (a pose and a homography
    need that): the smaller singular value of the centred x-y coordinates above 1e-6 of
    the larger."""
    xy = np.asarray(points, float)[:, :2]
    if len(xy) < 3:
        return False
    s = np.linalg.svd(xy - xy.mean(axis=0), compute_uv=False)
    return bool(s[0] > 0 and s[1] > 1e-6 * s[0])
