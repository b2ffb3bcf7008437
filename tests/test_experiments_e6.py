"""Experiment E6 (beyond the paper), --quick: E6a corner-noise sweep, E6b hand-eye shoot-out.

The default dataset is rendered once per module and shared (symlinked) by every run's
output folder; each run calibrates it through the real pipeline. E6a runs four times:
A and B (workers 1), C (workers 2), F (the full protocol, workers 2); E6b three times:
A (workers 1), C (workers 2) and P (workers 1, with three fake failing methods added to
the method table). Result files (CSV/JSON) must be byte-identical across A, B, C.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import e6_pixel_noise as e6a  # noqa: E402
import e6_shootout as e6b  # noqa: E402
from _common import Context, read_csv  # noqa: E402

from rasc.errors import SolverFailure  # noqa: E402
from rasc.geometry.frames import EYES  # noqa: E402
from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu  # noqa: E402
from rasc.geometry.transforms import make_transform, matrix_from_rotvec  # noqa: E402
from rasc.handeye.methods import METHODS  # noqa: E402
from rasc.handeye.solver import solve_rasc  # noqa: E402

pytestmark = pytest.mark.slow  # renders and whole experiment runs


@pytest.fixture(scope="module")
def dataset(default_dataset) -> Path:
    """The default dataset (seed 0, as ``Context.dataset_dir`` renders it): conftest's,
    rendered once per test run."""
    return default_dataset


def make_ctx(root: Path, dataset: Path, workers: int = 1, quick: bool = True) -> Context:
    """A fresh output folder whose data/dataset is the shared rendering."""
    (root / "data").mkdir(parents=True)
    (root / "data" / "dataset").symlink_to(dataset, target_is_directory=True)
    return Context.from_argv(e6a.__doc__, [*(["--quick"] if quick else []), "--out", str(root),
                                           "--workers", str(workers)])


def result_files(folder: Path) -> dict[str, bytes]:
    """Every result file (CSV, JSON) of an experiment folder, by name."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())
            if p.suffix in (".csv", ".json")}


@pytest.fixture(scope="module")
def e6a_runs(dataset, tmp_path_factory):
    out = {}
    for name, workers, quick in (("A", 1, True), ("B", 1, True), ("C", 2, True),
                                 ("F", 2, False)):
        ctx = make_ctx(tmp_path_factory.mktemp(f"e6a_{name}"), dataset, workers, quick)
        out[name] = (ctx, e6a.run(ctx))
    return out


def _raises(T_cw, T_gp):
    raise SolverFailure("fake solver gave up")


def _returns_nan(T_cw, T_gp):
    return SimpleNamespace(T_cam_from_gaze=np.full((4, 4), np.nan), quality=np.nan)


def _returns_identity(T_cw, T_gp):
    return SimpleNamespace(T_cam_from_gaze=np.eye(4), quality=0.0)


FAKES = {"test-raises": _raises, "test-nan": _returns_nan, "test-identity": _returns_identity}


@pytest.fixture(scope="module")
def e6b_runs(dataset, tmp_path_factory):
    out = {}
    for name, workers in (("A", 1), ("C", 2)):
        ctx = make_ctx(tmp_path_factory.mktemp(f"e6b_{name}"), dataset, workers)
        out[name] = (ctx, e6b.run(ctx))
    patch = pytest.MonkeyPatch()
    try:
        patch.setattr(e6b, "METHODS", {**METHODS, **FAKES})
        ctx = make_ctx(tmp_path_factory.mktemp("e6b_P"), dataset, 1)
        out["P"] = (ctx, e6b.run(ctx))
    finally:
        patch.undo()
    return out


# ------------------------------------------------------------------------ E6a


