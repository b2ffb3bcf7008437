"""``rasc study``'s keys for E6: ``intrinsics_from = "dataset"`` (pose sets rendered in a
base dataset's scene and measured with its intrinsics), the gross-failure thresholds
``gross_rotation_deg`` / ``gross_translation_mm``, and the pose-error columns
(``run_study(..., pose_errors=True)``), each on synthetic truth or checked input.
"""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from test_study import assert_refused, synthetic_dataset, write

from rasc.cli import main as cli
from rasc.errors import InputError, SolverFailure
from rasc.geometry.kinematics import PAPER_POSES_DEG
from rasc.geometry.transforms import make_transform, matrix_from_rotvec
from rasc.handeye.methods import METHODS
from rasc.study import load_spec, run_study
from rasc.study.engine import (
    POSE_ERROR_COLUMNS,
    SAMPLE_COLUMNS,
    cell_task,
    classify_gross,
    pose_error_rms,
    same_poses,
)

HEAD = "seed = 5\nsamples = 4\nmethods = ['rasc', 'li']\n"
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def own_cache(tmp_path, monkeypatch):
    """Each test its own dataset cache (RASC_CACHE_DIR), so that what it counts as
    rendered does not depend on earlier runs."""
    monkeypatch.setenv("RASC_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache" / "study-datasets"

# ------------------------------------------------------------------ bad input

BAD = [
    ("[fixed]\nintrinsics_from = 'views'\n",
     "fixed.intrinsics_from: expected one of calibrate, dataset"),
    ("[axes]\nintrinsics_from = ['dataset', 'x']\n",
     "axes.intrinsics_from[1]: expected one of calibrate, dataset"),
    ("gross_rotation_deg = 0\n", "gross_rotation_deg: expected a number > 0"),
    ("gross_translation_mm = 'big'\n", "gross_translation_mm: expected a number"),
    ("gross_translation_mm = nan\n", "gross_translation_mm: must be finite, got NaN"),
]


@pytest.mark.parametrize(("text", "message"), BAD)
def test_bad_keys_are_one_line_naming_file_and_key(tmp_path, capsys, text, message):
    assert_refused(tmp_path, capsys, HEAD + text, message)


BESIDE_A_DATASET = [
    ("[fixed]\nmotion_deg = 4.0\n", "fixed.motion_deg: a render parameter, but",
     "give intrinsics_from = 'dataset'"),
    ("[fixed]\nintrinsics_from = 'dataset'\nimage_noise = 2.0\n",
     "fixed.image_noise: a render parameter", "only motion_deg, layout and positions"),
    ("[fixed]\nintrinsics_from = 'calibrate'\n", "fixed.intrinsics_from: ",
     "'calibrate' would calibrate it again"),
    ("[axes]\nintrinsics_from = ['dataset']\n", "axes.intrinsics_from: ",
     "give intrinsics_from = 'dataset' in [fixed]"),
]


@pytest.mark.parametrize(("text", "key", "why"), BESIDE_A_DATASET)
def test_render_parameters_beside_a_given_dataset(tmp_path, text, key, why):
    """From Python (run_study(dataset=...)): one line naming the spec and key, and no
    folder; the [fixed] dataset folder is checked by the same function (test below)."""
    spec = load_spec(write(tmp_path, HEAD + text))
    with pytest.raises(InputError) as err:
        run_study(spec, tmp_path / "o", quiet=True, dataset=synthetic_dataset())
    msg = str(err.value)
    assert msg.startswith(f"{spec.path}: {key}") and why in msg and "\n" not in msg, msg
    assert not (tmp_path / "o").exists()


def test_pose_sets_of_a_dataset_without_a_scene_are_refused_and_nothing_is_kept(tmp_path):
    """A dataset that records no scene (here synthetic, as a real head's) cannot be
    rendered again; its own pose set needs no render and runs."""
    data = synthetic_dataset()
    spec = load_spec(write(tmp_path, HEAD + "[fixed]\nintrinsics_from = 'dataset'\n"
                           "[axes]\nmotion_deg = [8.0, 2.0]\n"))
    with pytest.raises(InputError, match="records none") as err:
        run_study(spec, tmp_path / "o", quiet=True, dataset=data)
    assert str(err.value).startswith(f"{spec.path}: ") and "\n" not in str(err.value)
    assert not (tmp_path / "o").exists()
    own = load_spec(write(tmp_path, HEAD + "[fixed]\nintrinsics_from = 'dataset'\n"
                          "motion_deg = 8.0\n", "own.toml"))
    res = run_study(own, tmp_path / "o2", quiet=True, dataset=data, figures=False)
    assert res.datasets_rendered == 0
    assert len(list((tmp_path / "o2" / "datasets").glob("*.json"))) == 1


def test_same_poses():
    data = synthetic_dataset()
    assert same_poses(data, PAPER_POSES_DEG)
    assert not same_poses(data, [(p / 2, t / 2) for p, t in PAPER_POSES_DEG])
    assert not same_poses(data, PAPER_POSES_DEG[::-1])       # the order is the set's
    assert not same_poses(data, PAPER_POSES_DEG[:8])


# ------------------------------------------------------------------ gross failures

def test_classify_gross_at_its_thresholds():
    ok = ("ok", 99.0, 9.9, 0.1, 0.0, np.eye(4))
    assert classify_gross(ok, (10.0, 100.0)) is ok
    assert classify_gross(ok, (None, None)) is ok
    assert classify_gross(("ok", 101.0, *ok[2:]), (10.0, 100.0))[0] == "gross"
    assert classify_gross(("ok", 1.0, 10.1, *ok[3:]), (10.0, 100.0))[0] == "gross"
    assert classify_gross(("ok", 101.0, *ok[2:]), (10.0, None))[0] == "ok"
    failed = ("failed: SolverFailure", *([float("nan")] * 4), None)
    assert classify_gross(failed, (10.0, 100.0)) is failed


def _raises(T_cw, T_gp, **kw):
    raise SolverFailure("fake solver gave up")


def _nan(T_cw, T_gp, **kw):
    return SimpleNamespace(T_cam_from_gaze=np.full((4, 4), np.nan), quality=np.nan)


def _identity(T_cw, T_gp, **kw):
    return SimpleNamespace(T_cam_from_gaze=np.eye(4), quality=0.0)


def test_failures_are_classified_by_kind_and_left_out_of_the_summary(tmp_path, monkeypatch):
    """Fake methods on the synthetic truth: one raises, one returns NaN, one returns the
    identity (the synthetic T_cam_from_gaze is ~90° and 6 cm from it: gross). RASC on
    exact poses is recovered to round-off, never gross."""
    for name, fn in (("fake-raises", _raises), ("fake-nan", _nan),
                     ("fake-identity", _identity)):
        monkeypatch.setitem(METHODS, name, fn)
    spec = load_spec(write(tmp_path, "seed = 5\nsamples = 3\nmethods = ['rasc', "
                           "'fake-raises', 'fake-nan', 'fake-identity']\n"
                           "gross_rotation_deg = 10.0\ngross_translation_mm = 100.0\n"
                           "[axes]\nsigma_r = [0.0, 0.001]\n"))
    assert spec.to_dict()["gross_rotation_deg"] == 10.0
    res = run_study(spec, tmp_path / "o", quiet=True, dataset=synthetic_dataset(),
                    figures=False)
    with open(res.samples_csv) as f:
        rows = list(csv.DictReader(f))
    status = {m: {r["status"] for r in rows if r["method"] == m} for m in spec.methods}
    assert status == {"rasc": {"ok"}, "fake-raises": {"failed: SolverFailure"},
                      "fake-nan": {"non-finite"}, "fake-identity": {"gross"}}
    gross = [r for r in rows if r["status"] == "gross"]
    assert all(float(r["rotation_deg"]) > 10.0 for r in gross)   # its numbers are kept
    with open(res.summary_csv) as f:
        summary = {(r["sigma_r"], r["method"]): r for r in csv.DictReader(f)}
    for s in ("0.0", "0.001"):
        assert summary[(s, "rasc")]["n"] == "3" and summary[(s, "rasc")]["n_failed"] == "0"
        for m in ("fake-raises", "fake-nan", "fake-identity"):
            assert summary[(s, m)]["n"] == "0" and summary[(s, m)]["n_failed"] == "3"
            assert summary[(s, m)]["rotation_deg_mean"] == ""
    # without the keys nothing is gross, and the spec's hash is that of older specs
    plain = load_spec(write(tmp_path, "seed = 5\nsamples = 1\nmethods = ['fake-identity']\n",
                            "plain.toml"))
    assert "gross_rotation_deg" not in plain.to_dict()
    rows = cell_task({"cell": plain.cells()[0], "dataset": synthetic_dataset(), "seed": 5,
                      "samples": 1, "methods": plain.methods})
    assert rows[0][2] == "ok"


# ------------------------------------------------------------------ pose errors

def test_pose_error_rms_of_known_perturbations():
    """Each view turned by a known angle about one camera axis and shifted along one:
    the RMS over views is exact (1e-12), on the right axis, zero on the others."""
    rng = np.random.default_rng(3)
    T_true = np.array([make_transform(matrix_from_rotvec(rng.normal(0, 0.3, 3)),
                                      rng.normal(0, 0.5, 3)) for _ in range(4)])
    angles = np.array([0.001, -0.002, 0.003, 0.0])           # rad, about camera y
    shifts = np.array([0.5, -0.5, 1.5, -1.5])                 # mm, along camera z
    T = T_true.copy()
    for k in range(4):      # R = R_d R_true, t = t_true + d (camera-frame errors)
        T[k, :3, :3] = matrix_from_rotvec([0.0, angles[k], 0.0]) @ T_true[k, :3, :3]
        T[k, 2, 3] += shifts[k] / 1000.0
    rms = pose_error_rms(T, T_true)
    np.testing.assert_allclose(rms, [0.0, np.sqrt(np.mean(angles**2)), 0.0,
                                     0.0, 0.0, np.sqrt(np.mean(shifts**2))], atol=1e-12)


def test_pose_error_columns_zero_without_noise_and_the_noise_with_it(tmp_path):
    """Exact synthetic poses with their truth: no noise → the columns are 0 (1e-12);
    eq. 13-14 translation noise of 2 mm per axis → each axis's RMS over 9 views and
    40 samples pooled is 2 mm within 10 % (its standard error is ~2.6 %)."""
    data = synthetic_dataset()
    for eye in data["eyes"].values():
        eye["T_cam_from_world_true"] = eye["T_cam_from_world"]
    spec = load_spec(write(tmp_path, "seed = 5\nsamples = 40\nmethods = ['rasc']\n"
                           "[axes]\nsigma_t_mm = [0.0, 2.0]\n"))
    res = run_study(spec, tmp_path / "o", quiet=True, dataset=data, figures=False,
                    pose_errors=True)
    with open(res.samples_csv) as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0])[-len(POSE_ERROR_COLUMNS):] == POSE_ERROR_COLUMNS
    assert len(rows[0]) == 1 + 1 + len(SAMPLE_COLUMNS) + len(POSE_ERROR_COLUMNS)
    for r in (r for r in rows if r["sigma_t_mm"] == "0.0"):
        assert max(abs(float(r[c])) for c in POSE_ERROR_COLUMNS) < 1e-12
    noisy = [r for r in rows if r["sigma_t_mm"] == "2.0"]
    for a in "xyz":
        rms = np.sqrt(np.mean([float(r[f"pose_t_{a}_mm"]) ** 2 for r in noisy]))
        assert rms == pytest.approx(2.0, rel=0.10)
        assert max(float(r[f"pose_rot_{a}_rad"]) for r in noisy) < 1e-12
    # a dataset without the truth per view: empty columns, never a number
    res = run_study(spec, tmp_path / "o2", quiet=True, dataset=synthetic_dataset(),
                    figures=False, pose_errors=True)
    with open(res.samples_csv) as f:
        assert all(r[c] == "" for r in csv.DictReader(f) for c in POSE_ERROR_COLUMNS)


