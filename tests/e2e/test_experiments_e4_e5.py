"""Experiments E4 (Table 1, triangulation) and E5 (base-to-ptu), run in --quick mode.

One quick run of both experiments (workers 1, seed 0, on the default dataset rendered
once per test run) is checked for structure and the sanity of its numbers: conftest's
``quick_experiments``, made once per test run and shared with tests/e2e/test_reproduce.py,
whose claim it is that the same seed gives byte-identical result files for any worker
count (its pool run, ``--workers 2``, against these); a second run here with --workers 2
repeated it for E4 and E5 (see tests/e2e/test_experiments_e1_e3.py).
The exact-recovery tests use the true model built from the dataset's ground truth.
"""

from __future__ import annotations

import os
import sys
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import numpy as np
import pytest

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"
sys.path.insert(0, str(EXPERIMENTS.parent))  # the experiments package

from experiments import e4_triangulation as e4  # noqa: E402
from experiments import e5_base_to_ptu as e5  # noqa: E402
from experiments._common import read_csv  # noqa: E402
from rasc.geometry.frames import EYES  # noqa: E402
from rasc.geometry.kinematics import T_gaze_from_ptu  # noqa: E402
from rasc.geometry.transforms import transform_points  # noqa: E402
from rasc.head.base_to_ptu import T_ptuL_from_ptuR_loop_closure, perturb_mounts  # noqa: E402
from rasc.head.model import EyeCalibration, HeadCalibration  # noqa: E402
from rasc.sim.scene import T_base_from_world_facing  # noqa: E402

pytestmark = pytest.mark.slow  # renders and whole experiment runs

RESULT_SUFFIXES = (".csv", ".json")


@pytest.fixture(scope="module")
def quick(quick_experiments):
    """Both experiments, --quick, --workers 1, seed 0 (conftest's, shared)."""
    ctx, sec4 = quick_experiments("e4_triangulation")
    _, sec5 = quick_experiments("e5_base_to_ptu")
    return ctx, sec4, sec5


# ------------------------------------------------------------------------ E4

def test_e4_structure_and_point_count(quick):
    ctx, sec, _ = quick
    out = ctx.out / "e4"
    s = sec.summary
    # --quick: one plane, two poses, a 22×21 board
    assert s["n_points"] == len(e4.QUICK_DEPTHS_M) * 2 * 22 * 21 == 924
    assert len(read_csv(out / "detections.csv")) == s["n_points"]
    points = read_csv(out / "points.csv")
    assert len(points) == len(e4.MODELS) * s["n_points"]
    assert {r["model"] for r in points} == set(e4.MODELS)
    values = np.array([[float(r[k]) for k in r if k not in ("model",)] for r in points])
    assert np.all(np.isfinite(values))
    assert len(read_csv(out / "poses.csv")) == 2 * len(EYES) * len(e4.QUICK_DEPTHS_M)
    for f in ("table1.csv", "summary.json", "mount_draws.csv", "fig_table1.png"):
        assert (out / f).is_file(), f
    assert not (out / "fig_table1.svg").exists()   # --quick: PNG only
    assert all(Path(f).is_file() for f in sec.files)
    md = sec.markdown
    assert f"**{s['n_points']} points**" in md
    assert "(e4/fig_table1.png)" in md and "18.3" in md and "53.7" in md
    assert "lateral = our −z" in md


def test_e4_error_bounds(quick):
    _, sec, _ = quick
    m = sec.summary["models"]
    # rendered corners detect to ≤ 0.04 px (measured 0.024–0.037 px RMS here); at 1.77 m
    # with b = 0.3 m and f ≈ 1150 px a disparity error of 0.05 px is Z²/(f b)·0.05 =
    # 0.45 mm in depth and ~0.08 mm across: bounds 1 mm / 0.2 mm (measured 0.34 / 0.06)
    true = m["true"]["ls"]
    assert max(abs(v) for v in true["mean"]) < 1.0
    assert true["std"][0] < 0.2 and true["std"][1] < 0.2 and true["std"][2] < 1.0
    # calibrated intrinsics and hand-eye (0.01–0.02°, < 0.5 mm): measured depth std
    # 0.68 mm on the full run; the simulation's goal is 5.4 mm
    for model in ("cal_true_mounts", "cal_loop_closure"):
        s = m[model]["ls"]
        assert all(sd <= g for sd, g in zip(s["std"], e4.GOAL_STD_MM, strict=True)), model
        assert abs(s["mean"][2]) < 2.0, model
    # a 0.5° / 2.5 mm mount error: mm to ~0.1 m (Z²δ/b ≈ 91 mm at 1.77 m for the whole
    # 0.5° about the vertical), always far above the detection floor
    meas = m["cal_measured_mounts"]["ls"]
    rms3 = float(np.linalg.norm(meas["rms"]))
    assert 1.0 < rms3 < 150.0
    assert rms3 > 5 * float(np.linalg.norm(true["rms"]))


