"""Chessboard and ChArUco corner detection, in the board's one canonical order
(docs/METHOD.md §7).

The board ("world" frame w, docs/CONTRACTS.md): inner corners (nx, ny) with nx + ny odd,
square size s; corner (i, j), i fastest, sits at (i·s, j·s, 0); +z points into the board.
The square bounded by corners (0,0), (1,0), (0,1), (1,1) is black. OpenCV numbers the
corners from either end of the board: measured with 4.14 on boards with nx + ny odd, the
classic detector starts next to a black square and findChessboardCornersSB next to a white
one, whatever the view. :func:`detect_corners` re-orders both to this rule so that every
view of one physical board shares one board frame, whichever detector found it (needed by
hand-eye, stereo and loop closure; single-camera calibration does not care, see
:func:`rasc.vision.camera.calibrate_intrinsics`).

Pixels follow OpenCV's convention (pixel centres at integers, row 0 at the top). Part of
rasc's camera pipeline (:mod:`rasc.vision.camera` re-exports every public name here).
"""

from __future__ import annotations

import os

import cv2
import numpy as np

from rasc.errors import InputError
from rasc.vision.board import (
    MIN_VIEW_CORNERS,
    Board,
    CharucoBoard,
    _is_integral,
    corners_by_id,
    spans_plane,
)
from rasc.vision.images import read_image, to_grey
from rasc.vision.subpixel import (  # noqa: F401  (re-exported: rasc.vision.detect's names)
    SUBPIX_CRITERIA,
    _opencv_threads,
    saddle_points,
    saddle_points_inside,
)

ORDER_RULES = ("colour", "image", None)

#: corner detectors of :func:`detect_corners`
DETECTORS = ("classic", "saddle", "sb")


# ------------------------------------------------------------------ corner detection

@_opencv_threads(1)
def detect_corners(image: np.ndarray, board: Board, method: str = "classic",
                   order_by: str | None = "colour", *, fast_check: bool = False,
                   subpix_window: tuple[int, int] = (11, 11),
                   min_corners: int = MIN_VIEW_CORNERS) -> np.ndarray | None:
    """Find the board's inner corners in ``image``; ``None`` when the board is not found.

    A ChArUco board (:class:`rasc.vision.board.CharucoBoard`) goes to
    :func:`detect_charuco` (``method`` "classic" refines its corners with cornerSubPix,
    "saddle" and "sb" with the saddle points), an AprilGrid to
    :func:`rasc.vision.aprilgrid.detect_aprilgrid` (``order_by`` and the rest do not apply:
    their corners are identified by the markers); the rest of this description is the
    chessboard's.

    Parameters
    ----------
    image : array, shape (H, W) or (H, W, 3) BGR
    board : Board
    method : "classic" (findChessboardCorners with ADAPTIVE_THRESH | NORMALIZE_IMAGE, then
        cornerSubPix over ``subpix_window`` half-sizes with :data:`SUBPIX_CRITERIA`),
        "saddle" (classic, then :func:`refine_saddle`: the most accurate and still fast) or
        "sb" (findChessboardCornersSB with CALIB_CB_ACCURACY). Measured here on synthetic
        1280×960 renders (2 shared cores): classic 0.004–0.008 s, sb 0.3–1.2 s per image;
        corner error 0.02–0.03 px RMS (classic), 0.03–0.08 px (sb). OpenCV numbers the
        corners from opposite ends in the two methods; the ordering below reconciles them.
    order_by : "colour" (default) — canonical order of docs/CONTRACTS.md, read from the
        squares' colours; "image" — of the two 180°-related orders, the one whose corner
        (0, 0) is nearer the image's top-left (for boards whose colours cannot be read);
        None — OpenCV's order. A mirrored grid is always put right (see
        :func:`order_corners`).
    fast_check : add CALIB_CB_FAST_CHECK (quick rejection of images without a board).

    Returns
    -------
    corners : ndarray, shape (N, 2), float64, N = nx·ny, or None (not found, or the colour
        rule could not decide).
    """
    if method not in DETECTORS:
        raise InputError(f"detect_corners: unknown method {method!r} (use one of "
                         f"{', '.join(DETECTORS)})")
    if getattr(board, "type", None) == "aprilgrid":
        from rasc.vision.aprilgrid import detect_aprilgrid

        return detect_aprilgrid(image, board, min_corners=min_corners,
                                method="classic" if method == "classic" else "saddle")
    if getattr(board, "partial_views", False):
        # "sb" has no ChArUco counterpart: its corners are refined as "saddle"'s
        return detect_charuco(image, board, min_corners=min_corners,
                              method="classic" if method == "classic" else "saddle")
    if order_by not in ORDER_RULES:
        raise InputError(f"detect_corners: unknown order_by {order_by!r} (use 'colour', "
                         "'image' or None)")
    grey = to_grey(image)
    pattern = board.inner_corners
    if method in ("classic", "saddle"):
        flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
        if fast_check:
            flags |= cv2.CALIB_CB_FAST_CHECK
        found, corners = cv2.findChessboardCorners(grey, pattern, flags=flags)
        if not found or corners is None:
            return None
        corners = cv2.cornerSubPix(grey, corners.reshape(-1, 1, 2).astype(np.float32),
                                   tuple(subpix_window), (-1, -1), SUBPIX_CRITERIA)
        if method == "saddle":
            corners = refine_saddle(grey, corners.reshape(-1, 2), board)
            if corners is None:
                return None
    else:
        # ACCURACY alone: adding NORMALIZE_IMAGE was measured to raise the corner error on
        # synthetic boards from 0.03 to 0.16 px RMS (640x480 and 1280x960 alike)
        found, corners = cv2.findChessboardCornersSB(grey, pattern, flags=cv2.CALIB_CB_ACCURACY)
        if not found or corners is None:
            return None
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 2)  # 4.x: (N,1,2); 5.x: (N,2)
    if corners.shape[0] != board.n_corners or not np.all(np.isfinite(corners)):
        return None
    return order_corners(corners, grey, board, order_by)