def test_e6a_files_rows_and_section(e6a_runs):
    ctx, sec = e6a_runs["A"]
    folder = ctx.out / e6a.NAME
    raw = read_csv(folder / "raw.csv")
    assert tuple(raw[0]) == e6a.RAW_HEADER
    n = len(e6a.QUICK_SIGMAS_PX) * e6a.QUICK_N_SEEDS * len(EYES) * len(e6a.SOLVERS)
    assert len(raw) == n
    assert {r["status"] for r in raw} == {"ok"}
    assert sorted({float(r["sigma_px"]) for r in raw}) == sorted(e6a.QUICK_SIGMAS_PX)
    model = read_csv(folder / "eq13_matched_raw.csv")
    n_pos = sum(s > 0 for s in e6a.QUICK_SIGMAS_PX)
    assert len(model) == n_pos * len(EYES) * e6a.QUICK_MODEL_SAMPLES
    summary = read_csv(folder / "summary.csv")
    assert tuple(summary[0]) == e6a.SUMMARY_HEADER
    assert len(summary) == len(EYES) * (len(e6a.QUICK_SIGMAS_PX) * len(e6a.SOLVERS) + n_pos)
    assert all(int(r["n"]) == e6a.QUICK_N_SEEDS for r in summary if r["method"] != e6a.MODEL)
    pose = read_csv(folder / "pose_noise.csv")
    assert [float(r["sigma_px"]) for r in pose] == sorted(e6a.QUICK_SIGMAS_PX)
    # the figure exists and the section embeds it by a path relative to out/
    for ext in (".png", ".svg"):
        assert (folder / f"e6a_pixel_noise{ext}").stat().st_size > 1000
    assert "](e6a/e6a_pixel_noise.png)" in sec.markdown
    assert (ctx.out / "e6a/e6a_pixel_noise.png").is_file()
    assert all(Path(f).is_file() for f in sec.files)
    assert sec.key == "e6a" and sec.summary["failures"] == 0
    for s in e6a.QUICK_SIGMAS_PX:
        assert f"| {s:g} |" in sec.markdown        # one table row per level


def test_e6a_error_grows_with_corner_noise(e6a_runs):
    """Errors are linear in σ above a floor of ~0.01 deg / 0.3 mm (full run: slope 0.6
    deg/px, i.e. ~20x from 0.1 to 2 px); a factor 2 leaves room for 3-seed scatter."""
    _, sec = e6a_runs["A"]
    s = sec.summary
    assert s["max_sigma_px"] == 2.0 and s["min_positive_sigma_px"] == 0.1
    assert s["rasc_rotation_deg_at_max_sigma"] > 2 * s["rasc_rotation_deg_at_min_positive_sigma"]
    assert (s["rasc_translation_mm_at_max_sigma"]
            > 2 * s["rasc_translation_mm_at_min_positive_sigma"])
    # the extrinsics' own error grows with σ too, in both eq. 13-14 parameters
    pose = read_csv(e6a_runs["A"][0].out / "e6a/pose_noise.csv")
    for col in ("eq13_sigma_r_rad", "eq13_sigma_t_mm"):
        v = [float(r[col]) for r in pose]
        assert all(a < b for a, b in zip(v, v[1:], strict=False)), col


def test_e6a_noise_free_row_is_the_pipeline_result(e6a_runs):
    """σ = 0: same corners, intrinsics, extrinsics and solver as rasc.head.pipeline, so the
    errors must be the pipeline's own (computed there from its HeadCalibration) to
    round-off (1e-9 deg / 1e-6 mm, far below the 0.006 deg / 0.19 mm being compared)."""
    ctx, _ = e6a_runs["A"]
    errors = ctx.calibration().errors
    raw = read_csv(ctx.out / "e6a/raw.csv")
    for eye in EYES:
        rows = [r for r in raw if r["method"] == "rasc" and r["eye"] == eye
                and float(r["sigma_px"]) == 0.0]
        assert len(rows) == e6a.QUICK_N_SEEDS
        want = errors[eye]["T_cam_from_gaze"]
        for r in rows:
            assert float(r["rotation_deg"]) == pytest.approx(want["rotation_deg"], abs=1e-9)
            assert float(r["translation_mm"]) == pytest.approx(1000 * want["translation"],
                                                               abs=1e-6)


