"""Shared by ``rasc triangulate``, ``rasc project`` and ``rasc look-at``: the calibration and
points files, angle units, and the output rule.

Points files are CSV (comma-separated, UTF-8, an optional byte-order mark): the first
non-comment line is a header naming the columns, in any order; lines starting with ``#``
and blank lines are skipped; every other line holds one point, one finite decimal number
per column (``nan``, ``inf`` and empty cells are refused). An optional ``label`` column
is free text, echoed in the output. Any other column name is an error (a misspelt
``pan_lfet`` is never silently ignored).
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rasc.errors import InputError

if TYPE_CHECKING:
    import numpy as np

ANGLE_UNITS = ("deg", "rad")
#: largest |angle| in each unit: one full turn (rasc.head.model.MAX_ABS_ANGLE_RAD)
MAX_ABS_ANGLE = {"deg": 360.0, "rad": 2.0 * math.pi}
#: largest |coordinate| or |pixel| accepted: far beyond any scene or image, small enough
#: that squares and products of a few such numbers stay finite and exact to ~1e-16.
MAX_ABS_VALUE = 1e12
#: Largest points file read, bytes: about ten million points.
MAX_CSV_BYTES = 1 << 30


def add_calibration(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("calibration", metavar="CAL",
                        help="calibration JSON (rasc-calibration/1 from rasc calibrate, or "
                             "rasc-head/1)")


def add_angle_unit(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--angle-unit", required=True, choices=ANGLE_UNITS,
                        help=f"unit of {what} (required: deg or rad)")


def add_out(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", metavar="FILE",
                        help="write the result JSON here (atomically) instead of stdout")


def check_out(out: str | None, inputs: list[str]) -> None:
    """Before any work: ``--out`` obeys the output rule (:func:`rasc.io.check_outputs`)."""
    from rasc.io import check_outputs

    check_outputs([("--out", out, "file", ())], inputs=inputs)


def write_result(doc: dict, out: str | None) -> None:
    from rasc.io import dumps_json, write_json_atomic, write_stdout

    if out is None:
        write_stdout(dumps_json(doc))
    else:
        write_json_atomic(out, doc)


def warn(command: str, message: str) -> None:
    print(f"rasc {command}: warning: {message}", file=sys.stderr)


def read_calibration(path: str):
    """The calibration file (:func:`rasc.head.use.read_calibration`)."""
    from rasc.head.use import read_calibration as _read

    return _read(path)


@dataclass(frozen=True)
class Table:
    """A points file: ``columns[name]`` (N,) floats, ``labels`` (N,) str or None,
    ``lines`` (N,) the file's line number of each point (1-based)."""

    path: str
    columns: dict[str, np.ndarray]
    labels: list[str] | None
    lines: list[int]

    def where(self, i: int) -> str:
        return f"{self.path}: line {self.lines[i]}"


def read_points_csv(path: str, required: tuple[str, ...],
                    optional: tuple[str, ...] = ()) -> Table:
    """Read a CSV points file (module docstring) with these numeric columns."""
    import numpy as np

    from rasc.io import finite_number, read_text_file

    text = read_text_file(path, "CSV points file", MAX_CSV_BYTES)
    if "\x00" in text:
        raise InputError(f"{path}: contains a NUL byte; not a text CSV file")
    try:
        rows = list(csv.reader(io.StringIO(text, newline="")))
    except csv.Error as exc:
        raise InputError(f"{path}: malformed CSV: {exc}") from None
    # csv.reader yields one row per record; map each record back to its line number
    numbered, line = [], 1
    for row in rows:
        numbered.append((line, row))
        line += sum(cell.count("\n") for cell in row) + 1
    body = [(n, r) for n, r in numbered
            if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    allowed = tuple(required) + tuple(optional) + ("label",)
    if not body:
        raise InputError(f"{path}: no header line; expected columns {','.join(required)}")
    header_line, header = body[0]
    names = [c.strip() for c in header]
    for name in names:
        if name not in allowed:
            raise InputError(f"{path}: line {header_line}: unknown column {name!r} "
                             f"(expected {', '.join(allowed)})")
    for name in set(names):
        if names.count(name) > 1:
            raise InputError(f"{path}: line {header_line}: column {name!r} appears twice")
    missing = [c for c in required if c not in names]
    if missing:
        raise InputError(f"{path}: line {header_line}: missing column {missing[0]!r} "
                         f"(required: {', '.join(required)})")
    if len(body) < 2:
        raise InputError(f"{path}: no points after the header")
    numeric = [c for c in names if c != "label"]
    values: dict[str, list[float]] = {c: [] for c in numeric}
    labels: list[str] = []
    lines: list[int] = []
    for n, row in body[1:]:
        if len(row) != len(names):
            raise InputError(f"{path}: line {n}: {len(row)} fields, the header has "
                             f"{len(names)}")
        for name, cell in zip(names, row, strict=True):
            if name == "label":
                labels.append(cell.strip())
                continue
            values[name].append(finite_number(cell, f"{path}: line {n}, column {name}",
                                              text=True, max_abs=MAX_ABS_VALUE))
        lines.append(n)
    columns = {c: np.array(v, dtype=float) for c, v in values.items()}
    return Table(path, columns, labels if "label" in names else None, lines)


def angles_to_radians(values: np.ndarray, unit: str, name: str, where) -> np.ndarray:
    """Angles in ``unit`` → radians; refuse values beyond one turn, suggesting the other
    unit. ``where(i)`` names point i (file and line, or option)."""
    import numpy as np

    limit = MAX_ABS_ANGLE[unit]
    big = np.abs(values) > limit
    if np.any(big):
        i = int(np.argmax(big))
        hint = ("; are these degrees? use --angle-unit deg" if unit == "rad"
                else "; a pan-tilt joint turns less than a full turn")
        raise InputError(f"{where(i)}: {name} = {values[i]:g} {unit} is beyond "
                         f"±{limit:g} {unit}{hint}")
    return np.radians(values) if unit == "deg" else values.astype(float)


def angle_out(radians: float, unit: str) -> float:
    import numpy as np

    return float(np.degrees(radians)) if unit == "deg" else float(radians)


def parse_point_option(text: str) -> np.ndarray:
    """``--point X,Y,Z`` → (3,) floats."""
    import numpy as np

    from rasc.io import finite_number

    parts = text.split(",")
    if len(parts) != 3:
        raise InputError(f"--point {text}: expected X,Y,Z (three comma-separated numbers)")
    return np.array([finite_number(s, f"--point {text}", text=True, max_abs=MAX_ABS_VALUE)
                     for s in parts])
