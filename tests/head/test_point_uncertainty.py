"""Uncertainty of triangulated points (rasc.head.uncertainty) against Monte-Carlo.

Pixel noise: a plausible head (tests/nominal_rig.py), four points 0.6–3 m in front, their
exact projections plus Gaussian noise (seeded), triangulated 4000 times: the observed
standard deviation per base axis over the predicted one. Sampling alone scatters a
standard deviation from 4000 draws by 1/sqrt(2·4000) = 1.1 %; the band ±7 % is six of
those (measured: within ±3.3 %).

Calibration covariance: a refined calibration of a small rendered dataset (its
``refinement.covariance``), 400 calibrations drawn from N(θ̂, Σ_θ) through
:func:`perturbed_head`, the same pixels triangulated with each. Sampling scatter 3.5 %;
band ±15 % (measured with 1000 draws: within ±4 %).
"""

import json

import numpy as np
import pytest

from rasc.errors import InputError
from rasc.head.uncertainty import (
    HeadCovariance,
    covariance_from_refinement,
    perturbed_head,
    point_uncertainty,
    read_covariance,
)

from nominal_rig import plausible_head

POINTS = np.array([[0.0, 1.0, 0.0], [0.2, 2.0, -0.3], [-0.1, 3.0, 0.4], [0.05, 0.6, 0.1]])
ANGLES = np.radians([3.0, -2.0, -4.0, -2.0])     # pan_left, tilt_left, pan_right, tilt_right


def test_pixel_noise_sigma_matches_monte_carlo():
    head, _ = plausible_head(0)
    uvl, uvr = head.project(POINTS, *ANGLES)
    sig = 0.3
    unc = point_uncertainty(head, uvl, uvr, *ANGLES, pixel_sigma=sig)
    assert not unc.with_calibration and np.all(unc.calibration == 0)
    rng = np.random.default_rng(7)
    M, n = 4000, len(POINTS)
    UL = (uvl[None] + sig * rng.standard_normal((M, n, 2))).reshape(-1, 2)
    UR = (uvr[None] + sig * rng.standard_normal((M, n, 2))).reshape(-1, 2)
    P = head.triangulate(UL, UR, *ANGLES).reshape(M, n, 3)
    ratio = P.std(axis=0, ddof=1) / unc.sigma
    assert np.all(np.abs(ratio - 1) < 0.07), ratio
    # depth (y, forward) is the least certain axis, and it grows with distance
    assert np.all(np.argmax(unc.sigma, axis=1) == 1)
    assert unc.sigma[2, 1] > unc.sigma[1, 1] > unc.sigma[0, 1] > unc.sigma[3, 1]
    # the covariance scales with sigma squared
    unc2 = point_uncertainty(head, uvl, uvr, *ANGLES, pixel_sigma=2 * sig)
    np.testing.assert_allclose(unc2.total, 4 * unc.total, rtol=1e-9)


def test_tls_propagates_like_ls_on_consistent_pixels():
    """On exact pixels (zero residual) the first-order change of the TLS solution is the
    LS one, -(AᵀA)⁻¹Aᵀ(δA p - δb): the same sigmas, up to the central differences'
    error (1e-6 relative here; measured equal to 1e-9)."""
    head, _ = plausible_head(1)
    uvl, uvr = head.project(POINTS, *ANGLES)
    a = point_uncertainty(head, uvl, uvr, *ANGLES, pixel_sigma=0.5, method="ls")
    b = point_uncertainty(head, uvl, uvr, *ANGLES, pixel_sigma=0.5, method="tls")
    np.testing.assert_allclose(b.sigma, a.sigma, rtol=1e-6)


def test_bad_pixel_sigma_is_refused():
    head, _ = plausible_head(0)
    uvl, uvr = head.project(POINTS, *ANGLES)
    with pytest.raises(InputError, match="pixel_sigma"):
        point_uncertainty(head, uvl, uvr, *ANGLES, pixel_sigma=-1.0)
    with pytest.raises(InputError, match=r"^pixel_sigma: must be finite, got NaN$"):
        point_uncertainty(head, uvl, uvr, *ANGLES, pixel_sigma=float("nan"))
    with pytest.raises(InputError, match=r'^pixel_sigma: expected a number, got "0.5"$'):
        point_uncertainty(head, uvl, uvr, *ANGLES, pixel_sigma="0.5")


@pytest.fixture(scope="module")
def refined(rasc_render):
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset

    return calibrate_dataset(rasc_render(intrinsics_views=8).load(),
                             CalibrationOptions(model="general"))


@pytest.mark.slow
def test_calibration_covariance_sigma_matches_monte_carlo(refined):
    head = refined.head
    cov = covariance_from_refinement(refined.refinement)
    assert cov is not None and not any(n.startswith("board[") for n in cov.names)
    pts = np.array([[0.0, 1.0, 0.0], [0.2, 2.0, -0.3], [-0.1, 1.5, 0.4], [0.05, 0.6, 0.1]])
    uvl, uvr = head.project(pts, *ANGLES)
    unc = point_uncertainty(head, uvl, uvr, *ANGLES, pixel_sigma=0.0, covariance=cov)
    assert np.all(unc.pixels == 0) and unc.with_calibration
    # zero change: the same head, the same points, bit for bit
    same = perturbed_head(head, cov.names, np.zeros(len(cov.names)))
    np.testing.assert_array_equal(same.triangulate(uvl, uvr, *ANGLES),
                                  head.triangulate(uvl, uvr, *ANGLES))
    rng = np.random.default_rng(11)
    w, V = np.linalg.eigh(cov.matrix)
    L = V * np.sqrt(np.clip(w, 0.0, None))
    P = np.array([perturbed_head(head, cov.names, L @ rng.standard_normal(len(w)))
                  .triangulate(uvl, uvr, *ANGLES) for _ in range(400)])
    ratio = P.std(axis=0, ddof=1) / unc.sigma
    assert np.all(np.abs(ratio - 1) < 0.15), ratio


