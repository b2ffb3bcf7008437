"""Calibrating a head through any lens model (issue 32): the rational and fisheye
``dist_model``s through the intrinsics (cv2.calibrateCamera's rational model,
cv2.fisheye.calibrate), the per-view extrinsics, the whole-head refinement with its
covariance, the calibration file; the wrong-lens warning and the verdict; the command
door on painted fisheye images. Truth: projected corners (rasc.sim.synthetic)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from rasc.errors import DegenerateDataError
from rasc.geometry import lens
from rasc.head import options as calopts
from rasc.head import refine as rf
from rasc.head.model import HeadCalibration
from rasc.head.pipeline import CalibrationOptions, calibrate_dataset, transform_error
from rasc.report.verdict import verdict
from rasc.sim.lens_render import focal_for_fov
from rasc.sim.synthetic import corner_dataset, default_head, fisheye_head, rational_head
from rasc.vision.camera import (
    calibrate_intrinsics,
    estimate_extrinsics,
    is_wrong_lens,
    lens_check_F,
    wrong_lens_warning,
)


def _intrinsics_views(ds, eye="left"):
    return {e.file: ds.corners[e.file] for e in ds.select(eye, "intrinsics")}


def _handeye_errors(cal, head):
    return {eye: transform_error(getattr(cal.head, eye).T_cam_from_gaze,
                                 head.T_cam_from_gaze[eye]) for eye in ("left", "right")}


def test_one_table_of_dist_models():
    """The options' names, the intrinsics and the refinement read one table."""
    from rasc.vision.camera import CALIB_FLAGS, DIST_MODELS

    assert set(calopts.DIST_MODEL_NAMES) == set(lens.DIST_MODELS) == set(DIST_MODELS)
    assert set(CALIB_FLAGS) | {"fisheye"} == set(lens.DIST_MODELS)
    for name, (model, estimated, n) in lens.DIST_MODELS.items():
        assert set(estimated) <= set(lens.LENS_MODELS[model])
        assert n in lens.MODEL_N_COEFFS[model]
        assert rf.DIST_PARAMS[name] == estimated
        for c in estimated:
            assert rf.parameter_unit(f"left.{c}") == "1"


@pytest.fixture(scope="module")
def fisheye_cal():
    head = fisheye_head()
    ds = corner_dataset(head, seed=2, noise_px=0.1)
    return head, ds, calibrate_dataset(ds, CalibrationOptions(dist_model="fisheye"))


def test_fisheye_head_calibrates_to_its_truth(fisheye_cal):
    head, ds, cal = fisheye_cal
    errs = _handeye_errors(cal, head)
    for eye in ("left", "right"):
        e = getattr(cal.head, eye)
        assert e.lens == "fisheye" and e.dist.shape == (4,)
        # focal length within 0.5 px of 420 px, the coefficients within 0.005 of the truth
        assert abs(e.K[0, 0] - head.K[eye][0, 0]) < 0.5
        assert np.abs(e.dist - head.dist[eye]).max() < 5e-3
        # measured 0.002-0.076° and 0.19-1.6 mm over seeds 0-9 at 0.1 px
        assert errs[eye]["rotation_deg"] < 0.25 and errs[eye]["translation"] < 3e-3
        # the refinement's parameters are the fisheye's, with standard deviations
        params = cal.refinement.parameters[eye]
        assert {"k1", "k2", "k3", "k4"} <= set(params)
        assert not {"p1", "p2", "k5"} & set(params)
        assert all(params[k]["std"] > 0 for k in ("k1", "k2", "k3", "k4"))
    assert cal.refinement.rms_after < 0.2
    assert not [w for w in cal.warnings if "--dist-model" in w], cal.warnings
    doc = json.loads(json.dumps(cal.to_dict(), default=float))
    assert verdict(doc).level == "usable", verdict(doc).line()
    assert doc["head"]["left"]["lens"] == "fisheye"
    assert doc["eyes"]["left"]["lens"] == "fisheye"
    again = HeadCalibration.from_dict(doc["head"])
    assert again.left.lens == "fisheye"
    # the calibration projects through the fisheye: a corner 70° off axis comes back
    p = np.array([[np.tan(np.radians(70.0)), 0.0, 1.0]])
    uv = lens.project_points(p, again.left.K, again.left.dist, model="fisheye")
    ideal = (again.left.K @ (p[0] / p[0, 2]))[:2]
    assert np.abs(again.left.undistort(uv)[0] - ideal).max() < 1e-6


