"""Issue 21, command level: one mechanism per class of fault, one regression test each.

* outputs checked against every input and each other before any work
  (:func:`rasc.io.check_outputs`), including ``--plots`` and unwritable targets;
* non-finite numbers never reach a JSON writer (:func:`rasc.io.dumps_json`; the
  calibration marks an image the refinement rejected whole);
* C libraries' own stderr never leaks (:func:`rasc.io.native_stderr_captured`);
* warnings once each, naming the right comparison (measured mounts);
* a plugin cannot end the process or corrupt its stdout (rasc.handeye.methods._run_plugin).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rasc.errors import DegenerateDataError, InputError
from rasc.io import check_outputs, dumps_json

from running import python_rasc

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "handeye_nine_poses.json"
UNWRITABLE = [p for p in ("/proc/rasc-x", "/sys/rasc-x") if Path(p).parent.is_dir()]


def _copy(dataset: Path, dest: Path) -> Path:
    shutil.copytree(dataset, dest)
    return dest


def _no_work(monkeypatch):
    """Make any calibration work fail the test: refusals must come before it."""
    import rasc.head.pipeline as pipeline

    def forbidden(*args, **kwargs):
        raise AssertionError("the calibration started before the outputs were checked")

    monkeypatch.setattr(pipeline, "calibrate_dataset", forbidden)


# ------------------------------------------------------------------- outputs

def test_plots_never_overwrite_an_input_image(default_dataset, tmp_path, rasc_cli,
                                              monkeypatch):
    ds = _copy(default_dataset, tmp_path / "ds")
    manifest = json.loads((ds / "manifest.json").read_text())
    first = manifest["images"][0]
    (ds / first["file"]).rename(ds / "residuals_left.png")     # an input with the plot's name
    first["file"] = "residuals_left.png"
    (ds / "manifest.json").write_text(json.dumps(manifest))
    before = (ds / "residuals_left.png").read_bytes()
    _no_work(monkeypatch)
    status, out, err = rasc_cli("calibrate", ds, "--out", tmp_path / "cal.json", "--plots", ds)
    assert status == 2 and out == ""
    assert err.splitlines() == [f"rasc calibrate: error: --plots {ds} is the input folder; "
                                "choose another path"]
    assert (ds / "residuals_left.png").read_bytes() == before
    assert not (tmp_path / "cal.json").exists()


@pytest.mark.parametrize("argv", [
    ["--out", "{t}/x", "--plots", "{t}/x"],
    ["--plots", "{t}", "--out", "{t}/residuals_right.png"],
] + [["--plots", p] for p in UNWRITABLE] + [["--out", f"{p}.json"] for p in UNWRITABLE])
def test_calibrate_outputs_are_refused_before_any_work(argv, tmp_path, rasc_cli, monkeypatch):
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "manifest.json").write_text("{}")
    _no_work(monkeypatch)
    argv = [a.format(t=tmp_path) for a in argv]
    status, out, err = rasc_cli("calibrate", tmp_path / "ds", *argv)
    assert status == 2 and out == "" and len(err.splitlines()) == 1, err
    assert err.startswith("rasc calibrate: error: --")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]     # nothing written


@pytest.mark.skipif(not UNWRITABLE, reason="no /proc or /sys here")
@pytest.mark.parametrize("command", ["handeye", "triangulate", "project", "look-at",
                                     "detect"])
def test_every_command_refuses_an_unwritable_out_in_one_line(command, tmp_path, rasc_cli):
    cal = REPO / "examples" / "use" / "calibration.json"
    argv = {"handeye": [EXAMPLE],
            "triangulate": [cal, REPO / "examples" / "use" / "pixels.csv", "--angle-unit",
                            "deg"],
            "project": [cal, REPO / "examples" / "use" / "points.csv", "--angle-unit", "deg"],
            "look-at": [cal, "--point", "0,1,0", "--angle-unit", "deg"],
            "detect": [tmp_path]}[command]
    status, out, err = rasc_cli(command, *argv, "--out", f"{UNWRITABLE[0]}.json")
    assert status == 2 and out == ""
    assert err.splitlines() == [f"rasc {command}: error: --out {UNWRITABLE[0]}.json: cannot "
                                "write: " + err.split("cannot write: ", 1)[1].strip()]


def test_check_outputs_compares_every_output_with_every_input(tmp_path):
    image = tmp_path / "plots" / "residuals_left.png"
    image.parent.mkdir()
    image.write_bytes(b"input")
    with pytest.raises(InputError, match="holds an input of this command"):
        check_outputs([("--plots", tmp_path / "plots", "folder", ("residuals_left.png",))],
                      inputs=[image])
    other = tmp_path / "elsewhere" / "residuals_left.png"       # a hard link to the input
    other.parent.mkdir()
    other.hardlink_to(image)
    with pytest.raises(InputError, match="is the input file"):
        check_outputs([("--plots", other.parent, "folder", ("residuals_left.png",))],
                      inputs=[image])
    with pytest.raises(InputError, match="--plots .* is the output file of --out"):
        check_outputs([("--out", tmp_path / "o", "file", ()),
                       ("--plots", tmp_path / "o", "folder", ("a.png",))])
    with pytest.raises(InputError, match="is the output folder of --plots"):
        check_outputs([("--plots", tmp_path / "o", "folder", ("a.png",)),
                       ("--out", tmp_path / "o", "file", ())])
    check_outputs([("--out", tmp_path / "cal.json", "file", ()),
                   ("--plots", tmp_path / "new", "folder", ("a.png",))], inputs=[image])
    assert not (tmp_path / "new").exists() and not (tmp_path / "cal.json").exists()


# ------------------------------------------------------------------- non-finite

def test_no_nan_reaches_a_json_writer():
    with pytest.raises(DegenerateDataError, match=r"the result's b\[1\]\.c is not a finite"):
        dumps_json({"a": 1.0, "b": [{"c": 0.0}, {"c": np.float64("nan")}]})
    with pytest.raises(DegenerateDataError, match=r"the result's x\[2\] is not"):
        dumps_json({"x": np.array([0.0, 1.0, np.inf])})


@pytest.mark.slow
def test_swapped_pose_images_are_marked_not_a_traceback(default_dataset, tmp_path):
    ds = _copy(default_dataset, tmp_path / "ds")
    manifest = json.loads((ds / "manifest.json").read_text())
    left = [im for im in manifest["images"] if im["role"] == "pose" and im["eye"] == "left"]
    left[1]["file"], left[5]["file"] = left[5]["file"], left[1]["file"]
    (ds / "manifest.json").write_text(json.dumps(manifest))
    run = python_rasc("calibrate", ds, "--out", tmp_path / "cal.json", "--quiet")
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    doc = json.loads((tmp_path / "cal.json").read_text())
    marked = sorted(im["file"] for im in doc["refinement"]["images"] if im.get("all_rejected"))
    assert marked == sorted([left[1]["file"], left[5]["file"]])
    lines = [w for w in run.stderr.splitlines() if "rejected every corner" in w]
    assert len(lines) == 1 and all(f in lines[0] for f in marked)


# ------------------------------------------------------------------- native stderr

def test_a_corrupt_png_is_one_line_without_libpng_s_own(default_dataset, tmp_path):
    ds = _copy(default_dataset, tmp_path / "ds")
    victim = ds / "poses" / "left_03.png"
    data = victim.read_bytes()
    victim.write_bytes(data[: len(data) // 2])               # cut mid-stream
    for command in ("calibrate", "detect"):
        run = python_rasc(command, ds, "--quiet")
        assert run.returncode == 2 and run.stdout == ""
        assert run.stderr.count("\n") == 1, run.stderr         # one line, libpng's inside it
        assert run.stderr.startswith(f"rasc {command}: error: ")
        assert "poses/left_03.png" in run.stderr and "libpng error" in run.stderr


# ------------------------------------------------------------------- warnings

@pytest.mark.slow
def test_measured_mounts_disagreeing_are_warned_once_naming_the_refinement(
        default_cli_run, tmp_path):
    from rasc.geometry.transforms import make_transform, matrix_from_rotvec

    cal = json.loads((default_cli_run / "cal.json").read_text())
    T = np.array(cal["base_to_ptu"]["T_ptuL_from_ptuR"])
    wrong = make_transform(matrix_from_rotvec([0.0, np.radians(10.0), 0.0]), [0, 0, 0]) @ T
    mounts = tmp_path / "mounts.json"
    mounts.write_text(json.dumps({"T_ptuL_from_ptuR": wrong.tolist()}))
    run = python_rasc("calibrate", default_cli_run / "ds", "--mounts", mounts, "--out",
                      tmp_path / "cal.json", "--quiet")
    assert run.returncode == 0, run.stderr
    said = [w for w in run.stderr.splitlines() if "measured mounts" in w]
    assert len(said) == 1, run.stderr
    assert "the measured mounts and the whole-head refinement differ by 10°" in said[0]


# ------------------------------------------------------------------- plugins

PLUGIN = '''
import sys
from rasc.handeye.solver import solve_rasc

def exits(T_cam_from_world, T_gaze_from_ptu):
    sys.exit(0)

def chatty(T_cam_from_world, T_gaze_from_ptu):
    print("solving with my plugin...")
    return solve_rasc(T_cam_from_world, T_gaze_from_ptu, check_rigid=False)
'''


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    import sys

    from rasc.handeye import methods

    (tmp_path / "doorsplug.py").write_text(PLUGIN)
    monkeypatch.syspath_prepend(str(tmp_path))
    methods.clear_cache()
    yield
    methods.clear_cache()
    sys.modules.pop("doorsplug", None)


def test_a_plugin_calling_sys_exit_is_one_error_line(plugin, tmp_path, rasc_cli):
    status, out, err = rasc_cli("handeye", EXAMPLE, "--method", "doorsplug:exits",
                                "--out", tmp_path / "r.json")
    assert status == 2 and out == ""
    assert err.splitlines() == ["rasc handeye: error: method doorsplug:exits called "
                                "sys.exit(0) instead of returning a result"]
    assert not (tmp_path / "r.json").exists()


def test_a_plugin_that_prints_does_not_corrupt_the_json(plugin, rasc_cli):
    status, out, err = rasc_cli("handeye", EXAMPLE, "--method", "doorsplug:chatty")
    assert status == 0
    assert json.loads(out)["method"] == "doorsplug:chatty"
    assert "solving with my plugin..." in err


# ------------------------------------------------------------------- outputs, any spelling

#: the files of a small tree: inputs are some of them; outputs are spelt through
#: relative parts, "..", "." and a symbolic link to a folder
_FILES = ("a/in.png", "a/b/in.json", "c/residuals_left.png")


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(target=st.sampled_from(_FILES + ("a/new.json", "c/new.png")),
       spelling=st.sampled_from(("plain", "dots", "link")),
       as_folder=st.booleans())
def test_an_output_is_refused_exactly_when_it_is_an_input(tmp_path_factory, target, spelling,
                                                          as_folder):
    """Whatever way a path is spelt, check_outputs refuses it exactly when it (or, for a
    --plots folder, a file it would write) is one of the inputs."""
    root = tmp_path_factory.mktemp("tree")
    for f in _FILES:
        (root / f).parent.mkdir(parents=True, exist_ok=True)
        (root / f).write_bytes(b"input")
    (root / "link").symlink_to(root / "a")
    inputs = [root / f for f in _FILES]
    folder, name = target.rsplit("/", 1)
    if spelling == "dots":
        spelt = root / "c" / ".." / folder / "." / name
    elif spelling == "link" and folder == "a":
        spelt = root / "link" / name
    else:
        spelt = root / folder / name
    if as_folder:                      # --plots FOLDER writing `name` into it
        outputs = [("--plots", spelt.parent, "folder", (name,))]
    else:
        outputs = [("--out", spelt, "file", ())]
    is_input = target in _FILES
    try:
        check_outputs(outputs, inputs=inputs)
        refused = False
    except InputError:
        refused = True
    if as_folder:
        # a folder holding an input is refused whatever it would write
        assert refused
    else:
        assert refused == is_input
    assert all((root / f).read_bytes() == b"input" for f in _FILES)
