"""Rendering through any lens (:mod:`rasc.geometry.lens`) with exact truth.

MuJoCo renders pinhole cameras only, and one pinhole render cannot hold a wide lens's
image: a fisheye of 150° would need an ideal image ``tan(75°)·f`` wide, and one of 180°
an infinite one. So the image of a lens is put together from several pinhole views from
the camera's own centre, turned towards the faces of a cube (front, left, right, up,
down; back when a ray needs it): every output sub-pixel's ray (the lens model's
inverse, :func:`pixel_rays`) is sent to the face it points at most directly and read
there with bilinear interpolation (two faces blended over :data:`BLEND_PX` across their
seam). Each face is rendered only over the rays it serves, with a margin, as fine as
the sub-pixels need there (:data:`VIEW_QUALITY`). The output is built at S times its
size and averaged over S × S blocks, as
:meth:`rasc.sim.scene.StereoHeadSim.render_camera` does for ``supersample`` S, with S
at least :data:`MIN_SUBPIXELS`: then the corners detected on a 150° fisheye are as
close to the truth as on the stock pinhole's renders, and the seams between the faces do
not show (tests/sim/test_lens_render.py measures both).

A point ``P`` in the camera frame lands where ``rasc.geometry.lens.project_points(P, K,
dist, model=)`` puts it: the truth of every corner comes from the lens core, as for the
pinhole renders.
"""

from __future__ import annotations

import math

import numpy as np

from rasc.errors import InputError, RascError
from rasc.geometry import lens as lens_core

#: each face's pixels per step between neighbouring output sub-pixels where they are
#: closest in its image (0.5: about the output's own pixel density, each output pixel's
#: 2 x 2 sub-pixels read bilinearly from it). Views finer than their reading alias, being
#: read at points: measured on the 640x480 renders of tests/sim/test_lens_render.py
#: (seeds 0-4), 0.5 gives 0.017-0.018 px RMS and seam/off 1.05-1.17, 1 gives
#: 0.018-0.021 px and 0.98-1.18 for four times the rendered pixels; with one sub-pixel
#: per pixel 1, 1.5 and 3 gave 0.061, 0.065 and 0.176 px (the 9x6 board 0.8 m ahead of a
#: 150° fisheye on 1280x960)
VIEW_QUALITY = 0.5
#: through a lens every output pixel averages at least this many sub-pixels each way
#: (supersample 1 renders as 2). Measured with a 7x4 board of 40 mm squares on 640x480
#: renders of a 150° fisheye (tests/sim/test_lens_render.py, seeds 0-2, views at the
#: sub-pixels' density): 1 sub-pixel gives 0.032-0.035 px RMS, and corners on a seam
#: 1.3-1.5 times the error of the same corners off every seam; 2 sub-pixels give
#: 0.018-0.021 px (the stock pinhole's S = 1 pose views: 0.017-0.019 px) and 0.98-1.14
MIN_SUBPIXELS = 2
#: output pixels over which two faces are blended across their seam (0: a step).
#: Measured as MIN_SUBPIXELS (seeds 0-2): corners on a seam against the same corners off
#: it 0.98-1.14 blended over 6 px, 1.09-1.21 without
BLEND_PX = 6.0
#: pixels of margin around the rays a face serves (bilinear reads one pixel beyond)
VIEW_MARGIN_PX = 3
#: the largest face image rendered (width or height, pixels)
MAX_VIEW_PX = 8192

#: the cube's faces: the view's axes in the camera frame (columns x, y, z; OpenCV axes)
FACES = {
    "front": np.eye(3),
    "right": np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]),
    "left": np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]]),
    "down": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]),
    "up": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
    "back": np.array([[-1.0, 0, 0], [0, 1, 0], [0, 0, -1]]),
}


def _fisheye_fold(d: np.ndarray) -> float:
    """The angle θ (rad, at most π) up to which the fisheye's θ_d(θ) increases."""
    theta = np.linspace(0.0, math.pi, 20001)
    _, dtheta_d = lens_core._fisheye_theta_d(theta, d)
    bad = np.flatnonzero(dtheta_d <= 0)
    return float(theta[bad[0] - 1]) if len(bad) else math.pi


