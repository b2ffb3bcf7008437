"""The calibration file's ``dataset`` field (issue 30 item 6): written relative to the
calibration file's own folder, so that ``rasc report CAL`` finds the dataset whichever
folder it is run from; files written before (the path as given to ``rasc calibrate``,
relative to the folder it ran in) keep working from that folder."""

from __future__ import annotations

import json
import shutil

import pytest

from rasc.head.use import dataset_reference, named_dataset


def _dataset(folder):
    folder.mkdir(parents=True)
    (folder / "manifest.json").write_text("{}")
    return folder


def test_reference_is_relative_to_the_calibration_file(tmp_path, monkeypatch):
    ds = _dataset(tmp_path / "work" / "ds")
    (tmp_path / "work" / "out").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    reference = dataset_reference("ds", "out/cal.json")
    assert reference == "../ds"
    # read from elsewhere: found beside the file, not in the working directory
    monkeypatch.chdir(tmp_path)
    doc = {"dataset": reference}
    assert named_dataset(doc, "work/out/cal.json") == str(ds.resolve())
    monkeypatch.chdir(ds)
    assert named_dataset(doc, tmp_path / "work" / "out" / "cal.json") == str(ds.resolve())
    # to stdout: no file to be relative to, the absolute path
    assert dataset_reference(ds, None) == str(ds.resolve())
    assert named_dataset({"dataset": str(ds)}, tmp_path / "x" / "cal.json") == str(ds)


def test_old_files_resolve_from_the_working_directory(tmp_path, monkeypatch):
    ds = _dataset(tmp_path / "work" / "ds")
    (tmp_path / "elsewhere").mkdir()
    cal = tmp_path / "elsewhere" / "cal.json"
    monkeypatch.chdir(tmp_path / "work")          # where rasc calibrate ds ran, as before
    assert named_dataset({"dataset": "ds"}, cal) == "ds"
    # a dataset that is nowhere, no field, a field of the wrong type: none
    shutil.rmtree(ds)
    for doc in ({"dataset": "ds"}, {}, {"dataset": 3}, {"dataset": ""}, []):
        assert named_dataset(doc, cal) is None, doc


@pytest.mark.slow
def test_report_finds_the_dataset_from_another_folder(rasc_render, rasc_cli, tmp_path,
                                                      monkeypatch):
    """``rasc calibrate ds --out out/cal.json`` in one folder, ``rasc report`` of it from
    another: the report is the one ``--dataset`` gives (the same bytes), not the one
    without images (before: the path "ds" was looked up in the report's folder)."""
    work = tmp_path / "work"
    shutil.copytree(rasc_render(intrinsics_views=8).path, work / "ds")
    (work / "out").mkdir()
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(work)
    code, _, err = rasc_cli("calibrate", "ds", "--out", "out/cal.json", "--quiet")
    assert code == 0, err
    assert json.loads((work / "out" / "cal.json").read_text())["dataset"] == "../ds"
    monkeypatch.chdir(tmp_path / "elsewhere")
    cal = str(work / "out" / "cal.json")
    reports = {}
    for name, extra in (("named", []), ("given", ["--dataset", str(work / "ds")])):
        code, _, err = rasc_cli("report", cal, "--out", f"{name}.pdf", "--quiet", *extra)
        assert code == 0, err
        reports[name] = (tmp_path / "elsewhere" / f"{name}.pdf").read_bytes()
    assert reports["named"] == reports["given"]
    # and the dataset made a difference: moved away, the report has no images
    (work / "ds").rename(tmp_path / "moved")
    assert rasc_cli("report", cal, "--out", "alone.pdf", "--quiet")[0] == 0
    assert (tmp_path / "elsewhere" / "alone.pdf").read_bytes() != reports["named"]


def test_a_dataset_that_is_a_link_is_named_by_the_link(tmp_path, monkeypatch):
    """A link beside the calibration (the report page's ``ln -s``) stays the name; the
    links above it are resolved, so that ``..`` climbs the real folders."""
    real = _dataset(tmp_path / "cache" / "entry")
    (tmp_path / "work").mkdir()
    (tmp_path / "work" / "rendered").symlink_to(real, target_is_directory=True)
    (tmp_path / "via").symlink_to(tmp_path / "work", target_is_directory=True)
    monkeypatch.chdir(tmp_path / "via")
    assert dataset_reference("rendered", "cal.json") == "rendered"
    assert dataset_reference("rendered", tmp_path / "cache" / "cal.json") == "../work/rendered"
    monkeypatch.chdir(tmp_path)
    assert named_dataset({"dataset": "../work/rendered"}, "cache/cal.json") == \
        str(tmp_path.resolve() / "work" / "rendered")
