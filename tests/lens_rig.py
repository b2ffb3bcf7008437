"""Heads with lenses for the use side's tests (``from lens_rig import lens_head, ...``):
the geometry of :func:`rasc.sim.synthetic.default_head` (its hand-eyes and mounts, 0.3 m
between the units) with, per eye, a fisheye lens (OpenCV's equidistant model), OpenCV's
rational model (8 coefficients) or the default head's own pinhole lens, built directly as
:class:`rasc.head.model.HeadCalibration` objects (no calibration, no render).

- ``lens_head(kind)``: ``kind`` one of :data:`KINDS`.
- ``GAZES``: (name, the base point both eyes fixate, the pan and tilt added to each eye's
  fixation, degrees).
- ``gaze_readings(head, point, d_left, d_right)``: the readings (radians) of one gaze.
- ``points_seen(head, readings, rng, n)``: seeded scene points (N, 3) in the base frame
  that both eyes see inside their images, with their true distorted pixels.
"""

from __future__ import annotations

import numpy as np

EYES = ("left", "right")
IMAGE_SIZE = (1280, 960)
KINDS = ("fisheye", "rational", "pinhole")

#: a fisheye of about 130° across the width and 165° across the diagonal at 1280×960
#: (f = 560 px; the image corner 1.43 rad = 82° off the axis)
FISHEYE_K = {"left": np.array([[560.0, 0.0, 638.0], [0.0, 559.0, 481.0], [0.0, 0.0, 1.0]]),
             "right": np.array([[562.0, 0.0, 642.0], [0.0, 561.5, 478.5], [0.0, 0.0, 1.0]])}
#: cv2.fisheye's k1..k4 of a typical wide-angle lens
FISHEYE_DIST = {"left": np.array([0.04, -0.012, 0.004, -0.0006]),
                "right": np.array([0.035, -0.01, 0.003, -0.0005])}
#: OpenCV's rational model (k1 k2 p1 p2 k3 k4 k5 k6) on the default head's K: a barrel lens
#: whose denominator matters (k4..k6 ≠ 0), invertible over the whole image
RATIONAL_DIST = {"left": np.array([0.35, -0.12, 0.0006, -0.0004, 0.02, 0.62, -0.08, 0.05]),
                 "right": np.array([0.3, -0.1, -0.0005, 0.0003, 0.015, 0.55, -0.07, 0.04])}

#: (name, fixation point in the base frame (x up, y forward, z left; m), then (pan, tilt)
#: added to the left and the right eye's fixation, degrees)
GAZES = (
    ("converging", (0.0, 0.75, 0.0), (0.0, 0.0), (0.0, 0.0)),
    ("diverging", (0.0, 1.6, 0.0), (8.0, 0.0), (-8.0, 0.0)),
    ("asymmetric", (0.35, 1.0, 0.3), (-2.0, 1.5), (1.0, -1.0)),
    ("down-right", (-0.45, 1.0, -0.5), (1.5, -1.0), (-1.0, 2.0)),
)


def lens_head(kind: str = "fisheye"):
    """A :class:`HeadCalibration` with the default head's geometry and ``kind``'s lens."""
    from rasc.head.model import EyeCalibration, HeadCalibration
    from rasc.sim.synthetic import default_head

    g = default_head()
    eyes = {}
    for eye in EYES:
        K, dist, model = {"fisheye": (FISHEYE_K[eye], FISHEYE_DIST[eye], "fisheye"),
                          "rational": (g.K[eye], RATIONAL_DIST[eye], "pinhole"),
                          "pinhole": (g.K[eye], g.dist[eye], "pinhole")}[kind]
        eyes[eye] = EyeCalibration(K=K, dist=dist, T_cam_from_gaze=g.T_cam_from_gaze[eye],
                                   T_ptu_from_base=g.T_ptu_from_base[eye],
                                   image_size=IMAGE_SIZE, lens=model)
    return HeadCalibration(**eyes)


def gaze_readings(head, point, d_left=(0.0, 0.0), d_right=(0.0, 0.0)) -> dict:
    """``{eye: (pan, tilt)}`` radians: each eye fixating ``point``, plus the offsets (deg)."""
    from rasc.head.use import look_at

    out = {}
    for eye, d in (("left", d_left), ("right", d_right)):
        fix = look_at(getattr(head, eye), np.asarray(point, float))
        out[eye] = (fix.pan + np.radians(d[0]), fix.tilt + np.radians(d[1]))
    return out


def points_seen(head, readings: dict, rng: np.random.Generator, n: int = 400,
                spread: float = 0.6, centre=(0.0, 1.0, 0.0)):
    """Up to ``n`` points around ``centre`` (normal, ``spread`` m per axis, in front of
    the base) that both eyes see inside their images: ``(p_base (N, 3), {eye: uv})``."""
    from rasc.head.use import project_eye

    p = np.asarray(centre, float) + rng.normal(0.0, spread, (8 * n, 3))
    p = p[p[:, 1] > 0.25]
    proj = {eye: project_eye(getattr(head, eye), p, *readings[eye]) for eye in EYES}
    keep = np.flatnonzero(proj["left"].in_image & proj["right"].in_image)[:n]
    return p[keep], {eye: proj[eye].uv[keep] for eye in EYES}
