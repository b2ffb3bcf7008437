"""A study's specification: a TOML file read with :mod:`tomllib`, checked key by key.

    seed = 0                      # the one seed of the study
    samples = 30                  # samples per cell
    methods = ["rasc", "li", "opencv-park"]
    bootstrap = 1000              # resamples for the confidence interval of each mean
    confidence = 0.95

    [fixed]                       # parameters shared by every cell (defaults below)
    noise_model = "literal"

    [axes]                        # one list per swept parameter; cells = their product
    noise_level = [0, 1, 4, 8]
    eye = ["left", "right"]

A parameter is either a *sample* parameter (drawn per sample on one rendered dataset's
measurements: pose-level noise eq. 13-14, corner noise, the eye) or a *render* parameter
(it changes the images: image noise, blur, distortion, motion range, positions, board
distance, intrinsics views, the MJCF model); cells with the same render parameters share
one rendered and calibrated dataset. :data:`PARAMS` lists them with their defaults.

Later keys (at their defaults they leave a cell's identity, seeds and bytes unchanged):

- ``noise_on = "home"`` (sample): eq. 13-14 noise on the home view only (E2);
- head-model render parameters ``tilt_axis_offset_mm`` (the axis distance along the
  common normal, mm), ``axis_skew_deg``, ``pan_zero_deg``, ``tilt_zero_deg``,
  ``pan_scale``, ``tilt_scale``, applied to the unit(s) of ``units_eye`` ("both", "left",
  "right") as a :class:`rasc.sim.units.UnitBuild`; the truth is the renderer's;
- ``paired = ["noise_model"]`` (top level): axes left out of the sample seed, so cells
  that differ only in them draw the same noise (common random numbers; not ``eye``);
- ``[fixed] dataset = "folder"``: an existing dataset instead of rendering (no render
  parameter beside it); ``run_study(..., dataset=doc)`` does the same from Python;
- ``[quick]`` with ``samples``, ``methods`` and ``[quick.axes]`` (subsets): the reduced
  protocol ``load_spec(path, quick=True)`` returns, made of the full protocol's cells;
- ``intrinsics_from = "dataset"`` (render): the cell's pose views are rendered in the
  scene of its *base* dataset and measured with the base's intrinsics instead of
  calibrating intrinsics again; only the pose set (``motion_deg``, ``layout``,
  ``positions``) differs from the base. The base is the ``[fixed] dataset`` (or the
  dataset given to ``run_study``), which must then be a rendered one (its
  ``ground_truth.json`` records the scene), else the dataset the same render parameters
  give at the default pose set. A cell whose pose set is the base's own is the base (no
  render). Beside a given dataset only ``intrinsics_from = "dataset"`` and the pose-set
  parameters are allowed;
- ``gross_rotation_deg``, ``gross_translation_mm`` (top level, > 0): a solve farther
  from the truth than either is a failure with status ``gross`` (its errors are kept in
  ``samples.csv``, left out of the summary's statistics); absent, nothing is gross;
- ``[fixed] keep_datasets = true`` (a *study* setting, outside every cell's identity and
  the spec's hash): each rendered dataset is also written under the study folder as a
  dataset folder, ``datasets/<key>/`` (``rasc calibrate`` reads it); by default the
  images and corners stay in memory (rendered, detected and calibrated without a file);
- ``time_limit_s`` (top level, > 0, at most a week): the time limit of one call of a
  plugin method (:func:`rasc.guard.guarded`; absent: 300 s); a call past it is a failed
  sample, status ``failed: PluginTimedOut``;
- ``target`` (render): the calibration target drawn, as ``rasc render --target`` takes it
  (``chessboard:NXxNY,SQUARE``, ``charuco:SXxSY,SQUARE,MARKER[,DICTIONARY][,legacy]`` or
  ``aprilgrid:COLSxROWS,TAGSIZE[,SPACING][,FAMILY]``, metres; '' = the model's own
  board); with ``model``, in place of that model's target; not with ``intrinsics_from =
  "dataset"``;
- ``urdf`` (render): a head described in a URDF (relative to the spec; its bytes'
  sha256 in the cell's identity), rendered as :class:`rasc.sim.urdf.UrdfHead` with the
  joints ``urdf_joints`` and camera links ``urdf_cameras`` (comma lists, default
  ``rasc export``'s names); not with ``model``, ``tilt_axis_offset_mm`` or
  ``axis_skew_deg`` (:func:`_check_urdf`);
- ``positions_file`` (render): a positions file (relative to the spec; what ``rasc plan``
  writes and ``rasc render --poses FILE`` reads, :func:`rasc.sim.render.read_positions`)
  whose positions replace the ``layout``/``positions``/``motion_deg`` grid; a cell's
  identity holds the positions themselves, not the file's name;
- ``supersample`` (render, an integer from 1 to
  :data:`rasc.sim.render.MAX_SUPERSAMPLE`): each image rendered at S times the size and
  averaged over S x S pixels (:attr:`rasc.sim.render.RenderOptions.supersample`, whose
  default, 2, is this parameter's; 1 is the plain render; corners closer to the
  renderer's truth, renders slower; docs/topics/datasets.md);
- the camera degradations (render; :data:`rasc.sim.render.DEGRADATIONS`, each off at its
  default; docs/topics/degradations.md): ``full_well`` (sensor shot noise, electrons at
  grey level 255) and ``read_noise`` (electrons RMS), ``vignetting`` (fraction of light
  lost at the image corners), ``motion_blur`` (px) and ``motion_angle`` (deg),
  ``focus_distance`` (m; thin-lens defocus changing with depth) with ``f_number`` and
  ``focal_length_mm``, ``jpeg_quality`` (1-100; 0 = none);
- the lens (render; :data:`rasc.sim.render.LENS_FIELDS`, docs/topics/lenses.md):
  ``lens`` (``pinhole`` or ``fisheye``; ``distortion`` holds that model's coefficients)
  and ``fov`` (horizontal field of view, degrees; 0 = the model camera's focal length),
  with ``dist_model``, the model the cell's dataset is calibrated with (''
  = the lens's own: ``k1k2`` for a pinhole, ``fisheye`` for a fisheye); not with
  ``intrinsics_from = "dataset"`` (:func:`_check_lens`). A cell's closed form and its
  corner-noise samples go through the calibrated lens;
- continuous motion (render; :data:`rasc.sim.render.CONTINUOUS`, each off at its
  default; docs/topics/continuous.md): ``motion_speed_deg_s`` (0 = stop-and-go; the
  others need it > 0 in every cell, :func:`_check_continuous`), ``dwell``,
  ``frame_rate``, ``exposure``, ``subframes``, ``rolling_shutter``, ``joint_rate``,
  ``clock_offset``, ``clock_jitter``, ``max_frames``; not with ``intrinsics_from =
  "dataset"``. A cell's calibration takes the readings at each image's stamp (δ is not
  estimated by the study's closed form).

The work a spec asks for is bounded before anything runs (:func:`check_work` and the
parameters' own checks: :data:`MAX_POSITIONS`, :data:`MAX_INTRINSICS_VIEWS`,
:data:`MAX_RENDERED_VIEWS`, :data:`MAX_BOOTSTRAP`, :data:`MAX_BOOTSTRAP_DRAWS`,
:data:`MAX_BOOTSTRAP_WORK`; ``blur`` and ``image_noise`` within the renderer's bounds).

Every error is one line naming the file and the key (``spec.toml: axes.noise_level:
empty list``) as :class:`rasc.errors.InputError`; nothing is written before the spec has
been read in full.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from rasc import formats
from rasc.errors import InputError
from rasc.study.params import (  # noqa: F401  (re-exported: rasc.study.spec's names)
    IDENTITY_OPTIONAL,
    INTRINSICS_FROM,
    LAYOUTS,
    MAX_ABS_NUMBER,
    MAX_BOOTSTRAP,
    MAX_BOOTSTRAP_DRAWS,
    MAX_BOOTSTRAP_WORK,
    MAX_INTRINSICS_VIEWS,
    MAX_POSITIONS,
    MAX_RENDERED_VIEWS,
    MAX_SKEW_DEG,
    NOISE_MODELS,
    NOISE_ON,
    PAPER_SIGMA_R_PER_LEVEL,
    PAPER_SIGMA_T_MM_PER_LEVEL,
    PARAMS,
    POSE_PARAMS,
    QUICK_KEYS,
    REQUIRED,
    TOP_KEYS,
    UNIT_PARAMS,
    UNITS_EYES,
    Param,
    _choice,
    _coefficients,
    _int_at_least,
    _nonneg,
    _number,
    _positive,
    _render_bound,
    _show,
    _skew,
    _target,
    _text,
    _time_limit,
    _yes_no,
)

#: version of the study folder layout (``study.json`` ``format``)
#: the summary's statistics of each error, and its columns after the cell and axes
STATS = ("mean", "median", "std", "ci_low", "ci_high")
ERRORS = ("translation_mm", "rotation_deg")
SUMMARY_TAIL = ("method", "n", "n_failed",
                *(f"{e}_{s}" for e in ERRORS for s in STATS))

FORMAT = formats.STUDY.tag
#: a spec larger than this is refused before it is parsed
MAX_SPEC_BYTES = 1 << 20

def pose_grid(layout: str, positions: int, motion_deg: float
              ) -> tuple[tuple[float, float], ...]:
    """The pan-tilt positions (deg) of a layout; ``ValueError`` if ``positions`` does not fit.

    grid: k x k positions (``positions`` = k², k ≥ 2) on ``linspace(-A, A, k)``, the home
    view (when k is odd) first, then by decreasing pan and tilt (k = 3, A = 8 gives the
    paper's nine in its order); cross: the home view and ``(positions - 1) / 4`` steps along
    each half-axis; ring: the home view and ``positions - 1`` positions on a circle of
    radius A.
    """
    a = motion_deg
    if layout == "grid":
        k = math.isqrt(positions)
        if k * k != positions or k < 2:
            raise ValueError(f"layout 'grid' needs a square number of positions (4, 9, 16, "
                             f"...), got {positions}")
        vals = [a - 2 * a * i / (k - 1) for i in range(k)]
        vals = [0.0 if abs(v) < 1e-12 else v for v in vals]
        grid = [(p, t) for p in vals for t in vals]
        home = [g for g in grid if g == (0.0, 0.0)]
        return tuple(home + [g for g in grid if g != (0.0, 0.0)])
    if layout == "cross":
        if (positions - 1) % 4 or positions < 5:
            raise ValueError(f"layout 'cross' needs 1 + 4m positions (5, 9, 13, ...), got "
                             f"{positions}")
        m = (positions - 1) // 4
        out = [(0.0, 0.0)]
        for j in range(1, m + 1):
            s = a * j / m
            out += [(s, 0.0), (-s, 0.0), (0.0, s), (0.0, -s)]
        return tuple(out)
    n = positions - 1
    return ((0.0, 0.0),) + tuple(
        (a * math.cos(2 * math.pi * i / n), a * math.sin(2 * math.pi * i / n))
        for i in range(n))


def poses_of(params: dict[str, Any]) -> tuple[tuple[float, float], ...]:
    """A cell's pan-tilt positions (deg): its positions file's (``positions_file``, which
    :meth:`Spec.cells` replaces by the positions), else :func:`pose_grid`'s."""
    listed = params.get("positions_file")
    if listed:
        return tuple((float(p), float(t)) for p, t in listed)
    return pose_grid(params.get("layout", PARAMS["layout"].default),
                     params.get("positions", PARAMS["positions"].default),
                     params.get("motion_deg", PARAMS["motion_deg"].default))


def identity(params: dict[str, Any]) -> dict[str, Any]:
    """``params`` without the :data:`IDENTITY_OPTIONAL` ones left at their default (what
    a cell's key and a dataset's key hash: specs written before those parameters existed
    keep their keys, seeds and bytes)."""
    return {k: v for k, v in params.items()
            if not (k in IDENTITY_OPTIONAL and v == PARAMS[k].default)
            and PARAMS[k].kind != "study"}


@dataclass(frozen=True)
class Cell:
    """One point of the study's grid: its index, every parameter, and its identity."""

    index: int
    params: dict[str, Any]          # every parameter of PARAMS, resolved
    axes: dict[str, Any]            # the swept ones, in the spec's order
    paired: tuple[str, ...] = ()    # axes left out of the sample seed (common draws)

    @property
    def key(self) -> str:
        """sha256 of the cell's parameters (its identity, independent of its index)."""
        return _digest(identity(self.params))

    @property
    def seed_words(self) -> tuple[int, ...]:
        """Four 32-bit words of the sha256 of the cell's parameters without its
        :attr:`paired` axes (and, with ``noise_level`` paired, without the σ it sets):
        the cell's part of every sample's seed. Without pairing, of :attr:`key`."""
        drop = set(self.paired)
        if "noise_level" in drop:
            drop |= {"sigma_r", "sigma_t_mm"}
        key = _digest({k: v for k, v in identity(self.params).items() if k not in drop}) \
            if drop else self.key
        return tuple(int(key[i:i + 8], 16) for i in range(0, 32, 8))

    def render_params(self) -> dict[str, Any]:
        """The parameters that change the images (those at an optional default left out)."""
        return {k: v for k, v in identity(self.params).items()
                if PARAMS[k].kind == "render"}

    def render_value(self, name: str) -> Any:
        return self.params.get(name, PARAMS[name].default)


@dataclass(frozen=True)
class Spec:
    """A checked study specification."""

    path: Path
    name: str
    description: str
    seed: int
    samples: int
    methods: tuple[str, ...]
    bootstrap: int
    confidence: float
    fixed: dict[str, Any]
    axes: dict[str, tuple[Any, ...]]
    model_digests: dict[str, str]
    paired: tuple[str, ...] = ()
    dataset_digests: dict[str, str] = field(default_factory=dict)
    #: gross-failure thresholds (deg, mm); None: not given
    gross_rotation_deg: float | None = None
    gross_translation_mm: float | None = None
    #: the time limit of one plugin call, s (None: rasc.guard.DEFAULT_TIME_LIMIT_S)
    time_limit_s: float | None = None
    #: positions file (as written in the spec) → its positions (deg)
    positions_files: dict[str, tuple[tuple[float, float], ...]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The normalised spec (what its hash covers; relative model paths resolved to
        the digest of the model file's bytes, a dataset folder to the digest of its
        manifest and ground truth). ``paired`` and ``dataset_digests`` appear only when
        given, so older specs keep their hash."""
        out = {"name": self.name, "description": self.description, "seed": self.seed,
               "samples": self.samples, "methods": list(self.methods),
               "bootstrap": self.bootstrap, "confidence": self.confidence,
               "fixed": {k: _plain(v) for k, v in self.fixed.items()
                         if PARAMS[k].kind != "study"},
               "axes": {k: [_plain(v) for v in vs] for k, vs in self.axes.items()},
               "model_digests": dict(self.model_digests)}
        if self.paired:
            out["paired"] = list(self.paired)
        if self.dataset_digests:
            out["dataset_digests"] = dict(self.dataset_digests)
        if self.positions_files:
            out["positions_files"] = {k: [list(p) for p in v]
                                      for k, v in self.positions_files.items()}
        for key in ("gross_rotation_deg", "gross_translation_mm", "time_limit_s"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        return out

    @property
    def digest(self) -> str:
        return _digest(self.to_dict())

    def cells(self) -> list[Cell]:
        """Every cell: the product of the axes in the order they are written."""
        names = list(self.axes)
        out = []
        for k, values in enumerate(itertools.product(*(self.axes[n] for n in names))):
            swept = dict(zip(names, values, strict=True))
            params = {n: p.default for n, p in PARAMS.items()}
            params.update(self.fixed)
            params.update(swept)
            if params["noise_level"] is not None:
                params["sigma_r"] = PAPER_SIGMA_R_PER_LEVEL * params["noise_level"]
                params["sigma_t_mm"] = PAPER_SIGMA_T_MM_PER_LEVEL * params["noise_level"]
            for name in ("model", "urdf"):
                if params[name]:
                    params[name] = self.model_digests[params[name]]
            if params["dataset"]:
                params["dataset"] = self.dataset_digests[params["dataset"]]
            if params["positions_file"]:
                params["positions_file"] = self.positions_files[params["positions_file"]]
            out.append(Cell(k, params, swept, self.paired))
        return out

    @property
    def keep_datasets(self) -> bool:
        """Whether the rendered datasets are written under the study folder
        (``[fixed] keep_datasets``)."""
        return bool(self.fixed.get("keep_datasets", False))

    def dataset_path(self) -> Path | None:
        """The ``[fixed] dataset`` folder, resolved against the spec's folder (or None)."""
        rel = self.fixed.get("dataset", "")
        return (self.path.parent / rel).resolve() if rel else None

    def model_path(self, digest: str) -> Path | None:
        """The model file or URDF whose bytes have ``digest`` ('' → the package's model)."""
        for rel, d in self.model_digests.items():
            if d == digest:
                return (self.path.parent / rel).resolve()
        return None


def _plain(v):
    return list(v) if isinstance(v, tuple) else v


def _digest(obj) -> str:
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), default=_plain)
    return hashlib.sha256(text.encode()).hexdigest()


