"""Hand-eye from two timestamped pose streams, with the time offset between their clocks.

A head that never stops records two streams, each on its own clock: the unit's poses
``T_gaze_from_ptu(s_j)`` (encoders, 100–1000 Hz) and the target's poses in the camera
``T_cam_from_world(t_k)`` (10–60 Hz). **Sign convention**: the unit's clock reads the
camera's plus δ, so the camera pose stamped ``t_k`` pairs with the unit's pose at
``t_k + δ`` on the unit's clock. Pairing each camera pose with the unit pose nearest in
time (δ taken as 0) turns δ into a pose error of δ times the rotation speed (0.05 s at
30°/s is 1.5°), which no closed form can undo.

:func:`solve_streams` estimates δ in two steps (the time alignment of ethz-asl's
hand_eye_calibration, the refinement done jointly as Kalibr does):

1. **Coarse** (:func:`coarse_time_offset`): the rotation speed of each stream, the angle
   between camera poses :data:`SPEED_BASELINE` apart over their interval, and the same for
   the unit's poses interpolated at the camera's stamps plus a trial δ. The angle of a
   relative rotation is the same in the camera's frame and the unit's (``A = X B X⁻¹``),
   so the two speed signals are equal at the true δ whatever the hand-eye. δ on a grid over
   ``±max_offset`` (half a camera interval apart) maximises their correlation, refined
   by a parabola through the best three.
2. **Joint refinement**: ``T_cam_from_world_k ≈ X · T_gaze_from_ptu(t_k + δ) · Y`` over
   X, Y and δ (13 unknowns), the unit stream interpolated at ``t_k + δ`` (a rotation
   spline, :class:`scipy.spatial.transform.RotationSpline`, and a cubic spline for the
   translation: both smooth in δ), solved by the pose-residual refinement of
   :mod:`rasc.handeye.robust_refine` (its residuals, robust loss, noise scales and
   covariance, :func:`~rasc.handeye.robust_refine.fit_problem`) from a closed form
   (``method``, through the outlier policy :func:`rasc.handeye.robust_calibrate.closed_form`)
   on :data:`START_POSES` camera poses paired at the coarse δ. δ's standard deviation is
   the square root of its entry in the covariance ``s² (Jᵀ W J)⁻¹``, scaled by the
   residuals (``s²``); X's covariance has δ's uncertainty in it.

With ``time_offset`` a number, δ is held at it (X and Y refined; no σ for δ).

Refused (:class:`~rasc.errors.DegenerateDataError`, one line): a unit stream that turns less
than :data:`MIN_TURN_DEG`; streams that share fewer than :data:`MIN_POSES` camera
poses, or overlap for less than :data:`MIN_OVERLAP` seconds, at every δ in range; a
rotation speed nearly constant (coefficient of variation below
:data:`MIN_SPEED_VARIATION`), whose magnitude cannot time the streams; speeds that match
at no δ (correlation below :data:`MIN_CORRELATION`); two δ that match about as well
(within :data:`AMBIGUITY`: a periodic motion); a best δ at the edge of the range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.transforms import make_transform, project_to_rotation
from rasc.handeye.robust_refine import (
    F_SCALE,
    N_PARAMS,
    RefinedHandEyeResult,
    _log,
    _Problem,
    fit_problem,
    target_start,
)
from rasc.handeye.solver import quality_eq10, validate_poses
from rasc.io import finite_number

#: The choices of ``time_offset`` besides a number of seconds: "estimate" (the default
#: for streams) and "hold" (held at 0: the two clocks taken as one).
TIME_OFFSET_MODES = ("estimate", "hold")

#: The default search range of the coarse step, ±seconds. Clock offsets between a camera
#: and encoders on separate machines are tens of milliseconds (kalibr#117's users report
#: 10–100 ms); half a second covers a driver's buffering too while keeping the motion's
#: own periods (seconds) out of the search.
DEFAULT_MAX_OFFSET = 0.5

#: Camera poses that must lie inside the unit stream's span (at the δ tried) for the
#: streams to be compared: fewer cannot show a speed profile (a second of a 30 Hz camera
#: is 30).
MIN_POSES = 20

#: The streams must overlap for at least this long (seconds) at the δ tried: a shorter
#: stretch holds a few swings of a head's motion (0.1–1 Hz) at most, and its speed profile
#: can match a wrong δ by chance (measured: camera poses whose true overlap with the unit
#: stream was 0.2 s matched a δ 2.5 s off, over the 2.7 s of overlap there, with a
#: correlation above the best elsewhere).
MIN_OVERLAP = 5.0

#: A unit stream that turns less than this (degrees, largest angle from its first pose)
#: has no motion to time.
MIN_TURN_DEG = 1.0

#: The unit's rotation speed over the camera's interval must vary by at least this
#: fraction of its mean (standard deviation / mean): a constant speed gives the same
#: magnitude at every δ.
MIN_SPEED_VARIATION = 0.1

#: The best δ's correlation of the two speed signals must be at least this.
MIN_CORRELATION = 0.5

#: A second local maximum of the correlation within this of the best (outside the best
#: one's own peak) makes δ ambiguous.
AMBIGUITY = 0.05

#: The coarse step's rotation speeds are angles between camera poses this far apart
#: (seconds, rounded to whole camera intervals): a pose's noise then counts for a
#: fraction of the angle (at 30 Hz, six intervals: 0.002 rad of noise against the 0.06 rad
#: that 0.3 rad/s turns in 0.2 s), while the speed still follows a head's motion (0.1–1 Hz).
SPEED_BASELINE = 0.2

#: Camera poses paired at the coarse δ that the closed-form start uses (evenly spread
#: over the overlap): enough to average the noise, few enough for a fast solve.
START_POSES = 60

#: δ's std above this fraction of the camera's interval is warned of as poorly
#: determined: the unit's pose is then uncertain by a good part of what it turns between
#: two frames (measured on 0.002 rad / 1 mm poses at 30 Hz: 0.09 ms for ±20° motions,
#: 0.9 ms for ±3°; a δ matched by chance on too little overlap: 33 ms).
POOR_STD_FRACTION = 0.25

#: Central-difference step of δ in the covariance's Jacobian, seconds.
STEP_TIME = 1e-5


def parse_time_offset(value: Any, name: str = "time_offset") -> str | float:
    """``"estimate"``, ``"hold"`` (returned as 0.0) or a number of seconds (a string that
    reads as one, or a number) → "estimate" or a float; else :class:`InputError`."""
    if isinstance(value, str):
        text = value.strip()
        if text == "estimate":
            return "estimate"
        if text == "hold":
            return 0.0
        try:
            number = float(text)
        except ValueError:
            raise InputError(f"{name} = {value!r}: expected 'estimate', 'hold' or a number "
                             "of seconds (the unit's clock minus the camera's)") from None
        if not math.isfinite(number):
            raise InputError(f"{name} = {value!r}: expected a finite number of seconds")
        return number
    return finite_number(value, name)


def check_max_offset(value: Any, name: str = "max_offset") -> float:
    """A positive finite number of seconds, else :class:`InputError`."""
    v = finite_number(value, name)
    if v <= 0:
        raise InputError(f"{name} = {v:g}: expected a positive number of seconds")
    return v


@dataclass(frozen=True)
class TimeOffsetOptions:
    """The one set of choices for streams, shared by :func:`solve_streams` and
    ``rasc handeye``.

    time_offset : "estimate" (default) or seconds to hold δ at ("hold" reads as 0).
    max_offset : the coarse search range ±seconds (:data:`DEFAULT_MAX_OFFSET`).
    method : the closed form the refinement starts from (any method name).
    loss : the refinement's robust loss (:data:`rasc.handeye.robust_refine.LOSSES`).
    """

    time_offset: str | float = "estimate"
    max_offset: float = DEFAULT_MAX_OFFSET
    method: str = "rasc"
    loss: str = "huber"

    def __post_init__(self):
        object.__setattr__(self, "time_offset", parse_time_offset(self.time_offset))
        object.__setattr__(self, "max_offset", check_max_offset(self.max_offset))

    @property
    def estimate(self) -> bool:
        """True when δ is estimated, False when held."""
        return self.time_offset == "estimate"


class UnitStream:
    """The unit's poses as a function of time (its own clock): a rotation spline and a
    cubic spline of the translations through the samples."""

    def __init__(self, times: np.ndarray, T_gaze_from_ptu: np.ndarray):
        from scipy.interpolate import CubicSpline
        from scipy.spatial.transform import Rotation, RotationSpline

        self.times = np.asarray(times, dtype=float)
        R = project_to_rotation(np.asarray(T_gaze_from_ptu, dtype=float)[:, :3, :3])
        self._rotation = RotationSpline(self.times, Rotation.from_matrix(R))
        self._translation = CubicSpline(self.times, T_gaze_from_ptu[:, :3, 3])
        self._R0 = R[0]
        self._R = R

    @property
    def span(self) -> tuple[float, float]:
        """The first and last sample's time."""
        return float(self.times[0]), float(self.times[-1])

    def rotations(self, t: np.ndarray) -> np.ndarray:
        """(..., 3, 3) at times t (any shape)."""
        t = np.asarray(t, dtype=float)
        return self._rotation(t.ravel()).as_matrix().reshape(t.shape + (3, 3))

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """(len(t), 4, 4) poses at times t (1-D)."""
        t = np.asarray(t, dtype=float)
        return make_transform(self.rotations(t), self._translation(t))

    def largest_turn_deg(self) -> float:
        """The largest angle between the first sample and any other, degrees."""
        rel = np.swapaxes(self._R, -1, -2) @ self._R0
        return float(np.degrees(np.linalg.norm(_log(rel), axis=1).max()))


