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


class _LogLines(tqdm):
    """tqdm for a log: each refresh is a whole line (no carriage returns, no padding)."""

    def display(self, msg=None, pos=None):  # noqa: ARG002 (tqdm's signature)
        line = (msg if msg is not None else self.__str__()).strip()
        if line and line != getattr(self, "_last_line", None):
            self.fp.write(line + "\n")
            self.fp.flush()
            self._last_line = line
        return True

    def close(self):
        if self.disable:
            return
        self.display()  # the final count, once
        self.disable = True  # tqdm's own close would add a carriage return and newline
        with self.get_lock():
            self._decr_instances(self)


def progress(total: int | None = None, *, desc: str = "", quiet: bool = False,
             unit: str = "it", file=None) -> tqdm:
    """A tqdm bar on stderr (or ``file``). ``quiet`` disables it entirely.

    On a terminal the bar redraws in place; otherwise tqdm writes a plain line at most
    every :data:`LOG_INTERVAL_S` seconds and one at the end, so logs stay short.
    """
    stream = sys.stderr if file is None else file
    tty = hasattr(stream, "isatty") and stream.isatty()
    cls = tqdm if tty else _LogLines
    return cls(total=total, desc=desc, unit=unit, file=stream, disable=quiet,
               dynamic_ncols=tty, mininterval=0.1 if tty else LOG_INTERVAL_S,
               ascii=not tty, leave=True)
