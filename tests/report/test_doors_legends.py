"""No legend entry without data (issue 25 item 7): E1's all-methods figure draws no
curve, and lists no legend entry, for a method none of whose samples solved; it says so."""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))
import experiments.e1_noise as e1  # noqa: E402


def _row(eye, level, method, t):
    return {"eye": eye, "noise_level": str(level), "method": method,
            "t_err_mean_mm": "" if t is None else str(t),
            "R_deg_mean": "" if t is None else str(t / 10)}


def test_a_method_without_results_has_no_legend_entry(tmp_path, monkeypatch):
    summary = [_row(eye, lv, m, None if m == "never" else 1.0 + lv)
               for eye in ("left", "right") for lv in range(3)
               for m in ("rasc", "li", "never")]
    seen = {}

    def keep(fig, stem, formats, draft):
        legend = fig.axes[0].get_legend()
        seen["labels"] = [t.get_text() for t in legend.get_texts()]
        seen["title"] = legend.get_title().get_text()
        seen["lines"] = [line.get_label() for ax in fig.axes for line in ax.get_lines()]
        return []

    monkeypatch.setattr(e1, "save_figure", keep)
    e1.plot_all_methods(summary, tmp_path, formats=(".png",), draft=True)
    assert seen["labels"] == ["rasc", "li"]
    assert "never" not in seen["lines"]
    assert seen["title"] == "no sample solved (not drawn): never"