def _angles(Ra: np.ndarray, Rb: np.ndarray) -> np.ndarray:
    """Angles (rad) of Ra_k Rb_kᵀ, any leading shape."""
    rel = Ra @ np.swapaxes(Rb, -1, -2)
    shape = rel.shape[:-2]
    return np.linalg.norm(_log(rel.reshape(-1, 3, 3)), axis=1).reshape(shape)


@dataclass(frozen=True)
class CoarseOffset:
    """The coarse step's answer (:func:`coarse_time_offset`).

    time_offset : δ, seconds. correlation : the speeds' correlation there.
    offsets, correlations : the grid and its correlations (NaN: too little overlap).
    speed_variation : the unit's rotation speed's standard deviation / mean.
    """

    time_offset: float
    correlation: float
    offsets: np.ndarray
    correlations: np.ndarray
    speed_variation: float


def _inside(times: np.ndarray, offset: float, unit: UnitStream, margin: float = 0.0
            ) -> np.ndarray:
    lo, hi = unit.span
    t = times + offset
    return (t >= lo + margin) & (t <= hi - margin)


def _describe_spans(times: np.ndarray, unit: UnitStream, origin: float) -> str:
    lo, hi = unit.span
    return (f"the camera poses are stamped {times[0] + origin:.6g} to "
            f"{times[-1] + origin:.6g} s, the unit stream {lo + origin:.6g} to "
            f"{hi + origin:.6g} s")