def _saddle_window(corners: np.ndarray, board: Board) -> tuple[int, float]:
    """:func:`refine_saddle`'s half-window r (a quarter of the smallest corner spacing, 2
    to 6 px) and blur σ = r/3 (0.8 to 2 px), for corners (N, 2) in the board's order."""
    nx, ny = board.inner_corners
    grid = np.asarray(corners, dtype=np.float64).reshape(ny, nx, 2)
    spacing = min(np.linalg.norm(np.diff(grid, axis=1), axis=2).min(),
                  np.linalg.norm(np.diff(grid, axis=0), axis=2).min())
    r = int(np.clip(np.floor(spacing / 4), 2, 6))
    return r, float(np.clip(r / 3, 0.8, 2.0))


def refine_saddle(grey: np.ndarray, corners: np.ndarray, board: Board, *,
                  iterations: int = 4) -> np.ndarray | None:
    """Sub-pixel corners as saddle points of the smoothed image.

    Each corner of a chessboard is a saddle of the intensity surface. The image is
    smoothed by a Gaussian of σ pixels; around each corner a quadratic
    ``a x² + b xy + c y² + d x + e y + f`` is fitted by Gaussian-weighted least squares
    over a (2r+1)² grid of bilinear samples (one precomputed pseudo-inverse for all
    corners), and the corner moves to the quadratic's stationary point; a few iterations.
    r is a quarter of the smallest corner spacing (2 to 6 px) so the window never
    reaches a neighbouring corner; σ = r/3 (0.8 to 2 px).

    Measured on rendered 1280×960 boards against the projected truth: 0.012–0.015 px RMS,
    against 0.06–0.08 px for cornerSubPix (any window) and 0.033 px for
    findChessboardCornersSB with CALIB_CB_ACCURACY, and far faster than SB (per-image
    times: ``benchmarks/bench_pipeline.py``, figures in the README).

    Returns ``None`` when a corner is not a saddle (the fitted Hessian is not indefinite)
    or moves more than r in total: no reliable corner there.
    """
    c0 = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
    r, sigma = _saddle_window(c0, board)
    c, ok = saddle_points(grey, c0, r, sigma, iterations=iterations)
    return c if bool(np.all(ok)) else None


