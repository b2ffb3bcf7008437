"""Detection of Kalibr's AprilGrid (:class:`rasc.vision.board.AprilGrid`) with OpenCV's
maintained AprilTag reader (``cv2.aruco.ArucoDetector`` with the family's
``DICT_APRILTAG_*`` dictionary and Kalibr's 2-bit tag border).

Each tag found gives its four corners by id (Kalibr's corner ids,
:meth:`~rasc.vision.board.AprilGrid.tag_corner_ids`); every corner is then refined with
``cornerSubPix`` on the saddle that the tag and its corner square make, and, as Kalibr
does, a corner the refinement moves too far (out of its search window) is dropped.
A view may show any subset of the corners: the result is (N, 2) with NaN rows for the
corners not seen, as for ChArUco (:func:`rasc.vision.camera.detect_charuco`).
"""

from __future__ import annotations

import cv2
import numpy as np

from rasc.errors import InputError
from rasc.vision.board import (
    APRILGRID_BORDER_BITS,
    APRILGRID_FAMILIES,
    MIN_VIEW_CORNERS,
    AprilGrid,
    _is_integral,
    spans_plane,
)
from rasc.vision.camera import SUBPIX_CRITERIA, _opencv_threads, to_grey

#: cornerSubPix half-window as a fraction of the clean saddle around a tag corner (the
#: smaller of the tag's 2-bit border and the corner square, in pixels), clipped to
#: [3, 11] px. Kalibr uses a fixed 2 px half-window; measured here on renders of small
#: tags (bits of 4 px), OpenCV's tag corners lie 2-3 px off the saddle (the corner
#: squares touch the tag's outline) and a 2 px window leaves 10 % of them there, 3-5 px
#: bring all within 0.1 px.
APRILGRID_SUBPIX_FRACTION = 0.7

#: A corner that cornerSubPix moves farther than its half-window from the tag reader's
#: corner is dropped (it left the saddle it was looking for). Kalibr drops corners moved
#: more than √1.5 ≈ 1.22 px (``maxSubpixDisplacement2``), which trusts its own tag
#: reader's corners to a pixel; OpenCV's are 2-3 px off on small tags (above).

#: corners closer than this to the image edge (px) are not refined and not kept (the
#: window must lie inside the image; Kalibr drops tags within 10 px of the border)
EDGE_PX = 4


def _detector(board: AprilGrid):
    key = (board.family,)
    det = _DETECTORS.get(key)
    if det is None:
        params = cv2.aruco.DetectorParameters()
        params.markerBorderBits = APRILGRID_BORDER_BITS
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        det = _DETECTORS[key] = cv2.aruco.ArucoDetector(board.cv_dictionary(), params)
    return det


_DETECTORS: dict = {}

#: OpenCV's marker corners (its canonical top left, top right, bottom right, bottom left)
#: as positions in the tag as printed (bottom left, bottom right, top right, top left,
#: :meth:`AprilGrid.tag_corner_ids`): the printed tag is OpenCV's marker turned 180°
_CV_TO_PRINTED = (1, 0, 3, 2)


@_opencv_threads(1)
def detect_aprilgrid(image: np.ndarray, board: AprilGrid,
                     min_corners: int = MIN_VIEW_CORNERS) -> np.ndarray | None:
    """The AprilGrid corners seen in ``image``, by id: (N, 2) float64 with NaN rows for
    the corners not seen; ``None`` when fewer than ``min_corners`` are seen or they all
    lie on one line (no pose, no homography).

    Tags with an id outside the grid, and ids seen twice (a stray tag in the scene), are
    left out. Each kept corner is refined with cornerSubPix (:data:`SUBPIX_CRITERIA`,
    half-window :data:`APRILGRID_SUBPIX_FRACTION` of the local saddle size).
    """
    if not isinstance(board, AprilGrid):
        raise InputError(f"detect_aprilgrid: expected an AprilGrid, got {type(board).__name__}")
    if not _is_integral(min_corners) or min_corners < 4:
        raise InputError(f"detect_aprilgrid: min_corners must be an integer >= 4 (a planar "
                         f"pose needs 4 corners), got {min_corners!r}")
    grey = to_grey(image)
    corners, ids, _ = _detector(board).detectMarkers(grey)
    if ids is None or len(ids) == 0:
        return None
    ids = np.asarray(ids).ravel().astype(int)
    n_tags = board.tags[0] * board.tags[1]
    uniq, counts = np.unique(ids, return_counts=True)
    twice = set(uniq[counts > 1].tolist())
    pid, uv = [], []
    for tid, c in zip(ids, corners, strict=True):
        if tid < 0 or tid >= n_tags or tid in twice:
            continue
        printed = board.tag_corner_ids(int(tid))
        c = np.asarray(c, dtype=np.float64).reshape(4, 2)
        for k in range(4):
            pid.append(printed[_CV_TO_PRINTED[k]])
            uv.append(c[k])
    if len(pid) < min_corners:
        return None
    pid, uv = np.array(pid), np.array(uv)
    h, w = grey.shape[:2]
    inside = np.all((uv >= EDGE_PX) & (uv <= [w - 1 - EDGE_PX, h - 1 - EDGE_PX]), axis=1)
    pid, uv = pid[inside], uv[inside]
    if len(pid) < min_corners or not spans_plane(board.object_points()[pid]):
        return None
    win = _window(board, pid, uv)
    refined = cv2.cornerSubPix(grey, uv.reshape(-1, 1, 2).astype(np.float32), (win, win),
                               (-1, -1), SUBPIX_CRITERIA).reshape(-1, 2).astype(np.float64)
    keep = np.linalg.norm(refined - uv, axis=1) <= win
    pid, refined = pid[keep], refined[keep]
    if len(pid) < min_corners or not spans_plane(board.object_points()[pid]):
        return None
    out = np.full((board.n_corners, 2), np.nan)
    out[pid] = refined
    return out


def _window(board: AprilGrid, pid: np.ndarray, uv: np.ndarray) -> int:
    """cornerSubPix half-window (px): a fraction of the smallest image size of the clean
    saddle (the smaller of the tag border and the corner square) over the seen corners,
    from the homography of the seen corners."""
    P = board.object_points()[pid, :2]
    H, _ = cv2.findHomography(P, uv, 0)
    if H is None:
        return 3
    bits = APRILGRID_FAMILIES[board.family][1] + 2 * APRILGRID_BORDER_BITS
    d = min(board.gap, board.tag_size * APRILGRID_BORDER_BITS / bits)
    a = cv2.perspectiveTransform(P.reshape(-1, 1, 2), H).reshape(-1, 2)
    b = cv2.perspectiveTransform((P + [d, 0]).reshape(-1, 1, 2), H).reshape(-1, 2)
    c = cv2.perspectiveTransform((P + [0, d]).reshape(-1, 1, 2), H).reshape(-1, 2)
    side = min(np.linalg.norm(b - a, axis=1).min(), np.linalg.norm(c - a, axis=1).min())
    if not np.isfinite(side):
        return 3
    return int(np.clip(round(APRILGRID_SUBPIX_FRACTION * side), 3, 11))
