"""Solver plugins (rasc.handeye.methods): one contract for built-in names,
``package.module:function`` and the ``rasc.methods`` entry points.

The plugins are tiny modules written into a temporary folder put on sys.path; the entry
point is a hand-written ``*.dist-info`` in that folder, which importlib.metadata finds
exactly as it finds an installed package. Every bad plugin must give one line naming the
plugin and what it did, exit 2 and no output file.
"""

from __future__ import annotations

import json
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from rasc.cli import main
from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.kinematics import PAPER_POSES_DEG
from rasc.handeye import methods
from rasc.handeye.methods import (
    METHODS,
    PluginError,
    available_methods,
    get_method,
    jackknife_uncertainty,
    solve,
)
from rasc.handeye.noise import perturb_T_cam_from_world
from rasc.handeye.solver import diagnose, solve_rasc

from nominal_rig import PAPER
from nominal_rig import rig as draw_rig

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "handeye_nine_poses.json"

PLUGIN_SOURCE = '''
import numpy as np
from rasc.handeye.solver import solve_rasc

CALLS = []

def good(T_cam_from_world, T_gaze_from_ptu):
    CALLS.append(len(T_cam_from_world))
    return solve_rasc(T_cam_from_world, T_gaze_from_ptu, check_rigid=False).T_cam_from_gaze

def as_result(T_cam_from_world, T_gaze_from_ptu):
    return solve_rasc(T_cam_from_world, T_gaze_from_ptu, check_rigid=False)

def as_list(T_cam_from_world, T_gaze_from_ptu):
    return good(T_cam_from_world, T_gaze_from_ptu).tolist()

def with_option(T_cam_from_world, T_gaze_from_ptu, *, shift=0.0):
    T = good(T_cam_from_world, T_gaze_from_ptu).copy()
    T[:3, 3] += shift
    return T

def three_by_three(T_cam_from_world, T_gaze_from_ptu):
    return np.eye(3)

def nan(T_cam_from_world, T_gaze_from_ptu):
    return np.full((4, 4), np.nan)

def scaled(T_cam_from_world, T_gaze_from_ptu):
    T = good(T_cam_from_world, T_gaze_from_ptu).copy()
    T[:3, :3] *= 1.01
    return T

def last_row(T_cam_from_world, T_gaze_from_ptu):
    T = good(T_cam_from_world, T_gaze_from_ptu).copy()
    T[3, 3] = 2.0
    return T

def words(T_cam_from_world, T_gaze_from_ptu):
    return "identity"

def raises(T_cam_from_world, T_gaze_from_ptu):
    raise ValueError("matrix is singular\\nsecond line")

class Solvers:
    @staticmethod
    def nested(T_cam_from_world, T_gaze_from_ptu):
        return good(T_cam_from_world, T_gaze_from_ptu)

NOT_CALLABLE = 3
'''

#: the board's position in the ptu frame (m): these tests' truth since they were written
BOARD = (-0.15, 1.0, 0.05)


def rig(seed=3, sigma_r=0.002, sigma_t=0.001):
    """Nine ±8° positions, a seeded truth, the paper's noise (exponential)."""
    rng = np.random.default_rng(seed)
    X, Y = draw_rig(rng, BOARD)
    T_cw = perturb_T_cam_from_world(X @ PAPER @ Y, sigma_r, sigma_t, rng, variant="exponential")
    return T_cw, PAPER, X


