"""Atomic, deterministic output (rasc.io)."""

import json
import os
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rasc.errors import InputError
from rasc.io import check_output, dumps_json, write_json_atomic

from json_strategies import json_documents

json_values = json_documents(
    st.none() | st.booleans() | st.integers(-10**12, 10**12)
    | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=8), key_size=5)


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(json_values)
def test_dumps_json_round_trips(value):
    # the compact number-array layout must never change what the JSON says
    assert json.loads(dumps_json(value)) == json.loads(json.dumps(value))


def test_matrix_rows_on_one_line_and_strings_untouched():
    text = dumps_json({"T": np.eye(2), "s": "[1,\n 2]", "v": [1.5, -2e-9]})
    assert '"T": [\n    [1.0, 0.0],\n    [0.0, 1.0]\n  ]' in text
    assert '"v": [1.5, -2e-09]' in text
    assert json.loads(text)["s"] == "[1,\n 2]"
    assert dumps_json({"b": 1, "a": 2}) == dumps_json({"a": 2, "b": 1})  # sorted keys


def test_nan_is_refused():
    with pytest.raises(ValueError):
        dumps_json({"x": float("nan")})


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.json"
    with pytest.raises(ValueError):
        write_json_atomic(target, {"x": float("nan")})
    assert os.listdir(tmp_path) == []
    write_json_atomic(target, {"x": 1})
    assert json.loads(target.read_text()) == {"x": 1}


def test_unwritable_paths(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        check_output(tmp_path / "missing" / "x.json")
    with pytest.raises(InputError, match="is a folder"):
        check_output(tmp_path)
    with pytest.raises(InputError, match="does not exist"):
        write_json_atomic(tmp_path / "missing" / "x.json", {})


@pytest.mark.parametrize("argv, fragment", [
    (["render", "--seed", "abc"], "rasc render: error: argument --seed: invalid int value"),
    (["handeye", "x.json", "--method", "bogus"], "rasc handeye: error: method 'bogus'"),
    ([], "rasc: error: the following arguments are required"),
])
def test_usage_errors_are_one_line(argv, fragment, capsys):
    """argparse's errors (SystemExit 2) and the commands' own (status 2) look alike."""
    from rasc.cli import main

    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(fragment)


# ------------------------------------------------------------------ the output rule

def test_check_output_refuses_inputs_by_any_name(tmp_path, monkeypatch):
    from rasc.io import check_output

    monkeypatch.chdir(tmp_path)
    (tmp_path / "ds" / "poses").mkdir(parents=True)
    manifest = tmp_path / "ds" / "manifest.json"
    manifest.write_text("{}")
    image = tmp_path / "ds" / "poses" / "a.png"
    image.write_bytes(b"")
    os.symlink(manifest, tmp_path / "link.json")
    os.link(image, tmp_path / "hard.png")
    inputs = [manifest, image]
    for out in ("ds/manifest.json", "ds/poses/../manifest.json", "link.json", "hard.png",
                str(image)):
        with pytest.raises(InputError, match="is the input file"):
            check_output(out, inputs=inputs, input_folders=[tmp_path / "ds"])
    (tmp_path / "ds" / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match="is a file of the input dataset"):
        check_output("ds/notes.txt", inputs=inputs, input_folders=[tmp_path / "ds"])
    # a new file beside the inputs, or inside the dataset folder, is an output like any other
    assert check_output("ds/cal.json", inputs=inputs, input_folders=[tmp_path / "ds"]) \
        == tmp_path.joinpath("ds/cal.json").relative_to(tmp_path)
    check_output("cal.json", inputs=inputs)


@pytest.mark.parametrize("out, kind, fragment", [
    ("", "file", "--out: empty path"),
    (".", "file", "names a folder"),
    ("sub/", "file", "names a folder"),
    ("sub", "file", "it is a folder"),
    ("fifo", "file", "not a regular file"),
    ("", "folder", "--out: empty path"),
    (".", "folder", "the current or parent folder"),
    ("sub/..", "folder", "the current or parent folder"),
    ("link", "folder", "is a symbolic link"),
    ("file.txt", "folder", "exists as a file"),
    ("missing/new", "folder", "folder missing does not exist"),
])
def test_check_output_refuses_what_is_no_output(out, kind, fragment, tmp_path, monkeypatch):
    from rasc.io import check_output

    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "file.txt").write_text("x")
    os.mkfifo(tmp_path / "fifo")
    os.symlink(tmp_path / "sub", tmp_path / "link")
    with pytest.raises(InputError, match=re.escape(fragment)):
        check_output(out, kind=kind)
    assert sorted(os.listdir(tmp_path)) == ["fifo", "file.txt", "link", "sub"]


def test_write_stdout_on_a_full_device_is_one_error(monkeypatch):
    from rasc.io import write_stdout

    class Full:
        def write(self, text):
            raise OSError(28, "No space left on device")

        def flush(self):
            pass

        def fileno(self):
            raise ValueError("no descriptor")

    monkeypatch.setattr("sys.stdout", Full())
    with pytest.raises(InputError, match="^standard output: cannot write: No space left"):
        write_stdout("{}\n")


def test_module_files_follows_every_import_of_the_package(tmp_path):
    """module_files: absolute, relative and in-function imports, ``from p import module``,
    the packages on the way; not other packages, not names that are no module, and a
    circle ends."""
    from rasc.io import module_files

    pkg = tmp_path / "pkg"
    files = {
        "__init__.py": "",
        "a/__init__.py": "from . import b\n",
        "a/b.py": "import os\nfrom ..c import name\n",
        "a/unused.py": "",
        "c/__init__.py": "",
        "c/name.py": "def f():\n    import pkg.d.e\n",
        "d/__init__.py": "from pkg.a import b  # a circle\n",
        "d/e.py": "from pkg.c import not_a_module, name as n\nimport numpy\n",
        "f.py": "import pkg.a.b\n",
    }
    for rel, text in files.items():
        (pkg / rel).parent.mkdir(parents=True, exist_ok=True)
        (pkg / rel).write_text(text)
    got = [p.relative_to(pkg).as_posix() for p in module_files(pkg, ["pkg.a"])]
    assert got == ["__init__.py", "a/__init__.py", "a/b.py", "c/__init__.py", "c/name.py",
                   "d/__init__.py", "d/e.py"]
    assert [p.name for p in module_files(pkg, ["pkg.f"])][-1] == "f.py"
    assert module_files(pkg, ["other.a", "pkg.missing"]) == []
