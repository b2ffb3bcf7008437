"""The fixtures that several rooms use, and the run-wide shared folder they are built in.

A room's conftest names the ones its tests ask for (``import shared_fixtures as shared``,
then ``default_dataset = shared.default_dataset``), so that each room's conftest lists its
rig; tests/ is on sys.path through the root conftest. Which room takes which: the root
conftest's docstring.

- ``rasc_cli`` (function scope): ``rasc_cli(*argv)`` runs ``rasc ARGV`` in this process
  (:func:`rasc.cli.main`) and returns ``(status, stdout, stderr)``.
- ``detections_counted`` (function scope): the images ``detect_corners`` really looks at.
- ``default_dataset`` (session): the default dataset (the default model, 20 intrinsics
  views and the paper's nine positions per eye, seed 0). Treat it as read-only (copy it
  to change it).
- ``default_cli_run`` (session): a folder holding exactly ``ds`` (that dataset) and
  ``cal.json``, its calibration by ``rasc calibrate`` in a subprocess.
- ``default_calibration`` (session): :func:`rasc.head.pipeline.calibrate_dataset` of the
  dataset with the default options, in a test process (not the command line); once per
  run, the xdist workers share it (pickled). Treat it as read-only.
- ``rasc_testing_cache`` (session): one folder for rasc.testing's dataset cache, shared by
  the tests that run a user's suite in a subprocess (examples/my_solver's tests, the test
  file of docs/guide/solver.md, the documentation's examples) and by
  tests/handeye/test_plugins.py, so the dataset they all ask for (10 intrinsics views) is
  rendered once per run.

Plain helpers for fixtures and tests that build something once per run:
``shared_root(tmp_path_factory)`` (the run's temporary folder, shared by all xdist
workers) and ``locked(path)`` (an exclusive file lock across processes).

Under pytest-xdist the rendered files are made once per run, not once per worker: the
first worker to need them builds them under a file lock in the run's shared temporary
folder; the others wait for the lock and reuse them. pytest registers a fixture once per
conftest that names it, so a session fixture named by two rooms runs once per room
in a process: the second finds its files made (a lock and a file check), and
``default_calibration`` is kept per process (the same object in every room).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from running import python_rasc, run_rasc

#: the repository (the experiments package is imported from there)
REPO = Path(__file__).resolve().parents[1]


def shared_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The run's temporary folder: shared by all xdist workers, else this session's."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@contextlib.contextmanager
def locked(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` across processes (POSIX flock; no lock elsewhere)."""
    try:
        import fcntl
    except ImportError:            # not POSIX: one process per run is assumed
        yield
        return
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def experiments_importable() -> None:
    """Put the repository on sys.path, for the ``experiments`` package."""
    if str(REPO) not in sys.path:
        sys.path.insert(0, str(REPO))


@pytest.fixture
def rasc_cli(capsys) -> Callable[..., tuple[int, str, str]]:
    """``rasc ARGV`` in this process: ``rasc_cli(*argv)`` runs :func:`rasc.cli.main` and
    returns ``(status, stdout, stderr)`` (a usage error's SystemExit gives its status).

    For a test whose claim is the status, the output or the files; one about the process
    itself (signals, the exit status through ``exit_process``, the console script, no
    traceback at start-up) runs ``python -m rasc`` (:func:`running.python_rasc`). main()
    restores the signal handlers and warning filters it changes; give paths absolute, and
    set the environment (``RASC_CACHE_DIR``, ...) with monkeypatch."""
    return lambda *argv: run_rasc(argv, capsys)


@pytest.fixture
def detections_counted(monkeypatch) -> Iterator[list[bytes]]:
    """The images ``rasc.vision.camera.detect_corners`` really looks at (their pixels'
    bytes, in order; images whose detections were kept are not there), with the
    detections kept (``rasc.vision.dataset.forget_detections``) emptied before and after
    the test."""
    import rasc.vision.camera as camera
    from rasc.vision.dataset import forget_detections

    seen: list[bytes] = []
    detect = camera.detect_corners

    def spy(image, *args, **kwargs):
        seen.append(image.tobytes())
        return detect(image, *args, **kwargs)

    forget_detections()
    monkeypatch.setattr(camera, "detect_corners", spy)
    yield seen
    forget_detections()


