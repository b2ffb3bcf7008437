"""One interrupt path for SIGINT and SIGTERM.

``timeout`` and process managers send SIGTERM, a terminal sends SIGINT (Ctrl-C). Inside
:func:`signals_as_interrupt` both raise :class:`KeyboardInterrupt` in the main thread, so
one mechanism serves both: code that writes files cleans its temporaries in ``finally`` /
``except BaseException`` blocks (see :mod:`rasc.io`), and the entry point (``rasc.cli``,
the experiments) catches the interrupt once, says what was kept, and exits 130.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator

#: the signals that arrived in this process through :func:`raise_interrupt`
_RECEIVED: list[int] = []


def raise_interrupt(signum, frame):  # noqa: ARG001 (signal handler signature)
    """The handler of SIGINT and SIGTERM: note the signal, raise KeyboardInterrupt."""
    _RECEIVED.append(signum)
    raise KeyboardInterrupt(signal.Signals(signum).name)


def received() -> bool:
    """Whether SIGINT or SIGTERM has arrived through :func:`raise_interrupt` since the
    last :func:`signals_as_interrupt` block began: a library
    interrupted while it loads may turn the KeyboardInterrupt into an ImportError (numpy
    does), which is then the interrupt, not a broken installation."""
    return bool(_RECEIVED)


@contextlib.contextmanager
def signals_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM (and SIGINT, as always) raises KeyboardInterrupt.

    A no-op outside the main thread (Python delivers signals to the main thread only).
    The previous handlers are restored on exit.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}
    _RECEIVED.clear()       # received() answers for this block (main() may run many times)
    signal.signal(signal.SIGTERM, raise_interrupt)
    signal.signal(signal.SIGINT, raise_interrupt)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


class Interrupted(KeyboardInterrupt):
    """An interrupt after the command cleaned up; ``note`` says what was kept and removed,
    e.g. ``"nothing written (removed the partial dataset out/.ds.x.tmp)"``. The command
    line prints ``rasc <command>: interrupted: <note>`` and exits 130."""

    def __init__(self, note: str):
        super().__init__(note)
        self.note = note


@contextlib.contextmanager
def shielded(reraise: bool = True) -> Iterator[None]:
    """Within the block (cleaning up after an interrupt), SIGINT and SIGTERM are held
    back, so a second Ctrl-C cannot leave half-removed temporaries; one that arrived is
    raised as KeyboardInterrupt when the block ends (``reraise``; not when the block
    already cleans up after one). A no-op outside the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    arrived: list[int] = []
    previous = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}
    for s in previous:
        signal.signal(s, lambda signum, frame: arrived.append(signum))
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
    if arrived and reraise:
        raise KeyboardInterrupt(signal.Signals(arrived[0]).name)


def exit_process(status: int, *, teardown: bool = True) -> None:
    """End the process with an entry point's ``status`` (never returns).

    After an interrupt (status 130; the command has cleaned up and said what it kept) the
    process ends with ``os._exit(130)`` once the output is flushed: CPython marks a
    KeyboardInterrupt that passed through code run by a library's import as unhandled
    even when the entry point caught it, and would then end the process by SIGINT instead
    of with status 130 (python/cpython gh-128130; measured here: about a third of the
    SIGINTs that arrive 0.25-0.3 s after ``rasc`` starts). ``teardown=False`` ends any
    status that way, without the interpreter's teardown (for a command whose results are
    all written and closed, and whose loaded libraries take long to free).
    """
    if status == 130 or not teardown:
        _multiprocessing_teardown()
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):
                stream.flush()
        os._exit(status)
    sys.exit(status)


def _multiprocessing_teardown() -> None:
    """What the interpreter's exit would do for :mod:`multiprocessing` (its ``atexit``
    function), before an ``os._exit``: end daemonic children, run the finalizers that
    unlink the pools' semaphores (else the resource tracker reports them as leaked) and
    remove the ``pymp-*`` temporary folder. Best effort; nothing when it was not used."""
    util = sys.modules.get("multiprocessing.util")
    if util is None:
        return
    with contextlib.suppress(Exception):
        util._exit_function()          # the function multiprocessing registers at exit


#: temporary folders this process made and removes itself; :func:`end_by_sigterm`
#: removes them when the process is ended before its own clean-up can run
_TEMPORARY: set[str] = set()


def register_temporary(path: str) -> str:
    """Note a temporary folder this process will remove (returns ``path``)."""
    _TEMPORARY.add(str(path))
    return str(path)


def forget_temporary(path: str) -> None:
    """Remove the temporary folder ``path`` and forget it."""
    import shutil
    shutil.rmtree(path, ignore_errors=True)
    _TEMPORARY.discard(str(path))


def end_by_sigterm(signum, frame) -> None:  # noqa: ARG001 (signal handler signature)
    """A worker's SIGTERM handler: remove the registered temporary folders and end the
    process at once (raising instead would unwind through whatever code runs, a weakref
    callback or a queue's flush among them, and may never end)."""
    import shutil
    for path in list(_TEMPORARY):
        shutil.rmtree(path, ignore_errors=True)
    os._exit(128 + signum)
