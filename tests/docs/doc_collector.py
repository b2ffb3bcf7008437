"""The one collector of the documentation's examples (README.md and docs/**/*.md).

Every page's examples run, in order, as one test (``tests/docs/test_doc_examples.py``,
one parametrised case per page, so that under pytest-xdist a page never splits across
workers). The conventions, which every page follows (docs/guide/developer.md repeats
them for writers):

- ```` ```python ```` blocks of a page run in order in one namespace (sybil's MyST
  parser; ``>>>`` blocks are doctests), with the working directory a fresh temporary
  folder per page, ``RASC_CACHE_DIR`` the test run's shared cache and ``MUJOCO_GL=egl``.
  The folder holds a copy of the repository's ``examples/`` folder, so that a command
  written "from the repository's root" (``rasc handeye examples/handeye_nine_poses.json``)
  runs as shown.
- ```` ```console ```` blocks: each line starting with ``$ `` (continued by a trailing
  backslash) is run with bash in the page's folder, with this checkout's ``rasc`` and
  ``python`` first on PATH and the checkout on PYTHONPATH. The lines after a command are
  the output a reader should expect; they are not compared. Every command must exit 0,
  unless the block is preceded by ``<!-- exit: N -->``: then the block's last command
  must exit N and each earlier one 0 or N.
- ``<!-- file: NAME -->`` right before a fenced block (any language) writes the block's
  text to NAME in the page's folder instead of running it: a spec, a test file or a
  parameter file the reader is asked to save, which later commands then use.
- ``<!-- skip: next -->`` before a block leaves it out (sybil's skip directive; also
  ``skip: start`` / ``skip: end``). Other fences (text, sh, toml, json, ...) never run.

A page is marked ``slow`` when it runs a console command or a Python block that renders,
calibrates or runs a study (subprocesses and renders take a second or more); the other
pages run in ``make test-fast`` too.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def doc_pages() -> list[Path]:
    """README.md and every Markdown page under docs/ (the built site's folder excluded)."""
    pages = [REPO / "README.md"]
    docs = REPO / "docs"
    if docs.is_dir():
        pages += sorted(p for p in docs.rglob("*.md")
                        if "_build" not in p.relative_to(docs).parts)
    return pages


# ----------------------------------------------------------------------- console blocks

#: ``<!-- exit: N -->`` right before a block (blank lines and other comments between)
EXIT_DIRECTIVE = re.compile(r"<!--+\s*exit:\s*(\d+)\s*--+>\s*(?:<!--.*?-->\s*)*\Z", re.S)


def console_commands(source: str) -> list[str]:
    """The ``$ `` commands of a console block, a trailing backslash joining lines into one
    command (as a shell's line continuation does: they were joined by a newline, which
    ran the halves as two commands)."""
    commands: list[str] = []
    lines = iter(source.splitlines())
    for line in lines:
        if not line.startswith("$ "):
            continue
        command = line[2:]
        while command.endswith("\\"):
            command = command[:-1].rstrip() + " " + next(lines, "").lstrip()
        commands.append(command)
    return commands


def expected_exit(document_text: str, start: int) -> int:
    """N of a ``<!-- exit: N -->`` just before the block starting at ``start``, else 0."""
    match = EXIT_DIRECTIVE.search(document_text[max(0, start - 400):start])
    return int(match.group(1)) if match else 0


def page_environment(cache: Path) -> dict[str, str]:
    env = dict(os.environ)
    bin_dir = str(Path(sys.executable).parent)
    env["PATH"] = bin_dir + os.pathsep + env.get("PATH", "")
    env["PYTHONPATH"] = os.pathsep.join(
        [str(REPO)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    env["RASC_CACHE_DIR"] = str(cache)
    env["MUJOCO_GL"] = env.get("MUJOCO_GL") or "egl"
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def run_console(example) -> str | None:
    """Evaluator of a console block: its commands in order; a failure message or None."""
    commands = console_commands(str(example.parsed))
    want = expected_exit(example.document.text, example.start)
    env = example.namespace["__doc_env__"]
    example.namespace["__doc_ran__"] = example.namespace.get("__doc_ran__", 0) + 1
    for k, command in enumerate(commands):
        proc = subprocess.run(["bash", "-c", command], cwd=os.getcwd(), env=env,
                              capture_output=True, text=True, timeout=600, check=False)
        last = k == len(commands) - 1
        allowed = {want} if last else {0, want}
        if proc.returncode not in allowed:
            return (f"$ {command}\nexited {proc.returncode}, the page promises "
                    f"{' or '.join(map(str, sorted(allowed)))}\n"
                    f"--- stdout\n{proc.stdout[-3000:]}--- stderr\n{proc.stderr[-3000:]}")
    return None


# ------------------------------------------------------------------------ file blocks

FILE_BLOCK = re.compile(
    r"^<!--+\s*file:\s*(?P<name>[^\s>]+)\s*--+>[ \t]*\n(?:[ \t]*\n)*"
    r"(?P<fence>`{3,}|~{3,})[^\n]*\n(?P<body>.*?)^(?P=fence)[ \t]*$", re.M | re.S)


def write_file(example) -> None:
    name, body = example.parsed
    path = Path(os.getcwd()) / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(body, encoding="utf-8")


def file_regions(document):
    from sybil import Region

    for m in FILE_BLOCK.finditer(document.text):
        yield Region(m.start(), m.end(), (m.group("name"), m.group("body")), write_file)


# ----------------------------------------------------------------------------- parsing

def parse_page(path: Path):
    """The sybil Document of a page: python (and doctest) blocks, console blocks, skips."""
    from sybil import Document
    from sybil.parsers.abstract import AbstractCodeBlockParser
    from sybil.parsers.markdown.lexers import FencedCodeBlockLexer
    from sybil.parsers.myst import PythonCodeBlockParser, SkipParser

    python = PythonCodeBlockParser()
    run_python = python.codeblock_parser._evaluator

    def counted_python(example):
        __tracebackhide__ = True
        example.namespace["__doc_ran__"] = example.namespace.get("__doc_ran__", 0) + 1
        return run_python(example)

    python.codeblock_parser._evaluator = counted_python
    console = AbstractCodeBlockParser([FencedCodeBlockLexer("console")],
                                      language="console", evaluator=run_console,
                                      language_lexeme_name="language")
    text = path.read_text(encoding="utf-8")
    document = Document(text, str(path))
    files = list(file_regions(document))
    for region in files:
        document.add(region)
    for parser in (python, console, SkipParser()):
        for region in parser(document):
            if not any(f.start <= region.start < f.end for f in files):
                document.add(region)
    return document


SLOW_WORDS = re.compile(r"render|calibrat|run_study|study|reproduce|subprocess")


def page_is_slow(document) -> bool:
    for example in document.examples():
        parsed = str(example.parsed)
        if example.region.evaluator is run_console or (
                isinstance(example.parsed, str) and SLOW_WORDS.search(parsed)):
            return True
    return False


def page_params() -> Iterator:
    for path in doc_pages():
        rel = path.relative_to(REPO).as_posix()
        try:
            slow = page_is_slow(parse_page(path))
        except Exception:                   # a page that does not parse fails in its test
            slow = False
        yield pytest.param(path, id=rel, marks=[pytest.mark.slow] if slow else [])


def copy_examples(folder: Path) -> None:
    """The repository's examples/ folder into a page's folder."""
    shutil.copytree(REPO / "examples", folder / "examples", ignore=shutil.ignore_patterns(
        "__pycache__", "build", "*.egg-info"))


def run_page(path: Path, cache: Path) -> int:
    """Every example of the page in order (one namespace); the number evaluated."""
    document = parse_page(path)
    document.namespace["__doc_env__"] = page_environment(cache)
    document.namespace["__name__"] = "__doc_example__"
    for example in document.examples():
        if example.region.evaluator is None:
            continue
        try:
            example.evaluate()
        except Exception as exc:
            if type(exc).__name__ == "SkipTest":
                pytest.skip(f"{path.name}:{example.line}: {exc}")
            rel = path.relative_to(REPO) if path.is_relative_to(REPO) else path
            raise AssertionError(f"{rel}, the example at line {example.line}: "
                                 f"{type(exc).__name__}: {exc}") from exc
    return document.namespace.get("__doc_ran__", 0)


