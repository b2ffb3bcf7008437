"""Running rasc, pip and child processes from the tests (plain functions, no fixtures).

Import them from any room (``from running import python_rasc``; tests/ is on sys.path
through the root conftest):

- ``python_rasc(*argv)``: ``python -m rasc ARGV`` in a subprocess.
- ``run_rasc(argv, capsys)``: ``rasc ARGV`` in this process (behind the ``rasc_cli``
  fixture of :mod:`shared_fixtures` and the CLI modules' ``run_cli``).
- ``pip_build_flags()``: ``["--no-build-isolation"]`` when this environment has the build
  backend pyproject asks for (setuptools >= 77, in the ``test`` extra), else ``[]``: the
  tests' ``pip install``/``pip wheel`` of local folders then build without a fresh build
  environment (about 2 s of CPU less each, and no registry or pip cache needed).
- ``marked_processes(mark)``: the processes left of an interrupted child's tree.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path


def python_rasc(*argv, cwd=None) -> subprocess.CompletedProcess:
    """``python -m rasc ARGV`` in a subprocess (text output captured, 300 s limit)."""
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    return subprocess.run([sys.executable, "-m", "rasc", *map(str, argv)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300, check=False)


def run_rasc(argv, capsys) -> tuple[int, str, str]:
    """``rasc ARGV`` in this process (:func:`rasc.cli.main`, arguments as ``str``):
    ``(status, stdout, stderr)``, a usage error's SystemExit giving its status; ``capsys``
    is the test's fixture (emptied first). Behind the ``rasc_cli`` fixture and the CLI
    test modules' ``run_cli``."""
    from rasc.cli import main

    capsys.readouterr()
    try:
        status = main([str(a) for a in argv])
    except SystemExit as exc:
        status = exc.code
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def pip_build_flags() -> list[str]:
    """``["--no-build-isolation"]`` if setuptools >= 77 (pyproject's [build-system]
    requirement, also in the ``test`` extra) is importable here, else ``[]``."""
    try:
        import setuptools
    except ImportError:
        return []
    major = int(setuptools.__version__.split(".")[0])
    return ["--no-build-isolation"] if major >= 77 else []


def marked_processes(mark: str) -> list[int]:
    """The processes whose environment holds ``mark`` (a variable a test set in a child's
    environment: what is left of the child's process tree after it was interrupted)."""
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if mark.encode() in (d / "environ").read_bytes():
                    pids.append(int(d.name))
            except OSError:
                continue
    return pids
