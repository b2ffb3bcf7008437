"""The study room's rig: the rendered default dataset and its calibration
(:mod:`shared_fixtures`), and a short temporary folder for pooled children.

``short_tmp``: an empty folder with a short path, for a subprocess's TMPDIR (see its
docstring). The interrupt tests look for leftover processes with
:func:`running.marked_processes`.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import pytest

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
default_calibration = shared.default_calibration
default_dataset = shared.default_dataset


@pytest.fixture
def short_tmp():
    """An empty folder with a short path, for a subprocess's TMPDIR: multiprocessing's
    forkserver binds a Unix socket there, and a socket path has at most 107 bytes
    (pytest's tmp_path under an xdist worker can be longer: "AF_UNIX path too long")."""
    path = Path(tempfile.mkdtemp(prefix="rasc-t-", dir="/tmp"))
    yield path
    shutil.rmtree(path, ignore_errors=True)
