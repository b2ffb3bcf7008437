"""Rendering through any lens (:mod:`rasc.geometry.lens`) with exact truth.

MuJoCo renders pinhole cameras only, and one pinhole render cannot hold a wide lens's
image: a fisheye of 150° would need an ideal image ``tan(75°)·f`` wide, and one of 180°
an infinite one. So the image of a lens is put together from several pinhole views from
the camera's own centre, turned towards the faces of a cube (front, left, right, up,
down; back when a ray needs it): every output pixel's ray (the lens model's inverse,
:func:`pixel_rays`) is sent to the face it points at most directly and read there with
bilinear interpolation. Each face is rendered only over the rays it serves, with a
margin, at a resolution at least :data:`VIEW_QUALITY` times the finest the output needs
there, so the seams between faces do not show (tests/sim/test_lens_render.py measures
it). With ``supersample`` S the output is built at S times its size and averaged over
S × S blocks, as :meth:`rasc.sim.scene.StereoHeadSim.render_camera` does.

A point ``P`` in the camera frame lands where ``rasc.geometry.lens.project_points(P, K,
dist, model=)`` puts it: the truth of every corner comes from the lens core, as for the
pinhole renders.
"""

from __future__ import annotations

import math

import numpy as np

from rasc.errors import InputError, RascError
from rasc.geometry import lens as lens_core

#: each face is rendered this many times finer than the output needs there (the smallest
#: step between neighbouring output pixels in the face's image). Measured with the 9x6
#: board 0.8 m ahead of a 150° fisheye on 1280x960 (f = 489 px), detected corners
#: against the truth: 0.061 px RMS at 1, 0.065 at 1.5, 0.176 at 3. A finer view read at
#: points is sharper than the output pixel and aliases; the lens's supersample
#: (averaging S x S sub-pixels) is what makes it finer: 0.031 px at 1 with S = 2.
VIEW_QUALITY = 1.0
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
        for _ in range(4):          # Newton from the table's guess: to round-off
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


def scaled_K(K: np.ndarray, S: int) -> np.ndarray:
    """The camera matrix of an image S times larger whose S × S block means are the image
    of ``K`` (pixel centres at integers: c → S·(c + 0.5) − 0.5)."""
    K_S = np.array(K, dtype=float)
    K_S[:2, :2] *= S
    K_S[:2, 2] = S * (K_S[:2, 2] + 0.5) - 0.5
    return K_S


class LensView:
    """The pinhole views one lens's image is made of, and where each output pixel reads.

    Built once per eye (the rays and maps cost about a second at 1280×960); then
    :meth:`render` makes each image from the views rendered at the current state.

    Parameters
    ----------
    K : array-like, shape (3, 3) — the lens camera's matrix
    dist : coefficients of ``model`` (or None)
    size : (width, height) of the output image
    model : "pinhole" or "fisheye"
    supersample : int — build the output at S times its size, then average S × S blocks
    quality : float — :data:`VIEW_QUALITY`
    """

    def __init__(self, K, dist, size: tuple[int, int], model: str = "pinhole",
                 supersample: int = 1, quality: float = VIEW_QUALITY) -> None:
        self.size = (int(size[0]), int(size[1]))
        self.supersample = S = int(supersample)
        w, h = S * self.size[0], S * self.size[1]
        rays, ok = pixel_rays(scaled_K(K, S), dist, (w, h), model)
        self.ok = ok.ravel()
        names = list(FACES)
        axes = np.stack([FACES[n][:, 2] for n in names])            # (6, 3)
        face = np.argmax(rays @ axes.T, axis=2)                      # (h, w)
        views = []
        for i, name in enumerate(names):
            mine = (face == i) & ok
            if not mine.any():
                continue
            R = FACES[name]
            q = rays @ R                                             # in the face's axes
            with np.errstate(divide="ignore", invalid="ignore"):
                a, b = q[..., 0] / q[..., 2], q[..., 1] / q[..., 2]
            # the finest step between neighbouring output pixels in the face's image
            steps = []
            for axis in (0, 1):
                both = mine & np.roll(mine, -1, axis)
                if axis == 0:
                    both[-1, :] = False
                else:
                    both[:, -1] = False
                da = np.hypot(np.roll(a, -1, axis) - a, np.roll(b, -1, axis) - b)[both]
                if da.size:
                    steps.append(da.min())
            step = min(steps) if steps else 1e-3
            f = quality / step
            a0, a1, b0, b1 = a[mine].min(), a[mine].max(), b[mine].min(), b[mine].max()
            views.append((name, R, mine.ravel(), a[mine], b[mine], f,
                          (a0, a1, b0, b1)))
        m = VIEW_MARGIN_PX
        # one renderer size for all faces: each face at least as fine as it needs
        vw = max(math.ceil((v[6][1] - v[6][0]) * v[5]) + 2 * m + 1 for v in views)
        vh = max(math.ceil((v[6][3] - v[6][2]) * v[5]) + 2 * m + 1 for v in views)
        if max(vw, vh) > MAX_VIEW_PX:
            raise RascError(f"the lens needs views of {vw}x{vh} px to render at this size "
                            f"and supersample (more than {MAX_VIEW_PX}); use a smaller "
                            "supersample or field of view")
        self.view_size = (vw, vh)
        self.views = []
        for name, R, mine, a, b, _, (a0, a1, b0, b1) in views:
            fx = (vw - 1 - 2 * m) / max(a1 - a0, 1e-9)
            fy = (vh - 1 - 2 * m) / max(b1 - b0, 1e-9)
            K_view = np.array([[fx, 0.0, m - fx * a0], [0.0, fy, m - fy * b0],
                               [0.0, 0.0, 1.0]])
            coords = np.stack([fy * b + K_view[1, 2], fx * a + K_view[0, 2]])  # (row, col)
            self.views.append((name, R, K_view, np.flatnonzero(mine), coords))

    def render(self, sim, eye: str) -> np.ndarray:
        """The ``eye``'s image through the lens at the simulator's current state: 8-bit
        grey (height, width); pixels without a ray are black."""
        from scipy.ndimage import map_coordinates

        from rasc.vision.camera import to_grey

        w, h = self.size
        S = self.supersample
        out = np.zeros(S * w * S * h)
        for _, R, K_view, index, coords in self.views:
            grey = to_grey(sim.render_view(eye, R, K_view, self.view_size), order="rgb")
            out[index] = map_coordinates(grey.astype(float), coords, order=1, mode="nearest")
        out = out.reshape(S * h, S * w)
        if S > 1:
            out = out.reshape(h, S, w, S).mean(axis=(1, 3))
        return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def focal_for_fov(fov_deg: float, width: int, dist, model: str = "pinhole") -> float:
    """The focal length (px) that puts a ray ``fov_deg / 2`` off the axis, horizontally,
    at the image's left and right edges (``width / 2`` from the centre) through the lens:
    ``fov_deg`` is the horizontal field of view."""
    half = math.radians(float(fov_deg)) / 2
    model = lens_core.check_model(model)
    d = lens_core._coefficients(dist, model=model)
    if model == "fisheye":
        edge = float(lens_core._fisheye_theta_d(np.array(half), d)[0])
    else:
        if half >= math.pi / 2:
            raise InputError(f"a pinhole lens sees less than 180 deg, got fov {fov_deg:g}")
        edge = float(lens_core.distort_normalized([[math.tan(half), 0.0]], d)[0, 0])
    if not edge > 0:
        raise InputError(f"fov {fov_deg:g} deg lies past the lens model's fold with "
                         f"distortion {list(d)}")
    return (width / 2) / edge
