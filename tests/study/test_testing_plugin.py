"""rasc.testing, the pytest plugin for users' own regression tests: pose sets by the
paper's noise model, the assertion helper, the rendered-dataset cache, and the plugin
itself run the way a user runs it (``pytest -p rasc.testing`` in a subprocess)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from rasc.geometry.transforms import (
    is_rigid_transform,
    make_transform,
    matrix_from_rotvec,
    rotvec_from_matrix,
)
from rasc.handeye.methods import solve
from rasc.testing import (
    PoseSet,
    assert_handeye_close,
    dataset_key,
    handeye_errors,
    make_pose_set,
    render_cached,
)


def _run_pytest(path, *args, **env):
    """pytest in a fresh process with only rasc.testing loaded explicitly."""
    environ = dict(os.environ, PYTEST_DISABLE_PLUGIN_AUTOLOAD="1", MUJOCO_GL="egl", **env)
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "rasc.testing",
                           "-p", "no:cacheprovider", "-q", str(path), *args],
                          capture_output=True, text=True, env=environ, timeout=600,
                          cwd=os.path.dirname(str(path)))


# ------------------------------------------------------------------- pose sets

def test_noise_free_set_is_the_model_exactly():
    s = make_pose_set(0)
    assert isinstance(s, PoseSet) and s.sigma_r == 0 and s.sigma_t == 0
    np.testing.assert_allclose(s.T_cam_from_world,
                               s.T_cam_from_gaze @ s.T_gaze_from_ptu @ s.T_ptu_from_world,
                               atol=1e-15)
    assert s.T_cam_from_world.shape == (9, 4, 4) and s.truth is s.T_cam_from_gaze
    # the board is ahead of the camera at every position, about 1 m away
    depth = s.T_cam_from_world[:, 2, 3]
    assert np.all((depth > 0.9) & (depth < 1.1))


def test_levels_seeds_and_variants():
    """Level k is the paper's (0.005 k rad, k mm); the same seed gives the same bytes;
    the noise's spread is σ_r (recovered from ω = log(R_trueᵀ R') over 10 seeds, 270
    draws: a standard deviation estimated to ±5 %, bound 15 %)."""
    a, b = make_pose_set(4, seed=7), make_pose_set(4, seed=7)
    assert a.sigma_r == 0.02 and a.sigma_t == pytest.approx(0.004)
    assert a.T_cam_from_world.tobytes() == b.T_cam_from_world.tobytes()
    assert not np.array_equal(a.T_cam_from_world, make_pose_set(4, seed=8).T_cam_from_world)
    omega = []
    for seed in range(10):
        s = make_pose_set(4, seed=seed)
        clean = s.T_cam_from_gaze @ s.T_gaze_from_ptu @ s.T_ptu_from_world
        R = np.swapaxes(clean[:, :3, :3], -1, -2) @ s.T_cam_from_world[:, :3, :3]
        omega.append(rotvec_from_matrix(R))
    assert np.std(np.concatenate(omega)) == pytest.approx(0.02, rel=0.15)
    literal = make_pose_set(8, variant="literal")
    assert not literal.check_rigid and make_pose_set(8).check_rigid
    assert not is_rigid_transform(literal.T_cam_from_world[0])
    explicit = make_pose_set(sigma_r=0.001, sigma_t=0.0005, poses_deg=[(0, 0), (5, 0), (0, 5),
                                                                      (5, 5)])
    assert explicit.T_cam_from_world.shape == (4, 4, 4) and explicit.sigma_t == 0.0005
    with pytest.raises(ValueError, match="level: expected 0"):
        make_pose_set(9)


# ------------------------------------------------------------------ the assertion

def test_assert_handeye_close_passes_and_fails_with_both_errors():
    X = make_pose_set(0).truth
    near = make_transform(matrix_from_rotvec(np.radians([0.2, 0.0, 0.0])) @ X[:3, :3],
                          X[:3, 3] + [0.003, 0.0, 0.004])
    rot, trans = handeye_errors(near, X)
    assert rot == pytest.approx(0.2, rel=1e-9) and trans == pytest.approx(0.005, rel=1e-12)
    assert_handeye_close(near, X, rotation_deg=0.25, translation=0.006)
    with pytest.raises(AssertionError) as info:
        assert_handeye_close(near, X, rotation_deg=0.1, translation=0.006)
    assert str(info.value) == ("T_cam_from_gaze is 0.2° and 0.005 from the truth; allowed "
                               "0.1° and 0.006: rotation too far")
    s = make_pose_set(8, seed=1)
    result = solve("rasc", s.T_cam_from_world, s.T_gaze_from_ptu)
    with pytest.raises(AssertionError, match=r"\(method rasc\) is .* allowed 0.001° and "
                                             r"1e-06: rotation and translation too far"):
        assert_handeye_close(result, s, rotation_deg=0.001, translation=1e-6)
    with pytest.raises(ValueError, match="expected a 4x4"):
        handeye_errors(np.eye(3), X)


# ------------------------------------------------------------ rendered datasets

SMALL = {"intrinsics_views": 4, "poses_deg": [(0, 0), (8, 0), (0, 8), (-8, -8)]}


@pytest.mark.slow
def test_rendered_dataset_is_cached_by_its_parameters(tmp_path):
    """Rendered once into the cache; asked again, the same folder comes back untouched;
    any changed option is another key. The ground truth is the model's."""
    first = render_cached(tmp_path, **SMALL)
    manifest = first.path / "manifest.json"
    stamp = manifest.stat().st_mtime_ns
    again = render_cached(tmp_path, **SMALL)
    assert again.path == first.path and manifest.stat().st_mtime_ns == stamp
    other = render_cached(tmp_path, **{**SMALL, "seed": 1})
    assert other.key != first.key
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([first.key, other.key])
    X = first.T_cam_from_gaze("left")
    assert X.shape == (4, 4) and is_rigid_transform(X)
    # the true pose views are exact hand-eye data: RASC recovers the model's transform
    # (1e-9: round-off of the renderer's float64 chain, far below any calibration error)
    for eye in ("left", "right"):
        T_cw, T_gp = first.pose_views(eye)
        assert T_cw.shape == T_gp.shape == (4, 4, 4)
        result = solve("rasc", T_cw, T_gp)
        assert_handeye_close(result, first.T_cam_from_gaze(eye), rotation_deg=1e-9,
                             translation=1e-9)
    assert len(first.load().images) == 2 * (4 + 4)
    # the key covers every option, the model files and rasc's code
    assert dataset_key(first.options) == first.key
    assert dataset_key(other.options) != first.key
    import rasc.datasets.keys as keys

    with pytest.MonkeyPatch.context() as mp:        # another renderer, the same version
        mp.setattr(keys, "code_digest", lambda: "0" * 64)
        assert dataset_key(first.options) != first.key
    assert dataset_key(first.options) == first.key


