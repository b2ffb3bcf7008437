"""Issue 21 at the study level: nothing takes a study down or gives silent wrong numbers.

One regression test per class: the study folder locked (two studies into one folder),
cell and dataset files verified on resume (cut, garbage, truncated: recomputed with a
note, never trusted), work bounded from the spec (one line naming the file and key), an
output folder that cannot be made (one line), plugins that print, exit or hang (a failed
sample), a crashed worker (one line naming the plugin), and spec values named by the
spec's keys, never by a command's flags.

The studies here run on a synthetic dataset document (exact poses from
:func:`rasc.testing.make_pose_set`), so no rendering is needed: every cell solves in
milliseconds.
"""

from __future__ import annotations

import csv
import io
import os
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

os.environ.setdefault("MUJOCO_GL", "egl")

from rasc.errors import InputError  # noqa: E402
from rasc.study import load_spec, run_study  # noqa: E402
from rasc.study.engine import (  # noqa: E402
    SAMPLE_COLUMNS,
    _found_datasets,
    csv_text,
    dataset_name,
    study_lock,
    verified_cell,
)
from rasc.testing import make_pose_set  # noqa: E402


@pytest.fixture(autouse=True)
def no_cache(monkeypatch):
    monkeypatch.setenv("RASC_CACHE_DIR", "none")


def synthetic_dataset(seed: int = 0) -> dict:
    """A study dataset document (rasc-study-dataset/1) of exact poses: the truth is
    recovered exactly without added noise."""
    eyes = {}
    for k, eye in enumerate(("left", "right")):
        s = make_pose_set(0, seed=seed + k)
        n = len(s.poses_deg)
        eyes[eye] = {"files": [f"poses/{eye}_{i:02d}.png" for i in range(n)],
                     "pan_tilt_rad": np.radians(np.asarray(s.poses_deg, float)).tolist(),
                     "T_cam_from_world": s.T_cam_from_world.tolist(),
                     "corners": [[] for _ in range(n)],
                     "K": np.eye(3).tolist(), "dist": [0.0] * 5,
                     "T_cam_from_gaze_true": s.T_cam_from_gaze.tolist()}
    return {"format": "rasc-study-dataset/1", "board": {"inner_corners": [9, 6],
                                                       "square_size": 0.03},
            "eyes": eyes}


SPEC = """\
seed = 1
samples = 5
methods = ["rasc", "li"]
bootstrap = 200
[fixed]
noise_model = "exponential"
[axes]
noise_level = [1, 3]
eye = ["left", "right"]
"""


def spec_file(tmp_path: Path, text: str = SPEC, name: str = "spec.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


# ------------------------------------------------------------- data loss: the lock

def test_a_second_study_into_a_locked_folder_is_refused_with_one_line(tmp_path):
    spec = load_spec(spec_file(tmp_path))
    out = tmp_path / "out"
    out.mkdir()
    with study_lock(out):                       # another study holds the folder
        with pytest.raises(InputError, match="another rasc study is writing") as info:
            run_study(spec, out, quiet=True, dataset=synthetic_dataset())
        assert "\n" not in str(info.value)
    assert list(out.iterdir()) == []            # nothing written by the refused one
    # the lock goes with its holder: the same study now runs
    run_study(spec, out, quiet=True, dataset=synthetic_dataset(), figures=False)
    assert (out / "samples.csv").is_file()


@pytest.mark.slow
def test_the_lock_refuses_a_second_holder_in_another_process(tmp_path):
    """flock is per open file: a child process cannot take the folder either."""
    import subprocess
    out = tmp_path / "out"
    out.mkdir()
    code = ("import sys; from pathlib import Path; from rasc.study.engine import study_lock\n"
            "try:\n  with study_lock(Path(sys.argv[1])): print('took it')\n"
            "except Exception as e: print(type(e).__name__, e)")
    with study_lock(out):
        run = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True,
                             text=True, timeout=60)
    assert run.stdout.startswith("InputError") and "another rasc study" in run.stdout
    run = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True,
                         text=True, timeout=60)
    assert run.stdout.strip() == "took it"


# ---------------------------------------------- silent wrong numbers: verified resume

