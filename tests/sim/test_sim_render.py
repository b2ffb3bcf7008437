"""Rendering: rendered chessboard corners against ground-truth projection, the board's
colour rule, geometry out of view, image degradation and the OpenGL backend probe.

Corner detection (OpenCV, allowed in tests) is the independent measurement: the truth is
the board pose and camera model read from the MuJoCo model, projected with K.
"""

import os
import subprocess
import sys
import time

import cv2
import numpy as np
import pytest
from scipy.stats import norm

from rasc.errors import InputError
from rasc.geometry.kinematics import PAPER_POSES_DEG
from rasc.geometry.transforms import make_transform, transform_points
from rasc.sim.scene import (
    Board,
    StereoHeadSim,
    T_base_from_world_facing,
    add_pixel_noise,
    blur,
    degrade,
    import_mujoco,
)

EYES = ("left", "right")
#: Brief: rendered corners within 0.1 px of projection. Measured here 0.02 px RMS
#: (findChessboardCornersSB + CALIB_CB_ACCURACY); a half-pixel convention error or a
#: wrong principal-point sign gives ≥ 0.5 px, so 0.1 px separates them.
CORNER_RMS_PX = 0.1


@pytest.fixture(scope="module")
def sim():
    with StereoHeadSim() as s:
        yield s


def _detect(image, board):
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    ok, corners = cv2.findChessboardCornersSB(grey, board.inner_corners,
                                              flags=cv2.CALIB_CB_ACCURACY)
    assert ok, "chessboard not found"
    return corners.reshape(-1, 2).astype(float)


def _corner_errors(sim, eye, crop=False):
    """Detected minus projected corners (N, 2); OpenCV's order fixed to the contract's.

    ``crop``: detect in the image's rectangle around the projected board plus three
    squares of margin (the quiet zone and more), then shift the corners back by the
    rectangle's integer corner. The detector sees the same pixels around the board, only
    less of the empty image: ~2.5x faster at 1280x960 (1.3 s against 0.5 s per image,
    measured); its corners move by at most 0.04 px against the whole image (measured on
    three paper poses), which either way is the detector's own scatter, not the render's.
    """
    board = sim.board
    image = sim.render(eye)
    projected = sim.project_world_points(eye, board.object_points())
    lo = np.zeros(2, dtype=int)
    if crop:
        square = np.linalg.norm(projected[1] - projected[0])
        lo = np.floor(projected.min(axis=0) - 3 * square).astype(int).clip(0)
        hi = np.ceil(projected.max(axis=0) + 3 * square).astype(int)
        image = image[lo[1]:hi[1], lo[0]:hi[0]]
    detected = _detect(image, board) + lo
    if np.linalg.norm(detected[0] - projected[-1]) < np.linalg.norm(detected[0] - projected[0]):
        detected = detected[::-1]  # OpenCV started from the other end
    return detected - projected


def _rms(err):
    return float(np.sqrt(np.mean(np.sum(err**2, axis=1))))


@pytest.mark.slow
def test_corners_match_projection_at_the_nine_paper_poses(sim):
    # Board 1 m ahead of the base, both eyes at each of the paper's nine (pan, tilt).
    sim.set_target(T_base_from_world_facing(sim.board, 1.0))
    errors = []
    for pan, tilt in PAPER_POSES_DEG:
        for eye in EYES:
            sim.set_angles(eye, np.radians(pan), np.radians(tilt))
            err = _corner_errors(sim, eye, crop=True)
            assert _rms(err) < CORNER_RMS_PX, (eye, pan, tilt, _rms(err))
            errors.append(err)
    for eye in EYES:
        sim.set_angles(eye, 0.0, 0.0)
    all_err = np.concatenate(errors)
    print(f"\ncorner RMS at the nine paper poses, both eyes: {_rms(all_err):.4f} px "
          f"(max {np.abs(all_err).max():.4f} px, mean {all_err.mean(axis=0).round(4)})")
    assert _rms(all_err) < CORNER_RMS_PX


def test_corners_match_projection_at_half_resolution():
    # K read for a 640x480 render (scaled with the pixel-centre convention) still projects.
    with StereoHeadSim(image_size=(640, 480)) as s:
        s.set_target(T_base_from_world_facing(s.board, 1.0, (0.0, -0.15)))
        assert s.render("right").shape == (480, 640, 3)
        assert _rms(_corner_errors(s, "right")) < CORNER_RMS_PX