def test_e6a_deterministic_and_independent_of_workers(e6a_runs):
    files = {k: result_files(e6a_runs[k][0].out / e6a.NAME) for k in "ABC"}
    assert len(files["A"]) == 6
    assert files["A"] == files["B"]          # same seed, same bytes
    assert files["A"] == files["C"]          # workers 1 vs 2


def test_e6a_quick_rows_are_the_full_protocol_rows(e6a_runs):
    """Each (σ, seed) has its own generator keyed by σ, so the quick levels' results are
    exactly the full run's rows for those levels and seeds."""
    quick = read_csv(e6a_runs["A"][0].out / "e6a/raw.csv")
    full = read_csv(e6a_runs["F"][0].out / "e6a/raw.csv")
    assert len(full) == (len(e6a.SIGMAS_PX) * e6a.N_SEEDS * len(EYES) * len(e6a.SOLVERS))
    key = ("sigma_px", "seed", "eye", "method")
    by_key = {tuple(r[k] for k in key): r for r in full}
    for r in quick:
        assert by_key[tuple(r[k] for k in key)] == r
    sec = e6a_runs["F"][1]
    assert sec.summary["failures"] == 0
    assert "| 0.25 |" in sec.markdown and "10 seeds per level" in sec.markdown


# ------------------------------------------------------------------------ E6b


def test_e6b_files_rows_and_section(e6b_runs):
    ctx, sec = e6b_runs["A"]
    folder = ctx.out / e6b.NAME
    raw = read_csv(folder / "raw.csv")
    assert tuple(raw[0]) == e6b.RAW_HEADER
    sets, n_methods = e6b.QUICK_POSE_SETS_DEG, len(METHODS)
    assert len(raw) == len(sets) * (1 + e6b.QUICK_N_SEEDS) * len(EYES) * n_methods
    # every method ran on every (set, sigma, seed, eye)
    cells = {(r["pose_set_deg"], r["sigma_px"], r["seed"], r["eye"]) for r in raw}
    assert len(cells) == len(sets) * (1 + e6b.QUICK_N_SEEDS) * len(EYES)
    for c in cells:
        assert sorted(r["method"] for r in raw
                      if (r["pose_set_deg"], r["sigma_px"], r["seed"], r["eye"]) == c
                      ) == sorted(METHODS)
    summary = read_csv(folder / "summary.csv")
    assert tuple(summary[0]) == e6b.SUMMARY_HEADER
    assert len(summary) == len(sets) * n_methods
    assert all(int(r["n"]) == 2 * e6b.QUICK_N_SEEDS for r in summary)
    for ext in (".png", ".svg"):
        assert (folder / f"e6b_shootout{ext}").stat().st_size > 1000
    assert "](e6b/e6b_shootout.png)" in sec.markdown
    assert all(Path(f).is_file() for f in sec.files)
    for m in METHODS:
        assert f"| ±2° | {m} |" in sec.markdown and f"| ±8° | {m} |" in sec.markdown
    assert sec.summary["noisy_runs_per_cell"] == 2 * e6b.QUICK_N_SEEDS


