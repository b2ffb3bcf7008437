"""``rasc handeye POSES.json [--method M] [--out FILE]``: gaze→camera calibration.

Reads a ``rasc-handeye/1`` document (:mod:`rasc.handeye.document`), solves ``A X = X B`` for
``X = T_cam_from_gaze`` with the chosen method (RASC, docs/METHOD.md §3, by default) and writes the
result as deterministic JSON to ``--out`` (atomically) or to stdout. The output path is
checked before anything is read or solved; on any error no output file appears.

Output (``rasc-handeye-result/1``): ``T_cam_from_gaze`` (4×4) and its inverse
``T_gaze_from_cam`` (OpenCV's ``cam2gripper``), translations in the input's length unit;
``quality`` (eq. 10) with a note; the solver's ``diagnostics``; ``method``,
``n_positions``, ``input`` (the path as given), ``angle_unit``, ``length_unit``,
``uncertainty`` (the estimated error, :func:`rasc.handeye.methods.jackknife_uncertainty`), and
``home`` with ``--method li``. Each of :func:`rasc.handeye.solver.solution_warnings` (a quality
above 1, motions mostly about one axis, a large estimated error, a camera looking
backwards) adds a warning line on stderr; the exit status stays 0.

The method goes through the outlier policy ``rasc calibrate`` uses
(:func:`rasc.handeye.robust_calibrate.closed_form`): with "rasc", the default, a solution
the consistency checks flag is replaced by ``rasc-robust``'s when it rejects positions;
the output's ``method`` is then "rasc-robust", its ``robust`` block says why, and the
policy's note is a warning. Any other method is used as it is.

A document with a ``unit_stream`` (two timestamped streams, :mod:`rasc.handeye.document`)
goes to :func:`rasc.handeye.time_offset.solve_streams`: the clocks' offset is estimated
(``--time-offset estimate``, the default) or held (``hold``: 0, or a number of seconds),
searched within ``--max-time-offset``, and the result is always refined; a line on
stderr gives the offset and its σ, the output a ``time_offset`` block, and
``uncertainty`` comes from the refinement's covariance.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from rasc import formats
from rasc.commands import loading
from rasc.errors import DegenerateDataError, InputError, RascError, SolverFailure

if TYPE_CHECKING:
    from rasc.handeye.document import HandEyeInput

RESULT_FORMAT = formats.HANDEYE_RESULT.tag

#: The built-in names of rasc.handeye.methods.METHODS, listed here so that building the
#: parser imports no solver (and no cv2); a test checks that they match.
METHOD_NAMES = ("rasc", "li", "rasc-inverse", "rasc-views", "rasc-robust", "rasc-scale",
                "opencv-park", "opencv-tsai",
                "opencv-horaud", "opencv-andreff", "opencv-daniilidis")

#: --method's help, shared with ``rasc calibrate``.
METHOD_HELP = ("hand-eye method: a built-in name (" + ", ".join(METHOD_NAMES) + "), "
               "package.module:function, or a name an installed package registers in the "
               "rasc.methods entry points (default: rasc, the paper's method, replaced by "
               "rasc-robust when its solution fails the consistency checks and rasc-robust "
               "rejects positions; any other name is used as it is)")

#: rasc.handeye.time_offset.DEFAULT_MAX_OFFSET, written here so that building the parser
#: imports no solver; a test checks that they match.
DEFAULT_MAX_OFFSET = 0.5

QUALITY_NOTE = ("eq. 10: mean over ordered pairs i != j of ||X B_ij X^T - A_ij||_F; "
                "0 is a perfect fit, the paper found solutions above 1 unusable")


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "handeye",
        help="gaze->camera (hand-eye) calibration from target poses and pan/tilt angles",
        description=("Solve T_cam_from_gaze from a POSES.json document (format "
                     "rasc-handeye/1: 'positions' with pan/tilt or T_gaze_from_ptu, and "
                     "T_cam_from_world each; see README). The result's translation is in "
                     "the input's length unit."))
    parser.add_argument("poses", metavar="POSES.json", help="input document (rasc-handeye/1)")
    parser.add_argument("--method", metavar="M", default="rasc", help=METHOD_HELP)
    parser.add_argument("--home", metavar="K", type=int,
                        help="li only: index of the home position in 'positions' (default: "
                             "the position at pan = tilt = 0, else the first)")
    parser.add_argument("--refine", action="store_true",
                        help="refine the method's result on the pose residuals (rotation "
                             "and translation jointly, robust loss) and report its "
                             "covariance (rasc.handeye.robust_refine)")
    parser.add_argument("--time-offset", metavar="T", default=None,
                        help="POSES.json with a unit_stream (two timestamped streams) "
                             "only: 'estimate' (the default) estimates the offset between "
                             "the clocks with its std, 'hold' holds it at 0, a number holds "
                             "it at that many seconds (the unit's clock minus the camera's; "
                             "rasc.handeye.time_offset)")
    parser.add_argument("--max-time-offset", metavar="S", type=float, default=None,
                        help="with a unit_stream: search the offset within ±S seconds "
                             f"(default {DEFAULT_MAX_OFFSET:g})")
    parser.add_argument("--out", metavar="FILE",
                        help="write the result JSON here (atomically) instead of stdout")
    parser.set_defaults(func=run)
    return parser


def _solver(method: str):
    """The resolved method (rasc.handeye.methods.get_method): a callable
    ``(T_cam_from_world, T_gaze_from_ptu, **options) -> HandEyeResult``."""
    from rasc.handeye.methods import get_method  # imported when needed: cv2 only by opencv-*

    return get_method(method)


def result_document(data: HandEyeInput, result, *, source: str, method: str,
                    home: int | None = None) -> dict:
    """The output JSON object (``rasc-handeye-result/1``); ``home``: Li's home position."""
    import numpy as np

    from rasc.geometry.transforms import invert_transform

    T = np.asarray(result.T_cam_from_gaze, dtype=float)
    quality = float(result.quality)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)) or not np.isfinite(quality):
        other = "li" if method == "rasc" else "rasc"
        raise SolverFailure(f"{source}: method {method} returned a non-finite result (NaN or "
                            f"infinity); check the positions' translations (one length "
                            f"unit for all), or try --method {other}")
    diagnostics = result.to_dict().get("diagnostics")
    return {
        "format": RESULT_FORMAT,
        "input": source,
        "method": method,
        "n_positions": data.n_positions,
        "T_cam_from_gaze": T,
        "T_gaze_from_cam": invert_transform(T),
        "quality": quality,
        "quality_note": QUALITY_NOTE,
        "diagnostics": diagnostics,
        "angle_unit": data.angle_unit,
        "length_unit": data.length_unit or "same as the input's T_cam_from_world translations",
        **({} if home is None else {"home": home}),
        # rasc-robust's rejections, rasc-scale's scale, --refine's covariance
        **{k: v for k, v in result.to_dict().items() if k in ("robust", "scale", "refinement",
                                                        "time_offset")},
    }