def _method_checker() -> Callable[[str], None]:
    """The one place a method name is checked: B1's resolver once it exists, else the
    built-in registry."""
    from rasc.handeye import methods

    get = getattr(methods, "get_method", None)
    if get is not None:
        return get

    def check(name: str) -> None:
        if name not in methods.METHODS:
            raise InputError(f"unknown method {name!r}; expected one of "
                             f"{', '.join(sorted(methods.METHODS))}")
    return check


def check_method(name: str) -> None:
    """Raise :class:`InputError` unless ``name`` names a hand-eye method."""
    _method_checker()(name)


def load_spec(path: str | os.PathLike, quick: bool = False) -> Spec:
    """Read and check a study spec; with ``quick``, narrowed by its ``[quick]`` table.

    The stages, in order: the file (:func:`_read_toml`), the top-level keys
    (:func:`_top_level`), the methods (:func:`_methods`), the confidence level
    (:func:`_confidence`), the parameters of ``[fixed]``
    and ``[axes]`` (:func:`_parameters`), the work and the render parameters that must fit
    together (:func:`check_work`, :func:`_check_poses`), the model files and the dataset
    folder (:func:`_model_digests`, :func:`_dataset_digests`), the paired axes
    (:func:`_paired`), then ``[quick]``.

    Raises
    ------
    rasc.errors.InputError
        One line naming the file and the key: unreadable or invalid TOML, unknown key,
        wrong type, empty axis, unknown method, values that do not fit together.
    """
    path = Path(path)
    where = str(path)
    doc = _read_toml(path)

    def fail(key: str, msg: str):
        raise InputError(f"{where}: {key}: {msg}")

    top = _top_level(doc, fail)
    methods = _methods(doc, fail)
    confidence = _confidence(doc, fail)
    fixed, axes = _parameters(doc, fail)
    n_cells = math.prod(len(v) for v in axes.values())
    if n_cells * top["samples"] > 10**8:
        fail("samples", f"{n_cells} cells x {top['samples']} samples is more than 10^8")
    check_work(top, len(methods), n_cells, fixed, axes, fail)
    _check_poses(fixed, axes, fail)
    digests = _model_digests(path, fixed, axes, fail)
    positions_files = _positions_files(path, fixed, axes, fail)
    _check_target(fixed, axes, fail)
    _check_continuous(fixed, axes, fail)
    _check_lens(fixed, axes, fail)
    dataset_digests = _dataset_digests(path, fixed, axes, fail)
    paired = _paired(doc, axes, fail)
    if positions_files:
        longest = max(len(v) for v in positions_files.values())
        check_work(top, len(methods), n_cells,
                   {**fixed, "positions": max(longest, fixed.get("positions", 9))}, axes, fail)

    spec = Spec(path=path, name=top.get("name", path.stem),
                description=top.get("description", ""), seed=top["seed"],
                samples=top["samples"], methods=tuple(methods),
                bootstrap=top.get("bootstrap", 1000), confidence=confidence, fixed=fixed,
                axes=axes, model_digests=digests, paired=tuple(paired),
                dataset_digests=dataset_digests,
                gross_rotation_deg=top.get("gross_rotation_deg"),
                gross_translation_mm=top.get("gross_translation_mm"),
                time_limit_s=top.get("time_limit_s"), positions_files=positions_files)
    narrowed = _quick(doc.get("quick", {}), spec, fail)
    return narrowed if quick else spec


