"""One refinement's problem: parameter layout, prediction and residuals of every corner
(:class:`_Problem`; its Jacobians are in :mod:`rasc.head.refine.jacobian`). See
:mod:`rasc.head.refine`."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from rasc.errors import InputError
from rasc.geometry import lens as lens_models
from rasc.geometry.frames import EYES
from rasc.geometry.transforms import invert_transform, make_transform
from rasc.head.refine.jacobian import _JacobianMixin
from rasc.head.refine.model import (
    DIST_MODELS,
    DIST_PARAMS,
    UNIT_DEFAULTS,
    HeadObservations,
    _axis_rotation,
    _left_jacobian,
    _rodrigues_batch,
    _unit_motion,
    _unit_motion_of,
)
from rasc.head.refine.timing import angles_at, rates_at


class _Problem(_JacobianMixin):
    """Parameter layout, residuals and Jacobian structure of one refinement."""

    def __init__(self, obs: HeadObservations, unit_free: dict[str, list[str]],
                 dist_held: tuple[str, ...] = (), time_offset: bool = False,
                 time_offset0: float = 0.0):
        """``time_offset``: estimate the camera-to-encoder offset δ (one global parameter,
        ``"time_offset"``, from ``time_offset0`` s): each pose image's readings are then
        its eye's joint stream at the image's time + δ (:mod:`rasc.head.refine.timing`)
        instead of its ``pan_tilt``. Needs ``obs.has_stream``."""
        self.obs = obs
        if time_offset and not obs.has_stream:
            raise InputError("refinement: the time offset needs every pose image's time "
                             "and a joint stream")
        # the lens model, all its coefficients' names, those estimated (the others are 0,
        # but those ``dist_held``, which keep the intrinsics' value: a rational model's
        # coefficient the corners cannot determine, :func:`_identifiable`)
        self.lens = DIST_MODELS[obs.dist_model][0]
        self.coef_names = lens_models.LENS_MODELS[self.lens]
        self.dist_idx = tuple(self.coef_names.index(n) for n in DIST_PARAMS[obs.dist_model]
                              if n not in dist_held)
        self.dist_held = tuple(dist_held)
        self.dist_fixed = {}
        for eye in EYES:
            fixed = np.zeros(len(self.coef_names))
            given = np.asarray(obs.eyes[eye].dist, float).ravel()[:len(fixed)]
            for n in dist_held:
                i = self.coef_names.index(n)
                if i < len(given):
                    fixed[i] = given[i]
            self.dist_fixed[eye] = fixed
        P = obs.board_points
        # length scale for translations: the median camera-to-board distance
        depths = [T[2, 3] for e in obs.eyes.values()
                  for T in (*e.T_cam_from_world_intrinsics.values(),
                            *e.T_cam_from_world_pose.values())]
        L = float(np.median(depths))
        self.length_scale = L
        names, scales, x0 = [], [], []

        def add(name, value, scale):
            names.append(name)
            scales.append(scale)
            x0.append(value)

        self.eye_cols: dict[str, dict[str, int]] = {}
        for eye in EYES:
            e = obs.eyes[eye]
            start = len(names)
            for k, n in enumerate(("fx", "fy", "cx", "cy")):
                add(f"{eye}.{n}", (e.K[0, 0], e.K[1, 1], e.K[0, 2], e.K[1, 2])[k], 100.0)
            dist = np.zeros(len(self.coef_names))
            given = np.asarray(e.dist, float).ravel()[:len(dist)]
            dist[:len(given)] = given
            for i in self.dist_idx:
                add(f"{eye}.{self.coef_names[i]}", dist[i], 1.0)
            n_intr = len(names) - start
            for k in range(3):
                add(f"{eye}.T_cam_from_gaze.rot{'xyz'[k]}", 0.0, 0.1)
            for k in range(3):
                add(f"{eye}.T_cam_from_gaze.t{'xyz'[k]}", e.T_cam_from_gaze[k, 3], 0.1 * L)
            for n in unit_free[eye]:
                s = 0.1 * L if n.startswith("tilt_point") else (1.0 if n.endswith("scale")
                                                                 else 0.1)
                add(f"{eye}.unit.{n}", UNIT_DEFAULTS[n], s)
            self.eye_cols[eye] = {"start": start, "n_intr": n_intr, "stop": len(names)}
        self.head_start = len(names)
        for k in range(3):
            add(f"T_ptuL_from_ptuR.rot{'xyz'[k]}", 0.0, 0.1)
        for k in range(3):
            add(f"T_ptuL_from_ptuR.t{'xyz'[k]}", obs.T_ptuL_from_ptuR[k, 3], 0.1 * L)
        # δ (s), scaled by 10 ms: the size of an offset between two clocks on one machine
        self.time_col = None
        if time_offset:
            self.time_col = len(names)
            add("time_offset", float(time_offset0), 0.01)
        self.n_global = len(names)
        # board poses: rotation as a perturbation exp(w)·R0, translation absolute
        pose_R0, pose_t0, pose_names = [], [], []
        for eye in EYES:
            for n, T in obs.eyes[eye].T_cam_from_world_intrinsics.items():
                pose_names.append(f"{eye}:{n}")
                pose_R0.append(T[:3, :3])
                pose_t0.append(T[:3, 3])
        # one board pose for every pose view: the target stays put while the units move,
        # as hand-eye (eq. 4-7) and loop closure (eq. 11-12) assume; initial value from the
        # first pose image (left eye if any), with the ideal unit
        T_pLpR = obs.T_ptuL_from_ptuR
        T = None
        for eye in EYES:
            e = obs.eyes[eye]
            if not e.pose:
                continue
            f = next(iter(e.pose))
            R, t = _unit_motion(UNIT_DEFAULTS, np.array([e.pan_tilt[f][0]]),
                                np.array([e.pan_tilt[f][1]]))
            T = invert_transform(make_transform(R[0], t[0])) \
                @ invert_transform(e.T_cam_from_gaze) @ e.T_cam_from_world_pose[f]
            if eye == "right":
                T = T_pLpR @ T
            break
        if T is None:
            raise InputError("refinement: no pose images")
        pose_names.append("pose views")
        pose_R0.append(T[:3, :3])
        pose_t0.append(T[:3, 3])
        self.pose_names = pose_names
        self.pose_R0 = np.array(pose_R0)
        n_poses = len(pose_names)
        for i, pn in enumerate(pose_names):
            for k in range(3):
                add(f"board[{pn}].rot{'xyz'[k]}", 0.0, 0.1)
            for k in range(3):
                add(f"board[{pn}].t{'xyz'[k]}", pose_t0[i][k], 0.1 * L)
        self.names = names
        self.scale = np.array(scales)
        self.p0 = np.array(x0)
        self.n_poses = n_poses
        self.R0_cg = {eye: obs.eyes[eye].T_cam_from_gaze[:3, :3] for eye in EYES}
        self.R0_pLpR = T_pLpR[:3, :3]
        self.unit_free = unit_free
        # images
        img_eye, img_role, img_name, img_pose, pan, tilt, corners = [], [], [], [], [], [], []
        img_time = []
        pose_view_index = len(pose_names) - 1
        for ei, eye in enumerate(EYES):
            e = obs.eyes[eye]
            for n, c in e.intrinsics.items():
                img_eye.append(ei)
                img_role.append(0)
                img_name.append(n)
                img_pose.append(pose_names.index(f"{eye}:{n}"))
                pan.append(0.0)
                tilt.append(0.0)
                img_time.append(np.nan)
                corners.append(c)
            for f, c in e.pose.items():
                img_eye.append(ei)
                img_role.append(1)
                img_name.append(f)
                img_pose.append(pose_view_index)
                pan.append(e.pan_tilt[f][0])
                tilt.append(e.pan_tilt[f][1])
                img_time.append(e.pose_time.get(f, np.nan))
                corners.append(c)
        self.img_eye = np.array(img_eye)
        self.img_role = np.array(img_role)
        self.img_name = img_name
        self.img_pose = np.array(img_pose)
        self.pan, self.tilt = np.array(pan), np.array(tilt)
        self.img_time = np.array(img_time, float)     # camera clock, s (NaN: none)
        self.streams = obs.streams if time_offset else None
        # per eye, the stream's readings at encoder times (one function each, for _cached)
        self._angles_of = {eye: functools.partial(angles_at, self.streams[eye])
                           for eye in EYES} if time_offset else {}
        self.corners = np.array(corners, dtype=float)          # (n_img, N, 2)
        self.P = np.asarray(P, float)
        # a partial view (ChArUco) marks the corners it does not show with NaN rows: they
        # are never part of the fit (``seen``); ``mask`` is the seen corners still kept
        self.seen = np.all(np.isfinite(self.corners), axis=-1)
        if not self.seen.all():
            self.corners[~self.seen] = 0.0
        self.mask = self.seen.copy()
        self.pose_images = {ei: np.flatnonzero((self.img_eye == ei) & (self.img_role == 1))
                            for ei in range(2)}
        # results of pure functions of a few parameters (rotations, unit motions), by the
        # bytes of their arguments: a Jacobian column changes one parameter, so most of
        # its chain is the same numbers as the last one's (see _cached)
        self._memo: dict[tuple, Any] = {}

    def _cached(self, fn, *args: np.ndarray) -> Any:
        """``fn(*args)`` (arrays), computed once for the same argument bytes (exact: the
        same input bits give the same output bits). Its arrays are made read-only: a
        caller that wrote into one would change the next call's result."""
        key = (fn, *((a.shape, a.tobytes()) for a in args))
        hit = self._memo.get(key)
        if hit is None:
            if len(self._memo) >= 256:                # a few iterations' worth
                self._memo.clear()
            hit = self._memo[key] = fn(*args)
            for a in hit if isinstance(hit, tuple) else (hit,):
                a.flags.writeable = False
        return hit

    # ---- parameters -----------------------------------------------------------------

    def unpack(self, x: np.ndarray, poses: np.ndarray | None = None) -> dict[str, Any]:
        """Parameters by name; board poses only for the indices ``poses`` (default all),
        as ``pose_R``/``pose_t`` in that order."""
        p = self.p0 + self.scale * x
        out: dict[str, Any] = {}
        for eye in EYES:
            c = self.eye_cols[eye]
            i = c["start"]
            fx, fy, cx, cy = p[i:i + 4]
            d = self.dist_fixed[eye].copy()
            for k, j in enumerate(self.dist_idx):
                d[j] = p[i + 4 + k]
            j = i + c["n_intr"]
            R = self._cached(_rodrigues_batch, p[j:j + 3][None])[0] @ self.R0_cg[eye]
            T_cg = make_transform(R, p[j + 3:j + 6])
            u = dict(UNIT_DEFAULTS)
            for k, n in enumerate(self.unit_free[eye]):
                u[n] = p[j + 6 + k]
            out[eye] = {"K": (fx, fy, cx, cy), "dist": d, "T_cam_from_gaze": T_cg, "unit": u}
        h = self.head_start
        R = self._cached(_rodrigues_batch, p[h:h + 3][None])[0] @ self.R0_pLpR
        out["T_ptuL_from_ptuR"] = make_transform(R, p[h + 3:h + 6])
        b = p[self.n_global:].reshape(self.n_poses, 6)
        poses = np.arange(self.n_poses) if poses is None else poses
        out["pose_R"] = self._cached(_rodrigues_batch, b[poses, :3]) @ self.pose_R0[poses]
        out["pose_t"] = b[poses, 3:].copy()
        return out

    # ---- prediction -----------------------------------------------------------------

    def predict(self, x: np.ndarray, sel: np.ndarray | None = None) -> np.ndarray:
        """Predicted pixels (n_img, N, 2), or (len(sel), N, 2) for the images ``sel``."""
        sel = np.arange(len(self.img_eye)) if sel is None else sel
        return self._project(x, sel, self._chain(x, sel))[0]

    def _chain(self, x: np.ndarray, sel: np.ndarray) -> dict[str, Any]:
        """The kinematic chain of the images ``sel``: ``R`` (n, 3, 3), ``t`` (n, 3) of
        ``T_cam_from_board`` (eq. 1-2 with the general unit), ``RA`` (n, 3, 3) the rotation
        of the chain in front of the board pose (I for an intrinsics view), ``Rb``
        (n, 3, 3) the board pose's rotation and ``w`` (n, 3) its rotation vector, ``s``
        the unpacked parameters."""
        img_eye, img_role = self.img_eye[sel], self.img_role[sel]
        poses, img_pose = np.unique(self.img_pose[sel], return_inverse=True)
        s = self.unpack(x, poses)
        R = s["pose_R"][img_pose]
        t = s["pose_t"][img_pose]
        Rb = R.copy()
        RA_all = np.broadcast_to(np.eye(3), R.shape).copy()
        T_pRpL = None
        for ei, eye in enumerate(EYES):
            idx = np.flatnonzero((img_eye == ei) & (img_role == 1))
            if len(idx) == 0:
                continue
            u = s[eye]["unit"]
            pan, tilt = self._readings(x, sel[idx], eye)
            Rg, tg = self._cached(_unit_motion_of, np.array([u[n] for n in UNIT_DEFAULTS]),
                                  pan, tilt)
            T_cg = s[eye]["T_cam_from_gaze"]
            if eye == "left":
                M = np.eye(4)
            else:
                T_pRpL = invert_transform(s["T_ptuL_from_ptuR"]) if T_pRpL is None else T_pRpL
                M = T_pRpL
            # chain A = T_cg · T_gp · M, then A · T_board
            RA = T_cg[:3, :3] @ Rg @ M[:3, :3]
            tA = (T_cg[:3, :3] @ (Rg @ M[:3, 3] + tg)[..., None])[..., 0] + T_cg[:3, 3]
            t[idx] = np.einsum("nij,nj->ni", RA, t[idx]) + tA
            R[idx] = RA @ R[idx]
            RA_all[idx] = RA
        b = (self.p0 + self.scale * x)[self.n_global:].reshape(self.n_poses, 6)
        return {"R": R, "t": t, "RA": RA_all, "Rb": Rb, "w": b[poses, :3][img_pose],
                "tb": s["pose_t"][img_pose],
                "s": s, "img_eye": img_eye,
                "Kp": np.array([s[eye]["K"] for eye in EYES])[img_eye],      # (n, 4)
                "D": np.array([s[eye]["dist"] for eye in EYES])[img_eye]}    # (n, k)

    def time_offset(self, x: np.ndarray) -> float:
        """δ (s) at ``x``; 0 when it is not estimated."""
        if self.time_col is None:
            return 0.0
        j = self.time_col
        return float(self.p0[j] + self.scale[j] * x[j])

    def _readings(self, x: np.ndarray, imgs: np.ndarray, eye: str
                  ) -> tuple[np.ndarray, np.ndarray]:
        """(pan, tilt) of the pose images ``imgs`` of ``eye``: the dataset's, or with δ
        estimated its stream at each image's time + δ."""
        if self.time_col is None:
            return self.pan[imgs], self.tilt[imgs]
        a = self._cached(self._angles_of[eye], self.img_time[imgs] + self.time_offset(x))
        return a[:, 0], a[:, 1]

    def time_derivative(self, x: np.ndarray, ch: dict[str, Any], sel: np.ndarray
                        ) -> np.ndarray:
        """d pc / dδ (n, N, 3) of the images ``sel`` (zero for intrinsics views): the
        stream's angular velocity at t + δ times the camera-frame point's derivatives with
        respect to the readings (eq. 1-2 with the general unit: the pan turns the point
        about the ptu x axis by −φ, the tilt about the tilt axis a through q by τ), in
        seconds."""
        out = np.zeros((len(sel), len(self.P), 3))
        if self.time_col is None:
            return out
        s, d = ch["s"], self.time_offset(x)
        img_eye, img_role = self.img_eye[sel], self.img_role[sel]
        T_pRpL = invert_transform(s["T_ptuL_from_ptuR"])
        for ei, eye in enumerate(EYES):
            idx = np.flatnonzero((img_eye == ei) & (img_role == 1))
            if len(idx) == 0:
                continue
            u = s[eye]["unit"]
            imgs = sel[idx]
            t = self.img_time[imgs] + d
            ang = angles_at(self.streams[eye], t)
            rate = rates_at(self.streams[eye], t)
            phi = u["pan_scale"] * ang[:, 0] + u["pan_offset"]
            tau = u["tilt_scale"] * ang[:, 1] + u["tilt_offset"]
            a = np.array([u["tilt_axis_x"], u["tilt_axis_y"], 1.0])
            a /= np.linalg.norm(a)
            qt = np.array([u["tilt_point_x"], u["tilt_point_y"], u["tilt_point_z"]])
            M = np.eye(4) if eye == "left" else T_pRpL
            # the board point in this unit's ptu frame
            q = np.einsum("nij,kj->nki", ch["Rb"][idx], self.P) + ch["tb"][idx][:, None]
            y = q @ M[:3, :3].T + M[:3, 3]
            R_pan = _axis_rotation(np.array([1.0, 0.0, 0.0]), -phi)
            R_tilt = _axis_rotation(a, tau)
            v = np.einsum("nij,nkj->nki", R_pan, y)
            dg_dphi = -np.einsum("nij,nkj->nki", R_tilt,
                                 np.cross(np.array([1.0, 0.0, 0.0]), v))
            dg_dtau = np.cross(a, np.einsum("nij,nkj->nki", R_tilt, v - qt))
            dg = (dg_dphi * (u["pan_scale"] * rate[:, 0])[:, None, None]
                  + dg_dtau * (u["tilt_scale"] * rate[:, 1])[:, None, None])
            out[idx] = dg @ s[eye]["T_cam_from_gaze"][:3, :3].T
        return out

    def _project(self, x: np.ndarray, sel: np.ndarray, ch: dict[str, Any],
                 derivatives: bool = False, board: bool = True):
        """Pixels (n, N, 2) of the chain ``ch`` of the images ``sel`` (eq. 1-2 with
        distortion and K; without ``derivatives`` only ``ch``'s ``R``, ``t``, ``Kp`` and
        ``D`` are used, as :meth:`_residuals_batch` passes them); with ``derivatives``
        also the analytic derivatives (each (n, N, 2, k)) of the pixels with respect to
        the camera-frame point (k = 3), to the eye's intrinsics in the layout of
        :attr:`names` (fx fy cx cy, then the distortion terms of the dataset's model) and
        to the image's board pose (k = 6: its rotation vector w, ``R = exp(w) R0``, then
        its translation), in natural units; ``board=False`` leaves the last out (the
        planner, :mod:`rasc.plan`, needs the others only)."""
        R, t = ch["R"], ch["t"]
        pc = np.einsum("nij,kj->nki", R, self.P) + t[:, None, :]
        x_, y_ = pc[..., 0] / pc[..., 2], pc[..., 1] / pc[..., 2]
        Kp, D = ch["Kp"], ch["D"]                                   # (n, 4), (n, k)
        # the lens model's distortion and its derivatives (rasc.geometry.lens, one for
        # every model: pinhole k1 k2 p1 p2 k3 k4 k5 k6, fisheye k1 k2 k3 k4)
        xd, yd, (jxx, jxy, jyx, jyy), by_coef = lens_models.distortion_jacobians(
            x_, y_, [D[:, i:i + 1] for i in range(D.shape[1])], self.lens)
        fx, fy = Kp[:, 0:1], Kp[:, 1:2]
        u = fx * xd + Kp[:, 2:3]
        v = fy * yd + Kp[:, 3:4]
        uv = np.stack([u, v], axis=-1)
        if not derivatives:
            return uv, None
        iz = 1.0 / pc[..., 2]
        # d(u, v)/d pc: the distortion's Jacobian scaled by fx, fy, times
        # d(x_, y_)/d pc = [[1/Z, 0, -x_/Z], [0, 1/Z, -y_/Z]]
        J = np.empty(pc.shape[:2] + (2, 3))
        J[..., 0, 0] = fx * jxx * iz
        J[..., 0, 1] = fx * jxy * iz
        J[..., 0, 2] = -(J[..., 0, 0] * x_ + J[..., 0, 1] * y_)
        J[..., 1, 0] = fy * jyx * iz
        J[..., 1, 1] = fy * jyy * iz
        J[..., 1, 2] = -(J[..., 1, 0] * x_ + J[..., 1, 1] * y_)
        # intrinsics: fx fy cx cy, then the distortion terms the model estimates
        zero, one = np.zeros_like(x_), np.ones_like(x_)
        cols = [(xd, zero), (zero, yd), (one, zero), (zero, one)]
        for i in self.dist_idx:
            dxd, dyd = by_coef[self.coef_names[i]]
            cols.append((fx * dxd, fy * dyd))
        d_intr = np.stack([np.stack(np.broadcast_arrays(*c), axis=-1) for c in cols], axis=-1)
        if not board:
            return uv, {"point": J, "intrinsics": d_intr}
        # board pose: q = exp(w) R0 P + t_b, pc = RA q + tA; a change dw of the rotation
        # vector turns q by J_l(w) dw (J_l: SO(3)'s left Jacobian), so
        # d pc / d w = -RA [Rb P]x J_l(w), d pc / d t_b = RA
        q = np.einsum("nij,kj->nki", ch["Rb"], self.P)          # (n, N, 3), without t_b
        Jl = _left_jacobian(ch["w"])                              # (n, 3, 3)
        neg_skew = np.zeros(q.shape + (3,))
        neg_skew[..., 0, 1], neg_skew[..., 0, 2] = q[..., 2], -q[..., 1]
        neg_skew[..., 1, 0], neg_skew[..., 1, 2] = -q[..., 2], q[..., 0]
        neg_skew[..., 2, 0], neg_skew[..., 2, 1] = q[..., 1], -q[..., 0]
        JRA = np.einsum("nkab,nbc->nkac", J, ch["RA"])            # d uv / d q
        d_board = np.concatenate(
            [np.einsum("nkab,nkbc,ncd->nkad", JRA, neg_skew, Jl), JRA], axis=-1)
        return uv, {"point": J, "intrinsics": d_intr, "board": d_board}

    def residuals_of(self, x: np.ndarray, sel: np.ndarray) -> np.ndarray:
        """Residuals of the images ``sel`` (ascending), kept corners, flattened."""
        return (self.predict(x, sel) - self.corners[sel])[self.mask[sel]].ravel()

    def _residuals_batch(self, xs: list[np.ndarray], sel: np.ndarray) -> list[np.ndarray]:
        """:meth:`residuals_of` of the images ``sel`` at each parameter vector of ``xs``:
        each chain as :meth:`_chain` builds it, then the pixels of all of them in one
        :meth:`_project`. Its arithmetic is elementwise (and a per-image einsum), so every
        number is the one a call per vector gives, bit for bit (the refined calibration
        JSON, byte for byte), for a fraction of the calls: the differences of the
        Jacobian's kinematic columns, about half of a refinement's time before."""
        chains = [self._chain(x, sel) for x in xs]
        batch = {k: np.concatenate([ch[k] for ch in chains]) for k in ("R", "t", "Kp", "D")}
        uv = self._project(None, sel, batch)[0]
        uv = uv.reshape((len(xs), len(sel)) + uv.shape[1:])
        want, keep = self.corners[sel], self.mask[sel]
        return [(u - want)[keep].ravel() for u in uv]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return (self.predict(x) - self.corners)[self.mask].ravel()

    def all_residuals(self, x: np.ndarray) -> np.ndarray:
        """(n_img, N, 2), rejected corners included."""
        return self.predict(x) - self.corners

    # ---- Jacobian -------------------------------------------------------------------

    def column_images(self) -> list[np.ndarray]:
        """For every parameter, the images whose corners it moves."""
        cols = []
        for ei, eye in enumerate(EYES):
            c = self.eye_cols[eye]
            all_e = np.flatnonzero(self.img_eye == ei)
            cols += [all_e] * c["n_intr"]
            cols += [self.pose_images[ei]] * (c["stop"] - c["start"] - c["n_intr"])
        cols += [self.pose_images[1]] * 6
        if self.time_col is not None:
            cols += [np.concatenate([self.pose_images[0], self.pose_images[1]])]
        for i in range(self.n_poses):
            cols += [np.flatnonzero(self.img_pose == i)] * 6
        return cols

    def _rows_of_images(self) -> list[np.ndarray]:
        counts = self.mask.sum(axis=1) * 2
        ends = np.cumsum(counts)
        return [np.arange(e - c, e) for c, e in zip(counts, ends, strict=True)]