@pytest.mark.slow
def test_dense_one_metre_board():
    # The experiments' 1 m x 1 m plane (870 corners) at 1.8 m: detected where projected.
    board = Board((30, 29), 1.0 / 32)
    with StereoHeadSim(board=board) as s:
        s.set_target(T_base_from_world_facing(board, 1.8, (0.0, -0.15)))
        err = _corner_errors(s, "left")
        assert len(err) == 870 and _rms(err) < CORNER_RMS_PX, _rms(err)


@pytest.mark.slow
@pytest.mark.parametrize(("square", "distance"), [(0.02, 0.4), (0.05, 3.5)])
def test_near_and_far_boards_survive_clipping(square, distance):
    # Clipping planes are visual/map znear, zfar × statistic extent (docs/NOTES.md): a board
    # 0.4 m and 3.5 m away is rendered whole and its corners land where projected.
    board = Board((9, 6), square)
    with StereoHeadSim(board=board) as s:
        m = s.model
        assert m.vis.map.znear * m.stat.extent < 0.1 and m.vis.map.zfar * m.stat.extent > 5
        s.set_target(T_base_from_world_facing(board, distance, (0.048, 0.15)))  # left eye
        assert _rms(_corner_errors(s, "left")) < CORNER_RMS_PX


def _grey_at(image, uv):
    u, v = np.rint(uv).astype(int)
    return float(np.median(image[v - 1:v + 2, u - 1:u + 2]))


@pytest.mark.parametrize("board", [None, Board((30, 29), 1.0 / 32), Board((6, 9), 0.04)],
                         ids=["scene.xml", "dense-30x29", "generated-6x9"])
def test_board_colour_rule(board):
    # Contract: the square bounded by corners (0,0), (1,0), (0,1), (1,1) is black; its
    # edge neighbours white, its diagonal neighbour (outside the corner grid) black; the
    # quiet zone one square beyond the last square white. Turned 30° in its plane so that
    # a mirrored or rotated texture would not pass.
    with StereoHeadSim(board=board) if board else StereoHeadSim() as s:
        board = s.board
        s.set_target(T_base_from_world_facing(board, 1.0 + 50 * board.square_size)
                     @ make_transform(cv2.Rodrigues(np.array([0.0, 0.0, 0.5]))[0], np.zeros(3)))
        image = s.render("left")
        sq = board.square_size
        nx, ny = board.inner_corners
        points = np.array([[0.5, 0.5], [1.5, 0.5], [0.5, 1.5], [-0.5, -0.5],
                           [nx - 0.5, ny - 0.5], [-1.5, 0.5], [0.5, ny + 0.5]]) * sq
        uv = s.project_world_points("left", np.c_[points, np.zeros(len(points))])
        grey = [_grey_at(image, p) for p in uv]
        expected_black = [True, False, False, True, nx % 2 == ny % 2, False, False]
        for g, black in zip(grey, expected_black, strict=True):
            assert (g < 40) if black else (g > 200), (grey, expected_black)