def coarse_time_offset(times: np.ndarray, T_cam_from_world: np.ndarray, unit: UnitStream,
                       max_offset: float = DEFAULT_MAX_OFFSET, *, origin: float = 0.0
                       ) -> CoarseOffset:
    """δ from the two streams' rotation speeds (module docstring, step 1). ``origin``:
    what was subtracted from both streams' stamps (added back in messages).

    Raises :class:`DegenerateDataError` (one line, what would fix it) for the cases the
    module docstring lists.
    """
    times = np.asarray(times, dtype=float)
    turn = unit.largest_turn_deg()
    if turn < MIN_TURN_DEG:
        raise DegenerateDataError(
            f"the unit stream turns at most {turn:.3g}° (< {MIN_TURN_DEG:g}°): no motion "
            "to time the streams by; record the unit while it moves")
    R_cam = project_to_rotation(np.asarray(T_cam_from_world, dtype=float)[:, :3, :3])
    step = float(np.median(np.diff(times)))
    lag = max(1, int(round(SPEED_BASELINE / step)))   # poses apart: noise / lag
    if len(times) <= lag:
        lag = max(1, len(times) - 1)
    a, b = np.arange(len(times) - lag), np.arange(lag, len(times))
    dt = times[b] - times[a]
    speed_cam = _angles(R_cam[a], R_cam[b]) / dt
    h = step / 2
    k = max(int(math.ceil(max_offset / h)), 1)
    offsets = np.linspace(-max_offset, max_offset, 2 * k + 1)
    lo, hi = unit.span
    speed_unit = np.empty((len(offsets), len(dt)))
    for i, offset in enumerate(offsets):       # one offset at a time: memory ∝ n
        R_unit = unit.rotations(np.clip(times + offset, lo, hi))
        speed_unit[i] = _angles(R_unit[a], R_unit[b]) / dt
    shifted = times[None, :] + offsets[:, None]
    inside = (shifted >= lo) & (shifted <= hi)
    valid = inside[:, a] & inside[:, b]
    count = inside.sum(axis=1)
    lasts = np.array([np.ptp(times[v]) + step if v.any() else 0.0 for v in inside])
    enough = (count >= MIN_POSES) & (lasts >= MIN_OVERLAP) & (valid.sum(axis=1) >= 3)
    if not enough.any():
        poses = int(count.max())
        raise DegenerateDataError(
            f"the streams overlap for at most {lasts.max():.3g} s ({poses} camera "
            f"poses) at any time offset within ±{max_offset:g} s (need {MIN_OVERLAP:g} s "
            f"and {MIN_POSES} poses): {_describe_spans(times, unit, origin)}; record both "
            "streams over the same motion, or widen the offset's range")
    corr = np.full(len(offsets), np.nan)
    variation = np.full(len(offsets), np.nan)
    for i in np.flatnonzero(enough):
        cam, own = speed_cam[valid[i]], speed_unit[i][valid[i]]
        variation[i] = own.std() / max(own.mean(), 1e-300)
        if cam.std() > 0 and own.std() > 0:
            corr[i] = float(np.corrcoef(cam, own)[0, 1])
    speed_variation = float(np.nanmedian(variation))
    if speed_variation < MIN_SPEED_VARIATION:
        raise DegenerateDataError(
            f"the unit's rotation speed is nearly constant (it varies by {speed_variation:.2g}"
            f" of its mean, < {MIN_SPEED_VARIATION:g}): its magnitude cannot time the "
            "streams; record a motion whose speed changes (speed up, slow down, reverse)")
    if not np.any(np.isfinite(corr)):
        raise DegenerateDataError("the camera's rotation speed is constant: it cannot time "
                                  "the streams")
    best = int(np.nanargmax(corr))
    c1 = float(corr[best])
    if c1 < MIN_CORRELATION:
        raise DegenerateDataError(
            f"the two streams' rotation speeds match at no time offset within "
            f"±{max_offset:g} s (best correlation {c1:.2f} at {offsets[best]:+.4f} s, "
            f"need {MIN_CORRELATION:g}): are they the same motion, is the offset larger?")
    if best == 0 or best == len(offsets) - 1 or not (np.isfinite(corr[best - 1])
                                                     and np.isfinite(corr[best + 1])):
        raise DegenerateDataError(
            f"the best time offset, {offsets[best]:+.4f} s, is at the edge of the range "
            f"searched (±{max_offset:g} s, or of the streams' overlap): widen the range "
            "(--max-time-offset) or record longer streams")
    # the best one's own peak: downhill from it on both sides
    left = best
    while left > 0 and np.isfinite(corr[left - 1]) and corr[left - 1] <= corr[left]:
        left -= 1
    right = best
    while right < len(corr) - 1 and np.isfinite(corr[right + 1]) \
            and corr[right + 1] <= corr[right]:
        right += 1
    others = np.r_[corr[:left], corr[right + 1:]]
    others = others[np.isfinite(others)]
    if others.size and others.max() >= c1 - AMBIGUITY:
        j = int(np.flatnonzero(np.where(np.isfinite(corr), corr, -np.inf)
                               == others.max())[0])
        raise DegenerateDataError(
            f"two time offsets match the streams' rotation speeds about as well "
            f"({offsets[best]:+.4f} s: correlation {c1:.3f}; {offsets[j]:+.4f} s: "
            f"{corr[j]:.3f}), as a periodic motion does: narrow the range "
            "(--max-time-offset) or record a motion that does not repeat")
    y0, y1, y2 = corr[best - 1], c1, corr[best + 1]
    den = y0 - 2 * y1 + y2
    frac = 0.5 * (y0 - y2) / den if den < 0 else 0.0
    step = offsets[1] - offsets[0]
    return CoarseOffset(time_offset=float(offsets[best] + np.clip(frac, -0.5, 0.5) * step),
                        correlation=c1, offsets=offsets, correlations=corr,
                        speed_variation=speed_variation)