#: how a stage of :func:`load_spec` refuses: ``fail(key, message)`` raises InputError
Fail = Callable[[str, str], None]


def _read_toml(path: Path) -> dict[str, Any]:
    """The spec file's TOML document (a regular UTF-8 file of at most
    :data:`MAX_SPEC_BYTES`)."""
    where = str(path)
    if not path.is_file():
        raise InputError(f"{where}: no such file" if not path.exists()
                         else f"{where}: not a regular file")
    if path.stat().st_size > MAX_SPEC_BYTES:
        raise InputError(f"{where}: larger than {MAX_SPEC_BYTES} bytes; not a study spec")
    try:
        return tomllib.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError:
        raise InputError(f"{where}: not UTF-8 text") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{where}: not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"{where}: nested too deeply") from None


def _top_level(doc: dict[str, Any], fail: Fail) -> dict[str, Any]:
    """The top-level keys: only known ones, the required ones present, each checked."""
    for key in doc:
        if key not in TOP_KEYS:
            fail(key, f"unknown key (expected {', '.join(TOP_KEYS)})")
    for key in REQUIRED:
        if key not in doc:
            fail(key, "missing")
    top = {}
    for key in ("name", "description", "seed", "samples", "bootstrap",
                "gross_rotation_deg", "gross_translation_mm", "time_limit_s"):
        if key in doc:
            try:
                top[key] = TOP_KEYS[key](doc[key])
            except ValueError as exc:
                fail(key, str(exc))
    return top


