"""What the report draws from the images: each view's detected corners and their
reprojection residuals under the calibration, and the corner coverage of each eye.

Residuals: an intrinsics view's board pose is its own
(:func:`rasc.vision.camera.estimate_extrinsics` with the eye's calibrated K and
distortion, the refinement's model of those views); the pose views of both eyes share ONE
board pose in the base frame (the target stays put while the units move,
:mod:`rasc.head.refine`), fitted here to all of them at once
(:func:`scipy.optimize.least_squares`, started from the closed-form extrinsics of the pose
view showing the most corners), and every pose corner is predicted through the whole head
(eq. 1–2 with the eye's unit). A target seen in part (ChArUco, AprilGrid) counts only the
corners each view shows (:func:`rasc.vision.board.seen_mask`): the views keep those, by
id. Detection is :meth:`rasc.vision.dataset.Dataset.detect`'s (kept per process:
after ``rasc calibrate`` in the same process nothing is detected again).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rasc.geometry.frames import EYES
from rasc.vision.board import MIN_VIEW_CORNERS, seen_mask

#: the coverage grid: the image divided into this many cells (columns, rows)
COVERAGE_GRID = (8, 6)


@dataclass
class ViewResiduals:
    """One view's reprojection residuals as the report draws them: eye, role, image, the
    corners it shows and their residuals. A target seen in part (ChArUco, AprilGrid) keeps
    only the corners seen (``ids`` says which of the board's they are)."""
    eye: str
    role: str
    file: str
    corners: np.ndarray            # (N, 2) detected, the corners seen only
    residuals: np.ndarray          # (N, 2) predicted − detected, px
    ids: np.ndarray | None = None  # (N,) the board's corner ids (None: every corner, in order)
    rejected: np.ndarray | None = None   # (N,) bool: rejected by the refinement (None: none)

    @property
    def kept(self) -> np.ndarray:
        """(N,) bool: the corners the calibration kept (not rejected as outliers)."""
        return np.ones(len(self.corners), bool) if self.rejected is None else ~self.rejected


@dataclass
class ReportData:
    """What the report draws of a dataset: every view's residuals and each eye's image size
    (``skipped``: the views left out, each with the reason, one line each)."""
    views: list[ViewResiduals] = field(default_factory=list)
    image_size: dict[str, tuple[int, int]] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)

    def of(self, eye: str, role: str | None = None) -> list[ViewResiduals]:
        """The views of one eye (and one role, if given)."""
        return [v for v in self.views if v.eye == eye and (role is None or v.role == role)]

    def rms_by_role(self) -> dict[str, float]:
        """The reprojection RMS (px, over every corner of both eyes) of each role that has
        views: what :func:`rasc.report.verdict.verdict` compares with the calibration's own."""
        out = {}
        for role in ("intrinsics", "pose"):
            r = [v.residuals[v.kept] for v in self.views if v.role == role and v.kept.any()]
            if r:
                r = np.concatenate(r)
                out[role] = float(np.sqrt(np.mean(np.sum(r ** 2, axis=1))))
        return out


def coverage(corners: list[np.ndarray], size: tuple[int, int],
             grid: tuple[int, int] = COVERAGE_GRID) -> float:
    """The fraction of the grid's cells that hold at least one corner (NaN rows, the
    corners of a target seen in part that a view does not show, are left out)."""
    w, h = size
    hit = np.zeros(grid[::-1], bool)
    for c in corners:
        c = np.asarray(c, float).reshape(-1, 2)
        c = c[seen_mask(c)]
        if len(c) == 0:
            continue
        i = np.clip((c[:, 0] / w * grid[0]).astype(int), 0, grid[0] - 1)
        j = np.clip((c[:, 1] / h * grid[1]).astype(int), 0, grid[1] - 1)
        hit[j, i] = True
    return float(hit.mean())


def rejected_corners(doc: dict) -> dict[tuple[str, str], set[int]]:
    """The corners the whole-head refinement rejected as outliers, by (eye, file): board
    corner ids (the calibration document's ``refinement.images[].rejected_corners``)."""
    out: dict[tuple[str, str], set[int]] = {}
    for im in (doc.get("refinement") or {}).get("images") or []:
        ids = im.get("rejected_corners") if isinstance(im, dict) else None
        if ids:
            out[(im.get("eye"), im.get("file"))] = {int(k) for k in ids}
    return out


