"""``rasc import SOURCE --out DIR``: a recording → a ``rasc-dataset/1`` folder.

SOURCE is a ROS 1 bag (``.bag``), a ROS 2 bag (a folder with ``metadata.yaml``, SQLite3 or
MCAP), or a folder of images with ``--csv ANGLES.csv``. What to read (image topics,
joints, the target (any target rasc reads: ``--target``), thresholds) comes from
``--config FILE.toml`` and/or the options (options win); see
:mod:`rasc.recordings.config`. The library is :mod:`rasc.recordings`; this
module parses, calls and prints.
"""

from __future__ import annotations

import argparse
import sys

from rasc.commands import loading
from rasc.errors import InputError


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "import", help="a ROS bag (or images + CSV of angles) -> a dataset folder",
        description="Import a recording into a rasc-dataset/1 folder: the still moments of "
                    "the pan-tilt joints of a ROS 1 or ROS 2 bag (SQLite3, MCAP) become pose "
                    "views, each with the image of each eye nearest in time; --intrinsics "
                    "adds the images of a second recording as intrinsics views. A folder of "
                    "images with --csv (file,eye,pan,tilt[,view][,role]) is the other "
                    "source.")
    p.add_argument("source", metavar="SOURCE", help="bag file, ROS 2 bag folder, or image folder")
    p.add_argument("--out", required=True, metavar="DIR", help="the new dataset folder")
    p.add_argument("--config", metavar="FILE.toml", help="topics, joints, board, thresholds")
    p.add_argument("--csv", metavar="FILE", help="SOURCE is an image folder: its angles")
    p.add_argument("--continuous", action="store_true",
                   help="a head that never stops: keep every image within the joint stream "
                        "(not only the still moments), each with its time, and write the "
                        "stream into the dataset (joints.csv); rasc calibrate then estimates "
                        "the camera-to-encoder time offset. With --csv: the CSV gives each "
                        "pose image's time, --joints the stream")
    p.add_argument("--joints", metavar="FILE.csv",
                   help="with --csv --continuous: the joint stream, time,eye,pan,tilt "
                        "(encoder clock, s; radians)")
    p.add_argument("--intrinsics", metavar="BAG",
                   help="a recording of the board moved in front of the still cameras")
    for eye in ("left", "right"):
        p.add_argument(f"--{eye}-topic", metavar="TOPIC", help=f"the {eye} eye's image topic")
        p.add_argument(f"--{eye}-joints", metavar="TOPIC:PAN,TILT",
                       help=f"the {eye} unit's sensor_msgs/JointState topic and joint names")
    p.add_argument("--angle-unit", choices=("deg", "rad"),
                   help="unit of the joint readings / CSV angles (default rad)")
    p.add_argument("--board", metavar="NXxNY", help="a chessboard's inner corners, e.g. 9x6 "
                   "(with --square-size)")
    p.add_argument("--square-size", type=float, metavar="S", help="the chessboard's square size")
    p.add_argument("--target", metavar="SPEC",
                   help="the calibration target, any rasc reads (as rasc render --target): "
                        "chessboard:NXxNY,SQUARE, charuco:SXxSY,SQUARE,MARKER[,DICTIONARY]"
                        "[,legacy], aprilgrid:COLSxROWS,TAGSIZE[,SPACING][,FAMILY], a JSON "
                        "file of the manifest's board object, or a Kalibr target yaml")
    p.add_argument("--length-unit", metavar="U",
                   help="unit of the target's lengths, e.g. m")
    p.add_argument("--still-threshold", type=float, metavar="A",
                   help="max spread of each joint reading in a still moment (angle unit; "
                        "default 0.1 deg)")
    p.add_argument("--still-time", type=float, metavar="S",
                   help="shortest still moment, seconds (default 0.5)")
    p.add_argument("--tolerance", type=float, metavar="S",
                   help="image stamp to the still moment's middle, at most (s, default 0.5)")
    p.add_argument("--intrinsics-interval", type=float, metavar="S",
                   help="intrinsics recording: one image per eye per S seconds (default 1)")
    p.add_argument("--stamp", choices=("header", "bag"),
                   help="time of a message: header stamp (default) or receive time")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)
    return p


