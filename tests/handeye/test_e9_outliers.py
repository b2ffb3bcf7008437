"""E9 (experiments/e9_outliers.py) in its --quick protocol: files, rows and its claims."""

from __future__ import annotations

import pytest

from experiments import e9_outliers as e9
from experiments._common import Context, read_csv


@pytest.mark.slow
def test_e9_quick_files_rows_and_claims(tmp_path):
    ctx = Context.from_argv(e9.__doc__, ["--quick", "--out", str(tmp_path)])
    sec = e9.run(ctx)
    folder = tmp_path / e9.NAME
    syn = read_csv(folder / "synthetic.csv")
    assert len(syn) == len(e9.FRACTIONS) * e9.QUICK_SAMPLES * len(e9.METHODS)
    assert (folder / "e9_outliers.png").stat().st_size > 10_000
    for m in e9.METHODS:
        assert f"| {m} |" in sec.markdown

    def median(method, fraction, col):
        v = sorted(float(r[col]) for r in syn
                   if r["method"] == method and float(r["fraction"]) == fraction)
        return v[len(v) // 2]

    # issue 22's bar on these draws (4 samples: loose, 1.5x as the issue states): with
    # 20 % bad positions rasc-robust within 1.5x its clean-data error; RASC far off
    for col in ("rotation_deg", "translation_mm"):
        assert median("rasc-robust", 0.2, col) <= 1.5 * median("rasc", 0.0, col)
        assert median("rasc", 0.2, col) > 5 * median("rasc", 0.0, col)
    assert sec.summary["recall"] == 1.0 and sec.summary["precision"] >= 0.9
    scale = read_csv(folder / "scale.csv")
    assert all(abs(float(r["scale"]) - e9.SCALE) < 0.01 * e9.SCALE
               for r in scale if r["method"] == "rasc-scale")