def _methods(doc: dict[str, Any], fail: Fail) -> list[str]:
    """``methods``: a non-empty list of distinct names of hand-eye methods."""
    methods = doc["methods"]
    if not isinstance(methods, list):
        fail("methods", f"expected a list of method names, got {_show(methods)}")
    if not methods:
        fail("methods", "empty list")
    for k, m in enumerate(methods):
        if not isinstance(m, str):
            fail(f"methods[{k}]", f"expected a method name, got {_show(m)}")
        if methods.index(m) != k:
            fail(f"methods[{k}]", f"{m!r} given twice")
        try:
            check_method(m)
        except InputError as exc:
            fail(f"methods[{k}]", str(exc))
    return methods


def _confidence(doc: dict[str, Any], fail: Fail) -> float:
    """``confidence``: the level of the summary's intervals, in [0.5, 1)."""
    confidence = doc.get("confidence", 0.95)
    try:
        confidence = _number(confidence)
    except ValueError as exc:
        fail("confidence", str(exc))
    if not 0.5 <= confidence < 1:
        fail("confidence", f"expected a level in [0.5, 1), got {confidence:g}")
    return confidence


def _parameters(doc: dict[str, Any], fail: Fail
                ) -> tuple[dict[str, Any], dict[str, tuple]]:
    """``[fixed]`` and ``[axes]``: known parameters, each value checked by its
    :data:`PARAMS` entry, none in both tables, no axis empty or with a value twice,
    ``noise_level`` not beside the σ it sets."""
    tables = {}
    for table in ("fixed", "axes"):
        t = doc.get(table, {})
        if not isinstance(t, dict):
            fail(table, f"expected a table [{table}], got {_show(t)}")
        for key in t:
            if key not in PARAMS:
                fail(f"{table}.{key}", f"unknown parameter (expected one of "
                     f"{', '.join(PARAMS)})")
        tables[table] = t
    fixed: dict[str, Any] = {}
    for key, value in tables["fixed"].items():
        if key in tables["axes"]:
            fail(f"fixed.{key}", "also an axis; give it in one table only")
        try:
            fixed[key] = PARAMS[key].check(value)
        except ValueError as exc:
            fail(f"fixed.{key}", str(exc))
    axes: dict[str, tuple] = {}
    for key, values in tables["axes"].items():
        if not isinstance(values, list):
            fail(f"axes.{key}", f"expected a list of values, got {_show(values)}")
        if not values:
            fail(f"axes.{key}", "empty list")
        checked = []
        for k, value in enumerate(values):
            try:
                checked.append(PARAMS[key].check(value))
            except ValueError as exc:
                fail(f"axes.{key}[{k}]", str(exc))
            if checked[-1] in checked[:-1]:
                fail(f"axes.{key}[{k}]", f"{_show(value)} given twice")
        axes[key] = tuple(checked)
    given = set(fixed) | set(axes)
    if "noise_level" in given:
        for other in ("sigma_r", "sigma_t_mm"):
            if other in given:
                table = "axes" if other in axes else "fixed"
                fail(f"{table}.{other}", "noise_level already sets sigma_r and sigma_t_mm; "
                     "give one or the other")
    return fixed, axes