def run(args: argparse.Namespace) -> int:
    with loading():  # here, not at module level: building the parser loads no library
        from rasc.guard import PluginExited, PluginTimedOut
        from rasc.handeye.advice import input_warnings, solution_warnings, translation_warnings
        from rasc.handeye.document import load_handeye_input
        from rasc.handeye.li import NO_HOME_POSE, has_home_pose, home_index
        from rasc.handeye.methods import PluginError, jackknife_uncertainty
        from rasc.handeye.robust_calibrate import closed_form
        from rasc.io import check_outputs, dumps_json, write_json_atomic, write_stdout

    source = args.poses
    # the output rule, before reading or solving
    check_outputs([("--out", args.out, "file", ())], inputs=[source])
    if args.home is not None and args.method != "li":
        raise InputError(f"--home {args.home}: only --method li uses a home position")
    solve = _solver(args.method)  # an unknown name or a broken plugin: before reading
    stream_options = _stream_options(args)  # a malformed --time-offset: before reading
    data = load_handeye_input(source)
    if data.is_stream:
        return _run_streams(args, data, stream_options)
    for flag, value in (("--time-offset", args.time_offset),
                        ("--max-time-offset", args.max_time_offset)):
        if value is not None:
            raise InputError(f"{flag}: {source} has no unit_stream (timestamped unit poses); "
                             "the time offset is only estimated between two streams")
    kwargs = {} if args.home is None else {"home": args.home}
    try:
        # the outlier policy rasc calibrate uses: rasc, or rasc-robust when the data ask
        closed = closed_form(solve, data.T_cam_from_world, data.T_gaze_from_ptu,
                             names=[label or f"positions[{k}]"
                                    for k, label in enumerate(data.labels)], **kwargs)
    except (PluginError, PluginExited, PluginTimedOut):
        raise  # names the plugin and what it did; the input is not at fault
    except DegenerateDataError as exc:
        raise DegenerateDataError(f"{source}: {exc}") from None
    except RascError as exc:
        raise RascError(f"{source}: {exc}") from None
    result, method = closed.result, closed.method if closed.switched else args.method
    if closed.switched:
        solve = _solver(method)     # the jackknife repeats the method that was used
    if args.refine:
        from rasc.handeye.robust_refine import refine_handeye

        try:
            result = refine_handeye(data.T_cam_from_world, data.T_gaze_from_ptu, result)
        except RascError as exc:
            raise type(exc)(f"{source}: --refine: {exc}") from None
    home, notes = None, list(closed.notes)
    if args.method == "li":
        home = home_index(data.T_gaze_from_ptu) if args.home is None else args.home
        if args.home is None and data.from_angles and not has_home_pose(data.T_gaze_from_ptu):
            notes.append(f"{NO_HOME_POSE}; give --home K or add the (0, 0) position")
    doc = result_document(data, result, source=source, method=method, home=home)
    uncertainty = jackknife_uncertainty(solve, data.T_cam_from_world,
                                        data.T_gaze_from_ptu, result, **kwargs)
    doc["uncertainty"] = uncertainty.to_dict()
    if args.out is None:
        write_stdout(dumps_json(doc))
    else:
        write_json_atomic(args.out, doc)
    for warning in notes + input_warnings(data.T_cam_from_world, data.T_gaze_from_ptu) + \
            solution_warnings(result, uncertainty=uncertainty, pan_tilt=data.from_angles) + \
            translation_warnings(data.T_cam_from_world, data.T_gaze_from_ptu, result):
        print(f"rasc handeye: warning: {warning}", file=sys.stderr)
    return 0