# ------------------------------------------------ pose sets rendered (MuJoCo)

@pytest.fixture(scope="module")
def default_doc(default_dataset, default_calibration):
    """The default dataset calibrated by the pipeline (conftest's ``default_calibration``,
    ``calibrate_dataset`` with the default options), as the engine takes it."""
    from rasc.study.engine import dataset_document
    from rasc.vision.dataset import load_dataset

    ds = load_dataset(default_dataset)
    truth = json.loads((default_dataset / "ground_truth.json").read_text())
    return dataset_document(default_calibration, ds.board, truth)


@pytest.mark.slow
def test_pose_sets_rendered_with_a_given_datasets_intrinsics(default_doc, tmp_path,
                                                             monkeypatch):
    """±8° is the dataset's own pose set (not rendered, the same document); ±2° is
    rendered in its scene and measured with its intrinsics: its noise-free extrinsics
    are within 5e-4 rad and 0.2 mm per axis of the rendered truth (measured on the ±8°
    views: 6e-5 rad and 0.04 mm; a wrong board pose or angle would be off by degrees and
    centimetres), and RASC recovers T_cam_from_gaze to the ±8° floor's order (< 2 mm)."""
    spec = load_spec(write(tmp_path, "seed = 0\nsamples = 2\nmethods = ['rasc']\n"
                           "[fixed]\nintrinsics_from = 'dataset'\n"
                           "[axes]\nmotion_deg = [8.0, 2.0]\neye = ['left', 'right']\n"))
    res = run_study(spec, tmp_path / "o", quiet=True, dataset=default_doc, figures=False,
                    pose_errors=True)
    assert res.datasets_rendered == 1
    docs = [json.loads(p.read_text()) for p in sorted((tmp_path / "o" / "datasets").glob("*"))]
    assert len(docs) == 2
    rendered = next(d for d in docs if "intrinsics_of" in d)
    base = next(d for d in docs if "intrinsics_of" not in d)
    assert base == json.loads(json.dumps(default_doc))
    for eye in ("left", "right"):
        assert rendered["eyes"][eye]["K"] == default_doc["eyes"][eye]["K"]
        assert rendered["eyes"][eye]["dist"] == default_doc["eyes"][eye]["dist"]
        np.testing.assert_allclose(np.degrees(rendered["eyes"][eye]["pan_tilt_rad"]),
                                   np.array(PAPER_POSES_DEG) / 4, atol=1e-12)
    with open(res.samples_csv) as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        assert max(float(r[f"pose_rot_{a}_rad"]) for a in "xyz") < 5e-4
        assert max(float(r[f"pose_t_{a}_mm"]) for a in "xyz") < 0.2
        assert r["status"] == "ok" and float(r["translation_mm"]) < 2.0
    # the same study again on 2 workers, rendering again (no cache): the same bytes
    monkeypatch.setenv("RASC_CACHE_DIR", "none")
    again = run_study(spec, tmp_path / "o2", workers=2, quiet=True, dataset=default_doc,
                      figures=False, pose_errors=True)
    for name in ("samples.csv", "summary.csv"):
        assert (tmp_path / "o" / name).read_bytes() == (tmp_path / "o2" / name).read_bytes()
    assert again.datasets_rendered == 1


