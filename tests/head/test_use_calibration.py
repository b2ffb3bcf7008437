"""Using a calibration (rasc.head.use, rasc.load_calibration, the model's angle rule).

Truth chosen, data generated, truth recovered: a HeadCalibration with known parameters,
points projected at known angles, triangulated back; angles chosen, the point on their
optical axis generated, look-at recovers the angles.
"""

import copy
import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rasc
from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.transforms import invert_transform, make_transform
from rasc.head import use
from rasc.head.model import MAX_ABS_ANGLE_RAD, EyeCalibration, HeadCalibration

from json_strategies import json_documents
from nominal_rig import HEAD_IMAGE_SIZE as SIZE
from nominal_rig import R_CAM_FROM_GAZE_NOMINAL, plausible_head


def make_head(seed=0):
    return plausible_head(seed)[0]


def calibration_document(head, pan_deg=(-8.0, 8.0), tilt_deg=(-8.0, 8.0)):
    """A minimal ``rasc-calibration/1`` document as rasc calibrate writes it (its head, length
    unit and the pose views' angles; the rest of its report is not read)."""
    views = [{"pan_deg": p, "tilt_deg": t, "file": "x.png", "rms": 0.02}
             for p in pan_deg for t in tilt_deg]
    return {"format": "rasc-calibration/1", "length_unit": "m", "head": head.to_dict(),
            "eyes": {e: {"pose_views": views, "quality": 1e-4} for e in ("left", "right")},
            "base_to_ptu": {}, "options": {}}


# --------------------------------------------------------------------------------------
# the angle rule of the Python API


@pytest.mark.parametrize("bad", [8.0, 400.0, -6.3, 2 * np.pi + 1e-12, 360.0])
def test_angles_that_cannot_be_radians_are_refused(bad):
    eye = make_head().left
    with pytest.raises(InputError, match=r"beyond ±2π.*np\.radians") as exc:
        eye.T_cam_from_base(bad, 0.0)
    assert "\n" not in str(exc.value)
    with pytest.raises(InputError, match="tilt"):
        eye.T_cam_from_base(0.0, np.array([0.1, bad]))
    with pytest.raises(InputError, match="pan"):
        eye.project(np.array([[0.0, 2.0, 0.0]]), bad, 0.0)
    with pytest.raises(InputError, match="pan"):
        make_head().triangulate([[600, 400]], [[600, 400]], bad, 0.0, 0.0, 0.0)


def test_angles_up_to_one_turn_are_accepted():
    """The rule is |angle| ≤ 2π exactly: a full turn is the same pose as none."""
    eye = make_head().left
    for a in (MAX_ABS_ANGLE_RAD, -MAX_ABS_ANGLE_RAD):
        np.testing.assert_allclose(eye.T_cam_from_base(a, a), eye.T_cam_from_base(0, 0),
                                   atol=1e-14)  # cos/sin of 2π: 2.4e-16 off


@pytest.mark.parametrize("bad", ["8", True, [0.1, float("nan")], [np.inf]])
def test_non_numeric_and_non_finite_angles_are_refused(bad):
    with pytest.raises(InputError):
        make_head().left.T_cam_from_base(bad, 0.0)


# --------------------------------------------------------------------------------------
# project and triangulate


def _scene(rng, n):
    p = np.c_[rng.uniform(-0.3, 0.3, n), rng.uniform(1.5, 2.0, n), rng.uniform(-0.3, 0.3, n)]
    angles = rng.uniform(np.radians(-5), np.radians(5), (4, n))
    return p, angles


def test_project_then_triangulate_recovers_the_points():
    """Noise-free pixels at known per-point angles triangulate back to 1e-9 m: the only
    errors are rounding (1e-16 relative) and the undistortion's convergence target
    (1e-12 normalised, i.e. 2e-12 m at 2 m)."""
    head = make_head()
    rng = np.random.default_rng(1)
    p, (pl, tl, pr, tr) = _scene(rng, 200)
    left = use.project_eye(head.left, p, pl, tl)
    right = use.project_eye(head.right, p, pr, tr)
    assert left.in_image.all() and right.in_image.all()
    tri = use.triangulate(head, left.uv, right.uv, pl, tl, pr, tr)
    np.testing.assert_allclose(tri.p_base, p, rtol=0, atol=1e-9)
    for eye in ("left", "right"):
        assert tri.in_front[eye].all()
        assert np.max(tri.residual_px[eye]) < 1e-6  # reprojection of an exact match


