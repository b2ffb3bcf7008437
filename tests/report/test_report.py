"""rasc report: the verdict's rules (documents made to trip each one), and the PDF of a
small rendered dataset's calibration: its page count read from the file itself, its
pages rendered to PNG by pdftoppm where installed (poppler-utils), same bytes twice."""

import copy
import math
import re

import pytest
from report_pages import pages_whole

from rasc.report import PAGES, verdict, write_report
from rasc.report.verdict import CHECK_COVERAGE

# ------------------------------------------------------------------- the verdict


def good_doc() -> dict:
    """The fields the verdict reads, as a good general-model calibration has them."""
    params = {eye: {"fx": {"value": 1150.0, "std": 0.08, "unit": "px"},
                    "fy": {"value": 1148.0, "std": 0.08, "unit": "px"}}
              for eye in ("left", "right")}
    return {"format": "rasc-calibration/1", "options": {"model": "general"},
            "refinement": {"rms_after_px": 0.2, "rms_by_role_px": {"intrinsics": 0.15,
                                                                   "pose": 0.25},
                           "corners": 2000, "rejected_corners": 3, "parameters": params,
                           "not_identifiable": [{"eye": "left", "parameter": "pan_offset"}]},
            "paper_model_fit": {"left": {"F": 1.1}, "right": {"F": 0.9}}}


def test_good_calibration_is_usable():
    v = verdict(good_doc(), {"left": 0.8, "right": 0.7})
    assert v.level == "usable" and all(c.passed for c in v.checks)
    assert v.line().startswith("USABLE: reprojection RMS 0.2 px")


@pytest.mark.parametrize("change, level, words", [
    (lambda d: d["refinement"].update(rms_after_px=1.5), "unusable", "1.5 px is above 1 px"),
    (lambda d: d["refinement"].update(rms_after_px=0.7), "check", "0.7 px is above 0.5 px"),
    (lambda d: d["refinement"]["rms_by_role_px"].update(pose=0.9), "check",
     "pose views fit 6 times worse"),
    (lambda d: d["refinement"].update(rejected_corners=150), "check", "7.5 % of the corners"),
    (lambda d: d["refinement"]["parameters"]["right"]["fy"].update(std=20.0), "check",
     "right fy is uncertain by 1.7 %"),
    (lambda d: d["refinement"]["not_identifiable"].append(
        {"eye": "right", "parameter": "tilt_axis_x"}), "check", "did not determine right "
                                                               "tilt_axis_x"),
    (lambda d: d["refinement"]["parameters"]["left"]["fx"].update(std=math.nan), "unusable",
     "left fx std is not a finite number"),
])
def test_each_rule_gives_its_level_and_reason(change, level, words):
    doc = good_doc()
    change(doc)
    v = verdict(doc)
    assert v.level == level
    assert words in v.reason


def test_worst_level_wins_and_the_first_reason_of_it_is_given():
    doc = good_doc()
    doc["refinement"]["rejected_corners"] = 500               # check
    doc["refinement"]["rms_after_px"] = 3.0                   # unusable
    v = verdict(doc)
    assert v.level == "unusable" and "3 px is above 1 px" in v.reason


def test_paper_model_misfit_is_judged_only_for_the_paper_model():
    doc = good_doc()
    doc["paper_model_fit"]["left"]["F"] = 40.0
    assert verdict(doc).level == "usable"              # general: its own unit fits
    paper = {"format": "rasc-calibration/1", "options": {"model": "paper"},
             "eyes": {"left": {"intrinsics_rms": 0.2}, "right": {"intrinsics_rms": 0.3}},
             "paper_model_fit": doc["paper_model_fit"]}
    v = verdict(paper)
    assert v.level == "check" and "--model general" in v.reason
    assert next(c for c in v.checks if c.name == "rms").value == 0.3   # the worse eye


def test_coverage_threshold():
    v = verdict(good_doc(), {"left": 0.9, "right": CHECK_COVERAGE - 0.01})
    assert v.level == "check" and "right intrinsics corners touch 49 %" in v.reason


# ------------------------------------------------------------------- the PDF


def pdf_pages(data: bytes) -> int:
    """Page objects of a PDF (matplotlib writes each page's dictionary uncompressed)."""
    return len(re.findall(rb"/Type\s*/Page(?![a-zA-Z])", data))


@pytest.fixture(scope="module")
def calibrated(rasc_render):
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset

    ds = rasc_render(intrinsics_views=8).load()
    return ds, calibrate_dataset(ds, CalibrationOptions(model="general")).to_dict()


