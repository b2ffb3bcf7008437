"""``rasc study``: spec checking, the sample computation against synthetic truth, and one
tiny rendered study run on every executor (this process, a process pool, a 2-worker dask
LocalCluster) with byte-equal outputs, interrupted and resumed.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

from rasc.cli import main as cli  # noqa: E402
from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu  # noqa: E402
from rasc.geometry.transforms import invert_transform, make_transform, matrix_from_rotvec  # noqa: E402
from rasc.study import load_spec, run_study  # noqa: E402
from rasc.study.engine import cell_task  # noqa: E402
from rasc.study.executors import Executor  # noqa: E402
from rasc.study.spec import pose_grid  # noqa: E402


@pytest.fixture(scope="module", autouse=True)
def no_dataset_cache():
    """Without the dataset cache (RASC_CACHE_DIR=none): every study here renders what it
    needs, in the executor under test (the cache: tests/study/test_study_pose_sets.py)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RASC_CACHE_DIR", "none")
        yield

TINY = """\
name = "tiny"
seed = 3
samples = 4
methods = ["rasc", "li", "opencv-park"]

[fixed]
intrinsics_views = 6
noise_model = "literal"

[axes]
noise_level = [0, 2, 6]
eye = ["left", "right"]
"""


def write(tmp_path: Path, text: str, name: str = "spec.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# ------------------------------------------------------------------ bad input

BAD = [
    ("samples = 3\nmethods = ['rasc']\n", "seed: missing"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\ncolour = 1\n", "colour: unknown key"),
    ("seed = 0\nsamples = 3\nmethods = []\n", "methods: empty list"),
    ("seed = 0\nsamples = 3\nmethods = ['nosuch']\n", "methods[0]: "),   # names 'nosuch'
    ("seed = 0\nsamples = 3\nmethods = ['rasc', 'rasc']\n", "methods[1]: 'rasc' given twice"),
    ("seed = 0\nsamples = 'x'\nmethods = ['rasc']\n", "samples: expected an integer"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\n[axes]\nnoise_level = []\n",
     "axes.noise_level: empty list"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\n[axes]\nnoise_levle = [1]\n",
     "axes.noise_levle: unknown parameter"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\n[axes]\nsigma_r = [0.1, -1]\n",
     "axes.sigma_r[1]: expected a number >= 0"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\n[fixed]\neye = 'middle'\n",
     "fixed.eye: expected one of left, right"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\n[fixed]\npositions = 8\n",
     "fixed.positions: layout 'grid' needs a square number"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\n[fixed]\nnoise_level = 2\nsigma_r = 0.1\n",
     "fixed.sigma_r: noise_level already sets"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\n[fixed]\nmodel = 'none.xml'\n",
     "fixed.model: "),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\n[fixed]\ndistance = true\n",
     "fixed.distance: expected a number"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc'\n", "not valid TOML"),
    ("seed = 0\nsamples = 3\nmethods = ['rasc']\naxes = 3\n", "axes: expected a table"),
]


def assert_refused(tmp_path: Path, capsys, text: str, message: str) -> str:
    """``rasc study`` on a spec of ``text``: status 2, one line on stderr naming the spec
    file and holding ``message``, and no output folder. Returns the line."""
    spec = write(tmp_path, text)
    out = tmp_path / "out"
    assert cli(["study", str(spec), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"rasc study: error: {spec}: "), err
    assert message in err, err
    assert not out.exists()          # nothing written
    return err


@pytest.mark.parametrize(("text", "message"), BAD)
def test_bad_spec_is_one_line_naming_file_and_key(tmp_path, capsys, text, message):
    err = assert_refused(tmp_path, capsys, text, message)
    if "nosuch" in text:
        assert "'nosuch'" in err and "unknown" in err, err


def test_a_dataset_that_cannot_be_rendered_is_one_line_and_leaves_nothing(tmp_path, capsys):
    spec = write(tmp_path, "seed = 0\nsamples = 2\nmethods = ['rasc']\n[fixed]\n"
                 "intrinsics_views = 4\n[axes]\ndistance = [0.3]\n")
    out = tmp_path / "out"
    assert cli(["study", str(spec), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "distance = 0.3" in err, err
    assert not out.exists()


def test_out_holding_another_study_or_files_is_refused(tmp_path, capsys):
    spec = write(tmp_path, TINY)
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "x.txt").write_text("keep me")
    assert cli(["study", str(spec), "--out", str(busy), "--quiet"]) == 2
    assert "not empty" in capsys.readouterr().err
    assert (busy / "x.txt").read_text() == "keep me"
    assert cli(["study", str(spec), "--out", str(tmp_path / "new"), "--resume",
                "--quiet"]) == 2
    assert "no study to resume" in capsys.readouterr().err


def test_library_messages_name_the_parameter_and_the_command_its_flag(tmp_path, capsys):
    """The same refusals from Python name run_study's parameters (out, resume=True,
    workers), never a flag; ``rasc study`` names its flags (--out, --resume, --workers)."""
    from rasc.errors import InputError
    from rasc.study.executors import make_executor
    spec_path = write(tmp_path, TINY)
    spec = load_spec(spec_path)
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "x.txt").write_text("keep me")
    cases = [(busy, {}, "out: exists and is not empty", "--out: exists and is not empty"),
             (tmp_path / "new", {"resume": True}, "resume=True: no study to resume",
              "--resume: no study to resume"),
             (tmp_path / "w", {"workers": 0}, "workers: expected an integer >= 1",
              "--workers: expected an integer >= 1")]
    for out, kwargs, python_words, cli_words in cases:
        with pytest.raises(InputError) as info:
            run_study(spec, out, quiet=True, **kwargs)
        assert python_words in str(info.value) and "--" not in str(info.value)
        argv = ["study", str(spec_path), "--out", str(out), "--quiet"]
        argv += ["--resume"] if kwargs.get("resume") else []
        argv += ["--workers", "0"] if "workers" in kwargs else []
        assert cli(argv) == 2
        err = capsys.readouterr().err
        assert cli_words in err and err.count("\n") == 1, err
    assert (busy / "x.txt").read_text() == "keep me"
    with pytest.raises(InputError, match="^dask: "):  # (not installed, or this)
        make_executor(2, dask="nonsense")


# ------------------------------------------------------------------ layouts

def test_grid_of_nine_is_the_papers_positions_in_order():
    assert pose_grid("grid", 9, 8.0) == PAPER_POSES_DEG


@pytest.mark.parametrize(("layout", "n"), [("grid", 16), ("cross", 9), ("ring", 7)])
def test_layouts_have_their_count_and_amplitude(layout, n):
    poses = np.array(pose_grid(layout, n, 5.0))
    assert poses.shape == (n, 2)
    assert len({tuple(p) for p in poses.round(9)}) == n      # all distinct
    assert np.isclose(np.abs(poses).max(), 5.0)
    if layout != "grid":                                      # home view first
        assert tuple(poses[0]) == (0.0, 0.0)


# --------------------------------------------------- the samples, on synthetic truth

def synthetic_dataset(seed: int = 0) -> dict:
    """Exact ``T_cam_from_world`` = T_cam_from_gaze · T_gaze_from_ptu · T_ptu_from_world
    for the paper's nine positions, with chosen (true) transforms; no corners needed."""
    rng = np.random.default_rng(seed)
    T_cg = make_transform(matrix_from_rotvec(rng.normal(0, 0.05, 3)) @
                          np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
                          np.array([0.03, -0.05, 0.02]))
    T_pw = invert_transform(make_transform(matrix_from_rotvec(rng.normal(0, 0.1, 3)),
                                           np.array([0.1, 1.0, 0.05])))
    pan_tilt = np.radians(np.array(PAPER_POSES_DEG))
    T_gp = T_gaze_from_ptu(pan_tilt[:, 0], pan_tilt[:, 1])
    T_cw = T_cg @ T_gp @ T_pw
    eye = {"files": [], "pan_tilt_rad": pan_tilt.tolist(), "T_cam_from_world": T_cw.tolist(),
           "corners": [], "K": np.eye(3).tolist(), "dist": [],
           "T_cam_from_gaze_true": T_cg.tolist()}
    return {"board": {"inner_corners": [9, 6], "square_size": 0.05},
            "eyes": {"left": eye, "right": eye}}


def cell_of(tmp_path, axes: str, index: int = 0):
    spec = load_spec(write(tmp_path, "seed = 5\nsamples = 6\nmethods = ['rasc', 'li', "
                           f"'opencv-park']\n[axes]\n{axes}\n"))
    return spec, spec.cells()[index]


def test_noise_free_samples_recover_the_truth(tmp_path):
    spec, cell = cell_of(tmp_path, "noise_level = [0]")
    rows = cell_task({"cell": cell, "dataset": synthetic_dataset(), "seed": 5, "samples": 2,
                      "methods": spec.methods})
    assert [r[1] for r in rows] == ["rasc", "li", "opencv-park"] * 2
    for _, _, status, t_mm, r_deg, r_fro, _ in rows:
        # exact poses: only floating-point error (1e-9 mm, 1e-9 deg are ~1e4 x eps scale)
        assert status == "ok" and t_mm < 1e-6 and r_deg < 1e-6 and r_fro < 1e-8


def test_noisy_samples_are_seeded_by_cell_and_sample_and_paired_across_methods(tmp_path):
    spec, cell = cell_of(tmp_path, "noise_level = [1, 4]\nnoise_model = ['exponential']", 1)
    task = {"cell": cell, "dataset": synthetic_dataset(), "seed": 5, "samples": 6,
            "methods": spec.methods}
    a, b = cell_task(task), cell_task(task)
    assert a == b                                             # same seed, same numbers
    fewer = cell_task({**task, "samples": 3})
    assert fewer == a[:9]                # sample s draws from (seed, cell, s) alone
    errs = np.array([r[3] for r in a if r[1] == "rasc"])
    # σ_t = 4 mm, σ_r = 0.02 rad at 1 m: errors of millimetres to centimetres, all distinct
    assert len(set(errs)) == 6 and 0.1 < errs.mean() < 1000
    # one noisy pose set per sample for all methods: RASC and OpenCV's Park solve the same
    # rotation problem the same way, so their rotation errors agree per sample
    park = np.array([r[4] for r in a if r[1] == "opencv-park"])
    rasc = np.array([r[4] for r in a if r[1] == "rasc"])
    np.testing.assert_allclose(park, rasc, rtol=1e-3)


# ------------------------------------------------------------- the rendered study

class InterruptAfter(Executor):
    """Runs tasks here; raises KeyboardInterrupt after ``n`` cell results."""

    def __init__(self, n: int) -> None:
        self.n = n

    def map_unordered(self, fn, tasks):
        for k, task in enumerate(tasks):
            if fn.__name__ == "cell_task" and k == self.n:
                raise KeyboardInterrupt
            yield k, fn(task)


def files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The tiny study run by the process pool (``--workers 2``); the serial path (one
    process) is compared with it byte for byte by the resume test below."""
    root = tmp_path_factory.mktemp("study")
    spec = write(root, TINY)
    assert cli(["study", str(spec), "--out", str(root / "pool"), "--workers", "2",
                "--quiet"]) == 0
    return spec, root / "pool"


@pytest.mark.slow                                   # the reference run: a pool, ~6 s
def test_study_writes_tidy_samples_summary_and_figures(reference):
    _, out = reference
    import csv
    with open(out / "samples.csv") as f:
        samples = list(csv.DictReader(f))
    assert len(samples) == 3 * 2 * 4 * 3               # cells x samples x methods
    assert {r["status"] for r in samples} == {"ok"}
    with open(out / "summary.csv") as f:
        summary = list(csv.DictReader(f))
    assert len(summary) == 6 * 3
    for r in summary:
        lo, mean, hi = (float(r[f"translation_mm_{k}"]) for k in ("ci_low", "mean", "ci_high"))
        assert lo <= mean <= hi
    by = {(r["noise_level"], r["eye"], r["method"]): float(r["translation_mm_mean"])
          for r in summary}
    for eye in ("left", "right"):
        for m in ("rasc", "li", "opencv-park"):
            # the pipeline's own floor is sub-millimetre; set 6 (6 mm, 0.03 rad) is not
            assert by[("0", eye, m)] < 1.0 and by[("6", eye, m)] > 5 * by[("0", eye, m)]
    names = set(files(out))
    for axis in ("noise_level", "eye"):
        assert {f"figures/{axis}.png", f"figures/{axis}.svg"} <= names
    assert not [n for n in names if n.endswith(".tmp")]


@pytest.mark.slow
def test_process_pool_and_dask_localcluster_give_the_same_bytes(reference, tmp_path):
    spec, pool = reference                      # the process pool's run, 2 workers
    assert cli(["study", str(spec), "--out", str(tmp_path / "dask"), "--workers", "2",
                "--dask", "local", "--quiet"]) == 0
    assert files(tmp_path / "dask") == files(pool)


@pytest.mark.slow
def test_interrupted_study_keeps_finished_cells_and_resumes_to_the_same_bytes(
        reference, tmp_path, capsys):
    spec_path, pool = reference
    spec = load_spec(spec_path)
    out = tmp_path / "run"
    from rasc.interrupt import Interrupted
    with pytest.raises(Interrupted) as info:      # one note, carried by the interrupt
        run_study(spec, out, quiet=True, executor=InterruptAfter(2))
    # from Python the note names the parameter, never a flag of the command line
    assert "kept 2 of 6 finished cells" in info.value.note
    assert "resume=True" in info.value.note and "--" not in info.value.note
    assert capsys.readouterr().err == ""          # nothing else said
    kept = files(out)
    assert sorted(n for n in kept if n.startswith("cells/")) == [
        "cells/cell-00000.csv", "cells/cell-00001.csv"]
    assert not {"samples.csv", "summary.csv"} & set(kept)
    assert not [n for n in kept if n.endswith(".tmp")]
    # without --resume the folder is refused; with it, the study completes identically
    assert cli(["study", str(spec_path), "--out", str(out), "--quiet"]) == 2
    assert "--resume" in capsys.readouterr().err
    assert cli(["study", str(spec_path), "--out", str(out), "--resume", "--quiet"]) == 0
    assert files(out) == files(pool)             # serial (resumed) = pool
    # a different spec does not resume into it
    other = write(tmp_path, TINY.replace("samples = 4", "samples = 5"), "other.toml")
    assert cli(["study", str(other), "--out", str(out), "--resume", "--quiet"]) == 2
    assert "different spec" in capsys.readouterr().err


# --------------------------------------------------------------- shipped specs
# (the guide's study examples run in docs/guide/studies.md, by tests/docs)

REPO = Path(__file__).resolve().parents[2]


def test_shipped_specs_of_the_papers_experiments_load():
    specs = sorted((REPO / "experiments" / "specs").glob("*.toml"))
    assert [p.stem for p in specs] == ["e1_all_methods", "e1_noise", "e2_home_view",
                                       "e3_quality", "e6a_pixel_noise", "e6b_shootout"]
    cells = {p.stem: load_spec(p).cells() for p in specs}
    assert {p.stem: len(load_spec(p, quick=True).cells()) for p in specs} == {
        "e1_all_methods": 4 * 2, "e1_noise": 4 * 2 * 2, "e2_home_view": 2 * 2,
        "e3_quality": 6 * 2 * 2, "e6a_pixel_noise": 4 * 2, "e6b_shootout": 2 * 2 * 2}
    assert len(cells["e1_noise"]) == 9 * 2 * 2
    # E1's every-method cells draw what E1's exponential cells draw (paired noise_model)
    e1 = {(c.params["noise_level"], c.params["eye"]): c.seed_words
          for c in cells["e1_noise"] if c.params["noise_model"] == "exponential"}
    assert all(e1[(c.params["noise_level"], c.params["eye"])] == c.seed_words
               for c in cells["e1_all_methods"])
    # E3's paper sets are E1's cells
    assert {c.key for c in cells["e1_noise"]} <= {c.key for c in cells["e3_quality"]}
    # E1's set k is the paper's (0.005k rad, k mm)
    k8 = [c for c in cells["e1_noise"] if c.params["noise_level"] == 8][0]
    assert (k8.params["sigma_r"], k8.params["sigma_t_mm"]) == (0.04, 8.0)