def test_e6b_sanity(e6b_runs, e6a_runs):
    ctx, sec = e6b_runs["A"]
    s = sec.summary
    # RASC never fails on these grids, and its error grows as the motions shrink (full
    # run: 3x from ±8° to ±2°, so the ordering is robust to 2 seeds)
    assert all(v == 0 for v in s["failures"]["rasc"].values())
    assert all(v == 0 for v in s["clean_failures"]["rasc"].values())
    assert s["median_rotation_deg"]["rasc"]["2"] > s["median_rotation_deg"]["rasc"]["8"]
    assert s["median_translation_mm"]["rasc"]["2"] > s["median_translation_mm"]["rasc"]["8"]
    # the ±8° set is the dataset's: its noise-free RASC error is the pipeline's (mean of
    # the eyes; 1e-9 / 1e-6 as in the E6a test)
    errors = ctx.calibration().errors
    summary = {(r["pose_set_deg"], r["method"]): r
               for r in read_csv(ctx.out / "e6b/summary.csv")}
    r8 = summary[("8.0", "rasc")]
    assert float(r8["clean_rotation_deg"]) == pytest.approx(
        np.mean([errors[e]["T_cam_from_gaze"]["rotation_deg"] for e in EYES]), abs=1e-9)
    assert float(r8["clean_translation_mm"]) == pytest.approx(
        1000 * np.mean([errors[e]["T_cam_from_gaze"]["translation"] for e in EYES]), abs=1e-6)
    # the rendered ±2° set matches its recorded truth: noise-free extrinsics within
    # 5e-4 rad and 0.2 mm per axis (measured on the ±8° renders: 6e-5 rad, 0.025 mm; a
    # wrong target pose or angle would be off by degrees and centimetres)
    pose = read_csv(ctx.out / "e6b/pose_noise_raw.csv")
    clean2 = [r for r in pose if float(r["pose_set_deg"]) == 2.0 and float(r["sigma_px"]) == 0]
    assert len(clean2) == 2
    for r in clean2:
        assert float(r["eq13_sigma_r_rad"]) < 5e-4 and float(r["eq13_sigma_t_mm"]) < 0.2


def test_e6b_deterministic_and_independent_of_workers(e6b_runs):
    a = result_files(e6b_runs["A"][0].out / e6b.NAME)
    c = result_files(e6b_runs["C"][0].out / e6b.NAME)
    assert len(a) == 4
    assert a == c
    # run P (workers 1, another process state, extra methods) gives the real methods'
    # rows byte for byte as run A: two runs with the same seed agree
    raw_a = read_csv(e6b_runs["A"][0].out / "e6b/raw.csv")
    raw_p = read_csv(e6b_runs["P"][0].out / "e6b/raw.csv")
    assert [r for r in raw_p if r["method"] in METHODS] == raw_a


def test_e6b_failures_are_counted_not_crashes(e6b_runs):
    """Fake methods: one raises, one returns NaN, one returns the identity (gross). The
    run completes and every one of their runs is counted, by kind."""
    ctx, sec = e6b_runs["P"]
    n_runs = 2 * e6b.QUICK_N_SEEDS
    raw = read_csv(ctx.out / "e6b/raw.csv")
    kinds = {"test-raises": "exception", "test-nan": "nan", "test-identity": "gross"}
    for name, kind in kinds.items():
        rows = [r for r in raw if r["method"] == name]
        assert len(rows) == len(e6b.QUICK_POSE_SETS_DEG) * (1 + e6b.QUICK_N_SEEDS) * 2
        assert {r["status"] for r in rows} == {kind}
        for a in e6b.QUICK_POSE_SETS_DEG:
            assert sec.summary["failures"][name][f"{a:g}"] == n_runs
            assert sec.summary["clean_failures"][name][f"{a:g}"] == 2
    assert all("SolverFailure: fake solver gave up" in r["detail"]
               for r in raw if r["method"] == "test-raises")
    assert all("(the identity returned)" in r["detail"]
               for r in raw if r["method"] == "test-identity")
    summary = {(r["pose_set_deg"], r["method"]): r
               for r in read_csv(ctx.out / "e6b/summary.csv")}
    for name, col in (("test-raises", "exceptions"), ("test-nan", "nans"),
                      ("test-identity", "gross")):
        assert int(summary[("2.0", name)][col]) == n_runs
        assert summary[("2.0", name)]["rotation_median_deg"] == "nan"
    assert f"**{n_runs}** ({n_runs} exc.)" in sec.markdown
    assert f"**{n_runs}** ({n_runs} NaN)" in sec.markdown
    assert f"**{n_runs}** ({n_runs} gross)" in sec.markdown


# -------------------------------------------------------- run_method, render-free


