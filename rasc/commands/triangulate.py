"""``rasc triangulate CAL POINTS.csv --angle-unit deg|rad [--method ls|tls] [--out FILE]``.

Matched pixels of both eyes, each with the eyes' pan and tilt, → base-frame points
(eq. 15–19 after undistortion, :meth:`rasc.head.model.HeadCalibration.triangulate`).

POINTS.csv columns (header line required, any order; :mod:`rasc.commands._use_common`):
``u_left, v_left, u_right, v_right`` (measured, distorted pixels; pixel centres are
integers, (0, 0) the top-left pixel), ``pan_left, tilt_left, pan_right, tilt_right`` (in
``--angle-unit``), optional ``label``.

Output (``rasc-triangulation/1``): per point its ``line`` in the file, ``label`` (if
given), ``p_base`` (x, y, z in the calibration's length unit; x up, y forward, z left)
and ``residual_px`` per eye (distance from the measured pixel to the point's
reprojection; null if the point lies behind that camera), ``sigma_base`` (σ per base axis)
and ``covariance_base`` (3x3) from the pixel noise (``--pixel-sigma``, default the
calibration's corner noise) and the calibration's covariance where it has one
(:mod:`rasc.head.uncertainty`); the document's ``uncertainty`` says which. Warned: points
behind a camera and reprojection residuals above :data:`RESIDUAL_WARN_PX`.
"""

from __future__ import annotations

import argparse

from rasc import formats
from rasc.commands import _use_common as common
from rasc.commands import loading
from rasc.errors import DegenerateDataError, InputError

RESULT_FORMAT = formats.TRIANGULATION.tag
COLUMNS = ("u_left", "v_left", "u_right", "v_right",
           "pan_left", "tilt_left", "pan_right", "tilt_right")
#: A matched pair whose triangulated point reprojects this far from either measured pixel
#: is not one point seen twice (a mismatch or wrong angles): corner detectors are good to
#: 0.02–0.5 px, and an exact match reprojects to within ~1e-9 px.
RESIDUAL_WARN_PX = 2.0


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "triangulate", help="matched pixel pairs with pan/tilt -> base-frame points",
        description="Triangulate matched pixels of both eyes (eq. 15-19, undistorted) into "
                    "base-frame points. POINTS.csv columns: u_left,v_left,u_right,v_right,"
                    "pan_left,tilt_left,pan_right,tilt_right[,label].")
    common.add_calibration(p)
    p.add_argument("points", metavar="POINTS.csv", help="matched pixels and angles (CSV)")
    common.add_angle_unit(p, "the pan and tilt columns")
    p.add_argument("--method", choices=("ls", "tls"), default="ls",
                   help="least squares (default) or total least squares (eq. 19)")
    p.add_argument("--pixel-sigma", type=float, metavar="PX",
                   help="noise of each measured pixel coordinate for the points' sigmas "
                        "(default: the calibration's corner noise)")
    common.add_out(p)
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    with loading():  # here, not at module level: building the parser loads no library
        import numpy as np

        from rasc.head.use import reading_warnings, triangulate

    common.check_out(args.out, [args.calibration, args.points])
    cal = common.read_calibration(args.calibration)
    table = common.read_points_csv(args.points, COLUMNS)
    c = table.columns
    ang = {n: common.angles_to_radians(c[n], args.angle_unit, n, table.where)
           for n in COLUMNS[4:]}
    uv_left = np.c_[c["u_left"], c["v_left"]]
    uv_right = np.c_[c["u_right"], c["v_right"]]
    try:
        tri = triangulate(cal.head, uv_left, uv_right, ang["pan_left"], ang["tilt_left"],
                          ang["pan_right"], ang["tilt_right"], method=args.method)
    except DegenerateDataError as exc:
        i = getattr(exc, "index", None)
        where = args.points if i is None else table.where(i)
        raise DegenerateDataError(f"{where}: {exc}") from None
    except InputError as exc:
        raise InputError(f"{args.points}: {exc}") from None
    if not np.all(np.isfinite(tri.p_base)):
        i = int(np.argmax(~np.all(np.isfinite(tri.p_base), axis=1)))
        raise InputError(f"{table.where(i)}: numbers too large to triangulate")
    unc, unc_doc = _uncertainty(args, cal, uv_left, uv_right, ang)
    points = []
    for i in range(tri.p_base.shape[0]):
        entry = {"line": table.lines[i], "p_base": tri.p_base[i],
                 "residual_px": {e: (float(tri.residual_px[e][i]) if tri.in_front[e][i]
                                     else None) for e in ("left", "right")},
                 **({} if unc is None else {"sigma_base": unc.sigma[i],
                                            "covariance_base": unc.total[i]})}
        if table.labels is not None:
            entry["label"] = table.labels[i]
        points.append(entry)
    doc = {"format": RESULT_FORMAT, "calibration": args.calibration, "input": args.points,
           "angle_unit": args.angle_unit, "method": args.method,
           "length_unit": cal.length_unit or "that of the calibration",
           "frame": "base (x up, y forward, z left)", "uncertainty": unc_doc, "points": points}
    common.write_result(doc, args.out)
    readings = {"left": (ang["pan_left"], ang["tilt_left"]),
                "right": (ang["pan_right"], ang["tilt_right"])}
    for warning in reading_warnings(cal, readings, args.angle_unit, where=table.where):
        common.warn("triangulate", warning)
    for eye in ("left", "right"):
        behind = np.nonzero(~tri.in_front[eye])[0]
        if behind.size:
            common.warn("triangulate", f"{behind.size} point(s) triangulate behind the {eye} "
                        f"camera (first: {table.where(int(behind[0]))}); the pixels or angles "
                        "do not belong together")
    res = np.fmax(np.nan_to_num(tri.residual_px["left"], nan=0.0),
                  np.nan_to_num(tri.residual_px["right"], nan=0.0))
    high = np.nonzero(res > RESIDUAL_WARN_PX)[0]
    if high.size:
        worst = int(high[np.argmax(res[high])])
        common.warn("triangulate", f"{high.size} point(s) reproject more than "
                    f"{RESIDUAL_WARN_PX:g} px from their pixels (worst {res[worst]:.3g} px, "
                    f"{table.where(worst)}): mismatched pixels or wrong angles?")
    return 0


def _uncertainty(args, cal, uv_left, uv_right, ang):
    """Each point's covariance (rasc.head.uncertainty) and the document's account of it."""
    import math

    from rasc.head.use import point_covariances

    if args.pixel_sigma is not None and not (math.isfinite(args.pixel_sigma)
                                             and args.pixel_sigma >= 0):
        raise InputError(f"--pixel-sigma: must be a number of pixels >= 0, got "
                         f"{args.pixel_sigma:g}")
    unc, note = point_covariances(args.calibration, cal.head, uv_left, uv_right,
                                  ang["pan_left"], ang["tilt_left"], ang["pan_right"],
                                  ang["tilt_right"], pixel_sigma=args.pixel_sigma,
                                  method=args.method)
    return unc, note