@pytest.fixture
def plugins(tmp_path, monkeypatch):
    """A folder on sys.path with module ``userplug`` and a distribution ``userplug-0.1``
    registering ``user-good`` (and a few broken names) in the rasc.methods group."""
    (tmp_path / "userplug.py").write_text(PLUGIN_SOURCE, encoding="utf-8")
    (tmp_path / "brokenplug.py").write_text("import numpy\nraise RuntimeError('no GPU')\n",
                                            encoding="utf-8")
    dist = tmp_path / "userplug-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: userplug\nVersion: 0.1\n",
                                   encoding="utf-8")
    (dist / "entry_points.txt").write_text(textwrap.dedent("""\
        [rasc.methods]
        user-good = userplug:good
        user-nan = userplug:nan
        user-broken = brokenplug:solve
        rasc = userplug:nan
        """), encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    methods.clear_cache()
    yield tmp_path
    methods.clear_cache()
    for name in ("userplug", "brokenplug"):
        sys.modules.pop(name, None)


# ------------------------------------------------------------------ the contract

@pytest.mark.parametrize("name", ["userplug:good", "userplug:as_result", "userplug:as_list",
                                  "userplug:Solvers.nested", "user-good"])
def test_a_plugin_is_wrapped_like_a_built_in(plugins, name):
    """Whatever form the plugin returns (array, HandEyeResult, nested lists) and however
    it is named, the result is RASC's transform with the library's own quality (eq. 10)
    and diagnostics: the same numbers as solve_rasc's, since the rotation is the same."""
    T_cw, T_gp, _ = rig()
    ref = solve_rasc(T_cw, T_gp)
    res = solve(name, T_cw, T_gp)
    assert res.method == name
    # the plugins call solve_rasc(check_rigid=False), which takes each view's nearest
    # rotation first: the same transform to rounding (5e-16 measured), not bit for bit
    np.testing.assert_allclose(res.T_cam_from_gaze, ref.T_cam_from_gaze, rtol=0, atol=1e-12)
    # eq. 10 is computed by one routine for both; only summation order may differ
    assert res.quality == pytest.approx(ref.quality, rel=1e-12)
    assert res.diagnostics == diagnose(T_cw, T_gp)[0] == ref.diagnostics


def test_a_callable_and_a_method_object_resolve_too(plugins):
    import userplug

    T_cw, T_gp, _ = rig()
    by_callable = solve(userplug.good, T_cw, T_gp)
    assert by_callable.method == "userplug:good"
    m = get_method("userplug:good")
    assert get_method(m) is m and m.origin == "module:function" and not m.builtin
    assert get_method("rasc").builtin and get_method("rasc").function is METHODS["rasc"]
    np.testing.assert_array_equal(m(T_cw, T_gp).T_cam_from_gaze, by_callable.T_cam_from_gaze)


def test_entry_points_are_listed_and_built_in_names_win(plugins):
    registered = methods.registered_methods()
    assert registered["user-good"] == "userplug:good"
    assert "rasc" not in registered          # a plugin cannot take over a built-in name
    assert available_methods()["rasc"] == "built-in"
    assert get_method("rasc").function is METHODS["rasc"]
    m = get_method("user-good")
    assert m.origin == "entry point user-good = userplug:good (userplug 0.1)"


def test_options_reach_the_plugin_and_check_rigid_is_the_wrappers(plugins):
    """check_rigid=False lets the paper's literal eq. 13 matrices through to the plugin
    (the plugin itself does not take that keyword); other options are the plugin's."""
    T_cw, T_gp, _ = rig()
    shifted = solve("userplug:with_option", T_cw, T_gp, shift=0.5)
    base = solve("userplug:good", T_cw, T_gp)
    np.testing.assert_allclose(shifted.T_cam_from_gaze[:3, 3] - base.T_cam_from_gaze[:3, 3],
                               0.5, atol=1e-12)
    literal = T_cw.copy()
    literal[:, :3, :3] += 0.01 * np.random.default_rng(0).normal(size=(9, 3, 3))
    with pytest.raises(InputError, match="check_rigid=False"):
        solve("userplug:good", literal, T_gp)
    assert solve("userplug:good", literal, T_gp, check_rigid=False).method == "userplug:good"


def test_degenerate_data_is_refused_before_the_plugin_runs(plugins):
    import userplug

    T_cw, T_gp, _ = rig()
    pan_only = [k for k, (_, tilt) in enumerate(PAPER_POSES_DEG) if tilt == 0]
    userplug.CALLS.clear()
    with pytest.raises(DegenerateDataError, match="cannot be determined"):
        solve("userplug:good", T_cw[pan_only], T_gp[pan_only])
    assert userplug.CALLS == []


def test_jackknife_works_for_any_method(plugins):
    """The plugin returns RASC's answer for every subset, so its jackknife is RASC's."""
    T_cw, T_gp, _ = rig()
    ref = solve_rasc(T_cw, T_gp)
    a = jackknife_uncertainty("rasc", T_cw, T_gp, ref)
    b = jackknife_uncertainty("userplug:good", T_cw, T_gp, solve("userplug:good", T_cw, T_gp))
    assert b.n_subsets == 9 and b.reason is None
    assert b.rotation_deg == pytest.approx(a.rotation_deg, rel=1e-9)
    assert b.translation == pytest.approx(a.translation, rel=1e-9)


# --------------------------------------------------------------- broken plugins

BROKEN = {
    "userplug:three_by_three": "method userplug:three_by_three returned shape (3, 3), "
                               "expected (4, 4)",
    "userplug:nan": "method userplug:nan returned a matrix with NaN or infinity",
    "userplug:scaled": "method userplug:scaled returned a matrix that is not a rigid "
                       "transform: max |RᵀR − I| = 0.0201",
    "userplug:last_row": "method userplug:last_row returned a matrix whose last row is "
                         "[0.0, 0.0, 0.0, 2.0], expected [0, 0, 0, 1]",
    "userplug:words": "method userplug:words returned str, expected a 4x4",
    "userplug:raises": "method userplug:raises raised ValueError: matrix is singular "
                       "second line",
    "user-nan": "method user-nan returned a matrix with NaN or infinity",
    "nosuchmodule:solve": "method nosuchmodule:solve: cannot import module nosuchmodule "
                          "(ModuleNotFoundError: No module named 'nosuchmodule')",
    "brokenplug:solve": "method brokenplug:solve: cannot import module brokenplug "
                        "(RuntimeError: no GPU)",
    "user-broken": "method user-broken (brokenplug:solve): cannot import module brokenplug "
                   "(RuntimeError: no GPU)",
    "userplug:missing": "method userplug:missing: module userplug has no attribute 'missing'",
    "userplug:NOT_CALLABLE": "method userplug:NOT_CALLABLE: userplug:NOT_CALLABLE is a int, "
                             "not a callable",
    "userplug:": "method 'userplug:': expected a method name or package.module:function",
    "no-such-method": "method 'no-such-method': unknown; expected one of rasc, li, "
                      "rasc-inverse, rasc-views, rasc-robust, rasc-scale, opencv-park",
}


@pytest.mark.parametrize("name", list(BROKEN))
def test_a_broken_plugin_is_one_line_exit_2_and_no_file(plugins, name, tmp_path, capsys):
    out = tmp_path / "result.json"
    rc = main(["handeye", str(EXAMPLE), "--method", name, "--out", str(out)])
    captured = capsys.readouterr()
    assert rc == 2 and captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("rasc handeye: error: " + BROKEN[name]), lines[0]
    assert not out.exists()


def test_broken_plugins_raise_rasc_errors_from_the_library(plugins):
    T_cw, T_gp, _ = rig()
    with pytest.raises(PluginError, match="returned shape"):
        solve("userplug:three_by_three", T_cw, T_gp)
    with pytest.raises(InputError, match="cannot import"):
        get_method("nosuchmodule:solve")


def test_a_name_registered_twice_is_refused(plugins):
    dist = plugins / "other-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: other\nVersion: 1.0\n",
                                   encoding="utf-8")
    (dist / "entry_points.txt").write_text("[rasc.methods]\nuser-good = other:solve\n",
                                           encoding="utf-8")
    with pytest.raises(InputError, match="registered twice .* as userplug:good and "
                                         "other:solve|as other:solve and userplug:good"):
        get_method("user-good")


