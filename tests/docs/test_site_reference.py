"""The generators behind the site's reference pages (docs/_ext/rasc_docs.py).

They parse the package's sources; these tests pin what they must find on hand-made
source text and on the real package, so that a reference page cannot quietly go empty.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

DOCS_EXT = Path(__file__).resolve().parents[2] / "docs" / "_ext"
sys.path.insert(0, str(DOCS_EXT))
rasc_docs = pytest.importorskip("rasc_docs")   # needs docutils and Sphinx (the docs extra)


def _expr(source: str) -> ast.AST:
    return ast.parse(source, mode="eval").body


def test_message_text_keeps_the_words_and_marks_what_is_filled_in():
    assert rasc_docs.message_text(_expr('f"{path}: line {pos.line}: bad {x[0] + 1:.3g}"')) \
        == "{path}: line {pos.line}: bad {…}"
    assert rasc_docs.message_text(_expr('"plain " + f"{name}"')) == "plain {name}"
    assert rasc_docs.message_text(_expr('"n = {}".format(n)')) == "n = {}"
    assert rasc_docs.message_text(_expr("message")) is None     # passed on from elsewhere


@pytest.mark.slow   # parses every module of the package (about 1 s of CPU)
def test_refusals_and_warnings_of_the_package():
    refusals = rasc_docs.collect_messages("refusals")
    warnings = rasc_docs.collect_messages("warnings")
    # the hand-eye document reader refuses, the advice module warns (both long-lived)
    assert "rasc.handeye.document" in refusals
    texts = [t for items in warnings.values() for *_, t in items]
    assert any("the paper found such solutions unusable" in t for t in texts)
    kinds = {cls for items in refusals.values() for _, _, cls, _ in items}
    assert "InputError" in kinds and "DegenerateDataError" in kinds
    assert sum(map(len, refusals.values())) > 100


@pytest.mark.slow   # may parse every module of the package
def test_formats_of_the_package():
    rows = {r["tag"]: r for r in rasc_docs.format_rows()}
    assert "rasc-handeye/1" in rows and "rasc-dataset/1" in rows
    assert all(rasc_docs.FORMAT_RE.match(tag) for tag in rows)
    assert rows["rasc-dataset/1"]["written"] and rows["rasc-dataset/1"]["read"]


def test_format_scan_finds_declaration_writer_and_reader():
    source = (
        'FORMAT = "rasc-thing/2"\n'
        'def write(x):\n    return {"format": FORMAT, "x": x}\n'
        'def read(doc):\n    if doc.get("format") != FORMAT:\n        raise ValueError\n'
        'def other():\n    return {"format": "rasc-other/1"}\n')
    found = rasc_docs.collect_formats([("rasc.thing", None, ast.parse(source))])
    assert dict(found["rasc-thing/2"]) == {"declared": {"rasc.thing.FORMAT"},
                                           "written": {"rasc.thing.write"},
                                           "read": {"rasc.thing.read"}}
    assert dict(found["rasc-other/1"]) == {"written": {"rasc.thing.other"}}


def test_plain_field_lists_become_bullets_and_sections_stay():
    lines = ["A dataclass.", "", "name : what it is", "    and more of it.",
             "a, b : two at once", "", "Parameters", "----------",
             "x : int", "    left as numpydoc wrote it"]
    out = rasc_docs.plain_field_lists(lines)
    assert out[:5] == ["A dataclass.", "", "- ``name`` : what it is", "  and more of it.",
                       "- ``a``, ``b`` : two at once"]
    assert out[-4:] == lines[-4:]


def test_bars_are_escaped_outside_literals_only():
    lines = ["the norm |t| and ``|x|`` stay", "Example::", "", "    |a| = 1", "", "back |b|"]
    out = rasc_docs._escape_bars(lines)
    assert out[0] == "the norm \\|t\\| and ``|x|`` stay"
    assert out[3] == "    |a| = 1"
    assert out[5] == "back \\|b\\|"


def test_front_page_globs_that_match_nothing_are_dropped(tmp_path):
    from types import SimpleNamespace

    (tmp_path / "guide").mkdir()
    (tmp_path / "guide" / "install.md").write_text("# Install\n")
    (tmp_path / "topics").mkdir()                     # no page yet
    (tmp_path / "METHOD.md").write_text("# Method\n")
    app = SimpleNamespace(srcdir=str(tmp_path), config=SimpleNamespace(root_doc="index"))
    text = "```{toctree}\n:glob:\n\nguide/*\ntopics/*\nMETHOD*\nNOTES*\nchangelog\n```\n"
    source = [text]
    rasc_docs._drop_empty_globs(app, "index", source)
    assert source[0] == "```{toctree}\n:glob:\n\nguide/*\nMETHOD*\nchangelog\n```\n"
    other = [text]
    rasc_docs._drop_empty_globs(app, "guide/install", other)    # only the front page
    assert other == [text]


@pytest.mark.slow   # parses every module of the package
def test_exceptions_of_the_package():
    found = {(module, name): bases for module, name, bases, _ in rasc_docs.collect_exceptions()}
    assert found[("rasc.errors", "RascError")] == ["Exception"]
    assert ("rasc.errors", "InputError") in found
    # every class listed derives from RascError through the listed names
    names = {name for _, name in found}
    assert all(set(bases) & (names | {"Exception"}) for bases in found.values())
