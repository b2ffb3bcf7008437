"""The e2e room's rig: the rendered default dataset and its calibration
(:mod:`shared_fixtures`), and the reproduction's experiments run once each.

``quick_experiments(name)`` runs the reproduction's experiment ``experiments.<name>``
once per run (``--quick --seed 0 --workers 1`` on the default dataset, one shared folder)
and returns ``(ctx, section)``. Read-only.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
default_calibration = shared.default_calibration
default_dataset = shared.default_dataset


@pytest.fixture(scope="session")
def quick_experiments(default_dataset, tmp_path_factory) -> Callable[[str], tuple]:
    """The reproduction's experiments as its serial run does them (``--quick --seed 0
    --workers 1``, one context), on the default dataset: ``quick_experiments(name)`` (a
    module of ``experiments.reproduce.EXPERIMENTS``, e.g. ``"e4_triangulation"``) returns
    ``(ctx, section)``, ``ctx.out/<NAME>`` holding its files. The default dataset's
    calibration is computed afresh in each process that asks (never read from a cache).

    Each experiment runs once per test run (``module.run(ctx)``), into one folder shared
    by the xdist workers (a lock per experiment, as the dataset); its Section is pickled
    beside it. E3 runs after E1 and reads E1's samples from its folder, as in the serial
    reproduction. ``ctx.out/data/dataset`` (also ``quick_experiments.dataset``) is a copy
    of :func:`default_dataset` with the render record ``ctx.dataset_dir()`` asks for, so
    that it is used, not rendered again (link to it from another run's folder).
    Read-only. Shared by the experiment modules, test_doors_figure_margins.py and
    test_reproduce.py (whose pool run must give the same bytes)."""
    import importlib
    import pickle
    import shutil

    shared.experiments_importable()
    from experiments._common import DATASET_OPTIONS, Context
    from rasc.io import write_bytes_atomic, write_json_atomic

    run_root = shared.shared_root(tmp_path_factory)
    root = run_root / "quick_w1"
    dataset = root / "data" / "dataset"
    ctx = Context.from_argv("quick experiments", ["--quick", "--seed", "0", "--workers", "1",
                                                  "--out", str(root)])
    with shared.locked(run_root / "quick_w1.lock"):
        if not (dataset / DATASET_OPTIONS).is_file():       # written last
            shutil.rmtree(dataset, ignore_errors=True)
            shutil.copytree(default_dataset, dataset)
            write_json_atomic(dataset / DATASET_OPTIONS, ctx.dataset_options())

    def run(name: str) -> tuple:
        # calibrated in this process before ctx is used (Context keeps it), never read
        # from the reproduction's cache: the fresh side of tests/e2e/test_reproduce_cache.py
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv("RASC_CACHE_DIR", "none")
            ctx.calibration()
        if name == "e3_quality":
            run("e1_noise")                          # E3 reuses E1's samples (ctx.reuse_e1)
        record = run_root / f"quick_w1.{name}.pickle"
        with shared.locked(run_root / f"quick_w1.{name}.lock"):
            if not record.is_file():                 # written last: the run is complete
                section = importlib.import_module(f"experiments.{name}").run(ctx)
                write_bytes_atomic(record, pickle.dumps(section))
        return ctx, pickle.loads(record.read_bytes())

    run.dataset = dataset
    return run