def test_triangulation_residual_sees_a_mismatch():
    """Moving one right-eye pixel by 10 px vertically (off the epipolar line) shows in the
    residual; the other points stay exact."""
    head = make_head()
    p, (pl, tl, pr, tr) = _scene(np.random.default_rng(2), 5)
    uv_l = head.left.project(p, pl, tl)
    uv_r = head.right.project(p, pr, tr)
    uv_r[3, 1] += 10.0
    tri = use.triangulate(head, uv_l, uv_r, pl, tl, pr, tr)
    res = np.maximum(tri.residual_px["left"], tri.residual_px["right"])
    assert res[3] > 1.0  # 10 px off the epipolar line split between two eyes: ≈ 5 px
    assert np.all(np.delete(res, 3) < 1e-6)


def test_parallel_rays_are_degenerate_with_their_index():
    head = make_head()
    p = np.array([[0.0, 1.8, 0.0], [0.0, 1e9, 0.0]])  # the second: rays parallel to 1e-10
    uv_l = head.left.project(p, 0.0, 0.0)
    uv_r = head.right.project(p, 0.0, 0.0)
    with pytest.raises(DegenerateDataError, match="point 1") as exc:
        use.triangulate(head, uv_l, uv_r, 0.0, 0.0, 0.0, 0.0)
    assert exc.value.index == 1


def test_project_flags_behind_outside_and_folded_points():
    """A point behind the camera has no pixel; one beside the image is in front but not in
    the image; one 58° off the axis that the lens (k1 = −0.3) folds back into the image
    (its distorted pixel lies inside) is not in the image either."""
    e = make_head().left
    eye = EyeCalibration(e.K, [-0.3, 0.0, 0.0, 0.0], e.T_cam_from_gaze, e.T_ptu_from_base, SIZE)
    T = eye.T_cam_from_base(0.0, 0.0)
    T_base_from_cam = invert_transform(T)

    def base(p_cam):
        return T_base_from_cam[:3, :3] @ np.asarray(p_cam, float) + T_base_from_cam[:3, 3]

    # r = 1.6 normalised: radial 1 − 0.3 r² = 0.232, so x_d = 0.37 (the fold is at r = 1.05)
    pts = np.array([base([0.1, 0.05, 2.0]), base([0.0, 0.0, -2.0]), base([3.0, 0.0, 2.0]),
                    base([1.6, 0.0, 1.0])])
    proj = use.project_eye(eye, pts, 0.0, 0.0)
    assert proj.in_front.tolist() == [True, False, True, True]
    assert np.all(np.isnan(proj.uv[1]))
    assert proj.in_image.tolist() == [True, False, False, False]
    w, h = SIZE
    u, v = proj.uv[3]
    assert -0.5 <= u <= w - 0.5 and -0.5 <= v <= h - 0.5, "the folded pixel lies inside"
    np.testing.assert_allclose(proj.depth, [2.0, -2.0, 2.0, 1.0], atol=1e-12)


# --------------------------------------------------------------------------------------
# look-at


@pytest.mark.parametrize("eye_name", ["left", "right"])
def test_look_at_recovers_chosen_angles(eye_name):
    """Truth: angles (pan, tilt) within ±40°; the point 0.5–5 m down the optical axis at
    those angles. Look-at returns the same angles (to 1e-9 rad: the fixation is locally
    unique, and the solver's 1e-15 tolerances leave only rounding) and puts the point on
    the principal point to 1e-9 px."""
    head = make_head(3)
    eye = getattr(head, eye_name)
    rng = np.random.default_rng(4)
    for _ in range(20):
        pan, tilt = rng.uniform(np.radians(-40), np.radians(40), 2)
        T_base_from_cam = invert_transform(eye.T_cam_from_base(pan, tilt))
        p = T_base_from_cam[:3, :3] @ [0.0, 0.0, rng.uniform(0.5, 5.0)] + T_base_from_cam[:3, 3]
        if p[1] <= 0:
            continue
        fix = use.look_at(eye, p)
        assert abs(fix.pan - pan) < 1e-9 and abs(fix.tilt - tilt) < 1e-9
        assert fix.residual_px < 1e-9
        uv = eye.project(p[None], fix.pan, fix.tilt)[0]  # distortion vanishes on the axis
        np.testing.assert_allclose(uv, eye.K[:2, 2], rtol=0, atol=1e-9)
        assert fix.depth > 0


