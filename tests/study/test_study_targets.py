"""``rasc study``'s ``target`` axis and ``positions_file`` (issue 23): checked spec keys,
cell identities unchanged at their defaults, and one tiny rendered study with a ChArUco
target and a positions file."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_study import assert_refused, write

from rasc.study import load_spec, run_study
from rasc.study.spec import PARAMS, poses_of

HEAD = "seed = 5\nsamples = 2\nmethods = ['rasc']\n"
POSITIONS = "pan,tilt\n0,0\n6,4\n-6,4\n6,-4\n"


BAD = [
    ("[axes]\ntarget = ['charuco:8x6,0.1']\n", "axes.target[0]: expected charuco:"),
    ("[fixed]\ntarget = 'board'\n", "fixed.target: expected chessboard:NXxNY,SQUARE, charuco:"),
    ("[fixed]\ntarget = 'chessboard:9x6'\n", "fixed.target: expected chessboard:NXxNY"),
    ("[fixed]\npositions_file = 'missing.csv'\n", "fixed.positions_file: "),
    ("[fixed]\ntarget = 'charuco:8x6,0.1,0.075'\nintrinsics_from = 'dataset'\n",
     "fixed.target: a target is drawn in the rendered scene, not the base dataset's; not "
     "with intrinsics_from"),
]


@pytest.mark.parametrize(("text", "message"), BAD)
def test_bad_target_or_positions_file_is_one_line_naming_the_key(tmp_path, capsys, text,
                                                                  message):
    assert_refused(tmp_path, capsys, HEAD + text, message)


def test_a_positions_file_with_too_few_positions_names_file_and_key(tmp_path, capsys):
    (tmp_path / "two.csv").write_text("0,0\n4,4\n")
    line = assert_refused(tmp_path, capsys, HEAD + "[fixed]\npositions_file = 'two.csv'\n",
                          "fixed.positions_file: ")
    assert "two.csv: 2 positions; expected 3 to" in line


def test_defaults_leave_cell_keys_unchanged_and_the_file_gives_the_positions(tmp_path):
    """target = '' and positions_file = '' are the old behaviour: the same cell keys as a
    spec without them. A positions file's positions (not its name) are the cell's."""
    plain = load_spec(write(tmp_path, HEAD + "[axes]\neye = ['left', 'right']\n", "a.toml"))
    given = load_spec(write(tmp_path, HEAD + "[fixed]\ntarget = ''\npositions_file = ''\n"
                            "[axes]\neye = ['left', 'right']\n", "b.toml"))
    assert [c.key for c in plain.cells()] == [c.key for c in given.cells()]
    (tmp_path / "p.csv").write_text(POSITIONS)
    (tmp_path / "q.csv").write_text("# the same positions, another file\n" + POSITIONS)
    spec = load_spec(write(tmp_path, HEAD + "[axes]\npositions_file = ['p.csv', 'q.csv']\n"
                           "target = ['', 'charuco:8x6,0.1,0.075']\n", "c.toml"))
    cells = spec.cells()
    assert len(cells) == 4
    want = ((0.0, 0.0), (6.0, 4.0), (-6.0, 4.0), (6.0, -4.0))
    assert all(poses_of(c.params) == want for c in cells)
    assert cells[0].axes["positions_file"] == "p.csv"
    by_target = {}
    for c in cells:
        by_target.setdefault(c.params["target"], set()).add(c.key)
    # same positions in both files: one identity per target; two targets: two identities
    assert [len(v) for v in by_target.values()] == [1, 1] and len(by_target) == 2
    assert poses_of({k: p.default for k, p in PARAMS.items()})[0] == (0.0, 0.0)


def test_every_target_and_a_model_with_a_target_are_accepted(tmp_path):
    """Every target rasc reads is a study's too (the AprilGrid was refused by the message
    only, not the check), and a model takes a target in place of its own, as ``rasc
    render --model M --target T`` does."""
    from rasc.sim.scene import SCENE_XML

    spec = load_spec(write(tmp_path, HEAD + f"[fixed]\nmodel = '{SCENE_XML}'\n[axes]\n"
                           "target = ['aprilgrid:6x4,0.1,0.3', 'charuco:8x6,0.1,0.075']\n"))
    cells = spec.cells()
    assert [c.params["target"] for c in cells] == ["aprilgrid:6x4,0.1,0.3",
                                                   "charuco:8x6,0.1,0.075"]
    assert all(c.params["model"].startswith("sha256:") for c in cells)   # its digest
    assert len({c.key for c in cells}) == 2


@pytest.mark.slow
def test_tiny_study_with_a_charuco_target_and_a_positions_file(tmp_path, monkeypatch):
    """Rendered and calibrated by the real pipeline: the ChArUco dataset's documents hold
    the positions of the file and the ChArUco board's corners (7×5 for 8×6 squares), and
    every sample has finite errors."""
    monkeypatch.setenv("RASC_CACHE_DIR", "none")
    (tmp_path / "p.csv").write_text(POSITIONS)
    spec = write(tmp_path, HEAD + "[fixed]\nintrinsics_views = 4\npositions_file = 'p.csv'\n"
                 "target = 'charuco:8x6,0.1,0.075'\n[axes]\neye = ['left', 'right']\n")
    result = run_study(load_spec(spec), tmp_path / "out", quiet=True, workers=1)
    docs = [json.loads(p.read_text()) for p in (tmp_path / "out" / "datasets").glob("*.json")]
    assert len(docs) == 1
    doc = docs[0]
    assert doc["board"]["inner_corners"] == [7, 5]
    for eye in ("left", "right"):
        got = np.degrees(np.asarray(doc["eyes"][eye]["pan_tilt_rad"]))
        np.testing.assert_allclose(got, [[0, 0], [6, 4], [-6, 4], [6, -4]], atol=1e-9)
        assert np.asarray(doc["eyes"][eye]["corners"][0]).shape == (35, 2)
    rows = result.samples_text.strip().splitlines()
    assert len(rows) == 1 + 2 * 2            # header, 2 eyes x 2 samples
    head = rows[0].split(",")
    col = head.index("translation_mm")
    assert all(np.isfinite(float(r.split(",")[col])) for r in rows[1:])