def test_the_wrong_model_on_a_fisheye_is_warned_and_checked(fisheye_cal):
    head, ds, right = fisheye_cal
    cal = calibrate_dataset(ds, CalibrationOptions(dist_model="k1k2"))
    lens_warnings = [w for w in cal.warnings if "--dist-model fisheye" in w]
    assert {w.split()[0] for w in lens_warnings} == {"left", "right"}, cal.warnings
    assert cal.warnings[0] in lens_warnings       # first: everything else follows from it
    doc = json.loads(json.dumps(cal.to_dict(), default=float))
    v = verdict(doc)
    failed = {c.name for c in v.checks if not c.passed}
    assert {"left.lens", "right.lens"} <= failed and v.level != "usable"
    # ... and its hand-eye is far off (what the warning is for): several times the right
    # model's error
    worst = max(e["rotation_deg"] for e in _handeye_errors(cal, head).values())
    assert worst > 4 * max(e["rotation_deg"] for e in _handeye_errors(right, head).values())


def test_a_lens_check_alone_sends_the_verdict_to_check():
    # a calibration document fine in every respect but the lens check
    doc = {"options": {"model": "paper"},
           "eyes": {eye: {"intrinsics_rms": 0.2,
                          "lens_check": {"dist_model": "k1k2", "rms_px": 0.2,
                                         "alternative": "fisheye",
                                         "alternative_rms_px": 0.05,
                                         "corners": 1080, "views": 20}}
                    for eye in ("left", "right")}}
    v = verdict(doc)
    assert v.level == "check" and "--dist-model fisheye" in v.reason
    for eye in ("left", "right"):
        # within the noise: F = 1080 (0.2² - 0.1995²) / 4 / (1080 · 0.1995² / 2032) ≈ 2.6
        doc["eyes"][eye]["lens_check"]["alternative_rms_px"] = 0.1995
    assert verdict(doc).level == "usable", verdict(doc).line()


@pytest.mark.parametrize(("rms", "alt", "F", "warned"), [
    (4.3, 0.14, 1e5, True),        # k1k2 on a 170° fisheye
    (0.1, 0.0686, 600.0, True),    # k1k2 on a 90° fisheye at 0.05 px: 46 % of the RMS more
    (0.0691, 0.0691, 0.5, False),  # a pinhole lens either way
    (0.0415, 0.0413, 3.7, False),  # the right model: within the noise (F below 10)
    (0.0700, 0.0697, 12.0, False),  # F above 10, but 9 % of the RMS: a negligible excess
    (0.3, 0.1, None, True),        # F not known (an older file): the excess alone
    (0.5, None, None, False),      # the other model could not be fitted
])
def test_is_wrong_lens(rms, alt, F, warned):
    assert is_wrong_lens(rms, alt, F) is warned


def test_the_lens_check_F_counts_corners_views_and_coefficients():
    check = {"dist_model": "k1k2", "rms_px": 0.2, "alternative": "fisheye",
             "alternative_rms_px": 0.1, "corners": 1000, "views": 20}
    # q = 4 (fisheye k1-k4), df = 2000 - 4 - 4 - 120
    want = (1000 * (0.2 ** 2 - 0.1 ** 2) / 4) / (1000 * 0.1 ** 2 / 1872)
    assert lens_check_F(check) == pytest.approx(want)
    # the refinement's RMS, when better, is the chosen model's
    assert lens_check_F({**check, "refined_rms_px": 0.1}) == pytest.approx(0.0)
    # a check without its counts (written before them) has no F: the excess decides
    assert lens_check_F({k: v for k, v in check.items() if k != "corners"}) is None


def _lens_head(model, fov, dist):
    head = default_head()
    f = focal_for_fov(fov, 1280, dist, model)
    for K in head.K.values():
        K[0, 0] = K[1, 1] = f
    return dataclasses.replace(head, dist={e: np.asarray(dist, float) for e in head.K},
                               lens={e: model for e in head.K})


FISHEYE = (0.02, -0.01, 0.003, -0.0005)
PINHOLE = (-0.05, 0.01, 0.0, 0.0, 0.0)


