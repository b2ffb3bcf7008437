"""Using a head with fisheye or rational lenses (rasc.head.use: project_eye, triangulate,
look_at, point_covariances), on heads built directly (tests/lens_rig.py) at the gazes of
lens_rig.GAZES, against the truth.

Measured (2026-11-28; printed):

* noise-free: projected, then triangulated back to ≤ 5e-14 of the depth (fisheye,
  rational and pinhole alike; bound 1e-9), reprojection residuals ≤ 3.2e-12 px; look-at
  puts the point on the principal point through the fisheye (bound 1e-9 px);
* 0.1 px of pixel noise: the triangulation errors' normalised squared error against the
  propagated covariance (first order, :func:`rasc.head.uncertainty.point_uncertainty`)
  averages 2.996–2.998 (its expectation: 3 coordinates; bound ±5 %) for each lens; the
  median depth σ is 0.73 mm through the fisheye (f 560 px) against 0.37–0.39 mm through
  the pinhole and rational lenses (f 1150 px).
"""

from __future__ import annotations

import numpy as np
import pytest
from lens_rig import EYES, GAZES, KINDS, gaze_readings, lens_head, points_seen

from rasc.head.use import look_at, project_eye, triangulate


@pytest.mark.parametrize("kind", KINDS)
def test_noise_free_round_trip_through_the_lens(kind):
    head = lens_head(kind)
    rng = np.random.default_rng(5)
    worst_rel, worst_res = 0.0, 0.0
    for name, point, d_left, d_right in GAZES:
        r = gaze_readings(head, point, d_left, d_right)
        p, uv = points_seen(head, r, rng, 300, centre=point)
        assert len(p) == 300, name
        t = triangulate(head, uv["left"], uv["right"], *r["left"], *r["right"])
        rel = np.linalg.norm(t.p_base - p, axis=1) / np.linalg.norm(p, axis=1)
        worst_rel = max(worst_rel, float(rel.max()))
        worst_res = max(worst_res, max(float(t.residual_px[e].max()) for e in EYES))
        assert all(t.in_front[e].all() for e in EYES)
    print(f"{kind}: triangulated within {worst_rel:.2g} of the depth, residuals "
          f"≤ {worst_res:.2g} px")
    assert worst_rel < 1e-9 and worst_res < 1e-6


def test_look_at_fixates_through_the_fisheye():
    head = lens_head("fisheye")
    for _, point, _, _ in GAZES:
        p = np.asarray(point, float)
        for eye in EYES:
            e = getattr(head, eye)
            fix = look_at(e, p)
            uv = e.project(p[None], fix.pan, fix.tilt)[0]
            assert np.abs(uv - e.K[:2, 2]).max() < 1e-9


def test_a_fisheye_sees_far_off_axis_and_nothing_behind():
    """project_eye through the fisheye: points towards the image's corner up to 75° off
    the axis are in the image (a pinhole with the same K sees 55° there), one 100° off is
    behind the camera."""
    head = lens_head("fisheye")
    e = head.left
    pan, tilt = 0.1, -0.05
    T = e.T_cam_from_base(pan, tilt)
    T_bc = np.linalg.inv(T)
    angles = np.radians([0.0, 40.0, 60.0, 75.0, 100.0])
    p_cam = np.c_[0.8 * np.sin(angles), 0.6 * np.sin(angles), np.cos(angles)] * 1.5
    p_base = p_cam @ T_bc[:3, :3].T + T_bc[:3, 3]
    proj = project_eye(e, p_base, pan, tilt)
    assert proj.in_image.tolist() == [True, True, True, True, False]
    assert proj.in_front.tolist() == [True, True, True, True, False]
    assert np.isnan(proj.uv[4]).all()


@pytest.mark.parametrize("kind", KINDS)
def test_pixel_noise_gives_the_propagated_covariance(kind, tmp_path):
    """Seeded 0.1 px noise on both eyes' pixels, 200 draws × 20 points: the errors'
    normalised squared error (eᵀ Σ⁻¹ e) averages 3, Σ the covariance rasc triangulate
    reports (point_covariances, pixel noise only)."""
    import json

    from rasc.head.use import point_covariances

    head = lens_head(kind)
    path = tmp_path / "head.json"
    path.write_text(json.dumps(head.to_dict()))
    rng = np.random.default_rng(17)
    name, point, d_left, d_right = GAZES[2]
    r = gaze_readings(head, point, d_left, d_right)
    p, uv = points_seen(head, r, rng, 20, centre=point, spread=0.3)
    sigma = 0.1
    unc, info = point_covariances(path, head, uv["left"], uv["right"], *r["left"],
                                  *r["right"], pixel_sigma=sigma)
    assert info["pixel_sigma_px"] == sigma and not info["calibration_covariance"]
    inv = np.linalg.inv(unc.total)
    nees = []
    for _ in range(200):
        noisy = {eye: uv[eye] + rng.normal(0.0, sigma, uv[eye].shape) for eye in EYES}
        q = head.triangulate(noisy["left"], noisy["right"], *r["left"], *r["right"])
        e = q - p
        nees.append(np.einsum("ni,nij,nj->n", e, inv, e))
    mean = float(np.mean(nees))
    print(f"{kind}: mean normalised squared error {mean:.3f} (expected 3), σ_depth "
          f"{1e3 * np.median(unc.sigma[:, 1]):.2f} mm median")
    # 4000 draws of a χ²(3): the mean's standard error is √6/√4000 = 0.04 (1.3 %)
    assert abs(mean / 3.0 - 1.0) < 0.05, mean
