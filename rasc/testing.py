"""Regression tests for your own calibration code: a pytest plugin (README "Regression
tests for your own code (rasc.testing)").

Installed with rasc, the plugin loads itself (entry point ``rasc.testing`` in the group
``pytest11``); ``pytest -p rasc.testing`` loads it explicitly (e.g. with
``PYTEST_DISABLE_PLUGIN_AUTOLOAD=1``). Everything is lazy: loading the plugin imports
nothing beyond numpy and pytest, and a fixture costs nothing until a test asks for it.

Fixtures
--------
``rasc_pose_set``
    A :class:`PoseSet`: nine (by default) noisy target poses ``T_cam_from_world`` by the
    paper's model (eq. 13–14), the unit's motions ``T_gaze_from_ptu`` and the truth.
    Default: the paper's noise level 1, exponential form, seed 0. Parametrise it
    indirectly with a level (0 = no noise, 1–8 = the paper's levels) or a dict of
    :func:`make_pose_set`'s arguments::

        @pytest.mark.parametrize("rasc_pose_set", [1, {"level": 4, "variant": "literal"}],
                                 indirect=True)
        def test_mine(rasc_pose_set): ...

``rasc_pose_set_factory``
    :func:`make_pose_set` itself, to draw as many sets as a test needs.
``rasc_dataset``
    A rendered calibration dataset (images, manifest and ground truth) from rasc's
    simulated head, cached on disk by its parameters: rasc's one dataset class,
    :class:`rasc.vision.dataset.Dataset`, read from the cached folder, with the truth
    (``.truth``, ``.T_cam_from_gaze(eye)``, ``.pose_views(eye)``), ``.path``,
    ``.options`` and ``.key``; ``.ground_truth`` is the truth file's path
    (:class:`GroundTruthFile`: used as the document it was in rasc 0.2.0, it warns).
    Default: :class:`rasc.sim.render.RenderOptions` defaults (58 images, supersampled 2×:
    about 6 s the first time, 2 s of it the supersampling). Parametrise indirectly with
    a dict of RenderOptions fields (and ``model_path``; ``units``, an imperfect head as
    ``rasc render --unit`` takes it; ``target``, a chessboard or ChArUco board as
    ``rasc render --target`` takes it).
``rasc_render``
    The factory behind it: ``rasc_render(intrinsics_views=10, seed=3) -> Dataset``,
    ``rasc_render(target="charuco:12x9,0.06,0.045", units={"tilt_axis_offset_mm":
    (0, 5, 0)})``.

A deprecated name reaching you through the plugin (an old RenderOptions field given to
``rasc_render`` or written in a ``rasc_dataset`` parameter, the old ``.ground_truth``
document, ``RenderedDataset``) warns with a DeprecationWarning at your test's line (for a
fixture's parameter, the test's first line, its ``parametrize``).

Cache: the dataset service's (:mod:`rasc.datasets`): a dataset is stored under the
one key over every render option, the model file and rasc's code digest
(:func:`dataset_key`), so a changed option, model, release or renderer renders anew;
each entry is verified by the sha256 of its content when read (a damaged one is rendered
again, with a note).
Directory: ``--rasc-cache-dir DIR``, else the ini option ``rasc_cache_dir``, else
``$RASC_CACHE_DIR/rendered`` (the store the reproduction shares), else pytest's cache
(``.pytest_cache/d/rasc``), else (with ``-p no:cacheprovider``) a temporary folder of the
session; ``none`` or ``off`` means no cache (a temporary folder of the process). A
dataset is rendered into a temporary folder and renamed into place, so parallel workers
(pytest-xdist) never see half a dataset. Rendering chooses the OpenGL backend before
mujoco is imported (``MUJOCO_GL``, egl by default on a headless machine).

Assertion
---------
:func:`assert_handeye_close` ``(result, truth, rotation_deg=..., translation=...)``.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

#: The cache's sub-folder of pytest's cache directory.
CACHE_NAME = "rasc"


# --------------------------------------------------------------------- pose sets

@dataclass(frozen=True)
class PoseSet:
    """One noisy pose set and its truth. Lengths in metres.

    T_cam_from_world : (n, 4, 4) the target's pose in the camera at each position, with
        eq. 13–14 noise (``literal``: not rigid, solve with ``check_rigid=False``).
    T_gaze_from_ptu : (n, 4, 4) the unit's motion at each position (eq. 3), exact.
    T_cam_from_gaze : (4, 4) the truth (the paper's ``T_cg``); also ``.truth``.
    T_ptu_from_world : (4, 4) the board's true pose in the unit's frame.
    sigma_r : radians; sigma_t : metres; variant : "exponential" or "literal";
    seed : the seed of the draw; poses_deg : (n, 2) pan, tilt in degrees.
    """

    T_cam_from_world: np.ndarray
    T_gaze_from_ptu: np.ndarray
    T_cam_from_gaze: np.ndarray
    T_ptu_from_world: np.ndarray
    sigma_r: float
    sigma_t: float
    variant: str
    seed: int
    poses_deg: tuple[tuple[float, float], ...] = field(repr=False)

    @property
    def truth(self) -> np.ndarray:
        """The true ``T_cam_from_gaze`` (4, 4), for :func:`assert_handeye_close`."""
        return self.T_cam_from_gaze

    @property
    def check_rigid(self) -> bool:
        """What to pass to a solver's ``check_rigid``: False for literal eq. 13 noise."""
        return self.variant != "literal"


def default_T_cam_from_gaze() -> np.ndarray:
    """The pose sets' true hand-eye transform, (4, 4), metres: a camera looking along
    the gaze (+y forward), its centre 42 mm above, 31 mm in front of and 65 mm left of
    the unit's centre, its axes turned 2.1° off the ideal mounting about an oblique axis
    (the README's ``rasc handeye`` example)."""
    from rasc.geometry.transforms import invert_transform, make_transform, matrix_from_rotvec

    R_gaze_from_cam_ideal = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
    misalign = matrix_from_rotvec(np.radians(2.1) * np.array([0.48, -0.6, 0.64]))
    return invert_transform(make_transform(R_gaze_from_cam_ideal @ misalign,
                                           [0.042, 0.031, 0.065]))


def default_T_ptu_from_world(T_cam_from_gaze: np.ndarray) -> np.ndarray:
    """The board 1 m ahead of the camera at home, face-on within a few degrees."""
    from rasc.geometry.transforms import invert_transform, make_transform, matrix_from_rotvec

    T_cam_from_world_home = make_transform(matrix_from_rotvec(np.radians([2.0, -3.0, 1.0])),
                                           [-0.2, -0.125, 1.0])
    return invert_transform(T_cam_from_gaze) @ T_cam_from_world_home


def make_pose_set(level: int | None = 1, *, sigma_r: float | None = None,
                  sigma_t: float | None = None, variant: str = "exponential", seed: int = 0,
                  poses_deg=None, T_cam_from_gaze: np.ndarray | None = None) -> PoseSet:
    """A noisy pose set by the paper's model (docs/METHOD.md §8, eq. 13–14).

    Parameters
    ----------
    level : int or None
        0: no noise; 1–8: the paper's levels (σ_r = 0.005·level rad, σ_t = level mm).
        Ignored for whichever of ``sigma_r`` / ``sigma_t`` is given.
    sigma_r, sigma_t : float, optional
        Explicit noise: radians, metres.
    variant : {"exponential", "literal"}
        ``R' = R exp([ω]×)`` (a rotation) or eq. 13 as printed ``R (I + [ω]×)``.
    seed : int
        ``np.random.default_rng(seed)`` draws the noise: same seed, same set.
    poses_deg : sequence of (pan, tilt), optional
        Default: the paper's nine ±8° positions.
    T_cam_from_gaze : (4, 4), optional
        The truth; default :func:`default_T_cam_from_gaze`.
    """
    from rasc.errors import InputError
    from rasc.geometry.kinematics import PAPER_POSES_DEG, T_gaze_from_ptu
    from rasc.handeye.noise import PAPER_LEVELS_RAD_MM, perturb_T_cam_from_world

    if sigma_r is None or sigma_t is None:
        if not (isinstance(level, int) and 0 <= level <= len(PAPER_LEVELS_RAD_MM)):
            raise InputError(f"level: expected 0 (no noise) to {len(PAPER_LEVELS_RAD_MM)} "
                             f"(the paper's levels), got {level!r}")
        r, t_mm = (0.0, 0.0) if level == 0 else PAPER_LEVELS_RAD_MM[level - 1]
        sigma_r = r if sigma_r is None else sigma_r
        sigma_t = t_mm / 1000.0 if sigma_t is None else sigma_t
    poses = tuple((float(p), float(t)) for p, t in (poses_deg or PAPER_POSES_DEG))
    X = default_T_cam_from_gaze() if T_cam_from_gaze is None else np.array(T_cam_from_gaze,
                                                                            dtype=float)
    T_pw = default_T_ptu_from_world(X)
    a = np.radians(np.array(poses))
    T_gp = T_gaze_from_ptu(a[:, 0], a[:, 1])
    T_cw = perturb_T_cam_from_world(X @ T_gp @ T_pw, sigma_r, sigma_t,
                                    np.random.default_rng(seed), variant=variant)
    return PoseSet(T_cam_from_world=T_cw, T_gaze_from_ptu=T_gp, T_cam_from_gaze=X,
                   T_ptu_from_world=T_pw, sigma_r=float(sigma_r), sigma_t=float(sigma_t),
                   variant=variant, seed=seed, poses_deg=poses)


# ---------------------------------------------------------------- the assertion

def handeye_errors(result: Any, truth: Any) -> tuple[float, float]:
    """(rotation error in degrees, translation error in the inputs' length unit) of a
    HandEyeResult or 4×4 ``T_cam_from_gaze`` against a 4×4 truth (or a :class:`PoseSet`)."""
    from rasc.geometry.transforms import rotation_error_deg

    T = np.asarray(getattr(result, "T_cam_from_gaze", result), dtype=float)
    X = np.asarray(getattr(truth, "T_cam_from_gaze", truth), dtype=float)
    for name, M in (("result", T), ("truth", X)):
        if M.shape != (4, 4):
            raise ValueError(f"{name}: expected a 4x4 T_cam_from_gaze, got shape {M.shape}")
    return (float(rotation_error_deg(T[:3, :3], X[:3, :3])),
            float(np.linalg.norm(T[:3, 3] - X[:3, 3])))


def assert_handeye_close(result: Any, truth: Any, *, rotation_deg: float,
                         translation: float) -> None:
    """Assert that a hand-eye solution is within ``rotation_deg`` degrees (angle of
    ``R R_trueᵀ``) and ``translation`` (distance, in the inputs' unit) of the truth.

    ``result``: a HandEyeResult or a 4×4 ``T_cam_from_gaze``; ``truth``: a 4×4 or a
    :class:`PoseSet`. The failure message gives both errors and both tolerances::

        AssertionError: T_cam_from_gaze (method rasc) is 0.2113° and 0.004182 from the
        truth; allowed 0.1° and 0.01: rotation too far
    """
    __tracebackhide__ = True
    T = np.asarray(getattr(result, "T_cam_from_gaze", result), dtype=float)
    if T.shape == (4, 4) and not np.all(np.isfinite(T)):
        method = getattr(result, "method", None)
        raise AssertionError("T_cam_from_gaze" + (f" (method {method})" if method else "")
                             + " has non-finite entries (NaN or infinity): no solution "
                             f"to compare; allowed {rotation_deg:g}° and {translation:g}")
    rot, trans = handeye_errors(result, truth)
    bad = [what for what, err, tol in (("rotation", rot, rotation_deg),
                                       ("translation", trans, translation))
           if not err <= tol]
    if bad:
        method = getattr(result, "method", None)
        who = "T_cam_from_gaze" + (f" (method {method})" if method else "")
        raise AssertionError(f"{who} is {rot:.4g}° and {trans:.4g} from the truth; allowed "
                             f"{rotation_deg:g}° and {translation:g}: "
                             f"{' and '.join(bad)} too far")


# ---------------------------------------------------------------- rendered data

def dataset_key(options: Any, model_path: str | os.PathLike | None = None, *,
                units: Any = None, target: Any = None) -> str:
    """The cache key of a rendered dataset: the dataset service's one key
    (:func:`rasc.datasets.render.render_key`: rasc's code digest, the rasc version and
    the libraries) of every render option, the model file's content and, when given,
    the units (:func:`unit_builds`) and the target (:func:`target_board`) (32 hex
    digits)."""
    from rasc.datasets.render import render_key

    return render_key(options, model_path, unit_builds(units), target_board(target))


def target_board(target: Any):
    """The target of a rendered dataset as :func:`rasc.sim.render.render_dataset` takes
    it, from what a test may write: None (the model's 9x6 chessboard of 50 mm squares),
    a target as ``rasc render --target`` reads it (``"chessboard:9x6,0.05"``,
    ``"charuco:12x9,0.06,0.045[,DICT_5X5_100][,legacy]"``, or the path of a JSON file of
    the manifest's ``board`` object; lengths in metres), that object as a dict, or a
    :class:`rasc.vision.board.Board` / :class:`~rasc.vision.board.CharucoBoard`."""
    if target is None:
        return None
    from rasc.vision.board import board_from_dict, parse_target

    if isinstance(target, str | os.PathLike):
        return parse_target(os.fspath(target))
    if isinstance(target, dict):
        return board_from_dict(target, "target")
    if hasattr(target, "to_dict") and hasattr(target, "object_points"):
        return target
    raise TypeError(f"target: expected a target description, a dict or a board, got "
                    f"{type(target).__name__}")


def unit_builds(units: Any) -> dict | None:
    """The pan-tilt units of an imperfect head as :func:`rasc.sim.render.render_dataset`
    takes them (``{eye: UnitBuild}``), from what a test may write:

    * None: the ideal units;
    * a path (str or PathLike): a unit file, as ``rasc render --unit FILE`` reads it
      (tables ``[both]``, ``[left]``, ``[right]``; :func:`rasc.sim.units.read_unit_file`);
    * a :class:`rasc.sim.units.UnitBuild`, or a dict of its fields: both units;
    * ``{"left": ..., "right": ...}`` (each a UnitBuild or a dict of fields; an eye left
      out is ideal).

    Fields are checked as the unit file's are (one :class:`~rasc.errors.InputError` line
    naming the field)."""
    from rasc.sim.units import IDEAL_BUILD, UnitBuild, build_from_dict, read_unit_file

    if units is None:
        return None
    if isinstance(units, str | os.PathLike):
        return read_unit_file(units)

    def one(v: Any, where: str) -> UnitBuild:
        if isinstance(v, UnitBuild):
            return build_from_dict(asdict(v), where)
        if isinstance(v, dict):
            return build_from_dict(v, where)
        raise TypeError(f"{where}: expected a UnitBuild or a dict of its fields, got "
                        f"{type(v).__name__}")

    if isinstance(units, dict) and units and set(units) <= {"left", "right"}:
        return {eye: one(units[eye], f"units.{eye}") if eye in units else IDEAL_BUILD
                for eye in ("left", "right")}
    build = one(units, "units")
    return {"left": build, "right": build}


def render_cached(cache_dir: str | os.PathLike | None,
                  model_path: str | os.PathLike | None = None, *, units: Any = None,
                  target: Any = None, **options):
    """Render (or find in the cache folder ``cache_dir``) the dataset of
    ``RenderOptions(**options)``, through the dataset service
    (:func:`rasc.datasets.render.rendered`): entries verified by the sha256 of their
    content when read, a damaged one rendered again with a note. ``cache_dir`` None: no
    cache (rendered into a temporary folder of the process). ``units``: an imperfect
    head (:func:`unit_builds`: a unit file as ``rasc render --unit`` reads it, a
    :class:`rasc.sim.units.UnitBuild` or its fields for both units, or per eye); its
    ground truth is the true head, and the key covers the units. ``target``: the
    calibration target drawn around the stock head, or in place of ``model_path``'s own
    (:func:`target_board`: the descriptions ``rasc render --target`` reads, a chessboard,
    a ChArUco board or an AprilGrid); the key covers it.

    Returns the :class:`rasc.vision.dataset.Dataset` read from the cached folder (treat
    it as read-only: it is shared), with ``truth`` (the ground truth document),
    ``options`` (the RenderOptions) and ``key`` (the cache key) set; ``.path`` is the
    folder, ``.T_cam_from_gaze(eye)`` and ``.pose_views(eye)`` read the truth."""
    from rasc.datasets import CacheStore
    from rasc.datasets.render import rendered
    from rasc.sim.render import RenderOptions
    from rasc.vision.dataset import load_dataset

    with _warnings_at(_users_line()):     # an old option name: the caller's line, not ours
        opts = RenderOptions(**{k: tuple(tuple(p) for p in v) if k == "poses_deg" else
                                tuple(v) if k in ("distortion", "dist") else v
                                for k, v in options.items()})
        builds, board = unit_builds(units), target_board(target)
    store = CacheStore(folder=cache_dir, label="rasc.testing") if cache_dir is not None \
        else None
    path, key = rendered(opts, model_path, store, units=builds, board=board)
    ds = load_dataset(path)
    ds.truth = ds.load_ground_truth()
    if ds.ground_truth is not None:
        ds.ground_truth = GroundTruthFile(ds.ground_truth)
    ds.options, ds.key = opts, key
    return ds


class GroundTruthFile(type(Path())):
    """``Dataset.ground_truth`` of a dataset from :func:`render_cached` (``rasc_render``,
    ``rasc_dataset``): the ground-truth file's path, as for every dataset. Tests written
    for rasc 0.2.0, when it was the document itself, keep working until rasc 0.4: used as
    the document (``ds.ground_truth["left"]``, ``.get``, ``.keys()``, ``in``, ...), it
    reads the file, with a DeprecationWarning at that line naming ``.truth``."""

    def _document(self) -> dict:
        warnings.warn("rasc.testing: a dataset's .ground_truth is the ground-truth file's "
                      "path (renamed after rasc 0.2.0); the document is .truth. Using "
                      ".ground_truth as the document goes in rasc 0.4",
                      DeprecationWarning, stacklevel=3)
        from rasc.io import read_json_document

        return read_json_document(self, "ground truth")

    def __getitem__(self, key):
        return self._document()[key]

    def __contains__(self, key) -> bool:
        return key in self._document()

    def __iter__(self):
        return iter(self._document())

    def __len__(self) -> int:
        return len(self._document())

    def __bool__(self) -> bool:        # a path is true, as before; not the length above
        return True

    def get(self, key, default=None):
        """The document's ``get`` (deprecated: use ``.truth``)."""
        return self._document().get(key, default)

    def keys(self):
        """The document's ``keys`` (deprecated: use ``.truth``)."""
        return self._document().keys()

    def values(self):
        """The document's ``values`` (deprecated: use ``.truth``)."""
        return self._document().values()

    def items(self):
        """The document's ``items`` (deprecated: use ``.truth``)."""
        return self._document().items()


#: where the warnings of a fixture's parameters are reported: set by a fixture to the
#: test that wrote them (:func:`_users_line`)
_PARAMETERS_WRITTEN_AT: contextvars.ContextVar[tuple[str, int, dict] | None] = \
    contextvars.ContextVar("rasc_testing_parameters_written_at", default=None)


def _users_line() -> tuple[str, int, dict] | None:
    """(file, line, module globals) of the user's code that called into this module: the
    test whose parameters a fixture is using, else the first frame outside this file."""
    given = _PARAMETERS_WRITTEN_AT.get()
    if given is not None:
        return given
    frame = sys._getframe(1)
    while frame is not None and frame.f_code.co_filename == __file__:
        frame = frame.f_back
    return None if frame is None else (frame.f_code.co_filename, frame.f_lineno,
                                       frame.f_globals)


@contextlib.contextmanager
def _warnings_at(where: tuple[str, int, dict] | None):
    """Warnings raised inside (a deprecated option name, which the library reports where
    this module passed it on) are reported at ``where``, the user's line
    (:func:`_users_line`), even when the block raises: they point at what to change,
    and Python's and pytest's filters judge them there."""
    caught: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield
    finally:
        for w in caught:
            if where is None:
                warnings.warn(w.message, w.category, stacklevel=3)
                continue
            filename, lineno, globs = where
            warnings.warn_explicit(w.message, w.category, filename, lineno,
                                   module=globs.get("__name__"),
                                   registry=globs.setdefault("__warningregistry__", {}),
                                   module_globals=globs)


@contextlib.contextmanager
def _parameters_of(request: pytest.FixtureRequest):
    """Within: warnings about a fixture's parameters go to the test that wrote them (its
    first line: the ``parametrize`` decorator above it)."""
    function = getattr(request, "function", None)
    code = getattr(function, "__code__", None)
    if code is None:
        yield
        return
    token = _PARAMETERS_WRITTEN_AT.set((code.co_filename, code.co_firstlineno,
                                        function.__globals__))
    try:
        yield
    finally:
        _PARAMETERS_WRITTEN_AT.reset(token)


def __getattr__(name: str):
    if name == "RenderedDataset":
        import warnings

        warnings.warn("rasc.testing.RenderedDataset is deprecated: rasc_render and "
                      "render_cached return rasc.vision.Dataset "
                      "(rasc.vision.dataset.Dataset; .path, .truth, .options, .key, "
                      ".T_cam_from_gaze(eye), .pose_views(eye))", DeprecationWarning,
                      stacklevel=2)
        from rasc.vision.dataset import Dataset

        return Dataset
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# ---------------------------------------------------------------- pytest plugin

def pytest_addoption(parser: pytest.Parser) -> None:
    """pytest hook: the ``--rasc-cache-dir`` option and the ``rasc_cache_dir`` ini setting."""
    group = parser.getgroup("rasc", "rasc.testing (rendered datasets, pose sets)")
    group.addoption("--rasc-cache-dir", metavar="DIR", default=None,
                    help="where rasc.testing caches rendered datasets (default: pytest's "
                         "cache, or RASC_CACHE_DIR)")
    parser.addini("rasc_cache_dir", "where rasc.testing caches rendered datasets",
                  default="")


def _cache_dir(config: pytest.Config, tmp_path_factory) -> Path | None:
    """The cache folder: ``--rasc-cache-dir`` / ``rasc_cache_dir`` as given, else the
    dataset service's store of rendered datasets under ``RASC_CACHE_DIR`` (shared with
    the reproduction), else pytest's cache, else a folder of the session. None: no cache
    (``none``, ``off``: as everywhere in rasc; never a folder named "none")."""
    chosen = (config.getoption("rasc_cache_dir", default=None)
              or config.getini("rasc_cache_dir"))
    off = ("none", "off")
    if chosen:
        return None if chosen.strip().lower() in off else Path(chosen).expanduser()
    env = os.environ.get("RASC_CACHE_DIR")
    if env:
        return None if env.strip().lower() in off else Path(env).expanduser() / "rendered"
    cache = getattr(config, "cache", None)
    if cache is not None:
        return Path(cache.mkdir(CACHE_NAME))
    return tmp_path_factory.getbasetemp() / "rasc-datasets"


@pytest.fixture(scope="session")
def rasc_render(request: pytest.FixtureRequest, tmp_path_factory):
    """``rasc_render(**RenderOptions fields, model_path=None, units=None, target=None)
    -> rasc.vision.dataset.Dataset``, cached on disk (see the module docstring);
    ``units`` renders an imperfect head (:func:`unit_builds`: the unit options of
    ``rasc render --unit``), ``target`` another target (:func:`target_board`: those of
    ``rasc render --target``, chessboard or ChArUco)."""
    cache = _cache_dir(request.config, tmp_path_factory)

    def render(model_path: str | os.PathLike | None = None, *, units: Any = None,
               target: Any = None, **options):
        return render_cached(cache, model_path=model_path, units=units, target=target,
                             **options)

    return render


@pytest.fixture
def rasc_dataset(request: pytest.FixtureRequest, rasc_render):
    """A rendered dataset with ground truth (a :class:`rasc.vision.dataset.Dataset`);
    parametrise indirectly with a dict of RenderOptions fields (and ``model_path``,
    ``units``, ``target``)."""
    with _parameters_of(request):
        return rasc_render(**dict(getattr(request, "param", None) or {}))


@pytest.fixture
def rasc_pose_set_factory():
    """:func:`make_pose_set`."""
    return make_pose_set


@pytest.fixture
def rasc_pose_set(request: pytest.FixtureRequest) -> PoseSet:
    """A noisy pose set (default: the paper's level 1, exponential, seed 0);
    parametrise indirectly with a level or a dict of :func:`make_pose_set` arguments."""
    param = getattr(request, "param", None)
    if param is None:
        return make_pose_set()
    if isinstance(param, dict):
        return make_pose_set(**param)
    return make_pose_set(param)
