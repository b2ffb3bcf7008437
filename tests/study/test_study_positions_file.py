"""A study's ``positions_file`` (issue 30's hostile leftovers): a device is named as one
(not "not found"), and a position the head cannot take is attributed to the file and the
position's index, not to the grid's keys (layout, positions, motion_deg)."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import pytest
from test_study import assert_refused

from rasc.errors import InputError
from rasc.sim.render import parse_poses, read_positions

HEAD = "seed = 5\nsamples = 2\nmethods = ['rasc']\n"


def test_a_device_is_not_a_positions_file(tmp_path, capsys):
    with pytest.raises(InputError, match="^/dev/zero: not a regular file"):
        read_positions("/dev/zero")
    with pytest.raises(InputError, match="^/dev/zero: not a regular file"):
        parse_poses("/dev/zero", "--poses")        # rasc render --poses: a file, not a list
    with pytest.raises(InputError, match="missing.csv: positions file not found"):
        read_positions(tmp_path / "missing.csv")
    line = assert_refused(tmp_path, capsys, HEAD + "[fixed]\npositions_file = '/dev/zero'\n",
                          "fixed.positions_file: /dev/zero: not a regular file")
    assert "not found" not in line


def test_a_position_the_head_cannot_take_names_the_file_and_the_position(tmp_path, capsys,
                                                                          monkeypatch):
    monkeypatch.setenv("RASC_CACHE_DIR", "none")
    (tmp_path / "bad.csv").write_text("pan,tilt\n0,0\n6,4\n200,4\n6,-4\n")
    line = assert_refused(tmp_path, capsys, HEAD + "[fixed]\nintrinsics_views = 4\n"
                          "positions_file = 'bad.csv'\n",
                          "positions_file bad.csv: item 2 (200,4): left pan = 200 deg is "
                          "outside the joint range")
    assert "layout" not in line and "motion_deg" not in line
