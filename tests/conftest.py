"""What the test modules share: the nominal rig, and one rendered default dataset.

Helpers (import them: ``from conftest import PAPER, rig``):

- ``R_CAM_FROM_GAZE_NOMINAL``: the camera on its gaze frame at home (gaze x up, y forward,
  z left; cam x right = −gaze z, cam y down = −gaze x, optical axis cam z = gaze y).
- ``PAPER``: the paper's nine pan-tilt positions as ``T_gaze_from_ptu`` (9, 4, 4), eq. 3.
- ``rig(rng)``: a realistic eye, ``(T_cam_from_gaze, T_ptu_from_world)``.
- ``random_rigid(rng, n)``: n random rigid transforms.
- ``pan_tilt(poses_deg)``: ``T_gaze_from_ptu`` of (pan, tilt) pairs in degrees.
- ``pip_build_flags()``: ``["--no-build-isolation"]`` when this environment has the build
  backend pyproject asks for (setuptools >= 77, in the ``test`` extra), else ``[]``: the
  tests' ``pip install``/``pip wheel`` of local folders then build without a fresh build
  environment (about 2 s of CPU less each, and no registry or pip cache needed).

Fixture ``rasc_cli``: ``rasc_cli(*argv)`` runs ``rasc ARGV`` in this process
(:func:`rasc.cli.main`) and returns ``(status, stdout, stderr)``; for tests whose claim is
not about the process (see its docstring).

Fixtures (session scope, built on first use):

- ``default_dataset``: the default dataset (the default model, 20 intrinsics views and the
  paper's nine positions per eye, seed 0) rendered once by ``rasc render`` in a
  subprocess. Treat it as read-only (copy it to change it).
- ``default_cli_run``: a folder holding exactly ``ds`` (that dataset) and ``cal.json``,
  its calibration by ``rasc calibrate`` in a subprocess.
- ``default_calibration``: :func:`rasc.head.pipeline.calibrate_dataset` of the dataset
  with the default options, in a test process (not the command line); once per run, the
  xdist workers share it (pickled). Treat it as read-only.
- ``rasc_testing_cache``: one folder for rasc.testing's dataset cache, shared by the tests
  that run a user's suite in a subprocess (examples/my_solver's tests, the test file of
  docs/guide/solver.md, the documentation's examples) and by tests/handeye/test_plugins.py, so
  the dataset they all ask for (10 intrinsics views) is rendered once per run.
- ``quick_experiments``: ``quick_experiments(name)`` runs the reproduction's experiment
  ``experiments.<name>`` once per run (``--quick --seed 0 --workers 1`` on the default
  dataset, one shared folder) and returns ``(ctx, section)``. Read-only.
- ``my_solver_site``: examples/my_solver installed once per run (``pip install --no-deps
  --target SITE`` of a copy, as a user's ``pip install ./examples/my_solver``); put SITE
  on PYTHONPATH. Read-only.

Under pytest-xdist the rendered files are made once per run, not once per worker: the
first worker to need them builds them under a file lock in the run's shared temporary
folder; the others wait for the lock and reuse them.

Marker ``slow`` (registered in pyproject.toml): tests that take a second or more each
(renders, experiments, subprocesses, large property tests); every test that uses one of
the fixtures above gets it automatically. ``make test-fast`` (``-m "not slow"``) leaves
them out. Slow tests are collected first (see ``pytest_collection_modifyitems``), so that
under pytest-xdist the long ones start early and the short ones fill in around them.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import numpy as np
import pytest

from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu
from rasc.geometry.transforms import make_transform, matrix_from_rotvec

# ------------------------------------------------------------------------- the rig

#: Camera axes in gaze coordinates at home: cam x (right) = −gaze z (left), cam y (down)
#: = −gaze x (up), cam z (optical axis) = gaze y (forward): a camera looking forward.
R_CAM_FROM_GAZE_NOMINAL = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def pan_tilt(poses_deg) -> np.ndarray:
    """``T_gaze_from_ptu`` (n, 4, 4) of (pan, tilt) pairs in degrees (eq. 3)."""
    p = np.radians(np.asarray(poses_deg, dtype=float))
    return T_gaze_from_ptu(p[:, 0], p[:, 1])


#: The paper's nine ±8° pan-tilt positions, ``T_gaze_from_ptu`` (9, 4, 4).
PAPER = pan_tilt(PAPER_POSES_DEG)


def rig(rng: np.random.Generator, board_position=None) -> tuple[np.ndarray, np.ndarray]:
    """A realistic eye: camera a few cm from the unit's centre and ~3° off nominal, board
    ~1 m ahead (drawn, or at ``board_position``, (3,) in the ptu frame, m, which draws
    nothing for it). Returns ``(T_cam_from_gaze, T_ptu_from_world)``, each (4, 4)."""
    X = make_transform(R_CAM_FROM_GAZE_NOMINAL @ matrix_from_rotvec(rng.normal(0, 0.05, 3)),
                       rng.uniform(-0.05, 0.05, 3))
    Y = make_transform(R_CAM_FROM_GAZE_NOMINAL.T @ matrix_from_rotvec(rng.normal(0, 0.05, 3)),
                       [rng.uniform(-0.3, 0.0), rng.uniform(0.9, 1.1), rng.uniform(-0.2, 0.2)]
                       if board_position is None else board_position)
    return X, Y


def random_rigid(rng: np.random.Generator, n: int, max_angle: float = np.pi,
                 t_scale: float = 1.0) -> np.ndarray:
    """n rigid transforms (n, 4, 4): uniform random axes, angles uniform in
    [0, max_angle), translations normal with standard deviation ``t_scale``."""
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = rng.uniform(0, max_angle, (n, 1))
    return make_transform(matrix_from_rotvec(axis * angle), rng.normal(0, t_scale, (n, 3)))


# --------------------------------------------------------- the rendered dataset

#: image size of the plausible head's cameras
HEAD_IMAGE_SIZE = (1280, 960)


def plausible_head(seed: int = 0):
    """A plausible head and its ``T_ptuL_from_ptuR``: 0.3 m baseline, 1.5° between the
    mounts, cameras a few cm and ~2° off nominal, different intrinsics and lenses per eye
    (k1 ≈ −0.2 to −0.3)."""
    from rasc.head.base_to_ptu import T_ptuL_from_ptuR_from_mounts, cyclopean_base
    from rasc.head.model import EyeCalibration, HeadCalibration

    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    T_LR = T_ptuL_from_ptuR_from_mounts([0.0, 0.0, -0.3] + rng.normal(0, 0.005, 3),
                                        np.radians(1.5) * axis / np.linalg.norm(axis))
    T_pb = cyclopean_base(T_LR)
    dists = ([-0.22, 0.06, 0.0008, -0.0005, 0.0], [-0.3, 0.09, -0.0004, 0.0007])
    eyes = []
    for k in range(2):
        f = rng.uniform(950, 1050)
        K = np.array([[f, 0, 639.5 + rng.normal(0, 5)], [0, f * 1.001, 479.5 + rng.normal(0, 5)],
                      [0, 0, 1]])
        T_cg = make_transform(R_CAM_FROM_GAZE_NOMINAL @ matrix_from_rotvec(rng.normal(0, 0.03, 3)),
                              rng.uniform(-0.05, 0.05, 3))
        eyes.append(EyeCalibration(K, dists[k], T_cg, T_pb[k], HEAD_IMAGE_SIZE))
    return HeadCalibration(*eyes), T_LR


def python_rasc(*argv, cwd=None) -> subprocess.CompletedProcess:
    """``python -m rasc ARGV`` in a subprocess (text output captured, 300 s limit)."""
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    return subprocess.run([sys.executable, "-m", "rasc", *map(str, argv)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300, check=False)


def run_rasc(argv, capsys) -> tuple[int, str, str]:
    """``rasc ARGV`` in this process (:func:`rasc.cli.main`, arguments as ``str``):
    ``(status, stdout, stderr)``, a usage error's SystemExit giving its status; ``capsys``
    is the test's fixture (emptied first). Behind the ``rasc_cli`` fixture and the CLI
    test modules' ``run_cli``."""
    from rasc.cli import main

    capsys.readouterr()
    try:
        status = main([str(a) for a in argv])
    except SystemExit as exc:
        status = exc.code
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture
def rasc_cli(capsys) -> Callable[..., tuple[int, str, str]]:
    """``rasc ARGV`` in this process: ``rasc_cli(*argv)`` runs :func:`rasc.cli.main` and
    returns ``(status, stdout, stderr)`` (a usage error's SystemExit gives its status).

    For a test whose claim is the status, the output or the files; one about the process
    itself (signals, the exit status through ``exit_process``, the console script, no
    traceback at start-up) runs ``python -m rasc`` (:func:`python_rasc`). main() restores
    the signal handlers and warning filters it changes; give paths absolute, and set the
    environment (``RASC_CACHE_DIR``, ...) with monkeypatch."""
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


