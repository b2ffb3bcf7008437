"""Experiment E6 (beyond the paper), --quick: E6a corner-noise sweep, E6b hand-eye shoot-out,
both run by the study engine from their specs (experiments/specs/e6*.toml).

The default dataset is rendered once per test run and shared (symlinked) by every run's
output folder; each run calibrates it through the real pipeline. E6a runs twice: A
(--quick) and F (the full protocol), E6b once: A; all with workers 1 (a pool of 2 cost F
about 3 s more CPU than one process). The A runs are conftest's ``quick_experiments``
(once per test run, shared with tests/e2e/test_reproduce.py). That the same seed gives
byte-identical result files (CSV/JSON, the study's own files too) for any worker count is
tests/e2e/test_reproduce.py's claim for every experiment (its pool run, ``--workers 2``,
against these); runs C here with ``--workers 2`` repeated it for E6a and E6b (see
tests/e2e/test_experiments_e1_e3.py for what the repeats cost). Failure
counting is checked on the analysis functions with made-up study rows (the engine's
classification itself: tests/study/test_study_pose_sets.py).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the experiments package

import experiments._common as common  # noqa: E402
from experiments import e6a_pixel_noise as e6a  # noqa: E402
from experiments import e6b_shootout as e6b  # noqa: E402
from experiments._common import Context, read_csv  # noqa: E402
from rasc.geometry.frames import EYES  # noqa: E402
from rasc.handeye.methods import METHODS as ALL_METHODS  # noqa: E402

#: E6b's methods: every method but rasc-scale (it needs a unit that translates; the
#: pan-tilt head's data always refuse it)
METHODS = tuple(m for m in ALL_METHODS if m != "rasc-scale")
from rasc.study.spec import load_spec  # noqa: E402

pytestmark = pytest.mark.slow  # renders and whole experiment runs


@pytest.fixture(scope="module")
def dataset(quick_experiments) -> Path:
    """The default dataset (seed 0) with the render record ``Context.dataset_dir`` asks
    for, so that a run's folder linking to it uses it (conftest's, rendered once per test
    run)."""
    return quick_experiments.dataset


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
def e6a_runs(dataset, quick_experiments, tmp_path_factory):
    ctx = make_ctx(tmp_path_factory.mktemp("e6a_F"), dataset, 1, quick=False)
    return {"A": quick_experiments("e6a_pixel_noise"), "F": (ctx, e6a.run(ctx))}


@pytest.fixture(scope="module")
def e6b_runs(quick_experiments):
    return {"A": quick_experiments("e6b_shootout")}


def spec(name: str, quick: bool = True):
    return load_spec(common.SPECS / f"{name}.toml", quick=quick)


# ------------------------------------------------------------------------ E6a


def test_e6a_files_rows_and_section(e6a_runs):
    ctx, sec = e6a_runs["A"]
    folder = ctx.out / e6a.NAME
    q = spec(e6a.SPEC)
    sigmas = q.axes["corner_noise_px"]
    assert q.methods == e6a.SOLVERS and q.samples == 3 and sigmas == (0.0, 0.1, 0.5, 2.0)
    raw = read_csv(folder / "raw.csv")
    assert tuple(raw[0]) == e6a.RAW_HEADER
    assert len(raw) == len(sigmas) * q.samples * len(EYES) * len(e6a.SOLVERS)
    assert {r["status"] for r in raw} == {"ok"}
    assert sorted({float(r["corner_noise_px"]) for r in raw}) == sorted(sigmas)
    model = read_csv(folder / "eq13_matched_raw.csv")
    n_pos = sum(s > 0 for s in sigmas)
    assert len(model) == n_pos * len(EYES) * e6a.QUICK_MODEL_SAMPLES
    summary = read_csv(folder / "summary.csv")
    assert tuple(summary[0]) == e6a.SUMMARY_HEADER
    assert len(summary) == len(EYES) * (len(sigmas) * len(e6a.SOLVERS) + n_pos)
    assert all(int(r["n"]) == q.samples for r in summary if r["method"] != e6a.MODEL)
    pose = read_csv(folder / "pose_noise.csv")
    assert [float(r["corner_noise_px"]) for r in pose] == sorted(sigmas)
    # the study itself is kept beside the files, with its pose-error columns
    assert (folder / e6a.SPEC / "study.json").is_file()
    assert "pose_t_z_mm" in read_csv(folder / e6a.SPEC / "samples.csv")[0]
    # the figure exists and the section embeds it by a path relative to out/
    # --quick draws a draft PNG only; the full run (F) also the SVG
    assert (folder / "e6a_pixel_noise.png").stat().st_size > 1000
    assert not (folder / "e6a_pixel_noise.svg").exists()
    for ext in (".png", ".svg"):
        assert (e6a_runs["F"][0].out / "e6a" / f"e6a_pixel_noise{ext}").stat().st_size > 1000
    assert "](e6a/e6a_pixel_noise.png)" in sec.markdown
    assert (ctx.out / "e6a/e6a_pixel_noise.png").is_file()
    assert all(Path(f).is_file() for f in sec.files)
    assert sec.key == "e6a" and sec.summary["failures"] == 0
    for s in sigmas:
        assert f"| {s:g} |" in sec.markdown        # one table row per level


def test_e6a_error_grows_with_corner_noise(e6a_runs):
    """Errors are linear in σ above a floor of ~0.01 deg / 0.3 mm (full run: slope 0.6
    deg/px, i.e. ~20x from 0.1 to 2 px); a factor 2 leaves room for 3-sample scatter."""
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
                and float(r["corner_noise_px"]) == 0.0]
        assert len(rows) == spec(e6a.SPEC).samples
        want = errors[eye]["T_cam_from_gaze"]
        for r in rows:
            assert float(r["rotation_deg"]) == pytest.approx(want["rotation_deg"], abs=1e-9)
            assert float(r["translation_mm"]) == pytest.approx(1000 * want["translation"],
                                                               abs=1e-6)


def test_e6a_result_files(e6a_runs):
    """The result files and the study's own (same bytes for any worker count:
    tests/e2e/test_reproduce.py)."""
    assert len(result_files(e6a_runs["A"][0].out / e6a.NAME)) == 6
    assert "samples.csv" in result_files(e6a_runs["A"][0].out / e6a.NAME / e6a.SPEC)


def test_e6a_quick_rows_are_the_full_protocol_rows(e6a_runs):
    """The engine seeds each sample by its cell's parameters, so the quick levels'
    results are exactly the full run's rows for those levels and samples."""
    quick = read_csv(e6a_runs["A"][0].out / "e6a/raw.csv")
    full = read_csv(e6a_runs["F"][0].out / "e6a/raw.csv")
    f = spec(e6a.SPEC, quick=False)
    assert len(full) == (len(f.axes["corner_noise_px"]) * f.samples * len(EYES)
                         * len(e6a.SOLVERS))
    key = ("corner_noise_px", "sample", "eye", "method")
    by_key = {tuple(r[k] for k in key): r for r in full}
    for r in quick:
        assert by_key[tuple(r[k] for k in key)] == r
    sec = e6a_runs["F"][1]
    assert sec.summary["failures"] == 0
    assert "| 0.25 |" in sec.markdown and "10 samples per level" in sec.markdown