def _check_poses(fixed: dict[str, Any], axes: dict[str, tuple], fail: Fail) -> None:
    """The render parameters that must fit together (layout, positions, motion_deg),
    checked over every combination given."""
    pos_layout = [(lay, n, a) for lay in axes.get("layout", (fixed.get("layout", "grid"),))
                  for n in axes.get("positions", (fixed.get("positions", 9),))
                  for a in axes.get("motion_deg", (fixed.get("motion_deg", 8.0),))]
    for lay, n, a in pos_layout:
        try:
            pose_grid(lay, n, a)
        except ValueError as exc:
            fail("axes.positions" if "positions" in axes else "fixed.positions", str(exc))


def _model_digests(path: Path, fixed: dict[str, Any], axes: dict[str, tuple],
                   fail: Fail) -> dict[str, str]:
    """The sha256 of each model file and URDF the spec names (relative to the spec's
    folder); a ``urdf`` is not given with ``model`` (:func:`_check_urdf`)."""
    _check_urdf(fixed, axes, fail)
    digests: dict[str, str] = {}
    for name, what in (("model", "model file"), ("urdf", "URDF file")):
        models = list(axes.get(name, ())) + ([fixed[name]] if fixed.get(name) else [])
        for k, rel in enumerate(m for m in models if m):
            key = f"fixed.{name}" if name in fixed else f"axes.{name}[{k}]"
            file = path.parent / rel
            if not file.is_file():
                fail(key, f"{file}: no such {what}")
            digests[rel] = "sha256:" + hashlib.sha256(file.read_bytes()).hexdigest()
    return digests