class _TimedProblem(_Problem):
    """:class:`rasc.handeye.robust_refine._Problem` with the unit's poses interpolated at
    the camera's stamps plus δ; with ``estimate`` δ is the 13th unknown (its change from
    ``offset0``)."""

    def __init__(self, times, T_cw, unit: UnitStream, X0, Y0, offset0: float,
                 estimate: bool):
        super().__init__(T_cw, unit(times + offset0), X0, Y0)
        self.times, self.unit = times, unit
        self.offset0, self.estimate = offset0, estimate
        self._at = offset0

    @property
    def n_params(self) -> int:
        return N_PARAMS + int(self.estimate)

    def offset(self, p) -> float:
        return self.offset0 + (float(p[N_PARAMS]) if self.estimate else 0.0)

    def raw(self, p):
        if self.estimate:
            offset = self.offset(p)
            if offset != self._at:      # the Jacobian's other 12 columns keep δ
                self.G, self._at = self.unit(self.times + offset), offset
        return super().raw(p)


@dataclass(frozen=True)
class TimedHandEyeResult(RefinedHandEyeResult):
    """A hand-eye result from two pose streams (module docstring).

    time_offset : δ in seconds (the unit's clock minus the camera's).
    std_time_offset : its standard deviation (NaN when held).
    time_offset_mode : "estimate" or "hold".
    coarse_time_offset, correlation : the coarse step's δ and speed correlation (NaN when
        held).
    n_used : camera poses inside the unit stream at δ (refined over); n_camera : all.
    max_offset : the coarse step's range.
    notes : sentences for the user: camera poses left out, the outlier policy's note,
        :func:`rasc.handeye.advice.translation_warnings` on the aligned pairs.
    """

    time_offset: float = math.nan
    std_time_offset: float = math.nan
    time_offset_mode: str = "estimate"
    coarse_time_offset: float = math.nan
    correlation: float = math.nan
    n_used: int = 0
    n_camera: int = 0
    max_offset: float = DEFAULT_MAX_OFFSET
    notes: tuple[str, ...] = field(default=())

    def to_dict(self) -> dict[str, Any]:
        """The refined result's document with a ``time_offset`` block."""
        out = super().to_dict()
        out["time_offset"] = time_offset_summary(self)
        return out


