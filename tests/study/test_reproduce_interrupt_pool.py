"""Ctrl-C of the pooled reproduction (``--workers 2``): exit 130 within seconds, every
worker gone, no ``pymp-*`` folder, no resource-tracker "leaked semaphore" line (8 of
them followed an interrupted reproduction before: the workers' progress-bar locks)."""

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
