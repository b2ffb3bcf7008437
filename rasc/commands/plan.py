"""``rasc plan``: choose the pan-tilt positions to record, and predict the accuracy.

Parses, calls :func:`rasc.plan.plan`, prints the prediction and writes the positions
file ``rasc render --poses FILE`` reads (:func:`rasc.sim.render.format_positions`).
"""

from __future__ import annotations

import argparse
import sys

from rasc.commands import loading
from rasc.commands._unit_options import add_unit_arguments, given, units_from_args
from rasc.errors import InputError
from rasc.head.options import SCALES_MODES


def _pair(text: str, flag: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"{flag}: expected MIN,MAX in degrees, got {text!r}") from None
    return a, b


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "plan", help="choose pan-tilt positions minimising the predicted uncertainty",
        description="Choose k pan-tilt positions (greedy D- or A-optimal design on the "
                    "whole-head refinement's information matrix over a grid of positions "
                    "where the target is seen), print the predicted standard deviation of "
                    "the calibrated parameters and of triangulated points, and write the "
                    "positions file rasc render --poses reads.")
    p.add_argument("--calibration", metavar="FILE",
                   help="the head to plan for: a rasc calibrate JSON (default: the simulated "
                        "head's nominal model, ideal units)")
    add_unit_arguments(p, "the simulated head's nominal model, ideal units; with these "
                          "options the head rasc render renders with them (not with "
                          "--calibration, whose units are its own)")
    p.add_argument("--scales", choices=SCALES_MODES, default=None,
                   help="the encoder scales, as rasc calibrate --scales treats them: "
                        "'estimate' predicts with them estimated, 'hold' with them held at "
                        "their value (exact encoders), 'auto' (default, rasc calibrate's) "
                        "as estimated: the calibration holds them only when the corners do "
                        "not reject 1, which only the data tell, so the plan takes the "
                        "worse case")
    p.add_argument("--target", default="chessboard:9x6,0.05", metavar="SPEC",
                   help="the target, as rasc render --target (default chessboard:9x6,0.05)")
    p.add_argument("--distance", type=float, default=1.0, metavar="M",
                   help="the target's centre ahead of the head, metres (default 1.0)")
    p.add_argument("--pan-range", default="-60,60", metavar="MIN,MAX",
                   help="pan joint range, degrees (default -60,60)")
    p.add_argument("--tilt-range", default="-45,30", metavar="MIN,MAX",
                   help="tilt joint range, degrees (default -45,30)")
    p.add_argument("--step", type=float, default=2.0, metavar="DEG",
                   help="candidate grid step, degrees (default 2)")
    p.add_argument("-k", "--positions", type=int, default=9, metavar="K",
                   help="positions to choose (default 9)")
    p.add_argument("--criterion", choices=("D", "A"), default="D",
                   help="D: log det of the information; A: trace of the hand-eye and unit "
                        "covariance (default D)")
    p.add_argument("--min-corners", type=int, default=8, metavar="N",
                   help="fewest corners a ChArUco view must show (default 8)")
    p.add_argument("--noise", type=float, default=None, metavar="PX",
                   help="the pose views' corner noise per coordinate the prediction "
                        "assumes, pixels (default: what the --calibration's residuals give, "
                        "else 0.05); the predicted sigmas scale with it")
    p.add_argument("--intrinsics-noise", type=float, default=None, metavar="PX",
                   help="the intrinsics views' corner noise per coordinate, pixels "
                        "(default: what the --calibration's residuals give, else --noise); "
                        "the design weighs the two kinds of view by it")
    p.add_argument("--workspace-depth", type=float, default=1.5, metavar="M",
                   help="depth of the 0.6 m square plane of points whose triangulation error "
                        "is predicted, metres ahead of the head; both eyes must see it "
                        "(default 1.5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the intrinsics views and "
                   "of the triangulation samples (default 0)")
    p.add_argument("--out", metavar="FILE", default="positions.csv",
                   help="positions file to write (default positions.csv)")
    p.set_defaults(func=run)
    return p