def time_offset_summary(result: TimedHandEyeResult) -> dict[str, Any]:
    """The time offset's numbers as a JSON-ready dict."""
    estimated = result.time_offset_mode == "estimate"
    return {
        "mode": result.time_offset_mode,
        "seconds": result.time_offset,
        "std": result.std_time_offset if estimated else None,
        "meaning": "the unit's clock minus the camera's: the camera pose stamped t pairs "
                   "with the unit's pose at t + seconds on the unit's clock",
        **({"coarse": result.coarse_time_offset, "speed_correlation": result.correlation,
            "max_offset": result.max_offset,
            "how": "coarse: correlation of the two streams' rotation speeds; then refined "
                   "jointly with T_cam_from_gaze (std from the refinement's covariance)"}
           if estimated else {}),
        "n_camera_poses_used": result.n_used,
        "n_camera_poses": result.n_camera,
    }


def _validate_times(times: Any, n: int, name: str) -> np.ndarray:
    t = np.asarray(times, dtype=float)
    if t.shape != (n,):
        raise InputError(f"{name}: expected shape ({n},), got {t.shape}")
    if not np.all(np.isfinite(t)):
        k = int(np.flatnonzero(~np.isfinite(t))[0])
        raise InputError(f"{name}[{k}]: NaN or infinity")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise InputError(f"{name}[{k}] = {t[k]:.9g} is not after {name}[{k - 1}] = "
                         f"{t[k - 1]:.9g}: stamps must increase")
    return t