def test_e4_mount_draws_follow_first_order_prediction(quick):
    ctx, sec, _ = quick
    out = ctx.out / "e4"
    draws = read_csv(out / "mount_draws.csv")
    assert len(draws) == e4.N_MOUNT_DRAWS_QUICK
    for r in draws:  # every draw has exactly the stated error sizes
        w = np.array([float(r[f"rot_err_{a}_deg"]) for a in "xyz"])
        assert np.linalg.norm(w) == pytest.approx(e4.MOUNT_ROTATION_DEG, rel=1e-9)
        assert float(r["trans_err_mm"]) == pytest.approx(1000 * e4.MOUNT_TRANSLATION_M,
                                                         rel=1e-9)
    P = e4.load_points(out / "points.csv")
    pred = e4.predicted_depth_bias_mm(P, draws, sec.summary["baseline_m"])
    mdep = np.array([float(r["mean_depth_mm"]) for r in draws])
    # first order in δ and Δb: the neglected roll/tilt couplings and second-order terms
    # were measured at ≤ 6.7 mm over 20 draws (full run); a sign or factor error in
    # either term would miss by tens of mm
    assert np.all(np.abs(mdep - pred) <= 0.1 * np.abs(pred) + 8.0), (mdep, pred)


def test_e4_exact_recovery_with_true_model_and_projected_points(quick):
    """The table-1 triangulation recovers ground truth exactly when fed the true model
    and noise-free projected points."""
    ctx, _, _ = quick
    head = e4.head_from_truth(ctx.truth())
    p_true, uv_l, uv_r, angles = [], [], [], []
    for k, depth in enumerate(e4.PLANE_DEPTHS_M):
        p = transform_points(T_base_from_world_facing(e4.BOARD, distance=depth),
                             e4.BOARD.object_points())
        for cmd in e4.plane_poses_deg(depth, k):
            a = np.radians(cmd)
            ul, ur = head.project(p, a[0], a[1], a[2], a[3])
            p_true.append(p)
            uv_l.append(ul)
            uv_r.append(ur)
            angles.append(np.tile(a, (len(p), 1)))
    p_true, uv_l, uv_r, angles = (np.concatenate(x) for x in (p_true, uv_l, uv_r, angles))
    assert len(p_true) == 2772  # the paper's count, all three planes
    for method in e4.METHODS:
        p = e4.triangulate_points(head, uv_l, uv_r, angles, method)
        rel = np.linalg.norm(p - p_true, axis=1) / np.linalg.norm(p_true, axis=1)
        # double precision through 4×4 systems of condition ~1e4: measured ~1e-13
        assert rel.max() < 1e-9, method
    # and the same pixels through a model with a mount error are visibly off (the test
    # can fail): 0.5° is ~mm at these depths
    T = perturb_mounts(head.T_ptuL_from_ptuR(), 0.5, 0.0025, np.random.default_rng(0))
    p = e4.triangulate_points(e4.with_mounts(head, T), uv_l, uv_r, angles, "ls")
    assert np.max(np.linalg.norm(p - p_true, axis=1)) > 1e-3