def test_loading_the_plugin_imports_no_heavy_module():
    code = ("import sys, rasc.testing; heavy = [m for m in ('mujoco', 'cv2', 'scipy', "
            "'matplotlib') if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


USER_TESTS = '''
import numpy as np
import pytest
from rasc.handeye.methods import solve
from rasc.testing import assert_handeye_close


@pytest.mark.parametrize("rasc_pose_set", [0, 2, {"level": 2, "variant": "literal"}],
                         indirect=True)
def test_rasc_on_pose_sets(rasc_pose_set):
    s = rasc_pose_set
    res = solve("rasc", s.T_cam_from_world, s.T_gaze_from_ptu, check_rigid=s.check_rigid)
    assert_handeye_close(res, s, rotation_deg=10.0, translation=0.1)


def test_default_and_factory(rasc_pose_set, rasc_pose_set_factory):
    assert rasc_pose_set.sigma_r == 0.005
    assert rasc_pose_set_factory(3, seed=5).seed == 5


@pytest.mark.parametrize("rasc_dataset", [SMALL], indirect=True)
def test_dataset(rasc_dataset):
    assert (rasc_dataset.path / "manifest.json").exists()
    assert rasc_dataset.T_cam_from_gaze("right").shape == (4, 4)


def test_too_strict(rasc_pose_set):
    s = rasc_pose_set
    res = solve("rasc", s.T_cam_from_world, s.T_gaze_from_ptu)
    assert_handeye_close(res, s, rotation_deg=1e-6, translation=1e-9)
'''


@pytest.mark.slow
def test_fixtures_in_a_users_suite(tmp_path):
    """A user's test file, run by pytest with the plugin: the fixtures work, indirect
    parametrisation works, the dataset lands in --rasc-cache-dir, and a too-strict
    tolerance fails with the helper's message."""
    test_file = tmp_path / "test_user.py"
    test_file.write_text(USER_TESTS.replace("[SMALL]", repr([SMALL])), encoding="utf-8")
    cache = tmp_path / "cache" / "rendered"         # the dataset service's store
    proc = _run_pytest(test_file, "--rasc-cache-dir", str(cache))
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "5 passed" in proc.stdout and "1 failed" in proc.stdout, proc.stdout
    assert "FAILED" in proc.stdout and "test_too_strict" in proc.stdout
    assert "from the truth; allowed 1e-06° and 1e-09: rotation and translation too far" \
        in proc.stdout
    assert len([p for p in cache.iterdir() if not p.name.startswith(".")]) == 1
    assert [p for p in cache.iterdir() if p.name.startswith(".")] == []  # no leftovers
    # the same store through the environment variable (rasc's cache root, whose
    # rendered/ store it is): nothing rendered again
    (key,) = [p for p in cache.iterdir()]
    stamp = (key / "data" / "manifest.json").stat().st_mtime_ns
    proc = _run_pytest(test_file, "-k", "dataset", RASC_CACHE_DIR=str(cache.parent))
    assert proc.returncode == 0, proc.stdout
    assert (key / "data" / "manifest.json").stat().st_mtime_ns == stamp
    # RASC_CACHE_DIR=none: no cache, and no folder ./none/
    proc = _run_pytest(test_file, "-k", "dataset", RASC_CACHE_DIR="none")
    assert proc.returncode == 0, proc.stdout
    assert not (tmp_path / "none").exists()