# ------------------------------------------------------------ the command line

@pytest.mark.slow
def test_cli_runs_a_plugin_by_module_and_by_entry_point(plugins, tmp_path, rasc_cli):
    """``rasc handeye --method my.module:function`` with the module on the path, and the
    entry-point name: the written result names the method and holds the wrapped quality
    and jackknife, and matches --method rasc (the plugin is RASC). In this process (the
    same in fresh processes with PYTHONPATH, as a user runs it: the console examples of
    docs/guide/solver.md)."""
    docs = {}
    for name in ("userplug:good", "user-good", "rasc"):
        out = tmp_path / f"{name.replace(':', '_')}.json"
        status, _, err = rasc_cli("handeye", EXAMPLE, "--method", name, "--out", out)
        assert status == 0, err
        docs[name] = json.loads(out.read_text(encoding="utf-8"))
        assert docs[name]["method"] == name
    for name in ("userplug:good", "user-good"):
        np.testing.assert_allclose(docs[name]["T_cam_from_gaze"], docs["rasc"]["T_cam_from_gaze"],
                                   rtol=0, atol=1e-15)
        assert docs[name]["quality"] == pytest.approx(docs["rasc"]["quality"], rel=1e-12)
        assert docs[name]["uncertainty"]["rotation_deg"] == pytest.approx(
            docs["rasc"]["uncertainty"]["rotation_deg"], rel=1e-9)