# ------------------------------------------------------------------------ E6b


def test_e6b_spec_has_every_method_and_the_gross_thresholds():
    f = spec(e6b.SPEC, quick=False)
    assert f.methods == tuple(METHODS)
    assert (f.gross_rotation_deg, f.gross_translation_mm) == (10.0, 100.0)
    assert f.axes["motion_deg"] == (8.0, 4.0, 2.0) and f.fixed["intrinsics_from"] == "dataset"


def test_e6b_files_rows_and_section(e6b_runs):
    ctx, sec = e6b_runs["A"]
    folder = ctx.out / e6b.NAME
    q = spec(e6b.SPEC)
    sets, n_methods = q.axes["motion_deg"], len(METHODS)
    assert sets == (8.0, 2.0)
    raw = read_csv(folder / "raw.csv")
    assert tuple(raw[0]) == e6b.RAW_HEADER
    assert len(raw) == len(sets) * (1 + q.samples) * len(EYES) * n_methods
    # every method ran on every (set, sigma, sample, eye)
    cells = {(r["motion_deg"], r["corner_noise_px"], r["sample"], r["eye"]) for r in raw}
    assert len(cells) == len(sets) * (1 + q.samples) * len(EYES)
    for c in cells:
        assert sorted(r["method"] for r in raw
                      if (r["motion_deg"], r["corner_noise_px"], r["sample"], r["eye"]) == c
                      ) == sorted(METHODS)
    summary = read_csv(folder / "summary.csv")
    assert tuple(summary[0]) == e6b.SUMMARY_HEADER
    assert len(summary) == len(sets) * n_methods
    assert all(int(r["n"]) == 2 * q.samples for r in summary)
    assert (folder / "e6b_shootout.png").stat().st_size > 1000      # --quick: a draft PNG
    assert "](e6b/e6b_shootout.png)" in sec.markdown
    assert all(Path(f).is_file() for f in sec.files)
    for m in METHODS:
        assert f"| ±2° | {m} |" in sec.markdown and f"| ±8° | {m} |" in sec.markdown
    assert sec.summary["noisy_runs_per_cell"] == 2 * q.samples
    # one pose set rendered (±2°); ±8° is the default dataset's own
    assert len(list((folder / e6b.SPEC / "datasets").glob("*.json"))) == 2