def solve_streams(times: np.ndarray, T_cam_from_world: np.ndarray, unit_times: np.ndarray,
                  T_gaze_from_ptu: np.ndarray,
                  options: TimeOffsetOptions | None = None) -> TimedHandEyeResult:
    """Hand-eye and the time offset from two timestamped pose streams (module docstring).

    Parameters
    ----------
    times : (n,) the camera poses' stamps (camera clock, seconds, increasing).
    T_cam_from_world : (n, 4, 4) the target's pose in the camera at each.
    unit_times : (m,) the unit poses' stamps (unit clock, seconds, increasing).
    T_gaze_from_ptu : (m, 4, 4) the unit's pose at each (for an arm, T_gripper_from_base).
    options : :class:`TimeOffsetOptions` (default: δ estimated within ±0.5 s, RASC start,
        Huber loss).

    Returns
    -------
    TimedHandEyeResult
        ``T_cam_from_gaze``, δ and its σ, X's covariance (δ's uncertainty included);
        ``quality`` (eq. 10) and ``diagnostics`` are those of the closed form's
        :data:`START_POSES` camera poses paired at the final δ.
        Raises :class:`DegenerateDataError` (module docstring), :class:`InputError` for
        malformed streams or streams whose motions do not match once aligned
        (:func:`rasc.handeye.advice.check_motions_match`), :class:`SolverFailure` when the
        refinement fails.
    """
    from rasc.handeye.advice import check_motions_match, translation_warnings
    from rasc.handeye.robust_calibrate import closed_form
    from rasc.handeye.solver import diagnose

    options = options or TimeOffsetOptions()
    T_cw = validate_poses(T_cam_from_world, "T_cam_from_world")
    T_gp = validate_poses(T_gaze_from_ptu, "T_gaze_from_ptu")
    t_cam = _validate_times(times, len(T_cw), "times")
    t_unit = _validate_times(unit_times, len(T_gp), "unit_times")
    if len(t_unit) < 4:
        raise InputError(f"unit_times: need at least 4 unit poses to interpolate, got "
                         f"{len(t_unit)}")
    origin = float(t_cam[0])            # stamps near 1.7e9 s (Unix time) lose nothing
    t_cam, t_unit = t_cam - origin, t_unit - origin
    unit = UnitStream(t_unit, T_gp)
    T_cw = T_cw.copy()
    T_cw[:, :3, :3] = project_to_rotation(T_cw[:, :3, :3])
    if options.estimate:
        coarse = coarse_time_offset(t_cam, T_cw, unit, options.max_offset,
                                    origin=origin)
        offset0 = coarse.time_offset
    else:
        coarse, offset0 = None, float(options.time_offset)
    interval = float(np.median(np.diff(t_cam)))
    margin = interval                   # δ moves by less in the refinement
    used = np.flatnonzero(_inside(t_cam, offset0, unit, margin if options.estimate else 0.0))
    if len(used) < MIN_POSES:
        raise DegenerateDataError(
            f"only {len(used)} camera poses lie inside the unit stream at the time offset "
            f"{offset0:+.4f} s (need {MIN_POSES}): {_describe_spans(t_cam, unit, origin)}")
    G_used = unit(t_cam[used] + offset0)
    pick = used[np.unique(np.linspace(0, len(used) - 1, min(len(used), START_POSES))
                          .round().astype(int))]
    G_pick = unit(t_cam[pick] + offset0)
    check_motions_match(T_cw[pick], G_pick)
    closed = closed_form(options.method, T_cw[pick], G_pick,
                         names=[f"positions[{k}]" for k in pick])
    X0 = np.asarray(closed.result.T_cam_from_gaze, dtype=float)
    Y0 = target_start(X0, G_used, T_cw[used])
    problem = _TimedProblem(t_cam[used], T_cw[used], unit, X0, Y0, offset0,
                            options.estimate)
    distance = max(float(np.median(np.linalg.norm(T_cw[used, :3, 3], axis=1))), 1e-300)
    p = np.zeros(problem.n_params)
    p[3:6], p[9:12] = X0[:3, 3], Y0[:3, 3]
    what = "T_cam_from_gaze and the time offset" if options.estimate else "T_cam_from_gaze"
    p, z, C = fit_problem(problem, p, loss=options.loss, distance=distance,
                          extra_steps=np.full(problem.n_params - N_PARAMS, STEP_TIME),
                          what=what)
    offset = problem.offset(p)
    X, Y = problem.transforms(p)
    G_final = unit(t_cam[used] + offset)
    # eq. 10 and the diagnostics over the closed form's poses, paired at the final δ (over
    # every camera pose they would cost n² pairs)
    G_pick = unit(t_cam[pick] + offset)
    R = np.ascontiguousarray(T_cw[None, pick, :3, :3])
    Q = np.ascontiguousarray(G_pick[None, :, :3, :3])
    quality = float(quality_eq10(R, Q, X[None, :3, :3])[0])
    diagnostics = diagnose(T_cw[pick], G_pick)[0]
    CX = C[:6, :6].copy()
    CX.flags.writeable = False
    per_position = np.abs(z.reshape(len(used), 6)).max(axis=1)
    notes = []
    if len(used) < len(t_cam):
        notes.append(f"{len(t_cam) - len(used)} of {len(t_cam)} camera poses lie outside "
                     f"the unit stream at the time offset {offset:+.4f} s and were left out")
    std_offset = math.sqrt(C[N_PARAMS, N_PARAMS]) if options.estimate else math.nan
    if std_offset > POOR_STD_FRACTION * interval:
        notes.append(f"the time offset is poorly determined: its std, {1e3 * std_offset:.3g}"
                     f" ms, is over {POOR_STD_FRACTION:g} of the camera's interval "
                     f"({1e3 * interval:.3g} ms); record a longer or livelier motion")
    notes += list(closed.notes)
    notes += translation_warnings(T_cw[used], G_final, X)
    return TimedHandEyeResult(
        T_cam_from_gaze=X, quality=quality, method=f"{closed.method}+refine",
        diagnostics=diagnostics, covariance=CX,
        std_rotation_deg=math.degrees(math.sqrt(np.trace(CX[:3, :3]))),
        std_translation=math.sqrt(np.trace(CX[3:, 3:])),
        sigma_rotation_deg=math.degrees(problem.w[0]), sigma_translation=problem.w[1],
        loss=options.loss, start=closed.method, T_ptu_from_world=Y,
        n_downweighted=int(np.sum(per_position > F_SCALE)) if options.loss != "linear" else 0,
        residual_rms=float(np.sqrt(np.mean(problem.raw(p)[1] ** 2))),
        time_offset=offset,
        std_time_offset=std_offset,
        time_offset_mode="estimate" if options.estimate else "hold",
        coarse_time_offset=coarse.time_offset if coarse else math.nan,
        correlation=coarse.correlation if coarse else math.nan,
        n_used=len(used), n_camera=len(t_cam), max_offset=options.max_offset,
        notes=tuple(notes))


def nearest_pairs(times: np.ndarray, unit_times: np.ndarray, T_gaze_from_ptu: np.ndarray,
                  time_offset: float = 0.0) -> np.ndarray:
    """The naive pairing: for each camera stamp t, the unit pose whose stamp is nearest
    to ``t + time_offset`` → (n, 4, 4). What a tool that ignores the streams' rates and
    offset does (the reference of ``benchmarks/bench_handeye_time_offset.py``)."""
    t = np.asarray(times, dtype=float) + time_offset
    u = np.asarray(unit_times, dtype=float)
    j = np.clip(np.searchsorted(u, t), 1, len(u) - 1)
    j -= (t - u[j - 1]) < (u[j] - t)
    return np.asarray(T_gaze_from_ptu, dtype=float)[j]
