"""The reproduction's cache of the default dataset's calibration (experiments/_common.py).

A cached calibration must round-trip exactly (every file an experiment writes from it is
the same bytes as from a fresh calibration), must be keyed so that another dataset or a
change to the calibration code can never be served a stale one, and a corrupt or foreign
entry must be ignored with a note and recomputed.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the experiments package

from experiments import _common  # noqa: E402
from experiments import e4_triangulation as e4  # noqa: E402
from experiments import e5_base_to_ptu as e5  # noqa: E402
from experiments._common import (  # noqa: E402
    Context,
    calibration_cache,
    calibration_key,
    load_cached_calibration,
    renderer_digest,
    store_calibration,
)
from rasc.io import dumps_json  # noqa: E402


def _context(out: Path, dataset: Path) -> Context:
    """A quick, single-worker context on ``dataset`` (the session's rendered default
    dataset, used in place: it has no render record, so dataset_dir is bypassed)."""
    (out / "data").mkdir(parents=True)
    ctx = Context(argparse.Namespace(seed=0, quick=True, out=out, workers=1))
    ctx.dataset_dir = lambda: dataset
    return ctx


def _outputs(folder: Path) -> dict[str, bytes]:
    """E4's and E5's files (CSV, JSON, Markdown) and the calibration file, by path."""
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for sub in ("data", e4.NAME, e5.NAME) for p in sorted((folder / sub).rglob("*"))
            if p.suffix in (".csv", ".json", ".md") and "dataset" not in p.parts}


def test_cached_calibration_gives_the_same_bytes_downstream(default_dataset, quick_experiments,
                                                            tmp_path, monkeypatch, capsys):
    """A calibration computed afresh (and stored on the way), then read back from the
    cache: the same calibration file and study document, and two experiments (E4, E5) run
    on the cached one write the same bytes as on a fresh one (conftest's
    ``quick_experiments``, whose calibration is never read from a cache)."""
    monkeypatch.setenv("RASC_CACHE_DIR", str(tmp_path / "cache"))
    fresh = _context(tmp_path / "fresh", default_dataset)
    cal = fresh.calibration()
    err = capsys.readouterr().err
    assert "calibrate the default dataset" in err and "from the cache" not in err
    key = calibration_key(default_dataset)
    assert calibration_cache(key).is_file()          # stored on the way

    cached = _context(tmp_path / "cached", default_dataset)
    cal2 = cached.calibration()
    err = capsys.readouterr().err
    assert "read from the cache" in err and "calibrate the default dataset (" not in err
    assert cal2 is not cal
    # the calibration file, the study document the study experiments start from, and
    # two experiments run on it: the same bytes
    assert (fresh.out / "data" / "calibration.json").read_bytes() == \
        (cached.out / "data" / "calibration.json").read_bytes()
    assert dumps_json(fresh.study_dataset()) == dumps_json(cached.study_dataset())
    for name in ("e4_triangulation", "e5_base_to_ptu"):
        reference, _ = quick_experiments(name)            # on a fresh calibration
    e4.run(cached)
    e5.run(cached)
    a, b = _outputs(reference.out), _outputs(cached.out)
    assert len(a) >= 6 and sorted(a) == sorted(b)
    assert [n for n in a if a[n] != b[n]] == []


def test_the_key_follows_the_dataset_bytes(default_dataset, tmp_path):
    copy = tmp_path / "ds"
    shutil.copytree(default_dataset, copy)
    k0 = calibration_key(copy)
    assert calibration_key(default_dataset) == k0      # content, not location
    image = sorted(copy.rglob("*.png"))[0]
    data = bytearray(image.read_bytes())
    data[-20] ^= 1                                     # one bit of one image
    image.write_bytes(bytes(data))
    k1 = calibration_key(copy)
    assert k1["dataset_sha256"] != k0["dataset_sha256"]
    assert calibration_cache(k1) != calibration_cache(k0)


def copy_of_the_package(tmp_path: Path) -> Path:
    """A copy of the rasc package folder with the models beside it, as in a checkout."""
    import rasc
    from rasc.sim import MODELS_DIR
    root = tmp_path / "rasc"
    shutil.copytree(Path(rasc.__file__).parent, root,
                    ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(MODELS_DIR, tmp_path / "sim" / "models")
    return root


def test_the_key_follows_the_one_code_digest(default_dataset, monkeypatch, tmp_path):
    """The calibration's key names the dataset service's one code digest (any change to
    rasc's files or libraries): another digest, another cache entry."""
    import rasc.datasets.keys as keys
    from rasc.datasets import code_digest

    monkeypatch.setenv("RASC_CACHE_DIR", str(tmp_path))
    key = calibration_key(default_dataset)
    assert key["code_sha256"] == code_digest()
    path = calibration_cache(key)
    monkeypatch.setattr(keys, "_CODE_DIGEST", ["0" * 64])
    other = calibration_key(default_dataset)
    assert other["code_sha256"] == "0" * 64 and calibration_cache(other) != path


def test_the_dataset_key_follows_the_rendering_code_only(tmp_path):
    """The default dataset's cache key (renderer_sha256) covers every module the renderer
    imports, not only rasc/sim: the unit's kinematics, the lens model, the manifest's
    writer (each missed by the earlier hand-kept list), and nothing else."""
    root = copy_of_the_package(tmp_path)
    d0 = renderer_digest(root)
    assert d0 == renderer_digest()
    # code no render runs: the same key
    for other in ("handeye/solver.py", "head/refine/solver.py", "study/engine.py",
                  "commands/render.py"):
        path = root / other
        path.write_text(path.read_text() + "\n# changed\n")
    assert renderer_digest(root) == d0
    # one character in the renderer or in what it imports: another key
    for part in ("sim/scene.py", "../sim/models/stereo_head.xml", "vision/camera.py",
                 "geometry/kinematics.py", "geometry/lens.py", "vision/dataset.py", "io.py"):
        path = root / part
        text = path.read_text()
        path.write_text(text + " ")
        assert renderer_digest(root) != d0, part
        path.write_text(text)
    assert renderer_digest(root) == d0


def test_cache_off_and_where_it_lives(monkeypatch, tmp_path):
    key = {"format": "x"}
    for off in ("none", "None", "off", ""):
        monkeypatch.setenv("RASC_CACHE_DIR", off)
        assert calibration_cache(key) is None
    monkeypatch.setenv("RASC_CACHE_DIR", str(tmp_path))
    assert calibration_cache(key).parent == tmp_path / "reproduce-calibrations"
    assert calibration_cache(key) != calibration_cache({"format": "y"})


def test_corrupt_or_foreign_entries_are_ignored_with_a_note(default_calibration, tmp_path,
                                                             capsys):
    path = tmp_path / "entry.pickle"
    key = {"format": _common.CALIBRATION_CACHE_FORMAT, "dataset_sha256": "a"}
    assert load_cached_calibration(path, key) is None          # missing: silent
    assert capsys.readouterr().err == ""
    store_calibration(path, key, default_calibration)
    assert [p.name for p in tmp_path.iterdir()] == ["entry.pickle"]   # no temporary left
    back = load_cached_calibration(path, key)
    assert dumps_json(back.to_dict()) == dumps_json(default_calibration.to_dict())
    # another key (a stale entry under a colliding name): ignored, with a note
    assert load_cached_calibration(path, {**key, "dataset_sha256": "b"}) is None
    assert "stored under another key" in capsys.readouterr().err
    # truncated, garbage, empty: ignored, with a note naming the file
    data = path.read_bytes()
    for bad in (data[:len(data) // 2], b"not a pickle", b""):
        path.write_bytes(bad)
        assert load_cached_calibration(path, key) is None
        err = capsys.readouterr().err
        assert err.startswith("reproduce: note: ignored the cached calibration")
        assert str(path) in err and err.count("\n") == 1


class _Trap:
    """Unpickling this writes a file: proof that the entry was unpickled."""

    def __init__(self, mark: Path) -> None:
        self.mark = mark

    def __reduce__(self):
        return (Path.write_text, (self.mark, "unpickled"))


def test_an_entry_others_can_write_is_never_unpickled(tmp_path, capsys):
    """Unpickling runs code, so an entry (or its folder) writable by group or others is
    refused before it is read; the same file in a private folder is read (the control)."""
    import os
    import pickle

    from rasc.datasets.cache import pack

    mark = tmp_path / "mark"
    key = {"format": _common.CALIBRATION_CACHE_FORMAT, "dataset_sha256": "a"}
    for folder_mode, file_mode in ((0o777, 0o600), (0o700, 0o666), (0o770, 0o600)):
        folder = tmp_path / f"c{folder_mode:o}{file_mode:o}"
        folder.mkdir()
        path = folder / "entry.pickle"
        path.write_bytes(pack(pickle.dumps({"key": key, "calibration": _Trap(mark)})))
        os.chmod(path, file_mode)
        os.chmod(folder, folder_mode)
        assert load_cached_calibration(path, key) is None
        err = capsys.readouterr().err
        assert "writable by others" in err and "not unpickled" in err
        assert not mark.exists()
    private = tmp_path / "private"
    private.mkdir(mode=0o700)
    path = private / "entry.pickle"
    path.write_bytes(pack(pickle.dumps({"key": key, "calibration": _Trap(mark)})))
    os.chmod(path, 0o600)
    assert load_cached_calibration(path, key) is None      # read, then refused: not a Calibration
    assert mark.read_text() == "unpickled"


def test_a_corrupt_entry_is_recomputed_and_replaced(default_dataset, tmp_path, monkeypatch,
                                                   capsys):
    monkeypatch.setenv("RASC_CACHE_DIR", str(tmp_path / "cache"))
    path = calibration_cache(calibration_key(default_dataset))
    path.parent.mkdir(parents=True)
    path.write_bytes(b"\x80\x05garbage")
    ctx = _context(tmp_path / "out", default_dataset)
    ctx.calibration()
    err = capsys.readouterr().err
    assert "ignored the cached calibration" in err and "calibrate the default dataset (" in err
    # replaced by a good entry: the next run reads it
    assert load_cached_calibration(path, calibration_key(default_dataset)) is not None
    assert capsys.readouterr().err == ""


if __name__ == "__main__":
    pytest.main([__file__, "-q"])
