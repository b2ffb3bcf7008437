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

    # The printed target's extent, for the renderer (a target whose corners are not on the
    # square grid, the AprilGrid, overrides these four).

    def centre(self) -> np.ndarray:
        """The centre of the corners' span in the board frame, (3,)."""
        return np.array([(self.nx - 1) / 2, (self.ny - 1) / 2, 0.0]) * self.square_size

    def face(self) -> tuple[float, float, float, float]:
        """The printed rectangle (x0, y0, x1, y1) in the board frame: one square beyond the
        outer corners (the chessboard's outer squares; a ChArUco texture covers it)."""
        s = self.square_size
        return -s, -s, self.nx * s, self.ny * s

    def quiet_box(self) -> tuple[float, float, float, float]:
        """The printed rectangle with its white quiet zone (one square more each side)."""
        s = self.square_size
        return -2 * s, -2 * s, (self.nx + 1) * s, (self.ny + 1) * s

    def extent(self) -> float:
        """The printed rectangle's longer side."""
        return (max(self.nx, self.ny) + 1) * self.square_size


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
TARGET_TYPES = ("chessboard", "charuco", "aprilgrid")


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


# ----------------------------------------------------------------------------- AprilGrid

#: AprilTag families an AprilGrid may use: Kalibr's name -> OpenCV's dictionary and the
#: side of the data grid in bits. Kalibr prints and detects t36h11 (its default and the
#: only family its detector reads); the others draw and detect the same way here.
APRILGRID_FAMILIES = {"t36h11": ("DICT_APRILTAG_36h11", 6), "t36h10": ("DICT_APRILTAG_36h10", 6),
                      "t25h9": ("DICT_APRILTAG_25h9", 5), "t16h5": ("DICT_APRILTAG_16h5", 4)}

#: black border of every tag, in bits (Kalibr's ``borderBits`` = 2: its PDF tool and its
#: detector's ``blackTagBorder``; OpenCV's own markers have 1)
APRILGRID_BORDER_BITS = 2

#: texels per tag bit in the rendered texture (a 36h11 tag is 10 bits with its border:
#: 120 texels, as the ChArUco texture's 120 per square)
APRILGRID_TEXELS_PER_BIT = 12


