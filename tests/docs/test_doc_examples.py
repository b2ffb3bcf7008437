"""Every example of README.md and docs/**/*.md runs, one test per page (the collector and
its conventions: tests/docs/doc_collector.py)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import doc_collector as collector


def pytest_generate_tests(metafunc):
    """``doc_page``: one case per page (README.md, docs/**/*.md)."""
    if "doc_page" in metafunc.fixturenames:
        metafunc.parametrize("doc_page", list(collector.page_params()))


@pytest.fixture
def page_folder(tmp_path, monkeypatch, rasc_testing_cache) -> Path:
    """A fresh folder per page with a copy of examples/, as the cwd; the cache set."""
    collector.copy_examples(tmp_path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("RASC_CACHE_DIR", str(rasc_testing_cache))
    monkeypatch.setenv("MUJOCO_GL", os.environ.get("MUJOCO_GL") or "egl")
    monkeypatch.syspath_prepend(str(collector.REPO))
    return tmp_path


def test_page_examples_run(doc_page, page_folder, rasc_testing_cache):
    assert collector.run_page(doc_page, rasc_testing_cache) >= 0


def test_the_collector_sees_the_readme_and_the_guide():
    rel = {p.relative_to(collector.REPO).as_posix() for p in collector.doc_pages()}
    assert "README.md" in rel
    assert all(not r.startswith("docs/_build/") for r in rel)


def test_console_blocks_split_into_commands():
    block = "$ echo a \\\n  b\nout\n$ false\n# not a command\n"
    assert collector.console_commands(block) == ["echo a b", "false"]


def test_exit_directive_is_read_only_right_before_a_block():
    text = "<!-- exit: 2 -->\n\n```console\n$ x\n```\n"
    assert collector.expected_exit(text, text.index("```")) == 2
    text = "<!-- exit: 2 -->\nsome prose\n```console\n$ x\n```\n"
    assert collector.expected_exit(text, text.index("```")) == 0


def test_a_failing_command_fails_its_page(page_folder, tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```console\n$ exit 3\n```\n")
    with pytest.raises(AssertionError, match="exited 3"):
        collector.run_page(page, tmp_path)
    page.write_text("<!-- exit: 3 -->\n```console\n$ true\n$ exit 3\n```\n"
                    "<!-- skip: next -->\n```python\nraise SystemExit(1)\n```\n"
                    "```python\nx = 1\n```\n```python\nassert x == 1\n```\n")
    assert collector.run_page(page, tmp_path) == 3


def test_a_failing_python_block_names_its_line(page_folder, tmp_path):
    page = tmp_path / "page.md"
    page.write_text("text\n\n```python\nassert 1 == 2, 'no'\n```\n")
    with pytest.raises(AssertionError, match="line 3"):
        collector.run_page(page, tmp_path)


def test_a_file_block_is_written_not_run(page_folder, tmp_path):
    page = tmp_path / "page.md"
    page.write_text("<!-- file: sub/spec.py -->\n\n```python\nraise SystemExit(1)\n```\n\n"
                    "```console\n$ grep -q SystemExit sub/spec.py\n```\n")
    assert collector.run_page(page, tmp_path) == 1
    assert (page_folder / "sub" / "spec.py").read_text() == "raise SystemExit(1)\n"