def pip_build_flags() -> list[str]:
    """``["--no-build-isolation"]`` if setuptools >= 77 (pyproject's [build-system]
    requirement, also in the ``test`` extra) is importable here, else ``[]``."""
    try:
        import setuptools
    except ImportError:
        return []
    major = int(setuptools.__version__.split(".")[0])
    return ["--no-build-isolation"] if major >= 77 else []


def _shared_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The run's temporary folder: shared by all xdist workers, else this session's."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
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
    shared = _shared_root(tmp_path_factory)
    root = default_dataset.parent
    with _locked(shared / "default.lock"):
        if not (root / "cal.json").is_file():
            _run_ok("calibrate", root / "ds", "--out", root / "cal.json", "--quiet")
    return root


@pytest.fixture(scope="session")
def default_dataset(tmp_path_factory) -> Path:
    """The default dataset (seed 0), from the dataset service (rasc.datasets: rendered
    once, then its verified cache entry under RASC_CACHE_DIR, the reproduction's), copied
    once per run. Read-only."""
    shared = _shared_root(tmp_path_factory)
    root = shared / "default"
    with _locked(shared / "default.lock"):
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


@pytest.fixture(scope="session")
def default_calibration(default_dataset, tmp_path_factory):
    """:func:`rasc.head.pipeline.calibrate_dataset` of the default dataset, the paper model.

    Through the reproduction's calibration cache (a dataset service entry keyed by the
    dataset's bytes and the one code digest; with the cache off, an entry in the run's
    shared folder): computed once, read back by every other xdist worker and run."""
    repo = str(Path(__file__).resolve().parents[1])
    if repo not in sys.path:
        sys.path.insert(0, repo)                     # the experiments package
    from experiments._common import (
        calibration_cache,
        calibration_key,
        load_cached_calibration,
        store_calibration,
    )

    shared = _shared_root(tmp_path_factory)
    key = calibration_key(default_dataset)
    path = calibration_cache(key) or shared / "default_calibration.entry"
    with _locked(shared / "default_calibration.lock"):
        cal = load_cached_calibration(path, key)
        if cal is None:
            from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
            from rasc.vision.dataset import load_dataset

            cal = calibrate_dataset(load_dataset(default_dataset),
                                    CalibrationOptions(model="paper"))
            store_calibration(path, key, cal)
        return cal


