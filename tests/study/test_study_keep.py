"""``[fixed] keep_datasets = true``: a study renders in memory by default; asked to keep
its datasets, it also writes each as a dataset folder under the study folder, and
nothing else changes (samples, summary, the spec's digest)."""

from pathlib import Path

import pytest

from rasc.errors import InputError
from rasc.study import load_spec, run_study
from rasc.vision import load_dataset

SPEC = """\
name = "keep"
seed = 2
samples = 3
methods = ["rasc"]

[fixed]
intrinsics_views = 4
layout = "grid"
positions = 4
noise_level = 1
"""


def _spec(tmp_path: Path, extra: str = "", name: str = "spec.toml") -> Path:
    path = tmp_path / name
    path.write_text(SPEC + extra)
    return path


@pytest.mark.slow
def test_kept_datasets_are_dataset_folders_and_change_nothing_else(tmp_path, monkeypatch):
    monkeypatch.setenv("RASC_CACHE_DIR", "none")
    plain = run_study(load_spec(_spec(tmp_path)), tmp_path / "plain", quiet=True)
    kept_spec = load_spec(_spec(tmp_path, "keep_datasets = true\n", "kept.toml"))
    # on two worker processes: the dataset comes back to the study, which writes it
    kept = run_study(kept_spec, tmp_path / "kept", quiet=True, workers=2)
    assert kept_spec.keep_datasets and kept_spec.digest == load_spec(
        _spec(tmp_path)).digest
    assert not [p for p in (tmp_path / "plain" / "datasets").iterdir() if p.is_dir()]
    folders = [p for p in (tmp_path / "kept" / "datasets").iterdir() if p.is_dir()]
    assert len(folders) == 1
    ds = load_dataset(folders[0])
    assert len(ds.select(role="pose")) == 2 * 4 and len(ds.select(role="intrinsics")) == 8
    assert ds.ground_truth is not None and ds.load_ground_truth()["render_options"]["seed"] == 2
    for name in ("samples.csv", "summary.csv", "study.json",
                 f"datasets/{folders[0].name}.json"):
        assert (tmp_path / "plain" / name).read_bytes() == \
            (tmp_path / "kept" / name).read_bytes(), name
    assert plain.samples_text == kept.samples_text
    # resumed, the kept dataset is found (not rendered again), and nothing changes
    again = run_study(kept_spec, tmp_path / "kept", quiet=True, resume=True)
    assert again.samples_text == kept.samples_text and again.datasets_rendered == 0


@pytest.mark.parametrize("text, message", [
    ("[axes]\nkeep_datasets = [true, false]\n", "axes.keep_datasets: a setting of the "
     "whole study"),
    ("keep_datasets = 1\n", "fixed.keep_datasets: expected true or false, got 1"),
])
def test_keep_datasets_is_a_study_setting(tmp_path, text, message):
    with pytest.raises(InputError, match=message):
        load_spec(_spec(tmp_path, text))


@pytest.mark.slow
def test_without_keep_datasets_no_image_is_written_or_read(tmp_path, monkeypatch):
    """Rendered, detected and calibrated in memory: the study runs with the image
    writer and reader out of order (workers=1 runs the tasks in this process)."""
    import rasc.vision.camera as camera

    def refuse(*args, **kwargs):
        raise AssertionError("an image file was written or read")

    monkeypatch.setenv("RASC_CACHE_DIR", "none")
    monkeypatch.setattr(camera, "write_image", refuse)
    monkeypatch.setattr(camera, "read_image", refuse)
    result = run_study(load_spec(_spec(tmp_path)), tmp_path / "study", quiet=True)
    assert result.datasets_rendered == 1 and result.samples_text
    assert not list((tmp_path / "study").rglob("*.png"))
