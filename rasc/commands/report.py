"""``rasc report CAL.json [--dataset DIR] --out report.pdf``: a calibration report to look at.

A PDF (:mod:`rasc.report.pdf`): the verdict (usable / check / unusable, with its
reason, :mod:`rasc.report.verdict`), the head drawn, every parameter with ± σ and those
the data could not determine, the reprojection residuals per eye, each eye's corner
coverage, the per-view RMS with outliers marked and the model-fit test. ``--dataset``
(default: the dataset the calibration names, a path from its own folder, if it exists)
gives the residual and coverage pages. The verdict line is printed on stderr. Written
atomically.
"""

from __future__ import annotations

import argparse
import sys

from rasc.commands import loading


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "report", help="a calibration report (PDF) with a one-line verdict",
        description="Write a PDF report of a calibration (rasc calibrate's JSON): verdict, "
                    "head, parameters with sigma, residuals, coverage, per-view RMS, "
                    "model-fit test.")
    p.add_argument("calibration", metavar="CAL.json", help="the calibration (rasc calibrate)")
    p.add_argument("--dataset", metavar="DIR",
                   help="its dataset, for residuals and coverage (default: the one the "
                        "calibration names, a path from its folder, if it exists)")
    p.add_argument("--out", required=True, metavar="FILE.pdf", help="the report")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    with loading():
        from rasc.head.use import named_dataset
        from rasc.io import check_outputs, read_json_document
        from rasc.report.pdf import write_report
        from rasc.vision.dataset import load_dataset

    outputs = [("--out", args.out, "file", ())]
    # before any work: also a folder that takes no file (/proc, read-only) is refused here
    check_outputs(outputs, inputs=[args.calibration])
    doc = read_json_document(args.calibration, "calibration file")
    ds_path = args.dataset if args.dataset is not None else \
        named_dataset(doc, args.calibration)
    dataset = load_dataset(ds_path) if ds_path is not None else None
    if dataset is not None:
        check_outputs(outputs, inputs=[args.calibration, dataset.manifest_path,
                                       *(e.path for e in dataset.images)],
                      input_folders=[dataset.root])

    def log(msg: str) -> None:
        if not args.quiet:
            print(f"report: {msg}", file=sys.stderr, flush=True)

    v = write_report(doc, args.out, dataset=dataset, source=args.calibration, log=log)
    print(f"rasc report: {v.line()}", file=sys.stderr)
    for warning in v.warnings():    # the other failed checks: printed even with --quiet
        print(f"rasc report: warning: {warning}", file=sys.stderr)
    log(f"wrote {args.out}")
    return 0
