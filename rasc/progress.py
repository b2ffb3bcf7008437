"""Progress for long work, drawn by tqdm: a live bar on a terminal, a quiet line now and
then in a log (stderr not a terminal), nothing at all with ``quiet``.

    with progress(total=58, desc="render", quiet=args.quiet) as bar:
        for ...:
            ...
            bar.update(1)
"""

from __future__ import annotations

import sys

from tqdm import tqdm

#: In a log (stderr is not a terminal), at most one line per this many seconds.
LOG_INTERVAL_S = 10.0


def progress(total: int | None = None, *, desc: str = "", quiet: bool = False,
             unit: str = "it", file=None) -> tqdm:
    """A tqdm bar on stderr (or ``file``). ``quiet`` disables it entirely.

    On a terminal the bar redraws in place; otherwise tqdm writes a plain line at most
    every :data:`LOG_INTERVAL_S` seconds and one at the end, so logs stay short.
    """
    stream = sys.stderr if file is None else file
    tty = hasattr(stream, "isatty") and stream.isatty()
    return tqdm(total=total, desc=desc, unit=unit, file=stream, disable=quiet,
                dynamic_ncols=tty, mininterval=0.1 if tty else LOG_INTERVAL_S,
                ascii=not tty, leave=True)
