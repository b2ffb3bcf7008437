"""An experiment script interrupted (SIGTERM, as Ctrl-C) ends with one line on stderr that
says what it kept, status 130, no section on stdout and no half-written file."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_sigterm_during_an_experiment_script(default_dataset, tmp_path):
    out = tmp_path / "out"
    (out / "data").mkdir(parents=True)
    (out / "data" / "dataset").symlink_to(default_dataset, target_is_directory=True)
    env = {**os.environ, "MUJOCO_GL": "egl", "RASC_CACHE_DIR": str(tmp_path / "cache")}
    proc = subprocess.Popen([sys.executable, "-m", "experiments.e1_noise", "--quick",
                             "--out", str(out), "--workers", "1"], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = []
    for line in proc.stderr:                 # the experiment's own stage has begun
        seen.append(line)
        if line.startswith("== E1"):
            proc.send_signal(signal.SIGTERM)
            break
    stdout, rest = proc.communicate(timeout=120)
    assert any(s.startswith("== E1") for s in seen), "".join(seen)
    assert proc.returncode == 130, "".join(seen) + rest
    lines = [s for s in rest.splitlines() if "interrupted" in s]
    assert lines == [f"e1_noise: interrupted: kept the files already written under {out} "
                     "(each written whole: nothing half-written is left); a study's finished "
                     "cells are reused by the next run; no section printed"], rest
    assert "Traceback" not in rest and stdout == ""
    leftovers = [p for p in out.rglob("*") if p.name.startswith((".tmp", ".partial"))
                 or p.suffix == ".tmp"]
    assert leftovers == []
