"""``rasc look-at CAL (--point X,Y,Z ... | --points FILE.csv) --angle-unit deg|rad [--out FILE]``.

The pan and tilt of each eye that fixate a base-frame point: its image on the principal
point, in front of the camera, solved numerically for the eye's full model
(:func:`rasc.head.use.look_at`: ``least_squares`` on the two angles from eq. 3's closed
form). ``--point`` may be repeated (a value starting with '-' is written
``--point=-0.1,2,0``); ``--points`` reads a CSV with columns ``x, y, z`` and optional
``label`` (:mod:`rasc.commands._use_common`). Coordinates: base frame (x up, y forward,
z left), the calibration's length unit.

Refused (one line, exit 2, nothing written): a point behind the head (base y ≤ 0), at an
optical centre, or unreachable (no angles put it on the principal point). Warned: an
answer outside the pan/tilt range the calibration's pose views spanned (recorded in
``rasc-calibration/1``; a bare ``rasc-head/1`` records none).

Output (``rasc-look-at/1``): per point ``p_base`` (and ``line``/``label`` from a file)
and per eye ``pan``, ``tilt`` (in ``--angle-unit``), ``residual_px`` (distance of the
ideal image from the principal point), ``depth`` and ``within_recorded_range`` (null
when the calibration records no range); and ``recorded_range`` per eye.
"""

from __future__ import annotations

import argparse

from rasc import formats
from rasc.commands import _use_common as common
from rasc.commands import loading
from rasc.errors import InputError
from rasc.geometry.frames import EYES

RESULT_FORMAT = formats.LOOK_AT.tag
#: from this many points (about 1 s at ~5 ms per point and eye) a progress bar is shown
PROGRESS_MIN_POINTS = 100


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "look-at", help="pan and tilt of each eye that fixate a base-frame point",
        description="Solve each eye's pan and tilt that put a base-frame point on its "
                    "principal point.")
    common.add_calibration(p)
    p.add_argument("--point", metavar="X,Y,Z", action="append", default=[],
                   help="a base-frame point (repeatable; write --point=-1,2,3 for a "
                        "leading minus)")
    p.add_argument("--points", metavar="FILE.csv",
                   help="base-frame points, CSV with columns x,y,z[,label]")
    common.add_angle_unit(p, "the output pan and tilt")
    common.add_out(p)
    p.add_argument("--quiet", action="store_true",
                   help=f"no progress bar (shown on stderr from {PROGRESS_MIN_POINTS} points)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    with loading():  # here, not at module level: building the parser loads no library
        import numpy as np

        from rasc.head.use import reading_warnings
        from rasc.progress import progress

    if not args.point and args.points is None:
        raise InputError("no point: give --point X,Y,Z or --points FILE.csv")
    common.check_out(args.out, [args.calibration] + ([args.points] if args.points else []))
    cal = common.read_calibration(args.calibration)
    targets = []  # (p_base, where, extra fields)
    for text in args.point:
        targets.append((common.parse_point_option(text), f"--point {text}", {}))
    if args.points is not None:
        table = common.read_points_csv(args.points, ("x", "y", "z"))
        c = table.columns
        for i in range(len(table.lines)):
            extra = {"line": table.lines[i]}
            if table.labels is not None:
                extra["label"] = table.labels[i]
            targets.append((np.array([c["x"][i], c["y"][i], c["z"][i]]), table.where(i),
                            extra))
    unit = args.angle_unit
    points, fixed = [], []
    quiet = args.quiet or len(targets) < PROGRESS_MIN_POINTS
    with progress(total=len(targets), desc="look-at", unit="point", quiet=quiet) as bar:
        for p, where, extra in targets:
            points.append(_fixate(cal, p, where, extra, unit, fixed))
            bar.update(1)
    recorded = None
    if cal.joint_range is not None:
        recorded = {eye: {j: [common.angle_out(a, unit) for a in cal.joint_range[eye][j]]
                          for j in ("pan", "tilt")} for eye in EYES}
    doc = {"format": RESULT_FORMAT, "calibration": args.calibration, "angle_unit": unit,
           "length_unit": cal.length_unit or "that of the calibration",
           "recorded_range": recorded, "points": points}
    common.write_result(doc, args.out)
    wheres = [where for _, where, _ in targets]
    readings = {eye: ([fix.pan for w, e, fix in fixed if e == eye],
                      [fix.tilt for w, e, fix in fixed if e == eye]) for eye in EYES}
    for warning in reading_warnings(cal, readings, unit, where=wheres.__getitem__):
        common.warn("look-at", warning)
    return 0


def _fixate(cal, p, where: str, extra: dict, unit: str, fixed: list) -> dict:
    """One point's entry; appends (where, eye, fixation) to ``fixed``."""
    from rasc.head.use import look_at, outside_range

    entry = {"p_base": p, **extra}
    for eye in EYES:
        try:
            fix = look_at(getattr(cal.head, eye), p)
        except InputError as exc:
            raise InputError(f"{where}: {eye} eye: {exc}") from None
        within = None
        if cal.joint_range is not None:
            span = cal.joint_range[eye]
            within = not (outside_range(fix.pan, span["pan"])
                          or outside_range(fix.tilt, span["tilt"]))
        fixed.append((where, eye, fix))
        entry[eye] = {"pan": common.angle_out(fix.pan, unit),
                      "tilt": common.angle_out(fix.tilt, unit),
                      "residual_px": fix.residual_px, "depth": fix.depth,
                      "within_recorded_range": within}
    return entry