@pytest.fixture(scope="session")
def rasc_testing_cache(tmp_path_factory) -> Path:
    """A rasc.testing dataset cache (``--rasc-cache-dir`` / ``RASC_CACHE_DIR``) for the run.
    Shared by xdist workers without a lock: rasc.testing renders into a temporary folder
    and renames it into place, so two suites asking at once at worst both render."""
    path = _shared_root(tmp_path_factory) / "rasc-testing-cache"
    path.mkdir(exist_ok=True)
    return path


#: the user's solver package (docs/guide/solver.md, "Bring your own solver") and of rasc.testing
MY_SOLVER = Path(__file__).resolve().parents[1] / "examples" / "my_solver"


@pytest.fixture(scope="session")
def my_solver_site(tmp_path_factory) -> Path:
    """examples/my_solver installed by ``pip install --no-deps --target SITE`` (this
    environment's dependencies, no network) from a copy (building in place would leave
    build/ in the checkout); once per run, under a file lock as the dataset. Read-only."""
    shared = _shared_root(tmp_path_factory)
    site, done = shared / "my_solver_site", shared / "my_solver_site.done"
    with _locked(shared / "my_solver_site.lock"):
        if not done.is_file():                        # written last: the install is whole
            src = shared / "my_solver_src"
            for folder in (site, src):
                shutil.rmtree(folder, ignore_errors=True)
            shutil.copytree(MY_SOLVER, src, ignore=shutil.ignore_patterns(
                "__pycache__", "build", "*.egg-info"))
            proc = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet",
                                   "--no-deps", *pip_build_flags(), "--target", str(site),
                                   str(src)], capture_output=True, text=True, timeout=600,
                                  check=False)
            assert proc.returncode == 0, proc.stdout + proc.stderr
            done.write_text("")
    return site


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
    Read-only. Shared by the experiment modules and tests/e2e/test_reproduce.py (whose pool
    run must give the same bytes)."""
    import importlib
    import pickle

    repo = str(Path(__file__).resolve().parents[1])
    if repo not in sys.path:
        sys.path.insert(0, repo)                     # the experiments package
    from experiments._common import DATASET_OPTIONS, Context
    from rasc.io import write_bytes_atomic, write_json_atomic

    shared = _shared_root(tmp_path_factory)
    root = shared / "quick_w1"
    dataset = root / "data" / "dataset"
    ctx = Context.from_argv("quick experiments", ["--quick", "--seed", "0", "--workers", "1",
                                                  "--out", str(root)])
    with _locked(shared / "quick_w1.lock"):
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
        record = shared / f"quick_w1.{name}.pickle"
        with _locked(shared / f"quick_w1.{name}.lock"):
            if not record.is_file():                 # written last: the run is complete
                section = importlib.import_module(f"experiments.{name}").run(ctx)
                write_bytes_atomic(record, pickle.dumps(section))
        return ctx, pickle.loads(record.read_bytes())

    run.dataset = dataset
    return run


#: A test using any of these needs the rendered default dataset: it is ``slow``.
DATASET_FIXTURES = frozenset({"default_dataset", "default_cli_run", "default_calibration",
                              "quick_experiments"})


#: The longest tests, longest first (wall seconds each, measured in one whole run on
#: 2026-11-23; ``pytest --durations=30`` lists them): they run before the other slow
#: tests. Only the order depends on this list; a test missing from it, or
#: listed and gone, changes nothing else.
LONGEST_FIRST = (
    "test_doc_examples.py::test_page_examples_run",   # the pages: 2-25 s each (renders)
    "test_reproduce.py::test_same_seed_same_bytes_for_any_worker_count",                # 12.6
    "test_cli_render_calibrate.py::test_distortion_is_rendered_and_recovered",           # 9.1
    "test_study.py::test_process_pool_and_dask_localcluster_give_the_same_bytes",        # 9.0
    "test_cli_render_calibrate.py::test_noise_and_blur_still_calibrate",                 # 8.1
    "test_study_pose_sets.py::test_a_study_run_twice_renders_once",                      # 7.2
    "test_hostile.py::test_refusal_session_is_true",                            # 7.1
    "test_refine.py::test_predicted_std_matches_the_spread_of_20_renoised_refinements",  # 6.9
    "test_packaging.py::test_wheel_installs_renders_and_calibrates_away_from_the_checkout",
    "test_experiments_e1_e3.py::test_e1_files_rows_and_report",                          # 5.9
    "test_sim_render.py::test_corners_match_projection_at_the_nine_paper_poses",         # 5.3
    "test_e7.py::test_offset_breaks_the_paper_model_and_the_refinement_recovers",        # 4.9
    "test_sim_render.py::test_head_geometry_stays_out_of_the_cameras_views",             # 4.8
    "test_study_keys.py::test_error_against_tilt_axis_offset_grows_for_the_paper_model",  # 4.5
    "test_study.py::test_study_writes_tidy_samples_summary_and_figures",                 # 3.4
    "test_study.py::test_interrupted_study_keeps_finished_cells_and_resumes_to_the_same_bytes",
)
_LONGEST_RANK = {name: rank for rank, name in enumerate(LONGEST_FIRST)}


def _schedule_key(item) -> tuple[bool, int]:
    # "room/test_x.py::test_y" -> "test_x.py::test_y" (module names are unique in tests/)
    path, _, test = item.nodeid.split("[")[0].partition("::")
    name = f"{path.rsplit('/', 1)[-1]}::{test}"
    return item.get_closest_marker("slow") is None, _LONGEST_RANK.get(name, len(LONGEST_FIRST))


def pytest_collection_modifyitems(config, items):
    for item in items:
        if DATASET_FIXTURES.intersection(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)
    # Slow tests first, the longest of them (LONGEST_FIRST) before the others (a stable
    # sort: otherwise pytest's order, the same on every xdist worker, as xdist requires):
    # the run's wall time is bounded by the test that starts last plus its length, so the
    # long ones should start while the short ones can still fill the other worker
    # (longest-first scheduling; with `--dist worksteal`, see the Makefile, an idle worker
    # takes the second half of a busy one's pending tests, so what runs last is a short
    # test from the middle of this order, not a study test of 9 s at its end).
    items.sort(key=_schedule_key)


@pytest.fixture
def short_tmp():
    """An empty folder with a short path, for a subprocess's TMPDIR: multiprocessing's
    forkserver binds a Unix socket there, and a socket path has at most 107 bytes
    (pytest's tmp_path under an xdist worker can be longer: "AF_UNIX path too long")."""
    import shutil
    import tempfile

    path = Path(tempfile.mkdtemp(prefix="rasc-t-", dir="/tmp"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


def marked_processes(mark: str) -> list[int]:
    """The processes whose environment holds ``mark`` (a variable a test set in a child's
    environment: what is left of the child's process tree after it was interrupted)."""
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if mark.encode() in (d / "environ").read_bytes():
                    pids.append(int(d.name))
            except OSError:
                continue
    return pids
