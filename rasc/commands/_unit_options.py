"""Shared by ``rasc render`` and ``rasc plan``: how a command is told the pan-tilt units'
imperfections — a unit parameter file (``--unit FILE``,
:func:`rasc.sim.units.read_unit_file`) and the options for both units that override it
(``--tilt-axis-offset``, ``--axis-skew``, ``--encoder-zero``). One set of options, one
reader: ``rasc plan --unit u.toml`` plans for the head ``rasc render --unit u.toml``
renders.
"""

from __future__ import annotations

import argparse

from rasc.errors import InputError


def add_unit_arguments(p: argparse.ArgumentParser, default: str) -> None:
    """The unit options; ``default`` says what the command does without them."""
    p.add_argument("--unit", metavar="FILE",
                   help="TOML file of pan-tilt unit imperfections, tables [both], [left], "
                        "[right] (the guide's 'Imperfect units', docs/guide/calibrate.md); "
                        f"default: {default}")
    p.add_argument("--tilt-axis-offset", default="", metavar="X,Y,Z",
                   help="both units: a point of the tilt axis in the tilt link's frame (x up, "
                        "y forward, z left), millimetres, e.g. 0,30,0 (overrides --unit; with '=' "
                        "when it starts with '-')")
    p.add_argument("--axis-skew", type=float, default=None, metavar="DEG",
                   help="both units: tilt axis turned towards the pan axis, degrees (the "
                        "axes meet at 90 - DEG degrees; overrides --unit)")
    p.add_argument("--encoder-zero", default="", metavar="PAN,TILT",
                   help="both units: encoder zero offsets in degrees, joint angle = reading + "
                        "offset (overrides --unit; --encoder-zero=-0.5,0.2 when it starts "
                        "with '-')")


def given(args: argparse.Namespace) -> list[str]:
    """The unit options given on the command line (their flags)."""
    return [flag for flag, value in (("--unit", args.unit),
                                     ("--tilt-axis-offset", args.tilt_axis_offset.strip()),
                                     ("--axis-skew", args.axis_skew),
                                     ("--encoder-zero", args.encoder_zero.strip()))
            if value not in (None, "")]


def units_from_args(args: argparse.Namespace) -> dict | None:
    """{eye: UnitBuild} from ``--unit FILE`` and the options for both units, or None."""
    from rasc.io import finite_numbers
    from rasc.sim.units import IDEAL_BUILD, MAX_SKEW_DEG, merge, read_unit_file

    units = read_unit_file(args.unit) if args.unit else None
    changes: dict = {}
    if args.tilt_axis_offset.strip():
        changes["tilt_axis_offset_mm"] = finite_numbers(
            args.tilt_axis_offset, "--tilt-axis-offset", count=3, what="X,Y,Z in millimetres",
            text=True)
    if args.axis_skew is not None:
        if not abs(args.axis_skew) < MAX_SKEW_DEG:
            raise InputError(f"--axis-skew: expected a finite angle within "
                             f"±{MAX_SKEW_DEG:g} degrees, got {args.axis_skew}")
        changes["axis_skew_deg"] = args.axis_skew
    if args.encoder_zero.strip():
        changes["pan_zero_deg"], changes["tilt_zero_deg"] = finite_numbers(
            args.encoder_zero, "--encoder-zero", count=2, what="PAN,TILT in degrees", text=True)
    if changes:
        units = {eye: merge((units or {}).get(eye, IDEAL_BUILD), **changes)
                 for eye in ("left", "right")}
    return units
