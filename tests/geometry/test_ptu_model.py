"""The general pan-tilt unit (rasc.geometry.kinematics.PanTiltUnit, docs/METHOD.md §10).

Every check builds the expected motion independently (scipy Rotation about an axis through
a point) or compares camera poses T_cam_from_base, the only thing images can see.
Tolerances: products of a few 4×4 transforms with entries ≤ 1 and translations ≤ 0.1 m
agree to ~1e-16 per operation; 1e-12 leaves a factor ~1e3 for accumulation and still
catches any modelling error (the smallest effect tested, 1e-4 rad, moves poses by ≥ 1e-6).
"""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from rasc.errors import InputError
from rasc.geometry.kinematics import IDEAL, PanTiltUnit, T_gaze_from_ptu, canonical_gauge
from rasc.geometry.transforms import invert_transform, make_transform

ATOL = 1e-12

rng = np.random.default_rng(20261123)
PAN = rng.uniform(-1.0, 1.0, 50)
TILT = rng.uniform(-0.8, 0.5, 50)


def _screw(axis, point, angle):
    """Rotation by ``angle`` about the line through ``point`` along ``axis``, 4×4."""
    R = Rotation.from_rotvec(np.asarray(axis) / np.linalg.norm(axis) * angle).as_matrix()
    return make_transform(R, np.asarray(point) - R @ np.asarray(point))


def _reference(unit, pan, tilt):
    phi = unit.pan_scale * pan + unit.pan_offset
    tau = unit.tilt_scale * tilt + unit.tilt_offset
    return _screw(unit.tilt_axis, unit.tilt_point, tau) @ _screw(unit.pan_axis, [0, 0, 0], -phi)


def _random_rigid(seed, scale=0.1):
    r = np.random.default_rng(seed)
    return make_transform(Rotation.random(random_state=r.integers(1 << 31)).as_matrix(),
                          r.normal(0.0, scale, 3))


IMPERFECT = PanTiltUnit(
    pan_axis=(0.999, 0.03, -0.02), tilt_axis=(0.0174524, 0.01, 0.9997),
    tilt_point=(0.004, 0.03, -0.012), pan_offset=np.radians(0.5),
    tilt_offset=np.radians(-0.5), pan_scale=1.002, tilt_scale=0.997)


def test_ideal_unit_is_eq3():
    T = IDEAL.T_gaze_from_ptu(PAN, TILT)
    assert T.shape == (50, 4, 4)
    np.testing.assert_allclose(T, T_gaze_from_ptu(PAN, TILT), rtol=0, atol=1e-15)
    assert IDEAL.axis_angle_deg == 90.0
    assert IDEAL.axis_distance == 0.0
    assert IDEAL.is_ideal and not IMPERFECT.is_ideal


def test_scalar_and_broadcast_shapes():
    assert IDEAL.T_gaze_from_ptu(0.1, 0.2).shape == (4, 4)
    assert IMPERFECT.T_gaze_from_ptu(PAN[:5, None], TILT[None, :3]).shape == (5, 3, 4, 4)
    np.testing.assert_array_equal(IMPERFECT.T_gaze_from_ptu(0.0, 0.0)[3], [0, 0, 0, 1])


@pytest.mark.parametrize("field, value", [
    ("pan_axis", (0.99, 0.1, 0.05)),
    ("tilt_axis", (0.03, -0.02, 1.0)),
    ("tilt_point", (0.01, 0.03, -0.02)),
    ("pan_offset", 0.01),
    ("tilt_offset", -0.02),
    ("pan_scale", 1.05),
    ("tilt_scale", 0.95),
])
def test_each_parameter_against_an_independent_construction(field, value):
    unit = PanTiltUnit(**{field: value})
    T = unit.T_gaze_from_ptu(PAN, TILT)
    expected = np.stack([_reference(unit, p, t) for p, t in zip(PAN, TILT, strict=True)])
    np.testing.assert_allclose(T, expected, rtol=0, atol=ATOL)
    # and the parameter has an effect (not silently ignored)
    assert np.abs(T - IDEAL.T_gaze_from_ptu(PAN, TILT)).max() > 1e-4


