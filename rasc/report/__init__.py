"""The calibration report (``rasc report``, ``rasc calibrate --report``): a PDF to look at
(:mod:`rasc.report.pdf`) and a one-line verdict (:mod:`rasc.report.verdict`)."""

from rasc.report.pdf import PAGES, write_report
from rasc.report.verdict import Check, Verdict, verdict

__all__ = ["PAGES", "write_report", "Check", "Verdict", "verdict"]