class _GeneralEye(EyeCalibration):
    """An eye whose unit is not eq. 3: the tilt axis 30 mm off the pan axis and 1° from
    orthogonal, encoder zero offsets 0.5° / −0.4° and scales 1.01 / 0.99 (the kind of unit
    issue 10 describes). Only ``T_cam_from_base`` changes; look-at must still work,
    because it uses the eye's public methods alone."""

    def T_cam_from_base(self, pan, tilt):
        from scipy.spatial.transform import Rotation

        pan = 1.01 * np.asarray(pan, float) + np.radians(0.5)
        tilt = 0.99 * np.asarray(tilt, float) - np.radians(0.4)
        tilt_axis = np.array([np.sin(np.radians(1.0)), 0.0, np.cos(np.radians(1.0))])
        q = np.array([0.0, 0.03, 0.0])
        R_tilt = Rotation.from_rotvec(tilt * tilt_axis).as_matrix()
        T_tilt = make_transform(R_tilt, q - R_tilt @ q)    # Trans(q) Rot Trans(−q)
        T_pan = make_transform(Rotation.from_rotvec([-pan, 0.0, 0.0]).as_matrix(), np.zeros(3))
        return self.T_cam_from_gaze @ T_tilt @ T_pan @ self.T_ptu_from_base


def test_look_at_works_for_a_general_unit():
    """Truth: angles within ±40° and a point 0.5–5 m down the optical axis of the general
    eye; look-at recovers the angles to 1e-9 rad and fixates to 1e-9 px (eq. 3 is only its
    first guess, 0.5–1° and a 30 mm lever off here)."""
    e = make_head(3).left
    eye = _GeneralEye(e.K, e.dist, e.T_cam_from_gaze, e.T_ptu_from_base, e.image_size)
    rng = np.random.default_rng(11)
    for _ in range(20):
        pan, tilt = rng.uniform(np.radians(-40), np.radians(40), 2)
        T_base_from_cam = invert_transform(eye.T_cam_from_base(pan, tilt))
        p = T_base_from_cam[:3, :3] @ [0.0, 0.0, rng.uniform(0.5, 5.0)] + T_base_from_cam[:3, 3]
        fix = use.look_at(eye, p)
        assert abs(fix.pan - pan) < 1e-9 and abs(fix.tilt - tilt) < 1e-9
        assert fix.residual_px < 1e-9
        np.testing.assert_allclose(eye.project(p[None], fix.pan, fix.tilt)[0], eye.K[:2, 2],
                                   rtol=0, atol=1e-9)


def test_look_at_random_points_ahead():
    """Points 1–10 m ahead, up to 30° off straight ahead: each fixated to 1e-9 px."""
    head = make_head(5)
    rng = np.random.default_rng(6)
    for _ in range(30):
        d = rng.uniform(1.0, 10.0)
        az, el = rng.uniform(np.radians(-30), np.radians(30), 2)
        p = d * np.array([np.sin(el), np.cos(el) * np.cos(az), np.cos(el) * np.sin(az)])
        for eye in (head.left, head.right):
            fix = use.look_at(eye, p)
            assert fix.residual_px < 1e-9
            P = eye.projection_matrix(fix.pan, fix.tilt)
            u, v, w = P @ np.r_[p, 1.0]
            assert w > 0 and math.hypot(u / w - eye.K[0, 2], v / w - eye.K[1, 2]) < 1e-9


def _eye_with_camera_offset(t_cam_from_gaze):
    """An ideal eye whose unit sits 0.1 m ahead of the base origin, camera on the gaze
    axis nominally, translated by ``t_cam_from_gaze``."""
    K = np.array([[1000.0, 0, 640], [0, 1000.0, 480], [0, 0, 1]])
    T_pb = make_transform(np.eye(3), [0.0, -0.1, 0.0])   # base origin 0.1 m behind the unit
    T_cg = make_transform(R_CAM_FROM_GAZE_NOMINAL, t_cam_from_gaze)
    return EyeCalibration(K, [], T_cg, T_pb, SIZE)


def test_look_at_refuses_a_point_behind_the_head():
    eye = make_head().left
    for p in ([0.0, -1.0, 0.0], [0.5, 0.0, 0.2]):
        with pytest.raises(InputError, match="behind the head"):
            use.look_at(eye, p)


def test_look_at_refuses_the_optical_centre():
    """A camera at the unit's centre (zero hand-eye translation) stays there at every
    angle: the centre has no direction."""
    eye = _eye_with_camera_offset([0.0, 0.0, 0.0])
    with pytest.raises(InputError, match="optical centre"):
        use.look_at(eye, [0.0, 0.1, 0.0])  # the unit's centre in the base frame


