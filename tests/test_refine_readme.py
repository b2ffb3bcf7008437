"""README "Whole-head refinement": the example runs as a user types it, prints what its
comments say, and the paper model's run warns with the remedy."""

from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
TITLE = "### Whole-head refinement (`rasc calibrate --model general`)"


def blocks(kind: str) -> list[str]:
    text = README.read_text()
    start = text.index(TITLE)
    end = text.index("\n### ", start + 1)
    return re.findall(rf"```{kind}\n(.*?)```", text[start:end], re.S)


@pytest.mark.slow
def test_readme_refinement_example(tmp_path, monkeypatch):
    # the three commands as typed, through the command line's own entry (rasc.cli.main)
    # in this process: their status and stderr are the claim, not the process boundary
    # (test_hostile and test_cli_* hold that for every command)
    from rasc.cli import main

    (sh,) = blocks("sh")
    monkeypatch.setenv("MUJOCO_GL", os.environ.get("MUJOCO_GL", "egl"))
    monkeypatch.chdir(tmp_path)
    results = []
    for line in sh.strip().splitlines():
        cmd = line.split("#")[0].split()
        assert cmd[0] == "rasc"
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = main(cmd[1:])
        results.append(SimpleNamespace(returncode=status, stderr=err.getvalue()))
    assert [r.returncode for r in results] == [0, 0, 0], [r.stderr for r in results]
    assert results[1].stderr == ""                     # general: fits, nothing to warn
    (warning,) = results[2].stderr.splitlines()
    assert warning.startswith("rasc calibrate: warning: the paper's pan-tilt model (eq. 3) "
                              "does not fit the pose views")
    assert warning.endswith("use --model general")
    assert sorted(p.name for p in (tmp_path / "plots").iterdir()) == [
        "residuals_left.png", "residuals_right.png"]
    (py,) = blocks("python")
    monkeypatch.chdir(tmp_path)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(py, "README.md", "exec"), {})
    expected = [m.group(1).split(":")[0].split(" (")[0].strip()
                for m in re.finditer(r"#\s*(.+)$", py, re.M)]
    printed = out.getvalue().splitlines()
    # the comments give each printed line (the last comment is the whole list)
    assert printed[0] == expected[0] and printed[1] == expected[1]
    assert printed[2] == "None"
    assert printed[3] == expected[-1]