@pytest.mark.slow
def test_report_pdf_pages(calibrated, tmp_path, page_problems):
    ds, doc = calibrated
    out = tmp_path / "report.pdf"
    v = write_report(doc, out, dataset=ds, source="cal.json")
    # noise-free renders: a few hundredths of a pixel, every check passes
    assert v.level == "usable", v.line()
    data = out.read_bytes()
    assert data.startswith(b"%PDF") and pdf_pages(data) == PAGES
    assert page_problems == []
    # the same calibration and images: the same bytes
    write_report(doc, tmp_path / "again.pdf", dataset=ds, source="cal.json")
    assert (tmp_path / "again.pdf").read_bytes() == data
    # every page rendered has ink and none at its edges (skipped without pdftoppm)
    pages_whole(out, tmp_path)


@pytest.mark.slow
def test_report_without_images_still_has_every_page(calibrated, tmp_path, page_problems):
    _, doc = calibrated
    out = tmp_path / "r.pdf"
    v = write_report(doc, out)
    assert pdf_pages(out.read_bytes()) == PAGES
    assert not any(c.name.endswith("coverage") for c in v.checks)
    # a paper-model document (no refinement): the parameters page says so
    paper = copy.deepcopy(doc)
    del paper["refinement"]
    paper["options"]["model"] = "paper"
    write_report(paper, tmp_path / "p.pdf")
    assert pdf_pages((tmp_path / "p.pdf").read_bytes()) == PAGES
    assert page_problems == []


def test_cli_refuses_a_missing_calibration(tmp_path, rasc_cli):
    code, out, err = rasc_cli("report", str(tmp_path / "nope.json"), "--out",
                              str(tmp_path / "r.pdf"))
    assert code == 2 and err.startswith("rasc report: error: ") and err.count("\n") == 1
    assert not (tmp_path / "r.pdf").exists()


@pytest.mark.slow
def test_calibrate_writes_the_report_too(rasc_render, tmp_path, rasc_cli):
    ds = rasc_render(intrinsics_views=8).path
    cal, pdf = tmp_path / "cal.json", tmp_path / "report.pdf"
    # the report may not overwrite the calibration (an input of the report)
    code, _, err = rasc_cli("calibrate", str(ds), "--out", str(cal), "--report", str(cal),
                            "--quiet")
    assert code == 2 and "--report" in err and not cal.exists()
    code, _, err = rasc_cli("calibrate", str(ds), "--out", str(cal), "--report", str(pdf),
                            "--quiet")
    assert code == 0, err
    assert "rasc calibrate: report: USABLE" in err
    assert pdf_pages(pdf.read_bytes()) == PAGES and cal.is_file()


def test_parameter_units_come_from_the_table_not_the_file():
    # a file written before rasc 0.3 labelled the scales and the tilt axis's components
    # lengths (".t" in the name): the report printed "unit.tilt_scale 1000 mm"
    from rasc.report.pdf import _parameter_rows

    doc = good_doc()
    doc["length_unit"] = "m"
    doc["refinement"]["parameters"]["left"].update({
        "unit.tilt_scale": {"value": 1.0004, "std": 4.4e-5, "unit": "length"},
        "unit.tilt_axis_x": {"value": 0.0087, "std": 2e-5, "unit": "length"},
        "unit.tilt_point_y": {"value": 0.025, "std": 1e-5, "unit": "length"},
        "unit.axis_angle_deg": {"value": 89.5, "std": 0.001, "unit": "deg"}})
    rows = {r.split()[0]: r for r in _parameter_rows(doc)[0]["left"]}
    assert "mm" not in rows["unit.tilt_scale"] and "1.0004" in rows["unit.tilt_scale"]
    assert "mm" not in rows["unit.tilt_axis_x"]
    assert "25 mm" in rows["unit.tilt_point_y"] and "0.01 mm" in rows["unit.tilt_point_y"]
    assert rows["unit.axis_angle_deg"].endswith("deg")


def test_a_negligible_misfit_is_not_judged():
    # the verdict's misfit check is the pipeline's (rasc.head.fit.is_misfit): F above 5
    # with the one-board RMS only 5 % above the per-view RMS is usable; 3x above is not
    doc = good_doc()
    doc["options"] = {"model": "paper"}
    del doc["refinement"]
    doc["eyes"] = {eye: {"intrinsics_rms": 0.03} for eye in ("left", "right")}
    doc["paper_model_fit"]["right"] = {"F": 5.39, "rms_model_px": 0.0329,
                                       "rms_free_px": 0.0314}
    assert verdict(doc).level == "usable", verdict(doc).line()
    doc["paper_model_fit"]["right"]["rms_model_px"] = 0.1
    v = verdict(doc)
    assert v.level == "check" and "right pose views (F = 5.39)" in v.reason
