"""README.md's "Frames" section lists exactly the rows of rasc/geometry/frames.py, and its
Python example runs and prints what its comments say."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

from rasc.geometry.frames import FRAMES, TRANSFORMS, UNIT_PARAMETERS

README = Path(__file__).resolve().parents[1] / "README.md"


def section(title: str) -> str:
    text = README.read_text()
    start = text.index(f"\n## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end > 0 else None]


def tables(text: str) -> dict[tuple[str, ...], list[tuple[str, ...]]]:
    """Markdown tables by header row; cells stripped of surrounding backticks."""
    out: dict = {}
    rows: list = []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            cells = tuple(c.strip().strip("`") for c in line.strip().strip("|").split("|"))
            if not all(set(c) <= {"-", ":"} for c in cells):
                rows.append(cells)
        elif rows:
            out[rows[0]] = rows[1:]
            rows = []
    return out


@pytest.fixture(scope="module")
def frames_tables():
    return tables(section("Frames"))


def test_frame_table(frames_tables):
    assert frames_tables[("frame", "paper", "meaning")] == [
        (f.name, f.symbol, f.meaning) for f in FRAMES]


def test_transform_table(frames_tables):
    assert frames_tables[("transform", "paper", "what")] == [
        (t.name, t.symbol, t.meaning) for t in TRANSFORMS]


def test_unit_parameter_table(frames_tables):
    assert frames_tables[("parameter", "symbol", "meaning", "unit")] == [
        (p.name, p.symbol, p.meaning, p.unit) for p in UNIT_PARAMETERS]


def test_unit_parameters_are_the_model_s():
    from dataclasses import fields

    from rasc.geometry.kinematics import PanTiltUnit
    names = {f.name for f in fields(PanTiltUnit)}
    listed = [p.name for p in UNIT_PARAMETERS]
    assert names <= set(listed)
    for extra in set(listed) - names:   # the derived ones are properties
        assert isinstance(getattr(PanTiltUnit, extra), property)


def test_frames_example_runs_and_prints_its_comments():
    blocks = re.findall(r"```python\n(.*?)```", section("Frames"), flags=re.S)
    assert len(blocks) == 1
    code = blocks[0]
    expected = [line.split("#", 1)[1] for line in code.splitlines()
                if line.startswith("print(") and "#" in line]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {})
    printed = out.getvalue().splitlines()
    assert len(printed) == len(expected) == 2
    number = r"-?\d+\.?\d*(?:e-?\d+)?"
    for got, want in zip(printed, expected, strict=True):
        got_n = [float(x) for x in re.findall(number, got)]
        want_n = [float(x) for x in re.findall(number, want.split("(")[0])]
        assert got_n == pytest.approx(want_n, abs=1e-12), (got, want)