def _stream_options(args: argparse.Namespace):
    """The :class:`rasc.handeye.time_offset.TimeOffsetOptions` of the flags (checked
    before anything is read)."""
    from rasc.handeye.time_offset import TimeOffsetOptions

    fields = {"method": args.method}
    if args.time_offset is not None:
        fields["time_offset"] = args.time_offset
    if args.max_time_offset is not None:
        fields["max_offset"] = args.max_time_offset
    try:
        return TimeOffsetOptions(**fields)
    except InputError as exc:
        text = str(exc).replace("time_offset", "--time-offset", 1) \
            .replace("max_offset", "--max-time-offset", 1)
        raise InputError(text) from None


def _run_streams(args: argparse.Namespace, data: HandEyeInput, options) -> int:
    """Two timestamped streams: hand-eye and the time offset, always refined
    (:func:`rasc.handeye.time_offset.solve_streams`)."""
    from rasc.handeye.advice import input_warnings, solution_warnings
    from rasc.handeye.time_offset import solve_streams
    from rasc.io import dumps_json, write_json_atomic, write_stdout

    source = args.poses
    if args.home is not None:
        raise InputError(f"--home {args.home}: {source} has a unit_stream; the closed form "
                         "there starts from camera poses spread over the streams, without a "
                         "home position")
    try:
        result = solve_streams(data.times, data.T_cam_from_world, data.unit_times,
                               data.unit_stream, options)
    except RascError as exc:
        raise type(exc)(f"{source}: {exc}") from None
    doc = result_document(data, result, source=source, method=result.method)
    doc["uncertainty"] = {
        "method": "covariance of the joint refinement (the time offset's uncertainty "
                  "included)",
        "rotation_deg": result.std_rotation_deg, "translation": result.std_translation}
    if args.out is None:
        write_stdout(dumps_json(doc))
    else:
        write_json_atomic(args.out, doc)
    ms = 1e3 * result.time_offset
    if result.time_offset_mode == "estimate":
        line = (f"time offset {ms:+.3f} ms ± {1e3 * result.std_time_offset:.3f} ms (the "
                "unit's clock minus the camera's")
    else:
        line = f"time offset held at {ms:+.3f} ms (the unit's clock minus the camera's"
    print(f"rasc handeye: {line}; {result.n_used} of {result.n_camera} camera poses)",
          file=sys.stderr)
    for warning in input_warnings(data.T_cam_from_world) + list(result.notes) + \
            solution_warnings(result, pan_tilt=data.from_angles):
        print(f"rasc handeye: warning: {warning}", file=sys.stderr)
    return 0
