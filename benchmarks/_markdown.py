"""``--markdown FILE`` for the benchmark scripts: what a script prints, as a Markdown page.

The documentation site's Results pages (docs/results/) are these files, written by the
benchmarks themselves, never typed: a title, when and where it ran (UTC date, the CPU,
its cores, the load average before and after, Python and numpy, the git commit and
whether the work tree had changes), the command, then the printed output. Lines that
form Markdown tables (``| ... |``) stay tables; every other run of lines is kept
verbatim in a text block. The page is written atomically (:func:`rasc.io.write_text_atomic`)
once the script has finished, so a failed run leaves no page.

Usage in a script::

    from _markdown import add_markdown_option, markdown_page
    add_markdown_option(parser)
    args = parser.parse_args(argv)
    with markdown_page(args.markdown, "Hand-eye solver speed", __file__, argv):
        ...  # print as usual
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import io
import os
import platform
import re
import shlex
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def add_markdown_option(parser) -> None:
    """Add ``--markdown FILE`` to an argparse parser."""
    parser.add_argument("--markdown", metavar="FILE", default=None,
                        help="also write the printed results as a Markdown page (with "
                             "date, machine and commit), e.g. docs/results/NAME.md")


def _git(*args: str) -> str:
    try:
        return subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True,
                              check=True, timeout=20).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_lines(load_before: float, load_after: float) -> list[str]:
    """The "when and where" list of a results page."""
    import numpy as np

    commit = _git("rev-parse", "--short=12", "HEAD") or "unknown"
    # uncommitted changes outside the results pages (which a run of the benchmarks writes)
    dirty = bool(_git("status", "--porcelain", "--untracked-files=no", "--", ".",
                      ":(exclude)docs/results"))
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    return [
        f"- **date**: {now}",
        f"- **machine**: {_cpu_model()}, {os.cpu_count()} cores; load average "
        f"{load_before:.2f} before, {load_after:.2f} after (other processes share the cores, "
        "so compare the ratios of one run, not absolute times across runs)",
        f"- **software**: Python {platform.python_version()}, numpy {np.__version__}, "
        f"{platform.system()} {platform.release()}",
        f"- **commit**: `{commit}`" + (" (work tree with uncommitted changes)" if dirty else ""),
    ]


def to_markdown(text: str) -> str:
    """Printed output → Markdown: table lines kept, other runs of lines in text blocks."""
    out: list[str] = []
    block: list[str] = []

    def flush():
        while block and not block[-1].strip():
            block.pop()
        while block and not block[0].strip():
            block.pop(0)
        if block:
            out.extend(["", "```text", *block, "```", ""])
        block.clear()

    in_table = False
    for line in text.splitlines():
        if line.lstrip().startswith("|") and line.rstrip().endswith("|"):
            if not in_table:
                flush()
                out.append("")
            in_table = True
            out.append(line.strip())
            continue
        if in_table:
            out.append("")
            in_table = False
        if re.match(r"#{2,6} ", line):    # a heading the script prints (under the title)
            flush()
            out.extend(["", line, ""])
            continue
        block.append(line)
    flush()
    text = "\n".join(out)
    while "\n\n\n" in text:
        text = text.replace("\n\n\n", "\n\n")
    return text.strip() + "\n"


class _Tee(io.TextIOBase):
    def __init__(self, stream):
        self.stream, self.buffer_ = stream, io.StringIO()

    def write(self, s: str) -> int:
        self.stream.write(s)
        self.buffer_.write(s)
        return len(s)

    def flush(self) -> None:
        self.stream.flush()


@contextlib.contextmanager
def markdown_page(path: str | None, title: str, script: str, argv: list[str] | None,
                  summary: str = ""):
    """Tee standard output; on success write it to ``path`` as a results page."""
    if path is None:
        yield
        return
    from rasc.io import write_text_atomic

    load_before = os.getloadavg()[0]
    tee = _Tee(sys.stdout)
    with contextlib.redirect_stdout(tee):
        yield
    args = sys.argv[1:] if argv is None else list(argv)
    command = shlex.join(["python", str(Path(script).resolve().relative_to(REPO)), *args])
    page = [f"# {title}", ""]
    if summary:   # a docstring paragraph: reST roles and literals as Markdown code
        summary = re.sub(r":[a-z]+:`~?([^`]+)`", r"`\1`", summary)
        page += [re.sub(r"``([^`]+)``", r"`\1`", summary), ""]
    page += [f"Written by `{command}`; do not edit by hand, run it again.", "",
             *machine_lines(load_before, os.getloadavg()[0]), "",
             to_markdown(tee.buffer_.getvalue())]
    write_text_atomic(path, "\n".join(page))


def run_main(main, title: str, script: str) -> int:
    """Run a benchmark's ``main()`` with ``--markdown FILE`` taken off the command line
    first (for scripts whose own parser does not declare it): ``sys.exit(run_main(main,
    "Title", __file__))``."""
    import argparse

    pre = argparse.ArgumentParser(add_help=False)
    add_markdown_option(pre)
    known, rest = pre.parse_known_args(sys.argv[1:])
    sys.argv[1:] = rest
    summary = ""
    module = sys.modules.get("__main__")
    if module is not None and module.__doc__:
        summary = " ".join(module.__doc__.split("\n\n")[0].split())
    with markdown_page(known.markdown, title, script, rest, summary=summary):
        status = main()
    return int(status or 0)