def _reference(tmp_path: Path) -> tuple[Path, dict[str, bytes]]:
    spec = load_spec(spec_file(tmp_path))
    ref = tmp_path / "ref"
    run_study(spec, ref, quiet=True, dataset=synthetic_dataset(), figures=False)
    return ref, tree(ref)


@pytest.mark.slow
def test_resume_recomputes_cut_and_garbage_cell_files_and_gives_the_same_bytes(tmp_path):
    spec = load_spec(spec_file(tmp_path))
    ref, want = _reference(tmp_path)
    out = tmp_path / "run"
    run_study(spec, out, quiet=True, dataset=synthetic_dataset(), figures=False)
    cells = sorted((out / "cells").iterdir())
    text = cells[0].read_text()
    cells[0].write_text(text[: len(text) // 2])                 # cut mid-line
    cells[1].write_text(cells[1].read_text() + "garbage,line\n")  # a garbage line
    lines = cells[2].read_text().splitlines(keepends=True)
    cells[2].write_text("".join(lines[:-2]))                    # cut at a line end
    os.unlink(cells[3])
    os.symlink("/dev/zero", cells[3])                           # not a file at all
    (out / "samples.csv").unlink()
    (out / "summary.csv").unlink()
    notes: list[str] = []
    run_study(spec, out, quiet=True, dataset=synthetic_dataset(), resume=True,
              figures=False, log=notes.append)
    assert tree(out) == want
    assert len(notes) == 4 and all("incomplete or damaged" in n and "computing the cell "
                                   "again" in n for n in notes), notes


def test_resume_rewrites_a_truncated_given_dataset_file(tmp_path):
    spec = load_spec(spec_file(tmp_path))
    ref, want = _reference(tmp_path)
    out = tmp_path / "run"
    run_study(spec, out, quiet=True, dataset=synthetic_dataset(), figures=False)
    (ds,) = (out / "datasets").iterdir()
    ds.write_bytes(ds.read_bytes()[:100])
    run_study(spec, out, quiet=True, dataset=synthetic_dataset(), resume=True, figures=False)
    assert tree(out) == want


def test_a_damaged_rendered_dataset_file_is_not_trusted(tmp_path):
    """``datasets/<key>.json`` of a rendered dataset: truncated, edited to another key,
    another format, a FIFO: each left to be computed again, with one note."""
    doc = {**synthetic_dataset(), "key": "k" * 20}
    (tmp_path / "datasets").mkdir()
    path = tmp_path / "datasets" / f"{'k' * 20}.json"
    from rasc.io import dumps_json
    good = dumps_json(doc)
    notes: list[str] = []
    path.write_text(good)
    assert _found_datasets(tmp_path, ["k" * 20], notes.append) == {"k" * 20: doc}
    short = synthetic_dataset()
    short["eyes"]["left"]["T_cam_from_world"].pop()
    bad = [good[: len(good) // 2], dumps_json({**doc, "key": "j" * 20}),
           dumps_json({**doc, "format": "rasc-study-dataset/9"}),
           dumps_json({**short, "key": "k" * 20}), "[]"]
    for text in bad:
        path.write_text(text)
        assert _found_datasets(tmp_path, ["k" * 20], notes.append) == {}
    path.unlink()
    os.mkfifo(path)
    assert _found_datasets(tmp_path, ["k" * 20], notes.append) == {}
    assert len(notes) == len(bad) + 1
    assert all("incomplete or damaged" in n for n in notes)


HEADER = SAMPLE_COLUMNS
METHODS = ("rasc", "li")
finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@st.composite
def cell_texts(draw):
    samples = draw(st.integers(1, 4))
    rows = []
    for s in range(samples):
        for m in METHODS:
            status = draw(st.sampled_from(["ok", "gross", "non-finite", "failed: X"]))
            nums = ([draw(finite) for _ in range(4)] if status in ("ok", "gross")
                    else [float("nan")] * 4)
            rows.append([s, m, status, *nums])
    return samples, csv_text(HEADER, rows)


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cell_texts(), st.data())
def test_a_cell_file_is_accepted_whole_and_refused_when_cut_or_spoiled(tmp_path_factory,
                                                                     case, data):
    """Any whole cell file is accepted as written; any cut (at any byte) and any garbage
    line (anywhere) is refused: a resumed study never counts fewer or more samples."""
    samples, text = case
    path = tmp_path_factory.mktemp("cell") / "cell.csv"
    path.write_text(text)
    assert verified_cell(path, HEADER, samples, METHODS) == (text, None)
    cut = data.draw(st.integers(0, len(text) - 1))
    path.write_text(text[:cut])
    got, why = verified_cell(path, HEADER, samples, METHODS)
    assert got is None and why
    lines = text.split("\n")
    at = data.draw(st.integers(1, len(lines) - 1))
    junk = data.draw(st.text(st.characters(codec="utf-8", exclude_characters="\n\r"),
                             max_size=30))
    path.write_text("\n".join(lines[:at] + [junk] + lines[at:]))
    got, why = verified_cell(path, HEADER, samples, METHODS)
    assert got is None and why


# --------------------------------------------------- tracebacks: bounded work, paths

BOUNDS = [
    ("bootstrap = 1000000000", "spec.toml: bootstrap: expected an integer from 100 to "),
    ("bootstrap = 1000000\nsamples_ = 0", "spec.toml: bootstrap: "),
    ("[fixed]\npositions = 999999997", "spec.toml: fixed.positions: expected an integer "
                                        "from 3 to 400"),
    ("[fixed]\nintrinsics_views = 100000", "spec.toml: fixed.intrinsics_views: "),
    ("[fixed]\nblur = 1000", "spec.toml: fixed.blur: expected a number from 0 to 50"),
    ("[fixed]\nimage_noise = 300", "spec.toml: fixed.image_noise: expected a number "),
    ("[axes]\nmotion_deg = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]\n"
     "distance = [0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4]\n"
     "image_noise = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10]\n"
     "positions = [400]", "spec.toml: axes.positions: 1100 rendered dataset(s)"),
    ("time_limit_s = -1", "spec.toml: time_limit_s: expected a number > 0"),
]


@pytest.mark.parametrize(("extra", "message"), BOUNDS)
def test_work_beyond_the_bounds_is_refused_from_the_spec_naming_the_key(tmp_path, extra,
                                                                       message):
    head = "seed = 0\nsamples = 30\nmethods = ['rasc']\n"
    if "samples_" in extra:           # bootstrap x samples beyond one interval's draws
        head, extra = head.replace("samples = 30", "samples = 1000"), extra.split("\n")[0]
    top, _, tables = extra.partition("[")
    text = head + top + ("\n[" + tables if tables else "") + "\n"
    with pytest.raises(InputError) as info:
        load_spec(spec_file(tmp_path, text))
    msg = str(info.value)
    assert message in msg and "\n" not in msg and "--" not in msg


def test_an_output_folder_that_cannot_be_made_is_one_line_exit_2(tmp_path, capsys):
    from rasc.cli import main
    spec = spec_file(tmp_path, "seed = 0\nsamples = 2\nmethods = ['rasc']\n")
    for out in ("/proc/x", "/sys/x", str(tmp_path / "no" / "such")):
        assert main(["study", str(spec), "--out", out, "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("rasc study: error: ") \
            and "Traceback" not in err, err
    assert not os.path.exists("/proc/x")


def test_render_errors_name_the_spec_key_not_a_flag():
    """RenderOptions' fields are the spec's keys: its messages name them as a study spec
    does, and only a command (rasc render) maps them to its flags."""
    from rasc.errors import InputError
    from rasc.sim.render import RenderOptions
    for field, value in (("distance", -1.0), ("blur", 99.0), ("image_noise", -2.0),
                         ("intrinsics_views", 2)):
        with pytest.raises(InputError) as e:
            RenderOptions(**{field: value}).validate()
        assert str(e.value).startswith(field) and "--" not in str(e.value)
    with pytest.raises(InputError, match=r"^--distance must be a positive number"):
        RenderOptions(distance=-1.0).validate({"distance": "--distance"})


# ------------------------------------------------------------ plugins in a study

PLUGIN = '''
import os, sys, time
from rasc.handeye.methods import solve

def prints(T_cw, T_gp, **kw):
    print("plugin output on stdout")
    return solve("rasc", T_cw, T_gp, **kw).T_cam_from_gaze

def exits(T_cw, T_gp, **kw):
    sys.exit(0)

def osexit(T_cw, T_gp, **kw):
    os._exit(3)

def hangs(T_cw, T_gp, **kw):
    while True:
        time.sleep(0.05)

def crashes(T_cw, T_gp, **kw):
    import signal
    os.kill(os.getpid(), signal.SIGKILL)
'''


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    (tmp_path / "faultyplug.py").write_text(PLUGIN)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        [str(tmp_path), *filter(None, [os.environ.get("PYTHONPATH")])]))
    return "faultyplug"


def _plugin_spec(tmp_path, fn: str, limit: float | None = None, samples: int = 2) -> Path:
    text = (f"seed = 0\nsamples = {samples}\nmethods = ['rasc', 'faultyplug:{fn}']\n"
            + (f"time_limit_s = {limit}\n" if limit else "")
            + "[fixed]\nnoise_level = 1\n")
    return spec_file(tmp_path, text, f"{fn}.toml")


@pytest.mark.parametrize(("fn", "status"), [("prints", "ok"), ("exits", "failed: PluginExited"),
                                            ("osexit", "failed: PluginExited"),
                                            ("hangs", "failed: PluginTimedOut")])
def test_a_plugin_that_prints_exits_or_hangs_is_a_sample_not_the_process(
        tmp_path, plugin, capfd, fn, status):
    spec = load_spec(_plugin_spec(tmp_path, fn, limit=0.3))
    out = tmp_path / "out"
    run_study(spec, out, quiet=True, dataset=synthetic_dataset(), figures=False)
    rows = list(csv.DictReader(io.StringIO((out / "samples.csv").read_text())))
    mine = [r for r in rows if r["method"] == f"faultyplug:{fn}"]
    assert len(mine) == 2 and {r["status"] for r in mine} == {status}
    assert {r["status"] for r in rows if r["method"] == "rasc"} == {"ok"}
    cap = capfd.readouterr()
    assert cap.out == ""                                  # stdout stays rasc's
    if fn == "prints":
        assert cap.err.count("plugin output on stdout") == 2


@pytest.mark.slow
def test_a_crashed_worker_is_one_line_naming_the_plugin(tmp_path, plugin):
    from rasc.study.executors import WorkerCrashed
    spec = load_spec(_plugin_spec(tmp_path, "crashes"))
    with pytest.raises(WorkerCrashed) as info:
        run_study(spec, tmp_path / "out", quiet=True, dataset=synthetic_dataset(),
                  workers=2, figures=False)
    msg = str(info.value)
    assert "\n" not in msg and "faultyplug:crashes" in msg and "worker process" in msg
    assert not (tmp_path / "out").exists()           # nothing finished: nothing kept


@pytest.mark.slow
def test_plugins_in_pool_workers_fail_their_samples_only(tmp_path, plugin, capfd):
    spec = load_spec(_plugin_spec(tmp_path, "osexit"))
    run_study(spec, tmp_path / "out", quiet=True, dataset=synthetic_dataset(), workers=2,
              figures=False)
    text = (tmp_path / "out" / "samples.csv").read_text()
    assert text.count("failed: PluginExited") == 2
    assert capfd.readouterr().out == ""


def test_dataset_names_stay_as_before():
    """The study's dataset names (file names in every study folder) are unchanged by the
    dataset service: the reproduction's bytes depend on them."""
    assert dataset_name({"blur": 1.0}, 0) == "dfc2ee4099a6685dd2bd"  # the value at 4cd7de8


def test_the_old_name_dataset_key_warns_at_the_callers_line():
    """``dataset_key`` (renamed ``dataset_name``: a name, not a cache key) still works
    until rasc 0.4, with a DeprecationWarning attributed to the line that used it."""
    from rasc.study import datasets, engine

    def users_line(module):
        return module.dataset_key

    for module in (datasets, engine):
        with pytest.warns(DeprecationWarning, match="dataset_name") as caught:
            assert users_line(module) is dataset_name
        assert [(w.filename, w.lineno) for w in caught] == \
            [(__file__, users_line.__code__.co_firstlineno + 1)]
    with pytest.raises(AttributeError):
        datasets.no_such_name  # noqa: B018
