"""What the report draws from the images: each view's detected corners and their
reprojection residuals under the calibration, and the corner coverage of each eye.

Residuals: an intrinsics view's board pose is its own (``cv2.solvePnP`` with the eye's
calibrated K and distortion, the refinement's model of those views); the pose views of
both eyes share ONE board pose in the base frame (the target stays put while the units
move, :mod:`rasc.head.refine`), fitted here to all of them at once
(:func:`scipy.optimize.least_squares`, started from the first pose view's closed-form
extrinsics), and every pose corner is predicted through the whole head (eq. 1–2 with the
eye's unit). Detection is :meth:`rasc.vision.dataset.Dataset.detect`'s (kept per process:
after ``rasc calibrate`` in the same process nothing is detected again).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rasc.geometry.frames import EYES

#: the coverage grid: the image divided into this many cells (columns, rows)
COVERAGE_GRID = (8, 6)


@dataclass
class ViewResiduals:
    """One view's reprojection residuals as the report draws them: eye, role, image, residuals,
    outliers."""
    eye: str
    role: str
    file: str
    corners: np.ndarray            # (N, 2) detected
    residuals: np.ndarray          # (N, 2) predicted − detected, px


@dataclass
class ReportData:
    """What the report draws of a dataset: every view's residuals and each eye's image size."""
    views: list[ViewResiduals] = field(default_factory=list)
    image_size: dict[str, tuple[int, int]] = field(default_factory=dict)

    def of(self, eye: str, role: str | None = None) -> list[ViewResiduals]:
        """The views of one eye (and one role, if given)."""
        return [v for v in self.views if v.eye == eye and (role is None or v.role == role)]


def coverage(corners: list[np.ndarray], size: tuple[int, int],
             grid: tuple[int, int] = COVERAGE_GRID) -> float:
    """The fraction of the grid's cells that hold at least one corner."""
    w, h = size
    hit = np.zeros(grid[::-1], bool)
    for c in corners:
        if len(c) == 0:
            continue
        i = np.clip((c[:, 0] / w * grid[0]).astype(int), 0, grid[0] - 1)
        j = np.clip((c[:, 1] / h * grid[1]).astype(int), 0, grid[1] - 1)
        hit[j, i] = True
    return float(hit.mean())


def report_data(head, dataset, detector: str = "saddle") -> ReportData:
    """Detections and residuals of every image of ``dataset`` under ``head``."""
    import cv2
    from scipy.optimize import least_squares

    from rasc.geometry.transforms import invert_transform, make_transform, matrix_from_rotvec

    P = dataset.board.object_points().astype(float)
    data = ReportData()
    pose_obs = []
    for eye in EYES:
        e = getattr(head, eye)
        data.image_size[eye] = tuple(e.image_size)
        det = dataset.detect(eye, "intrinsics", method=detector)
        for f, c in det.corners.items():
            ok, rvec, tvec = cv2.solvePnP(P, c.astype(float), e.K, e.dist)
            if not ok:
                continue
            rvec, tvec = cv2.solvePnPRefineLM(P, c.astype(float), e.K, e.dist, rvec, tvec)
            uv, _ = cv2.projectPoints(P, rvec, tvec, e.K, e.dist)
            data.views.append(ViewResiduals(eye, "intrinsics", f, c, uv[:, 0] - c))
        det = dataset.detect(eye, "pose", method=detector, board_seen=True)
        for f, c in det.corners.items():
            entry = det.entries[f]
            pose_obs.append((eye, f, c, entry.pan, entry.tilt))
    if not pose_obs:
        return data

    def predict(x):
        T_bw = make_transform(matrix_from_rotvec(x[:3]), x[3:])
        pb = P @ T_bw[:3, :3].T + T_bw[:3, 3]
        return [getattr(head, eye).project(pb, pan, tilt) for eye, _, _, pan, tilt in pose_obs]

    # start: the first pose view's own board pose (PnP), carried into the base frame
    eye, f, c, pan, tilt = pose_obs[0]
    e = getattr(head, eye)
    ok, rvec, tvec = cv2.solvePnP(P, c.astype(float), e.K, e.dist)
    T_cw = make_transform(matrix_from_rotvec(rvec.ravel()), tvec.ravel())
    T_bw = invert_transform(e.T_cam_from_base(pan, tilt)) @ T_cw
    from scipy.spatial.transform import Rotation

    x0 = np.r_[Rotation.from_matrix(T_bw[:3, :3]).as_rotvec(), T_bw[:3, 3]]
    sol = least_squares(lambda x: np.concatenate(
        [(u - o[2]).ravel() for u, o in zip(predict(x), pose_obs, strict=True)]), x0,
        method="lm")
    for uv, (eye, f, c, _, _) in zip(predict(sol.x), pose_obs, strict=True):
        data.views.append(ViewResiduals(eye, "pose", f, c, uv - c))
    return data
