"""``rasc detect``: images → the pixel points CSV that ``rasc triangulate`` reads.

Two inputs:

* ``rasc detect DATASET``: every view of the dataset whose left and right pose images
  both show the board (the manifest gives each image's pan and tilt);
* ``rasc detect --board 9x6 --angle-unit deg --pair LEFT.png RIGHT.png PL,TL,PR,TR ...``:
  loose image files, one ``--pair`` per simultaneous pair with its four angles.

Each board corner found in both images of a pair is one row (:mod:`rasc.vision.points`):
``u_left,v_left,u_right,v_right,pan_left,tilt_left,pan_right,tilt_right,label``. Each
image's detection status is a ``#`` comment line at the top of the file (and a progress
line on stderr); images without the board are warned once, their views left out. The
detection is the calibration's (:class:`rasc.head.options.CalibrationOptions`'s detector,
the canonical corner order).
"""

from __future__ import annotations

import argparse
import sys

from rasc.commands import _use_common as common
from rasc.commands import loading
from rasc.errors import InputError
from rasc.head import options as calopts


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "detect", help="images -> matched pixel points (the CSV rasc triangulate reads)",
        description="Detect the board in simultaneous left/right images and write each "
                    "corner seen by both eyes as one row of the points CSV that rasc "
                    "triangulate reads, with every image's detection status.")
    p.add_argument("dataset", metavar="DATASET", nargs="?",
                   help="dataset folder (manifest.json): its pose images, paired by view")
    p.add_argument("--board", metavar="NXxNY|FILE",
                   help="with --pair: the board's inner corners (e.g. 9x6), a JSON file "
                        "with a board object (any target, e.g. an AprilGrid) or a manifest, "
                        "or a Kalibr target yaml")
    p.add_argument("--pair", nargs=3, action="append", default=[],
                   metavar=("LEFT", "RIGHT", "PL,TL,PR,TR"),
                   help="two image files taken at the same time and their pan and tilt "
                        "(left pan, left tilt, right pan, right tilt; repeatable)")
    p.add_argument("--angle-unit", choices=common.ANGLE_UNITS,
                   help="with --pair: the unit of its angles (written as given)")
    p.add_argument("--detector", default=calopts.default("detector"),
                   choices=calopts.DETECTORS, help="corner detector (default saddle)")
    p.add_argument("--out", metavar="FILE",
                   help="write the points CSV here (atomically) instead of stdout")
    p.add_argument("--quiet", action="store_true", help="no per-image lines on stderr")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    with loading():
        from pathlib import Path

        from rasc.io import check_outputs, write_bytes_atomic, write_stdout
        from rasc.vision.dataset import load_dataset
        from rasc.vision.points import pairs_dataset, parse_board, pixel_points

    if (args.dataset is None) == (not args.pair):
        raise InputError("give a dataset folder or --pair LEFT RIGHT ANGLES (not both)")
    if args.pair:
        if args.board is None or args.angle_unit is None:
            raise InputError("--pair needs --board (e.g. 9x6) and --angle-unit deg|rad")
        inputs = [f for left, right, _ in args.pair for f in (left, right)] + [args.board]
        check_outputs([("--out", args.out, "file", ())], inputs=inputs)
        dataset = pairs_dataset(parse_board(args.board), args.pair, args.angle_unit)
    else:
        if args.board is not None or args.angle_unit is not None:
            raise InputError("--board and --angle-unit go with --pair; a dataset's manifest "
                             "gives its board and angle unit")
        check_outputs([("--out", args.out, "file", ())], inputs=[args.dataset])
        dataset = load_dataset(Path(args.dataset))
        check_outputs([("--out", args.out, "file", ())],
                      inputs=[dataset.manifest_path, *(e.path for e in dataset.images)],
                      input_folders=[dataset.root])

    def log(line: str) -> None:
        if not args.quiet:
            print(f"detect: {line}", file=sys.stderr, flush=True)

    points = pixel_points(dataset, detector=args.detector, log=log)
    text = points.to_csv()
    if args.out is None:
        write_stdout(text)
    else:
        write_bytes_atomic(args.out, text.encode("utf-8"))
    for warning in points.warnings():
        common.warn("detect", warning)
    log(f"{len(points.rows)} matched points from {len(points.views_used)} view(s); "
        f"triangulate them with --angle-unit {points.angle_unit}")
    return 0
