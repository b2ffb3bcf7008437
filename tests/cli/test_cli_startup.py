"""The command line's start-up: what ``rasc`` loads before a command runs.

Building the parser imports every command module, and none of them imports numpy, scipy,
OpenCV, MuJoCo or matplotlib at its top (rasc.commands): ``rasc --help``, ``--version`` and
a usage error cost a bare Python start-up. Each command loads its libraries at the start
of its ``run()`` inside :func:`rasc.commands.loading`, which raises an interrupt that
arrived while they loaded even when a library swallowed it (tested here by making
``received()`` answer yes; real signals during the load: tests/cli/test_hostile.py).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import rasc.commands
from rasc.cli import COMMANDS, main

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("numpy", "scipy", "cv2", "mujoco", "matplotlib", "tqdm")


def test_help_version_and_usage_errors_load_no_library():
    """In a fresh process: the parser, ``--help`` of rasc and of every command,
    ``--version``, a missing argument and an unknown option; none loads a library."""
    code = (
        "import contextlib, io, sys\n"
        "from rasc.cli import COMMANDS, command_name, main\n"
        "codes = []\n"
        "argvs = [['--help'], ['--version'], ['handeye'], ['calibrate', '--nope'],\n"
        "         *[[command_name(c), '--help'] for c in COMMANDS]]\n"
        "for argv in argvs:\n"
        "    with contextlib.redirect_stdout(io.StringIO()), "
        "contextlib.redirect_stderr(io.StringIO()):\n"
        "        try:\n"
        "            codes.append(main(argv))\n"
        "        except SystemExit as exc:\n"
        "            codes.append(exc.code)\n"
        f"print(codes, sorted(m for m in {HEAVY!r} if m in sys.modules))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=60, check=False)
    assert proc.returncode == 0, proc.stderr
    n = len(COMMANDS)
    assert proc.stdout.split("] [")[0] == "[" + ", ".join(["0", "0", "2", "2"] + ["0"] * n)
    assert proc.stdout.strip().endswith(" []"), proc.stdout


#: each command with arguments that parse; its inputs need not exist, since the libraries
#: load (and the interrupt check runs) before any input is read or output written
_ARGV = {
    "handeye": ["handeye", "{ws}/poses.json", "--out", "{ws}/out.json"],
    "render": ["render", "--out", "{ws}/ds", "--quiet"],
    "calibrate": ["calibrate", "{ws}/ds", "--out", "{ws}/out.json", "--quiet"],
    "detect": ["detect", "{ws}/ds", "--out", "{ws}/points.csv", "--quiet"],
    "triangulate": ["triangulate", "{ws}/cal.json", "{ws}/pixels.csv", "--angle-unit", "deg",
                    "--out", "{ws}/out.json"],
    "project": ["project", "{ws}/cal.json", "{ws}/points.csv", "--angle-unit", "deg",
                "--out", "{ws}/out.json"],
    "look_at": ["look-at", "{ws}/cal.json", "--point", "0,1,0", "--angle-unit", "deg",
                "--out", "{ws}/out.json"],
    "study": ["study", "{ws}/spec.toml", "--out", "{ws}/study", "--quiet"],
    "import_recording": ["import", "{ws}/rec.bag", "--out", "{ws}/ds", "--quiet"],
    "report": ["report", "{ws}/cal.json", "--out", "{ws}/report.pdf"],
    "plan": ["plan", "--out", "{ws}/positions.csv"],
    "rectify": ["rectify", "{ws}/cal.json", "--left-readings", "0,0", "--right-readings", "0,0",
                "--angle-unit", "deg", "--out", "{ws}/rectified"],
    "export": ["export", "{ws}/cal.json", "--format", "urdf", "--out", "{ws}/head.urdf"],
}


def test_every_command_is_listed_here():
    assert set(_ARGV) == set(COMMANDS)


@pytest.mark.parametrize("command", COMMANDS)
def test_an_interrupt_swallowed_while_the_libraries_load_still_counts(command, tmp_path,
                                                                      capsys, monkeypatch):
    """A signal that arrived while ``run()`` loaded its libraries, and that a library
    swallowed (``received()`` is true, no KeyboardInterrupt came): one line, exit 130,
    nothing written; without the check the command would go on (and here refuse its
    missing input with status 2)."""
    monkeypatch.setattr(rasc.commands, "received", lambda: True)
    argv = [a.format(ws=tmp_path) for a in _ARGV[command]]
    capsys.readouterr()
    assert main(argv) == 130
    cap = capsys.readouterr()
    assert cap.out == ""
    assert cap.err.splitlines() == [f"rasc {argv[0]}: interrupted: nothing written"]
    assert list(tmp_path.iterdir()) == []
