"""The frame tables are written once (rasc/geometry/frames.py) and generated where docs
show them: every marked block in docs/ is what rasc.geometry.frames renders."""

from __future__ import annotations

from pathlib import Path

from rasc import layout
from rasc.geometry.frames import FRAMES, TABLES, render_tables


def markdown_table(name: str) -> str:
    return layout.markdown_table(*{**layout.TABLES, **TABLES}[name])

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_docs_tables_are_generated_and_current():
    marked = {}
    for page in sorted(DOCS.rglob("*.md")):
        text = page.read_text(encoding="utf-8")
        assert render_tables(text) == text, f"{page}: run rasc.geometry.frames.render_tables"
        marked[page.name] = text.count("<!-- end table -->")
    assert marked["METHOD.md"] == 2                       # frames and transforms, §1
    assert marked["CONTRACTS.md"] == 1                    # the layout


def test_render_tables_replaces_a_stale_copy_and_keeps_the_rest():
    stale = ("intro\n<!-- table: frames (generated from rasc/geometry/frames.py) -->\n"
             "| frame | paper |\n| --- | --- |\n| base | b |\n<!-- end table -->\nafter\n")
    out = render_tables(stale)
    assert out != stale and out.startswith("intro\n")
    assert out.endswith("<!-- end table -->\nafter\n")
    assert markdown_table("frames") in out and render_tables(out) == out


def test_markdown_table_has_every_row():
    lines = markdown_table("frames").splitlines()
    assert lines[0] == "| frame | paper | meaning |" and lines[1] == "| --- | --- | --- |"
    assert [line.split(" | ")[0].lstrip("| ") for line in lines[2:]] == [f.name for f in FRAMES]
    for name, (header, rows) in {**layout.TABLES, **TABLES}.items():
        assert len(markdown_table(name).splitlines()) == 2 + len(rows)
        assert all(len(r) == len(header) for r in rows)