def test_calibrate_checks_the_method_before_reading_the_dataset(plugins, tmp_path, capsys):
    out = tmp_path / "cal.json"
    rc = main(["calibrate", str(tmp_path / "no-dataset"), "--method", "userplug:missing",
               "--out", str(out)])
    err = capsys.readouterr().err.splitlines()
    assert rc == 2 and len(err) == 1
    assert err[0] == ("rasc calibrate: error: method userplug:missing: module userplug has "
                      "no attribute 'missing'")
    assert not out.exists()


@pytest.mark.slow
def test_calibrate_runs_a_plugin_and_names_the_eye_when_it_fails(plugins, tmp_path, capsys,
                                                                  rasc_testing_cache):
    """rasc calibrate --method package.module:function on a rendered dataset: the
    calibration names the method and equals RASC's (the plugin returns RASC's answer);
    a plugin that fails during the solve is one line naming the manifest, the eye and
    the plugin, exit 2, no file. The dataset is docs/guide/solver.md's and examples/my_solver's
    (10 intrinsics views), rendered once per run into conftest's shared cache."""
    from rasc.testing import render_cached

    data = render_cached(rasc_testing_cache, intrinsics_views=10)
    docs = {}
    for name in ("userplug:good", "rasc"):
        out = tmp_path / f"{name.replace(':', '_')}.json"
        assert main(["calibrate", str(data.path), "--method", name, "--out", str(out),
                     "--quiet"]) == 0
        docs[name] = json.loads(out.read_text(encoding="utf-8"))
    capsys.readouterr()
    for eye in ("left", "right"):
        mine, ref = docs["userplug:good"]["eyes"][eye], docs["rasc"]["eyes"][eye]
        assert mine["handeye_method"] == "userplug:good"
        np.testing.assert_allclose(mine["T_cam_from_gaze"], ref["T_cam_from_gaze"], atol=1e-15)
    out = tmp_path / "bad.json"
    assert main(["calibrate", str(data.path), "--method", "userplug:scaled", "--out",
                 str(out), "--quiet"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"rasc calibrate: error: {data.path / 'manifest.json'}: left eye: "
                           "method userplug:scaled returned a matrix that is not a rigid")
    assert not out.exists()


def test_methods_pickle_for_process_pools(plugins):
    """A resolved method crosses a process boundary (process pool, dask) by reference."""
    import pickle

    T_cw, T_gp, _ = rig()
    for name in ("rasc", "opencv-park", "rasc-views", "userplug:good", "user-good"):
        m = pickle.loads(pickle.dumps(get_method(name)))
        assert m.name == name
        assert m(T_cw, T_gp).method == name