def test_all_parameters_together_against_independent_construction():
    T = IMPERFECT.T_gaze_from_ptu(PAN, TILT)
    expected = np.stack([_reference(IMPERFECT, p, t) for p, t in zip(PAN, TILT, strict=True)])
    np.testing.assert_allclose(T, expected, rtol=0, atol=ATOL)


def test_angles_and_readings_are_inverse():
    phi, tau = IMPERFECT.angles(PAN, TILT)
    pan, tilt = IMPERFECT.readings(phi, tau)
    np.testing.assert_allclose(pan, PAN, atol=1e-15)
    np.testing.assert_allclose(tilt, TILT, atol=1e-15)


def test_derived_quantities():
    # tilt axis tilted by 1° towards the pan axis: 89° between them
    a = np.radians(1.0)
    unit = PanTiltUnit(tilt_axis=(np.sin(a), 0.0, np.cos(a)), tilt_point=(0.02, 0.03, 0.5))
    assert unit.axis_angle_deg == pytest.approx(89.0, abs=1e-12)
    # the pan axis is x through the origin; the common normal is along y: distance 0.03
    assert unit.axis_distance == pytest.approx(0.03, abs=1e-15)
    foot_pan, foot_tilt = unit.common_normal
    assert np.linalg.norm(foot_tilt - foot_pan) == pytest.approx(0.03, abs=1e-14)
    # both feet on their axes, the normal perpendicular to both
    np.testing.assert_allclose(np.cross(foot_pan, unit.pan_axis), 0, atol=1e-15)
    np.testing.assert_allclose(np.cross(foot_tilt - np.array(unit.tilt_point), unit.tilt_axis),
                               0, atol=1e-15)
    n = foot_tilt - foot_pan
    assert abs(n @ unit.pan_axis) < 1e-15 and abs(n @ np.array(unit.tilt_axis)) < 1e-15


def test_axes_are_normalised_and_bad_parameters_refused():
    unit = PanTiltUnit(pan_axis=(2.0, 0.0, 0.0))
    assert unit.pan_axis == (1.0, 0.0, 0.0)
    with pytest.raises(InputError, match="tilt_axis.*zero"):
        PanTiltUnit(tilt_axis=(0, 0, 0))
    with pytest.raises(InputError, match="parallel"):
        PanTiltUnit(tilt_axis=(1, 0, 0))
    with pytest.raises(InputError, match="pan_scale: must be positive"):
        PanTiltUnit(pan_scale=0.0)
    with pytest.raises(InputError, match="tilt_offset: must be finite"):
        PanTiltUnit(tilt_offset=float("nan"))
    with pytest.raises(InputError, match="tilt_point: expected 3 numbers"):
        PanTiltUnit(tilt_point=(0.0, 1.0))


def test_dict_round_trip_and_errors():
    d = IMPERFECT.to_dict()
    assert PanTiltUnit.from_dict(json.loads(json.dumps(d))) == IMPERFECT
    assert PanTiltUnit.from_dict({}) == IDEAL
    with pytest.raises(InputError, match=r"^gt.json: left.unit.tilt_offest: unknown unit "):
        PanTiltUnit.from_dict({"tilt_offest": 0.1}, where="gt.json: left.unit")
    with pytest.raises(InputError, match=r"^unit.pan_scale: expected a number"):
        PanTiltUnit.from_dict({"pan_scale": "1"})
    with pytest.raises(InputError, match=r"^unit.pan_scale: expected a number"):
        PanTiltUnit.from_dict({"pan_scale": True})
    with pytest.raises(InputError, match=r"^unit: pan_axis .* parallel"):
        PanTiltUnit.from_dict({"pan_axis": [0, 0, 1]})


# ---- what the data can and cannot see (METHOD §10) -------------------------------------

T_CG = _random_rigid(1, 0.05)
T_PB = _random_rigid(2, 0.2)


def _cam_from_base(unit, T_cg, T_pb, pan=PAN, tilt=TILT):
    return T_cg @ unit.T_gaze_from_ptu(pan, tilt) @ T_pb


