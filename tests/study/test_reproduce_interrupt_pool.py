"""Ctrl-C of the pooled reproduction (``--workers 2``): exit 130 within seconds, every
worker gone, no ``pymp-*`` folder, no resource-tracker "leaked semaphore" line (8 of
them followed an interrupted reproduction before: the workers' progress-bar locks); a
Ctrl-C or SIGTERM while its forkserver warms up: one line, and no helper process left
when it has ended (issue 30)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from running import marked_processes

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_ctrl_c_of_the_pooled_reproduction_leaves_nothing_behind(tmp_path, short_tmp):
    tmp = short_tmp
    mark = f"RASC_TEST_MARK_{uuid.uuid4().hex}"
    env = {**os.environ, "TMPDIR": str(tmp), mark: "1", "MUJOCO_GL": "egl",
           "PYTHONPATH": os.pathsep.join([str(REPO), *filter(None, [os.environ.get(
               "PYTHONPATH")])])}
    proc = subprocess.Popen([sys.executable, "-m", "experiments.reproduce", "--quick",
                             "--workers", "2", "--out", str(tmp_path / "out")], cwd=REPO,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    deadline = time.monotonic() + 120                 # until the experiments run
    while time.monotonic() < deadline and not any(
            p.name.startswith(".partial-") for p in (tmp_path / "out").glob(".*")):
        time.sleep(0.2)
    time.sleep(2)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "reproduce: interrupted: " in err and "leaked semaphore" not in err, err
    assert "Traceback" not in err, err
    time.sleep(2)
    assert marked_processes(mark) == []
    assert list(tmp.iterdir()) == []


def _start_reproduction(tmp_path, tmp, mark) -> subprocess.Popen:
    """``python -m experiments.reproduce --quick --workers 2`` in its own process group,
    its environment marked (its process tree is found by ``mark``)."""
    env = {**os.environ, "TMPDIR": str(tmp), mark: "1", "MUJOCO_GL": "egl",
           "RASC_CACHE_DIR": str(tmp_path / "cache"),
           "PYTHONPATH": os.pathsep.join([str(REPO), *filter(None, [os.environ.get(
               "PYTHONPATH")])])}
    return subprocess.Popen([sys.executable, "-m", "experiments.reproduce", "--quick",
                             "--workers", "2", "--out", str(tmp_path / "out")], cwd=REPO,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)


def _forkserver_started(mark: str, proc: subprocess.Popen, loaded: bytes = b"",
                        timeout_s: float = 60) -> int:
    """Wait until the reproduction's forkserver process exists and has mapped a shared
    object whose path holds ``loaded`` (``b"cv2"``: experiments._warm's first import;
    matplotlib, scipy and mujoco follow, seconds on any machine); its pid."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        for pid in marked_processes(mark):
            with contextlib.suppress(OSError):
                if b"forkserver" in Path(f"/proc/{pid}/cmdline").read_bytes() and \
                        loaded in Path(f"/proc/{pid}/maps").read_bytes():
                    return pid
        time.sleep(0.01)
    raise AssertionError(f"the reproduction's forkserver did not load {loaded!r}")


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_ctrl_c_while_the_forkserver_warms_up_prints_one_line(tmp_path, short_tmp):
    """A terminal's Ctrl-C reaches the whole process group: the forkserver, importing its
    preload modules, printed an 18-line KeyboardInterrupt traceback of its own beside
    the reproduction's line. It now starts with SIGINT blocked: one line, 130."""
    mark = f"RASC_TEST_MARK_{uuid.uuid4().hex}"
    proc = _start_reproduction(tmp_path, short_tmp, mark)
    _forkserver_started(mark, proc, b"cv2")       # importing its preload modules
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("== ")]
    assert len(lines) == 1 and lines[0].startswith("reproduce: interrupted: "), err
    time.sleep(1)
    assert marked_processes(mark) == []


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_no_helper_outlives_the_reproduction_after_sigterm(tmp_path, short_tmp):
    """SIGTERM to the reproduction alone (as a process manager sends it) while its
    forkserver warms up: when the reproduction has ended, so have the forkserver and the
    resource tracker (the forkserver lived on until its imports were done and only then
    noticed; the tracker until every holder of its pipe had gone)."""
    mark = f"RASC_TEST_MARK_{uuid.uuid4().hex}"
    proc = _start_reproduction(tmp_path, short_tmp, mark)
    _forkserver_started(mark, proc)
    proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=60)
    left = marked_processes(mark)                 # at once: nothing may outlive it
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert left == [], [Path(f"/proc/{p}/cmdline").read_bytes() for p in left
                        if Path(f"/proc/{p}").exists()]
    assert "Traceback" not in err, err