def _check_urdf(fixed: dict[str, Any], axes: dict[str, tuple], fail: Fail) -> None:
    """A ``urdf`` is the head: not with ``model``, nor with the head-model parameters that
    move its joints (``tilt_axis_offset_mm``, ``axis_skew_deg``: edit the URDF; encoder
    zeros and scales may be added, as ``rasc render --urdf`` allows); ``urdf_joints`` and
    ``urdf_cameras`` only with a ``urdf``."""
    def given(name: str) -> list:
        return [v for v in axes.get(name, (fixed.get(name, PARAMS[name].default),))
                if v != PARAMS[name].default]

    def where(name: str) -> str:
        return f"{'axes' if name in axes else 'fixed'}.{name}"

    if not given("urdf"):
        for name in ("urdf_joints", "urdf_cameras"):
            if given(name):
                fail(where(name), "names the URDF's joints or links: only with urdf")
        return
    for name, why in (("model", "give model or urdf, not both"),
                      ("tilt_axis_offset_mm", "edit the URDF instead"),
                      ("axis_skew_deg", "edit the URDF instead")):
        if given(name):
            fail(where("urdf"), f"the URDF is the head; not with {name} = "
                 f"{_show(given(name)[0])} ({why})")


def _check_target(fixed: dict[str, Any], axes: dict[str, tuple], fail: Fail) -> None:
    """A ``target`` is drawn in the rendered scene (the package's head's, or a ``model``'s
    in place of its own target): not with ``intrinsics_from = "dataset"``, whose pose
    views are rendered in the base dataset's scene."""
    targets = [t for t in axes.get("target", (fixed.get("target", ""),)) if t]
    if targets:
        for other in ("intrinsics_from",):
            value = axes.get(other, (fixed.get(other, PARAMS[other].default),))
            if any(v and v != PARAMS[other].default for v in value):
                table = "axes" if "target" in axes else "fixed"
                fail(f"{table}.target", f"a target is drawn in the rendered scene, not "
                     f"the base dataset's; not with {other} = "
                     f"{_show(next(v for v in value if v))}")


def _check_continuous(fixed: dict[str, Any], axes: dict[str, tuple], fail: Fail) -> None:
    """A continuous capture (``motion_speed_deg_s`` > 0, docs/topics/continuous.md) is
    rendered whole: not with ``intrinsics_from = "dataset"``, which renders still pose
    views at the positions in the base dataset's scene; the other continuous-motion
    fields (:data:`rasc.sim.render.CONTINUOUS`) away from their defaults need a speed
    > 0 in every cell (as :meth:`rasc.sim.render.RenderOptions.validate` asks, but before
    anything runs)."""
    from rasc.sim.render import CONTINUOUS

    speeds = axes.get("motion_speed_deg_s", (fixed.get("motion_speed_deg_s", 0.0),))
    reuse = axes.get("intrinsics_from", (fixed.get("intrinsics_from", "calibrate"),))
    if any(speeds) and "dataset" in reuse:
        table = "axes" if "motion_speed_deg_s" in axes else "fixed"
        fail(f"{table}.motion_speed_deg_s", "a continuous capture is rendered whole; not "
             "with intrinsics_from = 'dataset' (still pose views in the base's scene)")
    if all(speeds):
        return
    for key in CONTINUOUS:
        values = axes.get(key, (fixed[key],) if key in fixed else ())
        if key != "motion_speed_deg_s" and any(v != PARAMS[key].default for v in values):
            fail(f"{'axes' if key in axes else 'fixed'}.{key}", "is for continuous motion: "
                 "give motion_speed_deg_s > 0 in every cell (0 is stop-and-go)")


def _check_lens(fixed: dict[str, Any], axes: dict[str, tuple], fail: Fail) -> None:
    """A lens (``lens``, ``fov``; docs/topics/lenses.md) and its ``dist_model`` belong to
    a dataset rendered and calibrated whole: not with ``intrinsics_from = "dataset"``,
    which renders pose views through the base's pinhole and keeps its intrinsics."""
    reuse = axes.get("intrinsics_from", (fixed.get("intrinsics_from", "calibrate"),))
    if "dataset" not in reuse:
        return
    for key in ("lens", "fov", "dist_model"):
        values = axes.get(key, (fixed[key],) if key in fixed else ())
        if any(v != PARAMS[key].default for v in values):
            fail(f"{'axes' if key in axes else 'fixed'}.{key}", "is the lens of a dataset "
                 "rendered and calibrated whole; not with intrinsics_from = 'dataset'")