def test_shift_of_q_along_tilt_axis_changes_nothing():
    z = np.array(IMPERFECT.tilt_axis)
    moved = PanTiltUnit(**{**IMPERFECT.__dict__,
                           "tilt_point": tuple(np.array(IMPERFECT.tilt_point) + 0.07 * z)})
    np.testing.assert_allclose(moved.T_gaze_from_ptu(PAN, TILT),
                               IMPERFECT.T_gaze_from_ptu(PAN, TILT), rtol=0, atol=ATOL)


def test_shift_of_q_along_pan_axis_is_absorbed_by_hand_eye_and_mount():
    p = np.array(IMPERFECT.pan_axis)
    a = 0.04
    moved = PanTiltUnit(**{**IMPERFECT.__dict__,
                           "tilt_point": tuple(np.array(IMPERFECT.tilt_point) + a * p)})
    shift = make_transform(np.eye(3), a * p)
    # T_gp' = Trans(a p) T_gp Trans(−a p)  ⇒  T_cg' = T_cg Trans(−a p), T_pb' = Trans(a p) T_pb
    np.testing.assert_allclose(
        _cam_from_base(moved, T_CG @ invert_transform(shift), shift @ T_PB),
        _cam_from_base(IMPERFECT, T_CG, T_PB), rtol=0, atol=ATOL)
    # without the absorption the poses differ by about a·sin(tilt): visible
    assert np.abs(_cam_from_base(moved, T_CG, T_PB)
                  - _cam_from_base(IMPERFECT, T_CG, T_PB)).max() > 1e-3


def test_pan_offset_absorbed_by_mount_tilt_offset_by_hand_eye():
    o_p, o_t = 0.013, -0.021
    offset = PanTiltUnit(**{**IMPERFECT.__dict__, "pan_offset": o_p, "tilt_offset": o_t})
    zero = PanTiltUnit(**{**IMPERFECT.__dict__, "pan_offset": 0.0, "tilt_offset": 0.0})
    T_pb = _screw(zero.pan_axis, [0, 0, 0], -o_p) @ T_PB
    T_cg = T_CG @ _screw(zero.tilt_axis, zero.tilt_point, o_t)
    np.testing.assert_allclose(_cam_from_base(zero, T_cg, T_pb),
                               _cam_from_base(offset, T_CG, T_PB), rtol=0, atol=ATOL)