@pytest.mark.slow
def test_pose_sets_of_a_fixed_dataset_folder_and_a_foreign_scene(default_dataset, tmp_path,
                                                                  capsys):
    """The [fixed] dataset folder as base (CLI); a dataset whose recorded scene is not the
    package model's (its board moved by 1 cm) is refused in one line, nothing written."""
    shutil.copytree(default_dataset, tmp_path / "ds")
    spec = write(tmp_path, "seed = 0\nsamples = 1\nmethods = ['rasc']\n[fixed]\n"
                 "dataset = 'ds'\nintrinsics_from = 'dataset'\nmotion_deg = 4.0\n")
    assert cli(["study", str(spec), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    with open(tmp_path / "o" / "summary.csv") as f:
        (row,) = list(csv.DictReader(f))
    assert row["n"] == "1" and float(row["translation_mm_mean"]) < 2.0
    gt_path = tmp_path / "ds" / "ground_truth.json"
    gt = json.loads(gt_path.read_text())
    for view in gt["views"].values():
        view["T_base_from_world"][0][3] += 0.01
    gt_path.write_text(json.dumps(gt))
    assert cli(["study", str(spec), "--out", str(tmp_path / "o3"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "T_base_from_world differs" in err and err.count("\n") == 1, err
    assert not (tmp_path / "o3").exists()


@pytest.mark.slow
def test_pose_sets_in_the_scene_the_study_renders(tmp_path):
    """No dataset given: the base is rendered at the default pose set (here with 6
    intrinsics views) and the ±4° cell's pose views only, with the base's intrinsics."""
    spec = load_spec(write(tmp_path, "seed = 1\nsamples = 1\nmethods = ['rasc']\n"
                           "[fixed]\nintrinsics_from = 'dataset'\nintrinsics_views = 6\n"
                           "[axes]\nmotion_deg = [8.0, 4.0]\n"))
    res = run_study(spec, tmp_path / "o", quiet=True, figures=False, pose_errors=True)
    assert res.datasets_rendered == 2
    docs = [json.loads(p.read_text()) for p in (tmp_path / "o" / "datasets").glob("*")]
    base = next(d for d in docs if "intrinsics_of" not in d)
    pose = next(d for d in docs if "intrinsics_of" in d)
    assert pose["intrinsics_of"] == base["key"]
    assert base["render"]["intrinsics_views"] == 6 and base["render"]["motion_deg"] == 8.0
    for eye in ("left", "right"):
        assert pose["eyes"][eye]["K"] == base["eyes"][eye]["K"]
    with open(res.samples_csv) as f:
        rows = list(csv.DictReader(f))
    assert [r["status"] for r in rows] == ["ok", "ok"]
    assert max(float(r["pose_t_z_mm"]) for r in rows) < 1.0   # 6 views: coarser K



# ------------------------------------------------------------------ the cache

TINY_RENDER = """\
seed = 2
samples = 2
methods = ['rasc']
[fixed]
intrinsics_views = 4
intrinsics_from = 'dataset'
corner_noise_px = 0.3
[axes]
motion_deg = [8.0, 3.0]
"""


@pytest.mark.slow
def test_a_study_run_twice_renders_once(tmp_path, own_cache, monkeypatch, capsys):
    """The second run copies both datasets (the base and the ±3° pose set) from the
    cache and writes the same bytes; a damaged cache file is rendered again;
    RASC_CACHE_DIR=none neither reads nor writes the cache."""
    spec = load_spec(write(tmp_path, TINY_RENDER))
    first = run_study(spec, tmp_path / "a", figures=False)
    assert (first.datasets_rendered, first.datasets_cached) == (2, 0)
    assert len(list(own_cache.glob("*.entry"))) == 2
    capsys.readouterr()
    second = run_study(spec, tmp_path / "b", figures=False)
    assert (second.datasets_rendered, second.datasets_cached) == (0, 2)
    assert "2 dataset(s) copied from the cache" in capsys.readouterr().err

    def tree(folder):
        return {p.relative_to(folder).as_posix(): p.read_bytes()
                for p in sorted(folder.rglob("*")) if p.is_file()}
    a, b = tree(tmp_path / "a"), tree(tmp_path / "b")
    assert a == b and any(n.startswith("datasets/") for n in a)
    # a damaged entry is rendered again (and stored whole)
    damaged = sorted(own_cache.glob("*.entry"))[0]
    damaged.write_bytes(damaged.read_bytes()[:100])
    third = run_study(spec, tmp_path / "c", quiet=True, figures=False)
    assert (third.datasets_rendered, third.datasets_cached) == (1, 1)
    assert tree(tmp_path / "c") == a
    from rasc.datasets.cache import unpack
    json.loads(unpack(damaged.read_bytes()))        # replaced by a whole entry
    # no cache at all
    monkeypatch.setenv("RASC_CACHE_DIR", "none")
    shutil.rmtree(own_cache)
    fourth = run_study(spec, tmp_path / "d", quiet=True, figures=False)
    assert (fourth.datasets_rendered, fourth.datasets_cached) == (2, 0)
    assert not own_cache.exists() and tree(tmp_path / "d") == a
