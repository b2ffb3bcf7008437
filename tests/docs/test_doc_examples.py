"""Every example of README.md and docs/**/*.md runs, one test per page (the collector and
its conventions: tests/docs/conftest.py)."""

from __future__ import annotations


def test_page_examples_run(doc_page, run_doc_page):
    assert run_doc_page(doc_page) >= 0


def test_the_collector_sees_the_readme_and_the_guide(doc_collector):
    rel = {p.relative_to(doc_collector.REPO).as_posix() for p in doc_collector.doc_pages()}
    assert "README.md" in rel
    assert all(not r.startswith("docs/_build/") for r in rel)


def test_console_blocks_split_into_commands(doc_collector):
    block = "$ echo a \\\n  b\nout\n$ false\n# not a command\n"
    assert doc_collector.console_commands(block) == ["echo a \n  b", "false"]


def test_exit_directive_is_read_only_right_before_a_block(doc_collector):
    text = "<!-- exit: 2 -->\n\n```console\n$ x\n```\n"
    assert doc_collector.expected_exit(text, text.index("```")) == 2
    text = "<!-- exit: 2 -->\nsome prose\n```console\n$ x\n```\n"
    assert doc_collector.expected_exit(text, text.index("```")) == 0


def test_a_failing_command_fails_its_page(doc_collector, page_folder, tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```console\n$ exit 3\n```\n")
    try:
        doc_collector.run_page(page, tmp_path)
    except AssertionError as exc:
        assert "exited 3" in str(exc)
    else:
        raise AssertionError("a command exiting 3 passed")
    page.write_text("<!-- exit: 3 -->\n```console\n$ true\n$ exit 3\n```\n"
                    "<!-- skip: next -->\n```python\nraise SystemExit(1)\n```\n"
                    "```python\nx = 1\n```\n```python\nassert x == 1\n```\n")
    assert doc_collector.run_page(page, tmp_path) == 3


def test_a_file_block_is_written_not_run(doc_collector, page_folder, tmp_path):
    page = tmp_path / "page.md"
    page.write_text("<!-- file: sub/spec.py -->\n\n```python\nraise SystemExit(1)\n```\n\n"
                    "```console\n$ grep -q SystemExit sub/spec.py\n```\n")
    assert doc_collector.run_page(page, tmp_path) == 1
    assert (page_folder / "sub" / "spec.py").read_text() == "raise SystemExit(1)\n"
