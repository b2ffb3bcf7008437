"""``python -m experiments.reproduce --quick`` end to end: the report, sane numbers,
determinism, interrupts.

One pooled run (``--quick --seed 0 --workers 2``, in this process: the pool of forkserver
workers) must write byte-identical result files (CSV and JSON) for every experiment to
the serial ones (``--workers 1``, one context, the same experiments' ``run(ctx)`` as the
serial path calls it: conftest's ``quick_experiments``, which the experiment modules'
tests check too), and render the default dataset byte for byte as ``rasc render`` does
(conftest's ``default_dataset``); its report must hold every section with its figures,
and the headline numbers must be sane. A second, serial ``python -m`` process is sent
SIGTERM when its third experiment (E3) starts: E1 and E2 are kept, E3's staging folder
removed, no report. (Before, that process ran E1–E6b and E7 ran alone after it, to be
the serial side of the byte comparison: the same experiments as the modules' runs.)
"""

import csv
import importlib
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from shared_fixtures import locked, shared_root

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"
sys.path.insert(0, str(EXPERIMENTS.parent))  # the experiments package

from experiments import reproduce  # noqa: E402

pytestmark = pytest.mark.slow  # renders and whole experiment runs

#: the experiment the serial run is interrupted in (the third: the two before it finish)
INTERRUPTED = reproduce.EXPERIMENTS[2][0]
#: every experiment's folder name (``module.NAME``), in report order
KEYS = [importlib.import_module(f"experiments.{name}").NAME for name, _ in reproduce.EXPERIMENTS]


@pytest.fixture(scope="module")
def pooled(tmp_path_factory) -> Path:
    """``reproduce --quick --seed 0 --workers 2`` (the pool) in this process; once per test
    run (xdist workers share it under a file lock, as conftest's dataset). Read-only."""
    shared = shared_root(tmp_path_factory)
    folder = shared / "reproduce_w2"
    with locked(shared / "reproduce_w2.lock"):
        if not (folder / "REPORT.md").is_file():      # written last: the run is complete
            shutil.rmtree(folder, ignore_errors=True)
            assert reproduce.main(["--quick", "--seed", "0", "--out", str(folder),
                                   "--workers", "2"]) == 0
    return folder


@pytest.fixture(scope="module")
def serial(pooled, tmp_path_factory) -> dict:
    """``python -m experiments.reproduce --quick --workers 1`` (seed 0), SIGTERM as soon as
    it announces :data:`INTERRUPTED`. Returns the folder, the exit status, stderr after the
    signal and the folder's names after the signal. After :func:`pooled` (whose default
    dataset and calibration the cache then holds, as on a second run); once per test run,
    as :func:`pooled`. Read-only."""
    shared = shared_root(tmp_path_factory)
    out, record = shared / "reproduce_w1", shared / "reproduce_w1.json"
    with locked(shared / "reproduce_w1.lock"):
        if not record.is_file():                      # written last: the run is complete
            shutil.rmtree(out, ignore_errors=True)
            out.mkdir()
            (out / "REPORT.md").write_text("an earlier run's report")
            title = dict(reproduce.EXPERIMENTS)[INTERRUPTED]
            proc = subprocess.Popen([sys.executable, "-m", "experiments.reproduce", "--quick",
                                     "--seed", "0", "--workers", "1", "--out", str(out)],
                                    cwd=EXPERIMENTS.parent, stderr=subprocess.PIPE, text=True,
                                    env={**os.environ, "MUJOCO_GL": "egl"})
            for line in proc.stderr:
                if line.startswith(f"== {title}"):   # every earlier one has been renamed
                    proc.send_signal(signal.SIGTERM)
                    break
            rest = proc.stderr.read()
            status = proc.wait(timeout=120)
            names = sorted(p.name for p in out.iterdir())
            record.write_text(json.dumps({"status": status, "stderr": rest,
                                          "names_after_sigterm": names}))
    info = json.loads(record.read_text())
    return {**info, "out": out, "names_after_sigterm": set(info["names_after_sigterm"])}


