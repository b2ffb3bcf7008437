"""``python -m experiments.reproduce --quick`` end to end: the report, sane numbers, determinism.

Two quick runs with one seed, one with --workers 1 and one with --workers 2, must write
byte-identical result files (CSV, JSON and the rendered dataset); the report must hold
every section with its figures, and the headline numbers must be sane.
"""

import csv
import json
import math
import re
import sys
from pathlib import Path

import pytest

EXPERIMENTS = Path(__file__).resolve().parents[1] / "experiments"
sys.path.insert(0, str(EXPERIMENTS.parent))  # the experiments package

from experiments import reproduce  # noqa: E402

pytestmark = pytest.mark.slow  # renders and whole experiment runs


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for workers in (1, 2):
        folder = tmp_path_factory.mktemp(f"reproduce_w{workers}")
        assert reproduce.main(["--quick", "--seed", "0", "--out", str(folder),
                               "--workers", str(workers)]) == 0
        out[workers] = folder
    return out


def _results(folder: Path) -> dict[str, bytes]:
    """Raw results (every CSV and JSON) and the rendered dataset's images, by path."""
    files = [p for p in sorted(folder.rglob("*")) if p.is_file()]
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in files
            if p.suffix in (".csv", ".json") or p.suffix == ".png" and "data" in p.parts}


def test_same_seed_same_bytes_for_any_worker_count(runs):
    a, b = _results(runs[1]), _results(runs[2])
    assert len(a) > 40  # every experiment's raw files plus the dataset's images
    assert sorted(a) == sorted(b)
    differ = [name for name in a if a[name] != b[name]]
    assert differ == []


def test_report_has_every_section_and_its_figures(runs):
    out = runs[1]
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


def test_headline_numbers_are_sane(runs):
    out = runs[1]
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


def test_dataset_is_reused_only_with_the_options_it_was_rendered_with(runs, tmp_path, capsys):
    """A seed-1 run into a folder holding a seed-0 dataset renders afresh and says so."""
    import shutil

    from experiments._common import DATASET_OPTIONS, Context

    out = tmp_path / "run"
    shutil.copytree(runs[1] / "data" / "dataset", out / "data" / "dataset")
    doc = Context.from_argv(reproduce.__doc__, ["--quick", "--out", str(out)])
    assert doc.dataset_dir() == out / "data" / "dataset"       # seed 0: reused
    assert "rendering it afresh" not in capsys.readouterr().err
    ctx = Context.from_argv(reproduce.__doc__, ["--quick", "--seed", "1", "--out", str(out)])
    ctx.dataset_dir()
    assert "rendered with other options (seed 0" in capsys.readouterr().err
    record = json.loads((out / "data" / "dataset" / DATASET_OPTIONS).read_text())
    assert record["render_options"]["seed"] == 1
    # the seed draws the intrinsics views (the pose views have no random part)
    old = (runs[1] / "data" / "dataset" / "intrinsics").iterdir()
    new = out / "data" / "dataset" / "intrinsics"
    changed = [p.name for p in old if p.read_bytes() != (new / p.name).read_bytes()]
    assert changed                     # the images are seed 1's, not seed 0's
    assert not [p for p in (out / "data").iterdir() if p.name.startswith(".")]


def test_sigterm_keeps_finished_experiments_and_removes_the_unfinished(tmp_path, runs):
    """SIGTERM while E2 runs: E1 kept, E2's staging folder removed, no REPORT.md, 130."""
    import os
    import shutil
    import signal
    import subprocess

    out = tmp_path / "run"
    shutil.copytree(runs[1] / "data" / "dataset", out / "data" / "dataset")
    (out / "REPORT.md").write_text("an earlier run's report")
    repo = EXPERIMENTS.parent
    proc = subprocess.Popen([sys.executable, "-m", "experiments.reproduce", "--quick",
                             "--workers", "1", "--out", str(out)], cwd=repo,
                            stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "MUJOCO_GL": "egl"})
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if line.startswith("== E2"):        # E1 has finished and been renamed
            proc.send_signal(signal.SIGTERM)
            break
    rest = proc.stderr.read()
    assert proc.wait(timeout=120) == 130
    assert "Traceback" not in rest
    last = rest.strip().splitlines()[-1]
    assert last.startswith("reproduce: interrupted: kept the finished experiments"), last
    assert ": e1;" in last and "stopped the unfinished: e2 and removed" in last
    names = {p.name for p in out.iterdir()}
    assert "e1" in names and "e2" not in names and "REPORT.md" not in names
    assert not [n for n in names if n.startswith(".")]
    assert not [p for p in out.rglob("*.tmp")]


def test_forkserver_warm_up_loads_the_libraries_and_every_experiment():
    """experiments._warm (imported once by the pool's forkserver) swallows its errors, so
    a broken warm-up would only show as slow workers: check that it loads everything."""
    import os
    import subprocess

    code = ("import sys, experiments._warm\n"
            "need = ['cv2', 'mujoco', 'matplotlib.pyplot', 'scipy.optimize', "
            "'matplotlib.backends.backend_svg'] + "
            "['experiments.' + n for n, _ in __import__('experiments.reproduce', "
            "fromlist=['x']).EXPERIMENTS]\n"
            "print([m for m in need if m not in sys.modules], experiments._warm.WARMED)\n")
    # (reproduce itself is imported by this check, after the warm-up: the warm-up must not
    # import it, or every worker of `python -m experiments.reproduce` warns at start-up)
    proc = subprocess.run([sys.executable, "-c", code], cwd=EXPERIMENTS.parent,
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "MUJOCO_GL": "egl"})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[] True"


def test_warm_up_leaves_the_main_module_alone():
    """The warm-up runs in the forkserver of ``python -m experiments.reproduce``; each worker
    then re-imports that module as its ``__main__`` and runpy warns if it is already loaded
    ("found in sys.modules after import of package"), a line per worker on stderr."""
    import os
    import subprocess

    code = "import sys, experiments._warm\nprint('experiments.reproduce' in sys.modules)\n"
    proc = subprocess.run([sys.executable, "-c", code], cwd=EXPERIMENTS.parent,
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "MUJOCO_GL": "egl"})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "False"
