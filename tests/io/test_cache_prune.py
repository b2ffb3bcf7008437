"""The caches' size bound: rasc.io.prune_cache removes the least recently used entries
(files or folders, by modification time, which readers refresh) down to the budget, never
the entry just written nor one being written; RASC_CACHE_MAX_MB sets the budget and a bad
value is refused before any work; the reproduction's calibration cache prunes itself."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from rasc.errors import InputError
from rasc.io import CACHE_MAX_BYTES, cache_max_bytes, cache_root, prune_cache, touch_cache_entry


def _entry(folder, name, size, mtime):
    p = folder / name
    p.write_bytes(b"x" * size)
    os.utime(p, (mtime, mtime))
    return p


def test_least_recently_used_go_first_down_to_the_budget(tmp_path):
    a, b, c = (_entry(tmp_path, n, 100, t) for n, t in (("a", 1000), ("b", 2000), ("c", 3000)))
    sub = tmp_path / "d"                                # a folder entry of 2 × 100 bytes
    sub.mkdir()
    _entry(sub, "1", 100, 500)
    _entry(sub, "2", 100, 500)
    os.utime(sub, (1500, 1500))
    tmp = _entry(tmp_path, ".c.json.x.tmp", 10_000, 1)   # being written: never counted
    # 500 bytes in all; a budget of 250 removes a (oldest), then d, and keeps b and c
    assert prune_cache(tmp_path, 250) == [a, sub]
    assert sorted(p.name for p in tmp_path.iterdir()) == [".c.json.x.tmp", "b", "c"]
    assert tmp.exists()
    # within the budget nothing goes
    assert prune_cache(tmp_path, 200) == []


def test_a_used_entry_is_kept_and_the_new_one_is_never_removed(tmp_path):
    a = _entry(tmp_path, "a", 100, 1000)
    b = _entry(tmp_path, "b", 100, 2000)
    touch_cache_entry(a)                                # read just now: the newest
    assert prune_cache(tmp_path, 100) == [b]
    # budget 0: everything but the entry just written
    c = _entry(tmp_path, "c", 100, 10)                  # older mtime than a, but kept
    assert prune_cache(tmp_path, 0, keep=c) == [a]
    assert [p.name for p in tmp_path.iterdir()] == ["c"]


def test_a_missing_folder_or_entry_is_no_error(tmp_path):
    assert prune_cache(tmp_path / "absent", 0) == []
    touch_cache_entry(tmp_path / "absent")


@pytest.mark.parametrize("value, expected", [(None, CACHE_MAX_BYTES), ("", CACHE_MAX_BYTES),
                                             ("1", 2**20), ("0.5", 2**19), ("0", 0)])
def test_the_budget_from_the_environment(value, expected, monkeypatch):
    if value is None:
        monkeypatch.delenv("RASC_CACHE_MAX_MB", raising=False)
    else:
        monkeypatch.setenv("RASC_CACHE_MAX_MB", value)
    assert cache_max_bytes() == expected


@pytest.mark.parametrize("value", ["-1", "ten", "nan", "inf"])
def test_a_bad_budget_is_refused_where_the_cache_is_found(value, monkeypatch, tmp_path):
    monkeypatch.setenv("RASC_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("RASC_CACHE_MAX_MB", value)
    with pytest.raises(InputError, match=r"^RASC_CACHE_MAX_MB: expected a number of MiB"):
        cache_root()
    monkeypatch.setenv("RASC_CACHE_DIR", "none")          # no cache: the budget is moot
    assert cache_root() is None


def test_the_calibration_cache_keeps_within_its_budget(monkeypatch, tmp_path):
    """Two calibrations stored under a budget of one: the older goes, the newer stays
    and is read back."""
    from experiments._common import calibration_cache, load_cached_calibration, store_calibration
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.sim.synthetic import corner_dataset, default_head

    monkeypatch.setenv("RASC_CACHE_DIR", str(tmp_path))
    cal = calibrate_dataset(corner_dataset(default_head(), seed=0, noise_px=0.0),
                            CalibrationOptions(model="paper"))
    keys = [{"format": "test", "n": k} for k in range(2)]
    first = calibration_cache(keys[0])
    store_calibration(first, keys[0], cal)
    size = first.stat().st_size
    monkeypatch.setenv("RASC_CACHE_MAX_MB", str(1.5 * size / 2**20))
    second = calibration_cache(keys[1])
    store_calibration(second, keys[1], cal)
    assert not first.exists() and second.exists()
    assert load_cached_calibration(second, keys[1]) is not None


def test_a_bad_budget_stops_the_reproduction_and_a_study_before_anything_is_written(
        monkeypatch, tmp_path, capsys):
    from experiments import reproduce
    from rasc.cli import main as rasc_main

    monkeypatch.setenv("RASC_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("RASC_CACHE_MAX_MB", "ten")
    assert reproduce.main(["--quick", "--out", str(tmp_path / "out")]) == 2
    spec = Path(__file__).resolve().parents[2] / "experiments" / "specs" / "e2_home_view.toml"
    assert rasc_main(["study", str(spec), "--out", str(tmp_path / "study")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == ["reproduce: error: RASC_CACHE_MAX_MB: expected a number of MiB >= 0, "
                   "got 'ten'",
                   "rasc study: error: RASC_CACHE_MAX_MB: expected a number of MiB >= 0, "
                   "got 'ten'"]
    assert sorted(p.name for p in tmp_path.iterdir()) == []
