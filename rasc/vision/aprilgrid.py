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
    corners_by_id,
    spans_plane,
)
from rasc.vision.images import to_grey
from rasc.vision.subpixel import SUBPIX_CRITERIA, _opencv_threads, saddle_points_inside

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
                     min_corners: int = MIN_VIEW_CORNERS,
                     method: str = "saddle") -> np.ndarray | None:
    """The AprilGrid corners seen in ``image``, by id: (N, 2) float64 with NaN rows for
    the corners not seen; ``None`` when fewer than ``min_corners`` are seen or they all
    lie on one line (no pose, no homography).

    Tags with an id outside the grid, and ids seen twice (a stray tag in the scene), are
    left out. Each kept corner is refined with cornerSubPix (:data:`SUBPIX_CRITERIA`,
    half-window :data:`APRILGRID_SUBPIX_FRACTION` of the local saddle size), then with
    ``method="saddle"`` (the default) moved to the saddle point of the smoothed image
    (:func:`rasc.vision.detect.saddle_points`, half-window the clean saddle's size, 2 to
    6 px); a corner that is not a saddle there, or whose window leaves the image, is
    dropped. ``method="classic"``: cornerSubPix alone. Measured on renders against the
    truth: 0.08–0.11 px RMS with cornerSubPix alone, about a tenth of that with the saddle.
    """
    if method not in ("classic", "saddle"):
        raise InputError(f"detect_aprilgrid: unknown method {method!r} (use classic or "
                         "saddle)")
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
    tags = {}       # tag id -> its corners as printed (bottom left, bottom right, ...)
    for tid, c in zip(ids, corners, strict=True):
        if tid < 0 or tid >= n_tags or tid in twice:
            continue
        c = np.asarray(c, dtype=np.float64).reshape(4, 2)
        tags[int(tid)] = c[np.argsort(_CV_TO_PRINTED)]
    if 4 * len(tags) < min_corners:
        return None
    tags = _reseeded(board, tags)
    pid = np.concatenate([board.tag_corner_ids(t) for t in tags])
    uv = np.concatenate(list(tags.values()))
    h, w = grey.shape[:2]
    inside = np.all((uv >= EDGE_PX) & (uv <= [w - 1 - EDGE_PX, h - 1 - EDGE_PX]), axis=1)
    pid, uv = pid[inside], uv[inside]
    if len(pid) < min_corners or not spans_plane(board.object_points()[pid]):
        return None
    win, side = _window(board, pid, uv)
    refined = cv2.cornerSubPix(grey, uv.reshape(-1, 1, 2).astype(np.float32), (win, win),
                               (-1, -1), SUBPIX_CRITERIA).reshape(-1, 2).astype(np.float64)
    keep = np.linalg.norm(refined - uv, axis=1) <= win
    pid, refined = pid[keep], refined[keep]
    if method == "saddle":
        # cornerSubPix leaves a bias of up to 0.1 px on sharp rendered edges (a sine in the
        # sub-pixel phase, as for ChArUco); the saddle point of the smoothed image does not.
        # Its window stays inside the clean saddle (the tag border, the corner square).
        r = int(np.clip(np.floor(side), 2, 6)) if np.isfinite(side) else 2
        sigma = float(np.clip(r / 3, 0.8, 2.0))
        moved, ok = saddle_points_inside(grey, refined, r, sigma)
        pid, refined = pid[ok], moved[ok]
    keep = _consistent(board, pid, refined)
    return corners_by_id(board, pid[keep], refined[keep], min_corners)


#: A tag corner farther than this fraction of the local saddle size from where the
#: neighbouring tags' centres put it is moved there before refinement (see _reseeded)
RESEED_FRACTION = 0.3


def _diagonals_meet(q: np.ndarray) -> np.ndarray:
    """Where the diagonals of the quadrilateral q (4, 2) (corners in order) cross: the
    image of the tag's centre, also when the quadrilateral is the tag scaled about it."""
    a, b, c, d = q
    M = np.column_stack([c - a, b - d])
    try:
        s = np.linalg.solve(M, b - a)[0]
    except np.linalg.LinAlgError:
        return q.mean(axis=0)
    return a + s * (c - a)


def _reseeded(board: AprilGrid, tags: dict) -> dict:
    """The tags' corners (printed order, as ``tags``), each moved to where the homography
    of the neighbouring tags' centres (tags within 2 columns and rows, at least 4, RANSAC)
    puts it when OpenCV's corner lies more than :data:`RESEED_FRACTION` of the local
    saddle size away. Measured (50°, blur 1.5 px, noise 5 grey levels): OpenCV's tag
    outline then takes in the corner squares, which touch the tag, so every corner of
    many tags lies a corner square out (10-16 px); their centres stay right, and
    cornerSubPix from the moved corners finds the true saddles."""
    ids = np.array(sorted(tags))
    cols = board.tags[0]
    a, p = board.tag_size, board.pitch
    col, row = ids % cols, ids // cols
    obj_c = np.column_stack([col * p + a / 2, -(row * p + a / 2)])
    img_c = np.array([_diagonals_meet(tags[t]) for t in ids])
    P = board.object_points()
    bits = APRILGRID_FAMILIES[board.family][1] + 2 * APRILGRID_BORDER_BITS
    d = min(board.gap, board.tag_size * APRILGRID_BORDER_BITS / bits)
    out = {}
    for k, t in enumerate(ids):
        near = np.flatnonzero((np.abs(col - col[k]) <= 2) & (np.abs(row - row[k]) <= 2))
        q = tags[t]
        if len(near) >= 4 and spans_plane(obj_c[near]):
            A, _ = cv2.estimateAffine2D(obj_c[near], img_c[near], method=cv2.LMEDS)
            scale = 1.0 if A is None else min(np.linalg.norm(A[:, 0]), np.linalg.norm(A[:, 1]))
            H, _ = cv2.findHomography(obj_c[near], img_c[near],
                                      cv2.RANSAC if len(near) >= 5 else 0, 0.2 * p * scale)
            if H is not None:
                pred = cv2.perspectiveTransform(
                    P[board.tag_corner_ids(int(t)), :2].reshape(-1, 1, 2), H).reshape(-1, 2)
                far = np.linalg.norm(q - pred, axis=1) > RESEED_FRACTION * d * scale
                q = np.where(far[:, None], pred, q)
        out[int(t)] = q
    return out