def _rays(x: np.ndarray, y: np.ndarray, d: np.ndarray, model: str):
    """Unit rays (N, 3) and where they exist (N,) of distorted normalised points."""
    if model == "fisheye":
        fold = _fisheye_fold(d)
        rd = np.hypot(x, y)
        grid = np.linspace(0.0, fold, 4001)
        grid_d, _ = lens_core._fisheye_theta_d(grid, d)
        ok = rd < grid_d[-1]
        theta = np.interp(rd, grid_d, grid)
        for _ in range(2):          # Newton from the table's guess (1e-7): to round-off
            f, df = lens_core._fisheye_theta_d(theta, d)
            theta = np.clip(theta - (f - rd) / df, 0.0, fold)
        with np.errstate(invalid="ignore", divide="ignore"):
            s = np.where(rd > 1e-12, np.sin(theta) / np.where(rd > 0, rd, 1.0), 1.0)
        rays = np.stack([s * x, s * y, np.cos(theta)], axis=1)
    else:
        xu, yu, ok = lens_core._undistort(x, y, d, lens_core.UNDISTORT_TOL,
                                          lens_core.UNDISTORT_MAX_ITER, model)
        rays = np.stack([xu, yu, np.ones_like(xu)], axis=1)
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    rays[~ok] = (0.0, 0.0, 1.0)
    return rays, ok


def pixel_rays(K: np.ndarray, dist, size: tuple[int, int], model: str = "pinhole",
               uv=None):
    """The unit ray (camera frame) of every pixel of a lens's image.

    Parameters
    ----------
    K : array-like, shape (3, 3)
    dist : array-like, shape (k,), or None — the coefficients of ``model``
    size : (width, height)
    model : "pinhole" or "fisheye"
    uv : array-like, shape (2,), optional — one pixel only: its ray (3,), or None
        where the lens has none

    Returns
    -------
    rays : ndarray, shape (height, width, 3)
        For a fisheye up to the model's fold or θ = 180° (rays behind the camera's plane
        included: θ ≥ 90° has no normalised coordinate, but it has a ray); for a pinhole
        the inverse of its distortion (:func:`rasc.geometry.lens.undistort_normalized`).
    ok : ndarray of bool, shape (height, width)
        False where the model has no ray (past its fold): those pixels stay black.
    """
    K = lens_core.validate_K(K)
    model = lens_core.check_model(model)
    d = lens_core._coefficients(dist, model=model)
    if uv is not None:
        x, y = lens_core._normalize_pixels(np.asarray(uv, dtype=float).reshape(1, 2), K)
        rays, ok = _rays(x, y, d, model)
        return rays[0] if ok[0] else None
    w, h = size
    vv, uu = np.mgrid[0:h, 0:w].astype(float)
    x, y = lens_core._normalize_pixels(np.stack([uu.ravel(), vv.ravel()], axis=1), K)
    rays, ok = _rays(x, y, d, model)
    return rays.reshape(h, w, 3), ok.reshape(h, w)


def _finest_step(rays: np.ndarray, main: np.ndarray, R: np.ndarray,
                 every: int = 4) -> float:
    """The smallest distance, in the normalised image of the view ``R``, between the rays
    of neighbouring pixels (along rows and columns) of the pixels ``main`` (h, w), on a
    lattice of every ``every``-th pixel."""
    h, w = main.shape
    vv, uu = np.mgrid[0:h - 1:every, 0:w - 1:every]
    pick = main[vv, uu] & main[vv + 1, uu] & main[vv, uu + 1]
    if not pick.any():
        vv, uu = np.nonzero(main[:-1, :-1] & main[1:, :-1] & main[:-1, 1:])
        pick = np.ones(len(vv), bool)
        if not pick.any():
            return 1e-3
    v, u = vv[pick], uu[pick]

    def ab(r):
        q = r @ R
        return q[:, :2] / q[:, 2:]

    here = ab(rays[v, u])
    step = np.minimum(np.linalg.norm(ab(rays[v, u + 1]) - here, axis=1),
                      np.linalg.norm(ab(rays[v + 1, u]) - here, axis=1))
    return float(step.min())


