"""The refinement's Jacobians (:meth:`_JacobianMixin.jacobian`, by differences, and
:meth:`_JacobianMixin.jacobian_lm`, analytic where it can be), methods of
:class:`rasc.head.refine.problem._Problem`. See :mod:`rasc.head.refine`, "Solver"."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from rasc.geometry.frames import EYES


class _JacobianMixin:
    """The Jacobians of :class:`rasc.head.refine.problem._Problem`."""

    def jacobian(self, x: np.ndarray, h: float = 1e-5, central: bool = True,
                 r0: np.ndarray | None = None, analytic: bool = True) -> sp.csr_matrix:
        """The Jacobian of :meth:`residuals` with respect to ``x`` (sparse, (2M, n)).

        ``analytic`` (default): the intrinsics and board-pose columns analytically, the
        kinematic ones by differences (:meth:`jacobian_lm`). Otherwise finite differences
        over the block structure: one evaluation (pair, when ``central``) per global
        parameter, on the images it moves only, and one per board-pose coordinate for all
        boards at once (their corners are disjoint). Central: truncation error ~h² (1e-10
        relative), for the identifiability test and the covariance; forward (with ``r0``,
        the residuals at x): for the iterations."""
        if analytic:
            return self.jacobian_lm(x, self.residuals(x) if r0 is None and not central
                                    else r0, h=h, central=central)
        rows_of = self._rows_of_images()
        n = len(self.names)
        col_imgs = self.column_images()
        groups = [[j] for j in range(self.n_global)]
        for k in range(6):
            groups.append([self.n_global + 6 * i + k for i in range(self.n_poses)])
        if not central and r0 is None:
            r0 = self.residuals(x)
        data_r, data_c, data_v = [], [], []
        for g in groups:
            imgs = np.unique(np.concatenate([col_imgs[j] for j in g]))
            if len(imgs) == 0:
                continue
            rows = np.concatenate([rows_of[i] for i in imgs])
            dx = np.zeros(n)
            dx[g] = h
            if central:
                d = (self.residuals_of(x + dx, imgs) - self.residuals_of(x - dx, imgs)) / (2 * h)
            else:
                d = (self.residuals_of(x + dx, imgs) - r0[rows]) / h
            local = np.full(rows.max() + 1 if len(rows) else 0, -1)
            local[rows] = np.arange(len(rows))
            for j in g:
                r = np.concatenate([rows_of[i] for i in col_imgs[j]]) if len(col_imgs[j]) \
                    else np.zeros(0, int)
                data_r.append(r)
                data_c.append(np.full(len(r), j))
                data_v.append(d[local[r]])
        m = int(self.mask.sum()) * 2
        return sp.csr_matrix((np.concatenate(data_v),
                              (np.concatenate(data_r), np.concatenate(data_c))), shape=(m, n))


    def jacobian_lm(self, x: np.ndarray, r0: np.ndarray | None, h: float = 1e-6,
                    central: bool = False) -> sp.csr_matrix:
        """The Jacobian with the intrinsics and every board pose analytically
        (:meth:`_project`: projection with distortion and K, chained through the board's
        rotation by SO(3)'s left Jacobian), the kinematic parameters (hand-eye, unit,
        mounts) by differences on their own images as in :meth:`jacobian`: forward from
        ``r0`` (the residuals at ``x``; the iterations) or ``central`` (the
        identifiability test, the covariance). The same matrix as ``jacobian(...,
        analytic=False)`` up to the differences' error (tests/head/test_refine_jacobian.py)."""
        n_img = len(self.img_eye)
        everything = np.arange(n_img)
        ch = self._chain(x, everything)
        _, d = self._project(x, everything, ch, derivatives=True)
        mask = self.mask
        rows_of = self._rows_of_images()
        n = len(self.names)
        data_r, data_c, data_v = [], [], []
        # analytic blocks: rows in residual order (image, kept corner, u/v)
        row_img = np.repeat(np.arange(n_img), mask.sum(axis=1) * 2)
        intr = d["intrinsics"][mask].reshape(-1, d["intrinsics"].shape[-1])   # (2M, ni)
        board = d["board"][mask].reshape(-1, 6)                              # (2M, 6)
        all_rows = np.arange(len(row_img))
        for ei, eye in enumerate(EYES):
            c = self.eye_cols[eye]
            rows = all_rows[self.img_eye[row_img] == ei]
            for k in range(c["n_intr"]):
                j = c["start"] + k
                data_r.append(rows)
                data_c.append(np.full(len(rows), j))
                data_v.append(intr[rows, k] * self.scale[j])
        pose_of_row = self.img_pose[row_img]
        for k in range(6):
            cols = self.n_global + 6 * pose_of_row + k
            data_r.append(all_rows)
            data_c.append(cols)
            data_v.append(board[:, k] * self.scale[cols])
        # forward differences: the kinematic globals, each on the images it moves; the
        # columns that move the same images evaluated together (_residuals_batch)
        col_imgs = self.column_images()
        intr_cols = {self.eye_cols[eye]["start"] + k for eye in EYES
                     for k in range(self.eye_cols[eye]["n_intr"])}
        kinematic = [j for j in range(self.n_global)
                     if j not in intr_cols and j != self.time_col and len(col_imgs[j])]
        if self.time_col is not None:
            # δ analytically: the stream's angular velocity times d(pixels)/d(angles)
            j = self.time_col
            dpix = np.einsum("nkab,nkb->nka", d["point"],
                             self.time_derivative(x, ch, everything))
            data_r.append(all_rows)
            data_c.append(np.full(len(all_rows), j))
            data_v.append(dpix[mask].ravel() * self.scale[j])
        by_images: dict[bytes, list[int]] = {}
        for j in kinematic:
            by_images.setdefault(col_imgs[j].tobytes(), []).append(j)
        columns = {}                              # j -> (the rows it moves, its values)
        for cols in by_images.values():
            imgs = col_imgs[cols[0]]
            rows = np.concatenate([rows_of[i] for i in imgs])
            xs = []
            for j in cols:
                dx = np.zeros(n)
                dx[j] = h
                xs += [x + dx, x - dx] if central else [x + dx]
            res = self._residuals_batch(xs, imgs)
            for k, j in enumerate(cols):
                columns[j] = (rows, (res[2 * k] - res[2 * k + 1]) / (2 * h) if central
                              else (res[k] - r0[rows]) / h)
        for j in kinematic:                       # in column order, as before
            rows, values = columns[j]
            data_r.append(rows)
            data_c.append(np.full(len(rows), j))
            data_v.append(values)
        m = int(mask.sum()) * 2
        return sp.csr_matrix((np.concatenate(data_v),
                              (np.concatenate(data_r), np.concatenate(data_c))), shape=(m, n))