#: A corner farther than this fraction of the local saddle size (the smaller of the tag
#: border and the corner square, in pixels) from where its neighbours' homography puts it
#: is dropped. Measured: on blurred, noisy, oblique views (50°, blur 1.5 px, noise 5
#: grey levels) OpenCV's tag outline can take in the corner squares (they touch), and
#: the corner then settles on the diagonal neighbour's saddle, a corner square or more
#: (≥ 1 saddle size) off; true corners sit within a few hundredths of it.
CONSISTENCY_FRACTION = 0.35

#: the neighbourhood of a tag for that check, in tags each way (lens distortion bends
#: three tags by a small fraction of a pixel)
CONSISTENCY_REACH = 1


def _consistent(board: AprilGrid, pid: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(M,) True for the corners that agree with their neighbours: the least-squares
    homography of the seen corners of a tag and its neighbours (tags within
    :data:`CONSISTENCY_REACH` columns and rows) puts each of the tag's corners within
    :data:`CONSISTENCY_FRACTION` of the local saddle size (at least 1 px) of where it was
    found. Two passes: the second fits only the corners the first kept, so a good corner
    next to a bad one is kept (a tag whose neighbourhood the first pass emptied keeps the
    first verdict). Least squares, not RANSAC: when OpenCV's tag outlines take in the
    corner squares on many tags at once, each tag alone is a perfect (scaled) square and
    RANSAC would accept one of them; together they fit no homography. A neighbourhood
    with fewer than 6 corners seen is not checked. Of two ids found within 1 px of each
    other, the one the check dropped goes, or both when it dropped neither."""
    keep = np.ones(len(pid), bool)
    if len(pid) < 6:
        return keep
    nx = board.inner_corners[0]
    cols = board.tags[0]
    tc, tr = (pid % nx) // 2, (pid // nx) // 2          # each corner's tag column, row
    tag = tr * cols + tc
    P = board.object_points()[pid, :2]
    bits = APRILGRID_FAMILIES[board.family][1] + 2 * APRILGRID_BORDER_BITS
    d = min(board.gap, board.tag_size * APRILGRID_BORDER_BITS / bits)
    groups = {t: (np.flatnonzero(tag == t),
                  np.flatnonzero((np.abs(tc - tc[tag == t][0]) <= CONSISTENCY_REACH)
                                 & (np.abs(tr - tr[tag == t][0]) <= CONSISTENCY_REACH)))
              for t in np.unique(tag)}

    def check(usable: np.ndarray) -> np.ndarray:
        out = usable.copy()         # unchecked corners keep the earlier verdict
        for own, near in groups.values():
            near = near[usable[near]]
            if len(near) < 6:
                continue
            H, _ = cv2.findHomography(P[near], uv[near], 0)
            if H is None:
                continue
            for i in own:
                q = H @ np.array([*P[i], 1.0])
                # the homography's local scale (its Jacobian at the corner), px per length
                J = (H[:2, :2] * q[2] - np.outer(q[:2], H[2, :2])) / q[2] ** 2
                tol = max(CONSISTENCY_FRACTION * d * min(np.linalg.norm(J[:, 0]),
                                                         np.linalg.norm(J[:, 1])), 1.0)
                out[i] = bool(np.linalg.norm(q[:2] / q[2] - uv[i]) <= tol)
        return out

    keep = check(check(keep))
    # two ids at one place (a corner on another's saddle): the one the check dropped
    # goes; if it dropped neither, both go
    gap = np.linalg.norm(uv[:, None] - uv[None], axis=2) + np.eye(len(pid)) * 1e9
    partner = gap.argmin(axis=1)
    twin = gap[np.arange(len(pid)), partner] <= 1.0
    return keep & ~(twin & keep[partner])


def _window(board: AprilGrid, pid: np.ndarray, uv: np.ndarray) -> tuple[int, float]:
    """cornerSubPix half-window (px), a fraction of the smallest image size of the clean
    saddle (the smaller of the tag border and the corner square) over the seen corners,
    from the homography of the seen corners; and that size (px, NaN if unknown)."""
    P = board.object_points()[pid, :2]
    H, _ = cv2.findHomography(P, uv, 0)
    if H is None:
        return 3, float("nan")
    bits = APRILGRID_FAMILIES[board.family][1] + 2 * APRILGRID_BORDER_BITS
    d = min(board.gap, board.tag_size * APRILGRID_BORDER_BITS / bits)
    a = cv2.perspectiveTransform(P.reshape(-1, 1, 2), H).reshape(-1, 2)
    b = cv2.perspectiveTransform((P + [d, 0]).reshape(-1, 1, 2), H).reshape(-1, 2)
    c = cv2.perspectiveTransform((P + [0, d]).reshape(-1, 1, 2), H).reshape(-1, 2)
    side = min(np.linalg.norm(b - a, axis=1).min(), np.linalg.norm(c - a, axis=1).min())
    if not np.isfinite(side):
        return 3, float("nan")
    return int(np.clip(round(APRILGRID_SUBPIX_FRACTION * side), 3, 11)), float(side)
