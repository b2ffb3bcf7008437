"""Calling code that is not rasc's (a solver plugin) so that it cannot take the process
down or corrupt its output.

:func:`guarded` runs ``fn`` with

- its ``print`` output sent to stderr (stdout carries rasc's results: JSON, CSV);
- ``SystemExit`` and ``os._exit`` turned into :class:`PluginExited` (the caller counts a
  failure and goes on: a failed sample, or one error line naming the plugin);
- a time limit (``time_limit_s``; SIGALRM, main thread of a POSIX process only — every
  rasc worker runs its tasks there): a call that does not return in time raises
  :class:`PluginTimedOut`, which the caller counts as a failure with its reason.

A crash that no Python code sees (a segmentation fault in a C extension) still ends a
worker process; :mod:`rasc.study.executors` turns that into one error line.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

from rasc.errors import RascError

T = TypeVar("T")

#: the default time limit of one plugin call, seconds: generous (a method solves in
#: milliseconds; this only turns a hang into a failure)
DEFAULT_TIME_LIMIT_S = 300.0


class PluginExited(RascError):
    """A guarded call tried to end the process (``sys.exit``, ``os._exit``)."""


class PluginTimedOut(RascError):
    """A guarded call ran past its time limit."""


def _exit_instead(status=0):
    raise PluginExited(f"called os._exit({status!r})")


@contextlib.contextmanager
def _time_limit(seconds: float | None, who: str) -> Iterator[None]:
    usable = (seconds is not None and math.isfinite(seconds) and seconds > 0
              and hasattr(signal, "setitimer")
              and threading.current_thread() is threading.main_thread())
    # a guarded call inside another (a study's cell calling a plugin method, which guards
    # its plugin too): the outer limit governs, its timer is left running
    if usable and signal.getitimer(signal.ITIMER_REAL)[0] > 0:
        usable = False
    if not usable:
        yield
        return

    def expired(signum, frame):  # noqa: ARG001 (signal handler signature)
        raise PluginTimedOut(f"{who}: did not return within its time limit of {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def guarded(fn: Callable[..., T], *args: Any, who: str = "plugin",
            time_limit_s: float | None = DEFAULT_TIME_LIMIT_S, **kwargs: Any) -> T:
    """``fn(*args, **kwargs)`` with stdout sent to stderr, process exits turned into
    :class:`PluginExited` and a time limit (:class:`PluginTimedOut`); ``who`` names the
    callee in their messages. Other exceptions pass unchanged."""
    real_exit = os._exit
    os._exit = _exit_instead
    try:
        with contextlib.redirect_stdout(sys.stderr), _time_limit(time_limit_s, who):
            return fn(*args, **kwargs)
    except SystemExit as exc:
        raise PluginExited(f"{who}: called sys.exit({exc.code!r})") from None
    except PluginExited as exc:
        raise PluginExited(f"{who}: {exc}") from None
    finally:
        os._exit = real_exit
