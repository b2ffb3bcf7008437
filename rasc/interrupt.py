"""One interrupt path for SIGINT and SIGTERM.

``timeout`` and process managers send SIGTERM, a terminal sends SIGINT (Ctrl-C). Inside
:func:`signals_as_interrupt` both raise :class:`KeyboardInterrupt` in the main thread, so
one mechanism serves both: code that writes files cleans its temporaries in ``finally`` /
``except BaseException`` blocks (see :mod:`rasc.io`), and the entry point (``rasc.cli``,
the experiments) catches the interrupt once, says what was kept, and exits 130.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator


def _raise_interrupt(signum, frame):  # noqa: ARG001 (signal handler signature)
    raise KeyboardInterrupt(signal.Signals(signum).name)


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
    signal.signal(signal.SIGTERM, _raise_interrupt)
    signal.signal(signal.SIGINT, _raise_interrupt)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
