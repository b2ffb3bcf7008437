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


@contextlib.contextmanager
def starting_helpers() -> Iterator[None]:
    """Start helper processes (a pool's forkserver and resource tracker, a dask
    LocalCluster's workers) within this block: a terminal's Ctrl-C, sent to the whole
    process group, never reaches them, and this process answers it once they are up.

    SIGINT is blocked in this thread for the block: the processes started meanwhile
    (and the threads, which start processes in their turn: dask's event loop) inherit
    the blocked signal through fork and exec (and those they fork, from them), so a
    Ctrl-C never interrupts their start-up with a KeyboardInterrupt traceback of their
    own (a forkserver's imports take seconds); they are stopped by SIGTERM, which they
    keep. :mod:`multiprocessing`'s resource tracker is started first
    (:func:`resource_tracker_started_quietly`): starting it unblocks SIGINT in the
    thread that does.

    In this process SIGINT and SIGTERM that arrive in the block are held (as
    :func:`shielded` holds them) and raised as one KeyboardInterrupt when it ends, so the
    caller stops what it started (not half of it); also when the block failed meanwhile
    (a helper ended by a SIGTERM sent to the whole group fails the start-up: the
    interrupt is the news, not that failure). A no-op outside the main thread or where
    the platform has no ``pthread_sigmask``.
    """
    if threading.current_thread() is not threading.main_thread() or \
            not hasattr(signal, "pthread_sigmask"):
        yield
        return
    # first the resource tracker, which unblocks SIGINT in the thread that starts it
    resource_tracker_started_quietly()
    arrived: list[int] = []

    def hold(signum, frame):  # noqa: ARG001 (signal handler signature)
        arrived.append(signum)
        _RECEIVED.append(signum)          # received() says so at once

    previous = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}
    for s in previous:
        signal.signal(s, hold)
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    failed: Exception | None = None
    try:
        yield
    except Exception as exc:    # a helper ended by the signal (sent to the whole group)
        failed = exc            # makes its start fail: then the signal is the news
    finally:
        if signal.SIGINT in signal.sigpending():    # held by the mask: count it, drop it
            hold(signal.SIGINT, None)
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for s, h in previous.items():
            signal.signal(s, h)
    if arrived:
        raise KeyboardInterrupt(signal.Signals(arrived[0]).name) from None
    if failed is not None:
        raise failed


#: the warnings filter multiprocessing's resource tracker starts with (see below)
QUIET_TRACKER = "ignore::UserWarning:multiprocessing.resource_tracker"


def resource_tracker_started_quietly() -> None:
    """Start multiprocessing's resource tracker (once per process) without its
    "leaked semaphore" warnings. A pool's queue semaphores are unlinked by finalizers,
    each of which unlinks the name and then tells the tracker; a Ctrl-C that arrives
    between the two (a finalizer run by the garbage collector at that instant) leaves a
    name the tracker still lists, and at exit it printed two warnings after rasc's one
    line (seen once in about six runs of the whole suite: "1 leaked semaphore objects",
    "'/mp-…': No such file or directory", the name already gone). The tracker still
    unlinks whatever is left; only its message is silenced, for the tracker alone (the
    filter is in the environment it starts with, then restored)."""
    from multiprocessing import resource_tracker

    before = os.environ.get("PYTHONWARNINGS")
    os.environ["PYTHONWARNINGS"] = ",".join(w for w in (before, QUIET_TRACKER) if w)
    try:
        resource_tracker.ensure_running()
    finally:
        if before is None:
            os.environ.pop("PYTHONWARNINGS", None)
        else:
            os.environ["PYTHONWARNINGS"] = before


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
    remove the ``pymp-*`` temporary folder; then :func:`stop_helpers`. Best effort;
    nothing when it was not used."""
    util = sys.modules.get("multiprocessing.util")
    if util is None:
        return
    with contextlib.suppress(Exception):
        util._exit_function()          # the function multiprocessing registers at exit
    stop_helpers()


#: how long :func:`stop_helpers` waits for each helper process to end, s
HELPER_GRACE_S = 2.0


def stop_helpers(grace_s: float = HELPER_GRACE_S) -> None:
    """End the helper processes :mod:`multiprocessing` started for this process, before
    it ends (after an interrupt its pool's workers are already stopped): the forkserver
    (SIGTERM; it may still be importing its preload modules, which takes seconds, and
    would only then notice that this process is gone) and the resource tracker (its pipe
    closed, it unlinks what is left and ends; waited for). Each is waited for at most
    ``grace_s``, then killed. No helper outlives the command."""
    import time

    def reap(pid: int, kill_first: bool) -> None:
        with contextlib.suppress(OSError):
            if kill_first:
                os.kill(pid, signal.SIGTERM)
            deadline = time.monotonic() + grace_s
            while os.waitpid(pid, os.WNOHANG) == (0, 0):
                if time.monotonic() > deadline:
                    os.kill(pid, signal.SIGKILL)
                    os.waitpid(pid, 0)
                    return
                time.sleep(0.01)

    fs = sys.modules.get("multiprocessing.forkserver")
    server = getattr(fs, "_forkserver", None)
    pid = getattr(server, "_forkserver_pid", None)
    if pid:
        with contextlib.suppress(OSError, TypeError):
            os.close(server._forkserver_alive_fd)
        server._forkserver_pid = server._forkserver_alive_fd = None
        server._forkserver_address = None
        reap(pid, kill_first=True)
    rt = sys.modules.get("multiprocessing.resource_tracker")
    tracker = getattr(rt, "_resource_tracker", None)
    pid = getattr(tracker, "_pid", None)
    if pid:
        with contextlib.suppress(OSError, TypeError):
            os.close(tracker._fd)
        tracker._fd = tracker._pid = None
        reap(pid, kill_first=False)


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
