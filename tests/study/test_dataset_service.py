"""The dataset service's cache (rasc.datasets): one key, entries verified by the sha256 of
their content; anything else in an entry's place (damaged, edited, truncated, a link to
/dev/zero, a FIFO, a folder) is ignored with one note and computed afresh, never
trusted, never blocking, never a MemoryError; ``RASC_CACHE_DIR=none`` means no cache."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rasc.datasets import CacheStore, cache_key, content_key
from rasc.datasets.cache import pack, unpack


@pytest.fixture(autouse=True)
def alarm():
    """Any read that blocks (a FIFO opened for reading) fails the test instead of hanging."""
    def expired(signum, frame):
        raise TimeoutError("a cache read blocked")
    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


def store(tmp_path: Path) -> CacheStore:
    notes: list[str] = []
    s = CacheStore(folder=tmp_path / "cache", label="test", log=notes.append)
    return s


@pytest.mark.slow
@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(payload=st.binary(min_size=1, max_size=300), data=st.data())
def test_any_change_to_an_entry_is_caught(tmp_path, payload, data):
    """An entry reads back exactly; any truncation, extension or flipped bit of it is
    ignored (None) with exactly one note naming the file."""
    s = store(tmp_path)
    assert s.put_bytes("k", payload) and s.get_bytes("k") == payload
    whole = s.path("k").read_bytes()
    kind = data.draw(st.sampled_from(["cut", "extend", "flip"]))
    if kind == "cut":
        bad = whole[: data.draw(st.integers(0, len(whole) - 1))]
    elif kind == "extend":
        bad = whole + data.draw(st.binary(min_size=1, max_size=20))
    else:
        at = data.draw(st.integers(0, len(whole) - 1))
        bad = whole[:at] + bytes([whole[at] ^ (1 << data.draw(st.integers(0, 7)))]) \
            + whole[at + 1:]
    s.path("k").write_bytes(bad)
    n = len(s.notes)
    assert s.get_bytes("k") is None
    assert len(s.notes) == n + 1 and str(s.path("k")) in s.notes[-1]
    assert "computing it afresh" in s.notes[-1]


@pytest.mark.parametrize("kind", ["devzero", "fifo", "folder", "dangling", "huge-claim"])
def test_things_in_place_of_an_entry_are_ignored_then_replaced(tmp_path, kind):
    s = store(tmp_path)
    s.folder.mkdir(parents=True)
    path = s.path("k")
    if kind == "devzero":
        os.symlink("/dev/zero", path)
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
        (path / "x").write_text("x")
    elif kind == "dangling":
        os.symlink(tmp_path / "nowhere", path)
    else:                        # a header that claims far more than is there
        path.write_bytes(b"rasc-cache-entry/1 sha256=" + b"0" * 64 + b" bytes=99999999999\n")
    assert s.get_json("k") is None
    assert len(s.notes) == 1 and "ignored the cache entry" in s.notes[0]
    # the next store replaces it (the link itself, never its target)
    assert s.put_json("k", {"a": 1}) and s.get_json("k") == {"a": 1}
    assert os.path.isfile(path) and not os.path.islink(path)


def test_an_edited_json_entry_is_not_used(tmp_path):
    s = store(tmp_path)
    s.put_json("k", {"format": "x", "value": 1.5})
    path = s.path("k")
    path.write_bytes(path.read_bytes().replace(b"1.5", b"2.5"))       # still valid JSON
    assert s.get_json("k") is None and "damaged or edited" in s.notes[0]


def test_folder_entries_are_verified(tmp_path):
    src = tmp_path / "src"
    (src / "sub").mkdir(parents=True)
    (src / "a.txt").write_text("a")
    (src / "sub" / "b.bin").write_bytes(bytes(range(256)))
    s = store(tmp_path)
    data = s.put_tree("t", src)
    assert data is not None and s.get_tree("t") == data
    assert (data / "sub" / "b.bin").read_bytes() == bytes(range(256))
    (data / "a.txt").write_text("edited")
    assert s.get_tree("t") is None and "damaged or edited" in s.notes[-1]
    assert s.put_tree("t", src) is not None and s.get_tree("t") is not None
    (s.get_tree("t") / "a.txt").unlink()
    os.symlink("/dev/zero", s.tree("t") / "data" / "a.txt")
    assert s.get_tree("t") is None and "not a regular file" in s.notes[-1]
    os.unlink(s.tree("t") / "data" / "a.txt")
    (s.tree("t") / "entry.json").unlink()           # unfinished
    assert s.get_tree("t") is None


@pytest.mark.parametrize("off", ["none", "None", "off", ""])
def test_cache_off_means_no_store_anywhere(monkeypatch, tmp_path, off):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("RASC_CACHE_DIR", off)
    s = CacheStore("study-datasets")
    assert not s.enabled and s.get_json("k") is None and not s.put_json("k", {})
    from rasc.study.engine import cache_dir
    assert cache_dir() is None
    assert list(tmp_path.iterdir()) == []


def test_one_key_from_one_code_digest(monkeypatch):
    import rasc.datasets.keys as keys
    k = cache_key("render-folder", {"options": {"seed": 0}})
    assert len(k) == 32 and k == cache_key("render-folder", {"options": {"seed": 0}})
    assert k != cache_key("calibration", {"options": {"seed": 0}})
    assert k != cache_key("render-folder", {"options": {"seed": 1}})
    monkeypatch.setattr(keys, "code_digest", lambda: "0" * 64)
    assert cache_key("render-folder", {"options": {"seed": 0}}) != k
    # the content key: canonical JSON (key order, tuples as lists)
    assert content_key({"a": (1, 2), "b": 1}) == content_key({"b": 1, "a": [1, 2]})


def test_pack_unpack_round_trip():
    payload = np.arange(10.0).tobytes()
    assert unpack(pack(payload)) == payload


def test_the_pytest_plugin_takes_none_for_no_cache(monkeypatch, tmp_path):
    """RASC_CACHE_DIR=none under the pytest plugin: no cache, and no folder ./none/."""
    import rasc.testing as testing

    class Config:
        def getoption(self, name, default=None):
            return None

        def getini(self, name):
            return ""

    monkeypatch.chdir(tmp_path)
    for off in ("none", "off", "NONE"):
        monkeypatch.setenv("RASC_CACHE_DIR", off)
        assert testing._cache_dir(Config(), None) is None
    monkeypatch.setenv("RASC_CACHE_DIR", str(tmp_path / "c"))
    assert testing._cache_dir(Config(), None) == tmp_path / "c" / "rendered"
    assert list(tmp_path.iterdir()) == []


def test_assert_handeye_close_on_a_nan_result_is_an_assertion():
    from rasc.testing import assert_handeye_close, make_pose_set
    s = make_pose_set(1)
    for bad in (np.full((4, 4), np.nan), np.where(np.eye(4) > 0, np.inf, 0.0)):
        with pytest.raises(AssertionError, match="non-finite"):
            assert_handeye_close(bad, s, rotation_deg=1.0, translation=0.01)
    assert_handeye_close(s.truth, s, rotation_deg=1e-12, translation=1e-12)   # control
