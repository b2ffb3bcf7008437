"""examples/my_solver: a user's own solver package with its own regression tests built on
rasc.testing. CI runs those tests as a user would (``pytest -p rasc.testing``), first by
``module:function`` without installing the package, then installed (its entry point in
``rasc.methods`` makes ``--method my-solver`` work). The install (handeye/conftest.py's
``my_solver_site``) and the dataset cache the example's rendered-images test fills
(conftest's ``rasc_testing_cache``) are made once per run and shared with
the examples of docs/guide/solver.md (tests/docs)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
#: the user's solver package (handeye/conftest.py installs it: ``my_solver_site``)
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
def test_example_suite_passes_without_installing(rasc_testing_cache):
    proc = _example_tests(_env(EXAMPLE_PKG), rasc_testing_cache)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "8 passed, 1 skipped" in proc.stdout, proc.stdout
    assert "my-solver is not installed" in proc.stdout


@pytest.mark.slow
def test_example_installed_registers_my_solver(my_solver_site, rasc_testing_cache, tmp_path):
    """``pip install`` (into a target folder, no dependencies: they are this
    environment's; conftest's ``my_solver_site``) registers ``my-solver``; rasc handeye
    then takes it by name, and the example's own entry-point test runs instead of
    skipping."""
    site = my_solver_site
    out = tmp_path / "result.json"
    proc = subprocess.run([sys.executable, "-m", "rasc", "handeye", str(POSES), "--method",
                           "my-solver", "--out", str(out)], capture_output=True, text=True,
                          env=_env(site), cwd=tmp_path, timeout=300)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["method"] == "my-solver" and doc["uncertainty"]["rotation_deg"] > 0
    proc = _example_tests(_env(site), rasc_testing_cache)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "9 passed" in proc.stdout, proc.stdout
