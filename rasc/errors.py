"""Exceptions. Every error the command line reports is a :class:`RascError`.

The command line prints ``rasc <command>: error: <message>`` on one line and exits 2,
so messages are single lines that name the problem and where it is (file, position,
field) and, for degenerate data, what data would fix it.
"""


class RascError(Exception):
    """Base class: an error with a one-line, user-facing message."""


class InputError(RascError, ValueError):
    """Malformed or invalid input (file, field, shape, value)."""


class DegenerateDataError(RascError, ValueError):
    """The data cannot determine the requested quantity.

    Raised instead of returning a number; the message says what cannot be determined
    and what data would fix it.
    """


class SolverFailure(RascError):
    """A solver returned no usable number (NaN, infinity, a non-rotation) or did not
    converge. The message names the solver and suggests another."""