def _signed_area(corners: np.ndarray, board: Board) -> float:
    """Shoelace area of the outer corner quadrilateral (0,0), (nx-1,0), (nx-1,ny-1), (0,ny-1).

    Positive (image y down) when the board's +x, +y look like image +x, +y up to a rotation,
    i.e. when its printed face is seen; negative for a mirrored numbering.
    """
    nx, ny = board.inner_corners
    q = corners[[0, nx - 1, nx * ny - 1, nx * (ny - 1)]]
    x, y = q[:, 0], q[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def square_means(grey: np.ndarray, corners: np.ndarray, board: Board) -> np.ndarray:
    """Mean intensity near the centre of each square between inner corners, (ny-1, nx-1).

    Each square (i, j), bounded by corners (i,j), (i+1,j), (i,j+1), (i+1,j+1), is sampled at
    3×3 bilinear points spanning its central half, away from the edges.
    """
    nx, ny = board.inner_corners
    g = corners.reshape(ny, nx, 2)
    c00, c10, c01, c11 = g[:-1, :-1], g[:-1, 1:], g[1:, :-1], g[1:, 1:]
    samples = []
    for a in (0.25, 0.5, 0.75):
        for b in (0.25, 0.5, 0.75):
            samples.append((1 - a) * (1 - b) * c00 + a * (1 - b) * c10
                           + (1 - a) * b * c01 + a * b * c11)
    pts = np.stack(samples, axis=-2).astype(np.float32)  # (ny-1, nx-1, 9, 2)
    flat = pts.reshape(1, -1, 2)
    vals = cv2.remap(grey.astype(np.float32), flat[..., 0], flat[..., 1], cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)
    return vals.reshape(ny - 1, nx - 1, 9).mean(axis=-1)


def colour_score(grey: np.ndarray, corners: np.ndarray, board: Board) -> float:
    """Vote of neighbouring square pairs on which end of the board is corner (0, 0), [-1, 1].

    Each pair of neighbouring squares votes +1 if its even-parity square (the parity of
    the square at corner (0, 0)) is the darker, −1 if the lighter, 0 on a tie. +1: the
    square at corner (0, 0) is black (canonical order); −1: it is white (the 180°
    relabelling is canonical); near 0: the colours cannot be read. Comparing neighbours
    rather than thresholding copes with lighting gradients.
    """
    m = square_means(grey, corners, board)
    ny1, nx1 = m.shape
    parity_even = (np.add.outer(np.arange(ny1), np.arange(nx1)) % 2) == 0
    sign = np.where(parity_even, 1.0, -1.0)  # +1 on squares that must be black
    votes = []
    if nx1 > 1:
        votes.append(((m[:, 1:] - m[:, :-1]) * sign[:, :-1]).ravel())  # >0: even darker
    if ny1 > 1:
        votes.append(((m[1:, :] - m[:-1, :]) * sign[:-1, :]).ravel())
    return float(np.mean(np.sign(np.concatenate(votes))))


def order_corners(corners: np.ndarray, image: np.ndarray | None, board: Board,
                  order_by: str | None = "colour") -> np.ndarray | None:
    """Put detected corners (N, 2) into the board's canonical order (docs/CONTRACTS.md).

    1. Mirror: if the numbering runs the wrong way round (negative signed area, the board
       frame would be left-handed or seen from behind), reverse every row.
    2. 180°: with ``order_by="colour"`` keep the order if the square at corner (0, 0) is
       black, else reverse the list (with nx + ny odd the 180° alternative has the opposite
       colour there); ``"image"``: keep the order whose corner (0, 0) is nearer the image's
       top-left; None: leave it.

    Returns None when the colour rule cannot decide (:func:`colour_score` within ±0.6:
    a blurred, saturated or low-contrast view).
    """
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
    if corners.shape[0] != board.n_corners:
        raise InputError(f"order_corners: expected {board.n_corners} corners for a "
                         f"{board.nx}x{board.ny} board, got {corners.shape[0]}")
    nx, ny = board.inner_corners
    if _signed_area(corners, board) < 0:
        corners = corners.reshape(ny, nx, 2)[:, ::-1].reshape(-1, 2)
    if order_by is None:
        return corners
    if order_by == "image":
        first, last = corners[0], corners[-1]
        return corners if first.sum() <= last.sum() else corners[::-1].copy()
    if image is None:
        raise InputError("order_corners: order_by='colour' needs the image")
    score = colour_score(to_grey(image), corners, board)
    # |score| >= 0.6 (at least 80 % of the pairs agree): a clean view is unanimous (±1 on
    # every real view of the two datasets here); below that either order is a guess, and
    # a wrong guess would silently break hand-eye and stereo.
    if score >= 0.6:
        return corners
    if score <= -0.6:
        return corners[::-1].copy()
    return None


#: cornerSubPix half-window for ChArUco corners, as a fraction of the square's image size
#: (between its nearest corners), clipped to [2, 11] px: the window should stay inside the
#: white margin around the markers (an eighth of the square on the usual boards with
#: markers 3/4 of the square). Measured on 1280x960 renders of a 12x9 board of 60 mm
#: squares at 1 m: 0.085-0.091 px RMS against the truth with 0.1, 0.10-0.12 px with the
#: window clipped at 11 px, 0.084-0.100 px for OpenCV's corners unrefined. These are
#: cornerSubPix's limit on sharp rendered edges, not the target's: the chessboard's
#: corners with cornerSubPix alone ("classic") are as far off (0.08-0.09 px), and the
#: error is almost all a sinusoid of the corner's sub-pixel position (amplitude
#: 0.08-0.10 px; 0.006-0.024 px left once it is removed), the known "pixel locking" of
#: gradient-based corner refinement; :func:`charuco_saddle_window` then removes it.
CHARUCO_SUBPIX_FRACTION = 0.1


def charuco_saddle_window(board: CharucoBoard, side_px: float) -> tuple[int, float]:
    """:func:`saddle_points`' half-window r and blur σ for ChArUco corners whose nearest
    square side is ``side_px`` pixels: the chessboard's rule (a quarter of the side, 2 to
    6 px; σ = r/3, 0.8 to 2 px), with r also at most the white margin between a corner
    and the markers, ``side_px · (s − m) / 2s`` (8.6 px for 68 px squares with markers
    3/4 of the square), so the fitted window sees the chessboard corner and not a
    marker's edge."""
    margin = side_px * (board.square_size - board.marker_size) / (2 * board.square_size)
    r = int(np.clip(np.floor(min(side_px / 4, margin)), 2, 6))
    return r, float(np.clip(r / 3, 0.8, 2.0))


def _charuco_detectors(board: CharucoBoard):
    key = board
    det = _CHARUCO_DETECTORS.get(key)
    if det is None:
        params = cv2.aruco.CharucoParameters()
        params.minMarkers = 1
        dparams = cv2.aruco.DetectorParameters()
        dparams.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        det = _CHARUCO_DETECTORS[key] = cv2.aruco.CharucoDetector(
            board.cv_board(), params, dparams)
    return det


_CHARUCO_DETECTORS: dict = {}

#: ChArUco refinements of :func:`detect_charuco` (the chessboard's names)
CHARUCO_METHODS = ("classic", "saddle")


@_opencv_threads(1)
def detect_charuco(image: np.ndarray, board: CharucoBoard,
                   min_corners: int = MIN_VIEW_CORNERS,
                   method: str = "saddle") -> np.ndarray | None:
    """The ChArUco corners seen in ``image``, by id: (N, 2) float64 with NaN rows for the
    corners not seen; ``None`` when fewer than ``min_corners`` are seen or they all lie
    on one line (no pose, no homography).

    OpenCV's ``CharucoDetector.detectBoard`` (markers refined with cornerSubPix, corners
    interpolated from the markers' homographies), then every corner refined again with
    cornerSubPix (:data:`SUBPIX_CRITERIA`, half-window :data:`CHARUCO_SUBPIX_FRACTION` of
    the local square size): ``method="classic"``; ``"saddle"`` (default) then moves each
    corner to the saddle point of the smoothed image (:func:`saddle_points`, window
    :func:`charuco_saddle_window`) and drops a corner that is not a saddle there or whose
    window (r + 2σ) does not lie inside the image.
    Measured on 1280×960 renders of a 12×9 board of 60 mm squares at 1 m, against the
    renderer's truth: 0.010–0.017 px RMS with "saddle" (the chessboard's 0.013–0.021 px
    on the same renders), 0.08–0.09 px with "classic" (:data:`CHARUCO_SUBPIX_FRACTION`).
    """
    if not _is_integral(min_corners) or min_corners < 4:
        raise InputError(f"detect_charuco: min_corners must be an integer >= 4 (a planar "
                         f"pose needs 4 corners), got {min_corners!r}")
    if method not in CHARUCO_METHODS:
        raise InputError(f"detect_charuco: unknown method {method!r} (use one of "
                         f"{', '.join(CHARUCO_METHODS)})")
    grey = to_grey(image)
    cc, ids, _, _ = _charuco_detectors(board).detectBoard(grey)
    if ids is None or cc is None or len(ids) < min_corners:
        return None
    ids = np.asarray(ids).ravel().astype(int)
    uv = np.asarray(cc, dtype=np.float64).reshape(-1, 2)
    keep = (ids >= 0) & (ids < board.n_corners) & np.all(np.isfinite(uv), axis=1)
    ids, uv = ids[keep], uv[keep]
    if len(ids) < min_corners or not spans_plane(board.object_points()[ids]):
        return None
    # local square size in pixels: the homography of the seen corners at each corner
    H, _ = cv2.findHomography(board.object_points()[ids, :2], uv, 0)
    side = np.nan
    if H is not None:
        s = board.square_size
        P = board.object_points()[ids, :2]
        a = cv2.perspectiveTransform(P.reshape(-1, 1, 2), H).reshape(-1, 2)
        b = cv2.perspectiveTransform((P + [s, 0]).reshape(-1, 1, 2), H).reshape(-1, 2)
        c = cv2.perspectiveTransform((P + [0, s]).reshape(-1, 1, 2), H).reshape(-1, 2)
        side = min(np.linalg.norm(b - a, axis=1).min(), np.linalg.norm(c - a, axis=1).min())
    win = int(np.clip(round(CHARUCO_SUBPIX_FRACTION * side), 2, 11)) if np.isfinite(side) \
        else 5
    uv = cv2.cornerSubPix(grey, uv.reshape(-1, 1, 2).astype(np.float32), (win, win),
                          (-1, -1), SUBPIX_CRITERIA).reshape(-1, 2).astype(np.float64)
    if method == "saddle":
        # no homography (side unknown): the smallest window, which reaches no marker
        r, sigma = charuco_saddle_window(board, side) if np.isfinite(side) else (2, 0.8)
        new, ok = saddle_points_inside(grey, uv, r, sigma)
        return corners_by_id(board, ids[ok], new[ok], min_corners)
    return corners_by_id(board, ids, uv, min_corners)


def detect_views(images: dict, board: Board, method: str = "classic",
                 order_by: str | None = "colour") -> tuple[dict[str, np.ndarray], list[str]]:
    """Detect the board in many views; ``images`` maps name → image array or file path.

    Returns ``(corners, not_found)``: corners by name (in input order) for the views where
    the board was found, and the names where it was not. Never raises for a missing board.
    """
    found: dict[str, np.ndarray] = {}
    missing: list[str] = []
    for name, img in images.items():
        if isinstance(img, (str, os.PathLike)):
            img = read_image(img)
        corners = detect_corners(img, board, method=method, order_by=order_by)
        if corners is None:
            missing.append(name)
        else:
            found[name] = corners
    return found, missing
