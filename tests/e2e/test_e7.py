"""E7 (experiments/e7_model_mismatch.py) on projected corners: the paper model's error
grows with the tilt-axis offset and the refinement removes it; encoder offsets are
absorbed by both; the report's files are written."""

from __future__ import annotations

import csv
import json
import sys
from argparse import Namespace
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "experiments"))
import e7_model_mismatch as e7  # noqa: E402

from rasc.head.fit import MISFIT_F_WARN  # noqa: E402

FIELDS = {c: f for c, _, f in e7.CASES}
pytestmark = pytest.mark.slow       # calibrations with refinement


@pytest.fixture(scope="module")
def results(quick_experiments):
    """The cases offset30 and encoder0.5 on projected corners, seed 0. offset30 is the
    reproduction's --quick E7 (its one case, the same task): read back from its
    summary.json (conftest's ``quick_experiments``, once per test run)."""
    ctx, _ = quick_experiments("e7_model_mismatch")
    (offset,) = json.loads((ctx.out / e7.NAME / "summary.json").read_text())
    assert offset["case"] == "offset30" and e7.QUICK == ("offset30",)
    return [offset, e7.run_case(e7.CaseTask("encoder0.5", FIELDS["encoder0.5"], 0, True))]


def test_offset_breaks_the_paper_model_and_the_refinement_recovers(results):
    r = results[0]
    for eye in e7.EYES:
        # paper: the 30 mm offset lands in the hand-eye translation (~15 mm, issue 10)
        assert r["models"]["paper"]["handeye"][eye]["translation_mm"] > 10.0
        # general: the 0.015 px corner noise alone (std ≈ 0.3 mm at most here)
        assert r["models"]["general"]["handeye"][eye]["translation_mm"] < 1.0
        assert r["F"][eye] > 100 * MISFIT_F_WARN
        assert abs(1000 * r["refined_unit"][eye]["tilt_point_y"]["value"] - 30.0) < 1.0
    paper, general = e7._mean_tri(r, "paper"), e7._mean_tri(r, "general")
    assert general < 0.5 < paper and general < paper / 5


def test_encoder_offsets_are_absorbed_by_both_models(results):
    r = results[1]
    for model in e7.MODELS:
        for eye in e7.EYES:
            assert r["models"][model]["handeye"][eye]["translation_mm"] < 1.5
    assert all(F < MISFIT_F_WARN for F in r["F"].values())


def test_outputs(results, tmp_path):
    e7.write_raw(results, tmp_path)
    e7.figure(results, tmp_path)
    md = e7.markdown(results, Namespace(seed=0, synthetic=True), tmp_path)
    with open(tmp_path / "cases.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2 * 3 * 2 and {r["model"] for r in rows} == set(e7.MODELS)
    with open(tmp_path / "triangulation.csv", newline="") as f:
        tri = list(csv.DictReader(f))
    # case × model × plane × gaze pose, both kinds of gaze (the home pose among them)
    assert len(tri) == 2 * 3 * 3 * len(e7.GAZES)
    assert {r["gaze_kind"] for r in tri} == {"parallel", "converging"}
    assert "home" in {r["gaze"] for r in tri}
    assert "![E7: hand-eye and triangulation error, paper model against the general " \
           "model](e7/fig_model_mismatch.png)" in md
    assert (tmp_path / "fig_model_mismatch.png").stat().st_size > 1000
    assert md.startswith("## E7") and "not renders" in md
