"""Capture planning: which pan-tilt positions to record, and the accuracy to expect.

Given a head (the nominal simulated head, or a calibration), a target and where it
stands, the joint ranges and a number of positions k, :func:`plan` chooses the k
positions that minimise the predicted uncertainty of the whole-head refinement
(:mod:`rasc.head.refine`, docs/METHOD.md §10) and predicts the standard deviation of
every calibrated parameter and of triangulated points in a stated workspace.

**Model.** The refinement's Jacobian J at the head itself (corners projected without
noise: the prediction assumes the model is right and the noise is independent with
``noise_px`` per coordinate) gives the information matrix JᵀJ; the covariance of the
estimate is ``noise_px² (JᵀJ)⁻¹`` — exactly what the refinement reports after the fit.
The Jacobian is taken at the head itself, its units included (each eye's axis angle and
distance and encoder scales: :func:`simulated_head` builds the head ``rasc render --unit``
renders), and the parameters are the refinement's under the calibration's ``scales``
choice (:attr:`PlanSetup.scales`): estimated, the two encoder scales per eye are free in
the information matrix; held, they are left out of it; ``auto`` is planned as estimated
(:func:`scales_estimated`). :meth:`PlanSetup.assumptions` states the unit, the scales and
the noise a plan assumes.
The two kinds of view may have different noise (``intrinsics_noise_px``: a board seen
close and tilted is often located better than one seen at the pose views' distance);
the covariance of the same least-squares estimate is then the sandwich
``H⁻¹ (σᵢ² I₀ + σₚ² Σ A_c) H⁻¹``, ``H = I₀ + Σ A_c``. A calibration's residuals give both
(:attr:`rasc.head.use.CalibrationFile.corner_noise`, what ``rasc plan --calibration``
uses unless told otherwise).
The intrinsics views (drawn as ``rasc render`` draws them, seeded) contribute a fixed
information ``I₀`` after their board poses are eliminated (Schur complement); each
candidate position c contributes ``A_c = J_cᵀ J_c`` over the global parameters
(intrinsics, hand-eye, unit, mounts) and the shared board pose of the pose views.

**Design.** Greedy: starting from ``I₀``, add the candidate that most increases
``log det`` of the information (D-optimal, the default) or most decreases the trace of
the covariance of the hand-eye and unit parameters (A-optimal), until k are chosen.
Greedy selection of a monotone submodular objective (log det) is within (1 − 1/e) of
the best subset; in practice it matches exhaustive search on small grids.

**Candidates.** Every position of a grid (``step_deg``, default 2°) over the joint
ranges at which both eyes see at least ``min_corners`` corners (all corners, for a
chessboard, which must be seen whole, each at least ``rasc render``'s margin of
:data:`rasc.sim.render.MARGIN_PX` pixels inside the image).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.frames import EYES
from rasc.vision.board import MIN_VIEW_CORNERS

#: the unit parameters planned for: the encoder scales (estimated, or held with
#: ``scales="hold"``: then left out of the information) and the axis angle and distance,
#: which the refinement always determines with free mounts (in the order of
#: :data:`rasc.head.refine.UNIT_PARAMETERS`)
PLAN_UNIT_PARAMETERS = ("pan_scale", "tilt_scale", "tilt_axis_x", "tilt_point_y")
#: the encoder scales (:data:`rasc.head.refine.SCALES`, the same names)
SCALE_PARAMETERS = ("pan_scale", "tilt_scale")
#: joint ranges of the simulated head (rasc/sim/models/stereo_head.xml), degrees
DEFAULT_PAN_RANGE = (-60.0, 60.0)
DEFAULT_TILT_RANGE = (-45.0, 30.0)
CRITERIA = ("D", "A")
#: the corner noise (px per coordinate) a plan assumes without a calibration to take it
#: from: about what OpenCV's sub-pixel chessboard corners give on sharp real images
DEFAULT_NOISE_PX = 0.05


#: the joint angles a range may reach, degrees: a reading beyond a full turn either way
#: names no other position
MAX_JOINT_DEG = 180.0
#: the most candidate positions a grid may have (the default grid over the simulated
#: head's ranges has 2318 at 2°, 9196 at 1°); their information blocks take about
#: 25 kB each
MAX_CANDIDATES = 10_000
#: the most corner projections (candidates × the target's corners) a grid may need: each
#: is a few dozen bytes in the arrays of :func:`_project_many` (about 1 GB at this limit)
MAX_PROJECTIONS = 10_000_000


def scales_estimated(scales: str | None) -> bool:
    """Whether a plan under ``scales`` (:data:`rasc.head.options.SCALES_MODES`; None is
    the calibration's default, :class:`rasc.head.options.CalibrationOptions`' ``auto``)
    predicts with the encoder scales estimated.

    ``estimate``: yes; ``hold``: no (held at their nominal value, left out of the
    information); ``auto``: yes. The calibration's ``auto`` holds the scales unless the
    corners reject 1, which only the data can tell; a plan cannot know it in advance, so
    it plans for the worse case, the scales estimated (their freedom can only widen the
    other parameters' σ)."""
    from rasc.head.options import CalibrationOptions

    mode = CalibrationOptions(scales=scales).scales_mode
    return mode != "hold"


@dataclass
class PlanSetup:
    """What a plan is made for. Angles in degrees, lengths in metres, pixels.

    ``scales``: the encoder scales as ``rasc calibrate --scales`` treats them (the same
    choices and default, :class:`rasc.head.options.CalibrationOptions`;
    :func:`scales_estimated` says what a plan makes of each). ``sources``: where the head
    and the noise come from, phrases for :meth:`assumptions` (``{"unit": "u.toml",
    "noise": "..."}``). ``names``: how the caller's user writes each field, for the
    messages (``rasc plan`` passes its flags, ``{"distance": "--distance", ...}``)."""

    head: Any                                    # rasc.sim.synthetic.SyntheticHead
    board: Any                                   # rasc.vision.board target
    distance: float = 1.0                        # the target's centre ahead of the base
    pan_range: tuple[float, float] = DEFAULT_PAN_RANGE
    tilt_range: tuple[float, float] = DEFAULT_TILT_RANGE
    step_deg: float = 2.0
    min_corners: int = MIN_VIEW_CORNERS
    noise_px: float = DEFAULT_NOISE_PX           # pose views' corner noise per coordinate
    intrinsics_noise_px: float | None = None     # the intrinsics views' (None: noise_px)
    n_intrinsics: int = 20
    seed: int = 0
    image_size: tuple[int, int] = (1280, 960)
    scales: str | None = None                    # None: the calibration's default (auto)
    sources: dict[str, str] = field(default_factory=dict, repr=False, compare=False)
    names: dict[str, str] | None = field(default=None, repr=False, compare=False)

    def _name(self, what: str, fallback: str) -> str:
        return (self.names or {}).get(what, fallback)

    def __post_init__(self):
        for what, label, r in (("pan_range", "pan range", self.pan_range),
                               ("tilt_range", "tilt range", self.tilt_range)):
            name = self._name(what, label)
            if len(r) != 2 or not all(np.isfinite(r)) or not r[0] < r[1]:
                raise InputError(f"{name}: expected MIN,MAX with MIN < MAX, got {r!r}")
            if not (r[0] >= -MAX_JOINT_DEG and r[1] <= MAX_JOINT_DEG):
                raise InputError(f"{name}: expected angles from {-MAX_JOINT_DEG:g} to "
                                 f"{MAX_JOINT_DEG:g} degrees, got {r[0]:g},{r[1]:g}")
        if not (np.isfinite(self.step_deg) and 0.1 <= self.step_deg <= 30):
            raise InputError(f"{self._name('step_deg', 'step')}: expected 0.1 to 30 degrees, "
                             f"got {self.step_deg!r}")
        noises = [(self._name("noise_px", "noise"), self.noise_px)]
        if self.intrinsics_noise_px is not None:        # None: the pose views' noise
            noises.append((self._name("intrinsics_noise_px", "intrinsics noise"),
                           self.intrinsics_noise_px))
        for name, v in noises:
            if v is None or not (np.isfinite(v) and v > 0):
                raise InputError(f"{name}: expected a positive number of pixels, got {v!r}")
        far = self.max_distance
        if not (np.isfinite(self.distance) and 0 < self.distance <= far):
            why = (f" (farther, the target's {self.board.square_size:g} m squares would be "
                   f"smaller than {_min_square_px():g} px in the images, which the detector "
                   "does not find)") if self.distance > far else ""
            raise InputError(f"{self._name('distance', 'distance')}: expected more than 0 "
                             f"and at most {far:.3g} metres, got {self.distance!r}{why}")
        from rasc.head.options import SCALES_MODES

        if self.scales is not None and self.scales not in SCALES_MODES:
            raise InputError(f"{self._name('scales', 'scales')}: expected one of "
                             f"{', '.join(SCALES_MODES)}, got {self.scales!r}")
        n_grid = len(_axis(*self.pan_range, self.step_deg)) \
            * len(_axis(*self.tilt_range, self.step_deg))
        n_corners = len(self.board.object_points())
        if n_grid > MAX_CANDIDATES or n_grid * n_corners > MAX_PROJECTIONS:
            raise InputError(
                f"{self._name('step_deg', 'step')} {self.step_deg:g}: the grid over pan "
                f"{self.pan_range[0]:g}..{self.pan_range[1]:g} and tilt "
                f"{self.tilt_range[0]:g}..{self.tilt_range[1]:g} deg has {n_grid} positions "
                f"of {n_corners} corners; expected at most {MAX_CANDIDATES} positions and "
                f"{MAX_PROJECTIONS:.0e} corner projections: use a coarser step or narrower "
                "ranges")

    @property
    def max_distance(self) -> float:
        """The farthest target distance (m) planned for: the target's squares at least
        :data:`rasc.sim.render.MIN_DETECTABLE_SQUARE_PX` pixels (the smaller focal length
        of the two cameras), what ``rasc render`` refuses to render below."""
        f = min(min(float(self.head.K[e][0, 0]), float(self.head.K[e][1, 1])) for e in EYES)
        return f * float(self.board.square_size) / _min_square_px()

    @property
    def noise(self) -> tuple[float, float]:
        """(pose views', intrinsics views') corner noise, px per coordinate."""
        return self.noise_px, (self.noise_px if self.intrinsics_noise_px is None
                               else self.intrinsics_noise_px)

    @property
    def scales_estimated(self) -> bool:
        """:func:`scales_estimated` of :attr:`scales`."""
        return scales_estimated(self.scales)

    def assumptions(self) -> dict[str, str]:
        """What the prediction assumes, one phrase each: ``unit`` (each eye's axis
        distance and angle and encoder scales, and where they come from), ``scales``
        (estimated or held, and why), ``noise`` (the corner noise and where it comes
        from) and ``images`` (the image size, which with K sets the field of view)."""
        from rasc.geometry.kinematics import canonical_gauge
        from rasc.head.options import CalibrationOptions

        described, off = {}, []
        for eye in EYES:
            u = canonical_gauge(self.head.unit[eye], self.head.T_cam_from_gaze[eye],
                                self.head.T_ptu_from_base[eye])[0]
            a = np.asarray(u.tilt_axis, float)
            angle = float(np.degrees(np.arctan2(a[2], a[0])))
            described[eye] = (f"axis distance {1e3 * u.tilt_point[1]:.3g} mm, axis angle "
                              f"{angle:.4g} deg, encoder scales {u.pan_scale:.6g} (pan) and "
                              f"{u.tilt_scale:.6g} (tilt)")
            off += [f"{eye} {n.split('_')[0]} {v:.6g}"
                    for n, v in (("pan_scale", u.pan_scale), ("tilt_scale", u.tilt_scale))
                    if abs(v - 1.0) > 1e-9]
        unit = (f"both units: {described['left']}" if described["left"] == described["right"]
                else "; ".join(f"{eye}: {described[eye]}" for eye in EYES))
        if self.sources.get("unit"):
            unit += f" ({self.sources['unit']})"
        mode = CalibrationOptions(scales=self.scales).scales_mode
        scales = {"estimate": "estimated (scales estimate)",
                  "hold": "held at 1 (scales hold): the prediction is the calibration's only "
                          "if the encoders are exact",
                  "auto": "estimated (scales auto: the calibration holds them at 1 unless "
                          "the corners reject 1, which only the data tell; the plan takes "
                          "the worse case)"}[mode]
        if mode == "hold" and off:
            scales += (f"; this head's are not 1 ({', '.join(off)}): held at 1 they "
                       "bias the calibration, which these σ do not include")
        sp, si = self.noise
        noise = self.sources.get("noise") or (
            f"corner noise {sp:.3g} px per coordinate"
            + (f" in the pose views and {si:.3g} px in the intrinsics views"
               if si != sp else "") + ", independent")
        w, h = self.image_size
        images = f"{w}x{h} pixels" + (f" ({self.sources['images']})"
                                      if self.sources.get("images") else "")
        return {"unit": unit, "scales": scales, "noise": noise, "images": images}


def _min_square_px() -> float:
    from rasc.sim.render import MIN_DETECTABLE_SQUARE_PX

    return MIN_DETECTABLE_SQUARE_PX


def _axis(lo: float, hi: float, step: float) -> np.ndarray:
    """The multiples of ``step`` from ``lo`` to ``hi`` (degrees)."""
    k0, k1 = int(np.ceil(lo / step - 1e-9)), int(np.floor(hi / step + 1e-9))
    return np.arange(k0, k1 + 1) * step


@dataclass
class Plan:
    """The chosen positions (degrees, in choice order) and the prediction."""

    positions: list[tuple[float, float]]
    criterion: str
    std: dict[str, float]                        # parameter → predicted σ (natural units)
    summary: dict[str, float]                    # hand-eye/unit σ in readable units
    triangulation: dict[str, float] = field(default_factory=dict)
    candidates: int = 0
    seconds: float = 0.0
    #: what the prediction assumes (:meth:`PlanSetup.assumptions`: unit, scales, noise)
    assumptions: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The plan as ``rasc plan`` prints it in JSON: positions, criterion, predicted
        standard deviations, and what they assume."""
        return {"positions_deg": [list(p) for p in self.positions],
                "criterion": self.criterion, "candidates": self.candidates,
                "predicted_std": self.std, "summary": self.summary,
                "triangulation": self.triangulation, "seconds": self.seconds,
                "assumptions": self.assumptions}


def candidate_grid(setup: PlanSetup) -> np.ndarray:
    """(M, 2) pan, tilt (degrees) on the step grid over the joint ranges, home included
    when inside them."""
    p, t = np.meshgrid(_axis(*setup.pan_range, setup.step_deg),
                       _axis(*setup.tilt_range, setup.step_deg), indexing="ij")
    return np.stack([p.ravel(), t.ravel()], axis=1)


def lens_model(head, eye: str) -> str:
    """The lens model of ``eye`` of a planner's head: its ``lens`` (``{eye: model}``, as
    :class:`rasc.sim.synthetic.SyntheticHead` may carry it) or, without one, pinhole."""
    lenses = getattr(head, "lens", None)
    return "pinhole" if lenses is None else lenses[eye]


def _project(head, eye, T_cw, P, size):
    """Noise-free pixels of board points, NaN outside the image or behind the camera."""
    return _pixels(head, eye, P @ T_cw[:3, :3].T + T_cw[:3, 3], size)


def _project_many(head, eye, T_cw, P, size, margin: float = 0.0):
    """:func:`_project` for a stack of poses (M, 4, 4): (M, N, 2); corners closer than
    ``margin`` pixels to the image border count as not seen."""
    p = np.einsum("mij,nj->mni", T_cw[:, :3, :3], P) + T_cw[:, None, :3, 3]
    return _pixels(head, eye, p, size, margin)


def _pixels(head, eye, p, size, margin: float = 0.0):
    """Pixels (..., 2) of camera-frame points ``p`` (..., 3) through the eye's lens model
    (:func:`lens_model`, :func:`rasc.geometry.lens.project_points`); NaN behind the
    camera (or within 5 cm of its plane), outside the image, or closer than ``margin``
    pixels to its border. Through a lens other than the pinhole a pixel must also
    undistort back to its point's ray (:func:`_round_trips`): a lens model folds points
    far outside its field of view back into the image, and those are not seen there."""
    from rasc.geometry import lens

    model = lens_model(head, eye)
    uv = np.full(p.shape[:-1] + (2,), np.nan)
    front = p[..., 2] > 0.05
    if front.any():
        uv[front] = lens.project_points(p[front], head.K[eye], head.dist[eye], model=model)
    w, h = size
    with np.errstate(invalid="ignore"):
        out = ~front | np.any(~(uv >= margin), axis=-1) | (uv[..., 0] > w - 1 - margin) \
            | (uv[..., 1] > h - 1 - margin)
    if model != "pinhole" and not out.all():
        inside = np.flatnonzero(~out.ravel())
        rays = p.reshape(-1, 3)[inside]
        out.flat[inside[~_round_trips(head, eye, model, uv.reshape(-1, 2)[inside],
                                      rays[:, :2] / rays[:, 2:])]] = True
    uv[out] = np.nan
    return uv


#: a pixel is its corner's when undistorting it gives back the corner's ray to this,
#: relative to 1 + |ray| (normalised units: 1e-6 px at a focal length of 1000 px, as
#: :data:`rasc.head.use.ROUND_TRIP_TOL_PX`)
ROUND_TRIP_TOL = 1e-9


def _round_trips(head, eye: str, model: str, uv: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Which pixels ``uv`` (N, 2) undistort (:func:`rasc.geometry.lens.undistort_normalized`)
    back to their rays ``xy`` (N, 2, normalised): False where the lens model folds."""
    import contextlib

    from rasc.geometry import lens

    K = head.K[eye]
    xd = np.c_[(uv[:, 0] - K[0, 2] - K[0, 1] * (uv[:, 1] - K[1, 2]) / K[1, 1]) / K[0, 0],
               (uv[:, 1] - K[1, 2]) / K[1, 1]]
    try:
        back = lens.undistort_normalized(xd, head.dist[eye], model=model)
    except InputError:                  # some pixel beyond the model's fold: one by one
        back = np.full_like(xd, np.nan)
        for i in range(len(xd)):
            with contextlib.suppress(InputError):
                back[i] = lens.undistort_normalized(xd[i:i + 1], head.dist[eye],
                                                    model=model)[0]
    with np.errstate(invalid="ignore"):
        return (np.abs(back - xy).max(axis=1)
                <= ROUND_TRIP_TOL * (1.0 + np.abs(xy).max(axis=1)))