def test_scales_and_axis_angle_and_distance_are_not_absorbed():
    """A change of scale, axis angle or axis distance cannot be matched by any hand-eye and
    mount: fit the best T_cg, T_pb (in the canonical gauge, least squares) and see a residual."""
    from scipy.optimize import least_squares

    from rasc.geometry.transforms import rotvec_from_matrix, transform_from_rotvec_translation

    truth = _cam_from_base(IMPERFECT, T_CG, T_PB)
    variants = {
        # control: absorbable (pan offset goes into the mount), so the fit must reach ~0
        "control": {"pan_offset": IMPERFECT.pan_offset + 0.02},
        "pan_scale": {"pan_scale": IMPERFECT.pan_scale * 1.01},
        "tilt_axis": {"tilt_axis": tuple(Rotation.from_rotvec([0, np.radians(1), 0]).apply(
            IMPERFECT.tilt_axis))},
        "distance": {"tilt_point": tuple(np.array(IMPERFECT.tilt_point)
                                         + 0.01 * np.cross(IMPERFECT.pan_axis,
                                                           IMPERFECT.tilt_axis))},
    }
    for name, change in variants.items():
        other = PanTiltUnit(**{**IMPERFECT.__dict__, **change})

        def residual(x, other=other):
            T_cg = transform_from_rotvec_translation(x[:3], x[3:6])
            T_pb = transform_from_rotvec_translation(x[6:9], x[9:12])
            return (_cam_from_base(other, T_cg, T_pb) - truth)[:, :3, :].ravel()

        x0 = np.concatenate([rotvec_from_matrix(T_CG[:3, :3]), T_CG[:3, 3],
                             rotvec_from_matrix(T_PB[:3, :3]), T_PB[:3, 3]])
        fit = least_squares(residual, x0, xtol=1e-14, ftol=1e-14, gtol=1e-14)
        worst = np.abs(residual(fit.x)).max()
        if name == "control":
            assert worst < 1e-9   # the fit works
        else:
            # each change moves some camera by > 1e-4 (metres or matrix elements)
            assert worst > 1e-4, name


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_canonical_gauge_keeps_every_camera_pose(seed):
    r = np.random.default_rng(seed)
    pan_axis = np.array([1.0, 0, 0]) + r.normal(0, 0.05, 3)
    tilt_axis = np.array([0.0, 0, 1]) + r.normal(0, 0.05, 3)
    unit = PanTiltUnit(pan_axis=tuple(pan_axis), tilt_axis=tuple(tilt_axis),
                       tilt_point=tuple(r.normal(0, 0.03, 3)),
                       pan_offset=r.normal(0, 0.01), tilt_offset=r.normal(0, 0.01),
                       pan_scale=1 + r.normal(0, 0.01), tilt_scale=1 + r.normal(0, 0.01))
    T_cg, T_pb = _random_rigid(seed + 1, 0.05), _random_rigid(seed + 2, 0.2)
    canon, T_cg_c, T_pb_c = canonical_gauge(unit, T_cg, T_pb)
    np.testing.assert_allclose(_cam_from_base(canon, T_cg_c, T_pb_c),
                               _cam_from_base(unit, T_cg, T_pb), rtol=0, atol=ATOL)
    # its form: pan axis x, tilt axis in the x–z plane, q on the common normal, no offsets
    assert canon.pan_axis == (1.0, 0.0, 0.0)
    assert canon.tilt_axis[1] == 0.0 and canon.tilt_axis[2] > 0
    assert canon.tilt_point[0] == 0.0 and canon.tilt_point[2] == 0.0
    assert canon.pan_offset == 0.0 and canon.tilt_offset == 0.0
    assert (canon.pan_scale, canon.tilt_scale) == (unit.pan_scale, unit.tilt_scale)
    # the observables are unchanged
    assert canon.axis_angle_deg == pytest.approx(unit.axis_angle_deg, abs=1e-9)
    assert canon.axis_distance == pytest.approx(unit.axis_distance, abs=1e-13)
    # and the gauge is idempotent
    again, T_cg_2, T_pb_2 = canonical_gauge(canon, T_cg_c, T_pb_c)
    assert np.allclose(again.tilt_axis, canon.tilt_axis, atol=1e-15)
    np.testing.assert_allclose(T_cg_2, T_cg_c, atol=1e-15)
    np.testing.assert_allclose(T_pb_2, T_pb_c, atol=1e-15)


def test_canonical_gauge_of_the_ideal_unit_is_itself():
    canon, T_cg, T_pb = canonical_gauge(IDEAL, T_CG, T_PB)
    assert canon == IDEAL
    np.testing.assert_array_equal(T_cg, T_CG)
    np.testing.assert_array_equal(T_pb, T_PB)


def test_canonical_parameters_round_trip():
    np.testing.assert_allclose(PanTiltUnit.canonical().T_gaze_from_ptu(PAN, TILT),
                               T_gaze_from_ptu(PAN, TILT), rtol=0, atol=1e-15)
    canon, _, _ = canonical_gauge(IMPERFECT, T_CG, T_PB)
    alpha, d, s_pan, s_tilt = canon.canonical_parameters
    assert np.degrees(alpha) == pytest.approx(IMPERFECT.axis_angle_deg, abs=1e-12)
    assert abs(d) == pytest.approx(IMPERFECT.axis_distance, abs=1e-15)
    again = PanTiltUnit.canonical(alpha, d, s_pan, s_tilt)
    np.testing.assert_allclose(again.T_gaze_from_ptu(PAN, TILT), canon.T_gaze_from_ptu(PAN, TILT),
                               rtol=0, atol=1e-15)
    with pytest.raises(InputError, match="not in the canonical gauge"):
        _ = IMPERFECT.canonical_parameters
