"""The README's sections "Bring your own solver" and "Regression tests for your own code
(rasc.testing)": every example in them runs as printed.

Console blocks: each ``$ `` line is run by the shell from the repository's root with this
environment's ``rasc`` first on PATH; lines after it up to the next ``$ `` are its
expected output (stdout and stderr). ``pip install ./examples/my_solver`` is run as
``pip install --no-deps --target SITE`` on a copy (this environment's dependencies, no
build/ left in the checkout; once per run, conftest's ``my_solver_site``, shared with
tests/test_example_solver.py), with SITE put on PYTHONPATH for the lines after it.
Python blocks run as scripts (or, for the test file, under pytest) with
``examples/my_solver`` on PYTHONPATH."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import MY_SOLVER as EXAMPLE_PKG

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text(encoding="utf-8")


def section(title: str) -> str:
    start = README.index(f"\n## {title}\n")
    end = README.index("\n## ", start + 1)
    return README[start:end]


def blocks(text: str, lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", text, flags=re.S)


def _env(**extra) -> dict:
    env = dict(os.environ, MUJOCO_GL="egl", **extra)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    return env


def test_sections_stand_right_before_measured_figures():
    titles = re.findall(r"^## (.*)$", README, flags=re.M)
    i = titles.index("Measured figures")
    assert titles[i - 2:i] == ["Bring your own solver",
                               "Regression tests for your own code (rasc.testing)"]


@pytest.mark.slow
def test_bring_your_own_solver_console(my_solver_site):
    (block,) = blocks(section("Bring your own solver"), "console")
    commands: list[tuple[str, list[str]]] = []
    for line in block.splitlines():
        if line.startswith("$ "):
            commands.append((line[2:], []))
        else:
            commands[-1][1].append(line)
    assert len(commands) == 4
    extra_path: list[str] = []
    for command, expected in commands:
        if command.startswith("pip install ./examples/my_solver"):
            # the install itself: the my_solver_site fixture (pip exited 0), shared
            assert command == "pip install ./examples/my_solver" and not expected, command
            extra_path.append(str(my_solver_site))
            continue
        env = _env(PYTHONPATH=os.pathsep.join(extra_path))
        proc = subprocess.run(["bash", "-c", command], capture_output=True, text=True,
                              cwd=REPO, env=env, timeout=300)
        if expected:
            assert proc.returncode == 2, (command, proc.stdout, proc.stderr)
            assert (proc.stdout + proc.stderr).splitlines() == expected
        else:
            assert proc.returncode == 0, (command, proc.stderr)
            assert '"method": ' in proc.stdout
            name = shlex.split(command)[-1]
            assert f'"method": "{name}"' in proc.stdout


@pytest.mark.slow
def test_bring_your_own_solver_python(tmp_path):
    (code,) = blocks(section("Bring your own solver"), "python")
    script = tmp_path / "example.py"
    script.write_text(code, encoding="utf-8")
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          cwd=tmp_path, env=_env(PYTHONPATH=str(EXAMPLE_PKG)), timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("quality ")
    assert proc.stdout.splitlines()[1] == "module:function True"


@pytest.mark.slow
def test_rasc_testing_example_file(tmp_path, rasc_testing_cache):
    """The user's test file as printed, run as the README says (the plugin loads itself
    from the installed rasc), with the dataset cache in a temporary folder (the run's,
    conftest's ``rasc_testing_cache``: shared with tests/test_example_solver.py, whose
    suite asks for the same dataset)."""
    (code,) = blocks(section("Regression tests for your own code (rasc.testing)"), "python")
    (tmp_path / "test_mine.py").write_text(code, encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "test_mine.py"], capture_output=True, text=True, cwd=tmp_path,
                          env=_env(PYTHONPATH=str(EXAMPLE_PKG),
                                   RASC_CACHE_DIR=str(rasc_testing_cache)), timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "4 passed" in proc.stdout, proc.stdout
    assert "PYTHONPATH=examples/my_solver pytest test_mine.py" in section(
        "Regression tests for your own code (rasc.testing)")
