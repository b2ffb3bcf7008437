"""Sub-pixel primitives shared by the detectors (:mod:`rasc.vision.detect` for the
chessboard and ChArUco, :mod:`rasc.vision.aprilgrid`): OpenCV's thread setting for
reproducible bytes, cornerSubPix's stop rule, and the saddle-point refinement."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import cv2
import numpy as np


@contextlib.contextmanager
def _opencv_threads(n: int = 1) -> Iterator[None]:
    """Run OpenCV with ``n`` threads inside the block; the caller's setting is restored.

    rasc's own OpenCV work (:func:`detect_corners`,
    :func:`~rasc.vision.camera.calibrate_intrinsics`,
    :func:`~rasc.vision.camera.estimate_extrinsics`) runs under ``_opencv_threads(1)``:
    calibrateCamera's multi-threaded sums change the last bits from run to run (measured:
    three runs, three different results), and the same seed must give the same bytes;
    parallelism comes from processes instead (the experiments' ``--workers``). Only the
    duration of the call is affected, not the rest of the user's program (the setting is
    process-wide while the block runs: do not run rasc's OpenCV work beside multi-threaded
    OpenCV work of your own that relies on its thread count).

    The OpenBLAS that OpenCV's wheel bundles (its LAPACK: ``cv2.fisheye.calibrate``'s
    solves) is held to ``n`` threads too: with two threads the fisheye intrinsics of the
    same corners differ in their last bits from one thread's (measured), so the reproduction's
    serial path and its single-threaded pool workers gave different bytes.
    """
    before = cv2.getNumThreads()
    cv2.setNumThreads(int(n))
    try:
        with _blas_controller().limit(limits=int(n)):
            yield
    finally:
        cv2.setNumThreads(before)


_BLAS = []


def _blas_controller():
    """threadpoolctl's controller of the BLAS libraries loaded (OpenCV's among them),
    made once: a controller's limit is cheaper than a fresh scan per call."""
    if not _BLAS:
        from threadpoolctl import ThreadpoolController

        _BLAS.append(ThreadpoolController())
    return _BLAS[0]


#: cornerSubPix stop rule. (EPS + COUNT, 30, 0.001) reproduces the independent figures of
#: docs/NOTES.md, "Real data used by the tests" exactly (0.408695 / 0.458636 px on
#: OpenCV's stereo samples);
#: 0.01 instead of 0.001 moves them by ~8e-4 px.
SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 0.001)


def saddle_points(grey: np.ndarray, corners: np.ndarray, r: int, sigma: float, *,
                  iterations: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """:func:`refine_saddle`'s refinement for any corners (N, 2) with a given half-window
    ``r`` (pixels) and blur ``sigma``: the refined corners (N, 2) and, per corner, whether
    it is a saddle that moved at most ``r`` (where not, its row is the starting corner's
    and must not be used). The targets seen in part (ChArUco) drop such corners one by
    one; a chessboard view (:func:`refine_saddle`) is refused whole."""
    from scipy.ndimage import map_coordinates

    c0 = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
    # Only the rectangle the samples can reach is smoothed: the corners, the window r,
    # ``iterations`` steps of at most 1 px, the bilinear neighbour, and the Gaussian's
    # reach (OpenCV's kernel for float images spans 4σ each side) plus a pixel. A pixel's
    # blur depends on its neighbourhood only, so there it is the whole image's blur bit for
    # bit (checked on 1740 crops of 116 renders, any offset and size, σ 0.8 to 2), and the
    # samples are taken at the same coordinates less the rectangle's integer corner
    # (exact): the same corners, for about a sixth of the blur's time on a 1280×960 view.
    reach = r + iterations + 2 + int(np.ceil(4 * sigma)) + 1
    height, width = grey.shape[:2]
    x0 = int(np.clip(np.floor(c0[:, 0].min()) - reach, 0, width))
    y0 = int(np.clip(np.floor(c0[:, 1].min()) - reach, 0, height))
    x1 = int(np.clip(np.ceil(c0[:, 0].max()) + reach + 1, x0, width))
    y1 = int(np.clip(np.ceil(c0[:, 1].max()) + reach + 1, y0, height))
    smooth = cv2.GaussianBlur(grey[y0:y1, x0:x1].astype(np.float32), (0, 0), sigma)
    o = np.arange(-r, r + 1, dtype=np.float64)
    dy, dx = (g.ravel() for g in np.meshgrid(o, o, indexing="ij"))
    A = np.stack([dx * dx, dx * dy, dy * dy, dx, dy, np.ones_like(dx)], axis=1)
    w = np.exp(-(dx ** 2 + dy ** 2) / (2 * (r / 1.5) ** 2))
    P = np.linalg.pinv(A * w[:, None]) * w[None, :]            # (6, (2r+1)²)
    c = c0.copy()
    ok = np.ones(len(c), dtype=bool)
    for _ in range(iterations):
        xs = c[:, 0, None] + dx[None]
        ys = c[:, 1, None] + dy[None]
        samples = map_coordinates(smooth, [ys.ravel() - y0, xs.ravel() - x0], order=1,
                                  mode="nearest").reshape(len(c), -1)
        a, b, cc, d, e, _ = (samples @ P.T).T
        det = 4 * a * cc - b * b
        ok &= det < 0                    # not a saddle: no corner here
        if not np.any(ok):
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.stack([(b * e - 2 * cc * d) / det, (b * d - 2 * a * e) / det], axis=1)
        step[~ok] = 0.0
        c += np.clip(step, -1.0, 1.0)
        if np.max(np.abs(step)) < 1e-4:
            break
    ok &= np.linalg.norm(c - c0, axis=1) <= r
    c[~ok] = c0[~ok]
    return c, ok


def saddle_points_inside(grey: np.ndarray, corners: np.ndarray, r: int, sigma: float
                         ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`saddle_points` for the targets seen in part (ChArUco, AprilGrid), which drop
    corners one by one: also not usable is a corner whose window (r + 2σ) leaves the
    image before or after the move, because such a window sees a made-up border
    (measured: a corner 1.7 px from the top edge moved 2 px out of the image)."""
    moved, ok = saddle_points(grey, corners, r, sigma)
    edge = r + int(np.ceil(2 * sigma))
    height, width = grey.shape[:2]
    for pts in (np.asarray(corners, dtype=np.float64).reshape(-1, 2), moved):
        ok &= np.all(pts >= edge, axis=1) & (pts[:, 0] <= width - 1 - edge) \
            & (pts[:, 1] <= height - 1 - edge)
    return moved, ok
