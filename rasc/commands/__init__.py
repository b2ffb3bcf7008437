"""Sub-commands of the ``rasc`` command line; see :mod:`rasc.cli`.

Each module here imports at its top only the standard library and cheap parts of rasc
(:mod:`rasc.errors`, :mod:`rasc.interrupt`, :mod:`rasc.geometry.frames`, another command
module), so that building the parser, ``rasc --help``, ``--version`` and a usage error load
neither numpy nor scipy nor OpenCV (a Python start-up, ~0.05 s, instead of ~0.75 s).
A command's ``run()`` imports the libraries it needs inside a :func:`loading` block, at its
start: the command line's interrupt handling covers them as it covered the parser.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from rasc.interrupt import received


@contextlib.contextmanager
def loading() -> Iterator[None]:
    """Wrap a command's imports of its libraries (numpy, scipy, OpenCV, rasc's own modules).

    SIGINT or SIGTERM while they load raises KeyboardInterrupt as anywhere in a command
    (``rasc <cmd>: interrupted: nothing written``, exit status 130). A library may swallow
    that interrupt (an optional import catching the ImportError numpy makes of it) and the
    command would then run to its end as if nothing had happened: so when the block ends,
    a signal that arrived meanwhile (:func:`rasc.interrupt.received`) is raised here.
    """
    yield
    if received():
        raise KeyboardInterrupt("interrupted while the libraries loaded")
