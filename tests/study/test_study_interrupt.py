"""Ctrl-C of a pooled study (a process pool, a dask LocalCluster) whose plugin never
returns: one line saying what was kept, exit 130 within seconds, every worker process and
temporary folder gone, no resource-tracker noise (issue 21, interrupts)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from running import marked_processes

SCRIPT = '''
import sys, time
sys.path.insert(0, sys.argv[1])
from pathlib import Path
from test_study_faults import synthetic_dataset
from rasc.interrupt import Interrupted, exit_process, signals_as_interrupt
from rasc.study import load_spec, run_study

spec = load_spec(Path(sys.argv[2]))
dask = None if sys.argv[4] == "pool" else "local"
try:
    with signals_as_interrupt():
        run_study(spec, sys.argv[3], workers=2, dask=dask, quiet=True,
                  dataset=synthetic_dataset(), figures=False)
    status = 0
except Interrupted as exc:
    print(f"rasc study: interrupted: {exc.note}", file=sys.stderr)
    status = 130
exit_process(status)
'''

PLUGIN = '''
import time
def hangs(T_cw, T_gp, **kw):
    while True:
        time.sleep(0.05)
'''


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
@pytest.mark.parametrize("where", ["pool", "dask"])
def test_ctrl_c_of_a_pooled_study_leaves_nothing_behind(tmp_path, where, short_tmp):
    if where == "dask":
        pytest.importorskip("dask.distributed")
    (tmp_path / "hangplug.py").write_text(PLUGIN)
    spec = tmp_path / "spec.toml"
    spec.write_text("seed = 0\nsamples = 2\nmethods = ['rasc', 'hangplug:hangs']\n"
                    "[axes]\nnoise_level = [1, 2]\n")
    tmp = short_tmp
    mark = f"RASC_TEST_MARK_{uuid.uuid4().hex}"
    env = {**os.environ, "TMPDIR": str(tmp), mark: "1", "PYTHONPATH": os.pathsep.join(
        [str(tmp_path), *filter(None, [os.environ.get("PYTHONPATH")])])}
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT, str(Path(__file__).parent),
                             str(spec), str(out), where], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    # wait until the cells run (the study wrote its dataset; the workers are busy)
    deadline = time.monotonic() + 120
    while not list((out / "datasets").glob("*.json")) and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(4 if where == "pool" else 8)
    os.killpg(proc.pid, signal.SIGINT)            # as a terminal's Ctrl-C does
    t0 = time.monotonic()
    _, err = proc.communicate(timeout=60)
    took = time.monotonic() - t0
    assert proc.returncode == 130, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("rasc study: interrupted: kept 0 of 2 "
                                                   "finished cells"), err
    assert took < 15, took                           # within seconds (2 cores, loaded)
    time.sleep(2)
    assert marked_processes(mark) == []                       # every worker process gone
    assert list(tmp.iterdir()) == []                 # no pymp-*, no dask scratch
    assert not (tmp_path / "dask-scratch-space").exists()
    assert not (out / "samples.csv").exists()


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_ctrl_c_of_rasc_study_while_its_workers_render(tmp_path, short_tmp):
    """The command line, interrupted while its pool's workers render: one line, 130,
    no worker left, no render folder, no "leaked semaphore" line (a worker killed while
    it held a multiprocessing lock left one before)."""
    spec = tmp_path / "spec.toml"
    # four datasets to render, two at a time: several seconds of work on a quiet machine
    # (two datasets of 6 views were done within the 3 s the test waited, and the study
    # exited 0 before its Ctrl-C)
    spec.write_text("seed = 0\nsamples = 2\nmethods = ['rasc']\n[fixed]\npositions = 4\n"
                    "intrinsics_views = 10\n[axes]\nnoise_level = [1, 2]\n"
                    "image_noise = [0.0, 1.0, 2.0, 3.0]\n")
    tmp = short_tmp
    mark = f"RASC_TEST_MARK_{uuid.uuid4().hex}"
    env = {**os.environ, "TMPDIR": str(tmp), mark: "1", "RASC_CACHE_DIR": "none"}
    proc = subprocess.Popen([sys.executable, "-m", "rasc", "study", str(spec), "--out",
                             str(tmp_path / "out"), "--workers", "2", "--quiet"],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 120
    while not (tmp_path / "out" / "study.json").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(1.5)                                 # the workers are rendering
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("rasc study: interrupted: "), err
    time.sleep(2)
    assert marked_processes(mark) == []
    assert list(tmp.iterdir()) == []


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_ctrl_c_while_the_dask_cluster_starts(tmp_path, short_tmp):
    """rasc study --dask local, Ctrl-C while its LocalCluster starts (its scratch folder
    made, its workers being spawned: a second or more): it ignored the Ctrl-C (its
    handler was SIG_IGN meanwhile, so that the workers inherit that), ran the study to
    its end and exited 0. Now: one line saying what was kept, 130, the cluster stopped,
    no worker process and no scratch folder left."""
    pytest.importorskip("dask.distributed")
    spec = tmp_path / "spec.toml"
    spec.write_text("seed = 0\nsamples = 2\nmethods = ['rasc']\n[fixed]\npositions = 4\n"
                    "intrinsics_views = 6\n[axes]\nnoise_level = [1, 2]\n")
    tmp = short_tmp
    mark = f"RASC_TEST_MARK_{uuid.uuid4().hex}"
    env = {**os.environ, "TMPDIR": str(tmp), mark: "1", "RASC_CACHE_DIR": "none"}
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "rasc", "study", str(spec), "--out",
                             str(out), "--dask", "local", "--workers", "2", "--quiet"],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 120       # the executor's scratch folder: start-up
    while not list(tmp.glob("rasc-dask-*")) and time.monotonic() < deadline \
            and proc.poll() is None:
        time.sleep(0.01)
    assert list(tmp.glob("rasc-dask-*")), proc.communicate()[1]
    os.killpg(proc.pid, signal.SIGINT)             # as a terminal's Ctrl-C does
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("rasc study: interrupted: "), err
    time.sleep(2)
    assert marked_processes(mark) == []
    assert list(tmp.iterdir()) == []
    assert not (out / "samples.csv").exists()