def _board(text: str | None, square: float | None, target: str | None) -> dict | None:
    """The target of ``--board``/``--square-size`` (a chessboard) or ``--target`` (any,
    :func:`rasc.vision.board.parse_target`), as the manifest's board object."""
    if target is not None:
        if text is not None or square is not None:
            raise InputError("--target names the whole target: give --target or --board "
                             "with --square-size, not both")
        from rasc.vision.board import parse_target

        return parse_target(target, "--target").to_dict()
    if text is None and square is None:
        return None
    if text is None or square is None:
        raise InputError("--board and --square-size go together (e.g. --board 9x6 "
                         "--square-size 0.05)")
    parts = text.lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
        raise InputError(f"--board: expected NXxNY inner corners (e.g. 9x6), got {text!r}")
    from rasc.recordings.config import parse_board

    return parse_board({"inner_corners": [int(p) for p in parts], "square_size": square},
                       "--board")


def run(args: argparse.Namespace) -> int:
    with loading():
        from rasc.io import check_output
        from rasc.recordings import ImportConfig, import_bag, import_image_folder, load_config
        from rasc.recordings.config import merged as merge
        from rasc.recordings.config import parse_joint_source

    inputs = [args.source, args.config, args.csv, args.intrinsics, args.target, args.joints]
    if args.joints is not None and not (args.continuous and args.csv is not None):
        raise InputError("--joints: the joint stream of a continuous capture from images; "
                         "use it with --csv and --continuous")
    if args.continuous and args.csv is not None and args.joints is None:
        raise InputError("--continuous with --csv: give the joint stream with --joints "
                         "FILE.csv (time,eye,pan,tilt)")
    check_output(args.out, inputs=[i for i in inputs if i], kind="folder")
    cfg = load_config(args.config) if args.config else ImportConfig()
    topics = {e: t for e in ("left", "right")
              if (t := getattr(args, f"{e}_topic")) is not None}
    joints = {e: parse_joint_source(j, f"--{e}-joints") for e in ("left", "right")
              if (j := getattr(args, f"{e}_joints")) is not None}
    for name in ("still_threshold", "still_time", "tolerance", "intrinsics_interval"):
        v = getattr(args, name)
        if v is not None and not (v > 0 or (name == "intrinsics_interval" and v == 0)):
            raise InputError(f"--{name.replace('_', '-')}: must be positive, got {v}")
    cfg = merge(cfg, board=_board(args.board, args.square_size, args.target),
                length_unit=args.length_unit,
                topics=topics or None, joints=joints or None, angle_unit=args.angle_unit,
                threshold=args.still_threshold, min_duration_s=args.still_time,
                tolerance_s=args.tolerance, interval_s=args.intrinsics_interval,
                stamp=args.stamp)

    def log(msg: str) -> None:
        if not args.quiet:
            print(f"import: {msg}", file=sys.stderr, flush=True)

    if args.csv is not None:
        if args.intrinsics is not None:
            raise InputError("--intrinsics: with --csv, list the intrinsics images in the CSV "
                             "(rows without pan and tilt)")
        res = import_image_folder(args.source, args.csv, args.out, cfg, joints=args.joints)
    else:
        res = import_bag(args.source, args.out, cfg, intrinsics=args.intrinsics,
                         quiet=args.quiet, log=log, continuous=args.continuous)
    for w in res.warnings:
        print(f"rasc import: warning: {w}", file=sys.stderr)
    log(f"wrote {res.out}/manifest.json: {res.n_pose} pose and {res.n_intrinsics} "
        f"intrinsics images ({res.bytes_read / 1e6:.1f} MB read in {res.seconds:.1f} s)")
    return 0