def report_data(head, dataset, detector: str = "saddle",
                min_corners: int = MIN_VIEW_CORNERS,
                rejected: dict[tuple[str, str], set[int]] | None = None,
                time_offset: float | None = None) -> ReportData:
    """Detections and residuals of every image of ``dataset`` under ``head``: only the
    corners each view shows (a target seen in part), with ``min_corners`` as the
    calibration used it. ``rejected`` (:func:`rejected_corners`): corners the calibration
    rejected, marked and left out of the shared board pose's fit. A view no board pose
    fits is left out (``skipped``). ``time_offset``: the calibration's estimate of δ for
    a continuous capture: each pose image's readings are then its joint stream at its time
    + δ, as the refinement had them (:mod:`rasc.head.refine.timing`)."""
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation

    from rasc.errors import RascError
    from rasc.geometry.transforms import invert_transform, make_transform, matrix_from_rotvec
    from rasc.vision.camera import estimate_extrinsics, project_board
    from rasc.vision.joint_stream import readings_at_offset

    board = dataset.board
    P = board.object_points().astype(float)
    data = ReportData()

    def out_of(eye: str, f: str, ids: np.ndarray) -> np.ndarray | None:
        bad = (rejected or {}).get((eye, f))
        return np.isin(ids, sorted(bad)) if bad else None

    pose_obs = []                  # (eye, file, seen ids, corners seen, pan, tilt)
    for eye in EYES:
        e = getattr(head, eye)
        data.image_size[eye] = tuple(e.image_size)
        det = dataset.detect(eye, "intrinsics", method=detector, min_corners=min_corners)
        for f, c in det.corners.items():
            seen = seen_mask(c)
            try:
                T_cw, _ = estimate_extrinsics(c, board, e.K, e.dist, lens=e.lens)
            except RascError as exc:
                data.skipped.append(f"{eye} intrinsics {f}: {exc}")
                continue
            uv = project_board(board, T_cw, e.K, e.dist, e.lens)[seen]
            ids = np.flatnonzero(seen)
            data.views.append(ViewResiduals(eye, "intrinsics", f, c[seen], uv - c[seen], ids,
                                            out_of(eye, f, ids)))
        det = dataset.detect(eye, "pose", method=detector, board_seen=True,
                             min_corners=min_corners)
        for f, c in det.corners.items():
            entry = det.entries[f]
            seen = seen_mask(c)
            pan, tilt = readings_at_offset(
                None if dataset.joint_stream is None else dataset.joint_stream[eye],
                [entry.time], np.array([entry.pan, entry.tilt]), time_offset)[0]
            pose_obs.append((eye, f, np.flatnonzero(seen), c[seen], pan, tilt))
    if not pose_obs:
        return data

    def predict(x):
        T_bw = make_transform(matrix_from_rotvec(x[:3]), x[3:])
        pb = P @ T_bw[:3, :3].T + T_bw[:3, 3]
        return [getattr(head, eye).project(pb[ids], pan, tilt)
                for eye, _, ids, _, pan, tilt in pose_obs]

    # start: the board pose of the pose view showing the most corners (its own PnP),
    # carried into the base frame
    T_bw = None
    for eye, _, ids, c, pan, tilt in sorted(pose_obs, key=lambda o: -len(o[2])):
        e = getattr(head, eye)
        full = np.full((board.n_corners, 2), np.nan)
        full[ids] = c
        try:
            T_cw, _ = estimate_extrinsics(full, board, e.K, e.dist, lens=e.lens)
        except RascError:
            continue
        T_bw = invert_transform(e.T_cam_from_base(pan, tilt)) @ T_cw
        break
    if T_bw is None:
        data.skipped.extend(f"{eye} pose {f}: no board pose fits" for eye, f, *_ in pose_obs)
        return data
    x0 = np.r_[Rotation.from_matrix(T_bw[:3, :3]).as_rotvec(), T_bw[:3, 3]]
    marks = [out_of(eye, f, ids) for eye, f, ids, *_ in pose_obs]
    keep = [np.ones(len(o[2]), bool) if m is None else ~m for o, m in zip(pose_obs, marks,
                                                                       strict=True)]
    n_kept = sum(int(k.sum()) for k in keep)

    def residuals(x):
        try:
            uv = predict(x)
        except RascError:      # a trial pose puts corners behind a camera: far off
            return np.full(2 * n_kept, 1e4)
        return np.concatenate([(u - o[3])[k].ravel()
                               for u, o, k in zip(uv, pose_obs, keep, strict=True)])

    try:
        if 2 * n_kept < len(x0):
            raise RascError(f"{n_kept} corners kept")
        uv = predict(least_squares(residuals, x0, method="lm").x)
    except RascError as exc:
        data.skipped.extend(f"{eye} pose {f}: no board pose through the head fits ({exc})"
                            for eye, f, *_ in pose_obs)
        return data
    for u, (eye, f, ids, c, _, _), m in zip(uv, pose_obs, marks, strict=True):
        data.views.append(ViewResiduals(eye, "pose", f, c, u - c, ids, m))
    return data
