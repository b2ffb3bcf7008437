"""``rasc project CAL POINTS.csv --angle-unit deg|rad [--out FILE]``: base points → pixels.

POINTS.csv columns (header line required, any order; :mod:`rasc.commands._use_common`):
``x, y, z`` (base frame: x up, y forward, z left; the calibration's length unit) and, for
each eye to project into, both ``pan_<eye>`` and ``tilt_<eye>`` (``<eye>`` = ``left`` or
``right``, in ``--angle-unit``); at least one eye; optional ``label``.

Output (``rasc-projection/1``): per point its ``line``, ``label`` (if given), ``p_base``
and, per eye, ``uv`` (the distorted pixel, as a camera would record it; null when the
point is at or behind the camera), ``in_front`` (depth along the optical axis > 0),
``in_image`` (in front, inside ``-0.5 ≤ u ≤ width − 0.5`` and ``-0.5 ≤ v ≤ height − 0.5``,
and not a lens-model fold: :func:`rasc.head.use.project_eye`) and ``depth``.
"""

from __future__ import annotations

import argparse

from rasc import formats
from rasc.commands import _use_common as common
from rasc.commands import loading
from rasc.errors import InputError
from rasc.geometry.frames import EYES

RESULT_FORMAT = formats.PROJECTION.tag


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "project", help="base-frame points with pan/tilt -> each eye's pixels",
        description="Project base-frame points into one or both eyes. POINTS.csv columns: "
                    "x,y,z and pan_left,tilt_left and/or pan_right,tilt_right[,label].")
    common.add_calibration(p)
    p.add_argument("points", metavar="POINTS.csv", help="base-frame points and angles (CSV)")
    common.add_angle_unit(p, "the pan and tilt columns")
    common.add_out(p)
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    with loading():  # here, not at module level: building the parser loads no library
        import numpy as np

        from rasc.head.use import project_eye, reading_warnings

    common.check_out(args.out, [args.calibration, args.points])
    cal = common.read_calibration(args.calibration)
    table = common.read_points_csv(
        args.points, ("x", "y", "z"), tuple(f"{a}_{e}" for e in EYES for a in ("pan", "tilt")))
    c = table.columns
    eyes = []
    for eye in EYES:
        have = [f"{a}_{eye}" in c for a in ("pan", "tilt")]
        if any(have) and not all(have):
            missing = f"{('pan', 'tilt')[have.index(False)]}_{eye}"
            raise InputError(f"{args.points}: missing column {missing!r} (the {eye} eye "
                             "needs both pan and tilt)")
        if all(have):
            eyes.append(eye)
    if not eyes:
        raise InputError(f"{args.points}: no eye to project into: give pan_left,tilt_left "
                         "and/or pan_right,tilt_right columns")
    p_base = np.c_[c["x"], c["y"], c["z"]]
    views, readings = {}, {}
    for eye in eyes:
        pan = common.angles_to_radians(c[f"pan_{eye}"], args.angle_unit, f"pan_{eye}",
                                       table.where)
        tilt = common.angles_to_radians(c[f"tilt_{eye}"], args.angle_unit, f"tilt_{eye}",
                                        table.where)
        readings[eye] = (pan, tilt)
        try:
            views[eye] = project_eye(getattr(cal.head, eye), p_base, pan, tilt)
        except InputError as exc:
            raise InputError(f"{args.points}: {eye} eye: {exc}") from None
    points = []
    for i in range(p_base.shape[0]):
        entry = {"line": table.lines[i], "p_base": p_base[i]}
        if table.labels is not None:
            entry["label"] = table.labels[i]
        for eye, v in views.items():
            entry[eye] = {"uv": v.uv[i] if v.in_front[i] else None,
                          "in_front": bool(v.in_front[i]), "in_image": bool(v.in_image[i]),
                          "depth": float(v.depth[i])}
        points.append(entry)
    doc = {"format": RESULT_FORMAT, "calibration": args.calibration, "input": args.points,
           "angle_unit": args.angle_unit,
           "length_unit": cal.length_unit or "that of the calibration",
           "image_size": {eye: list(getattr(cal.head, eye).image_size) for eye in eyes},
           "points": points}
    common.write_result(doc, args.out)
    for warning in reading_warnings(cal, readings, args.angle_unit, where=table.where):
        common.warn("project", warning)
    return 0