@pytest.mark.slow
def test_head_geometry_stays_out_of_the_cameras_views(sim):
    # Segmentation render with the board moved away: no pixel belongs to the head, at the
    # paper poses and at the tilt limits and ±45° pan.
    mujoco = import_mujoco()
    head_bodies = {sim.model.body("base_link").id}
    for b in range(sim.model.nbody):
        if sim.model.body_rootid[b] == sim.model.body("base_link").id:
            head_bodies.add(b)
    head_geoms = {g for g in range(sim.model.ngeom) if sim.model.geom_bodyid[g] in head_bodies}
    sim.set_target(make_transform(np.eye(3), [0.0, -5.0, 0.0]))  # behind the head
    w, h = sim.image_size
    poses = list(PAPER_POSES_DEG) + [(45, 0), (-45, 0), (0, 30), (0, -45), (45, -45)]
    # an int: numpy compares an array with the pybind11 enum element by element in Python
    # (0.1 s per 320x240 image, measured; 4 s of the test's 4.6 s)
    geom = int(mujoco.mjtObj.mjOBJ_GEOM)
    with mujoco.Renderer(sim.model, height=h // 4, width=w // 4) as renderer:
        renderer.enable_segmentation_rendering()
        for pan, tilt in poses:
            for eye in EYES:
                sim.set_angles(eye, np.radians(pan), np.radians(tilt))
                sim.forward()
                renderer.update_scene(sim.data, camera=f"{eye}_camera")
                seg = renderer.render()
                geoms = set(np.unique(seg[..., 0][seg[..., 1] == geom]))
                assert not geoms & head_geoms, (eye, pan, tilt, geoms & head_geoms)
    for eye in EYES:
        sim.set_angles(eye, 0.0, 0.0)
    sim.set_target(T_base_from_world_facing(sim.board))


def test_render_is_repeatable_and_fast(sim):
    # docs/NOTES.md: ~11 ms a frame at 1280x960 without multisampling (~37 ms with). The
    # bound (0.5 s) only catches gross regressions on a loaded 2-core machine.
    assert sim.model.vis.quality.offsamples == 0
    first = sim.render("left")
    n = 10
    start = time.perf_counter()
    for _ in range(n):
        image = sim.render("left")
    per_frame = (time.perf_counter() - start) / n
    print(f"\nrender time per frame at {sim.image_size}: {1000 * per_frame:.1f} ms")
    assert image.dtype == np.uint8 and image.shape == (960, 1280, 3)
    np.testing.assert_array_equal(image, first)
    assert per_frame < 0.5


# -- degradation ---------------------------------------------------------------------------

def test_pixel_noise_is_seeded_gaussian_and_clipped():
    grey = np.full((400, 400, 3), 128, np.uint8)
    a = add_pixel_noise(grey, 3.0, np.random.default_rng(7))
    b = add_pixel_noise(grey, 3.0, np.random.default_rng(7))
    c = add_pixel_noise(grey, 3.0, np.random.default_rng(8))
    np.testing.assert_array_equal(a, b)
    assert np.any(a != c)
    # rounding to integers adds 1/12 grey level² of variance; 480 000 samples estimate the
    # std to 0.1 %, so 2 % is loose and still catches a wrong sigma or a missing channel.
    d = a.astype(float) - 128
    assert abs(d.std() - np.sqrt(9 + 1 / 12)) < 0.02 * 3 and abs(d.mean()) < 0.02
    extremes = np.zeros((100, 100), np.uint8)
    extremes[:, 50:] = 255
    noisy = add_pixel_noise(extremes, 20.0, np.random.default_rng(9))
    assert noisy.dtype == np.uint8
    assert noisy[:, :50].mean() > 5 and noisy[:, 50:].mean() < 250  # clipped, not wrapped


def test_blur_matches_a_gaussian_edge_profile():
    # A step edge (0 | 255 from column 40) blurred by a normalised Gaussian kernel sampled
    # at integer offsets: pixel i = 255 Σ_{j≥40} g(i−j) / Σ g. Rounding to uint8 allows
    # 0.5 grey level, truncating the kernel at 4σ 0.02 more; σ off by 5 % moves a pixel
    # next to the edge by ~2 grey levels.
    sigma = 1.7
    step = np.zeros((41, 80), np.uint8)
    step[:, 40:] = 255
    row = blur(step, sigma)[20].astype(float)
    k = np.arange(-200, 201)
    g = np.exp(-0.5 * (k / sigma) ** 2)
    expected = [255 * g[(i - k >= 40)].sum() / g.sum() for i in range(80)]
    np.testing.assert_allclose(row, expected, atol=0.55)
    assert np.max(np.abs(row - 255 * norm.cdf((np.arange(80) - 39.5) / sigma))) < 1.5
    np.testing.assert_array_equal(blur(step, 0.0), step)
    rgb = np.dstack([step, step, step])
    np.testing.assert_array_equal(blur(rgb, sigma)[..., 1], blur(step, sigma))


@pytest.mark.slow
def test_distortion_warp_moves_corners_to_the_lens_model(sim):
    lens = pytest.importorskip("rasc.geometry.lens")
    sim.set_target(T_base_from_world_facing(sim.board, 1.0))
    K = sim.K("left")
    dist = np.array([-0.12, 0.05, 4e-4, -3e-4, 0.0])
    image = degrade(sim.render("left"), np.random.default_rng(0), K=K, dist=dist)
    detected = _detect(image, sim.board)
    p_cam = transform_points(sim.T_cam_from_world("left"), sim.board.object_points())
    expected = lens.project_points(p_cam, K, dist)
    if np.linalg.norm(detected[0] - expected[-1]) < np.linalg.norm(detected[0] - expected[0]):
        detected = detected[::-1]
    ideal = sim.project_world_points("left", sim.board.object_points())
    assert _rms(detected - ideal) > 1.0  # the warp did move the corners
    assert _rms(detected - expected) < CORNER_RMS_PX, _rms(detected - expected)


def test_degrade_needs_K_for_distortion():
    image = np.zeros((10, 10), np.uint8)
    with pytest.raises(InputError, match="needs the camera matrix K"):
        degrade(image, np.random.default_rng(0), dist=[0.1, 0, 0, 0])
    with pytest.raises(InputError, match="uint8 image"):
        blur(np.zeros((10, 10)), 1.0)


# -- OpenGL backend ------------------------------------------------------------------------

def _python(code, **env_changes):
    env = dict(os.environ)
    for key, value in env_changes.items():
        if value is None:
            env.pop(key, None)
        else:
            env[key] = value
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=300, check=False)


