"""rasc.study's executors one task at a time (``submit`` / ``completed``): what
reproduce.py's pool of experiments runs on. Tasks are builtins (``math.sqrt``,
``time.sleep``, ``os._exit``): a pool worker imports a task by name."""

from __future__ import annotations

import math
import os
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
