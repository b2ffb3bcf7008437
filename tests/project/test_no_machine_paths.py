"""No absolute path of a developer's machine in the project's text (issue 30 item 6):
every tracked text file (code, docs, specs, data) is read, and a path that only exists
on the machine it was written on (a home or work folder, a Windows user folder, this
checkout's own location) is a finding, named by file and line."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

#: absolute folders that are someone's machine: POSIX home, work and mount roots (not
#: preceded by a name character, a dot or a tilde, so "../work/x" and "~/x" pass) and
#: Windows user folders
MACHINE_PATH = re.compile(
    r"(?<![\w.~/-])/(?:home|root|Users|work|mnt|scratch|nfs|srv)/[\w.$-]"
    r"|\b[A-Za-z]:[\\/]+(?:Users|Documents and Settings)[\\/]", re.IGNORECASE)


def _tracked_text_files() -> list[Path]:
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("not a git checkout: the tracked files are unknown")
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True,
                            check=True, timeout=60).stdout.split(b"\0")
    return [REPO / os.fsdecode(name) for name in listed if name]


def machine_paths(text: str, own: tuple[str, ...] = ()) -> list[tuple[int, str]]:
    """(line number, line) of each line of ``text`` holding a machine's absolute path:
    :data:`MACHINE_PATH`, or one of the strings ``own`` (this checkout's folder, the
    home folder)."""
    found = []
    for n, line in enumerate(text.splitlines(), 1):
        if MACHINE_PATH.search(line) or any(s in line for s in own):
            found.append((n, line.strip()))
    return found


def test_the_pattern_finds_machine_paths_and_passes_relative_ones():
    bad = ["docs/METHOD.md §3 and " + "/wo" + "rk/shared/SPEC.md §3",
           "measured (" + "/ho" + "me/ana/notes/structure.md)",
           'open("C:' + '\\\\Users\\\\ana\\\\cal.json")', "cd " + "/Us" + "ers/ana/rasc"]
    good = ["../work/rendered", "~/.cache/rasc", "rasc/handeye/paper.py", "$HOME/x",
            "https://example.org/home/page", "the /tmp folder", "a/home/b"]
    assert [bool(machine_paths(line)) for line in bad] == [True] * len(bad)
    assert [machine_paths(line) for line in good] == [[]] * len(good)


def test_no_tracked_text_file_names_a_machine_path():
    home = os.path.expanduser("~")
    own = tuple(s for s in (str(REPO) + os.sep, home + os.sep) if len(s) > 2)
    findings = []
    for path in _tracked_text_files():
        try:
            data = path.read_bytes()
        except (FileNotFoundError, IsADirectoryError):     # deleted, not yet committed
            continue
        if b"\0" in data:
            continue                                        # binary: not text
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            continue
        findings += [f"{path.relative_to(REPO)}:{n}: {line}"
                     for n, line in machine_paths(text, own)]
    assert not findings, "absolute paths of a machine:\n" + "\n".join(findings)
