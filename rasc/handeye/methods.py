"""Every hand-eye method by name, and the plugin contract (README "Bring your own solver").

A *method* turns the target's poses ``T_cam_from_world`` (n, 4, 4) and the unit's
motions ``T_gaze_from_ptu`` (n, 4, 4) into ``T_cam_from_gaze`` (the paper's ``T_cg``).
Wherever a method is named (``rasc handeye --method``, ``rasc calibrate --method``, and
any code that calls :func:`solve` or :func:`get_method` — the one entry point for
experiments and studies) the name is resolved by :func:`get_method`, in this order:

1. a built-in name, a key of :data:`METHODS`: "rasc" (the paper's method), "li",
   "rasc-inverse" and "rasc-views" (RASC's rotation with other translations,
   :mod:`rasc.handeye.inverse`), "rasc-robust" (consensus that rejects bad positions,
   then RASC on the rest, :mod:`rasc.handeye.robust`), "rasc-scale" (the camera
   translations' unknown scale estimated too, :mod:`rasc.handeye.scale`) and OpenCV's
   five "opencv-<name>";
2. ``package.module:function`` (any importable callable; the module is imported when
   the method is first resolved);
3. a name registered by an installed package in the entry-point group ``rasc.methods``
   (``[project.entry-points."rasc.methods"] my-solver = "my_solver.solve:solve"``).

A plugin (2 or 3) is a callable ``f(T_cam_from_world, T_gaze_from_ptu, **options)``
returning a 4×4 ``T_cam_from_gaze`` (array-like) or a
:class:`~rasc.handeye.solver.HandEyeResult`. The library wraps it (:class:`Method`):
before the call it validates the input and refuses degenerate data exactly as RASC does
(:func:`rasc.handeye.solver.diagnose`: shapes, rigidity, at least 3 positions, motions
about two axes), and after it checks the output (shape (4, 4), finite, rigid to
:data:`rasc.geometry.transforms.RIGID_ATOL`) and computes the quality (eq. 10, over all
ordered pairs) and the diagnostics itself, so every method's are comparable;
:func:`jackknife_uncertainty` works for any method. A plugin that cannot be imported,
raises, or returns something else gives ONE line naming the plugin and what it did
(:class:`PluginError`, or :class:`~rasc.errors.InputError` for a name that cannot be
resolved). ``check_rigid`` and ``min_rotation_rad`` are the wrapper's options (as
:func:`~rasc.handeye.solver.solve_rasc`'s); any other option is passed to the plugin.

Built-in entries are ``callable(T_cam_from_world, T_gaze_from_ptu, **options) ->
HandEyeResult``; options are the solver's keywords (``check_rigid`` for all, ``pairs``
for "rasc", ``home`` for "li", ``seed`` and ``max_draws`` for "rasc-robust"). The
OpenCV entries import cv2 only when called.
"""

from __future__ import annotations

import functools
import importlib
import importlib.metadata
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rasc.errors import InputError, RascError, SolverFailure
from rasc.geometry.transforms import RIGID_ATOL, rotvec_from_matrix
from rasc.guard import PluginExited, PluginTimedOut, guarded
from rasc.handeye.inverse import solve_rasc_inverse, solve_rasc_views
from rasc.handeye.li import solve_li
from rasc.handeye.opencv import CV_METHODS, solve_opencv
from rasc.handeye.robust import solve_rasc_robust
from rasc.handeye.scale import solve_rasc_scaled
from rasc.handeye.solver import (
    MIN_PAIR_ROTATION_RAD,
    HandEyeResult,
    HandEyeUncertainty,
    diagnose,
    quality_eq10,
    solve_rasc,
    solve_rasc_each,
)

#: The entry-point group through which installed packages register method names.
ENTRY_POINT_GROUP = "rasc.methods"

METHODS: dict[str, Callable[..., HandEyeResult]] = {
    "rasc": solve_rasc,
    "li": solve_li,
    "rasc-inverse": solve_rasc_inverse,
    "rasc-views": solve_rasc_views,
    "rasc-robust": solve_rasc_robust,
    "rasc-scale": solve_rasc_scaled,
    **{f"opencv-{m}": functools.partial(solve_opencv, method=m) for m in CV_METHODS},
}

#: ``package.module:function`` (the function may be a dotted attribute path).
_REFERENCE = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*$")


class PluginError(SolverFailure):
    """A plugin method raised, or returned something that is not a rigid 4×4 transform.
    The message names the method and what it did."""