def test_e4_exact_recovery_through_lens_distortion(quick):
    """Same, with a distorted lens on both eyes: projection distorts, triangulation
    undistorts (UNDISTORT_TOL 1e-12 normalised ≈ 1e-9 px)."""
    ctx, _, _ = quick
    truth = ctx.truth()
    dist = np.array([-0.12, 0.05, 4e-4, -3e-4, 0.0])
    head = HeadCalibration(**{eye: EyeCalibration(
        K=np.asarray(truth[eye]["K"]), dist=dist,
        T_cam_from_gaze=np.asarray(truth[eye]["T_cam_from_gaze"]),
        T_ptu_from_base=np.asarray(truth[eye]["T_ptu_from_base"]),
        image_size=tuple(truth[eye]["image_size"])) for eye in EYES})
    depth = e4.PLANE_DEPTHS_M[0]
    p_true = transform_points(T_base_from_world_facing(e4.BOARD, distance=depth),
                              e4.BOARD.object_points())
    a = np.radians(e4.plane_poses_deg(depth, 0)[1])
    uv_l, uv_r = head.project(p_true, *a)
    p = e4.triangulate_points(head, uv_l, uv_r, np.tile(a, (len(p_true), 1)), "ls")
    rel = np.linalg.norm(p - p_true, axis=1) / np.linalg.norm(p_true, axis=1)
    assert rel.max() < 1e-9


def test_e4_paper_axes():
    # ours: x up, y forward, z left → paper order (lateral + right, vertical + up, depth)
    p = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    np.testing.assert_array_equal(e4.paper_axes(p), [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
                                                     [0.0, 0.0, 1.0]])


def test_e4_poses_within_calibrated_range():
    for k, depth in enumerate(e4.PLANE_DEPTHS_M):
        poses = np.array(e4.plane_poses_deg(depth, k))
        assert np.all(np.abs(poses) <= 8.0 + 1e-12)
        # pose 0 verges: the left eye pans right (negative), the right eye left
        assert poses[0, 0] < 0 < poses[0, 2]


# ------------------------------------------------------------------------ E5

def test_e5_structure(quick):
    ctx, _, sec = quick
    out = ctx.out / "e5"
    for f in ("loop_closure.json", "measured_draws.csv", "montecarlo.csv", "e5_table.csv",
              "summary.json", "fig_base_to_ptu.png"):
        assert (out / f).is_file(), f
    assert not (out / "fig_base_to_ptu.svg").exists()   # --quick: PNG only
    mc = read_csv(out / "montecarlo.csv")
    assert len(mc) == len(e5.QUICK_LEVELS) * len(e5.VARIANTS) * e5.N_SAMPLES_QUICK
    assert np.all(np.isfinite([[float(r[k]) for k in ("rotation_deg", "translation_mm",
                                                       "baseline_length_mm")] for r in mc]))
    s = sec.summary
    # loop closure on rendered views: measured 0.021° / 0.56 mm; 10× margin
    assert 0.0 < s["loop_closure"]["rotation_deg"] < 0.2
    assert 0.0 < s["loop_closure"]["translation_mm"] < 5.0
    # measured mounts: exactly the drawn sizes, within the stated ranges
    draws = read_csv(out / "measured_draws.csv")
    assert len(draws) == e5.N_MEASURED_QUICK
    for r in draws:
        assert 0.0 <= float(r["rotation_deg"]) < 1.0
        assert 2.0 - 1e-9 <= float(r["translation_mm"]) <= 3.0 + 1e-9
        assert abs(float(r["baseline_length_mm"])) <= float(r["translation_mm"]) + 1e-9
    md = sec.markdown
    assert "(e5/fig_base_to_ptu.png)" in md and "2–3" in md and "< 1" in md


def test_e5_noise_levels(quick):
    ctx, _, sec = quick
    mc = read_csv(ctx.out / "e5" / "montecarlo.csv")
    lc = sec.summary["loop_closure"]
    for v in e5.VARIANTS:
        level0 = [float(r["rotation_deg"]) for r in mc if r["level"] == "0" and r["variant"] == v]
        # no noise: every sample is the pipeline's own loop closure
        assert np.allclose(level0, lc["rotation_deg"], rtol=1e-9, atol=1e-12)
        means = sec.summary["montecarlo"][v]["rot_mean"]
        assert means[0] < means[1] < means[2], (v, means)
    # re-solving the hand-eye from noisy ±8° views adds its error to the loop
    res, fix = (sec.summary["montecarlo"][v]["rot_mean"] for v in ("resolved", "fixed"))
    assert res[-1] > fix[-1]


