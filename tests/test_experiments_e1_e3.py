"""Experiments E1 (Figs. 3–4), E2 (home-view noise) and E3 (quality measure), --quick.

The default dataset is rendered once per module and shared (symlinked) by every run's
output folder; each run calibrates it through the real pipeline. Quick runs: A (workers
1; E3 reuses E1's CSV) and B (workers 2) of E1–E3, and C (workers 1) of E3 alone, which
recomputes E1's samples. Their result files must be byte-identical.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import e2_home_view as e2  # noqa: E402
import e3_quality as e3  # noqa: E402
import fig3_fig4_noise as e1  # noqa: E402
from _common import Context, read_csv, spawn_rngs  # noqa: E402

from rasc.geometry.frames import EYES  # noqa: E402
from rasc.geometry.transforms import rotation_error_deg  # noqa: E402
from rasc.handeye.li import solve_li  # noqa: E402
from rasc.handeye.noise import VARIANTS, perturb_one_view, perturb_T_cam_from_world  # noqa: E402
from rasc.handeye.solver import solve_rasc  # noqa: E402

pytestmark = pytest.mark.slow  # renders and whole experiment runs

QUICK_LEVELS = [0, *e1.QUICK_LEVELS]


@pytest.fixture(scope="module")
def dataset(default_dataset) -> Path:
    """The default dataset (seed 0, as ``Context.dataset_dir`` renders it): conftest's,
    rendered once per test run."""
    return default_dataset


def make_ctx(root: Path, dataset: Path, workers: int = 1, seed: int = 0) -> Context:
    """A fresh output folder whose data/dataset is the shared rendering."""
    (root / "data").mkdir(parents=True)
    (root / "data" / "dataset").symlink_to(dataset, target_is_directory=True)
    return Context.from_argv(e1.__doc__, ["--quick", "--out", str(root), "--workers",
                                          str(workers), "--seed", str(seed)])


@pytest.fixture(scope="module")
def runs(dataset, tmp_path_factory):
    """Quick runs: A (workers 1) and B (workers 2) of E1–E3; C (workers 1) of E3 only."""
    out = {}
    for name, workers, order in (("A", 1, (e1, e2, e3)), ("B", 2, (e1, e2, e3)),
                                 ("C", 1, (e3,))):
        ctx = make_ctx(tmp_path_factory.mktemp(f"run{name}"), dataset, workers)
        out[name] = {"ctx": ctx, **{m.NAME: m.run(ctx) for m in order}}
    return out


def result_files(root: Path, names=("e1", "e2", "e3")) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes()
            for name in names for p in sorted((root / name).iterdir())}


# --------------------------------------------------------------------------- E1

def test_e1_files_rows_and_report(runs):
    ctx, sec = runs["A"]["ctx"], runs["A"]["e1"]
    folder = ctx.out / "e1"
    raw = read_csv(folder / e1.RAW_CSV)
    assert tuple(raw[0].keys()) == e1.HEADER
    # level 0: one solve; other quick levels: QUICK_SAMPLES; per eye, variant, method
    assert len(raw) == 2 * 2 * 2 * (1 + len(e1.QUICK_LEVELS) * e1.QUICK_SAMPLES)
    assert {r["status"] for r in raw} == {"ok"}
    assert sorted({int(r["level"]) for r in raw}) == QUICK_LEVELS
    for stem in ("fig3_translation", "fig4_rotation", "fig3_translation_exponential",
                 "fig4_rotation_exponential"):
        for ext in (".png", ".svg"):
            assert (folder / f"{stem}{ext}").stat().st_size > 1000
    # the report embeds the main figures by a path relative to --out, and they exist
    for rel in ("e1/fig3_translation.png", "e1/fig4_rotation.png"):
        assert f"]({rel})" in sec.markdown and (ctx.out / rel).is_file()
    assert set(sec.files) >= {folder / e1.RAW_CSV, folder / e1.SUMMARY_CSV}
    assert sec.summary["main_variant"] == "literal" and sec.summary["levels"] == QUICK_LEVELS


def test_e1_rasc_translation_error_grows_with_noise(runs):
    s = runs["A"]["e1"].summary
    for variant in VARIANTS:
        for eye in EYES:
            t = s[variant][eye]["rasc_t_mm"]          # per level 0, 1, 4, 8
            # level 8 has 8x the noise of level 1: the mean must be larger, and the
            # noise-free floor (0.2-0.5 mm measured) below level 1 (~10 mm measured)
            assert t[-1] > t[1] > t[0], (variant, eye, t)


def test_e1_samples_are_the_documented_noise_and_shared_by_both_methods(runs):
    """Regenerate one (eye, level) from the stated seeding, solve each sample with the
    single-sample solvers, and find the CSV's numbers: both methods saw these samples."""
    ctx = runs["A"]["ctx"]
    inputs = e1.eye_inputs(ctx)
    eye, e, level = "right", 1, 4
    sr, st = e1.PAPER_LEVELS[level - 1]
    d = inputs[eye]
    rng = spawn_rngs(ctx.seed, 1, e1.E1_KEY, e, level)[0]
    noisy = perturb_T_cam_from_world(
        np.broadcast_to(d["T_cam_from_world"], (e1.QUICK_SAMPLES, 9, 4, 4)), sr, st / 1000,
        rng, "literal")
    raw = {(r["method"], int(r["sample"])): r for r in read_csv(ctx.out / "e1" / e1.RAW_CSV)
           if (r["eye"], r["variant"], int(r["level"])) == (eye, "literal", level)}
    X = d["T_cam_from_gaze_true"]
    for s in range(e1.QUICK_SAMPLES):
        for method, res in (("rasc", solve_rasc(noisy[s], d["T_gaze_from_ptu"],
                                                check_rigid=False)),
                            ("li", solve_li(noisy[s], d["T_gaze_from_ptu"], home=d["home"],
                                            check_rigid=False))):
            T = res.T_cam_from_gaze
            r = raw[(method, s)]
            # batch vs single solve and CSV repr: agree to round-off (measured < 1e-12)
            assert float(r["t_err_mm"]) == pytest.approx(
                1000 * np.linalg.norm(T[:3, 3] - X[:3, 3]), rel=1e-9)
            assert float(r["R_err_deg"]) == pytest.approx(
                float(rotation_error_deg(T[:3, :3], X[:3, :3])), rel=1e-7, abs=1e-10)
            assert float(r["quality"]) == pytest.approx(res.quality, rel=1e-9)