def test_look_at_refuses_an_unreachable_point():
    """A camera 5 cm ahead of the unit's centre, looking outwards along the radius, sees
    only points farther than 5 cm from the centre on its axis: one 2 cm ahead is
    unreachable; one 1 m ahead is fine."""
    eye = _eye_with_camera_offset([0.0, 0.0, -0.05])  # camera centre at gaze y = +0.05
    T = eye.T_cam_from_base(0.0, 0.0)
    centre = invert_transform(T)[:3, 3]
    np.testing.assert_allclose(centre, [0.0, 0.15, 0.0], atol=1e-15)
    with pytest.raises(InputError, match="unreachable"):
        use.look_at(eye, [0.0, 0.12, 0.0])
    assert use.look_at(eye, [0.0, 1.1, 0.0]).residual_px < 1e-9


def test_look_at_refuses_non_finite_points():
    with pytest.raises(InputError, match="NaN"):
        use.look_at(make_head().left, [0.0, np.nan, 1.0])


# --------------------------------------------------------------------------------------
# load_calibration


def test_load_calibration_reads_both_formats(tmp_path):
    head = make_head()
    doc = calibration_document(head)
    (tmp_path / "cal.json").write_text(json.dumps(doc))
    (tmp_path / "head.json").write_text(json.dumps(head.to_dict()))
    for name in ("cal.json", "head.json"):
        loaded = rasc.load_calibration(tmp_path / name)
        assert isinstance(loaded, HeadCalibration)
        for eye in ("left", "right"):
            a, b = getattr(loaded, eye), getattr(head, eye)
            for f in ("K", "dist", "T_cam_from_gaze", "T_ptu_from_base"):
                np.testing.assert_array_equal(getattr(a, f), getattr(b, f))  # JSON: exact
            assert a.image_size == b.image_size
    cal = use.read_calibration(tmp_path / "cal.json")
    assert cal.length_unit == "m"
    assert cal.joint_range["left"]["pan"] == pytest.approx(np.radians([-8.0, 8.0]), abs=1e-15)
    assert use.read_calibration(tmp_path / "head.json").joint_range is None