def scaled_K(K: np.ndarray, S: int) -> np.ndarray:
    """The camera matrix of an image S times larger whose S × S block means are the image
    of ``K`` (pixel centres at integers: c → S·(c + 0.5) − 0.5)."""
    K_S = np.array(K, dtype=float)
    K_S[:2, :2] *= S
    K_S[:2, 2] = S * (K_S[:2, 2] + 0.5) - 0.5
    return K_S


class LensView:
    """The pinhole views one lens's image is made of, and where each output pixel reads.

    Built once per eye (the rays and maps: 1.8 s at 1280×960, measured on 2 cores); then
    :meth:`render` makes each image from the views rendered at the current state.

    Parameters
    ----------
    K : array-like, shape (3, 3) — the lens camera's matrix
    dist : coefficients of ``model`` (or None)
    size : (width, height) of the output image
    model : "pinhole" or "fisheye"
    supersample : int — build the output at S times its size, then average S × S blocks
    quality : float — :data:`VIEW_QUALITY`
    turn : array-like, shape (3, 3), optional — the cube turned by this rotation (camera
        frame): the seams between the faces fall elsewhere in the image (a test compares
        the same corners on and off a seam)
    blend_px : float — :data:`BLEND_PX`
    """

    def __init__(self, K, dist, size: tuple[int, int], model: str = "pinhole",
                 supersample: int = 1, quality: float = VIEW_QUALITY, turn=None,
                 blend_px: float = None) -> None:
        blend_px = BLEND_PX if blend_px is None else float(blend_px)
        self.size = (int(size[0]), int(size[1]))
        #: sub-pixels averaged per pixel each way: the supersample, at least
        #: MIN_SUBPIXELS
        self.supersample = S = max(int(supersample), MIN_SUBPIXELS)
        w, h = S * self.size[0], S * self.size[1]
        rays, ok = pixel_rays(scaled_K(K, S), dist, (w, h), model)
        self.ok = ok.ravel()
        names = list(FACES)
        turn = np.eye(3) if turn is None else np.asarray(turn, dtype=float)
        faces = {n: turn @ R for n, R in FACES.items()}
        self.faces = faces
        # in the cube's frame a face is an axis and a sign: the face a ray reads is its
        # largest component's, the face across the nearest seam its second largest's
        by_axis = {(int(np.argmax(np.abs(R[:, 2]))), int(np.sign(R[:, 2].sum()))): n
                   for n, R in FACES.items()}
        code = np.array([[names.index(by_axis[(k, -1)]), names.index(by_axis[(k, 1)])]
                         for k in range(3)])
        flat = rays.reshape(-1, 3)
        comp = flat if np.array_equal(turn, np.eye(3)) else flat @ turn  # the cube's axes
        mag = np.abs(comp)
        k1 = np.argmax(mag, axis=1)
        k2 = (3 - k1 - np.argmin(mag, axis=1)) % 3          # the middle component
        k2 = np.where(k2 == k1, (k1 + 1) % 3, k2)           # (all three equal)
        rows = np.arange(len(comp))
        c1, c2 = comp[rows, k1], comp[rows, k2]
        face = code[k1, (c1 > 0).astype(np.intp)]
        other = code[k2, (c2 > 0).astype(np.intp)]
        #: the face each output (sub-)pixel reads, an index into FACES (-1: no ray)
        self.face = np.where(ok, face.reshape(h, w), -1).astype(np.int8)
        # across a seam the two faces are blended over blend_px output pixels (a ramp,
        # not a step, between two renders' rasterisations): the other face's weight
        # falls from 1/2 at the seam to 0 at blend_px / 2 from it
        weight = np.zeros(h * w)
        if blend_px > 0:
            gap = (np.abs(c1) - np.abs(c2)).reshape(h, w)
            gy, gx = np.gradient(gap)
            dist_px = gap / np.maximum(np.hypot(gx, gy), 1e-15)
            weight = (0.5 * np.clip(1.0 - dist_px / (0.5 * blend_px * S), 0.0, 1.0)).ravel()
            weight[~self.ok] = 0.0
        del comp, mag, c1, c2
        m = VIEW_MARGIN_PX
        self.views = []
        for i, name in enumerate(names):
            main = (face == i) & self.ok
            if not main.any():
                continue
            mine = main | ((other == i) & (weight > 0))
            R = faces[name]
            index = np.flatnonzero(mine)
            q = flat[index] @ R                              # in the face's axes
            a, b = q[:, 0] / q[:, 2], q[:, 1] / q[:, 2]
            f = quality / _finest_step(rays, main.reshape(h, w), R)
            a0, a1, b0, b1 = a.min(), a.max(), b.min(), b.max()
            # its own size, rounded up to 32 px (the eyes' faces share renderers)
            size = tuple(32 * math.ceil((math.ceil(e * f) + 2 * m + 1) / 32)
                         for e in (a1 - a0, b1 - b0))
            if max(size) > MAX_VIEW_PX:
                raise RascError(f"the lens needs a view of {size[0]}x{size[1]} px to render "
                                f"at this size and supersample (more than {MAX_VIEW_PX}); "
                                "use a smaller supersample or a wider field of view")
            K_view = np.array([[f, 0.0, m - f * a0], [0.0, f, m - f * b0], [0.0, 0.0, 1.0]])
            coords = np.stack([f * b + K_view[1, 2], f * a + K_view[0, 2]])  # (row, col)
            wt = np.where(main[index], 1.0 - weight[index], weight[index])
            self.views.append((name, R, K_view, size, index, wt, coords))

    def render(self, sim, eye: str) -> np.ndarray:
        """The ``eye``'s image through the lens at the simulator's current state: 8-bit
        grey (height, width); pixels without a ray are black."""
        from scipy.ndimage import map_coordinates

        from rasc.vision.camera import to_grey

        w, h = self.size
        S = self.supersample
        out = np.zeros(S * w * S * h)
        for _, R, K_view, size, index, weight, coords in self.views:
            grey = to_grey(sim.render_view(eye, R, K_view, size), order="rgb")
            out[index] += weight * map_coordinates(grey.astype(float), coords, order=1,
                                                   mode="nearest")
        out = out.reshape(S * h, S * w)
        if S > 1:
            out = out.reshape(h, S, w, S).mean(axis=(1, 3))
        return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def focal_for_fov(fov_deg: float, width: int, dist, model: str = "pinhole",
                  name: str = "fov") -> float:
    """The focal length (px) that puts a ray ``fov_deg / 2`` off the axis, horizontally,
    at the image's left and right edges (``width / 2`` from the centre) through the lens:
    ``fov_deg`` is the horizontal field of view. ``name`` names it in messages."""
    half = math.radians(float(fov_deg)) / 2
    model = lens_core.check_model(model)
    d = lens_core._coefficients(dist, model=model)
    if model == "fisheye":
        folded = half >= _fisheye_fold(d)
        edge = float(lens_core._fisheye_theta_d(np.array(half), d)[0])
    else:
        if half >= math.pi / 2:
            raise InputError(f"{name} {fov_deg:g} deg: a pinhole lens sees less than 180 deg")
        x = np.linspace(0.0, math.tan(half), 512)
        xd = lens_core.distort_normalized(np.stack([x, np.zeros_like(x)], axis=1), d)[:, 0]
        folded = bool(np.any(np.diff(xd) <= 0))
        edge = float(xd[-1])
    if folded or not edge > 0:
        raise InputError(f"{name} {fov_deg:g} deg lies past the lens model's fold with "
                         f"distortion {', '.join(f'{v:g}' for v in d)}: rays that far off "
                         "the axis have no image; use a smaller field of view or "
                         "coefficients")
    return (width / 2) / edge
