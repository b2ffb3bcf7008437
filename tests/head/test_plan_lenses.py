"""rasc plan with a lens other than the pinhole: the candidates' corners go through the
eye's lens model (rasc.plan.candidate_views), and a head whose lens the prediction does
not model is refused in one line rather than planned as a pinhole.

The fisheye head is the default head's geometry with tests/lens_rig.py's fisheye (f 560
px, ~165° across the diagonal), carried as the planner's head (``SyntheticHead`` with a
``lens`` per eye).
"""

from __future__ import annotations

import numpy as np
import pytest
from lens_rig import EYES, FISHEYE_DIST, FISHEYE_K

from rasc.errors import InputError
from rasc.geometry import lens
from rasc.plan import PlanSetup, candidate_grid, candidate_views, check_planned_lens
from rasc.sim.synthetic import default_head
from rasc.vision.board import DEFAULT_BOARD


def fisheye_planner_head(dist=FISHEYE_DIST):
    """The planner's head (a SyntheticHead) with fisheye eyes."""
    head = default_head()
    head.K = {eye: FISHEYE_K[eye].copy() for eye in EYES}
    head.dist = {eye: np.asarray(dist[eye], float) for eye in EYES}
    head.lens = {eye: "fisheye" for eye in EYES}
    return head


def _setup(head, **kw):
    return PlanSetup(head=head, board=DEFAULT_BOARD, step_deg=6.0, **kw)


def test_a_fisheye_plans_corners_inside_the_image_as_the_lens_core_projects_them():
    """Every corner the planner counts as seen is where rasc.geometry.lens projects it
    through the fisheye, at least the render margin inside the image; every corner the
    lens puts there is counted; and the fisheye sees the target at candidates a pinhole
    reading of the same numbers would not."""
    from rasc.sim.render import MARGIN_PX

    head = fisheye_planner_head()
    setup = _setup(head, distance=0.6)
    candidates = candidate_grid(setup)
    uv, T_cw, ok = candidate_views(setup, candidates)
    P = DEFAULT_BOARD.object_points()
    w, h = setup.image_size
    for eye in EYES:
        p = np.einsum("mij,nj->mni", T_cw[eye][:, :3, :3], P) + T_cw[eye][:, None, :3, 3]
        front = p[..., 2] > 0.05
        want = np.full(p.shape[:2] + (2,), np.nan)
        want[front] = lens.project_points(p[front], head.K[eye], head.dist[eye],
                                          model="fisheye")
        with np.errstate(invalid="ignore"):
            inside = front & np.all(want >= MARGIN_PX, axis=-1) \
                & (want[..., 0] <= w - 1 - MARGIN_PX) & (want[..., 1] <= h - 1 - MARGIN_PX)
        seen = np.isfinite(uv[eye][..., 0])
        assert np.array_equal(seen, inside), eye
        assert np.abs(uv[eye][seen] - want[seen]).max() == 0.0
    # the planner's candidates: usable ones show the whole board to both eyes
    n = DEFAULT_BOARD.n_corners
    assert ok.sum() >= 3
    assert all(np.isfinite(uv[e][ok][..., 0]).sum(axis=1).min() == n for e in EYES)
    # a 120°+ lens sees the board at 0.6 m from far more positions than a pinhole reading
    # of the same K and numbers (what the planner did before it knew the lens)
    head.lens = None
    _, _, ok_pinhole = candidate_views(_setup(head, distance=0.6), candidates)
    print(f"fisheye: {ok.sum()} of {len(ok)} candidates usable; read as a pinhole "
          f"{ok_pinhole.sum()}")
    assert ok.sum() > ok_pinhole.sum()


def test_a_corner_beyond_the_lens_models_fold_is_not_seen():
    """A fisheye whose θ_d(θ) turns back before 90° folds far-off corners into the image:
    those are not counted (their pixel does not undistort back to their ray)."""
    k1 = -0.4                       # θ_d = θ (1 + k1 θ²) peaks at θ = 1/√(−3 k1): 52.3°
    fold = np.degrees(1.0 / np.sqrt(-3.0 * k1))
    k = {eye: np.array([k1, 0.0, 0.0, 0.0]) for eye in EYES}
    head = fisheye_planner_head(k)
    setup = _setup(head, distance=0.4)
    candidates = candidate_grid(setup)
    uv, T_cw, _ = candidate_views(setup, candidates, margin=0.0)
    P = DEFAULT_BOARD.object_points()
    for eye in EYES:
        p = np.einsum("mij,nj->mni", T_cw[eye][:, :3, :3], P) + T_cw[eye][:, None, :3, 3]
        seen = np.isfinite(uv[eye][..., 0])
        theta = np.degrees(np.arctan2(np.linalg.norm(p[..., :2], axis=-1), p[..., 2]))
        assert seen.any() and theta[seen].max() < fold, eye
        # and there are corners past the fold whose pixel lands inside the image
        front = p[..., 2] > 0.05
        past = front & (theta > fold)
        uv_past = lens.project_points(p[past], head.K[eye], head.dist[eye], model="fisheye")
        w, h = setup.image_size
        assert np.any(np.all((uv_past >= 0) & (uv_past <= [w - 1, h - 1]), axis=1)), eye


def test_a_lens_the_prediction_does_not_model_is_refused():
    head = fisheye_planner_head()
    with pytest.raises(InputError, match=r"^plan: the left eye's lens is fisheye: the "
                                         r"planner predicts with the whole-head refinement's "
                                         r"pinhole model"):
        check_planned_lens(head)
    from rasc.plan import Information

    with pytest.raises(InputError, match=r"lens is fisheye"):
        Information(_setup(head), candidate_grid(_setup(head)))
    rational = default_head(dist=(-0.2, 0.05, 0.0, 0.0, 0.01, 0.3, 0.0, 0.0))
    with pytest.raises(InputError, match=r"rational terms \(k4..k6 = 0.3, 0, 0\)"):
        check_planned_lens(rational)
    check_planned_lens(default_head())                   # the pinhole: planned


@pytest.mark.parametrize("dist", [[-0.2, 0.05, 0.001, -0.002], [], [-0.2, 0.05, 0.001,
                                                                    -0.002, 0.01]])
def test_a_calibrations_coefficients_reach_the_planner_as_they_are(tmp_path, dist):
    """head_from_calibration pads a calibration's coefficients with zeros (it repeated
    them: a 4-coefficient lens was planned with k3 = k1)."""
    import json
    from dataclasses import replace

    from lens_rig import lens_head

    from rasc.plan import head_from_calibration

    head = lens_head("pinhole")
    head = replace(head, left=replace(head.left, dist=np.array(dist)))
    path = tmp_path / "head.json"
    path.write_text(json.dumps(head.to_dict()))
    planned = head_from_calibration(path)
    want = np.r_[dist, np.zeros(5 - len(dist))]
    assert np.array_equal(planned.dist["left"], want)
    assert np.array_equal(planned.dist["right"], head.right.dist)