@pytest.mark.slow
def test_import_rasc_stays_cheap():
    """``import rasc`` loads neither numpy nor the loader; the attribute brings it."""
    import subprocess
    import sys

    code = ("import sys, rasc; a = sorted(m for m in ('numpy', 'scipy', 'rasc.head.use') "
            "if m in sys.modules); f = rasc.load_calibration; "
            "print(a, f.__module__, 'load_calibration' in dir(rasc))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["[]", "rasc.head.use", "True"]
    with pytest.raises(AttributeError, match="no attribute 'load_calibraton'"):
        rasc.load_calibraton  # noqa: B018


def test_calibration_format_is_the_pipelines():
    from rasc.head.pipeline import FORMAT

    assert use.CALIBRATION_FORMAT == FORMAT


def _set(doc, path, value):
    d = doc
    for k in path[:-1]:
        d = d[k]
    if value is _DELETE:
        del d[path[-1]]
    else:
        d[path[-1]] = value


_DELETE = object()

BAD_DOCUMENTS = [
    (("format",), "rasc-calibration/2", "format: expected"),
    (("format",), _DELETE, "format: expected"),
    (("head",), _DELETE, "head: missing"),
    (("head", "right"), _DELETE, "head.right: missing"),
    (("head", "format"), "rasc-head/9", "head.format"),
    (("head", "left", "K"), [[1000, 0, 640], [0, 1000, 480]], "head.left.K: expected a 3x3"),
    (("head", "left", "K", 0, 0), "1000", r"head.left.K\[0\]\[0\]: expected a number"),
    (("head", "left", "K", 0, 0), None, r"head.left.K\[0\]\[0\]"),
    (("head", "left", "K", 0, 0), True, r"head.left.K\[0\]\[0\]"),
    (("head", "left", "K", 0, 0), -1000.0, "focal lengths must be positive"),
    (("head", "right", "T_cam_from_gaze", 0, 0), 1.5, "head.right.T_cam_from_gaze: rotation"),
    (("head", "right", "T_ptu_from_base", 3), [0, 0, 1, 1], "last row"),
    (("head", "left", "dist"), [0.1, 0.2, 0.3], "head.left.dist: expected 0, 4, 5 or 8"),
    (("head", "left", "dist"), [[0.1, 0.2, 0.0, 0.0]], "head.left.dist: expected a flat list"),
    (("head", "left", "T_ptu_from_base"), [[1, 0, 0, 0]] * 4, "head.left.T_ptu_from_base"),
    (("head", "left"), [], "head.left: expected an object"),
    (("head",), "rasc-head/1", "head: expected an object"),
    (("head", "left", "image_size"), [1280], "head.left.image_size"),
    # refused by the project-wide reader (rasc.io.read_json_document), by JSON pointer
    (("head", "left", "K", 1, 2), float("nan"), "/head/left/K/1/2: NaN is not a finite"),
    (("head", "left", "T_cam_from_gaze", 0, 3), float("inf"),
     "/head/left/T_cam_from_gaze/0/3: Infinity is not a finite number"),
    (("head", "left", "extra"), 1, "head.left.extra: unknown field"),
    (("length_unit",), 3, "length_unit: expected text"),
    (("eyes", "left", "pose_views", 0, "pan_deg"), "8", "pan_deg: expected a number"),
    (("eyes", "left", "pose_views"), [], "pose_views: expected a non-empty list"),
]


@pytest.mark.parametrize("path,value,message", BAD_DOCUMENTS)
def test_bad_calibration_is_one_line_naming_file_and_field(tmp_path, path, value, message):
    doc = calibration_document(make_head())
    _set(doc, list(path), value)
    f = tmp_path / "cal.json"
    f.write_text(json.dumps(doc))   # json.dumps writes NaN and Infinity tokens
    with pytest.raises(InputError, match=message) as exc:
        rasc.load_calibration(f)
    assert str(exc.value).startswith(f"{f}: ") and "\n" not in str(exc.value)


@pytest.mark.parametrize("text,message", [
    ("{", "malformed JSON at line 1"),
    ('{"format": "rasc-head/1", "format": "rasc-head/1"}', "duplicate key"),
    ("[1, 2]", "expected a JSON object"),
    ("", "malformed JSON"),
    ("[" * 100000, "malformed JSON|nested deeper than"),
])
def test_bad_calibration_text(tmp_path, text, message):
    f = tmp_path / "cal.json"
    f.write_text(text)
    with pytest.raises(InputError, match=message):
        rasc.load_calibration(f)


def test_devices_huge_files_and_huge_integers(tmp_path, monkeypatch):
    with pytest.raises(InputError, match="not a regular file"):
        rasc.load_calibration("/dev/zero")   # would never end if read
    f = tmp_path / "cal.json"
    f.write_text(json.dumps(calibration_document(make_head())))
    monkeypatch.setattr("rasc.io.MAX_DOCUMENT_BYTES", 1000)
    with pytest.raises(InputError, match="more than the 1000 bytes a calibration file may"):
        rasc.load_calibration(f)
    monkeypatch.undo()
    f.write_text('{"format": "rasc-head/1", "left": ' + "9" * 5000 + "}")
    with pytest.raises(InputError, match="cal.json: ") as exc:
        rasc.load_calibration(f)
    assert "\n" not in str(exc.value)


def test_missing_file_folder_and_binary(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        rasc.load_calibration(tmp_path / "nope.json")
    with pytest.raises(InputError, match="is a folder"):
        rasc.load_calibration(tmp_path)
    (tmp_path / "b.json").write_bytes(b"\xff\xfe\x00")
    with pytest.raises(InputError, match="not UTF-8"):
        rasc.load_calibration(tmp_path / "b.json")


# hypothesis: random JSON values and mutations of a valid document never give a traceback

_JSON = json_documents(
    st.none() | st.booleans() | st.integers(-10**30, 10**30)
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=8), max_size=5)


def _paths(obj, prefix=()):
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, prefix + (i,))


_VALID = calibration_document(make_head())
_ALL_PATHS = [p for p in _paths(_VALID) if p]


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(path=st.sampled_from(_ALL_PATHS), value=_JSON | st.just(_DELETE))
def test_mutated_documents_never_traceback(path, value):
    doc = copy.deepcopy(_VALID)
    _set(doc, list(path), value)
    try:
        use.calibration_from_document(json.loads(json.dumps(doc)), "cal.json")
    except InputError as exc:
        assert str(exc).startswith("cal.json: ") and "\n" not in str(exc)


@pytest.mark.slow  # 200 examples: ~2.5 s
@settings(max_examples=200, deadline=None)
@given(doc=_JSON)
def test_random_documents_never_traceback(doc):
    with pytest.raises(InputError):
        use.calibration_from_document(doc, "cal.json")
