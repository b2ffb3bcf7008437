"""``rasc export CAL --format urdf|camera-info|opencv|kalibr [--out FILE_OR_DIR]
[--gaze PL,TL,PR,TR --angle-unit deg|rad] [--joints readings|angles] [--robot-name NAME]``.

The calibration in the formats robots read (:func:`rasc.export.export_calibration`,
docs/topics/export.md): a URDF of the head, ROS camera_info YAML per eye (``--out``
names a folder: ``left.yaml``, ``right.yaml``), OpenCV FileStorage YAML, a Kalibr
camchain. ``urdf``, ``opencv`` and ``kalibr`` go to ``--out FILE`` (atomically) or to
standard output. ``--gaze`` gives the readings at which ``opencv`` and ``kalibr`` take
the stereo extrinsics (default home, all zero).

Refused (one line, exit 2, nothing written): an unreadable calibration, ``--out`` that
is an input, camera-info without ``--out``, ``--gaze`` for urdf or camera-info or
without ``--angle-unit``, a length unit rasc cannot convert to metres, a camera Kalibr's
pinhole-radtan model cannot hold (skew, k3..k6 ≠ 0).
"""

from __future__ import annotations

import argparse
import sys

from rasc.commands import _use_common as common
from rasc.commands import loading
from rasc.errors import InputError

#: rasc.export.FORMATS and rasc.export.urdf.JOINT_VALUES, spelt here so that --help loads
#: no library (tests/export/test_export.py compares them)
_FORMATS = ("urdf", "camera-info", "opencv", "kalibr")
_JOINTS = ("readings", "angles")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "export", help="a calibration as URDF, ROS camera_info, OpenCV or Kalibr YAML",
        description="Write a calibration in a format robots read: a URDF of the head, ROS "
                    "camera_info YAML per eye, OpenCV FileStorage YAML, a Kalibr camchain.")
    common.add_calibration(p)
    p.add_argument("--format", required=True, choices=_FORMATS,
                   help="urdf: the head's joints and camera frames; camera-info: ROS "
                        "intrinsics per eye (--out names a folder); opencv: FileStorage "
                        "YAML with the stereo extrinsics at --gaze; kalibr: camchain yaml")
    p.add_argument("--out", metavar="FILE_OR_DIR",
                   help="the file to write (atomically; default standard output), or for "
                        "camera-info the folder to write left.yaml and right.yaml in")
    p.add_argument("--gaze", metavar="PL,TL,PR,TR",
                   help="opencv, kalibr: the readings pan_left,tilt_left,pan_right,"
                        "tilt_right at which the stereo extrinsics are taken (default all "
                        "0; needs --angle-unit; write --gaze=-1,0,1,0 for a leading minus)")
    p.add_argument("--angle-unit", choices=common.ANGLE_UNITS,
                   help="unit of --gaze (deg or rad)")
    p.add_argument("--joints", choices=_JOINTS, default="readings",
                   help="urdf: the joint values are the encoder readings (default; zeros in "
                        "the joint origins, scales as <mimic> multipliers) or the unit's "
                        "joint angles, which the driver computes")
    p.add_argument("--robot-name", default="rasc_head", help="urdf: the robot's name")
    p.set_defaults(func=run)
    return p


def _gaze(text: str | None, unit: str | None):
    """``--gaze`` in radians (a tuple of 4), or None."""
    import numpy as np

    from rasc.io import finite_number

    if text is None:
        if unit is not None:
            raise InputError("--angle-unit: only with --gaze")
        return None
    if unit is None:
        raise InputError("--gaze: give --angle-unit deg or rad")
    parts = text.split(",")
    if len(parts) != 4:
        raise InputError(f"--gaze {text}: expected PAN_LEFT,TILT_LEFT,PAN_RIGHT,TILT_RIGHT "
                         "(four comma-separated numbers)")
    values = np.array([finite_number(s, f"--gaze {text}", text=True) for s in parts])
    rad = common.angles_to_radians(values, unit, "reading", lambda i: f"--gaze {text}")
    return tuple(float(a) for a in rad)


def run(args: argparse.Namespace) -> int:
    with loading():  # here, not at module level: building the parser loads no library
        from pathlib import Path

        from rasc.export import FILE_NAMES, ExportOptions, export_calibration
        from rasc.io import check_outputs, write_stdout, write_text_atomic

    options = ExportOptions(args.format, gaze=_gaze(args.gaze, args.angle_unit),
                            joints=args.joints, robot_name=args.robot_name)
    folder = args.format == "camera-info"
    if folder and args.out is None:
        raise InputError("--format camera-info writes two files (left.yaml, right.yaml): "
                         "give --out FOLDER")
    if args.out is not None:
        check_outputs([("--out", args.out, "folder" if folder else "file",
                        FILE_NAMES[args.format] if folder else ())],
                      inputs=[args.calibration])
    cal = common.read_calibration(args.calibration)
    result = export_calibration(cal, options)
    if args.out is None:
        write_stdout(next(iter(result.files.values())))
        return 0
    if folder:
        Path(args.out).mkdir(exist_ok=True)
        for name, text in result.files.items():
            write_text_atomic(Path(args.out) / name, text)
            print(f"export: wrote {Path(args.out) / name}", file=sys.stderr)
    else:
        write_text_atomic(args.out, next(iter(result.files.values())))
        print(f"export: wrote {args.out}", file=sys.stderr)
    return 0