def _synthetic(seed: int = 0):
    """True X, the paper's nine poses, and exact T_cam_from_world (metres)."""
    rng = np.random.default_rng(seed)
    X = make_transform(matrix_from_rotvec(rng.normal(size=3)), rng.normal(0, 0.05, 3))
    pt = np.radians(np.array(PAPER_POSES_DEG))
    T_gp = T_gaze_from_ptu(pt[:, 0], pt[:, 1])
    T_ptu_from_world = make_transform(matrix_from_rotvec(rng.normal(size=3)), [0.1, 1.0, 0.0])
    return X, T_gp, X @ T_gp @ T_ptu_from_world


def test_run_method_ok_and_thresholds():
    X, T_gp, T_cw = _synthetic()
    r = e6a.run_method(solve_rasc, T_cw, T_gp, X)
    # exact data: recovered to round-off (1e-9 deg, 1e-6 mm)
    assert r["status"] == "ok" and r["detail"] == ""
    assert r["rotation_deg"] < 1e-9 and r["translation_mm"] < 1e-6
    for angle, status in ((9.9, "ok"), (10.1, "gross")):
        off = X @ make_transform(matrix_from_rotvec([np.radians(angle), 0, 0]), np.zeros(3))
        r = e6a.run_method(lambda a, b, off=off: SimpleNamespace(T_cam_from_gaze=off,
                                                                 quality=0.0), T_cw, T_gp, X)
        assert r["status"] == status
        assert r["rotation_deg"] == pytest.approx(angle, abs=1e-9)
    for mm, status in ((99.0, "ok"), (101.0, "gross")):
        off = X.copy()
        off[1, 3] += mm / 1000
        r = e6a.run_method(lambda a, b, off=off: SimpleNamespace(T_cam_from_gaze=off,
                                                                 quality=0.0), T_cw, T_gp, X)
        assert r["status"] == status
        assert r["translation_mm"] == pytest.approx(mm, abs=1e-9)


def test_run_method_failures():
    X, T_gp, T_cw = _synthetic(1)
    r = e6a.run_method(_raises, T_cw, T_gp, X)
    assert r["status"] == "exception" and r["detail"].startswith("SolverFailure: fake")
    assert np.isnan(r["rotation_deg"]) and np.isnan(r["quality"])
    # a real degenerate input: pan-only motion (all axes parallel) → DegenerateDataError
    pan_only = T_gaze_from_ptu(np.radians([0.0, 4.0, 8.0]), np.zeros(3))
    r = e6a.run_method(solve_rasc, X @ pan_only, pan_only, X)
    assert r["status"] == "exception" and r["detail"].startswith("DegenerateDataError")
    r = e6a.run_method(_returns_nan, T_cw, T_gp, X)
    assert r["status"] == "nan" and np.isnan(r["translation_mm"])
    r = e6a.run_method(_returns_identity, T_cw, T_gp, X)
    assert r["status"] == "gross" and "(the identity returned)" in r["detail"]

    def bug(a, b):
        raise TypeError("a programming error")
    with pytest.raises(TypeError):           # bugs are not swallowed as "failures"
        e6a.run_method(bug, T_cw, T_gp, X)


def test_noisy_extrinsics_draws_do_not_depend_on_sigma(e6a_runs):
    """σ scales one fixed stream of standard normals: σ = 0 consumes the generator like
    any σ and reproduces the noise-free extrinsics."""
    ctx, _ = e6a_runs["A"]
    eyes = e6a.pose_eye_data(ctx)
    board = e6a.load_dataset(ctx.dataset_dir()).board
    g0, g1 = np.random.default_rng(5), np.random.default_rng(5)
    T0 = e6a.noisy_extrinsics(eyes["left"], board, 0.0, g0)
    T1 = e6a.noisy_extrinsics(eyes["left"], board, 1.0, g1)
    assert g0.standard_normal() == g1.standard_normal()
    clean = np.array([e6a.estimate_extrinsics(c, board, eyes["left"].K, eyes["left"].dist)[0]
                      for c in eyes["left"].corners])
    assert np.array_equal(T0, clean)
    assert np.abs(T1 - clean).max() > 1e-6       # 1 px of noise moves the poses