#: PlanSetup's fields as this command's options name them (its messages say these)
FLAGS = {"distance": "--distance", "pan_range": "--pan-range", "tilt_range": "--tilt-range",
         "step_deg": "--step", "noise_px": "--noise", "intrinsics_noise_px": "--intrinsics-noise",
         "scales": "--scales", "workspace_depth": "--workspace-depth"}


def run(args: argparse.Namespace) -> int:
    with loading():
        from rasc.io import check_output, write_text_atomic
        from rasc.plan import (
            PlanSetup,
            head_from_calibration,
            image_size_of_calibration,
            plan,
            resolve_noise,
            simulated_head,
        )
        from rasc.sim.render import format_positions
        from rasc.sim.synthetic import default_head
        from rasc.vision.board import parse_target

    unit_flags = given(args)
    if args.calibration and unit_flags:
        raise InputError(f"{unit_flags[0]}: the head of --calibration {args.calibration} has "
                         "its own units; give --calibration or the unit options, not both")
    out = check_output(args.out, inputs=[p for p in (args.calibration, args.unit) if p])
    board = parse_target(args.target, "--target")
    size = {}
    if args.calibration:
        head, where = head_from_calibration(args.calibration), f"from {args.calibration}"
        size = {"image_size": image_size_of_calibration(args.calibration)}
    elif unit_flags:
        head = simulated_head(units_from_args(args))
        where = f"the simulated head with {' '.join(unit_flags)}"
    else:
        head, where = default_head(), "the simulated head's nominal model"
    noise, intrinsics_noise, how = resolve_noise(args.noise, args.intrinsics_noise,
                                                 args.calibration)
    setup = PlanSetup(head=head, board=board, distance=args.distance,
                      pan_range=_pair(args.pan_range, "--pan-range"),
                      tilt_range=_pair(args.tilt_range, "--tilt-range"),
                      step_deg=args.step, min_corners=args.min_corners, noise_px=noise,
                      intrinsics_noise_px=intrinsics_noise, seed=args.seed,
                      scales=args.scales,
                      sources={"unit": where, "noise": how,
                               **({"images": f"from {args.calibration}"} if size else {})},
                      names=FLAGS, **size)
    result = plan(setup, args.positions, args.criterion, args.workspace_depth)
    print(f"plan: {len(result.positions)} of {result.candidates} usable positions "
          f"({args.step:g} deg grid), criterion {args.criterion}, "
          f"{result.seconds:.1f} s")
    for p in result.positions:
        print(f"  pan {p[0]:+7.2f}  tilt {p[1]:+7.2f}")
    print("planned under:")
    for k, v in result.assumptions.items():
        print(f"  {k:7s} {v}")
    print("predicted standard deviations:")
    for k, v in result.summary.items():
        print(f"  {k:34s} {v:.4g}")
    t = result.triangulation
    if t:
        print(f"  triangulation, {t['side_m']:g} m plane at {t['depth_m']:g} m: RMS "
              f"{t['rms_mm']:.3g} mm, 95% {t['p95_mm']:.3g} mm")
    print("every parameter (px, m, deg for rotations, 1 for unit axes and scales):")
    for k, v in result.std.items():
        if not k.startswith("board["):
            print(f"  {k:34s} {v:.4g}")
    comment = (f"rasc plan: target {board.describe()} at {args.distance:g} m, "
               f"criterion {args.criterion}, scales "
               f"{'estimated' if setup.scales_estimated else 'held'}, predicted hand-eye "
               f"translation sigma {result.summary['left.handeye_translation_mm']:.3g} / "
               f"{result.summary['right.handeye_translation_mm']:.3g} mm (left / right)")
    write_text_atomic(out, format_positions(result.positions, comment))
    print(f"plan: wrote {out}", file=sys.stderr)
    return 0
