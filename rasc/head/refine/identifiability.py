"""Which unit parameters the corners determine (docs/METHOD.md §10): the column test on
the Jacobian at the initial guess. See :mod:`rasc.head.refine`, "Identifiability"."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from rasc.errors import DegenerateDataError
from rasc.geometry.frames import EYES
from rasc.head.refine.model import (
    UNIT_PARAMETERS,
    HeadObservations,
)
from rasc.head.refine.problem import _Problem

#: Why each parameter is not identifiable when the Jacobian says so (docs/METHOD.md §10).
REASONS = {
    "pan_offset": "a pan encoder offset turns the unit's frame about its pan axis, which the "
                  "mount (T_ptuL_from_ptuR) and the board poses absorb; it needs a measured "
                  "mount or a known home",
    "tilt_offset": "a tilt encoder offset turns the gaze frame about the tilt axis, which "
                   "T_cam_from_gaze absorbs; it needs a known home",
    "tilt_point_x": "moving the tilt axis along the pan axis commutes with the pan rotation "
                    "and is absorbed by T_cam_from_gaze and the mount",
    "tilt_point_z": "moving the point along the tilt axis changes nothing",
    "tilt_axis_y": "turning the tilt axis about the pan axis is absorbed by T_cam_from_gaze "
                   "and the mount",
    "pan_scale": "the pan readings do not vary enough to fix the pan scale",
    "tilt_scale": "the tilt readings do not vary enough to fix the tilt scale",
    "tilt_axis_x": "the motions cannot separate the axis angle from the hand-eye rotation",
    "tilt_point_y": "the motions cannot separate the axis distance from the hand-eye "
                    "translation",
    "time_offset": "the head is still (or moves too little) while the pose images are "
                   "taken: a clock offset changes no reading",
}

#: A Jacobian column (normalised) within this sine of the span of the others is not
#: determined by the data. Exact gauge directions measure ≤ 1e-9 here (central
#: differences, round-off); the weakest observable unit parameter on the default dataset
#: (the pan scale from ±8° pans) measures ~1e-2. The threshold sits between, at 1e-6.
IDENTIFIABILITY_SINE = 1e-6


#: The distortion coefficients tested like the unit's parameters (before them, in this
#: order), per ``dist_model``: the rational model's denominator k4 k5 k6 trades with its
#: numerator (multiplying both by 1 + g r² changes only terms of r⁸ and beyond): on a
#: 60° lens with the truth's k1-k6 = 0.3, -0.05, 0.004, 0.6, 0.02, 0.001, OpenCV's
#: calibration came out at k2 = 105, k5 = 101 (seed 3, 0.05 px), with five singular
#: values of the normalised Jacobian at 2e-8 to 3e-7 (measured). A coefficient the
#: corners cannot determine is held at the intrinsics' value (cv2.calibrateCamera's),
#: for both eyes.
DIST_CANDIDATES = {"rational": ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")}
#: ... and held when its column is within this sine of the others' span: stricter than
#: :data:`IDENTIFIABILITY_SINE`, since the covariance (JᵀJ)⁻¹ squares the conditioning (at
#: 1e-6 a rational calibration's k1 came out with a negative variance, measured)
DIST_IDENTIFIABILITY_SINE = 1e-3
DIST_REASON = ("the rational model's coefficients trade with each other on these views: "
               "held at the intrinsics' value")


# ----------------------------------------------------------------------------- identifiability

def _identifiable(obs: HeadObservations, hold: tuple[str, ...] = (),
                  time_offset: bool = False
                  ) -> tuple[dict[str, list[str]], list[dict[str, Any]]]:
    """Decide, from the Jacobian at the initial guess, which unit parameters the corners
    determine (see the module docstring); ``hold``: candidates not estimated at all.
    ``time_offset``: δ is the first candidate (a continuous capture); when the corners
    cannot determine it, it is dropped as ``{"eye": "head", "parameter": "time_offset"}``.
    Raises :class:`DegenerateDataError` when the basic parameters (intrinsics, hand-eye,
    mounts, board poses) are not determined."""
    candidates = [n for n in UNIT_PARAMETERS if n not in hold]
    full = {eye: list(candidates) for eye in EYES}
    prob = _Problem(obs, full, time_offset=time_offset)
    # the distortion coefficients tested like the unit's (before them; held for both eyes
    # when either eye's corners cannot determine one)
    dist_cand = [n for n in DIST_CANDIDATES.get(obs.dist_model, ())
                 if f"left.{n}" in prob.names]
    dist_cols = {(eye, n): prob.names.index(f"{eye}.{n}") for eye in EYES for n in dist_cand}
    J = prob.jacobian(np.zeros(len(prob.names)))
    d = np.sqrt(np.asarray(J.multiply(J).sum(axis=0)).ravel())
    unit_cols = {}
    for eye in EYES:
        c = prob.eye_cols[eye]
        first = c["start"] + c["n_intr"] + 6
        for k, n in enumerate(candidates):
            unit_cols[(eye, n)] = first + k
    if prob.time_col is not None:
        unit_cols[("head", "time_offset")] = prob.time_col
    for j in range(len(prob.names)):
        if d[j] == 0 and j not in set(unit_cols.values()) | set(dist_cols.values()):
            raise DegenerateDataError(f"refinement: parameter {prob.names[j]} moves no corner")
    Jn = (J @ sp.diags(1.0 / np.where(d > 0, d, 1.0))).tocsc()
    # The intrinsics views' board poses act on their own image's rows only: project each
    # image's rows onto the complement of its six pose columns (a 2N x 6 QR each), which
    # leaves the angles between the remaining columns and the span of all the others
    # unchanged; then one QR of the global columns (intrinsics, hand-eye, mounts, the pose
    # views' board pose) — no dense QR of the whole Jacobian, and no squared condition
    # number as with JᵀJ.
    glob = list(range(prob.n_global)) + list(range(len(prob.names) - 6, len(prob.names)))
    G = Jn[:, glob].toarray()
    rows_of = prob._rows_of_images()
    for i in np.flatnonzero(prob.img_role == 0):
        k = prob.n_global + 6 * int(prob.img_pose[i])
        rows = rows_of[i]
        B = Jn[rows][:, k:k + 6].toarray()
        Qi, Ri = np.linalg.qr(B)
        if np.abs(np.diag(Ri)).min() < IDENTIFIABILITY_SINE:
            raise DegenerateDataError(f"refinement: the board pose of intrinsics view "
                                      f"{prob.img_name[i]} is not determined by its corners")
        G[rows] -= Qi @ (Qi.T @ G[rows])
    col = {j: m for m, j in enumerate(glob)}
    base = [col[j] for j in glob
            if j not in set(unit_cols.values()) | set(dist_cols.values())]
    Q, Rq = np.linalg.qr(G[:, base])
    rdiag = np.abs(np.diag(Rq))
    if rdiag.min() < IDENTIFIABILITY_SINE:
        j = glob[base[int(np.argmin(rdiag))]]
        raise DegenerateDataError(
            f"refinement: the corners cannot determine {prob.names[j]} (and the parameters "
            "it trades with); add pose views that turn about both axes and intrinsics "
            "views tilted 20-45 degrees")
    free: dict[str, list[str]] = {eye: [] for eye in EYES}
    dropped = []
    for n in dist_cand:
        rs, sines = [], []
        for eye in EYES:
            j = dist_cols[(eye, n)]
            v = G[:, col[j]]
            r = v - Q @ (Q.T @ v)
            r -= Q @ (Q.T @ r)
            rs.append(r)
            sines.append(float(np.linalg.norm(r)) if d[j] > 0 else 0.0)
        if min(sines) < DIST_IDENTIFIABILITY_SINE:
            dropped += [{"eye": eye, "parameter": n, "reason": DIST_REASON, "sine": sine}
                        for eye, sine in zip(EYES, sines, strict=True)]
            continue
        for r in rs:
            r = r - Q @ (Q.T @ r)
            Q = np.column_stack([Q, r / np.linalg.norm(r)])
    order = ([("head", "time_offset")] if prob.time_col is not None else []) \
        + [(eye, n) for eye in EYES for n in candidates]
    for eye, n in order:
        j = unit_cols[(eye, n)]
        v = G[:, col[j]]
        r = v - Q @ (Q.T @ v)
        r -= Q @ (Q.T @ r)                       # re-orthogonalise once
        sine = float(np.linalg.norm(r)) if d[j] > 0 else 0.0
        if sine < IDENTIFIABILITY_SINE:
            dropped.append({"eye": eye, "parameter": n, "reason": REASONS[n],
                            "sine": sine})
        else:
            Q = np.column_stack([Q, r / sine])
            if eye in free:                      # (δ is the head's: kept unless dropped)
                free[eye].append(n)
    return free, dropped