def _dataset_digests(path: Path, fixed: dict[str, Any], axes: dict[str, tuple],
                     fail: Fail) -> dict[str, str]:
    """An existing dataset instead of rendering: [fixed] only, and no render parameter;
    the digest of its folder."""
    if "dataset" in axes:
        fail("axes.dataset", "a study runs on one dataset; give it in [fixed]")
    for key in axes:
        if PARAMS[key].kind == "study":
            fail(f"axes.{key}", "a setting of the whole study, not of a cell; give it "
                 "in [fixed]")
    dataset_digests: dict[str, str] = {}
    if fixed.get("dataset"):
        check_beside_dataset(fixed, axes, fail, "[fixed] dataset is given")
        folder = path.parent / fixed["dataset"]
        if not (folder / "manifest.json").is_file():
            fail("fixed.dataset", f"{folder}: not a dataset folder (no manifest.json)")
        try:
            dataset_metres(folder)
        except ValueError as exc:
            fail("fixed.dataset", f"{folder}: {exc}")
        dataset_digests[fixed["dataset"]] = dataset_digest(folder)
    return dataset_digests


def _paired(doc: dict[str, Any], axes: dict[str, tuple], fail: Fail) -> list[str]:
    """``paired``: common random numbers, axes left out of the sample seed (never
    ``eye``)."""
    paired = doc.get("paired", [])
    if not isinstance(paired, list):
        fail("paired", f"expected a list of axis names, got {_show(paired)}")
    for k, name in enumerate(paired):
        if not isinstance(name, str) or name not in axes:
            fail(f"paired[{k}]", f"expected the name of an axis ({', '.join(axes) or 'none'})"
                 f", got {_show(name)}")
        if paired.index(name) != k:
            fail(f"paired[{k}]", f"{name!r} given twice")
        if name == "eye":
            fail(f"paired[{k}]", "'eye' cannot be paired: the eyes have different poses")
    return paired


def _positions_files(path: Path, fixed: dict[str, Any], axes: dict[str, tuple],
                     fail: Callable[[str, str], None]
                     ) -> dict[str, tuple[tuple[float, float], ...]]:
    """Every ``positions_file`` of the spec read (relative to its folder) and checked:
    3 to :data:`MAX_POSITIONS` positions."""
    from rasc.sim.render import read_positions

    given = [(f"axes.positions_file[{k}]", rel)
             for k, rel in enumerate(axes.get("positions_file", ()))]
    if fixed.get("positions_file"):
        given.append(("fixed.positions_file", fixed["positions_file"]))
    out = {}
    for key, rel in given:
        if not rel:
            continue
        try:
            poses = read_positions(path.parent / rel)
        except InputError as exc:
            fail(key, str(exc))
        if not 3 <= len(poses) <= MAX_POSITIONS:
            fail(key, f"{path.parent / rel}: {len(poses)} positions; expected 3 to "
                 f"{MAX_POSITIONS}")
        out[rel] = poses
    return out


def check_work(top: dict[str, Any], n_methods: int, n_cells: int, fixed: dict[str, Any],
               axes: dict[str, tuple], fail: Callable[[str, str], None]) -> None:
    """Refuse, naming the key, a spec whose work is beyond :data:`MAX_BOOTSTRAP_DRAWS`,
    :data:`MAX_BOOTSTRAP_WORK` or :data:`MAX_RENDERED_VIEWS` (the per-value bounds are the
    parameters' own checks): before any work, never a MemoryError halfway."""
    boot, samples = top.get("bootstrap", 1000), top["samples"]
    if boot * samples > MAX_BOOTSTRAP_DRAWS:
        fail("bootstrap", f"{boot} resamples x {samples} samples is {boot * samples:.3g} "
             f"draws per confidence interval, more than {MAX_BOOTSTRAP_DRAWS:.0e}; "
             "lower bootstrap or samples")
    work = boot * samples * n_cells * n_methods
    if work > MAX_BOOTSTRAP_WORK:
        fail("bootstrap", f"{boot} resamples x {samples} samples x {n_cells} cells x "
             f"{n_methods} methods is {work:.3g} draws, more than {MAX_BOOTSTRAP_WORK:.0e}; "
             "lower bootstrap, samples or the axes")
    if fixed.get("dataset"):
        return
    render_axes = [k for k in axes if PARAMS[k].kind == "render"]
    n_sets = math.prod(len(axes[k]) for k in render_axes)
    per_view = max(axes.get("positions", (fixed.get("positions", 9),))) + max(
        axes.get("intrinsics_views", (fixed.get("intrinsics_views", 20),)))
    views = 2 * n_sets * per_view
    if views > MAX_RENDERED_VIEWS:
        key = next((f"axes.{k}" for k in ("positions", "intrinsics_views") if k in axes),
                   "axes" if render_axes else "fixed.positions")
        fail(key, f"{n_sets} rendered dataset(s) x up to {per_view} views x 2 eyes is "
             f"{views} images, more than {MAX_RENDERED_VIEWS}")