#: candidate images per block of the information computation (memory ~ block × corners
#: × 2 × 26 doubles: 20 MB for 256 images of 192 corners)
_BLOCK_IMAGES = 256
#: step of the central differences of the chain (in the scaled parameters: ~1e-7 rad,
#: ~1e-7 m): truncation error ~h² relative, round-off ~1e-16/h
_CHAIN_STEP = 1e-6


def _blocks(prob, keep: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The information ``I0`` of the intrinsics views (their board poses eliminated) and
    the blocks ``A`` (2, M, p, p) of the candidate pose views, per eye, over the
    parameters ``keep`` (indices into ``prob.names``: the globals and the pose views'
    board).

    Every parameter but the intrinsics moves a pose view's corners only through the
    chain ``T_cam_from_board = (R, t)``, so its column is a camera-frame twist (ω, v) per
    image: d pc = ω × pc + v, with ``[ω]x = dR Rᵀ`` and ``v = dt − ω × t`` from the
    central difference (dR, dt) of the chain of every image at once. Per corner the
    pixel's derivative with respect to [intrinsics, twist] is a 2×(ni + 6) matrix (ni
    intrinsics: 6 for a pinhole's fx fy cx cy k1 k2, 8 for a fisheye's k1..k4)
    (:meth:`rasc.head.refine._Problem._project`'s analytic derivatives: the intrinsics
    columns, and ``d pixel / d pc`` with the twist's rows ``pc × J_a`` and ``J_a``);
    its Gram matrix Z_cᵀZ_c (summed over the image's seen corners) and the
    image's twist map S_c give ``A_c = T_cᵀ Z_cᵀ Z_c T_c``, T_c = diag(I, S_c). The same
    numbers as :func:`_blocks_reference` (the refinement's sparse Jacobian, forward
    differences) to the latter's difference error (~1e-6 relative;
    tests/head/test_plan.py)."""
    n = len(prob.names)
    x = np.zeros(n)
    where = {j: i for i, j in enumerate(keep)}
    p = len(keep)
    I0 = np.zeros((p, p))
    A = np.zeros((len(EYES), int((prob.img_role == 1).sum()) // 2, p, p))
    board_cols = list(range(n - 6, n))
    for ei, eye in enumerate(EYES):
        c = prob.eye_cols[eye]
        intr_cols = list(range(c["start"], c["start"] + c["n_intr"]))
        ni = len(intr_cols)
        s_intr = prob.scale[intr_cols]
        # the intrinsics views: [intrinsics, own board pose], the board pose eliminated
        sel = np.flatnonzero((prob.img_eye == ei) & (prob.img_role == 0))
        if len(sel):
            _, d = prob._project(x, sel, prob._chain(x, sel), derivatives=True)
            idx = np.array([where[j] for j in intr_cols])
            for k, i in enumerate(sel):
                b0 = prob.n_global + 6 * int(prob.img_pose[i])
                m = prob.mask[i]
                G = (d["intrinsics"][k][m] * s_intr).reshape(-1, ni)
                B = (d["board"][k][m] * prob.scale[b0:b0 + 6]).reshape(-1, 6)
                GB = G.T @ B
                I0[np.ix_(idx, idx)] += G.T @ G - GB @ np.linalg.solve(B.T @ B, GB.T)
        # the candidate pose views: [intrinsics, kinematic (hand-eye, unit, mounts for
        # the right eye), the shared board pose]
        chain_cols = list(range(c["start"] + ni, c["stop"]))
        if eye == "right":
            chain_cols += list(range(prob.head_start, prob.head_start + 6))
        chain_cols += board_cols
        sel = np.flatnonzero((prob.img_eye == ei) & (prob.img_role == 1))
        ch0 = prob._chain(x, sel)
        S = np.empty((len(sel), 6, len(chain_cols)))             # twists per column
        for k, j in enumerate(chain_cols):
            dx = np.zeros(n)
            dx[j] = _CHAIN_STEP
            hi, lo = prob._chain(x + dx, sel), prob._chain(x - dx, sel)
            dR = (hi["R"] - lo["R"]) / (2 * _CHAIN_STEP)
            dt = (hi["t"] - lo["t"]) / (2 * _CHAIN_STEP)
            W = dR @ ch0["R"].transpose(0, 2, 1)                  # [ω]x (to O(h²))
            w = 0.5 * np.stack([W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0],
                                W[:, 1, 0] - W[:, 0, 1]], axis=-1)
            S[:, :3, k] = w
            S[:, 3:, k] = dt - np.cross(w, ch0["t"])
        q = ni + len(chain_cols)
        T = np.zeros((len(sel), ni + 6, q))                      # [intrinsics, twist]
        T[:, np.arange(ni), np.arange(ni)] = 1.0
        T[:, ni:, ni:] = S
        idx = np.array([where[j] for j in intr_cols + chain_cols])
        for lo_ in range(0, len(sel), _BLOCK_IMAGES):
            part = sel[lo_:lo_ + _BLOCK_IMAGES]
            blk = slice(lo_, lo_ + len(part))
            ch = prob._chain(x, part)
            _, d = prob._project(x, part, ch, derivatives=True, board=False)
            pc = np.einsum("mij,kj->mki", ch["R"], prob.P) + ch["t"][:, None]
            J = d["point"]                                         # (m, N, 2, 3)
            Z = np.concatenate([d["intrinsics"] * s_intr,
                                np.cross(pc[:, :, None, :], J), J], axis=-1)
            Z[~prob.mask[part]] = 0.0
            Z = Z.reshape(len(part), -1, Z.shape[-1])
            M = np.matmul(Z.transpose(0, 2, 1), Z)                 # (m, ni+6, ni+6)
            Tb = T[blk]
            cidx = np.array([int(prob.img_name[i][1:]) for i in part])
            A[ei][np.ix_(cidx, idx, idx)] += Tb.transpose(0, 2, 1) @ M @ Tb
    return I0, A


def _blocks_reference(prob, keep: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_blocks` from the refinement's own sparse Jacobian
    (:meth:`rasc.head.refine._Problem.jacobian`, forward differences for the kinematic
    columns), image by image: the reference the fast path is tested and timed against
    (``Information(..., reference=True)``; 10–30× slower)."""
    J = prob.jacobian(np.zeros(len(prob.names)), central=False).tocsr()
    rows = prob._rows_of_images()
    ng = prob.n_global
    p = len(keep)
    I0 = np.zeros((p, p))
    A = np.zeros((len(EYES), int((prob.img_role == 1).sum()) // 2, p, p))
    for i in range(len(prob.img_name)):
        Ji = J[rows[i]]
        G = Ji[:, keep].toarray()
        if prob.img_role[i] == 0:
            k = ng + 6 * int(prob.img_pose[i])
            B = Ji[:, k:k + 6].toarray()
            GB = G.T @ B
            I0 += G.T @ G - GB @ np.linalg.solve(B.T @ B, GB.T)
        else:
            c = int(prob.img_name[i][1:])
            A[int(prob.img_eye[i])][c] += G.T @ G
    return I0, A


def _spans_plane_many(seen: np.ndarray, P: np.ndarray) -> np.ndarray:
    """:func:`rasc.vision.board.spans_plane` of the seen board points of each row of the
    mask ``seen`` (M, N) at once: the smaller eigenvalue of the seen points' x-y scatter
    above 1e-12 of the larger (the singular values' 1e-6), so that corners on one line —
    no pose, no homography — never make a candidate."""
    w = seen.astype(float)
    n = np.maximum(w.sum(axis=1), 1.0)
    xy = P[:, :2]
    mean = (w @ xy) / n[:, None]
    sxx = w @ (xy[:, 0] ** 2) - n * mean[:, 0] ** 2
    syy = w @ (xy[:, 1] ** 2) - n * mean[:, 1] ** 2
    sxy = w @ (xy[:, 0] * xy[:, 1]) - n * mean[:, 0] * mean[:, 1]
    half_tr, det = 0.5 * (sxx + syy), sxx * syy - sxy ** 2
    root = np.sqrt(np.maximum(half_tr ** 2 - det, 0.0))
    big, small = half_tr + root, half_tr - root
    return (seen.sum(axis=1) >= 3) & (big > 0) & (small > 1e-12 * big)


def candidate_views(setup: PlanSetup, candidates: np.ndarray, margin: float | None = None):
    """What each eye sees of the target at each candidate position (degrees, (M, 2)):
    ``(uv, T_cam_from_world, ok)``, per eye the corners' pixels (M, N, 2) through the eye's
    lens model (:func:`_project_many`; NaN where not seen) and the camera poses (M, 4, 4),
    and which candidates (M,) show both eyes the target (a chessboard whole, at least
    :data:`rasc.sim.render.MARGIN_PX` inside the image unless ``margin`` says otherwise; a
    ChArUco at least ``min_corners`` corners, anywhere in the image)."""
    from rasc.sim.render import MARGIN_PX
    from rasc.sim.scene import T_base_from_world_facing

    head, board = setup.head, setup.board
    P = board.object_points()
    T_bw = T_base_from_world_facing(board, distance=setup.distance)
    partial = getattr(board, "partial_views", False)
    need = setup.min_corners if partial else board.n_corners
    pan, tilt = np.radians(candidates[:, 0]), np.radians(candidates[:, 1])
    uv_all, T_cw_all = {}, {}
    for eye in EYES:
        T_cw_all[eye] = (head.T_cam_from_gaze[eye]
                         @ head.unit[eye].T_gaze_from_ptu(pan, tilt)
                         @ head.T_ptu_from_base[eye] @ T_bw)          # (M, 4, 4)
        # a chessboard must be seen whole with rasc render's margin (MARGIN_PX, which
        # it refuses positions without); ChArUco corners count anywhere in the image
        # (``margin`` overrides: positions a user gives are taken as they are)
        uv_all[eye] = _project_many(head, eye, T_cw_all[eye], P, setup.image_size,
                                    margin if margin is not None
                                    else 0.0 if partial else MARGIN_PX)
    ok = np.all([(np.isfinite(uv_all[e][..., 0]).sum(axis=1) >= need)
                 & _spans_plane_many(np.isfinite(uv_all[e][..., 0]), P) for e in EYES],
                axis=0)
    return uv_all, T_cw_all, ok


class Information:
    """The refinement's information over the candidates (see the module docstring)."""

    def __init__(self, setup: PlanSetup, candidates: np.ndarray, margin: float | None = None,
                 reference: bool = False):
        from rasc.geometry.kinematics import canonical_gauge
        from rasc.geometry.transforms import invert_transform
        from rasc.head.refine import EyeObservations, HeadObservations, _Problem
        from rasc.sim.render import intrinsics_board_poses, wide_lens
        from rasc.sim.scene import T_base_from_world_facing

        head, board = setup.head, setup.board
        check_planned_lens(head)
        P = board.object_points()
        rng = np.random.default_rng(setup.seed)
        T_bw = T_base_from_world_facing(board, distance=setup.distance)
        partial = getattr(board, "partial_views", False)
        need = setup.min_corners if partial else board.n_corners
        # every candidate at once: (M, N, 2) pixels per eye, NaN where not seen, and the
        # camera poses (the pose views' initial values below: the canonical gauge leaves
        # every camera pose unchanged)
        pan, tilt = np.radians(candidates[:, 0]), np.radians(candidates[:, 1])
        uv_all, T_cw_all, ok = candidate_views(setup, candidates, margin)
        feasible = [(float(a), float(b)) for a, b in candidates[ok]]
        if len(feasible) < 3:
            raise DegenerateDataError(
                f"plan: only {len(feasible)} candidate position(s) show the target to both "
                f"eyes ({'at least ' + str(need) if partial else 'whole'}); place the target "
                "farther or use a ChArUco target, which counts when seen in part")
        self.feasible = np.array(feasible)
        eyes = {}
        gauge = {eye: canonical_gauge(head.unit[eye], head.T_cam_from_gaze[eye],
                                      head.T_ptu_from_base[eye]) for eye in EYES}
        T_pLpR = gauge["left"][2] @ invert_transform(gauge["right"][2])
        names_c = [f"c{c:05d}" for c in range(len(feasible))]
        pan_tilt = dict(zip(names_c, zip(pan[ok].tolist(), tilt[ok].tolist(), strict=True),
                            strict=True))
        for eye in EYES:
            unit, T_cg, T_pb = gauge[eye]
            intr, T_intr = {}, {}
            # (a wide lens is seen to its edges: the views rasc.sim.synthetic places)
            placed = intrinsics_board_poses(rng, board, head.K[eye], setup.image_size,
                                            setup.n_intrinsics, head.dist[eye],
                                            wide_lens(lens_model(head, eye)))
            for k, T_cw in enumerate(placed):
                intr[f"i{k:03d}"] = _project(head, eye, T_cw, P, setup.image_size)
                T_intr[f"i{k:03d}"] = T_cw
            eyes[eye] = EyeObservations(
                K=head.K[eye], dist=np.asarray(head.dist[eye], float),
                image_size=tuple(setup.image_size), intrinsics=intr,
                T_cam_from_world_intrinsics=T_intr,
                pose=dict(zip(names_c, uv_all[eye][ok], strict=True)), pan_tilt=pan_tilt,
                view={f: f for f in names_c},
                T_cam_from_world_pose=dict(zip(names_c, T_cw_all[eye][ok], strict=True)),
                T_cam_from_gaze=T_cg)
        obs = HeadObservations(board_points=P, eyes=eyes, T_ptuL_from_ptuR=T_pLpR,
                               dist_model=PLANNED_LENSES[lens_model(head, "left")])
        prob = _Problem(obs, {eye: list(PLAN_UNIT_PARAMETERS) for eye in EYES})
        _at_the_head(prob, {eye: gauge[eye][0] for eye in EYES},
                     gauge["left"][2] @ T_bw)
        ng = prob.n_global
        every = list(range(ng)) + list(range(len(prob.names) - 6, len(prob.names)))
        #: the encoder scales are estimated (in :attr:`names`) or held (left out)
        self.scales_estimated = setup.scales_estimated
        held = () if self.scales_estimated else SCALE_PARAMETERS
        #: indices into ``prob.names`` of the parameters :attr:`names` lists
        self.keep = [j for j in every
                     if not any(prob.names[j].endswith(f".unit.{n}") for n in held)]
        self.names = [prob.names[j] for j in self.keep]
        self.scale = prob.scale[self.keep]
        #: I0: the intrinsics views' information; A_by_eye (2, M, p, p): each candidate's
        #: pose view per eye (left, right); A: both eyes' (what the design adds up). Held
        #: parameters are left out: the information of the others is the rest of the
        #: matrix
        I0, A_by_eye = (_blocks_reference if reference else _blocks)(prob, every)
        sub = np.array([every.index(j) for j in self.keep])
        self.I0 = I0[np.ix_(sub, sub)]
        self.A_by_eye = A_by_eye[..., sub[:, None], sub[None, :]]
        self.A = self.A_by_eye.sum(axis=0)
        self.prob = prob
        self.T_pLpR = T_pLpR

    def covariance(self, chosen, noise_px, intrinsics_noise_px: float | None = None
                   ) -> np.ndarray:
        """σ² (I₀ + Σ A_c)⁻¹ in natural units over :attr:`names`.

        ``intrinsics_noise_px``: a different noise of the intrinsics views (``noise_px``
        then the pose views'): the covariance of the same unweighted least-squares
        estimate is H⁻¹ (σᵢ² I₀ + σₚ² Σ A_c) H⁻¹, H = I₀ + Σ A_c (the intrinsics views'
        board poses eliminated as in I₀). ``noise_px`` may also give each pose view its
        own noise: an array (len(chosen), 2), per chosen position the left and right
        eye's (σₚ² Σ A_c becomes Σ σ_c,e² A_c,e)."""
        chosen = list(chosen)
        A = self.A[chosen].sum(axis=0)
        info = self.I0 + A
        d = np.sqrt(np.diag(info))
        d = np.where(d > 0, d, 1.0)
        D = np.outer(d, d)
        H_inv = np.linalg.inv(info / D) / D
        if np.ndim(noise_px) > 0:                       # each pose view its own noise
            s2 = np.square(np.asarray(noise_px, float)).reshape(len(chosen), len(EYES))
            middle = np.einsum("ce,ecij->ij", s2, self.A_by_eye[:, chosen])
            si = float(np.sqrt(np.mean(s2))) if intrinsics_noise_px is None \
                else intrinsics_noise_px
            cov = H_inv @ (si ** 2 * self.I0 + middle) @ H_inv
        elif intrinsics_noise_px is None or intrinsics_noise_px == noise_px:
            cov = noise_px ** 2 * H_inv
        else:
            cov = H_inv @ (intrinsics_noise_px ** 2 * self.I0 + noise_px ** 2 * A) @ H_inv
        return cov * np.outer(self.scale, self.scale)


def _at_the_head(prob, units: dict, T_ptuL_from_world: np.ndarray) -> None:
    """Move the refinement problem's starting point to the head itself: each eye's
    canonical unit (``units``: its scales, axis angle and distance; the refinement starts
    from the ideal unit) and the pose views' board pose ``T_ptuL_from_world`` (the
    refinement's first guess assumes the ideal unit too), so that the Jacobian is the one
    at the truth (the corners' residuals there are nil)."""
    for eye in EYES:
        u = units[eye]
        a = np.asarray(u.tilt_axis, float)
        value = {"pan_scale": u.pan_scale, "tilt_scale": u.tilt_scale,
                 "tilt_axis_x": a[0] / a[2], "tilt_point_y": u.tilt_point[1]}
        for n in prob.unit_free[eye]:
            prob.p0[prob.names.index(f"{eye}.unit.{n}")] = value[n]
    j = prob.names.index("board[pose views].rotx")
    prob.pose_R0[-1] = T_ptuL_from_world[:3, :3]
    prob.p0[j:j + 3] = 0.0
    prob.p0[j + 3:j + 6] = T_ptuL_from_world[:3, 3]
    prob._memo.clear()


def _interest(names) -> np.ndarray:
    """Indices of the hand-eye and unit parameters (the A-optimal criterion's)."""
    return np.array([j for j, n in enumerate(names)
                     if ".T_cam_from_gaze." in n or ".unit." in n])


#: the lazy D-optimal greedy stops evaluating when the best exact gain beats every other
#: candidate's bound by this much (relative): gains closer than that are all evaluated,
#: so round-off in the bounds cannot change the choice
_LAZY_MARGIN = 1e-9


def greedy(I0: np.ndarray, A: np.ndarray, k: int, criterion: str = "D",
           interest: np.ndarray | None = None, lazy: bool = True) -> list[int]:
    """Indices of ``k`` candidates chosen greedily (module docstring); ties go to the
    lower index, so the result is deterministic.

    D-optimal with ``lazy`` (the default): log det is submodular, so a candidate's gain
    log det(I + A_c) − log det(I) can only shrink as others are added; its last computed
    gain is a bound, and each step evaluates candidates in the order of their bounds
    until the best exact gain beats every remaining bound (lazy greedy, Minoux 1978) —
    the same choice as evaluating every candidate (``lazy=False``), for a few dozen
    determinants a step instead of all of them."""
    if criterion not in CRITERIA:
        raise InputError(f"criterion: expected D or A, got {criterion!r}")
    M, p = A.shape[0], A.shape[1]
    if not 1 <= k <= M:
        raise InputError(f"k: expected 1 to {M} (the usable candidates), got {k}")
    d = np.sqrt(np.maximum(np.diag(I0) + A.sum(axis=0).diagonal(), 1e-300))
    Dn = np.outer(d, d)
    I0n, An = I0 / Dn, A / Dn
    # a ridge of 1e-9 (relative, after normalisation) keeps the first steps defined
    # when the pose views' parameters are not yet determined
    info = I0n + 1e-9 * np.eye(p)
    chosen: list[int] = []
    if criterion == "D" and lazy:
        return _lazy_d(info, An, k)
    for _ in range(k):
        trial = info[None] + An
        if criterion == "D":
            sign, logdet = np.linalg.slogdet(trial)
            score = np.where(sign > 0, logdet, -np.inf)
        else:
            inv = np.linalg.inv(trial)
            idx = interest if interest is not None else np.arange(p)
            score = -np.einsum("mii->m", inv[:, idx][:, :, idx] / Dn[idx][:, idx][None])
        score[chosen] = -np.inf
        c = int(np.argmax(score))
        chosen.append(c)
        info = info + An[c]
    return chosen


def _logdet(stack: np.ndarray) -> np.ndarray:
    sign, logdet = np.linalg.slogdet(stack)
    return np.where(sign > 0, logdet, -np.inf)


def _lazy_d(info: np.ndarray, An: np.ndarray, k: int) -> list[int]:
    """:func:`greedy`'s lazy D-optimal steps from the normalised ``info`` and blocks."""
    M = len(An)
    score = _logdet(info[None] + An)                 # the first step evaluates all
    base = float(np.linalg.slogdet(info)[1])
    c = int(np.argmax(score))
    chosen = [c]
    bound = score - base                             # gains: upper bounds from now on
    info = info + An[c]
    for _ in range(k - 1):
        base = float(np.linalg.slogdet(info)[1])
        bound[chosen] = -np.inf
        order = np.argsort(-bound, kind="stable")
        exact = np.full(M, -np.inf)
        best, done, batch = -np.inf, 0, 16
        while done < M:
            part = order[done:done + batch]
            part = part[np.isfinite(bound[part])]
            if not len(part):
                break
            exact[part] = _logdet(info[None] + An[part])
            bound[part] = exact[part] - base
            best = max(best, float(exact[part].max()))
            done += batch
            batch *= 2
            if done >= M or not np.isfinite(bound[order[done]]) or \
                    best - base > bound[order[done]] + _LAZY_MARGIN * (1 + abs(best - base)):
                break
        c = int(np.argmax(exact))                    # ties to the lower index
        chosen.append(c)
        info = info + An[c]
    return chosen


def summarise(names, cov: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
    """Every parameter's σ (natural units: px, m, rad; rotations as small angles in
    degrees) and per eye the hand-eye rotation and translation σ (deg, mm: the root sum
    of the three components'), the unit's axis distance (mm) and angle (deg) and, when
    estimated, its encoder scales (dimensionless)."""
    s = np.sqrt(np.maximum(np.diag(cov), 0.0))
    std = {}
    for n, v in zip(names, s, strict=True):
        std[n] = float(np.degrees(v)) if ".rot" in n else float(v)
    summary = {}
    for eye in EYES:
        rot = [std[f"{eye}.T_cam_from_gaze.rot{a}"] for a in "xyz"]
        tr = [std[f"{eye}.T_cam_from_gaze.t{a}"] for a in "xyz"]
        summary[f"{eye}.handeye_rotation_deg"] = float(np.sqrt(np.sum(np.square(rot))))
        summary[f"{eye}.handeye_translation_mm"] = 1e3 * float(np.sqrt(np.sum(np.square(tr))))
        summary[f"{eye}.axis_distance_mm"] = 1e3 * std[f"{eye}.unit.tilt_point_y"]
        summary[f"{eye}.axis_angle_deg"] = float(np.degrees(std[f"{eye}.unit.tilt_axis_x"]))
        for n in SCALE_PARAMETERS:                 # when estimated
            if f"{eye}.unit.{n}" in std:
                summary[f"{eye}.{n}"] = std[f"{eye}.unit.{n}"]
    tr = [std[f"T_ptuL_from_ptuR.t{a}"] for a in "xyz"]
    summary["mounts_translation_mm"] = 1e3 * float(np.sqrt(np.sum(np.square(tr))))
    return std, summary


#: the stated workspace for the triangulation prediction: a square plane facing the
#: head, its side and points per side, at ``workspace_depth`` metres
WORKSPACE_SIDE_M = 0.6
WORKSPACE_POINTS = 7
TRIANGULATION_SAMPLES = 200


def check_workspace_depth(setup: PlanSetup, depth: float | None) -> None:
    """Refuse a ``workspace_depth`` that is not a positive number of metres (a plane at
    or behind the head); what the cameras must see of it is checked with the head
    (:func:`workspace_views`). Raises :class:`InputError` naming the option."""
    if depth is None:
        return
    name = setup._name("workspace_depth", "workspace depth")
    if isinstance(depth, bool) or not isinstance(depth, (int, float, np.floating)) \
            or not np.isfinite(depth) or depth <= 0:
        raise InputError(f"{name}: expected a positive number of metres (the distance of "
                         f"the plane ahead of the head), got {depth!r}")


def workspace_views(head, setup: PlanSetup, depth: float):
    """The workspace plane's points (N, 3; base frame) at ``depth``, the eyes' vergence
    on its centre (rad; left pans by −verge, right by +verge) and each eye's pixels
    (N, 2) through ``head`` (:class:`rasc.head.model.HeadCalibration`). Raises
    :class:`InputError` naming the depth when a point is not in both images or the two
    eyes' rays meet at less than :data:`rasc.geometry.triangulation.MIN_PARALLAX_DEG`
    (the depths that work are stated: the plane in front of and inside both images, the
    rays not parallel)."""
    from rasc.geometry.triangulation import MIN_PARALLAX_DEG

    half = float(np.linalg.norm(head.T_ptuL_from_ptuR()[:3, 3])) / 2
    g = np.linspace(-WORKSPACE_SIDE_M / 2, WORKSPACE_SIDE_M / 2, WORKSPACE_POINTS)
    x, z = np.meshgrid(g, g, indexing="ij")

    def views(d):
        pts = np.stack([x.ravel(), np.full(x.size, d), z.ravel()], axis=1)
        verge = float(np.arctan2(half, d))
        out = []
        for eye, pan in (("left", -verge), ("right", verge)):
            e = getattr(head, eye)
            T = e.T_cam_from_base(pan, 0.0)
            if np.any(pts @ T[2, :3] + T[2, 3] <= 0.05):       # at or behind the camera
                return pts, verge, None
            uv = e.project(pts, pan, 0.0)
            w, h = setup.image_size
            if not np.all(np.isfinite(uv) & (uv >= 0) & (uv <= [w - 1, h - 1])):
                return pts, verge, None
            out.append(uv)
        return pts, verge, out

    far = half / np.tan(np.radians(MIN_PARALLAX_DEG) / 2)
    pts, verge, uv = views(depth)
    if uv is None or depth > far:
        near = next((float(d) for d in np.geomspace(0.05, far, 400)
                     if views(d)[2] is not None), None)
        allowed = (f"from about {near:.2g} to {far:.3g} m" if near is not None
                   else "none for this head")
        name = setup._name("workspace_depth", "workspace depth")
        raise InputError(f"{name} {depth:g}: both eyes must see the whole "
                         f"{WORKSPACE_SIDE_M:g} m plane there, verging on its centre, and "
                         f"their rays meet at {MIN_PARALLAX_DEG:g} deg or more; depths that "
                         f"do: {allowed}")
    return pts, verge, uv[0], uv[1]


def triangulation_std(info: Information, cov: np.ndarray, setup: PlanSetup,
                      depth: float, seed: int = 0) -> dict[str, float]:
    """Predicted error of triangulated points (mm): heads drawn from the predicted
    covariance (seeded, :data:`TRIANGULATION_SAMPLES`), each triangulating the points of a
    :data:`WORKSPACE_SIDE_M` square plane at ``depth`` (base frame, verging on its
    centre) projected through the true head; the RMS and 95th percentile of the 3-D
    deviation over samples and points."""
    from rasc.head.base_to_ptu import cyclopean_base
    from rasc.head.model import EyeCalibration, HeadCalibration
    from rasc.head.refine import unit_from_parameters

    prob = info.prob
    n = len(prob.names)
    keep_idx = info.keep
    rng = np.random.default_rng(seed)
    cov_x = cov / np.outer(info.scale, info.scale)
    L = np.linalg.cholesky(cov_x + 1e-30 * np.eye(len(cov_x)))

    def head_at(xk):
        x = np.zeros(n)
        x[keep_idx] = xk
        s = prob.unpack(x)
        T_pb = dict(zip(EYES, cyclopean_base(s["T_ptuL_from_ptuR"]), strict=True))
        eyes = {}
        for eye in EYES:
            fx, fy, cx, cy = s[eye]["K"]
            eyes[eye] = EyeCalibration(
                K=np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]]), dist=s[eye]["dist"],
                T_cam_from_gaze=s[eye]["T_cam_from_gaze"], T_ptu_from_base=T_pb[eye],
                image_size=tuple(setup.image_size), unit=unit_from_parameters(s[eye]["unit"]),
                lens=lens_model(setup.head, eye))
        return HeadCalibration(**eyes)

    true = head_at(np.zeros(len(keep_idx)))
    pts, verge, uvL, uvR = workspace_views(true, setup, depth)
    errs = []
    for _ in range(TRIANGULATION_SAMPLES):
        h = head_at(L @ rng.standard_normal(len(keep_idx)))
        q = h.triangulate(uvL, uvR, -verge, 0.0, verge, 0.0)
        errs.append(np.linalg.norm(q - pts, axis=1))
    e = np.concatenate(errs) * 1e3
    return {"depth_m": float(depth), "side_m": WORKSPACE_SIDE_M,
            "rms_mm": float(np.sqrt(np.mean(e ** 2))), "p95_mm": float(np.percentile(e, 95))}


def predict(setup: PlanSetup, positions, info: Information | None = None,
            workspace_depth: float | None = 1.5) -> Plan:
    """The prediction for given positions (degrees), each showing the target to both eyes
    (a chessboard whole, without :func:`plan`'s margin); ``info``: the information of
    a candidate set that holds them (else computed for them alone)."""
    check_workspace_depth(setup, workspace_depth)
    positions = np.asarray(positions, float).reshape(-1, 2)
    info = info or Information(setup, positions, margin=0.0)
    idx = []
    for p in positions:
        hit = np.flatnonzero(np.all(np.abs(info.feasible - p) < 1e-9, axis=1))
        if not len(hit):
            raise InputError(f"plan: position ({p[0]:g}, {p[1]:g}) deg does not show the "
                             "target to both eyes")
        idx.append(int(hit[0]))
    sp, si = setup.noise
    cov = info.covariance(idx, sp, intrinsics_noise_px=si)
    std, summary = summarise(info.names, cov)
    tri = {} if workspace_depth is None else triangulation_std(info, cov, setup,
                                                               workspace_depth, setup.seed)
    return Plan(positions=[tuple(map(float, p)) for p in positions], criterion="given",
                std=std, summary=summary, triangulation=tri, candidates=len(info.feasible),
                assumptions=setup.assumptions())


def plan(setup: PlanSetup, k: int, criterion: str = "D",
         workspace_depth: float | None = 1.5) -> Plan:
    """Choose ``k`` positions (module docstring) and predict their accuracy."""
    check_workspace_depth(setup, workspace_depth)
    t0 = time.perf_counter()
    info = Information(setup, candidate_grid(setup))
    sp, si = setup.noise
    # the design weighs each kind of view by its noise (the information of the weighted
    # estimate; the same choice when the noises are equal)
    chosen = greedy(info.I0 * (sp / si) ** 2, info.A, int(k), criterion,
                    _interest(info.names))
    cov = info.covariance(chosen, sp, intrinsics_noise_px=si)
    std, summary = summarise(info.names, cov)
    seconds = time.perf_counter() - t0
    tri = {} if workspace_depth is None else triangulation_std(info, cov, setup,
                                                               workspace_depth, setup.seed)
    return Plan(positions=[tuple(map(float, info.feasible[c])) for c in chosen],
                criterion=criterion, std=std, summary=summary, triangulation=tri,
                candidates=len(info.feasible), seconds=seconds,
                assumptions=setup.assumptions())


def nominal_setup(board=None, **kw) -> PlanSetup:
    """A setup for the simulated head's nominal model (:func:`rasc.sim.synthetic.default_head`)."""
    from rasc.sim.synthetic import default_head
    from rasc.vision.board import DEFAULT_BOARD

    return PlanSetup(head=default_head(), board=board or DEFAULT_BOARD, **kw)


def noise_from_calibration(path) -> tuple[float, float] | None:
    """(pose views', intrinsics views') corner noise per coordinate (px) that a ``rasc
    calibrate`` JSON's whole-head refinement residuals give
    (:attr:`rasc.head.use.CalibrationFile.corner_noise`), or None when it has none."""
    from rasc.head.use import read_calibration

    noise = read_calibration(path).corner_noise
    return None if noise is None else (noise["pose"], noise["intrinsics"])


def resolve_noise(noise: float | None = None, intrinsics_noise: float | None = None,
                  calibration=None) -> tuple[float, float | None, str]:
    """The corner noise a plan assumes: ``(noise_px, intrinsics_noise_px, how)`` for
    :class:`PlanSetup`, ``how`` a phrase saying where they come from. Each noise given
    is kept; one not given comes from the ``calibration`` file's residuals
    (:func:`noise_from_calibration`) when there is one with a refinement, else the pose
    views' is :data:`DEFAULT_NOISE_PX` and the intrinsics views' the same."""
    found = noise_from_calibration(calibration) if calibration is not None else None
    pose = noise if noise is not None else found[0] if found else DEFAULT_NOISE_PX
    intr = intrinsics_noise if intrinsics_noise is not None else found[1] if found else None
    taken = [what for what, given in (("pose", noise), ("intrinsics", intrinsics_noise))
             if given is None and found]
    how = (f"corner noise {pose:.3g} px per coordinate"
           + (f" in the pose views and {intr:.3g} px in the intrinsics views"
              if intr is not None and intr != pose else "") + ", independent")
    if len(taken) == 2:
        how += f" (from {calibration}'s residuals)"
    elif taken:
        how += f" (the {taken[0]} views' from {calibration}'s residuals)"
    elif noise is None and intrinsics_noise is None:
        how += " (the default)"
    return pose, intr, how


def image_size_of_calibration(path) -> tuple[int, int]:
    """The image size (width, height) of a ``rasc calibrate`` JSON's cameras, which a plan
    for that head must use (the field of view follows from it and K). The planner models
    one size: eyes of different sizes are refused in one line."""
    from rasc.head.use import load_calibration

    h = load_calibration(path)
    sizes = {eye: tuple(int(v) for v in getattr(h, eye).image_size) for eye in EYES}
    if sizes["left"] != sizes["right"]:
        raise InputError(f"{path}: the eyes' images differ in size (left "
                         f"{sizes['left'][0]}x{sizes['left'][1]}, right "
                         f"{sizes['right'][0]}x{sizes['right'][1]}); the planner models "
                         "one image size")
    return sizes["left"]


#: the lens models the planner's prediction holds, each with the refinement's
#: ``dist_model`` it predicts with (:data:`rasc.geometry.lens.DIST_MODELS`): a pinhole's
#: k1 k2 (``rasc calibrate``'s default), a fisheye's k1..k4 (``--dist-model fisheye``)
PLANNED_LENSES = {"pinhole": "k1k2", "fisheye": "fisheye"}


def check_planned_lens(head, where: str = "plan") -> None:
    """InputError (one line) when a head's lens is one the prediction does not model:
    a lens model other than :data:`PLANNED_LENSES`, eyes of two models, or OpenCV's
    rational terms k4..k6, which the planner's pinhole (5 coefficients) cannot hold."""
    models = {eye: lens_model(head, eye) for eye in EYES}
    for eye in EYES:
        model = models[eye]
        if model not in PLANNED_LENSES:
            raise InputError(f"{where}: the {eye} eye's lens is {model}: the planner "
                             f"predicts with {', '.join(PLANNED_LENSES)} lenses only")
        dist = np.asarray(head.dist[eye], float).ravel()
        if model == "pinhole" and np.any(dist[5:] != 0.0):
            raise InputError(f"{where}: the {eye} eye's lens has OpenCV's rational terms "
                             f"(k4..k6 = {', '.join(f'{v:g}' for v in dist[5:])}): the "
                             "planner models k1 k2 p1 p2 k3 and cannot plan for it")
    if models["left"] != models["right"]:
        raise InputError(f"{where}: the eyes' lens models differ (left {models['left']}, "
                         f"right {models['right']}); the planner predicts for a pair of one")


def _padded(dist, n: int) -> np.ndarray:
    """A lens's coefficients with the missing ones zero, at least ``n`` of them
    (``np.resize`` would repeat them: k1 k2 p1 p2 became k1 k2 p1 p2 k1)."""
    d = np.asarray(dist, float).ravel()
    return np.r_[d, np.zeros(max(0, n - d.size))]


def head_from_calibration(path) -> Any:
    """The head of a ``rasc calibrate`` JSON (or a rasc-head document) as the planner's
    head model. Refused (InputError naming the file) for a lens the planner does not model
    (:func:`check_planned_lens`)."""
    from types import SimpleNamespace

    from rasc.head.use import load_calibration
    from rasc.sim.synthetic import SyntheticHead

    h = load_calibration(path)
    check_planned_lens(SimpleNamespace(dist={e: getattr(h, e).dist for e in EYES},
                                       lens={e: getattr(h, e).lens for e in EYES}), str(path))
    lenses = {e: getattr(h, e).lens for e in EYES}
    # each model's full coefficients (a pinhole's OpenCV five, a fisheye's four)
    n = {"pinhole": 5, "fisheye": 4}
    return SyntheticHead(
        K={e: np.asarray(getattr(h, e).K, float) for e in EYES},
        dist={e: _padded(getattr(h, e).dist, n[lenses[e]]) for e in EYES},
        T_cam_from_gaze={e: np.asarray(getattr(h, e).T_cam_from_gaze, float) for e in EYES},
        T_ptu_from_base={e: np.asarray(getattr(h, e).T_ptu_from_base, float) for e in EYES},
        unit={e: getattr(h, e).unit for e in EYES},
        lens=None if set(lenses.values()) == {"pinhole"} else lenses)


def simulated_head(units: dict | None = None) -> Any:
    """The head ``rasc render --unit`` renders, as the planner's head model: the simulated
    head's cameras and mounts read from its model (no image is rendered), each pan-tilt
    unit built as ``units`` says (``{eye: rasc.sim.units.UnitBuild}``, what
    ``rasc render --unit FILE`` and its options for both units give; None: the model as
    written, ideal units)."""
    from rasc.sim.scene import StereoHeadSim
    from rasc.sim.synthetic import SyntheticHead

    with StereoHeadSim(units=units) as sim:
        return SyntheticHead(K={e: sim.K(e) for e in EYES},
                             dist={e: np.zeros(5) for e in EYES},
                             T_cam_from_gaze={e: sim.T_cam_from_gaze(e) for e in EYES},
                             T_ptu_from_base={e: sim.T_ptu_from_base(e) for e in EYES},
                             unit={e: sim.unit(e) for e in EYES})
