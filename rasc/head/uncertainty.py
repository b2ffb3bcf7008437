"""Uncertainty of triangulated points: first-order propagation of pixel noise and of the
calibration's covariance to each base-frame point.

A triangulated point is ``p = f(u, θ)``: ``u`` the four measured (distorted) pixel
coordinates of the point in both eyes, ``θ`` the head's parameters (eq. 15–19 after
undistortion, :meth:`rasc.head.model.HeadCalibration.triangulate`). To first order ::

    Σ_p = J_u Σ_u J_uᵀ + J_θ Σ_θ J_θᵀ

with ``Σ_u = σ_px² I₄`` (independent corner noise of σ_px per coordinate) and ``Σ_θ``
the covariance of the whole-head refinement (:mod:`rasc.head.refine`: σ² (JᵀJ)⁻¹ at the
optimum; the block of the head's own parameters, the board poses marginalised out, is
kept in the calibration file as ``refinement.covariance``, :func:`covariance_document`).
The two terms are independent: the pixels of a measured point are not the calibration's
corners. Both Jacobians are central differences of the whole mapping (undistortion,
both projections, the triangulation and, for θ, the base frame: the base is the
cyclopean frame of ``T_ptuL_from_ptuR``, so a change of the mounts moves the base and
with it every point's coordinates), so the propagation holds for ``ls`` and ``tls`` and
any lens and unit model.

The parameters follow the refinement's parameterisation (:func:`perturbed_head`):
intrinsics and distortion additive, rotations as a small rotation on the left
(``R ← exp(δ) R``), translations and the unit's parameters additive. (The refinement
estimates ``w`` in ``R = exp(w) R₀`` from the closed form's ``R₀``; at its optimum a change
``δw`` is the left rotation ``J_l(ŵ) δw``, and ``J_l(ŵ) = I + O(|ŵ|)``: with the
refinement's corrections of ~1e-3 rad the difference is ~1e-3 relative.)
Steps: :data:`PIXEL_STEP` px, and per parameter one hundredth of its standard deviation
(central differences: their error is ~1e-4 of the second-order terms, far below the
Monte-Carlo checks' bands, tests/head/test_point_uncertainty.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rasc import formats
from rasc.errors import InputError
from rasc.geometry import lens as lens_models
from rasc.geometry.frames import EYES
from rasc.head.model import EyeCalibration, HeadCalibration
from rasc.io import finite_number

#: central-difference step on the pixels, px: the triangulation is smooth on the scale of
#: pixels, and 1e-3 px leaves round-off (1e-16 · 1e3 px / 1e-3) far below 1e-6 relative
PIXEL_STEP = 1e-3
#: central-difference step of a calibration parameter, in its standard deviations
PARAMETER_STEP_STD = 1e-2

#: every lens model's distortion coefficients (pinhole k1-k6 p1 p2; the fisheye's k1-k4)
DIST_NAMES = lens_models.LENS_MODELS["pinhole"]
UNIT_NAMES = ("pan_scale", "tilt_scale", "tilt_axis_x", "tilt_axis_y", "tilt_point_x",
              "tilt_point_y", "tilt_point_z", "pan_offset", "tilt_offset")
FORMAT = formats.HEAD_COVARIANCE.tag


@dataclass(frozen=True)
class HeadCovariance:
    """The covariance of a head's parameters: ``names`` as the refinement names them
    (``left.fx``, ``left.T_cam_from_gaze.rotx``, ``right.unit.tilt_axis_x``,
    ``T_ptuL_from_ptuR.tz``, ...), ``matrix`` (n, n) in their natural units (px,
    radians, the length unit) and ``sigma_px`` the refinement's corner noise."""

    names: tuple[str, ...]
    matrix: np.ndarray
    sigma_px: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """The ``rasc-head-covariance/1`` document a calibration keeps in
        ``refinement.covariance``."""
        return {"format": FORMAT, "names": list(self.names), "matrix": self.matrix.tolist(),
                "sigma_px": self.sigma_px,
                "note": "covariance of the head's parameters (board poses marginalised out), "
                        "refinement parameterisation: rotations as a small left rotation "
                        "(rad), the rest additive; for rasc triangulate's sigmas"}

    @classmethod
    def from_dict(cls, d: Any, where: str = "covariance") -> HeadCovariance:
        """Read a ``rasc-head-covariance/1`` document; a malformed one is one
        :class:`InputError` line naming ``where``."""
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise InputError(f"{where}: expected an object with format {FORMAT!r}")
        names = d.get("names")
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise InputError(f"{where}.names: expected a list of parameter names")
        try:
            m = np.array(d.get("matrix"), dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{where}.matrix: not a numeric matrix") from None
        n = len(names)
        if m.shape != (n, n) or not np.all(np.isfinite(m)):
            raise InputError(f"{where}.matrix: expected a finite {n}x{n} matrix, got shape "
                             f"{m.shape}")
        scale = np.sqrt(np.outer(np.abs(np.diag(m)), np.abs(np.diag(m))))
        if np.any(np.abs(m - m.T) > 1e-6 * scale) or np.any(np.diag(m) < 0):
            raise InputError(f"{where}.matrix: not a covariance (asymmetric or negative "
                             "variances)")
        for name in names:
            _check_name(name, where)
        s = d.get("sigma_px")
        return cls(tuple(names), 0.5 * (m + m.T), None if s is None else float(s))


#: a continuous capture's camera-to-encoder offset δ (s), estimated with the head
#: (rasc.head.refine.timing): in the covariance for its correlations with the head's
#: parameters; a property of the capture, so it moves no point measured with the head
TIME_OFFSET = "time_offset"


def _check_name(name: str, where: str) -> None:
    group, _, rest = name.partition(".")
    ok = (group in EYES and (rest in ("fx", "fy", "cx", "cy") or rest in DIST_NAMES
                             or rest.startswith(("T_cam_from_gaze.rot", "T_cam_from_gaze.t"))
                             or rest.removeprefix("unit.") in UNIT_NAMES)) \
        or (group == "T_ptuL_from_ptuR" and rest in ("rotx", "roty", "rotz", "tx", "ty", "tz")) \
        or name == TIME_OFFSET
    if not ok:
        raise InputError(f"{where}.names: unknown parameter {name!r}")


def covariance_from_refinement(res) -> HeadCovariance | None:
    """The head block of a :class:`rasc.head.refine.RefinementResult`'s covariance (every
    parameter but the board poses; a marginal of a Gaussian is its sub-block)."""
    if res is None or res.covariance is None:
        return None
    keep = [i for i, n in enumerate(res.names) if not n.startswith("board[")]
    m = np.asarray(res.covariance)[np.ix_(keep, keep)]
    # (JᵀJ)⁻¹ is symmetric up to the inversion's round-off: make it exactly so
    return HeadCovariance(tuple(res.names[i] for i in keep), 0.5 * (m + m.T), float(res.sigma))


def covariance_document(res) -> dict | None:
    """What the calibration file keeps as ``refinement.covariance`` (None: no refinement
    covariance)."""
    cov = covariance_from_refinement(res)
    return None if cov is None else cov.to_dict()


def covariance_of_document(doc: Any, where: str = "calibration") -> HeadCovariance | None:
    """The covariance a calibration file (``rasc-calibration/1``) keeps, or None."""
    if not isinstance(doc, dict):
        return None
    ref = doc.get("refinement")
    if not isinstance(ref, dict) or "covariance" not in ref:
        return None
    return HeadCovariance.from_dict(ref["covariance"], f"{where}: refinement.covariance")


# ---------------------------------------------------------------------- perturbation

def _rotvec_matrix(w: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(w).as_matrix()


def perturbed_head(head: HeadCalibration, names, delta) -> HeadCalibration:
    """``head`` with the parameters ``names`` changed by ``delta`` in the refinement's
    parameterisation (module docstring). Changing ``T_ptuL_from_ptuR`` moves the base:
    both mounts become the cyclopean base of the changed ``T_ptuL_from_ptuR``."""
    from rasc.geometry.kinematics import PanTiltUnit
    from rasc.head.base_to_ptu import cyclopean_base

    parts: dict[str, dict[str, Any]] = {}
    for eye in EYES:
        e = getattr(head, eye)
        a = np.asarray(e.unit.tilt_axis, float)
        coef = lens_models.LENS_MODELS[e.lens]
        parts[eye] = {"K": e.K.copy(), "coef": coef,
                      "dist": np.r_[e.dist, np.zeros(len(coef) - len(e.dist))],
                      "R_cg": e.T_cam_from_gaze[:3, :3].copy(),
                      "t_cg": e.T_cam_from_gaze[:3, 3].copy(),
                      "unit": {"pan_scale": e.unit.pan_scale, "tilt_scale": e.unit.tilt_scale,
                               "tilt_axis_x": a[0] / a[2], "tilt_axis_y": a[1] / a[2],
                               "tilt_point_x": e.unit.tilt_point[0],
                               "tilt_point_y": e.unit.tilt_point[1],
                               "tilt_point_z": e.unit.tilt_point[2],
                               "pan_offset": e.unit.pan_offset,
                               "tilt_offset": e.unit.tilt_offset},
                      "n_dist": len(e.dist)}
    T_LR = head.T_ptuL_from_ptuR()
    R_LR, t_LR = T_LR[:3, :3].copy(), T_LR[:3, 3].copy()
    rot = {eye: np.zeros(3) for eye in (*EYES, "head")}
    mounts_changed = False
    for name, d in zip(names, np.asarray(delta, float), strict=True):
        if d == 0.0:
            continue
        group, _, rest = name.partition(".")
        if name == TIME_OFFSET:       # the capture's clock, not the head: moves no point
            continue
        if group == "T_ptuL_from_ptuR":
            mounts_changed = True
            k = "xyz".index(rest[-1])
            if rest.startswith("rot"):
                rot["head"][k] += d
            else:
                t_LR[k] += d
            continue
        p = parts[group]
        if rest in ("fx", "fy", "cx", "cy"):
            i, j = {"fx": (0, 0), "fy": (1, 1), "cx": (0, 2), "cy": (1, 2)}[rest]
            p["K"][i, j] += d
        elif rest in p["coef"]:
            p["dist"][p["coef"].index(rest)] += d
        elif rest.startswith("T_cam_from_gaze.rot"):
            rot[group]["xyz".index(rest[-1])] += d
        elif rest.startswith("T_cam_from_gaze.t"):
            p["t_cg"]["xyz".index(rest[-1])] += d
        elif rest.startswith("unit."):
            p["unit"][rest[5:]] += d
        else:
            raise InputError(f"unknown parameter {name!r}")
    if mounts_changed:
        T_new = np.eye(4)
        T_new[:3, :3] = _rotvec_matrix(rot["head"]) @ R_LR
        T_new[:3, 3] = t_LR
        T_pb = dict(zip(EYES, cyclopean_base(T_new), strict=True))
    else:
        T_pb = {eye: getattr(head, eye).T_ptu_from_base for eye in EYES}
    eyes = {}
    for eye in EYES:
        e, p = getattr(head, eye), parts[eye]
        T_cg = np.eye(4)
        T_cg[:3, :3] = _rotvec_matrix(rot[eye]) @ p["R_cg"]
        T_cg[:3, 3] = p["t_cg"]
        u = p["unit"]
        axis = np.array([u["tilt_axis_x"], u["tilt_axis_y"], 1.0])
        unit = PanTiltUnit(tilt_axis=tuple(axis / np.linalg.norm(axis)),
                           tilt_point=(u["tilt_point_x"], u["tilt_point_y"],
                                       u["tilt_point_z"]),
                           pan_offset=u["pan_offset"], tilt_offset=u["tilt_offset"],
                           pan_scale=u["pan_scale"], tilt_scale=u["tilt_scale"])
        # the eye's own length, unless a term beyond it was changed (then the shortest
        # length the lens model accepts that holds it)
        L = p["n_dist"]
        if np.any(p["dist"][L:]):
            last = int(np.flatnonzero(p["dist"])[-1]) + 1
            if e.lens == "pinhole":
                last = max(last, 5)          # OpenCV's five, as before the rational model
            L = min(n for n in lens_models.MODEL_N_COEFFS[e.lens] if n >= last)
        dist = p["dist"][:L]
        eyes[eye] = EyeCalibration(K=p["K"], dist=dist, T_cam_from_gaze=T_cg,
                                   T_ptu_from_base=T_pb[eye], image_size=e.image_size,
                                   unit=unit, std=e.std, lens=e.lens)
    return HeadCalibration(**eyes)


# ---------------------------------------------------------------------- propagation

@dataclass(frozen=True)
class PointUncertainty:
    """Covariances (N, 3, 3) of triangulated base-frame points: ``pixels`` from the pixel
    noise, ``calibration`` from the calibration's covariance (zeros without one),
    ``total`` their sum; ``sigma`` (N, 3) the standard deviation per base axis
    (x up, y forward, z left) of the total; ``pixel_sigma`` the σ_px used."""

    pixels: np.ndarray
    calibration: np.ndarray
    total: np.ndarray
    sigma: np.ndarray
    pixel_sigma: float
    with_calibration: bool


def point_uncertainty(head: HeadCalibration, uv_left, uv_right, pan_left, tilt_left,
                      pan_right, tilt_right, *, pixel_sigma: float,
                      covariance: HeadCovariance | None = None,
                      method: str = "ls") -> PointUncertainty:
    """First-order covariance of each triangulated point (module docstring).

    ``pixel_sigma``: the noise of each measured pixel coordinate, px (e.g. the
    refinement's ``sigma_px``: the same detector on the same cameras).
    """
    if finite_number(pixel_sigma, "pixel_sigma") < 0:
        raise InputError(f"pixel_sigma: expected a finite number >= 0 px, got {pixel_sigma!r}")
    uv = [np.array(uv_left, dtype=float), np.array(uv_right, dtype=float)]
    angles = (pan_left, tilt_left, pan_right, tilt_right)

    def tri(h: HeadCalibration, ul, ur) -> np.ndarray:
        return h.triangulate(ul, ur, *angles, method, on_degenerate="nan")

    n = uv[0].shape[0]
    J_u = np.zeros((n, 3, 4))
    for col in range(4):
        e, c = divmod(col, 2)
        plus = [u.copy() for u in uv]
        minus = [u.copy() for u in uv]
        plus[e][:, c] += PIXEL_STEP
        minus[e][:, c] -= PIXEL_STEP
        J_u[:, :, col] = (tri(head, *plus) - tri(head, *minus)) / (2 * PIXEL_STEP)
    cov_px = pixel_sigma ** 2 * np.einsum("nik,njk->nij", J_u, J_u)
    cov_cal = np.zeros_like(cov_px)
    if covariance is not None:
        std = np.sqrt(np.diag(covariance.matrix))
        cols = []
        for k in range(len(covariance.names)):
            h = PARAMETER_STEP_STD * std[k]
            if h == 0.0:
                cols.append(np.zeros((n, 3)))
                continue
            d = np.zeros(len(covariance.names))
            d[k] = h
            plus = tri(perturbed_head(head, covariance.names, d), *uv)
            minus = tri(perturbed_head(head, covariance.names, -d), *uv)
            cols.append((plus - minus) / (2 * h))
        J_t = np.stack(cols, axis=-1)                                   # (n, 3, k)
        cov_cal = np.einsum("nik,kl,njl->nij", J_t, covariance.matrix, J_t)
    total = cov_px + cov_cal
    sigma = np.sqrt(np.clip(np.diagonal(total, axis1=1, axis2=2), 0.0, None))
    return PointUncertainty(cov_px, cov_cal, total, sigma, float(pixel_sigma),
                            covariance is not None)


# ---------------------------------------------------------------------- from a file

def default_pixel_sigma(doc: Any) -> tuple[float, str] | None:
    """The pixel noise a calibration file implies for points measured with the same
    cameras and detector, and where it comes from: the refinement's σ (per coordinate),
    else the closed form's intrinsics RMS (a 2-D distance) / √2, the larger eye's; None
    for a bare head document."""
    if not isinstance(doc, dict):
        return None
    ref = doc.get("refinement")
    if isinstance(ref, dict) and isinstance(ref.get("sigma_px"), (int, float)):
        return float(ref["sigma_px"]), "the refinement's corner noise (refinement.sigma_px)"
    eyes = doc.get("eyes")
    if isinstance(eyes, dict):
        rms = [e.get("intrinsics_rms") for e in eyes.values() if isinstance(e, dict)]
        rms = [float(r) for r in rms if isinstance(r, (int, float)) and np.isfinite(r)]
        if rms:
            return max(rms) / np.sqrt(2.0), "the intrinsics RMS / sqrt(2) (eyes.*.intrinsics_rms)"
    return None


def read_covariance(path) -> tuple[HeadCovariance | None, tuple[float, str] | None]:
    """(the calibration covariance, the default pixel noise) of a calibration file."""
    from rasc.io import read_json_document

    doc = read_json_document(path, "calibration file")
    return covariance_of_document(doc, str(path)), default_pixel_sigma(doc)
