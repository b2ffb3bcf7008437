"""``rasc triangulate``, ``rasc project`` and ``rasc look-at`` tell the user the same things
about a calibration (issue 25 item 4, issue 21): readings outside the calibrated range, a
paper-model calibration that carries a misfit, a base translation in another length unit.
One check (:func:`rasc.head.use.reading_warnings`), one line each, exit 0, the result
still written."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rasc.head.use import calibration_from_document, project_eye, reading_warnings

from nominal_rig import plausible_head

#: the calibrated range of the documents below: the paper's ±8° poses
RANGE_DEG = 8.0


def _document(F: float | None = None, refined: bool = False, scale_left: float = 1.0):
    head, _ = plausible_head(seed=0)
    doc = {"format": "rasc-calibration/1", "length_unit": "m", "head": head.to_dict(),
           "eyes": {eye: {"pose_views": [{"pan_deg": s * RANGE_DEG, "tilt_deg": s * RANGE_DEG}
                                         for s in (-1, 0, 1)]} for eye in ("left", "right")}}
    doc["head"]["left"]["T_ptu_from_base"] = (
        np.asarray(doc["head"]["left"]["T_ptu_from_base"]) * [1, 1, 1, scale_left]).tolist()
    doc["head"]["left"]["T_ptu_from_base"][3][3] = 1.0
    if F is not None:
        doc["paper_model_fit"] = {eye: {"F": F, "threshold_F": 5.0, "rms_model_px": 1.0,
                                        "rms_free_px": 0.02, "views": 9}
                                  for eye in ("left", "right")}
    if refined:
        doc["refinement"] = {}
    return head, doc


def _points_csv(path, head, pan_deg: float):
    """Two base points seen by both eyes at (pan_deg, 0): exact pixels, so no residual
    warning can add a line."""
    p = np.array([[0.0, 1.5, 0.05], [0.1, 2.0, -0.1]])
    pan = np.radians(pan_deg)
    uv = {e: project_eye(getattr(head, e), p, pan, 0.0).uv for e in ("left", "right")}
    lines = ["u_left,v_left,u_right,v_right,pan_left,tilt_left,pan_right,tilt_right"]
    lines += [",".join(repr(float(x)) for x in (*uv["left"][i], *uv["right"][i]))
              + f",{pan_deg},0,{pan_deg},0" for i in range(2)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _warnings(err: str, command: str) -> list[str]:
    return [line for line in err.splitlines() if line.startswith(f"rasc {command}: warning")]


@pytest.mark.parametrize(("pan_deg", "F", "refined", "expect"), [
    (0.0, None, False, []),
    (5.0, 2.0, False, []),                         # in range, F below the threshold
    (20.0, None, False, ["left eye: pan 20", "right eye: pan 20"]),
    (0.0, 1e5, False, ["paper's pan-tilt model, which does not fit"]),
    (0.0, 1e5, True, []),                          # refined: the paper model's F is answered
])
def test_triangulate_warns_once_per_thing(rasc_cli, tmp_path, pan_deg, F, refined, expect):
    head, doc = _document(F, refined)
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(doc))
    pts = _points_csv(tmp_path / "pts.csv", head, pan_deg)
    status, out, err = rasc_cli("triangulate", cal, pts, "--angle-unit", "deg")
    assert status == 0 and json.loads(out)["points"]
    got = _warnings(err, "triangulate")
    assert len(got) == len(expect), err
    for line, text in zip(got, expect, strict=True):
        assert text in line


def test_project_and_look_at_share_the_check(rasc_cli, tmp_path):
    head, doc = _document(F=1e5)
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(doc))
    (tmp_path / "p.csv").write_text("x,y,z,pan_left,tilt_left\n0,1.5,0,0,0\n0,1.5,0.1,20,0\n")
    status, out, err = rasc_cli("project", cal, tmp_path / "p.csv", "--angle-unit", "deg")
    assert status == 0 and len(json.loads(out)["points"]) == 2
    got = _warnings(err, "project")
    assert len(got) == 2
    assert "left eye: pan 20, tilt 0 deg (" in got[0] and "p.csv: line 3)" in got[0]
    assert "does not fit its pose views" in got[1]
    status, out, err = rasc_cli("look-at", cal, "--point", "0,1.5,0", "--angle-unit", "deg")
    assert status == 0
    assert [w.split(": warning: ", 1)[1] for w in _warnings(err, "look-at")] == \
        reading_warnings(calibration_from_document(doc, str(cal)),
                         {e: (json.loads(out)["points"][0][e]["pan"] * np.pi / 180,
                              json.loads(out)["points"][0][e]["tilt"] * np.pi / 180)
                          for e in ("left", "right")}, "deg",
                         where=lambda i: "--point 0,1.5,0")


def test_a_base_translation_in_millimetres_among_metres_is_warned(rasc_cli, tmp_path):
    head, doc = _document(scale_left=1000.0)     # the case: left in mm
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(doc))
    pts = _points_csv(tmp_path / "pts.csv", head, 0.0)
    status, out, err = rasc_cli("triangulate", cal, pts, "--angle-unit", "deg")
    assert status == 0
    assert any("left.T_ptu_from_base's translation looks like another length unit" in w
               for w in _warnings(err, "triangulate"))
    # a bare rasc-head/1 may put its base at one unit: no such warning there
    bare = dict(doc["head"], format="rasc-head/1")
    bare["left"] = dict(bare["left"], T_ptu_from_base=np.eye(4).tolist())
    assert reading_warnings(calibration_from_document(bare, "head.json"), {}) == []