def _results(folder: Path) -> dict[str, bytes]:
    """Raw results (every CSV and JSON) and the rendered dataset's images, by path."""
    files = [p for p in sorted(folder.rglob("*")) if p.is_file()]
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in files
            if p.suffix in (".csv", ".json") or p.suffix == ".png" and "data" in p.parts}


def test_same_seed_same_bytes_for_any_worker_count(pooled, quick_experiments):
    """The pool (``--workers 2``) against the serial path (one context, ``--workers 1``)
    for every experiment; the pool's rendering of the default dataset against ``rasc
    render``'s (the serial side's dataset: conftest's, with the render record the
    reproduction writes beside it)."""
    for name, _ in reproduce.EXPERIMENTS:
        ctx, _ = quick_experiments(name)
    a, b = _results(ctx.out), _results(pooled)
    assert len(a) > 40  # every experiment's raw files plus the dataset's images
    assert {name.split("/")[0] for name in a} == {"data", *KEYS}
    assert sum(name.endswith(".png") for name in a) == 2 * (20 + 9)   # the dataset's
    assert sorted(a) == sorted(b)
    differ = [name for name in a if a[name] != b[name]]
    assert differ == []


def test_report_has_every_section_and_its_figures(pooled):
    out = pooled
    report = (out / "REPORT.md").read_text()
    for _, title in reproduce.EXPERIMENTS:
        assert f". {title}\n" in report, title
    assert "## Software" in report and "## Wall time" in report
    assert "quick (reduced protocol" in report
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", report)
    assert len(links) >= 9  # rig, Figs. 3 and 4, E2, E3, E4, E5, E6a, E6b
    for link in links:
        assert (out / link).is_file(), link
    # the paper's values stand beside ours
    for paper_value in ("18.3", "53.7", "2–3", "order of magnitude"):
        assert paper_value in report


def test_headline_numbers_are_sane(pooled):
    out = pooled
    with open(out / "e1" / "noise_summary.csv") as f:
        rows = [r for r in csv.DictReader(f)
                if r["method"] == "rasc" and r["variant"] == "literal"]
    for eye in ("left", "right"):
        by_level = {int(r["level"]): float(r["t_err_mean_mm"]) for r in rows if r["eye"] == eye}
        levels = sorted(k for k in by_level if k > 0)
        # more noise, more error: the highest level's mean is well above the lowest's
        assert by_level[levels[-1]] > 2 * by_level[levels[0]] > 0
    e2 = json.loads((out / "e2" / "summary.json").read_text())
    for eye in ("left", "right"):
        s = e2[f"{eye}_literal"]
        assert s["li_t_mean_mm"] > s["rasc_t_mean_mm"] and s["ratio_t"] > 2
    e4 = json.loads((out / "e4" / "summary.json").read_text())
    with open(out / "e4" / "points.csv") as f:
        n_rows = sum(1 for _ in csv.DictReader(f))
    # every corner of the 22×21-corner board, in both images, at both poses of each plane
    # (the full protocol: 3 planes, 2772 points as the paper's Table 1); one row per point
    # and model (four models)
    assert e4["n_points"] == 2 * 22 * 21 * e4["n_planes"] and e4["n_planes"] >= 1
    assert n_rows == 4 * e4["n_points"]
    assert f"**{e4['n_points']} points**" in (out / "REPORT.md").read_text()
    measured = e4["models"]["cal_measured_mounts"]["ls"]
    for stat in ("mean", "std"):
        assert all(math.isfinite(v) for v in measured[stat])
    # with mounts measured to 0.5° / 2.5 mm the depth error stays within a few paper stds
    # (the first-order bias at 1.86 m is ≤ 202 mm/deg × 0.5° + 6.2 × 2.5 mm ≈ 117 mm)
    assert abs(measured["mean"][2]) < 150 and measured["std"][2] < 60
    # the true and loop-closure models meet the tenth-of-the-paper goal
    for model in ("true", "cal_loop_closure"):
        std = e4["models"][model]["ls"]["std"]
        assert std[0] <= 0.9 and std[1] <= 1.3 and std[2] <= 5.4, (model, std)