@dataclass(frozen=True)
class AprilGrid(_CornerGrid):
    """Kalibr's AprilGrid target: ``tags`` (cols, rows) AprilTags of ``tag_size`` (edge to
    edge of the black border, any length unit) with ``tag_spacing`` × ``tag_size`` between
    neighbours, from ``family`` (Kalibr's names: t36h11, also t36h10, t25h9, t16h5), each
    tag with a 2-bit black border and a black square of the spacing's size at each of its
    corners (Kalibr's ``kalibr_create_target_pdf``), so that every tag corner is a
    chessboard-like saddle.

    Kalibr's conventions: tag id = row·cols + col, tag 0 at the printed target's bottom
    left, rows going up; the 4·cols·rows corners form a grid of (2·cols) × (2·rows),
    corner id n = r·(2·cols) + c, at x = (c // 2)·(1 + spacing)·size + (c % 2)·size and
    Kalibr's y = (r // 2)·(1 + spacing)·size + (r % 2)·size; corner 0 is the outer
    bottom-left corner of tag 0 and each tag's corners are ids b, b + 1, b + 2·cols + 1,
    b + 2·cols (bottom left, bottom right, top right, top left as printed).

    rasc's board frame (docs/CONTRACTS.md: +z into the board) is Kalibr's target frame
    turned 180° about its x axis: the same origin, x and corner ids, y = −Kalibr's y, so
    corner n sits at (x, −y_kalibr, 0) and ``T_kalibr_from_board`` = diag(1, −1, −1).
    Views may show any subset of the corners (NaN rows for the others).
    """

    tags: tuple[int, int]
    tag_size: float
    tag_spacing: float = 0.3
    family: str = "t36h11"

    type = "aprilgrid"
    #: corners are identified by their tag's id: a view may show any subset
    partial_views = True

    def __post_init__(self):
        tg = self.tags
        ok = (isinstance(tg, (tuple, list, np.ndarray)) and len(tg) == 2
              and all(_is_integral(v) for v in tg))
        if not ok:
            raise InputError(f"board: tags must be two integers (columns, rows), got {tg!r}")
        c, r = (int(v) for v in tg)
        if c < 1 or r < 1 or c * r < 2:
            raise InputError(f"board: tags must be two integers >= 1 with at least 2 tags, "
                             f"got {tg!r}")
        a = self.tag_size
        if not _is_number(a) or not np.isfinite(a) or a <= 0:
            raise InputError(f"board: tag_size must be a positive number, got {a!r}")
        if not SQUARE_SIZE_RANGE[0] <= a <= SQUARE_SIZE_RANGE[1]:
            raise InputError(f"board: tag_size {a:g} is outside [{SQUARE_SIZE_RANGE[0]:g}, "
                             f"{SQUARE_SIZE_RANGE[1]:g}]")
        g = self.tag_spacing
        # Kalibr's PDF tool takes spacings in [0, 1]; 0 would merge the corner squares with
        # the neighbouring tags (no saddle), and below 0.05 of a tag they are a sliver
        if not _is_number(g) or not np.isfinite(g) or not 0.05 <= g <= 1:
            raise InputError(f"board: tag_spacing must be a ratio in [0.05, 1] (the space "
                             f"between tags over tag_size, Kalibr's tagSpacing), got {g!r}")
        if self.family not in APRILGRID_FAMILIES:
            raise InputError(f"board: unknown family {self.family!r} (use one of "
                             f"{', '.join(APRILGRID_FAMILIES)})")
        size = _DICTIONARY_SIZES[APRILGRID_FAMILIES[self.family][0]]
        if c * r > size:
            raise InputError(f"board: {c}x{r} tags need {c * r} ids but {self.family} has "
                             f"{size}; use fewer tags or a larger family")
        object.__setattr__(self, "tags", (c, r))
        object.__setattr__(self, "tag_size", float(a))
        object.__setattr__(self, "tag_spacing", float(g))

    @property
    def inner_corners(self) -> tuple[int, int]:
        """(2·cols, 2·rows): the corner grid (four corners per tag, Kalibr's ordering)."""
        return 2 * self.tags[0], 2 * self.tags[1]

    @property
    def square_size(self) -> float:
        """The tag size: the length the target's unit is stated in (as a square's)."""
        return self.tag_size

    @property
    def pitch(self) -> float:
        """Distance between neighbouring tags' origins, (1 + tag_spacing)·tag_size."""
        return (1.0 + self.tag_spacing) * self.tag_size

    @property
    def gap(self) -> float:
        """Space between neighbouring tags (the corner squares' side), spacing·tag_size."""
        return self.tag_spacing * self.tag_size

    def object_points(self) -> np.ndarray:
        """Corners in the board frame, (N, 3), id n = r·(2·cols) + c (Kalibr's order), at
        (x, −y_kalibr, 0) (see the class description)."""
        nx, ny = self.inner_corners
        r, c = np.mgrid[0:ny, 0:nx]
        P = np.zeros((self.n_corners, 3))
        P[:, 0] = (c // 2).ravel() * self.pitch + (c % 2).ravel() * self.tag_size
        P[:, 1] = -((r // 2).ravel() * self.pitch + (r % 2).ravel() * self.tag_size)
        return P

    def kalibr_points(self) -> np.ndarray:
        """The corners in Kalibr's target frame (its ``createGridPoints``), (N, 3)."""
        return self.object_points() * [1.0, -1.0, 1.0]

    def tag_corner_ids(self, tag_id: int) -> np.ndarray:
        """Corner ids of tag ``tag_id`` as printed: bottom left, bottom right, top right,
        top left (Kalibr's order)."""
        cols = self.tags[0]
        b = (tag_id // cols) * 4 * cols + (tag_id % cols) * 2
        return np.array([b, b + 1, b + 2 * cols + 1, b + 2 * cols])

    def _span(self) -> tuple[float, float]:
        """Width and height of the corners' span: (cols − 1)·pitch + size, likewise rows."""
        c, r = self.tags
        return (c - 1) * self.pitch + self.tag_size, (r - 1) * self.pitch + self.tag_size

    def centre(self) -> np.ndarray:
        w, h = self._span()
        return np.array([w / 2, -h / 2, 0.0])

    def face(self) -> tuple[float, float, float, float]:
        """The printed rectangle: the corner squares plus one spacing of white each side,
        widened to whole texels (the texture's pixels, :meth:`texture`)."""
        w, h = self._span()
        t = self._texel()
        m = 2 * self.gap
        nx, ny = int(np.ceil((w + 2 * m) / t - 1e-9)), int(np.ceil((h + 2 * m) / t - 1e-9))
        return -m, -h - m, -m + nx * t, -h - m + ny * t

    def quiet_box(self) -> tuple[float, float, float, float]:
        x0, y0, x1, y1 = self.face()
        q = self.tag_size / 2
        return x0 - q, y0 - q, x1 + q, y1 + q

    def extent(self) -> float:
        x0, y0, x1, y1 = self.face()
        return max(x1 - x0, y1 - y0)

    def _texel(self) -> float:
        bits = APRILGRID_FAMILIES[self.family][1] + 2 * APRILGRID_BORDER_BITS
        return self.tag_size / bits / APRILGRID_TEXELS_PER_BIT

    def to_dict(self) -> dict:
        """The board as a dataset manifest names it (``board.type = "aprilgrid"``)."""
        return {"type": "aprilgrid", "tags": [self.tags[0], self.tags[1]],
                "tag_size": self.tag_size, "tag_spacing": self.tag_spacing,
                "family": self.family}

    def to_kalibr(self) -> dict:
        """Kalibr's target description (its ``aprilgrid.yaml`` fields)."""
        return {"target_type": "aprilgrid", "tagCols": self.tags[0], "tagRows": self.tags[1],
                "tagSize": self.tag_size, "tagSpacing": self.tag_spacing}

    def describe(self) -> str:
        """The board in words, for messages and reports."""
        c, r = self.tags
        return (f"AprilGrid {c}x{r} tags of {self.tag_size:g}, spacing {self.tag_spacing:g} "
                f"({self.family})")

    def cv_dictionary(self):
        """OpenCV's ``cv2.aruco.Dictionary`` of the family."""
        import cv2

        return cv2.aruco.getPredefinedDictionary(
            getattr(cv2.aruco, APRILGRID_FAMILIES[self.family][0]))

    def tag_image(self, tag_id: int) -> np.ndarray:
        """Tag ``tag_id`` as printed upright, one uint8 per bit with its 2-bit border
        (0 black, 255 white), row 0 at the top: OpenCV's marker turned 180° (Kalibr draws
        the code that way: ``rotation=2`` in its PDF tool; checked against tag36h11's
        published code 0 in tests/vision/test_aprilgrid.py)."""
        import cv2

        n = APRILGRID_FAMILIES[self.family][1] + 2 * APRILGRID_BORDER_BITS
        img = cv2.aruco.generateImageMarker(self.cv_dictionary(), int(tag_id), n,
                                            borderBits=APRILGRID_BORDER_BITS)
        return np.ascontiguousarray(img[::-1, ::-1])

    def texture(self) -> np.ndarray:
        """The printed pattern over :meth:`face`, grey uint8, row 0 at the face's smallest
        y (the printed target's top), column 0 at its smallest x; each texel is the exact
        share of its area that is white (the tags' bits, borders and corner squares are
        axis-aligned rectangles, so edges between texels are drawn to their true place)."""
        x0, y0, x1, y1 = self.face()
        t = self._texel()
        nx, ny = int(round((x1 - x0) / t)), int(round((y1 - y0) / t))
        black = np.zeros((ny, nx))
        edges_x = x0 + t * np.arange(nx + 1)
        edges_y = y0 + t * np.arange(ny + 1)

        def cover(edges, lo, hi):
            i0 = max(int(np.searchsorted(edges, lo, "right")) - 1, 0)
            i1 = min(int(np.searchsorted(edges, hi, "left")), len(edges) - 1)
            ov = np.clip(np.minimum(edges[i0 + 1:i1 + 1], hi) - np.maximum(edges[i0:i1], lo),
                         0.0, None) / t
            return i0, ov

        def fill(xa, xb, ya, yb):
            i, cx = cover(edges_x, xa, xb)
            j, cy = cover(edges_y, ya, yb)
            black[j:j + len(cy), i:i + len(cx)] += np.outer(cy, cx)

        cols, rows = self.tags
        a, p, g = self.tag_size, self.pitch, self.gap
        n = APRILGRID_FAMILIES[self.family][1] + 2 * APRILGRID_BORDER_BITS
        b = a / n
        for tid in range(cols * rows):
            c, r = tid % cols, tid // cols
            left, top = c * p, -(r * p + a)      # the tag's smallest x and y (board frame)
            img = self.tag_image(tid)
            for i, j in zip(*np.nonzero(img < 128), strict=True):
                fill(left + j * b, left + (j + 1) * b, top + i * b, top + (i + 1) * b)
        for c in range(cols + 1):               # corner squares, shared by neighbours
            for r in range(rows + 1):
                fill(c * p - g, c * p, -(r * p), -(r * p) + g)
        return np.round(255.0 * (1.0 - np.clip(black, 0.0, 1.0))).astype(np.uint8)


Target = Board | CharucoBoard | AprilGrid


def board_from_dict(b, where: str = "board") -> Target:
    """A target from its manifest dict: ``type`` absent or "chessboard": a :class:`Board`,
    {"inner_corners": [nx, ny], "square_size": s}; "charuco": a :class:`CharucoBoard`;
    "aprilgrid": an :class:`AprilGrid`, {"tags": [cols, rows], "tag_size", "tag_spacing",
    "family"}. A Kalibr target description (a dict with ``target_type``,
    :func:`board_from_kalibr`) is read too. Raises :class:`InputError` naming ``where`` and
    the field."""
    if not isinstance(b, dict):
        raise InputError(f"{where}: must be an object, got {type(b).__name__}")
    if "target_type" in b:
        return board_from_kalibr(b, where)
    kind = b.get("type", "chessboard")
    if kind not in TARGET_TYPES:
        raise InputError(f"{where}: field 'type' must be one of {', '.join(TARGET_TYPES)}, "
                         f"got {kind!r}")
    required, optional, pair = {
        "chessboard": (("inner_corners", "square_size"), (), "inner_corners"),
        "charuco": (("squares", "square_size", "marker_size"), ("dictionary", "legacy_pattern"),
                    "squares"),
        "aprilgrid": (("tags", "tag_size"), ("tag_spacing", "family"), "tags")}[kind]
    for key in required:
        if key not in b:
            raise InputError(f"{where}: missing field {key!r}")
    extra = sorted(set(b) - set(required) - set(optional) - {"type"})
    if extra:
        raise InputError(f"{where}: unknown field {extra[0]!r} for a {kind} target")
    ic = b[pair]
    if not isinstance(ic, (list, tuple)) or len(ic) != 2 or \
            not all(isinstance(v, int) and not isinstance(v, bool) for v in ic):
        raise InputError(f"{where}: {pair!r} must be two integers, got {ic!r}")
    try:
        if kind == "chessboard":
            return Board(tuple(ic), b["square_size"])
        if kind == "aprilgrid":
            return AprilGrid(tuple(ic), b["tag_size"], b.get("tag_spacing", 0.3),
                             b.get("family", "t36h11"))
        return CharucoBoard(tuple(ic), b["square_size"], b["marker_size"],
                            b.get("dictionary", "DICT_5X5_100"),
                            b.get("legacy_pattern", False))
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


#: Kalibr's target description (its target yaml): the fields of each ``target_type``
#: read here, required then optional. ``tagFamily`` is not Kalibr's own (its detector
#: reads t36h11 only) but some of its forks'; ``rowSpacingMeters`` and
#: ``colSpacingMeters`` must be equal (a rasc chessboard has square squares).
KALIBR_FIELDS = {
    "aprilgrid": (("tagCols", "tagRows", "tagSize", "tagSpacing"), ("tagFamily",)),
    "checkerboard": (("targetCols", "targetRows", "rowSpacingMeters", "colSpacingMeters"), ()),
}


def board_from_kalibr(d, where: str = "target") -> Target:
    """A target from Kalibr's target description (the dict of its ``aprilgrid.yaml`` or
    ``checkerboard.yaml``): ``target_type: aprilgrid`` with ``tagCols``, ``tagRows``,
    ``tagSize`` (metres), ``tagSpacing`` (ratio) → :class:`AprilGrid`;
    ``target_type: checkerboard`` with ``targetCols``, ``targetRows`` (inner corners),
    ``rowSpacingMeters`` = ``colSpacingMeters`` → :class:`Board`. Raises
    :class:`InputError` naming ``where`` and the field."""
    if not isinstance(d, dict):
        raise InputError(f"{where}: a Kalibr target description must be a mapping, got "
                         f"{type(d).__name__}")
    kind = d.get("target_type")
    if kind not in KALIBR_FIELDS:
        raise InputError(f"{where}: field 'target_type' must be one of "
                         f"{', '.join(KALIBR_FIELDS)} (Kalibr's circlegrid is not read), "
                         f"got {kind!r}")
    required, optional = KALIBR_FIELDS[kind]
    for key in required:
        if key not in d:
            raise InputError(f"{where}: missing field {key!r} for a Kalibr {kind}")
    extra = sorted(set(d) - set(required) - set(optional) - {"target_type"})
    if extra:
        raise InputError(f"{where}: unknown field {extra[0]!r} for a Kalibr {kind}")
    for key in required[:2]:
        v = d[key]
        if not isinstance(v, int) or isinstance(v, bool):
            raise InputError(f"{where}: field {key!r} must be an integer, got {v!r}")
    for key in required[2:]:
        if not _is_number(d[key]):
            raise InputError(f"{where}: field {key!r} must be a number, got {d[key]!r}")
    try:
        if kind == "aprilgrid":
            fam = d.get("tagFamily", "t36h11")
            if isinstance(fam, str) and not fam.startswith("t"):
                fam = "t" + fam
            return AprilGrid((d["tagCols"], d["tagRows"]), d["tagSize"], d["tagSpacing"], fam)
        if d["rowSpacingMeters"] != d["colSpacingMeters"]:
            raise InputError(f"fields 'rowSpacingMeters' {d['rowSpacingMeters']!r} and "
                             f"'colSpacingMeters' {d['colSpacingMeters']!r} differ: rasc's "
                             "chessboard has square squares")
        return Board((d["targetCols"], d["targetRows"]), d["rowSpacingMeters"])
    except InputError as exc:
        raise InputError(f"{where}: {str(exc).removeprefix('board: ')}") from None


def read_target_file(path: str) -> Target:
    """A target from a file: a JSON board object, alone as a manifest's ``board`` field
    is written (``{"type": "aprilgrid", "tags": [6, 6], ...}``), or a YAML file
    (``.yaml``/``.yml``) holding Kalibr's target description."""
    from rasc.io import read_json_document, read_text_file

    if str(path).lower().endswith((".yaml", ".yml")):
        import yaml

        text = read_text_file(path, "target description", 1 << 20)
        try:
            doc = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            at = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
            raise InputError(f"{path}: not valid YAML{at}") from None
        return board_from_kalibr(doc, str(path))
    return board_from_dict(read_json_document(path, "target"), str(path))


_TARGET_FORMS = {
    "chessboard": "chessboard:NXxNY,SQUARE (e.g. chessboard:9x6,0.05)",
    "charuco": "charuco:SXxSY,SQUARE,MARKER[,DICTIONARY][,legacy] (e.g. "
               "charuco:12x9,0.06,0.045,DICT_5X5_100)",
    "aprilgrid": "aprilgrid:COLSxROWS,TAGSIZE[,SPACING][,FAMILY] (e.g. "
                 "aprilgrid:6x6,0.088,0.3,t36h11)"}


def parse_target(text: str, where: str = "target") -> Target:
    """A target from its inline form: ``chessboard:NXxNY,SQUARE`` (inner corners),
    ``charuco:SXxSY,SQUARE,MARKER[,DICTIONARY][,legacy]`` (squares),
    ``aprilgrid:COLSxROWS,TAGSIZE[,SPACING][,FAMILY]`` (tags; spacing 0.3 and t36h11 by
    default), the path of a JSON file holding the manifest's ``board`` object, or of a
    Kalibr target yaml. Lengths in metres. ``where`` names the value in messages (a
    command passes its option, ``--target``)."""
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
            if kind == "aprilgrid":
                if not 2 <= len(parts) <= 4:
                    raise ValueError
                family = parts[3] if len(parts) == 4 else "t36h11"
                spacing = float(parts[2]) if len(parts) >= 3 else 0.3
                return AprilGrid(tuple(pair), float(parts[1]), spacing, family)
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
            raise InputError(f"{where} {text!r}: {exc}") from None
        except (ValueError, IndexError):
            raise InputError(f"{where} {text!r}: expected {_TARGET_FORMS[kind]}") from None
    if os.path.isfile(text):
        return read_target_file(text)
    raise InputError(f"{where} {text!r}: expected chessboard:NXxNY,SQUARE, "
                     "charuco:SXxSY,SQUARE,MARKER[,DICTIONARY][,legacy], "
                     "aprilgrid:COLSxROWS,TAGSIZE[,SPACING][,FAMILY], or a JSON file (the "
                     "manifest's board) or Kalibr target yaml")


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


def corners_by_id(board, ids: np.ndarray, uv: np.ndarray, min_corners: int
                  ) -> np.ndarray | None:
    """A target seen in part's detection as the detectors return it: (N, 2) pixels by
    corner id, NaN rows for the corners not seen; None when fewer than ``min_corners``
    were seen or they all lie on one line (no pose, no homography)."""
    if len(ids) < min_corners or not spans_plane(board.object_points()[ids]):
        return None
    out = np.full((board.n_corners, 2), np.nan)
    out[ids] = uv
    return out
