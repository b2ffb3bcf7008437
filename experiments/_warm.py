"""Warm-up for ``reproduce.py``'s worker pool: imported once in the forkserver process.

Every worker of the pool is forked from the forkserver, so what this module loads there
(numpy, scipy, OpenCV, mujoco, matplotlib with its fonts and mathtext parser, the
experiment modules) is loaded once instead of once per worker, and the workers start
warm. Nothing here computes a result or creates an OpenGL context (the workers still
create their own, after the fork). The single-threaded settings are made before numpy
is imported, so its BLAS starts with one thread in every worker.
"""

from __future__ import annotations

import contextlib
import io
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")


def warm() -> None:
    """Import the heavy libraries and draw one throw-away figure (loads the fonts, the
    Agg and SVG backends and the mathtext parser's caches)."""
    import importlib

    import cv2  # noqa: F401
    import matplotlib
    import numpy  # noqa: F401
    import scipy.optimize  # noqa: F401
    import scipy.spatial.transform  # noqa: F401
    import scipy.stats  # noqa: F401
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with contextlib.suppress(ImportError):  # the rendering experiments will say so
        import mujoco  # noqa: F401  (import only: no rendering context here)
    # every experiment module (e1_..., e7_...), found by name: importing
    # experiments.reproduce here would make each worker's start-up, which re-imports
    # ``python -m experiments.reproduce`` as its __main__, warn that it was already loaded
    import pkgutil

    import experiments
    for info in pkgutil.iter_modules(experiments.__path__):
        if info.name[:1] == "e" and info.name[1:2].isdigit():
            importlib.import_module(f"experiments.{info.name}")

    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([1.0, 10.0, 100.0], [1.0, 2.0, 3.0], "o-", label="σ (°)")
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=1.0)
    ax.set_title("warm-up")
    ax.legend()
    fig.tight_layout()
    for fmt in ("png", "svg"):
        fig.savefig(io.BytesIO(), format=fmt, dpi=40)
    plt.close(fig)
    global WARMED
    WARMED = True


#: whether :func:`warm` ran to its end in this process (tests check it)
WARMED = False


#: set (to "1") in the environment of the forkserver that reproduce.py starts: see
#: :func:`_exit_without_teardown`
FORKSERVER_ENV = "RASC_REPRODUCE_FORKSERVER"


def _exit_without_teardown() -> None:
    """The forkserver's last atexit handler: end it at once. It ends (SystemExit) when
    reproduce.py has finished, and its interpreter's teardown of everything imported
    here took 0.6-0.8 s on the bench machine, during which it still holds the stderr it
    shares with reproduce.py: a caller reading that pipe to its end (a test, the
    benchmark, a CI log) waited for it. It has nothing to flush or write (its children,
    the pool's workers, end with os._exit as forkserver children always do)."""
    from rasc.interrupt import exit_process
    exit_process(0, teardown=False)


if os.environ.get(FORKSERVER_ENV) == "1":
    import atexit
    atexit.register(_exit_without_teardown)

# a failed warm-up only costs time (the workers then import what they need themselves)
with contextlib.suppress(Exception):
    warm()
