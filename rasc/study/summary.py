"""A study's summary stage: rasc's one CSV writer (:func:`csv_text`), the tidy
``samples.csv`` from the cells' files, and per cell and method the statistics of each
error with a bootstrap confidence interval of the mean (:func:`summarise`)."""

from __future__ import annotations

import csv
import io
from collections.abc import Callable
from typing import Any

import numpy as np

from rasc.datasets.keys import CACHE_LIBRARIES, code_digest  # noqa: F401 (re-exported)
from rasc.study.spec import (
    STATS,
    Cell,
    Spec,
)

BOOTSTRAP_KEY = 0xB007


def fmt(x: Any) -> str:
    """A CSV field: floats in their shortest round-trip form, NaN and None as ''."""
    if x is None:
        return ""
    if isinstance(x, float | np.floating):
        x = float(x)
        return "" if not np.isfinite(x) else repr(x)
    if isinstance(x, list | tuple):
        return " ".join(fmt(v) for v in x)
    return str(x)


def csv_text(header, rows, field: Callable[[Any], str] | None = None) -> str:
    """rasc's one CSV writer: ``header``, then each row's fields formatted by ``field``
    (default :func:`fmt`), ``\\n`` line ends."""
    field = field or fmt
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in rows:
        w.writerow([field(v) for v in row])
    return buf.getvalue()


def bootstrap_ci(x: np.ndarray, rng: np.random.Generator, resamples: int,
                 confidence: float) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``x`` (n,); NaN for n < 2."""
    if len(x) < 2:
        return float("nan"), float("nan")
    means = x[rng.integers(0, len(x), (resamples, len(x)))].mean(axis=1)
    a = (1.0 - confidence) / 2.0
    lo, hi = np.quantile(means, [a, 1.0 - a])
    return float(lo), float(hi)


def summarise(spec: Spec, cells: list[Cell], rows_by_cell: dict[int, list[list]]
              ) -> list[list]:
    """Per cell and method: n ok, n failed, and for each error its mean, median, std
    (ddof 1) and the bootstrap CI of the mean."""
    out = []
    for cell in cells:
        rows = rows_by_cell[cell.index]
        for m_index, method in enumerate(spec.methods):
            mine = [r for r in rows if r[1] == method]
            ok = [r for r in mine if r[2] == "ok"]
            rng = np.random.default_rng(np.random.SeedSequence(
                [spec.seed, BOOTSTRAP_KEY, *cell.seed_words, m_index]))
            stats = []
            for col in (3, 4):
                x = np.array([float(r[col]) for r in ok])
                if len(x) == 0:
                    stats += [None] * len(STATS)
                    continue
                lo, hi = bootstrap_ci(x, rng, spec.bootstrap, spec.confidence)
                stats += [float(x.mean()), float(np.median(x)),
                          float(x.std(ddof=1)) if len(x) > 1 else None, lo, hi]
            out.append([cell.index, *cell.axes.values(), method, len(ok),
                        len(mine) - len(ok), *stats])
    return out


def _samples_text(cells: list[Cell], axes: list[str], header, texts: dict[int, str]) -> str:
    """samples.csv: each finished cell's lines (already formatted by :func:`csv_text`)
    behind the cell's index and axis values, in cell order (the same bytes as formatting
    the rows again, without doing it twice)."""
    parts = [csv_text(("cell", *axes, *header), [])]
    for c in cells:
        prefix = csv_text(("x",), [[c.index, *c.axes.values()]]).split("\n", 1)[1][:-1]
        parts += [f"{prefix},{line}\n" for line in texts[c.index].split("\n")[1:-1]]
    return "".join(parts)
