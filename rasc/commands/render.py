"""``rasc render [--model PATH] [--out DIR] [...]``: render a calibration dataset.

Writes the dataset format of :mod:`rasc.vision.dataset` (``manifest.json``, PNG images) plus
``ground_truth.json`` read from the model: intrinsics views of the board waved in front
of each fixed camera and the pan-tilt positions (the paper's nine by default) for both
eyes. See :mod:`rasc.sim.render`. The folder is built under a temporary name and renamed
when complete, so an interrupted run leaves no partial dataset.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from rasc.commands import loading
from rasc.commands._unit_options import add_unit_arguments, units_from_args
from rasc.errors import InputError
from rasc.sim import DEFAULT_SUPERSAMPLE


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "render", help="render a calibration dataset from the simulated head",
        description="Render intrinsics views and pan-tilt pose views of the chessboard for "
                    "both eyes of the simulated head, with ground truth.")
    p.add_argument("--model", metavar="PATH", help="MJCF scene (default sim/models/scene.xml)")
    p.add_argument("--urdf", metavar="HEAD.urdf",
                   help="render your own head, described in a URDF that MuJoCo compiles "
                        "(docs/topics/urdf-head.md), with the target in front; not with "
                        "--model")
    p.add_argument("--urdf-joints", metavar="LP,LT,RP,RT",
                   help="the URDF's left pan, left tilt, right pan, right tilt joints "
                        "(default: rasc export's names)")
    p.add_argument("--urdf-cameras", metavar="LEFT,RIGHT",
                   help="the URDF's camera links, REP 103 optical frames: z forward, x "
                        "right, y down (default: rasc export's names)")
    p.add_argument("--urdf-intrinsics", metavar="CAL",
                   help="the cameras' K and image size from a calibration file (default: "
                        "the stock cameras')")
    p.add_argument("--out", metavar="DIR", default="dataset",
                   help="output folder, new or empty: an existing dataset is never replaced "
                        "(default ./dataset)")
    p.add_argument("--poses", default="paper", metavar="LIST",
                   help="pan,tilt pairs in degrees separated by ';', or a positions file "
                        "(.csv: pan,tilt a line; .toml: positions = [[pan, tilt], ...]; "
                        "what rasc plan writes) (default: 'paper', the nine positions "
                        "(±8, ±8), (±8, 0), (0, ±8), (0, 0))")
    p.add_argument("--target", default=None, metavar="SPEC",
                   help="the calibration target, drawn from its description: "
                        "chessboard:NXxNY,SQUARE (inner corners), "
                        "charuco:SXxSY,SQUARE,MARKER[,DICTIONARY][,legacy] (squares; "
                        "seen in part at wide motions), "
                        "aprilgrid:COLSxROWS,TAGSIZE[,SPACING][,FAMILY] (Kalibr's "
                        "AprilGrid, tags; seen in part), a JSON file of the manifest's "
                        "board object, or a Kalibr target yaml; lengths in metres "
                        "(default: the model's own target, the stock scene's 9x6 chessboard "
                        "of 50 mm squares); with --model it replaces the model's target (a "
                        "model of the head alone gets the stock scene around it)")
    p.add_argument("--intrinsics-views", type=int, default=20, metavar="N",
                   help="intrinsics views per eye (default 20)")
    p.add_argument("--distance", type=float, default=1.0, metavar="M",
                   help="board distance in front of the head for pose views (default 1.0 m)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--noise", type=float, default=0.0, metavar="SIGMA",
                   help="Gaussian pixel noise, grey levels (default 0)")
    p.add_argument("--blur", type=float, default=0.0, metavar="SIGMA",
                   help="Gaussian blur, pixels (default 0)")
    p.add_argument("--distortion", default="", metavar="K1,K2,P1,P2,K3",
                   help="lens distortion applied by warping the renders (OpenCV model), "
                        "e.g. --distortion=-0.2,0.05 (with '=' when it starts with '-'); "
                        "with --lens fisheye its K1,K2,K3,K4; 8 numbers: the rational model")
    p.add_argument("--lens", default="pinhole", choices=("pinhole", "fisheye"),
                   help="the cameras' lens model: pinhole (radial-tangential distortion, "
                        "default) or fisheye (OpenCV's equidistant cv2.fisheye model); "
                        "docs/topics/lenses.md")
    p.add_argument("--fov", type=float, default=0.0, metavar="DEG",
                   help="the lens's horizontal field of view across the image width, "
                        "degrees (up to 180 for a fisheye; default 0: the model cameras' "
                        "own focal length); a wide lens is rendered from several views")
    p.add_argument("--supersample", type=int, default=DEFAULT_SUPERSAMPLE, metavar="S",
                   help="render each image at S times the width and height and average "
                        "each S x S block into one pixel: corners closer to the truth, "
                        "renders slower (1 to 4; 1: the plain render; default %(default)s: "
                        "half the plain render's corner error for 3 times its render time)")
    cam = p.add_argument_group(
        "camera degradations", "what real cameras show, each off by default "
        "(docs/topics/degradations.md)")
    cam.add_argument("--full-well", type=float, default=0.0, metavar="E",
                     help="sensor shot noise: electrons collected at grey level 255 (the "
                          "datasheet's saturation capacity; Poisson noise, variance = "
                          "signal; default 0: none)")
    cam.add_argument("--read-noise", type=float, default=0.0, metavar="E",
                     help="sensor read noise, electrons RMS (needs --full-well; default 0)")
    cam.add_argument("--vignetting", type=float, default=0.0, metavar="V",
                     help="fraction of light lost at the image corners, radial gain "
                          "1 - V (r/r_corner)^2 (0 to 0.95; default 0)")
    cam.add_argument("--motion-blur", type=float, default=0.0, metavar="PX",
                     help="linear motion blur of this length, pixels (default 0)")
    cam.add_argument("--motion-angle", type=float, default=0.0, metavar="DEG",
                     help="the motion blur's direction in the image, degrees (0: along "
                          "the rows, 90: along the columns; default 0)")
    cam.add_argument("--focus-distance", type=float, default=0.0, metavar="M",
                     help="thin-lens defocus that changes with depth, the lens focused at M "
                          "metres (needs the depth buffer; default 0: everything sharp)")
    cam.add_argument("--f-number", type=float, default=2.8, metavar="N",
                     help="the lens's f-number for --focus-distance (default 2.8)")
    cam.add_argument("--focal-length", type=float, default=8.0, metavar="MM",
                     help="the lens's focal length in mm for --focus-distance (default 8)")
    cam.add_argument("--jpeg-quality", type=int, default=0, metavar="Q",
                     help="JPEG compression at quality Q, 1 to 100 (default 0: none; the "
                          "images are still written as PNG)")
    mov = p.add_argument_group(
        "continuous motion", "a head that never stops, filmed by cameras on their own "
        "clock (docs/topics/continuous.md); off by default (stop-and-go); the other options "
        "of this group need --motion-speed")
    mov.add_argument("--motion-speed", type=float, default=0.0, metavar="DEG_S",
                     help="peak joint speed of minimum-jerk motions through the --poses "
                          "positions, deg/s (default 0: stop-and-go, one still image per "
                          "position)")
    mov.add_argument("--dwell", type=float, default=0.0, metavar="S",
                     help="seconds held at each position (default 0: never stops)")
    mov.add_argument("--frame-rate", type=float, default=30.0, metavar="HZ",
                     help="the cameras' frames per second (default 30)")
    mov.add_argument("--exposure", type=float, default=0.01, metavar="S",
                     help="exposure time, seconds: motion blur (default 0.01)")
    mov.add_argument("--subframes", type=int, default=8, metavar="N",
                     help="renders averaged over an exposure (default 8)")
    mov.add_argument("--rolling-shutter", type=float, default=0.0, metavar="S",
                     help="a rolling shutter's line time, seconds (default 0: global "
                          "shutter)")
    mov.add_argument("--joint-rate", type=float, default=200.0, metavar="HZ",
                     help="joint readings per second in joints.csv (default 200)")
    mov.add_argument("--clock-offset", type=float, default=0.0, metavar="S",
                     help="δ: encoder clock = camera clock + δ, seconds (default 0)")
    mov.add_argument("--clock-jitter", type=float, default=0.0, metavar="S",
                     help="Gaussian jitter (σ) of the joint stamps, seconds (default 0)")
    mov.add_argument("--max-frames", type=int, default=40, metavar="N",
                     help="pose frames kept per eye: every k-th of those the camera takes, "
                          "at most N (default 40)")
    add_unit_arguments(p, "the model as written (ideal units)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)
    return p


def _check_out(out: str, model: str | None) -> Path:
    """The output rule for a dataset folder: new, or an existing empty folder."""
    from rasc.io import check_output

    path = check_output(out, inputs=[model], kind="folder")
    if path.is_dir() and any(path.iterdir()):
        what = ("holds a dataset (manifest.json)" if (path / "manifest.json").exists()
                else "exists and is not empty")
        raise InputError(f"--out {out}: {what}; rasc render never replaces files: name a "
                         "new folder, or remove this one first")
    return path


#: RenderOptions' fields as this command's options name them (its messages say these)
FLAGS = {"poses_deg": "--poses", "intrinsics_views": "--intrinsics-views",
         "distance": "--distance", "seed": "--seed", "image_noise": "--noise",
         "blur": "--blur", "distortion": "--distortion", "supersample": "--supersample",
         "full_well": "--full-well", "read_noise": "--read-noise",
         "vignetting": "--vignetting", "motion_blur": "--motion-blur",
         "motion_angle": "--motion-angle", "focus_distance": "--focus-distance",
         "f_number": "--f-number", "focal_length_mm": "--focal-length",
         "jpeg_quality": "--jpeg-quality", "motion_speed_deg_s": "--motion-speed",
         "dwell": "--dwell", "frame_rate": "--frame-rate", "exposure": "--exposure",
         "subframes": "--subframes", "rolling_shutter": "--rolling-shutter",
         "joint_rate": "--joint-rate", "clock_offset": "--clock-offset",
         "clock_jitter": "--clock-jitter", "max_frames": "--max-frames",
         "lens": "--lens", "fov": "--fov"}


def _urdf_head(args: argparse.Namespace, out: Path):
    """The ``--urdf*`` options as a :class:`rasc.sim.urdf.UrdfHead`."""
    from rasc.head.use import intrinsics_from_calibration
    from rasc.io import check_output
    from rasc.sim.urdf import DEFAULT_CAMERAS, DEFAULT_JOINTS, UrdfHead, parse_names

    if args.model is not None:
        raise InputError("--urdf: give --model or --urdf, not both")
    if not Path(args.urdf).is_file():
        raise InputError(f"--urdf {args.urdf}: file not found")
    check_output(str(out), inputs=[args.urdf, args.urdf_intrinsics], kind="folder")
    K = size = None
    if args.urdf_intrinsics is not None:
        K, size = intrinsics_from_calibration(args.urdf_intrinsics)
    joints = DEFAULT_JOINTS if args.urdf_joints is None else \
        parse_names(args.urdf_joints, 4, "--urdf-joints")
    cameras = DEFAULT_CAMERAS if args.urdf_cameras is None else \
        parse_names(args.urdf_cameras, 2, "--urdf-cameras")
    return UrdfHead(args.urdf, joints, cameras, K, size)


def run(args: argparse.Namespace) -> int:
    with loading():  # here, not at module level: building the parser loads no library
        from rasc.io import finite_numbers, folder_built_atomically
        from rasc.sim.render import RenderOptions, parse_poses, render_dataset
        from rasc.vision.board import parse_target

    out = _check_out(args.out, args.model)
    if args.model is not None and not Path(args.model).is_file():
        raise InputError(f"--model {args.model}: file not found")
    if args.urdf is None:
        stray = [f for f, v in (("--urdf-joints", args.urdf_joints),
                                ("--urdf-cameras", args.urdf_cameras),
                                ("--urdf-intrinsics", args.urdf_intrinsics)) if v is not None]
        if stray:
            raise InputError(f"{stray[0]}: only with --urdf HEAD.urdf")
    model = args.model if args.urdf is None else _urdf_head(args, out)
    options = RenderOptions(
        poses_deg=parse_poses(args.poses, FLAGS["poses_deg"]),
        intrinsics_views=args.intrinsics_views, distance=args.distance, seed=args.seed,
        image_noise=args.noise, blur=args.blur,
        distortion=finite_numbers(args.distortion, FLAGS["distortion"], text=True),
        supersample=args.supersample,
        full_well=args.full_well, read_noise=args.read_noise, vignetting=args.vignetting,
        motion_blur=args.motion_blur, motion_angle=args.motion_angle,
        focus_distance=args.focus_distance, f_number=args.f_number,
        focal_length_mm=args.focal_length, jpeg_quality=args.jpeg_quality,
        motion_speed_deg_s=args.motion_speed, dwell=args.dwell, frame_rate=args.frame_rate,
        exposure=args.exposure, subframes=args.subframes,
        rolling_shutter=args.rolling_shutter, joint_rate=args.joint_rate,
        clock_offset=args.clock_offset, clock_jitter=args.clock_jitter,
        max_frames=args.max_frames,
        lens=args.lens, fov=args.fov,
    ).validate(FLAGS)
    units = units_from_args(args)
    board = None if args.target is None else parse_target(args.target, "--target")
    t0 = time.perf_counter()
    with folder_built_atomically(out, meanwhile=" (another render?)") as tmp:
        render_dataset(tmp, options, model_path=model, quiet=args.quiet, units=units,
                       board=board, names=FLAGS)
    if not args.quiet:
        print(f"render: wrote {out}/manifest.json ({time.perf_counter() - t0:.1f} s)",
              file=sys.stderr)
    return 0
