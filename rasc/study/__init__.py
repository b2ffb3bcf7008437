"""Declarative studies: sweep noise, rendering and head parameters over hand-eye methods.

``rasc study SPEC.toml --out DIR`` (:mod:`rasc.commands.study`); the spec format is in
:mod:`rasc.study.spec`, the computation in :mod:`rasc.study.engine`, where tasks run in
:mod:`rasc.study.executors` (this process, a process pool, or dask.distributed), the
figures in :mod:`rasc.study.figures`.
"""

from rasc.study.engine import StudyResult, run_study
from rasc.study.spec import PARAMS, Spec, load_spec

__all__ = ["PARAMS", "Spec", "StudyResult", "load_spec", "run_study"]
