"""The handeye room's rig: ``rasc_cli`` and ``rasc_testing_cache``
(:mod:`shared_fixtures`), and examples/my_solver installed once per run.

``my_solver_site``: examples/my_solver installed once per run (``pip install --no-deps
--target SITE`` of a copy, as a user's ``pip install ./examples/my_solver``); put SITE on
PYTHONPATH. Read-only. The nominal rig the solver tests draw from is
:mod:`nominal_rig` (imported by the modules).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import shared_fixtures as shared
from running import pip_build_flags

# this room's fixtures of shared_fixtures
rasc_cli = shared.rasc_cli
rasc_testing_cache = shared.rasc_testing_cache

#: the user's solver package (docs/guide/solver.md, "Bring your own solver") and of rasc.testing
MY_SOLVER = shared.REPO / "examples" / "my_solver"


@pytest.fixture(scope="session")
def my_solver_site(tmp_path_factory) -> Path:
    """examples/my_solver installed by ``pip install --no-deps --target SITE`` (this
    environment's dependencies, no network) from a copy (building in place would leave
    build/ in the checkout); once per run, under a file lock as the dataset. Read-only."""
    root = shared.shared_root(tmp_path_factory)
    site, done = root / "my_solver_site", root / "my_solver_site.done"
    with shared.locked(root / "my_solver_site.lock"):
        if not done.is_file():                        # written last: the install is whole
            src = root / "my_solver_src"
            for folder in (site, src):
                shutil.rmtree(folder, ignore_errors=True)
            shutil.copytree(MY_SOLVER, src, ignore=shutil.ignore_patterns(
                "__pycache__", "build", "*.egg-info"))
            proc = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet",
                                   "--no-deps", *pip_build_flags(), "--target", str(site),
                                   str(src)], capture_output=True, text=True, timeout=600,
                                  check=False)
            assert proc.returncode == 0, proc.stdout + proc.stderr
            done.write_text("")
    return site