def test_e1_summary_is_the_papers_definition(runs):
    """Mean errors and the paper's std (norm of component / element-wise std of the
    estimates), recomputed from the raw rows with variances instead of std."""
    folder = runs["A"]["ctx"].out / "e1"
    raw = read_csv(folder / e1.RAW_CSV)
    summ = {(r["eye"], r["variant"], int(r["level"]), r["method"]): r
            for r in read_csv(folder / e1.SUMMARY_CSV)}
    for key, row in summ.items():
        rows = [r for r in raw if (r["eye"], r["variant"], int(r["level"]), r["method"]) == key]
        t = np.array([[float(r[c]) for c in ("t_x_mm", "t_y_mm", "t_z_mm")] for r in rows])
        R = np.array([[float(r[c]) for c in e1.R_COLS] for r in rows])
        assert float(row["t_err_mean_mm"]) == pytest.approx(
            np.mean([float(r["t_err_mm"]) for r in rows]), rel=1e-12)
        if len(rows) == 1:
            assert row["t_std_mm"] == "" and row["R_std_fro"] == ""
            continue
        n = len(rows)
        var_t = ((t - t.mean(0)) ** 2).sum(0) / (n - 1)
        var_R = ((R - R.mean(0)) ** 2).sum(0) / (n - 1)
        assert float(row["t_std_mm"]) == pytest.approx(np.sqrt(var_t.sum()), rel=1e-9)
        assert float(row["R_std_fro"]) == pytest.approx(np.sqrt(var_R.sum()), rel=1e-9)
    # the error columns are what they say: ‖t − t_true‖ from the estimate columns
    X = {eye: np.array(runs["A"]["ctx"].truth()[eye]["T_cam_from_gaze"]) for eye in EYES}
    for r in raw[::7]:
        t = np.array([float(r[c]) for c in ("t_x_mm", "t_y_mm", "t_z_mm")])
        R = np.array([float(r[c]) for c in e1.R_COLS]).reshape(3, 3)
        assert float(r["t_err_mm"]) == pytest.approx(
            np.linalg.norm(t - 1000 * X[r["eye"]][:3, 3]), rel=1e-9)
        assert float(r["R_err_fro"]) == pytest.approx(
            np.linalg.norm(R - X[r["eye"]][:3, :3]), rel=1e-9)