def test_the_right_model_is_not_warned_over_noise_and_fields_of_view():
    # 24 intrinsics calibrations (4 cases x noise 0.03 and 0.3 px x seeds 0-2), none
    # warned: a fisheye of 90° and 150° fitted as a fisheye, a 60° pinhole fitted with
    # k1k2 and (the fisheye fits it to the noise) as a fisheye
    cases = [("fisheye", 90, FISHEYE, "fisheye"), ("fisheye", 150, FISHEYE, "fisheye"),
             ("pinhole", 60, PINHOLE, "k1k2"), ("pinhole", 60, PINHOLE, "fisheye")]
    checks = []
    for model, fov, dist, fit in cases:
        head = _lens_head(model, fov, dist)
        for noise in (0.03, 0.3):
            for seed in range(3):
                ds = corner_dataset(head, seed=seed, noise_px=noise, poses_deg=())
                intr = calibrate_intrinsics(_intrinsics_views(ds), ds.board, (1280, 960),
                                            dist_model=fit)
                checks.append(((model, fov, fit, noise, seed), intr.lens_check))
    assert len(checks) == 24
    warned = [(case, c) for case, c in checks if wrong_lens_warning(c)]
    assert not warned, warned
    assert all(c["corners"] == 20 * 54 and c["views"] == 20 for _, c in checks)


def test_a_90_degree_fisheye_fitted_as_a_pinhole_is_warned():
    # E11's 90° fisheye, where k1k2 costs 13x the right model's hand-eye error: warned
    # for every eye and seed, from the intrinsics alone
    head = _lens_head("fisheye", 90, FISHEYE)
    for seed in range(3):
        ds = corner_dataset(head, seed=seed, noise_px=0.05, poses_deg=())
        for eye in ("left", "right"):
            intr = calibrate_intrinsics(_intrinsics_views(ds, eye), ds.board, (1280, 960),
                                        dist_model="k1k2")
            w = wrong_lens_warning(intr.lens_check)
            assert w is not None and "--dist-model fisheye" in w and "F = " in w, \
                (seed, eye, intr.lens_check)


def test_rational_lens_calibrates_with_k1_to_k6():
    head = rational_head()
    ds = corner_dataset(head, seed=4, noise_px=0.1)
    views = _intrinsics_views(ds)
    intr = calibrate_intrinsics(views, ds.board, (1280, 960), dist_model="rational")
    assert intr.dist.shape == (8,) and intr.lens == "pinhole"
    cal = calibrate_dataset(ds, CalibrationOptions(dist_model="rational"))
    for eye in ("left", "right"):
        e = getattr(cal.head, eye)
        assert e.dist.shape == (8,) and e.lens == "pinhole"
        params = cal.refinement.parameters[eye]
        assert {"k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"} <= set(params)
        # every coefficient estimated with a σ, or held (at the intrinsics' value) where
        # the corners cannot determine it
        for c in ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"):
            assert (params[c]["std"] or 0) > 0 or params[c].get("held"), (c, params[c])
        # the lens is reproduced (the coefficients trade off, the projection does not):
        # over the image (±1, ±0.75 normalised, 63° off axis at the corners) within 2 px
        # of the truth's (measured 0.45 and 1.4 px, at the grid's corners; K's own σ
        # is 0.3-0.4 px)
        xy = np.stack(np.meshgrid(np.linspace(-1.0, 1.0, 9), np.linspace(-0.75, 0.75, 7)),
                      -1).reshape(-1, 2)
        p = np.c_[xy, np.ones(len(xy))]
        d = lens.project_points(p, e.K, e.dist) - lens.project_points(p, head.K[eye],
                                                                      head.dist[eye])
        assert np.abs(d).max() < 2.0, np.abs(d).max()
    assert cal.refinement.rms_after < 0.16
    errs = _handeye_errors(cal, head)
    assert max(e["rotation_deg"] for e in errs.values()) < 0.1
    assert max(e["translation"] for e in errs.values()) < 2e-3
    assert not [w for w in cal.warnings if "--dist-model" in w], cal.warnings


