"""``rasc study``'s ``urdf`` parameter (issue 31): a head described in a URDF rendered in a
study's cells (rasc.sim.urdf.UrdfHead), its content digest in the cell's identity, cell
keys unchanged without it, refusals naming the key, and one tiny rendered study over a
URDF written by ``rasc export``."""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import numpy as np
import pytest
from test_study import assert_refused, write

from rasc.cli import main
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import PanTiltUnit
from rasc.head.model import EyeCalibration, HeadCalibration
from rasc.sim.synthetic import default_head
from rasc.study import load_spec, run_study

HEAD = "seed = 5\nsamples = 2\nmethods = ['rasc']\n"
#: an imperfect unit: tilt axis skewed and 10 mm off the pan axis, encoder zeros
UNIT = PanTiltUnit(tilt_axis=(0.02, 0.0, 1.0), tilt_point=(0.0, 0.01, 0.0),
                   pan_offset=0.01, tilt_offset=-0.005)


def _exported_urdf(folder: Path, capsys, tilt_down: bool = False) -> Path:
    """``rasc export --format urdf`` of a calibration of the imperfect head; with
    ``tilt_down``, its tilt joints' axes turned round (positive tilt lowers the gaze, REP
    103's pitch: the cameras look along the canonical base's -y)."""
    truth = default_head(UNIT)
    head = HeadCalibration(*(EyeCalibration(truth.K[eye], truth.dist[eye],
                                            truth.T_cam_from_gaze[eye],
                                            truth.T_ptu_from_base[eye], (1280, 960), UNIT)
                             for eye in EYES))
    cal, urdf = folder / "cal.json", folder / "head.urdf"
    cal.write_text(json.dumps(head.to_dict()))
    assert main(["export", str(cal), "--format", "urdf", "--out", str(urdf)]) == 0, \
        capsys.readouterr().err
    if tilt_down:
        text = urdf.read_text()
        axis = re.search(r'name="left_tilt".*?(<axis xyz="[^"]*"/>)', text, re.S).group(1)
        flipped = " ".join(f"{-float(v):.17g}" for v in axis.split('"')[1].split())
        urdf.write_text(text.replace(axis, f'<axis xyz="{flipped}"/>'))
    return urdf


BAD = [
    ("[fixed]\nurdf = 'missing.urdf'\n", "fixed.urdf: ", "missing.urdf: no such URDF file"),
    ("[fixed]\nurdf = 'head.urdf'\nmodel = 'head.urdf'\n", "fixed.urdf: ",
     "not with model = 'head.urdf'"),
    ("[fixed]\nurdf = 'head.urdf'\n[axes]\naxis_skew_deg = [0.0, 1.0]\n", "fixed.urdf: ",
     "not with axis_skew_deg = 1"),
    ("[fixed]\nurdf_joints = 'a,b,c,d'\n", "fixed.urdf_joints: ", "only with urdf"),
    ("[fixed]\nurdf = 'head.urdf'\nurdf_cameras = 'a'\n", "fixed.urdf_cameras: ",
     "expected 2 different comma-separated names"),
    ("[fixed]\nurdf = 'head.urdf'\nurdf_joints = 'a,b,a,d'\n", "fixed.urdf_joints: ",
     "expected 4 different comma-separated names"),
]


@pytest.mark.parametrize(("text", "key", "message"), BAD)
def test_bad_urdf_is_one_line_naming_the_key(tmp_path, capsys, text, key, message):
    (tmp_path / "head.urdf").write_text("<robot name='x'/>")
    line = assert_refused(tmp_path, capsys, HEAD + text, message)
    assert line.split(".toml: ", 1)[1].startswith(key), line