def check_beside_dataset(fixed: dict[str, Any], axes: dict[str, tuple],
                         fail: Callable[[str, str], None], given: str) -> None:
    """Beside a given dataset, render parameters are refused, except the pose set
    (:data:`POSE_PARAMS`) with ``intrinsics_from = "dataset"`` in ``[fixed]``: the study
    then renders only pose views in that dataset's scene."""
    reuse = fixed.get("intrinsics_from") == "dataset"
    if "intrinsics_from" in axes:
        fail("axes.intrinsics_from", f"{given}: give intrinsics_from = 'dataset' in [fixed]")
    for table, t in (("fixed", fixed), ("axes", axes)):
        for key in t:
            if PARAMS[key].kind != "render" or key == "intrinsics_from" and reuse:
                continue
            if key in POSE_PARAMS and reuse:
                continue
            if key == "intrinsics_from":
                fail(f"{table}.{key}", f"{given}: 'calibrate' would calibrate it again; "
                     "'dataset' renders only pose views with its intrinsics")
            fail(f"{table}.{key}", f"a render parameter, but {given}: the study runs on "
                 "that dataset's images" + (" (with intrinsics_from = 'dataset' only "
                                            "motion_deg, layout and positions may differ)"
                                            if key not in POSE_PARAMS else
                                            "; give intrinsics_from = 'dataset' to render "
                                            "its pose views at another pose set"))


def _quick(table: Any, spec: Spec, fail: Callable[[str, str], None]) -> Spec:
    """The spec narrowed by its ``[quick]`` table (checked whether or not it is used):
    fewer samples, a subset of the methods, a subset of each axis's values."""
    if not isinstance(table, dict):
        fail("quick", f"expected a table [quick], got {_show(table)}")
    for key in table:
        if key not in QUICK_KEYS:
            fail(f"quick.{key}", f"unknown key (expected {', '.join(QUICK_KEYS)})")
    changes: dict[str, Any] = {}
    if "samples" in table:
        try:
            changes["samples"] = _int_at_least(1)(table["samples"])
        except ValueError as exc:
            fail("quick.samples", str(exc))
    if "methods" in table:
        methods = table["methods"]
        if not isinstance(methods, list) or not methods:
            fail("quick.methods", f"expected a non-empty list of methods, got {_show(methods)}")
        for k, m in enumerate(methods):
            if m not in spec.methods or methods.index(m) != k:
                fail(f"quick.methods[{k}]", f"expected one of the spec's methods, once each, "
                     f"got {_show(m)}")
        changes["methods"] = tuple(methods)
    if "axes" in table:
        quick_axes = table["axes"]
        if not isinstance(quick_axes, dict):
            fail("quick.axes", f"expected a table [quick.axes], got {_show(quick_axes)}")
        axes = dict(spec.axes)
        for key, values in quick_axes.items():
            if key not in axes:
                fail(f"quick.axes.{key}", "not an axis of [axes]")
            if not isinstance(values, list) or not values:
                fail(f"quick.axes.{key}", f"expected a non-empty list, got {_show(values)}")
            kept = []
            for k, v in enumerate(values):
                try:
                    v = PARAMS[key].check(v)
                except ValueError as exc:
                    fail(f"quick.axes.{key}[{k}]", str(exc))
                if v not in axes[key] or v in kept:
                    fail(f"quick.axes.{key}[{k}]", f"expected one of the axis's values, once "
                         f"each, got {_show(values[k])}")
                kept.append(v)
            axes[key] = tuple(x for x in spec.axes[key] if x in kept)   # the axis's order
        changes["axes"] = axes
    return replace(spec, **changes)


#: metres per unit of the length units a study converts (its errors and eq. 14's sigma_t
#: are in millimetres of metric space, so a dataset's lengths are converted to metres)
LENGTH_UNITS_M = {"m": 1.0, "cm": 0.01, "mm": 0.001}


def dataset_metres(folder: Path) -> float:
    """Metres per length unit of a dataset folder (its manifest's ``length_unit``; absent
    means metres, the renderer's unit); ``ValueError`` for a unit a study cannot convert,
    so that no error is reported in millimetres of something else."""
    from rasc.io import read_json_document

    doc = read_json_document(Path(folder) / "manifest.json")
    unit = doc.get("length_unit", "m") if isinstance(doc, dict) else "m"
    if unit not in LENGTH_UNITS_M:
        raise ValueError(f"manifest.json: length_unit {unit!r}: a study reports errors in "
                         f"mm and needs the board's square size in one of "
                         f"{', '.join(LENGTH_UNITS_M)}")
    return LENGTH_UNITS_M[unit]


def dataset_digest(folder: Path) -> str:
    """sha256 over a dataset folder's ``manifest.json`` and ``ground_truth.json`` (when
    present): what identifies the dataset a study ran on."""
    h = hashlib.sha256()
    for name in ("manifest.json", "ground_truth.json"):
        f = Path(folder) / name
        h.update(name.encode() + b"\0" + (f.read_bytes() if f.is_file() else b""))
    return "sha256:" + h.hexdigest()