def test_dataset_is_reused_only_with_the_options_it_was_rendered_with(pooled, tmp_path,
                                                                    capsys):
    """A seed-1 run into a folder holding a seed-0 dataset renders afresh and says so."""
    from experiments._common import DATASET_OPTIONS, Context

    out = tmp_path / "run"
    shutil.copytree(pooled / "data" / "dataset", out / "data" / "dataset")
    doc = Context.from_argv(reproduce.__doc__, ["--quick", "--out", str(out)])
    assert doc.dataset_dir() == out / "data" / "dataset"       # seed 0: reused
    assert "rendering it afresh" not in capsys.readouterr().err
    ctx = Context.from_argv(reproduce.__doc__, ["--quick", "--seed", "1", "--out", str(out)])
    ctx.dataset_dir()
    assert "rendered with other options (seed 0" in capsys.readouterr().err
    record = json.loads((out / "data" / "dataset" / DATASET_OPTIONS).read_text())
    assert record["render_options"]["seed"] == 1
    # the seed draws the intrinsics views (the pose views have no random part)
    old = (pooled / "data" / "dataset" / "intrinsics").iterdir()
    new = out / "data" / "dataset" / "intrinsics"
    changed = [p.name for p in old if p.read_bytes() != (new / p.name).read_bytes()]
    assert changed                     # the images are seed 1's, not seed 0's
    assert not [p for p in (out / "data").iterdir() if p.name.startswith(".")]


def test_sigterm_keeps_finished_experiments_and_removes_the_unfinished(serial):
    """SIGTERM while the third experiment (E3) runs: the two before it kept, E3's staging
    folder removed, none of the later ones started, the earlier report removed and none
    written, status 130."""
    assert serial["status"] == 130
    rest = serial["stderr"]
    assert "Traceback" not in rest
    last = rest.strip().splitlines()[-1]
    assert last.startswith("reproduce: interrupted: kept the finished experiments"), last
    k = KEYS.index(importlib.import_module(f"experiments.{INTERRUPTED}").NAME)
    assert k == 2
    assert f": {', '.join(KEYS[:k])};" in last, last
    assert f"stopped the unfinished: {KEYS[k]} and removed" in last, last
    names = serial["names_after_sigterm"]
    assert set(KEYS[:k]) <= names and not set(KEYS[k:]) & names and "REPORT.md" not in names
    assert not [n for n in names if n.startswith(".")]
    assert not [p for p in serial["out"].rglob("*.tmp")]


@pytest.fixture(scope="module")
def warm_up() -> dict:
    """What a fresh interpreter holds after ``import experiments._warm`` (what the pool's
    forkserver imports), asked once for both tests below."""
    code = ("import json, sys, experiments._warm\n"
            "main_loaded = 'experiments.reproduce' in sys.modules\n"
            "need = ['cv2', 'mujoco', 'matplotlib.pyplot', 'scipy.optimize', "
            "'matplotlib.backends.backend_svg'] + "
            "['experiments.' + n for n, _ in __import__('experiments.reproduce', "
            "fromlist=['x']).EXPERIMENTS]\n"
            "print(json.dumps({'main_loaded': main_loaded, 'warmed': experiments._warm.WARMED, "
            "'missing': [m for m in need if m not in sys.modules]}))\n")
    # (reproduce itself is imported by this check, after main_loaded is read: the warm-up
    # must not import it, or every worker of `python -m experiments.reproduce` warns)
    proc = subprocess.run([sys.executable, "-c", code], cwd=EXPERIMENTS.parent,
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "MUJOCO_GL": "egl"})
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_forkserver_warm_up_loads_the_libraries_and_every_experiment(warm_up):
    """experiments._warm (imported once by the pool's forkserver) swallows its errors, so
    a broken warm-up would only show as slow workers: check that it loads everything."""
    assert warm_up["missing"] == [] and warm_up["warmed"] is True


def test_warm_up_leaves_the_main_module_alone(warm_up):
    """The warm-up runs in the forkserver of ``python -m experiments.reproduce``; each worker
    then re-imports that module as its ``__main__`` and runpy warns if it is already loaded
    ("found in sys.modules after import of package"), a line per worker on stderr."""
    assert warm_up["main_loaded"] is False