def _run_ok(*argv, quiet_stdout: bool = True) -> None:
    """Run ``python -m rasc ARGV``: exit status 0, nothing on stderr (nor on stdout)."""
    proc = python_rasc(*argv)
    assert proc.returncode == 0 and proc.stderr == "", \
        f"rasc {argv[0]} failed ({proc.returncode}): {proc.stderr}"
    assert not quiet_stdout or proc.stdout == "", proc.stdout


@pytest.fixture(scope="session")
def default_cli_run(default_dataset, tmp_path_factory) -> Path:
    """A folder holding ``ds`` (the default dataset by ``rasc render``) and ``cal.json``
    (its calibration by ``rasc calibrate``), both written once per run."""
    shared = shared_root(tmp_path_factory)
    root = default_dataset.parent
    with locked(shared / "default.lock"):
        if not (root / "cal.json").is_file():
            _run_ok("calibrate", root / "ds", "--out", root / "cal.json", "--quiet")
    return root


@pytest.fixture(scope="session")
def default_dataset(tmp_path_factory) -> Path:
    """The default dataset (seed 0), from the dataset service (rasc.datasets: rendered
    once, then its verified cache entry under RASC_CACHE_DIR, the reproduction's), copied
    once per run. Read-only."""
    shared = shared_root(tmp_path_factory)
    root = shared / "default"
    with locked(shared / "default.lock"):
        if not (root / "ds" / "manifest.json").is_file():
            from rasc.datasets import CacheStore
            from rasc.datasets.render import rendered
            from rasc.sim.render import RenderOptions

            folder, _ = rendered(RenderOptions(seed=0), store=CacheStore("rendered"))
            root.mkdir(exist_ok=True)
            tmp = root / ".ds.tmp"
            shutil.rmtree(tmp, ignore_errors=True)
            shutil.copytree(folder, tmp)
            tmp.rename(root / "ds")
    return root / "ds"


#: default_calibration's result per dataset folder, in this process (one object for
#: every room's fixture)
_CALIBRATIONS: dict[Path, object] = {}


@pytest.fixture(scope="session")
def default_calibration(default_dataset, tmp_path_factory):
    """:func:`rasc.head.pipeline.calibrate_dataset` of the default dataset, the paper model.

    Through the reproduction's calibration cache (a dataset service entry keyed by the
    dataset's bytes and the one code digest; with the cache off, an entry in the run's
    shared folder): computed once, read back by every other xdist worker and run."""
    if default_dataset in _CALIBRATIONS:
        return _CALIBRATIONS[default_dataset]
    experiments_importable()
    from experiments._common import (
        calibration_cache,
        calibration_key,
        load_cached_calibration,
        store_calibration,
    )

    shared = shared_root(tmp_path_factory)
    key = calibration_key(default_dataset)
    path = calibration_cache(key) or shared / "default_calibration.entry"
    with locked(shared / "default_calibration.lock"):
        cal = load_cached_calibration(path, key)
        if cal is None:
            from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
            from rasc.vision.dataset import load_dataset

            cal = calibrate_dataset(load_dataset(default_dataset),
                                    CalibrationOptions(model="paper"))
            store_calibration(path, key, cal)
    _CALIBRATIONS[default_dataset] = cal
    return cal


@pytest.fixture(scope="session")
def rasc_testing_cache(tmp_path_factory) -> Path:
    """A rasc.testing dataset cache (``--rasc-cache-dir`` / ``RASC_CACHE_DIR``) for the run.
    Shared by xdist workers without a lock: rasc.testing renders into a temporary folder
    and renames it into place, so two suites asking at once at worst both render."""
    path = shared_root(tmp_path_factory) / "rasc-testing-cache"
    path.mkdir(exist_ok=True)
    return path
