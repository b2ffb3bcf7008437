"""rasc.testing's old names (issue 30 item 6): ``.ground_truth`` used as the document it
was in rasc 0.2.0 keeps working until 0.4, and every DeprecationWarning that reaches a
user through the plugin (an old option name given to ``rasc_render`` or written in a
``rasc_dataset`` parameter, the old ``.ground_truth``, ``RenderedDataset``) names the
user's own line, not rasc's."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from rasc.errors import InputError
from rasc.testing import GroundTruthFile


def _caught(call):
    """``call()``'s warnings, every one recorded."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        call()
    return [(w.category, w.filename, w.lineno, str(w.message)) for w in caught]


def test_an_old_option_name_warns_at_the_tests_line(rasc_render):
    """``rasc_render(n_intrinsics=...)``: the warning is the test's, the line that wrote
    the old name (before: rasc/testing.py, where the options are built). The bad
    distance stops it before any render."""
    def users_line():
        with pytest.raises(InputError, match="distance"):
            rasc_render(n_intrinsics=8, distance=-1.0)

    [(category, filename, lineno, message)] = _caught(users_line)
    assert category is DeprecationWarning and "intrinsics_views" in message
    assert (filename, lineno) == (__file__, users_line.__code__.co_firstlineno + 2)


def test_a_parameter_with_an_old_name_warns_at_the_test_that_wrote_it(tmp_path):
    """``rasc_dataset`` parametrised with an old option name: pytest calls the fixture,
    so the warning goes to the test's first line, its ``parametrize`` decorator."""
    test = tmp_path / "test_users.py"
    test.write_text(
        "import pytest\n"
        "\n"
        "\n"
        "@pytest.mark.parametrize('rasc_dataset', [{'n_intrinsics': 8, 'distance': -1.0}],\n"
        "                         indirect=True)\n"
        "def test_mine(rasc_dataset):\n"
        "    pass\n")
    env = dict(os.environ, PYTEST_DISABLE_PLUGIN_AUTOLOAD="1", MUJOCO_GL="egl",
               RASC_CACHE_DIR="none")
    run = subprocess.run([sys.executable, "-m", "pytest", "-p", "rasc.testing", "-p",
                          "no:cacheprovider", "-q", "-W", "always", str(test)],
                         capture_output=True, text=True, env=env, timeout=300,
                         cwd=tmp_path)
    assert "1 error" in run.stdout, run.stdout[-2000:]      # the distance, not rendered
    said = [line.strip() for line in run.stdout.splitlines() if "DeprecationWarning" in line]
    assert said == [f"{test}:4: DeprecationWarning: RenderOptions(n_intrinsics=...) is now "
                    "RenderOptions(intrinsics_views=...) (renamed after rasc 0.2.0); the "
                    "old name goes in rasc 0.4"], run.stdout[-2000:]


def test_ground_truth_used_as_the_document_warns_and_reads_it(tmp_path):
    truth = {"left": {"T_cam_from_gaze": [[1.0, 0.0], [0.0, 1.0]]}, "right": {}}
    file = tmp_path / "ground_truth.json"
    file.write_text(json.dumps(truth))
    gt = GroundTruthFile(file)
    # a path, as for every dataset: no warning
    assert _caught(lambda: (gt == file, gt.is_file(), str(gt), bool(gt), gt.parent)) == []
    assert gt == file and isinstance(gt, Path) and gt.is_file()
    assert pickle.loads(pickle.dumps(gt)) == file
    # the document, as in rasc 0.2.0: read from the file, each use warned at its line
    uses = {"getitem": lambda: gt["left"], "get": lambda: gt.get("right"),
            "in": lambda: "left" in gt, "keys": lambda: list(gt.keys()),
            "items": lambda: dict(gt.items()), "values": lambda: list(gt.values()),
            "dict": lambda: dict(gt), "len": lambda: len(gt), "iter": lambda: list(gt)}
    expected = {"getitem": truth["left"], "get": {}, "in": True,
                "keys": ["left", "right"], "items": truth, "values": list(truth.values()),
                "dict": truth, "len": 2, "iter": ["left", "right"]}
    for name, use in uses.items():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert use() == expected[name], name
        # (dict() reads keys() then each item: one warning each, all at that line)
        assert caught and {(w.category, w.filename, w.lineno) for w in caught} == \
            {(DeprecationWarning, __file__, use.__code__.co_firstlineno)}, name
        assert ".truth" in str(caught[0].message)


@pytest.mark.slow
def test_a_rendered_datasets_ground_truth_is_its_file_and_the_old_document(rasc_render):
    ds = rasc_render(intrinsics_views=8)
    assert isinstance(ds.ground_truth, GroundTruthFile)
    assert ds.ground_truth == ds.path / "ground_truth.json"
    with pytest.warns(DeprecationWarning, match=r"\.truth") as caught:
        left = ds.ground_truth["left"]
    assert left == ds.truth["left"] and caught[0].filename == __file__


def test_the_old_class_name_warns_at_the_import():
    def users_line():
        from rasc.testing import RenderedDataset  # noqa: F401

    [(category, filename, lineno, _)] = _caught(users_line)
    assert (category, filename, lineno) == \
        (DeprecationWarning, __file__, users_line.__code__.co_firstlineno + 1)