def test_e1_paired_tests_match_scipy(runs):
    from scipy.stats import wilcoxon

    folder = runs["A"]["ctx"].out / "e1"
    raw = read_csv(folder / e1.RAW_CSV)
    tests = {(r["eye"], r["variant"], r["level"], r["quantity"]): r
             for r in read_csv(folder / e1.TESTS_CSV)}
    for eye, level, q in (("left", 8, "t_err_mm"), ("right", 1, "R_err_fro")):
        sel = [r for r in raw if (r["eye"], r["variant"], int(r["level"])) ==
               (eye, "literal", level)]
        a = {r["sample"]: float(r[q]) for r in sel if r["method"] == "rasc"}
        b = {r["sample"]: float(r[q]) for r in sel if r["method"] == "li"}
        d = np.array([b[s] - a[s] for s in sorted(a)])
        row = tests[(eye, "literal", str(level), q)]
        assert float(row["wilcoxon_p"]) == pytest.approx(wilcoxon(d).pvalue, rel=1e-12)
        assert float(row["frac_rasc_better"]) == pytest.approx((d > 0).mean())
    # pooled rows exist per eye and for both eyes, over all quick levels x samples
    pooled = tests[("both", "literal", "all", "t_err_mm")]
    assert int(pooled["n"]) == 2 * len(e1.QUICK_LEVELS) * e1.QUICK_SAMPLES


def test_e1_seed_changes_the_noise_not_the_floor(runs, dataset, tmp_path):
    ctx1 = make_ctx(tmp_path, dataset, seed=1)
    rows1 = e1.compute_rows(ctx1, e1.eye_inputs(ctx1), e1.levels(True))
    raw0 = read_csv(runs["A"]["ctx"].out / "e1" / e1.RAW_CSV)
    key = lambda r: (r[0], r[1], int(r[2]), int(r[5]), r[6])  # noqa: E731
    t1 = {key(r): r[8] for r in rows1}
    t0 = {key([r[h] for h in e1.HEADER]): float(r["t_err_mm"]) for r in raw0}
    assert t1.keys() == t0.keys()
    for k, v in t0.items():
        assert (t1[k] == v) == (k[2] == 0), k      # level 0 has no noise: same numbers


# --------------------------------------------------------------------------- E2

def test_e2_li_error_exceeds_rasc(runs):
    sec = runs["A"]["e2"]
    summary = read_csv(runs["A"]["ctx"].out / "e2" / e2.SUMMARY_CSV)
    assert {(r["eye"], r["variant"]) for r in summary} == {(e, v) for e in EYES
                                                           for v in VARIANTS}
    for r in summary:
        # measured ratios 7.5-9 (30 samples); with 8 samples a factor 2 is a safe floor
        # that still fails if Li were not clearly worse
        assert float(r["ratio_t"]) > 2 and float(r["ratio_R"]) > 2, r
        assert float(r["li_t_mean_mm"]) > float(r["rasc_t_mean_mm"])
    assert "](e2/e2_home_view.png)" in sec.markdown
    assert (runs["A"]["ctx"].out / "e2" / "e2_home_view.svg").is_file()


def test_e2_noise_is_on_the_home_view_only(runs):
    """Regenerate eye 0's samples with perturb_one_view: Li's CSV errors match, and the
    perturbed poses differ from the pipeline's at the home view only."""
    ctx = runs["A"]["ctx"]
    d = e1.eye_inputs(ctx)["left"]
    rng = spawn_rngs(ctx.seed, 1, e2.E2_KEY, 0)[0]
    T0 = np.broadcast_to(d["T_cam_from_world"], (e2.QUICK_SAMPLES, 9, 4, 4))
    noisy = perturb_one_view(T0, d["home"], e2.SIGMA_R, e2.SIGMA_T_MM / 1000, rng, "literal")
    changed = np.abs(noisy - T0).max(axis=(2, 3)) > 0
    assert changed[:, d["home"]].all() and changed.sum() == e2.QUICK_SAMPLES
    raw = {int(r["sample"]): float(r["t_err_mm"])
           for r in read_csv(ctx.out / "e2" / e2.RAW_CSV)
           if (r["eye"], r["variant"], r["method"]) == ("left", "literal", "li")}
    X = d["T_cam_from_gaze_true"]
    for s in range(e2.QUICK_SAMPLES):
        T = solve_li(noisy[s], d["T_gaze_from_ptu"], home=d["home"],
                     check_rigid=False).T_cam_from_gaze
        assert raw[s] == pytest.approx(1000 * np.linalg.norm(T[:3, 3] - X[:3, 3]), rel=1e-9)