def test_fisheye_extrinsics_recover_the_pose():
    head = fisheye_head()
    ds = corner_dataset(head, seed=1, noise_px=0.0)
    rng = np.random.default_rng(5)
    for f in [e.file for e in ds.select("left", "intrinsics")][:6]:
        c = ds.corners[f]
        # the truth: undistort, then the exact pose of noise-free corners
        T, rms = estimate_extrinsics(c, ds.board, head.K["left"], head.dist["left"],
                                     lens="fisheye")
        assert rms < 1e-6
        uv = lens.project_points(ds.board.object_points() @ T[:3, :3].T + T[:3, 3],
                                 head.K["left"], head.dist["left"], model="fisheye")
        assert np.abs(uv - c).max() < 1e-6
        T2, rms2 = estimate_extrinsics(c + rng.normal(0, 0.1, c.shape), ds.board,
                                       head.K["left"], head.dist["left"], lens="fisheye")
        assert 0.05 < rms2 < 0.2
        assert transform_error(T2, T)["translation"] < 2e-3


def test_fisheye_failure_is_one_line():
    # views whose corners are shuffled: no lens maps the board onto them
    ds = corner_dataset(fisheye_head(), seed=0, noise_px=0.1, n_intrinsics=8)
    rng = np.random.default_rng(0)
    views = {n: c[rng.permutation(len(c))] for n, c in _intrinsics_views(ds).items()}
    with pytest.raises(DegenerateDataError) as info:
        calibrate_intrinsics(views, ds.board, (1280, 960), dist_model="fisheye")
    assert "\n" not in str(info.value) and "fisheye" in str(info.value)


def _problem(dist_model, head):
    ds = corner_dataset(head, seed=4, noise_px=0.05)
    cal = calibrate_dataset(ds, CalibrationOptions(dist_model=dist_model, model="paper"))
    obs = rf.observations_from_calibration(cal, ds.board)
    free, _ = rf._identifiable(obs)
    return rf._Problem(obs, free)


@pytest.mark.parametrize(("dist_model", "make"), [
    ("fisheye", fisheye_head), ("rational", rational_head)])
def test_refinement_jacobian_through_the_lens(dist_model, make):
    """The analytic intrinsics and board columns of the refinement's Jacobian for the
    fisheye (k1-k4) and rational (k1-k6 p1 p2) lenses, against central differences
    (tests/head/test_refine_jacobian.py has the tolerance's measurement)."""
    prob = _problem(dist_model, make())
    rng = np.random.default_rng(7)
    x = 0.02 * rng.standard_normal(len(prob.names))
    Ja = prob.jacobian_lm(x, prob.residuals(x)).toarray()
    Jc = prob.jacobian(x, h=1e-5, central=True, analytic=False).toarray()
    coef = set(lens.DIST_MODELS[dist_model][1])
    an = [j for j, n in enumerate(prob.names) if n.startswith("board[")
          or n.split(".")[-1] in coef | {"fx", "fy", "cx", "cy"}]
    assert sum(prob.names[j].split(".")[-1] in coef for j in an) == 2 * len(coef)
    colmax = np.abs(Jc).max(axis=0)
    err = np.abs(Ja - Jc).max(axis=0)[an] / colmax[an]
    assert err.max() < 1e-6, prob.names[an[int(np.argmax(err))]]


@pytest.mark.slow
def test_fisheye_through_the_command(tmp_path, rasc_cli):
    """``rasc calibrate --dist-model fisheye`` on painted images of a 170° fisheye head
    (rasc.sim.synthetic.image_dataset): detection, intrinsics, refinement, the file."""
    from rasc.sim.synthetic import image_dataset
    from rasc.vision.dataset import write_dataset

    head = fisheye_head()
    write_dataset(image_dataset(head, seed=0, n_intrinsics=12), tmp_path / "ds")
    out = tmp_path / "cal.json"
    code, _, err = rasc_cli("calibrate", str(tmp_path / "ds"), "--dist-model", "fisheye",
                            "--out", str(out))
    assert code == 0, err
    doc = json.loads(out.read_text())
    assert doc["options"]["dist_model"] == "fisheye"
    hc = HeadCalibration.from_dict(doc["head"])
    for eye in ("left", "right"):
        e = getattr(hc, eye)
        assert e.lens == "fisheye" and abs(e.K[0, 0] - 420.0) < 1.0
        he = transform_error(e.T_cam_from_gaze, head.T_cam_from_gaze[eye])
        assert he["rotation_deg"] < 0.25 and he["translation"] < 3e-3, (eye, he)
    assert "--dist-model" not in err
    # the wrong model on the same images: warned, exit 0 (a warning, not an error)
    code, _, err = rasc_cli("calibrate", str(tmp_path / "ds"), "--dist-model", "k1k2",
                            "--out", str(tmp_path / "wrong.json"))
    assert code == 0 and "--dist-model fisheye" in err
