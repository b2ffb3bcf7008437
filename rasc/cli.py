"""The ``rasc`` command line (also ``python -m rasc``).

Each sub-command lives in its own module under :mod:`rasc.commands` and exposes
``add_parser(subparsers)`` (which sets ``func`` on its parser) and is imported here.

One path for every way a command ends (README, "What rasc refuses and what it warns"):

* any :class:`rasc.errors.RascError` is printed as one line,
  ``rasc <command>: error: <message>``, and the exit status is 2;
* SIGINT (Ctrl-C) and SIGTERM (``timeout``, process managers), also during start-up
  while the libraries load, print one line, ``rasc <command>: interrupted: <what was
  kept and removed>``, exit status 130, no traceback (commands clean their temporaries
  and say so through :class:`rasc.interrupt.Interrupted`);
* numpy's RuntimeWarnings (overflow, invalid value, ...) never print beside the error
  line: with an error they are dropped (the error speaks), on success each distinct one
  becomes one ``rasc <command>: warning: numerical trouble ...`` line;
* standard output that cannot be written (a full device) is the one error line.

This module imports only the standard library and :mod:`rasc.errors` /
:mod:`rasc.interrupt` at the top, so that the console script reaches :func:`main`
(and its interrupt handling) before numpy, scipy or OpenCV load. The command modules
load those only in their ``run()``, inside :func:`rasc.commands.loading` (which also
raises an interrupt a library swallowed while it loaded): ``rasc --help``, ``--version``
and a usage error cost a bare Python start-up.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from rasc import __version__
from rasc.errors import RascError
from rasc.interrupt import Interrupted, exit_process, received, signals_as_interrupt

#: sub-command modules, in the order ``rasc --help`` lists them
COMMANDS = ("handeye", "render", "calibrate", "detect", "triangulate", "project", "look_at",
            "study", "import_recording", "report", "plan", "rectify", "export")
#: a command named otherwise than its module (``import`` is a Python keyword)
COMMAND_NAMES = {"import_recording": "import"}


def command_name(module: str) -> str:
    """The command of a module of :data:`COMMANDS` (``look_at`` → ``look-at``)."""
    return COMMAND_NAMES.get(module, module.replace("_", "-"))


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``rasc <command>: error: ...``), exit 2."""

    def error(self, message: str):
        if message.endswith("expected one argument"):
            # argparse takes a value starting with '-' for an option: say how to pass one
            message += " (a value starting with '-' is written with '=', e.g. --distortion=-0.2)"
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``rasc`` parser, with every sub-command of :data:`COMMANDS` (each module's
    ``add_parser``)."""
    parser = _Parser(
        prog="rasc", description="Robust Active Stereo Calibration (Neubert & Ferrier 2002).")
    parser.add_argument("--version", action="version", version=f"rasc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:  # a command that fails to import is a broken install: say so
        importlib.import_module(f"rasc.commands.{name}").add_parser(sub)
    return parser


def _command_name(argv: list[str]) -> str:
    """The sub-command named in ``argv`` (for messages before the parser exists)."""
    names = {command_name(name) for name in COMMANDS}
    return next((a for a in argv if a in names), "")


def main(argv: list[str] | None = None) -> int:
    """Run the command line on ``argv`` (default ``sys.argv[1:]``) and return the exit status:
    0 on success, 2 for a refusal (one error line), 130 when interrupted."""
    argv = sys.argv[1:] if argv is None else list(argv)
    prog = f"rasc {_command_name(argv)}".rstrip()
    try:
        with signals_as_interrupt(), warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuntimeWarning)
            parser = build_parser()          # the command modules: no numpy, scipy, OpenCV
            if received():
                # a signal that arrived while they loaded and was swallowed: it still
                # counts (the libraries load in each run(), checked the same way by
                # rasc.commands.loading: an optional import may catch the ImportError
                # numpy makes of an interrupt; seen as a command that ran to its end)
                raise KeyboardInterrupt("interrupted while the libraries loaded")
            args = parser.parse_args(argv)
            prog = f"rasc {args.command}"
            status = int(args.func(args) or 0)
    except RascError as exc:
        msg = str(exc).replace("\n", " ")
        print(f"{prog}: error: {msg}", file=sys.stderr)
        return 2
    except ImportError:
        if not received():
            raise
        # a library interrupted while it loaded (numpy reports a "bad install")
        print(f"{prog}: interrupted: nothing written", file=sys.stderr)
        return 130
    except Exception as exc:
        if type(exc).__module__ != "cv2" or type(exc).__name__ != "error":
            raise
        # OpenCV's assertion on data no validation caught: still one line, no traceback
        why = str(exc).strip().splitlines()[-1] if str(exc).strip() else "failed"
        print(f"{prog}: error: OpenCV could not process the input ({why})", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        note = exc.note if isinstance(exc, Interrupted) else "nothing written"
        print(f"{prog}: interrupted: {note}", file=sys.stderr)
        return 130
    _numerical_warnings(prog, caught)
    return status


def _numerical_warnings(prog: str, caught: list[warnings.WarningMessage]) -> None:
    """Each distinct RuntimeWarning of a command that succeeded, as one warning line."""
    seen = set()
    for w in caught:
        if not issubclass(w.category, RuntimeWarning):
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
            continue
        text = str(w.message).replace("\n", " ")
        if text not in seen:
            seen.add(text)
            print(f"{prog}: warning: numerical trouble during the computation ({text}); "
                  "check the result", file=sys.stderr)


def run() -> None:
    """The process entry point (the ``rasc`` console script, ``python -m rasc``): exit
    with :func:`main`'s status through :func:`rasc.interrupt.exit_process` (status 130
    stays 130)."""
    exit_process(main())


if __name__ == "__main__":
    run()
