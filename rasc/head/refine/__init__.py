"""Whole-head refinement: every detected corner of every image, both eyes, jointly.

docs/METHOD.md §10, "Whole-head refinement". The closed form (RASC per eye, eq. 4–10,
and loop closure, eq. 11–12) is the initial guess; this module minimises the
reprojection error of every corner in every image — both eyes, the intrinsics views and
the pose views — over

* per eye: the intrinsics fx, fy, cx, cy, the distortion of the dataset's model
  (``k1k2``: k1, k2; ``opencv5``: k1 k2 p1 p2 k3; ``none``: nothing), ``T_cam_from_gaze``
  (6) and the identifiable parameters of its general pan-tilt unit
  (:class:`rasc.geometry.kinematics.PanTiltUnit`: the encoder scales, the axis angle and
  the common-normal distance);
* per head: ``T_ptuL_from_ptuR`` (6);
* per intrinsics view: its board pose ``T_cam_from_world`` (6);
* for the pose views: one board pose ``T_ptuL_from_world`` (6) shared by every pose
  image of both eyes. The target stays put while the units move, as hand-eye (eq. 4–7)
  and loop closure (eq. 11–12) already assume; sharing it ties the eyes together and
  determines ``T_ptuL_from_ptuR``. (A board pose per view, free, would let each view
  absorb the kinematics: the hand-eye would then be seen only through the other eye.)

A corner of eye e at encoder readings (φ_r, τ_r) is predicted by eq. 1–2 with the
general unit, distortion and K::

    T_cam_from_world = T_cam_from_gaze · unit.T_gaze_from_ptu(φ_r, τ_r)
                       · T_ptu_from_ptuL · T_ptuL_from_world

(``T_ptu_from_ptuL`` = I for the left eye, ``T_ptuL_from_ptuR⁻¹`` for the right).

**Gauge.** The data fix camera poses only; the frames are fixed by convention
(:func:`rasc.geometry.kinematics.canonical_gauge`): each unit's ptu frame has x along its
pan axis, its origin at the foot of the common normal on the pan axis, the tilt axis in
its x–z plane at pan reading 0 (so ``tilt_axis = (cos α, 0, sin α)``,
``tilt_point = (0, d, 0)``) and zero encoder offsets; the left ptu frame is the frame
every pose view's board pose is expressed in; the base is the cyclopean frame of
``T_ptuL_from_ptuR`` (docs/METHOD.md §5). The paper's unit is this gauge with α = 90°,
d = 0 and unit scales.

**Identifiability.** Nine candidate unit parameters per eye are tested on the Jacobian at
the initial guess, in the order of :data:`UNIT_PARAMETERS`: a candidate whose column lies
within :data:`IDENTIFIABILITY_SINE` (sine of the angle, columns normalised) of the span
of the columns already kept cannot be determined by the corners; it is named, held at
its gauge value and returned as ``None`` with the reason, never as a number. With free
mounts this always removes the encoder offsets, the tilt point along the pan and the
tilt axis, and the turn of the tilt axis about the pan axis (docs/METHOD.md §10).

**Uncertainty.** σ² (JᵀJ)⁻¹ at the optimum, with J analytic where the Levenberg–Marquardt
Jacobian is and by central differences elsewhere (see Solver), and σ² the
residual sum of squares over (m − n): the standard deviation of every estimated
parameter, valid for independent corner noise of equal variance.

**Solver.** Levenberg–Marquardt on the dense normal equations (a few hundred
parameters: a Cholesky solve of milliseconds). Its Jacobian (:meth:`_Problem.jacobian_lm`)
follows the block structure — a corner depends only on its eye's intrinsics and
kinematics, the mounts (right eye) and its own board pose: the intrinsics and every board
pose analytically (projection with distortion and K, the board's rotation through SO(3)'s
left Jacobian; within 1e-7 of central differences, tests/head/test_refine_jacobian.py), the
kinematic parameters by differences on their own images only (forward in the iterations,
central for the identifiability test and the covariance). That halved the forward
Jacobian's time (57 → 26 ms on the default synthetic head) and cut E7's run per case by
about a third. The difference columns that move the same images are evaluated together
(:meth:`_Problem._residuals_batch`: one projection for all of them, and the rotations and
unit motions a column leaves unchanged reused, :meth:`_Problem._cached`), with the same
numbers bit for bit: a refinement of the default dataset took 0.52 s of CPU instead of
0.70 s. :func:`_levenberg_marquardt` says why not
:func:`scipy.optimize.least_squares`, which was tried first.

**Time offset** (a continuous capture: pose images with times and a joint stream,
:mod:`rasc.head.refine.timing`). One more global parameter, ``time_offset`` δ (s): each
pose image's readings are its eye's stream, cubic spline, at its time + δ; its column is
analytic (the stream's rate times the pixels' derivatives with respect to the angles,
:meth:`_Problem.time_derivative`). δ is the first identifiability candidate (held at 0,
named, when the head is still); an estimate beyond
:data:`~rasc.head.refine.timing.MAX_TIME_OFFSET_S` is refused. Pose frames whose RMS is
an outlier among their eye's (:func:`rasc.vision.camera.outlier_threshold`) are dropped
whole and named (``frames_rejected``): motion blur. On 180 pose images the refinement
took 1.10× the CPU time of the one without δ (``benchmarks/bench_time_offset.py``).

**Robustness.** The soft-L1 loss with ``f_scale`` three times the corner noise (estimated
from the closed form's intrinsics RMS); after the fit, corners whose residual exceeds
both :data:`REJECT_K` robust standard deviations (1.4826 MAD) and
:data:`REJECT_FLOOR_PX` in either coordinate are rejected, reported per image, and the
fit is repeated once without them.
"""

from rasc.head.refine.identifiability import (  # noqa: F401
    IDENTIFIABILITY_SINE,
    REASONS,
    _identifiable,
)
from rasc.head.refine.model import (  # noqa: F401
    DIST_NAMES,
    DIST_PARAMS,
    GAUGE,
    PARAMETER_UNITS,
    UNIT_DEFAULTS,
    UNIT_PARAMETERS,
    EyeObservations,
    HeadObservations,
    ImageResidual,
    RefinementResult,
    _axis_rotation,
    _dist5,
    _left_jacobian,
    _rodrigues_batch,
    _unit_motion,
    _unit_motion_of,
    observations_from_calibration,
    parameter_unit,
    unit_from_parameters,
)
from rasc.head.refine.problem import _Problem  # noqa: F401
from rasc.head.refine.solver import (  # noqa: F401
    REJECT_FLOOR_PX,
    REJECT_K,
    SCALES,
    _levenberg_marquardt,
    _refine_head,
    _soft_l1,
    refine_head,
)

__all__ = ["EyeObservations", "HeadObservations", "RefinementResult", "refine_head",
           "observations_from_calibration", "unit_from_parameters", "UNIT_PARAMETERS",
           "IDENTIFIABILITY_SINE", "REJECT_K", "GAUGE"]
