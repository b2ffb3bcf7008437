"""``rasc calibrate DATASET [--out FILE]``: calibrate the whole head from a dataset.

detection → intrinsics → extrinsics → hand-eye per eye → base-to-ptu → (``--model
general``, the default) whole-head refinement → one JSON calibration
(``rasc-calibration/1``, :mod:`rasc.head.pipeline`); with ground truth in the dataset,
also the errors against it. Written atomically; on any error, no file. ``--report``:
the report too (:mod:`rasc.report`); a report that cannot be written after the
calibration was is one error line (exit 2) saying so and keeping the calibration.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from rasc import formats
from rasc.commands import loading
from rasc.commands.handeye import METHOD_HELP
from rasc.errors import InputError, RascError
from rasc.head import options as calopts
from rasc.interrupt import Interrupted

if TYPE_CHECKING:
    import numpy as np

#: The --mounts file: {"format": "rasc-mounts/1" (optional), "T_ptuL_from_ptuR": 4x4 (the
#: right unit's frame in the left one, translation in the unit of board.square_size),
#: "description": free text (optional)}; any other key is an error.
MOUNTS_FORMAT = formats.MOUNTS.tag
MOUNTS_KEYS = ("format", "T_ptuL_from_ptuR", "description")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "calibrate", help="calibrate the whole head from a dataset (images + manifest)",
        description="Detect the board, calibrate intrinsics, per-pose extrinsics, hand-eye "
                    "per eye (RASC) and base-to-ptu; write one JSON calibration.")
    p.add_argument("dataset", metavar="DATASET", help="dataset folder (with manifest.json)")
    p.add_argument("--out", metavar="FILE", help="output JSON (default: stdout)")
    p.add_argument("--method", metavar="M", default=calopts.default("method"),
                   help=METHOD_HELP + "; with --model general its closed form seeds the "
                        "whole-head refinement (the calibration records it beside the "
                        "refined result, refinement.seed)")
    p.add_argument("--detector", default=calopts.default("detector"),
                   choices=calopts.DETECTORS,
                   help="corner detector (default saddle: classic + saddle-point refinement)")
    p.add_argument("--dist-model", default=calopts.default("dist_model"),
                   choices=calopts.DIST_MODEL_NAMES,
                   help="lens model (default k1k2): pinhole with k1 k2 (k1k2), k1 k2 p1 p2 "
                        "k3 (opencv5), OpenCV's rational k1-k6 p1 p2 (rational) or none; "
                        "fisheye: OpenCV's equidistant k1-k4 (docs/topics/lenses.md)")
    p.add_argument("--keep-outliers", action="store_true",
                   help="keep intrinsics views flagged as outliers")
    p.add_argument("--mounts", metavar="FILE",
                   help="measured mounts: JSON {\"T_ptuL_from_ptuR\": 4x4} (the right "
                        "unit's frame in the left one, translation in the unit of the "
                        "board's square_size; optional \"format\": \"rasc-mounts/1\", "
                        "\"description\"); used instead of loop closure, and compared "
                        "with it")
    p.add_argument("--model", default=calopts.default("model"), choices=calopts.MODELS,
                   help="pan-tilt model: 'paper' = the closed form with the paper's unit "
                        "(eq. 3); 'general' = the closed form refined over every corner "
                        "with a general unit per eye, each parameter with its standard "
                        "deviation (default general)")
    p.add_argument("--scales", choices=calopts.SCALES_MODES, default=None,
                   help="with --model general, the pan and tilt encoder scales: 'auto' "
                        "(default) holds them at 1 unless the corners reject 1 (an F "
                        "test), 'estimate', or 'hold' at 1")
    p.add_argument("--time-offset", choices=calopts.TIME_OFFSET_MODES, default=None,
                   help="with --model general, the offset between the camera and encoder "
                        "clocks of a continuous capture (pose images with times and a "
                        "joint stream, rasc import --continuous): 'auto' (default) "
                        "estimates it when the dataset has a joint stream, 'estimate' "
                        "requires one, 'hold' keeps it at 0")
    p.add_argument("--min-corners", type=int, default=calopts.default("min_corners"), metavar="N",
                   help="a target seen in part (ChArUco): the fewest corners a view must "
                        "show to be used; views with fewer are skipped (default 8)")
    p.add_argument("--plots", metavar="DIR",
                   help="with --model general: write residual plots residuals_left.png, "
                        "residuals_right.png into DIR")
    p.add_argument("--report", metavar="FILE.pdf",
                   help="also write the calibration report (as rasc report does)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)
    return p


def _read_mounts(path: str) -> np.ndarray:
    from rasc.geometry.transforms import validate_rigid_transform
    from rasc.io import read_json_document

    obj = read_json_document(path, "mounts file")
    if not isinstance(obj, dict) or "T_ptuL_from_ptuR" not in obj:
        raise InputError(f"{path}: expected an object with field T_ptuL_from_ptuR (4x4)")
    unknown = [key for key in obj if key not in MOUNTS_KEYS]
    if unknown:
        raise InputError(f"{path}: unknown key {unknown[0]!r}; allowed: "
                         + ", ".join(MOUNTS_KEYS))
    if "format" in obj and obj["format"] != MOUNTS_FORMAT:
        raise InputError(f"{path}: format = {obj['format']!r}: expected {MOUNTS_FORMAT!r}")
    return validate_rigid_transform(obj["T_ptuL_from_ptuR"], name=f"{path}: T_ptuL_from_ptuR")


#: how the options' fields are written on this command line (for the library's messages)
FLAGS = {"method": "--method", "detector": "--detector", "dist_model": "--dist-model",
         "model": "--model", "scales": "--scales", "T_ptuL_from_ptuR_measured": "--mounts",
         "exclude_outliers": "--keep-outliers", "min_corners": "--min-corners",
         "time_offset": "--time-offset"}


def run(args: argparse.Namespace) -> int:
    with loading():  # here, not at module level: building the parser loads no library
        from rasc.head.pipeline import CalibrationOptions, calibrate_dataset, format_length
        from rasc.head.plots import PLOT_FILES
        from rasc.head.use import dataset_reference
        from rasc.io import check_outputs, dumps_json, write_json_atomic, write_stdout
        from rasc.vision.dataset import load_dataset

    if args.plots and args.model != "general":
        raise InputError("--plots: residual plots come from the whole-head refinement; "
                         "use them with --model general")
    outputs = [("--out", args.out, "file", ()), ("--plots", args.plots, "folder", PLOT_FILES),
               ("--report", args.report, "file", ())]
    check_outputs(outputs, inputs=[args.dataset, args.mounts])   # before any long work
    mounts = _read_mounts(args.mounts) if args.mounts else None
    options = CalibrationOptions(method=args.method, detector=args.detector,
                                 dist_model=args.dist_model,
                                 exclude_outliers=not args.keep_outliers,
                                 T_ptuL_from_ptuR_measured=mounts, model=args.model,
                                 scales=args.scales, time_offset=args.time_offset,
                                 min_corners=args.min_corners).validate(FLAGS)
    dataset = load_dataset(Path(args.dataset))
    check_outputs(outputs, inputs=[dataset.manifest_path, dataset.ground_truth, args.mounts,
                                   *(e.path for e in dataset.images)],
                  input_folders=[dataset.root])

    def log(msg: str) -> None:
        if not args.quiet:
            print(f"calibrate: {msg}", file=sys.stderr, flush=True)

    cal = calibrate_dataset(dataset, options, log=log)
    doc = cal.to_dict()
    doc["dataset"] = dataset_reference(args.dataset, args.out)   # from cal.json's folder
    if args.out is not None:
        write_json_atomic(args.out, doc)
    else:
        write_stdout(dumps_json(doc))
    # the calibration is written: from here an interrupt or a failed report keeps it
    kept = [args.out or "the calibration (standard output)"]
    report_failed = None
    try:
        if args.plots and cal.refinement is not None:
            from rasc.head.plots import residual_plots

            for path in residual_plots(cal.refinement, args.plots):
                log(f"wrote {path}")
                kept.append(str(path))
        if args.report is not None:
            report_failed = _write_report(doc, args, dataset, kept)
    except KeyboardInterrupt:
        raise Interrupted(f"kept {', '.join(kept)}"
                          + (f"; the report {args.report} was not written"
                             if args.report is not None else "")) from None
    for warning in cal.warnings:    # warnings, not progress: printed even with --quiet
        print(f"rasc calibrate: warning: {warning}", file=sys.stderr)
    if not args.quiet:
        for eye in ("left", "right"):
            r = cal.eyes[eye]
            line = (f"{eye}: intrinsics RMS {r.intrinsics.rms:.3f} px, quality "
                    f"{r.handeye.quality:.2e}")
            if cal.errors:
                e = cal.errors[eye]["T_cam_from_gaze"]
                line += (f", T_cam_from_gaze error {e['rotation_deg']:.4f} deg "
                         f"{format_length(e['translation'], cal.length_unit)}")
            log(line)
        res = cal.refinement
        if res is not None:
            log(f"refinement: reprojection RMS {res.rms_before:.3f} px (closed form) -> "
                f"{res.rms_after:.4f} px over {res.n_corners - res.n_rejected} corners, "
                f"{res.n_rejected} rejected, {cal.timings.get('refinement', res.seconds):.2f} s; "
                f"encoder scales {'estimated' if res.scales.get('estimated') else 'held at 1'}")
            for eye in ("left", "right"):
                u = res.parameters[eye]
                d, a = u.get("unit.tilt_point_y"), u.get("unit.axis_angle_deg")
                if d and d["value"] is not None and a and a["value"] is not None:
                    log(f"{eye} unit: axis distance {format_length(d['value'], cal.length_unit)} "
                        f"± {format_length(d['std'], cal.length_unit)}, axis angle "
                        f"{a['value']:.4f} ± {a['std']:.4f} deg")
            held = sorted({f"{x['eye']} {x['parameter']}" for x in res.not_identifiable})
            log("not identifiable (held at the gauge, not reported): " + ", ".join(held))
    if report_failed is not None:
        raise RascError(report_failed)
    return 0


def _write_report(doc: dict, args: argparse.Namespace, dataset, kept: list[str]) -> str | None:
    """``--report``: write it and print its verdict; when it cannot be written, the one
    line to end with (exit 2), saying what was kept: the calibration stays (it is valid;
    ``rasc report`` draws it again), only the report is missing."""
    from rasc.report.pdf import write_report

    try:
        v = write_report(doc, args.report, dataset=dataset, source=args.out or "calibration")
    except Exception as exc:      # the calibration is written and kept: one line, exit 2
        why = str(exc) if isinstance(exc, RascError) else f"{type(exc).__name__}: {exc}"
        again = (f"; rasc report {args.out} --out {args.report} tries again"
                 if args.out is not None else "")
        return (f"--report {args.report}: not written ({' '.join(why.split())}); kept "
                f"{', '.join(kept)}{again}")
    print(f"rasc calibrate: report: {v.line()}", file=sys.stderr)
    for warning in v.warnings():
        print(f"rasc calibrate: report: warning: {warning}", file=sys.stderr)
    return None
