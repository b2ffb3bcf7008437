"""rasc.study's executors one task at a time (``submit`` / ``completed``): what
reproduce.py's pool of experiments runs on. Tasks are builtins (``math.sqrt``,
``time.sleep``, ``os._exit``): a pool worker imports a task by name."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time

import pytest

from rasc.study.executors import Executor, WorkerCrashed, make_executor


def test_in_process_submit_runs_now_and_hands_over_its_exception():
    ex = Executor()
    futures = {ex.submit(math.sqrt, 9.0): "nine", ex.submit(math.sqrt, 4.0): "four"}
    # finished together (both at once here): handed over in the order of their keys
    assert list(ex.completed(futures)) == [("four", 2.0), ("nine", 3.0)]
    assert futures == {}                                      # each taken out as handed over
    with pytest.raises(ValueError, match="math domain error"):
        list(ex.completed({ex.submit(math.sqrt, -1.0): "bad"}))


@pytest.mark.slow
def test_pool_hands_results_over_as_they_finish_while_more_are_submitted():
    with make_executor(2) as ex:
        futures = {ex.submit(time.sleep, 1.5): "slow"}
        futures[ex.submit(math.sqrt, 16.0)] = "fast"         # submitted after, done first
        got = ex.completed(futures)
        assert next(got) == ("fast", 4.0)
        futures[ex.submit(math.sqrt, 25.0)] = "late"          # while "slow" still runs
        assert sorted(got) == [("late", 5.0), ("slow", None)]
        assert futures == {}


@pytest.mark.slow
def test_pool_worker_that_ends_is_one_line_naming_the_task():
    with make_executor(2) as ex, pytest.raises(WorkerCrashed) as info:
        list(ex.completed({ex.submit(os._exit, 3): "e7"}))
    msg = str(info.value)
    assert "\n" not in msg and "_exit (e7)" in msg, msg


@pytest.mark.slow
def test_abort_after_a_failed_task_leaves_no_thread_traceback(monkeypatch):
    """A task fails while others wait in the pool: the waiting ones are cancelled and
    the workers stopped; the pool's manager thread must not die on the cancelled
    futures (Python 3.11 raised InvalidStateError there: "Exception in thread", a
    traceback on stderr after the interrupt's one line)."""
    import threading
    died = []
    monkeypatch.setattr(threading, "excepthook", died.append)
    ex = make_executor(2)
    futures = {ex.submit(math.sqrt, -1.0): "bad"}
    futures.update({ex.submit(time.sleep, 0.5): f"s{k}" for k in range(8)})
    with pytest.raises(ValueError):
        list(ex.completed(futures))
    ex.abort()
    ex.close()
    time.sleep(1.0)                         # the manager thread's end, if it were to fail
    assert [d.exc_type.__name__ for d in died] == []


RACE = '''
import multiprocessing, os, sys
from multiprocessing import synchronize

if __name__ == "__main__":
    if sys.argv[1] == "pool":
        from rasc.study.executors import ProcessExecutor
        with ProcessExecutor(1) as ex:
            assert ex.submit(abs, -3).result() == 3
        assert "PYTHONWARNINGS" not in os.environ     # the filter was the tracker's alone
    lock = multiprocessing.get_context("forkserver").Lock()
    # what a Ctrl-C between a semaphore finalizer's two steps leaves: the name unlinked,
    # the tracker not told
    synchronize.sem_unlink(lock._semlock.name)
    os._exit(0)
'''


@pytest.mark.slow
def test_a_pools_resource_tracker_prints_no_leaked_semaphore_lines(tmp_path):
    """After the race an interrupt can hit (a semaphore unlinked, the tracker not told),
    multiprocessing's tracker prints two 'leaked semaphore' warnings at exit; the tracker
    rasc's process pool starts does not (it still unlinks what is left). The same script
    without the pool shows the warnings, so the check can fail."""
    script = tmp_path / "race.py"
    script.write_text(RACE)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
    runs = {how: subprocess.run([sys.executable, str(script), how], capture_output=True,
                                text=True, timeout=120, env=env, cwd=tmp_path)
            for how in ("plain", "pool")}
    assert "leaked semaphore" in runs["plain"].stderr
    assert runs["pool"].returncode == 0 and runs["pool"].stderr == "", runs["pool"].stderr
