"""``python -m rasc``: the command line (:func:`rasc.cli.run`).

SIGTERM is turned into KeyboardInterrupt before anything else is imported, so a signal
during start-up ends like one during the work: one line, status 130, nothing written.
"""

import os
import signal
import sys

from rasc.interrupt import raise_interrupt

signal.signal(signal.SIGTERM, raise_interrupt)
signal.signal(signal.SIGINT, raise_interrupt)
try:
    from rasc.cli import run
except KeyboardInterrupt:
    _command = next((a for a in sys.argv[1:] if not a.startswith("-")), "")
    print(f"rasc {_command}".rstrip() + ": interrupted: nothing written", file=sys.stderr)
    sys.stderr.flush()
    os._exit(130)  # see rasc.interrupt.exit_process
run()
