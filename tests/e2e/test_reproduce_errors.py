"""An input error in the middle of ``experiments.reproduce``: the same clean-up as an
interrupt (experiments/reproduce.py ``main``).

The default dataset's section and the experiments are replaced by stand-ins (the error
path is the claim, not the experiments): the first experiment finishes and writes a file,
the second writes into its staging folder and raises :class:`rasc.errors.InputError`.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the experiments package

from experiments import reproduce  # noqa: E402
from experiments._common import PARTIAL_PREFIX, Section  # noqa: E402
from rasc.errors import InputError  # noqa: E402


def test_an_input_error_mid_run_keeps_the_finished_and_removes_the_partial(
        tmp_path, monkeypatch, capsys):
    (first, _), (second, _) = reproduce.EXPERIMENTS[:2]
    one, two = (importlib.import_module(f"experiments.{n}") for n in (first, second))
    ran = []

    def finishes(ctx):
        (ctx.dir(one.NAME) / "result.csv").write_text("a\n1\n")
        ran.append(one.NAME)
        return Section(one.NAME, "", "done")

    def fails(ctx):
        staging = ctx.dir(two.NAME)
        (staging / "half.csv").write_text("a\n")
        assert staging.name == PARTIAL_PREFIX + two.NAME          # it writes while staging
        ran.append(two.NAME)
        raise InputError("stand-in: a bad value met halfway")

    monkeypatch.setattr(reproduce, "pipeline_section", lambda ctx: Section("pipeline", "", ""))
    monkeypatch.setattr(one, "run", finishes)
    monkeypatch.setattr(two, "run", fails)
    out = tmp_path / "out"
    assert reproduce.main(["--quick", "--workers", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "reproduce: error: stand-in: a bad value met halfway"
    assert ran == [one.NAME, two.NAME]
    assert (out / one.NAME / "result.csv").read_text() == "a\n1\n"     # finished: kept
    assert not list(out.glob(PARTIAL_PREFIX + "*"))                    # unfinished: removed
    assert not (out / two.NAME).exists()
    assert not (out / "REPORT.md").exists()