def test_the_urdf_digest_is_the_cells_identity_and_keys_are_unchanged_without_it(
        tmp_path, capsys):
    """No ``urdf`` (or its names at their defaults): today's cell keys. A URDF's bytes,
    not its file name, identify the cell; other joint names are another cell."""
    plain = load_spec(write(tmp_path, HEAD + "[axes]\neye = ['left', 'right']\n", "a.toml"))
    given = load_spec(write(tmp_path, HEAD + "[fixed]\nurdf = ''\nurdf_joints = "
                            "'left_pan, left_tilt, right_pan, right_tilt'\n"
                            "[axes]\neye = ['left', 'right']\n", "b.toml"))
    assert [c.key for c in plain.cells()] == [c.key for c in given.cells()]
    urdf = _exported_urdf(tmp_path, capsys)
    (tmp_path / "copy.urdf").write_bytes(urdf.read_bytes())
    spec = load_spec(write(tmp_path, HEAD + "[axes]\nurdf = ['head.urdf', 'copy.urdf']\n"
                           "urdf_joints = ['left_pan,left_tilt,right_pan,right_tilt', "
                           "'left_pan,left_tilt,right_pan,other']\n", "c.toml"))
    cells = spec.cells()
    digest = "sha256:" + hashlib.sha256(urdf.read_bytes()).hexdigest()
    assert {c.params["urdf"] for c in cells} == {digest}
    assert len({c.key for c in cells}) == 2          # the same bytes twice, two name sets
    assert all(c.key not in {p.key for p in plain.cells()} for c in cells)


@pytest.mark.slow
def test_tiny_study_over_an_exported_urdf(tmp_path, capsys, monkeypatch):
    """Rendered from the URDF and calibrated by the real pipeline: the dataset's document
    records the URDF's digest and the scene's truth is the exported imperfect unit (its
    tilt axis skewed from the pan axis and 10 mm off it; the stock head's is neither);
    every sample is estimated."""
    monkeypatch.setenv("RASC_CACHE_DIR", "none")
    urdf = _exported_urdf(tmp_path, capsys)
    spec = write(tmp_path, HEAD + "[fixed]\nurdf = 'head.urdf'\nintrinsics_views = 4\n"
                 "distance = 1.4\n")
    result = run_study(load_spec(spec), tmp_path / "out", quiet=True, workers=1)
    docs = [json.loads(p.read_text()) for p in (tmp_path / "out" / "datasets").glob("*.json")]
    assert len(docs) == 1
    doc = docs[0]
    assert doc["render"]["urdf"] == "sha256:" + hashlib.sha256(urdf.read_bytes()).hexdigest()
    assert doc["scene"]["model_file"] == "head.urdf"
    want_cos = UNIT.tilt_axis[0] / np.linalg.norm(UNIT.tilt_axis)
    for eye in EYES:
        unit = doc["scene"]["heads"][eye]["unit"]
        pan, tilt = np.asarray(unit["pan_axis"]), np.asarray(unit["tilt_axis"])
        assert abs(pan @ tilt - want_cos) < 1e-6
        assert abs(np.linalg.norm(unit["tilt_point"]) - 0.01) < 1e-6
    rows = [r.split(",") for r in result.samples_text.strip().splitlines()]
    assert len(rows) == 1 + 2
    status, col = rows[0].index("status"), rows[0].index("translation_mm")
    assert all(r[status] == "ok" and np.isfinite(float(r[col])) for r in rows[1:]), rows


@pytest.mark.slow
def test_pose_sets_of_a_tilt_down_urdf_face_the_target(tmp_path, capsys, monkeypatch):
    """``intrinsics_from = "dataset"`` renders the pose sets in the URDF head's scene with
    the target in front of its cameras (``sim.facing_target``), also for a head whose
    cameras look along the canonical base's -y (before: the target was placed along +y,
    behind the cameras, and the pose set was refused)."""
    monkeypatch.setenv("RASC_CACHE_DIR", "none")
    _exported_urdf(tmp_path, capsys, tilt_down=True)
    spec = write(tmp_path, HEAD + "[fixed]\nurdf = 'head.urdf'\nintrinsics_views = 4\n"
                 "distance = 1.4\nintrinsics_from = 'dataset'\n[axes]\n"
                 "motion_deg = [8.0, 6.0]\n")
    result = run_study(load_spec(spec), tmp_path / "out", quiet=True, workers=1)
    docs = [json.loads(p.read_text()) for p in (tmp_path / "out" / "datasets").glob("*.json")]
    assert sorted("intrinsics_of" in d for d in docs) == [False, True]   # base + pose set
    rows = [r.split(",") for r in result.samples_text.strip().splitlines()]
    status = rows[0].index("status")
    assert len(rows) == 1 + 2 * 2 and all(r[status] == "ok" for r in rows[1:]), rows