# --------------------------------------------------------------------------- E3

def test_e3_structure_and_threshold_exercised(runs):
    ctx, sec = runs["A"]["ctx"], runs["A"]["e3"]
    folder = ctx.out / "e3"
    raw = read_csv(folder / e3.RAW_CSV)
    assert tuple(raw[0].keys()) == e3.HEADER
    n_e1 = 2 * 2 * (1 + len(e1.QUICK_LEVELS) * e1.QUICK_SAMPLES)     # RASC rows of E1
    n_ext = 2 * 2 * len(e3.QUICK_EXT) * e1.QUICK_SAMPLES
    assert sum(r["source"] == "e1" for r in raw) == n_e1
    assert sum(r["source"] == "e3" for r in raw) == n_ext
    for r in raw:        # the flag is the stated definition
        bad = float(r["R_err_deg"]) > 5.0 or float(r["t_err_mm"]) > 50.0
        assert r["unusable"] == str(int(bad))
    a = sec.summary
    for variant in VARIANTS:
        for subset in ("all", "paper_sets"):
            s = a[variant][subset]
            c = s["confusion_at_1"]
            assert (c["flagged_unusable"] + c["flagged_usable"] + c["passed_unusable"]
                    + c["passed_usable"]) == s["n"]
            assert -1 <= s["spearman_quality_R_err"]["rho"] <= 1
        # the extended sets reach the paper's threshold (measured median 1.27 at set 15)
        assert a[variant]["all"]["confusion_at_1"]["flagged_unusable"] > 0
        # quality ranks the errors (measured ρ ≈ 0.9): positive correlation
        assert a[variant]["all"]["spearman_quality_t_err"]["rho"] > 0.5
    assert "](e3/e3_quality_vs_error.png)" in sec.markdown
    assert (folder / "e3_quality_vs_error.svg").is_file()
    assert (folder / e3.LEVELS_CSV).is_file()


def test_e3_reuses_e1_only_when_protocol_matches(runs, dataset, tmp_path):
    ctx = runs["A"]["ctx"]
    inputs = e1.eye_inputs(ctx)
    rows, how = e3.e1_rasc_rows(ctx, inputs)
    assert how.startswith("reused")
    # a stale E1 output (another seed) is not reused
    other = make_ctx(tmp_path, dataset, seed=0)
    (other.out / "e1").mkdir()
    text = (ctx.out / "e1" / "inputs.json").read_text().replace('"seed": 0', '"seed": 7')
    (other.out / "e1" / "inputs.json").write_text(text)
    (other.out / "e1" / e1.RAW_CSV).write_bytes((ctx.out / "e1" / e1.RAW_CSV).read_bytes())
    rows2, how2 = e3.e1_rasc_rows(other, e1.eye_inputs(other))
    assert how2.startswith("recomputed")
    assert rows2 == rows            # same protocol otherwise: same numbers either way


# ----------------------------------------------------------------- determinism

def test_same_seed_same_bytes_any_worker_count(runs):
    # B: a second run with --workers 2; C: E3 alone, recomputing E1's samples
    for other, names in (("B", ("e1", "e2", "e3")), ("C", ("e3",))):
        a = result_files(runs["A"]["ctx"].out, names)
        assert any(k.endswith(".csv") for k in a) and any(k.endswith(".png") for k in a)
        b = result_files(runs[other]["ctx"].out, names)
        assert a.keys() == b.keys()
        differ = [k for k in a if a[k] != b[k]]
        assert not differ, (other, differ)
    assert not (runs["C"]["ctx"].out / "e1").exists()     # C really had no E1 output