@dataclass(frozen=True)
class Method:
    """A resolved hand-eye method: call it as ``method(T_cam_from_world,
    T_gaze_from_ptu, **options) -> HandEyeResult``.

    name : the name it was resolved from ("rasc", "mypkg.solvers:solve", "my-solver").
    function : the callable behind it.
    origin : "built-in", "module:function", or "entry point NAME = VALUE (DIST VERSION)".
    """

    name: str
    function: Callable[..., Any]
    origin: str

    @property
    def builtin(self) -> bool:
        """True for a method shipped with rasc, False for a plugin."""
        return self.origin == "built-in"

    def __call__(self, T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
                 **options) -> HandEyeResult:
        if self.builtin:
            return self.function(T_cam_from_world, T_gaze_from_ptu, **options)
        return _run_plugin(self, T_cam_from_world, T_gaze_from_ptu, **options)


def _run_plugin(method: Method, T_cam_from_world, T_gaze_from_ptu, *,
                check_rigid: bool = True, min_rotation_rad: float = MIN_PAIR_ROTATION_RAD,
                **options) -> HandEyeResult:
    """Validate and check the data (as RASC), call the plugin, check what it returned,
    add eq. 10 and the diagnostics."""
    diagnostics, T_cw, T_gp = diagnose(T_cam_from_world, T_gaze_from_ptu,
                                       min_rotation_rad=min_rotation_rad,
                                       check_rigid=check_rigid)
    who = f"method {method.name}"
    try:
        # rasc.guard: what the plugin prints goes to stderr (stdout carries the result, a
        # JSON document); sys.exit / os._exit end the call, never the process; a call
        # that hangs ends at the guard's time limit (generous: minutes)
        out = guarded(method.function, T_cw.copy(), T_gp.copy(), who=who, **options)
    except PluginExited as exc:      # its class kept: a study counts "failed: PluginExited"
        raise PluginExited(f"{who} {str(exc).removeprefix(who + ': ')} instead of "
                           "returning a result") from None
    except PluginTimedOut:
        raise
    except RascError as exc:  # the plugin's own one-line error keeps its class
        raise type(exc)(f"{who}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 -- any failure of user code, in one line
        text = " ".join(str(exc).split())
        raise PluginError(f"{who} raised {type(exc).__name__}"
                          + (f": {text}" if text else "")) from None
    T = check_plugin_output(out, who)
    R = np.ascontiguousarray(T_cw[None, :, :3, :3])
    Q = np.ascontiguousarray(T_gp[None, :, :3, :3])
    quality = float(quality_eq10(R, Q, T[None, :3, :3])[0])
    return HandEyeResult(T_cam_from_gaze=T, quality=quality, method=method.name,
                         diagnostics=diagnostics)


def check_plugin_output(out: Any, who: str = "method") -> np.ndarray:
    """``out`` (a 4×4 array-like or a HandEyeResult) as a rigid (4, 4) float array, else
    :class:`PluginError` ``"<who> returned ..."``."""
    T = out.T_cam_from_gaze if isinstance(out, HandEyeResult) else out
    try:
        T = np.array(T, dtype=float)
    except (TypeError, ValueError):
        raise PluginError(f"{who} returned {type(out).__name__}, expected a 4x4 "
                          "T_cam_from_gaze (array) or a HandEyeResult") from None
    if T.shape != (4, 4):
        raise PluginError(f"{who} returned shape {T.shape}, expected (4, 4)")
    if not np.isfinite(T).all():
        raise PluginError(f"{who} returned a matrix with NaN or infinity: "
                          f"{np.round(T, 6).tolist()}")
    last = float(np.abs(T[3] - [0.0, 0.0, 0.0, 1.0]).max())
    if last > RIGID_ATOL:
        raise PluginError(f"{who} returned a matrix whose last row is {T[3].tolist()}, "
                          "expected [0, 0, 0, 1]")
    R = T[:3, :3]
    ortho = float(np.abs(R.T @ R - np.eye(3)).max())
    det = float(np.linalg.det(R))
    if ortho > RIGID_ATOL or abs(det - 1.0) > RIGID_ATOL:
        raise PluginError(f"{who} returned a matrix that is not a rigid transform: "
                          f"max |RᵀR − I| = {ortho:.3g}, det R = {det:.6g} (tolerance "
                          f"{RIGID_ATOL:g})")
    return T


# -------------------------------------------------------------------- resolution

def _entry_points() -> dict[str, list[importlib.metadata.EntryPoint]]:
    """The group's entry points by name (a distribution found twice on the path is one)."""
    found: dict[str, list[importlib.metadata.EntryPoint]] = {}
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        same = found.setdefault(ep.name, [])
        if all(e.value != ep.value for e in same):
            same.append(ep)
    return found


def registered_methods() -> dict[str, str]:
    """Names registered through the ``rasc.methods`` entry points → their ``module:function``
    (built-in names win over a registration of the same name)."""
    return {name: eps[0].value for name, eps in sorted(_entry_points().items())
            if name not in METHODS}


def available_methods() -> dict[str, str]:
    """Every name :func:`get_method` resolves without a ``module:function``: built-in
    names → "built-in", registered names → their ``module:function``."""
    return {**{name: "built-in" for name in METHODS}, **registered_methods()}


def _import(reference: str, who: str) -> Callable[..., Any]:
    module_name, _, attr = reference.partition(":")
    try:
        obj: Any = importlib.import_module(module_name)
    except Exception as exc:  # noqa: BLE001 -- a broken plugin module, in one line
        text = " ".join(str(exc).split())
        raise InputError(f"{who}: cannot import module {module_name} "
                         f"({type(exc).__name__}: {text})") from None
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise InputError(f"{who}: module {module_name} has no attribute "
                             f"{attr!r}") from None
    if not callable(obj):
        raise InputError(f"{who}: {reference} is a {type(obj).__name__}, not a callable")
    return obj


def _describe(fn: Callable[..., Any]) -> str:
    module = getattr(fn, "__module__", None) or "?"
    return f"{module}:{getattr(fn, '__qualname__', type(fn).__name__)}"


@functools.lru_cache(maxsize=256)
def _resolve_plugin(name: str) -> Method:
    if ":" in name:
        if not _REFERENCE.match(name):
            raise InputError(f"method {name!r}: expected a method name or "
                             "package.module:function")
        return Method(name, _import(name, f"method {name}"), "module:function")
    eps = _entry_points().get(name)
    if not eps:
        known = ", ".join(available_methods())
        raise InputError(f"method {name!r}: unknown; expected one of {known} (built-in or "
                         f"registered through the {ENTRY_POINT_GROUP} entry points), or "
                         "package.module:function")
    if len(eps) > 1:
        raise InputError(f"method {name!r}: registered twice in the {ENTRY_POINT_GROUP} "
                         "entry points, as " + " and ".join(e.value for e in eps))
    ep = eps[0]
    dist = getattr(ep, "dist", None)
    origin = f"entry point {ep.name} = {ep.value}" + (
        f" ({dist.name} {dist.version})" if dist is not None else "")
    who = f"method {name} ({ep.value})"
    if not _REFERENCE.match(ep.value):
        raise InputError(f"{who}: the entry point is not package.module:function")
    return Method(name, _import(ep.value, who), origin)


def get_method(name: str | Method | Callable[..., Any]) -> Method:
    """Resolve a method: a built-in name, ``package.module:function``, a name registered
    in the ``rasc.methods`` entry points, a :class:`Method`, or a callable (wrapped as a
    plugin, named ``module:qualname``).

    Raises :class:`~rasc.errors.InputError` (one line) when the name cannot be resolved:
    unknown, malformed, a module that fails to import, a missing attribute.
    """
    if isinstance(name, Method):
        return name
    if callable(name) and not isinstance(name, str):
        return Method(_describe(name), name, "callable")
    if not isinstance(name, str) or not name:
        raise InputError(f"method: expected a name, got {name!r}")
    if name in METHODS:
        return Method(name, METHODS[name], "built-in")
    return _resolve_plugin(name)


def clear_cache() -> None:
    """Forget resolved plugins (after installing a package in a running process)."""
    _resolve_plugin.cache_clear()


def solve(method: str | Method | Callable[..., Any], T_cam_from_world: np.ndarray,
          T_gaze_from_ptu: np.ndarray, **options) -> HandEyeResult:
    """Run the hand-eye method ``method`` (anything :func:`get_method` resolves)."""
    return get_method(method)(T_cam_from_world, T_gaze_from_ptu, **options)


#: The options the batched RASC solve takes (:func:`solve_many`).
_BATCH_OPTIONS = frozenset({"pairs", "min_rotation_rad", "check_rigid"})


def solve_many(method: str | Method | Callable[..., Any], T_cam_from_world: np.ndarray,
               T_gaze_from_ptu: np.ndarray, **options) -> list[HandEyeResult | Exception]:
    """Solve S pose sets with one method: set s's result or the exception it raised.

    Parameters
    ----------
    method : anything :func:`get_method` resolves.
    T_cam_from_world : array-like, shape (S, n, 4, 4)
    T_gaze_from_ptu : array-like, shape (n, 4, 4) shared by all sets, or (S, n, 4, 4)
    **options : as for :func:`solve`.

    Returns
    -------
    list of HandEyeResult or Exception, length S
        Entry s is exactly what ``solve(method, T_cam_from_world[s], T_gaze_from_ptu[s],
        **options)`` returns (the same bits), or the exception it raises (the same class
        and message). "rasc" goes through the batched solver
        (:func:`~rasc.handeye.solver.solve_rasc_each`, whose results do not depend on the
        batch); a set that makes a batch fail is found by halving the batch, and solved
        alone. Every other method is called set by set. An exception is returned, not
        raised, whatever its class.
    """
    m = get_method(method)
    T_cw = np.asarray(T_cam_from_world, dtype=float)
    T_gp = np.asarray(T_gaze_from_ptu, dtype=float)
    if T_cw.ndim < 1:
        raise InputError(f"T_cam_from_world: expected shape (S, n, 4, 4), got {T_cw.shape}")
    shared = T_gp.ndim != T_cw.ndim
    if not shared and len(T_gp) != len(T_cw):
        raise InputError(f"T_gaze_from_ptu has {len(T_gp)} sets, T_cam_from_world "
                         f"{len(T_cw)}")

    def unit(s: slice | int) -> np.ndarray:
        return T_gp if shared else T_gp[s]

    def one(s: int) -> HandEyeResult | Exception:
        try:
            return m(T_cw[s], unit(s), **options)
        except Exception as exc:  # noqa: BLE001 -- handed back to the caller, per set
            return exc

    if not (m.builtin and m.function is solve_rasc and set(options) <= _BATCH_OPTIONS
            and T_cw.ndim == 4 and len(T_cw)):
        return [one(s) for s in range(len(T_cw))]

    def batch(lo: int, hi: int) -> list[HandEyeResult | Exception]:
        if hi - lo == 1:
            return [one(lo)]
        try:
            return solve_rasc_each(T_cw[lo:hi], unit(slice(lo, hi)), **options)
        except Exception:  # noqa: BLE001 -- some set fails: halve, down to single solves
            mid = (lo + hi) // 2
            return batch(lo, mid) + batch(mid, hi)

    return batch(0, len(T_cw))


def jackknife_uncertainty(method: str | Method | Callable[..., Any],
                          T_cam_from_world: np.ndarray,
                          T_gaze_from_ptu: np.ndarray, result: HandEyeResult,
                          **options) -> HandEyeUncertainty:
    """How far ``result`` is likely to be from the truth, from the data alone.

    The jackknife over positions: solve again with each position left out (same method
    and options; Li's ``home`` follows its position, and is the default home when it is
    the one left out), and take ``√((n−1)/n · Σ_k ‖d_k − mean d‖²)`` of the rotation
    vectors ``d_k = log(R_k R_resultᵀ)`` and of the translations. That is the jackknife
    standard error of the whole error vector, comparable with the RMS of the rotation
    error (as an angle) and of the translation error (as a distance) over repeated
    calibrations. It needs no noise model: it sees whatever the data carry (pose noise,
    small or one-sided motions), and works for any method (:func:`get_method`). Against
    the RMS of the real error over 200 seeded noisy calibrations it measured 1.08-1.25×
    it (slightly conservative) for nine positions at ±2°, ±8° and ±20° and σ_r from
    0.0005 to 0.02 rad; tests/handeye/test_methods.py checks three of those settings with 100
    calibrations each. It does not see an error that every view shares (a focal-length
    error biasing all the extrinsics alike), and for a single calibration it is an
    estimate of the spread, not of that calibration's own error.

    With fewer than 4 positions, or when leaving out a position makes the data degenerate
    (or the method fails), there is no estimate: ``rotation_deg`` and ``translation``
    are None and ``reason`` says why.
    """
    solver = get_method(method)
    T_cw = np.asarray(T_cam_from_world, dtype=float)
    T_gp = np.asarray(T_gaze_from_ptu, dtype=float)
    n = len(T_cw)
    if n < 4:
        return HandEyeUncertainty(None, None, 0, f"only {n} positions: the jackknife needs "
                                  "at least 4 (each left out once, 3 remain)")
    options = dict(options)
    home = options.pop("home", None)
    R0 = np.asarray(result.T_cam_from_gaze)[:3, :3]
    rot, trans = [], []
    for k in range(n):
        keep = np.array([i for i in range(n) if i != k])
        extra = dict(options)
        if home is not None and home != k:
            extra["home"] = home - (k < home)
        try:
            T = solver(T_cw[keep], T_gp[keep], **extra).T_cam_from_gaze
        except RascError as exc:
            return HandEyeUncertainty(None, None, 0, f"without position {k} the data "
                                      f"cannot be solved ({exc}); add positions")
        rot.append(rotvec_from_matrix(np.asarray(T)[:3, :3] @ R0.T))
        trans.append(np.asarray(T)[:3, 3])
    f = (n - 1) / n

    def se(v: np.ndarray) -> float:
        return float(np.sqrt(f * ((v - v.mean(axis=0)) ** 2).sum()))

    return HandEyeUncertainty(float(np.degrees(se(np.array(rot)))), se(np.array(trans)), n,
                              None)
