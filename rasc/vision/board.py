"""The chessboard target ("world" frame w, docs/CONTRACTS.md), shared by the camera
pipeline, the dataset format and the simulation. numpy only.

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


@dataclass(frozen=True)
class Board:
    """A chessboard target: ``inner_corners`` (nx, ny), ``square_size`` (any length unit).

    nx + ny must be odd: only then does a 180° turn of the board swap the colours of its
    squares, so that the image fixes which end is corner (0, 0).
    """

    inner_corners: tuple[int, int]
    square_size: float

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
        """Corners in the board frame, (N, 3): corner (i, j) at (i·s, j·s, 0), i fastest."""
        j, i = np.mgrid[0:self.ny, 0:self.nx]
        P = np.zeros((self.n_corners, 3))
        P[:, 0] = i.ravel() * self.square_size
        P[:, 1] = j.ravel() * self.square_size
        return P

    def to_dict(self) -> dict:
        """JSON-ready dict: ``inner_corners`` [nx, ny] and ``square_size``."""
        return {"inner_corners": [self.nx, self.ny], "square_size": self.square_size}


DEFAULT_BOARD = Board((9, 6), 0.05)