def test_e5_loop_closure_batch_matches_library(quick):
    ctx, _, _ = quick
    cal = ctx.calibration()
    L, R = cal.eyes["left"], cal.eyes["right"]
    assert L.views == R.views
    T_gp = {e: T_gaze_from_ptu(cal.eyes[e].pan_tilt[:, 0], cal.eyes[e].pan_tilt[:, 1])
            for e in EYES}
    T_lib, _ = T_ptuL_from_ptuR_loop_closure(
        L.T_cam_from_world, R.T_cam_from_world, L.handeye.T_cam_from_gaze,
        R.handeye.T_cam_from_gaze, pan_tilt_left=L.pan_tilt, pan_tilt_right=R.pan_tilt)
    T = e5.loop_closure_batch(L.T_cam_from_world[None], R.T_cam_from_world[None],
                              L.handeye.T_cam_from_gaze, R.handeye.T_cam_from_gaze,
                              T_gp["left"], T_gp["right"])
    # same average (chordal L2 mean by projection vs scipy's quaternion eigenvector)
    np.testing.assert_allclose(T[0], T_lib, atol=1e-12)
    np.testing.assert_allclose(T[0], cal.base["loop_closure"]["T_ptuL_from_ptuR"], atol=1e-12)


def test_e5_loop_closure_batch_exact_on_truth(quick):
    """Chosen truth: the rendered views' true T_cam_from_world and the true hand-eye
    close the loop onto the true T_ptuL_from_ptuR."""
    ctx, _, _ = quick
    truth = ctx.truth()
    views = {e: sorted(f for f in truth["views"] if f.startswith(f"poses/{e}_")) for e in EYES}
    T_cw = {e: np.array([truth["views"][f]["T_cam_from_world"] for f in views[e]])
            for e in EYES}
    T_gp = {e: T_gaze_from_ptu(*np.radians([[truth["views"][f]["pan"] for f in views[e]],
                                            [truth["views"][f]["tilt"] for f in views[e]]]))
            for e in EYES}
    T_true = np.asarray(truth["T_ptuL_from_ptuR"])
    T = e5.loop_closure_batch(T_cw["left"][None], T_cw["right"][None],
                              np.asarray(truth["left"]["T_cam_from_gaze"]),
                              np.asarray(truth["right"]["T_cam_from_gaze"]),
                              T_gp["left"], T_gp["right"])
    # all transforms come from one double-precision model state: round-off only
    err = e5.errors_batch(T, T_true)[0]
    assert err[0] < 1e-9 and err[1] < 1e-9  # degrees, mm
    # a 2° offset in the right unit's pan encoder opens the loop by that much
    pan_r = np.radians([truth["views"][f]["pan"] for f in views["right"]])
    tilt_r = np.radians([truth["views"][f]["tilt"] for f in views["right"]])
    T_bad = e5.loop_closure_batch(T_cw["left"][None], T_cw["right"][None],
                                  np.asarray(truth["left"]["T_cam_from_gaze"]),
                                  np.asarray(truth["right"]["T_cam_from_gaze"]),
                                  T_gp["left"], T_gaze_from_ptu(pan_r + np.radians(2.0),
                                                                tilt_r))
    assert e5.errors_batch(T_bad, T_true)[0, 0] == pytest.approx(2.0, abs=0.05)


def test_e5_montecarlo_task_is_seeded(quick):
    ctx, _, _ = quick
    cal = ctx.calibration()
    L, R = cal.eyes["left"], cal.eyes["right"]
    task = e5.MonteCarloTask(
        level=3, sigma_r=0.01, sigma_t=0.002, seed=0, n_samples=4,
        T_cw={"left": L.T_cam_from_world, "right": R.T_cam_from_world},
        T_gp={e: T_gaze_from_ptu(cal.eyes[e].pan_tilt[:, 0], cal.eyes[e].pan_tilt[:, 1])
              for e in EYES},
        T_cg={e: cal.eyes[e].handeye.T_cam_from_gaze for e in EYES},
        T_true=np.asarray(ctx.truth()["T_ptuL_from_ptuR"]))
    a, b = e5.montecarlo_task(task), e5.montecarlo_task(replace(task))
    assert a.shape == (2, 4, 3)
    np.testing.assert_array_equal(a, b)
    c = e5.montecarlo_task(replace(task, seed=1))
    assert not np.array_equal(a, c)


def test_e5_crossing():
    assert e5.crossing([0.0, 1.0, 2.0], [0.0, 1.0, 3.0], 2.0) == pytest.approx(1.5)
    assert e5.crossing([0.0, 1.0], [0.0, 1.0], 2.0) is None
    assert e5.crossing([0.5, 1.0], [3.0, 4.0], 2.0) == 0.5
