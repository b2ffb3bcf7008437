"""One place per file format (rasc/formats.py) and one number validator (rasc.io)."""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path

import numpy as np
import pytest

from rasc import formats
from rasc.errors import InputError
from rasc.io import finite_number, finite_numbers

ROOT = Path(__file__).resolve().parents[2]
TAG = re.compile(r"rasc-[a-z]+(?:-[a-z]+)*/\d+")

#: Modules that still spell a tag themselves, owned by another change in flight (issue
#: 20's study engine and the reproduction's cache); each should take it from
#: rasc/formats.py. The test fails as soon as one of them no longer needs its entry.
NOT_YET: set[str] = set()


def _resolve(ref: str):
    module, _, qualname = ref.partition(":")
    obj = importlib.import_module(module)
    for part in filter(None, qualname.split(".")):
        obj = getattr(obj, part)
    return obj


@pytest.mark.parametrize("fmt", list(formats.FORMATS.values()), ids=lambda f: f.tag)
def test_each_format_names_its_reader_and_writer(fmt):
    assert formats.FORMATS[fmt.tag] is fmt and TAG.fullmatch(fmt.tag)
    for ref in (fmt.reader, fmt.writer):
        assert callable(_resolve(ref)) or ":" not in ref, ref


def _spelled_tags(path: Path) -> list[str]:
    """String constants in code (docstrings left out) that are a format tag."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef
                                | ast.AsyncFunctionDef)
                  and node.body and isinstance(node.body[0], ast.Expr)}
    return [node.value for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in docstrings and TAG.fullmatch(node.value)]


def test_no_module_spells_a_format_tag_but_the_registry():
    found = {}
    for path in sorted([*(ROOT / "rasc").rglob("*.py"), *(ROOT / "experiments").glob("*.py")]):
        rel = path.relative_to(ROOT).as_posix()
        if rel != "rasc/formats.py" and _spelled_tags(path):
            found[rel] = _spelled_tags(path)
    assert set(found) == NOT_YET, found
    for tags in found.values():                    # even those name registered formats
        assert set(tags) <= set(formats.FORMATS), tags


def test_the_detector_can_fail(tmp_path):
    bad = tmp_path / "m.py"
    bad.write_text('"""rasc-head/1 in a docstring is prose."""\nFORMAT = "rasc-head/1"\n')
    assert _spelled_tags(bad) == ["rasc-head/1"]


@pytest.mark.parametrize(("value", "message"), [
    ("8", r'^f\.x: expected a number, got "8"$'),
    (True, r"^f\.x: expected a number, got true$"),
    (None, r"^f\.x: expected a number, got null$"),
    ([1.0], r"^f\.x: expected a number, got \[1\.0\]$"),
    (float("nan"), r"^f\.x: must be finite, got NaN$"),
    (-float("inf"), r"^f\.x: must be finite, got -Infinity$"),
    (10**400, r"^f\.x: 1000.*\.\.\. is out of range$"),
])
def test_finite_number_refuses_in_one_line_naming_where(value, message):
    with pytest.raises(InputError, match=message):
        finite_number(value, "f.x")


def test_finite_number_accepts_numbers_and_text_cells():
    assert finite_number(3, "x") == 3.0 and type(finite_number(3, "x")) is float
    assert finite_number(np.float32(0.5), "x") == 0.5
    assert finite_number(" -2.5e3 ", "x", text=True) == -2500.0
    with pytest.raises(InputError, match=r"^c: empty; expected a number$"):
        finite_number("  ", "c", text=True)
    with pytest.raises(InputError, match=r'^c: must be finite, got "nan"$'):
        finite_number("nan", "c", text=True)
    with pytest.raises(InputError, match=r'^c: "2e9" is out of range \(\|value\| > 1e\+09\)$'):
        finite_number("2e9", "c", text=True, max_abs=1e9)
    with pytest.raises(InputError, match=r"^c: expected a number, got np"):
        finite_number(np.bool_(True), "c")


def test_finite_number_without_where_gives_the_problem_alone():
    """For a caller that puts the place in front itself (the study spec's checkers)."""
    with pytest.raises(InputError, match=r'^expected a number, got "8"$'):
        finite_number("8", "")
    with pytest.raises(InputError, match=r"^2e\+16 is out of range \(\|value\| > 1e\+15\)$"):
        finite_number(2e16, "", max_abs=1e15)


def test_finite_numbers_checks_every_item_and_the_count():
    assert finite_numbers([1, 2.5, np.float64(3)], "v") == (1.0, 2.5, 3.0)
    assert finite_numbers(np.array([0.5, -1.0]), "v", count=2) == (0.5, -1.0)
    assert finite_numbers(" -0.2, 0.05", "--d", text=True) == (-0.2, 0.05)
    assert finite_numbers("", "--d", text=True) == ()
    for values, kwargs, message in [
        ([1, "2"], {}, r'^v\[1\]: expected a number, got "2"$'),
        ((0.0, float("nan")), {}, r"^v\[1\]: must be finite, got NaN$"),
        ("1,x", {"text": True}, r'^v\[1\]: expected a number, got "x"$'),
        ("1,,2", {"text": True}, r"^v\[1\]: empty; expected a number$"),
        ([1, 2], {"count": 3, "what": "X,Y,Z"},
         r"^v: expected 3 numbers \(X,Y,Z\), got 2: \[1, 2\]$"),
        ("0,30", {"count": 3, "text": True}, r'^v: expected 3 numbers, got 2: "0,30"$'),
        ("12", {}, r'^v: expected a list of numbers, got "12"$'),     # a string is no list
        (np.zeros((2, 2)), {"what": "k1,k2"}, r"^v: expected a list of numbers \(k1,k2\)"),
        ([1e10], {"max_abs": 1e9},
         r"^v\[0\]: 10000000000.0 is out of range \(\|value\| > 1e\+09\)$"),
    ]:
        with pytest.raises(InputError, match=message):
            finite_numbers(values, "v", **kwargs)
