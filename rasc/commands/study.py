"""``rasc study SPEC.toml --out DIR [--workers N | --dask local | --dask tcp://host:port]
[--resume] [--quiet]``: run a declarative study (:mod:`rasc.study`)."""

from __future__ import annotations

import argparse
import os
import sys
import time

from rasc.commands import loading
from rasc.errors import InputError

#: how the library's messages name the options of :func:`rasc.study.run_study` here
FLAGS = {"out": "--out", "resume": "--resume", "workers": "--workers", "dask": "--dask"}


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "study", help="run a declarative study (a TOML spec) of hand-eye error",
        description="Sweep pose noise, corner noise, rendering and head parameters over "
                    "hand-eye methods; write samples.csv, summary.csv and figures.")
    p.add_argument("spec", metavar="SPEC.toml", help="the study's specification")
    p.add_argument("--out", metavar="DIR", required=True,
                   help="study folder: new or empty, or (with --resume) the same study's")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="worker processes (default 1: this process); with --dask local, "
                        "the LocalCluster's workers")
    p.add_argument("--dask", metavar="ADDRESS",
                   help="run on dask.distributed: 'local' starts a LocalCluster on "
                        "loopback, tcp://host:port joins a running scheduler")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted study in DIR (same spec only)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")     # before anything imports mujoco
    with loading():  # here, not at module level: building the parser loads no library
        from rasc.study import load_spec, run_study

    if args.workers < 1:
        raise InputError(f"--workers: expected an integer >= 1, got {args.workers}")
    spec = load_spec(args.spec)
    t0 = time.perf_counter()
    result = run_study(spec, args.out, workers=args.workers, dask=args.dask,
                       resume=args.resume, quiet=args.quiet, names=FLAGS)
    if not args.quiet:
        print(f"rasc study: {result.cells} cells ({result.cells_computed} computed, "
              f"{result.datasets_rendered} dataset(s) rendered) in "
              f"{time.perf_counter() - t0:.1f} s; wrote {result.samples_csv}, "
              f"{result.summary_csv} and {len(result.figures)} figure file(s)",
              file=sys.stderr)
    return 0