_CONSTRUCT = """
import sys
from rasc.errors import RascError
{setup}
try:
    import rasc.sim.scene as sim
    {patch}
    with sim.StereoHeadSim() as s:
        print(sim.gl_backend(), s.render("left").mean())
except RascError as exc:
    print(exc)
    sys.exit(3)
"""


@pytest.mark.slow
def test_invalid_backend_gives_the_clear_message():
    proc = _python(_CONSTRUCT.format(setup="", patch="pass"), MUJOCO_GL="bogus")
    assert proc.returncode == 3, proc.stderr
    msg = proc.stdout.strip()
    assert "MUJOCO_GL='bogus'" in msg and "invalid value" in msg
    assert "libegl1 libegl-mesa0 libgl1-mesa-dri" in msg and "libosmesa6" in msg
    assert len(msg.splitlines()) == 1


@pytest.mark.slow
def test_glx_without_a_display_is_one_line_and_nothing_else():
    """MUJOCO_GL=glx on a machine without a screen: GLFW's own warnings are silenced, so
    stderr holds nothing and the message is the one line with the packages."""
    proc = _python(_CONSTRUCT.format(setup="", patch="pass"), MUJOCO_GL="glx", DISPLAY=None)
    assert proc.returncode == 3, proc.stderr
    msg = proc.stdout.strip()
    assert len(msg.splitlines()) == 1 and msg.startswith("MUJOCO_GL='glx': cannot render")
    assert "libegl1 libegl-mesa0 libgl1-mesa-dri" in msg and "libosmesa6" in msg
    assert proc.stderr == "", proc.stderr


@pytest.mark.slow
def test_no_working_backend_names_the_packages():
    patch = "sim._probe_backend = lambda name: False"
    proc = _python(_CONSTRUCT.format(setup="", patch=patch), MUJOCO_GL=None)
    assert proc.returncode == 3, proc.stderr
    assert proc.stdout.startswith("no OpenGL backend for offscreen rendering")
    assert "libegl1 libegl-mesa0 libgl1-mesa-dri" in proc.stdout and "libosmesa6" in proc.stdout


@pytest.mark.slow
def test_unset_backend_is_probed_and_renders():
    proc = _python(_CONSTRUCT.format(setup="", patch="pass"), MUJOCO_GL=None)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    backend, mean = proc.stdout.split()
    assert backend in ("egl", "osmesa") and float(mean) > 10


@pytest.mark.slow
def test_importing_rasc_sim_loads_neither_mujoco_nor_cv2():
    # mujoco must be imported only after the backend is chosen; cv2 never by rasc.sim.scene.
    proc = _python("import sys, rasc.sim.scene; "
                   "print('mujoco' in sys.modules, 'cv2' in sys.modules)",
                   MUJOCO_GL=None)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["False", "False"]


def test_old_render_option_names_work_for_a_minor_version_with_a_warning():
    """0.3 gave RenderOptions the study spec's names; the 0.2 names still construct and
    read, each with a DeprecationWarning naming the new one."""
    from rasc.sim.render import RenderOptions
    with pytest.warns(DeprecationWarning, match=r"RenderOptions\(distance=\.\.\.\)"):
        old = RenderOptions(target_distance=1.5, seed=2)
    assert old == RenderOptions(distance=1.5, seed=2)
    for name, new, value in (("n_intrinsics", "intrinsics_views", 5),
                             ("noise_sigma", "image_noise", 2.0), ("blur_sigma", "blur", 0.5),
                             ("dist", "distortion", (0.1,))):
        with pytest.warns(DeprecationWarning, match=new):
            o = RenderOptions(**{name: value})
        assert getattr(o, new) == value
        with pytest.warns(DeprecationWarning, match=f"RenderOptions.{new}"):
            assert getattr(o, name) == value
