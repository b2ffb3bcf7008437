"""examples/my_solver: a user's own solver package with its own regression tests built on
rasc.testing. CI runs those tests as a user would (``pytest -p rasc.testing``), first by
``module:function`` without installing the package, then installed (its entry point in
``rasc.methods`` makes ``--method my-solver`` work)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import pip_build_flags

REPO = Path(__file__).resolve().parents[1]
EXAMPLE_PKG = REPO / "examples" / "my_solver"
POSES = REPO / "examples" / "handeye_nine_poses.json"


def _env(pythonpath: Path, **extra) -> dict:
    return dict(os.environ, PYTHONPATH=str(pythonpath), PYTEST_DISABLE_PLUGIN_AUTOLOAD="1",
                MUJOCO_GL="egl", **extra)


def _example_tests(env: dict, cache: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "rasc.testing",
                           "-p", "no:cacheprovider", "-q", "-rs", "--rasc-cache-dir",
                           str(cache)], cwd=EXAMPLE_PKG, capture_output=True, text=True,
                          env=env, timeout=900)


@pytest.mark.slow
def test_example_suite_passes_without_installing(tmp_path):
    proc = _example_tests(_env(EXAMPLE_PKG), tmp_path / "cache")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "8 passed, 1 skipped" in proc.stdout, proc.stdout
    assert "my-solver is not installed" in proc.stdout


@pytest.mark.slow
def test_example_installed_registers_my_solver(tmp_path):
    """``pip install`` (into a target folder, no dependencies: they are this
    environment's) registers ``my-solver``; rasc handeye then takes it by name, and the
    example's own entry-point test runs instead of skipping."""
    src = tmp_path / "my_solver"   # a copy: building in place would leave build/ behind
    shutil.copytree(EXAMPLE_PKG, src, ignore=shutil.ignore_patterns(
        "__pycache__", "build", "*.egg-info"))
    site = tmp_path / "site"
    pip = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                          *pip_build_flags(), "--target", str(site), str(src)],
                         capture_output=True, text=True, timeout=600)
    assert pip.returncode == 0, pip.stdout + pip.stderr
    out = tmp_path / "result.json"
    proc = subprocess.run([sys.executable, "-m", "rasc", "handeye", str(POSES), "--method",
                           "my-solver", "--out", str(out)], capture_output=True, text=True,
                          env=_env(site), cwd=tmp_path, timeout=300)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["method"] == "my-solver" and doc["uncertainty"]["rotation_deg"] > 0
    proc = _example_tests(_env(site), tmp_path / "cache")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "9 passed" in proc.stdout, proc.stdout