@pytest.mark.slow
def test_covariance_round_trips_through_the_calibration_file(refined, tmp_path):
    from rasc.io import write_json_atomic

    path = tmp_path / "cal.json"
    write_json_atomic(path, refined.to_dict())
    cov, (sigma, source) = read_covariance(path)
    ref = covariance_from_refinement(refined.refinement)
    assert cov.names == ref.names
    np.testing.assert_allclose(cov.matrix, ref.matrix, rtol=1e-12, atol=0)
    assert sigma == pytest.approx(refined.refinement.sigma) and "refinement" in source
    # a broken matrix is one line naming the field
    doc = json.loads(path.read_text())
    doc["refinement"]["covariance"]["matrix"][0][0] = -1.0
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"refinement.covariance.matrix: not a covariance"):
        read_covariance(path)


def test_unknown_parameter_name_is_refused():
    with pytest.raises(InputError, match="unknown parameter 'left.fz'"):
        HeadCovariance.from_dict({"format": "rasc-head-covariance/1", "names": ["left.fz"],
                                  "matrix": [[1.0]]})


@pytest.mark.slow
def test_rasc_triangulate_writes_sigmas(refined, tmp_path, rasc_cli):
    """New keys per point (sigma_base, covariance_base) and an account of them; the
    existing keys are those of the point without them."""
    from rasc.io import write_json_atomic

    cal = tmp_path / "cal.json"
    write_json_atomic(cal, refined.to_dict())
    head = refined.head
    uvl, uvr = head.project(POINTS, *ANGLES)
    deg = np.degrees(ANGLES)
    rows = ["u_left,v_left,u_right,v_right,pan_left,tilt_left,pan_right,tilt_right"]
    rows += [",".join(repr(float(x)) for x in (*a, *b, *deg)) for a, b in zip(uvl, uvr,
                                                                                strict=True)]
    (tmp_path / "px.csv").write_text("\n".join(rows) + "\n")
    code, out, err = rasc_cli("triangulate", str(cal), str(tmp_path / "px.csv"),
                              "--angle-unit", "deg")
    assert code == 0, err
    doc = json.loads(out)
    u = doc["uncertainty"]
    assert u["calibration_covariance"] is True
    assert u["pixel_sigma_px"] == pytest.approx(refined.refinement.sigma)
    cov, _ = read_covariance(cal)
    want = point_uncertainty(head, uvl, uvr, *ANGLES, pixel_sigma=u["pixel_sigma_px"],
                             covariance=cov)
    got = np.array([p["sigma_base"] for p in doc["points"]])
    np.testing.assert_allclose(got, want.sigma, rtol=1e-6)
    assert set(doc["points"][0]) == {"line", "p_base", "residual_px", "sigma_base",
                                     "covariance_base"}
    np.testing.assert_allclose([p["p_base"] for p in doc["points"]], POINTS, atol=1e-9)
    # --pixel-sigma replaces the file's corner noise
    code, out, err = rasc_cli("triangulate", str(cal), str(tmp_path / "px.csv"),
                              "--angle-unit", "deg", "--pixel-sigma", "0.5")
    assert code == 0 and json.loads(out)["uncertainty"]["pixel_sigma_px"] == 0.5


def test_geometry_level_covariance_is_the_head_level_one_without_a_lens():
    """rasc.geometry.triangulation.point_covariance (analytic, ideal pixels) against
    point_uncertainty (central differences through the head) on a head without
    distortion: the same first-order covariance (1e-6 relative: the differences'
    error)."""
    from rasc.geometry.triangulation import point_covariance
    from rasc.head.model import EyeCalibration, HeadCalibration

    head, _ = plausible_head(2)
    flat = HeadCalibration(**{e: EyeCalibration(
        K=getattr(head, e).K, dist=[], T_cam_from_gaze=getattr(head, e).T_cam_from_gaze,
        T_ptu_from_base=getattr(head, e).T_ptu_from_base,
        image_size=getattr(head, e).image_size) for e in ("left", "right")})
    uvl, uvr = flat.project(POINTS, *ANGLES)
    rng = np.random.default_rng(5)         # inconsistent pixels: the residual term counts
    uvl, uvr = uvl + rng.normal(0, 0.5, uvl.shape), uvr + rng.normal(0, 0.5, uvr.shape)
    p = flat.triangulate(uvl, uvr, *ANGLES)
    cov = point_covariance(flat.left.projection_matrix(*ANGLES[:2]),
                           flat.right.projection_matrix(*ANGLES[2:]), uvl, uvr, p, 0.4)
    want = point_uncertainty(flat, uvl, uvr, *ANGLES, pixel_sigma=0.4).total
    np.testing.assert_allclose(cov, want, rtol=1e-6, atol=1e-6 * np.abs(want).max())
