"""``rasc rectify CAL --left-readings PAN,TILT --right-readings PAN,TILT --angle-unit deg|rad
[--left IMG --right IMG] --out DIR [--alpha A | --balance B --fov-scale S]
[--map-type fixed|float]``.

The stereo rectification of a calibrated head at one pair of pan-tilt readings
(:func:`rasc.stereo.rectify.rectify_head`: ``cv2.stereoRectify`` on the two cameras'
relative pose at those readings, then ``cv2.initUndistortRectifyMap``; for fisheye eyes
their ``cv2.fisheye`` counterparts, scaled by ``--balance`` and ``--fov-scale`` instead of
``--alpha``). A reading with a leading minus is written with '=': ``--left-readings=-10,5``.

Writes into the folder ``--out`` (created if missing; each file atomically):
``rectification.json`` (``rasc-rectification/1``: R1, R2, P1, P2, Q in OpenCV's meaning,
the readings in ``--angle-unit``, the image size, the baseline, ...) and, with ``--left``
and ``--right``, ``left.png`` and ``right.png``: the two images remapped (8-bit grey, as
rasc reads images).

Refused (one line, exit 2, nothing written): a reading that is not two numbers or beyond
a turn; images not of the calibration's size; one image without the other; an output
that is an input; coinciding optical centres; eyes of two lens models; ``--alpha`` for
fisheye eyes, ``--balance`` or ``--fov-scale`` for pinhole ones. Warned: readings outside
the range the calibration's pose views spanned.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rasc import formats
from rasc.commands import _use_common as common
from rasc.commands import loading
from rasc.errors import InputError
from rasc.geometry.frames import EYES

RESULT_FORMAT = formats.RECTIFICATION.tag
#: the files written into --out
GEOMETRY_FILE = "rectification.json"
IMAGE_FILES = {"left": "left.png", "right": "right.png"}


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "rectify", help="stereo rectification at a pair of pan-tilt readings (R1, R2, P1, "
                        "P2, Q, rectified images)",
        description="Rectify the head's two cameras at the given pan-tilt readings, as "
                    "cv2.stereoRectify rectifies a fixed rig: write the geometry "
                    f"({GEOMETRY_FILE}) and, with --left and --right, the rectified "
                    "images.")
    common.add_calibration(p)
    for eye in EYES:
        p.add_argument(f"--{eye}-readings", metavar="PAN,TILT", required=True,
                       help=f"the {eye} eye's encoder readings (write "
                            f"--{eye}-readings=-10,5 for a leading minus)")
    common.add_angle_unit(p, "--left-readings and --right-readings")
    for eye in EYES:
        p.add_argument(f"--{eye}", metavar="IMG",
                       help=f"the {eye} eye's image at those readings (with --"
                            f"{'right' if eye == 'left' else 'left'})")
    p.add_argument("--out", metavar="DIR", required=True,
                   help=f"folder to write {GEOMETRY_FILE} (and left.png, right.png) into")
    p.add_argument("--alpha", type=float, default=-1.0,
                   help="pinhole eyes: OpenCV's free scaling: -1 its default, 0 only valid "
                        "pixels, 1 all source pixels (default -1)")
    p.add_argument("--balance", type=float, default=None,
                   help="fisheye eyes: cv2.fisheye.stereoRectify's balance, 0 (default) "
                        "only valid pixels to 1 the whole fisheye image")
    p.add_argument("--fov-scale", type=float, default=None,
                   help="fisheye eyes: cv2.fisheye.stereoRectify's fov_scale, the "
                        "rectified focal length divided by it (default 1)")
    p.add_argument("--map-type", choices=("fixed", "float"), default="fixed",
                   help="remap tables: fixed (CV_16SC2, default) or float (CV_32FC1)")
    p.set_defaults(func=run)
    return p


def _readings(text: str, flag: str, unit: str) -> tuple[float, float]:
    import numpy as np

    from rasc.io import finite_numbers

    pan, tilt = finite_numbers(text, f"{flag} {text}", count=2, what="PAN,TILT", text=True,
                               max_abs=common.MAX_ABS_VALUE)
    return tuple(float(common.angles_to_radians(np.array([value]), unit, name,
                                                lambda i: f"{flag} {text}")[0])
                 for name, value in (("pan", pan), ("tilt", tilt)))


def _option(message: str) -> str:
    """A library message about an option, the option named as the command spells it."""
    return message.replace("fov_scale", "fov-scale", 1) if message.startswith(
        "fov_scale") else message


def run(args: argparse.Namespace) -> int:
    with loading():  # here, not at module level: building the parser loads no library
        from rasc.head.use import reading_warnings
        from rasc.io import check_outputs, write_json_atomic
        from rasc.stereo.rectify import RectifyOptions, rectify_head, rectify_images
        from rasc.vision.images import read_image, write_image

    if (args.left is None) != (args.right is None):
        given, missing = ("--left", "--right") if args.left else ("--right", "--left")
        raise InputError(f"{given} without {missing}: give both images, or neither for the "
                         "geometry alone")
    images = args.left is not None
    files = (GEOMETRY_FILE, *IMAGE_FILES.values()) if images else (GEOMETRY_FILE,)
    inputs = [args.calibration, args.left, args.right]
    check_outputs([("--out", args.out, "folder", files)], inputs=inputs)
    unit = args.angle_unit
    readings = {eye: _readings(getattr(args, f"{eye}_readings"), f"--{eye}-readings", unit)
                for eye in EYES}
    try:
        options = RectifyOptions(alpha=args.alpha, map_type=args.map_type,
                                 balance=args.balance, fov_scale=args.fov_scale)
    except InputError as exc:                 # "alpha: ..." is the option --alpha
        raise InputError(f"--{_option(str(exc))}") from None
    cal = common.read_calibration(args.calibration)
    try:
        rect = rectify_head(cal.head, readings["left"], readings["right"], options,
                            maps=images)
    except InputError as exc:      # the eyes' lens models, or an option they take none of
        text = str(exc)
        if text.startswith(("alpha", "balance", "fov_scale")):
            raise InputError(f"{args.calibration}: --{_option(text)}") from None
        if text.startswith("lens:"):
            raise InputError(f"{args.calibration}: {text}") from None
        raise
    rectified = None
    if images:
        pair = read_image(args.left), read_image(args.right)
        try:
            rectified = rectify_images(rect, *pair)
        except InputError as exc:         # "<eye> image: <size>, the calibration's ..."
            eye, _, why = str(exc).partition(" image: ")
            raise InputError(f"--{eye} {getattr(args, eye)}: {why}") from None
    doc = {"format": RESULT_FORMAT, "calibration": args.calibration, "angle_unit": unit,
           "length_unit": cal.length_unit or "that of the calibration",
           **rect.to_dict()}
    doc["readings"] = {eye: {"pan": common.angle_out(readings[eye][0], unit),
                             "tilt": common.angle_out(readings[eye][1], unit)} for eye in EYES}
    out = Path(args.out)
    out.mkdir(exist_ok=True)
    if rectified is not None:
        for eye, image in zip(EYES, rectified, strict=True):
            write_image(out / IMAGE_FILES[eye], image)
    write_json_atomic(out / GEOMETRY_FILE, doc)
    for warning in reading_warnings(cal, {eye: readings[eye] for eye in EYES}, unit,
                                    where=lambda i: "--left-readings/--right-readings"):
        common.warn("rectify", warning)
    return 0
