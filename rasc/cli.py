"""The ``rasc`` command line (also ``python -m rasc``).

Each sub-command lives in its own module under :mod:`rasc.commands` and exposes
``add_parser(subparsers)`` (which sets ``func`` on its parser) and is imported here.
Errors: any :class:`rasc.errors.RascError` is printed as one line,
``rasc <command>: error: <message>``, and the exit status is 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from rasc import __version__
from rasc.errors import RascError
from rasc.interrupt import signals_as_interrupt

#: sub-command modules, in the order ``rasc --help`` lists them
COMMANDS = ("handeye", "render", "calibrate", "triangulate", "project", "look_at", "study")


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``rasc <command>: error: ...``), exit 2."""

    def error(self, message: str):
        if message.endswith("expected one argument"):
            # argparse takes a value starting with '-' for an option: say how to pass one
            message += " (a value starting with '-' is written with '=', e.g. --distortion=-0.2)"
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="rasc", description="Robust Active Stereo Calibration (Neubert & Ferrier 2002).")
    parser.add_argument("--version", action="version", version=f"rasc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"rasc.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"rasc.commands.{name}":
                continue  # not built yet
            raise
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with signals_as_interrupt():
            return int(args.func(args) or 0)
    except RascError as exc:
        msg = str(exc).replace("\n", " ")
        print(f"rasc {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"rasc {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
