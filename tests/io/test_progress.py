"""rasc.progress: a bar on a terminal, whole lines in a log, nothing when quiet."""

import io

from rasc.progress import progress


def test_log_gets_whole_lines_without_carriage_returns():
    log = io.StringIO()  # not a terminal
    with progress(total=5, desc="render", file=log) as bar:
        for _ in range(5):
            bar.update(1)
    text = log.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert lines[0].startswith("render:   0%") and lines[-1].startswith("render: 100%")
    assert "5/5" in lines[-1] and text.endswith("\n")


def test_quiet_prints_nothing():
    log = io.StringIO()
    with progress(total=5, desc="render", file=log, quiet=True) as bar:
        for _ in range(5):
            bar.update(1)
    assert log.getvalue() == ""


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_terminal_bar_redraws_in_place():
    term = _Terminal()
    with progress(total=3, desc="x", file=term) as bar:
        for _ in range(3):
            bar.update(1)
    assert "\r" in term.getvalue()