def test_e6b_sanity(e6b_runs):
    ctx, sec = e6b_runs["A"]
    s = sec.summary
    # RASC never fails on these grids, and its error grows as the motions shrink (full
    # run: 3x from ±8° to ±2°, so the ordering is robust to 2 samples)
    assert all(v == 0 for v in s["failures"]["rasc"].values())
    assert all(v == 0 for v in s["clean_failures"]["rasc"].values())
    assert s["median_rotation_deg"]["rasc"]["2"] > s["median_rotation_deg"]["rasc"]["8"]
    assert s["median_translation_mm"]["rasc"]["2"] > s["median_translation_mm"]["rasc"]["8"]
    # the ±8° set is the dataset's: its noise-free RASC error is the pipeline's (mean of
    # the eyes; 1e-9 / 1e-6 as in the E6a test)
    errors = ctx.calibration().errors
    summary = {(r["motion_deg"], r["method"]): r
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
    clean2 = [r for r in pose if float(r["motion_deg"]) == 2.0 and float(r["corner_noise_px"]) == 0]
    assert len(clean2) == 2
    for r in clean2:
        assert float(r["eq13_sigma_r_rad"]) < 5e-4 and float(r["eq13_sigma_t_mm"]) < 0.2


def test_e6b_result_files(e6b_runs):
    """The result files and the study's own (same bytes for any worker count:
    tests/e2e/test_reproduce.py)."""
    assert len(result_files(e6b_runs["A"][0].out / e6b.NAME)) == 4
    assert "samples.csv" in result_files(e6b_runs["A"][0].out / e6b.NAME / e6b.SPEC)


def _tidy(method: str, status: str, sample: int, sigma: float, eye: str = "left",
          motion: float = 2.0, rot: float = 0.5, trans: float = 5.0) -> dict:
    """One made-up row of a study's samples.csv, as csv.DictReader gives it."""
    failed = status.startswith("failed") or status == "non-finite"
    num = (lambda x: "") if failed else repr
    return {"cell": "0", "motion_deg": repr(motion), "corner_noise_px": repr(sigma),
            "eye": eye, "sample": str(sample), "method": method, "status": status,
            "translation_mm": num(trans), "rotation_deg": num(rot), "rotation_fro": num(0.01),
            "quality": num(0.1), **{f"pose_rot_{a}_rad": "0.001" for a in "xyz"},
            **{f"pose_t_{a}_mm": "0.2" for a in "xyz"}}


def test_e6b_failures_are_counted_by_kind(tmp_path):
    """The analysis over made-up study rows: the engine's statuses become exception /
    nan / gross, are counted per kind over the noisy runs (both eyes), kept out of the
    medians, and the noise-free cell (one row per eye, its samples repeated) counts
    once per eye."""
    tidy = []
    for eye in EYES:
        for s in range(3):                 # noise-free cell: the engine repeats sample 0
            tidy += [_tidy("good", "ok", s, 0.0, eye, rot=0.1, trans=1.0),
                     _tidy("raises", "failed: SolverFailure", s, 0.0, eye),
                     _tidy("mixed", "non-finite", s, 0.0, eye)]
        for s in range(3):
            tidy += [_tidy("good", "ok", s, 0.25, eye, rot=0.2 + s, trans=2.0 + s),
                     _tidy("raises", "failed: SolverFailure", s, 0.25, eye),
                     _tidy("mixed", "gross" if s == 0 else "ok", s, 0.25, eye,
                           rot=20.0 if s == 0 else 1.0, trans=3.0)]
    raw = e6b.raw_rows(tidy)
    assert len(raw) == 2 * 3 + 2 * 3 * 3          # noise-free: sample 0 only
    write_csv_rows = [dict(zip(e6b.RAW_HEADER, map(str, r), strict=True)) for r in raw]
    assert {r["status"] for r in write_csv_rows if r["method"] == "raises"} == {"exception"}
    assert {r["detail"] for r in write_csv_rows if r["method"] == "raises"} == {"SolverFailure"}
    rows = e6b.summarise(write_csv_rows, ("good", "raises", "mixed"))
    by = {r[1]: dict(zip(e6b.SUMMARY_HEADER, r, strict=True)) for r in rows}
    assert (by["good"]["n"], by["good"]["failures"], by["good"]["clean_failures"]) == (6, 0, 0)
    assert by["good"]["rotation_median_deg"] == pytest.approx(1.2)   # 0.2 1.2 2.2 per eye
    assert by["good"]["clean_translation_mm"] == pytest.approx(1.0)
    assert (by["raises"]["failures"], by["raises"]["exceptions"]) == (6, 6)
    assert by["raises"]["clean_failures"] == 2 and by["raises"]["first_failure"] == "SolverFailure"
    assert (by["mixed"]["failures"], by["mixed"]["gross"], by["mixed"]["nans"]) == (2, 2, 0)
    assert by["mixed"]["clean_failures"] == 2           # its noise-free runs were non-finite
    assert by["mixed"]["rotation_median_deg"] == pytest.approx(1.0)  # gross left out
    assert by["mixed"]["first_failure"] == "non-finite T_cam_from_gaze"
    assert e6b._failure_kinds({k: str(v) for k, v in by["mixed"].items()}) == "**2** (2 gross)"
