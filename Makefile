# Two commands (README "Quick start"): `make reproduce` and `make test`.
# Each creates .venv and installs the package with the exact versions of constraints.txt
# on first use (and again whenever pyproject.toml or constraints.txt changes).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
OUT ?= out
# Test workers: pytest-xdist over the machine's cores ("0" runs in one process).
JOBS ?= auto
export MUJOCO_GL ?= egl

.PHONY: reproduce test test-fast lint bench results docs lock check-latest clean

# --no-compile: pip would compile every module of every package (33 s of CPU for the
# install, 13 s without); only the few hundred modules a run imports are compiled, on
# first import, into __pycache__ (about 4 s of CPU, once: both commands run with
# PYTHONDONTWRITEBYTECODE unset, see PYTEST below).
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet --no-compile -c constraints.txt -e '.[test,dask]'
	touch $(STAMP)

# The documentation site's tools (pyproject's docs extra), on top of the test install.
DOCS_STAMP := $(VENV)/.installed-docs
$(DOCS_STAMP): $(STAMP) pyproject.toml constraints.txt
	$(PY) -m pip install --quiet --no-compile -c constraints.txt -e '.[test,dask,docs]'
	touch $(DOCS_STAMP)

reproduce: $(STAMP)
	env -u PYTHONDONTWRITEBYTECODE $(PY) -m experiments.reproduce --out $(OUT)

# (--dist loadscope, one module per worker, was measured slower: 447 s against 379 s,
# its last modules run alone.) --dist worksteal: a worker that runs out of tests takes
# half of the other's pending ones, so no worker idles while a long batch waits elsewhere;
# tests/conftest.py puts the slow tests first.
DIST ?= worksteal
# The suite starts well over a hundred Python processes (xdist workers, pool workers, the
# CLI run as users run it). With PYTHONDONTWRITEBYTECODE set (as on the CI machines) each
# would compile rasc's and the tests' sources again; unset, each module is compiled once
# into __pycache__ (git-ignored) and read from there (measured: 10 % less CPU on the
# subprocess-heavy tests, 69 -> 62 s on the first run, 58 s on the next).
PYTEST := env -u PYTHONDONTWRITEBYTECODE $(PY) -m pytest
# The docs extra too: tests/docs/test_site_reference.py checks the site's generators
# (skipped where Sphinx and docutils are missing, as on the bare test install).
test: $(DOCS_STAMP)
	$(PYTEST) -q -n $(JOBS) --dist $(DIST)

# The quick loop while developing: everything not marked slow.
test-fast: $(STAMP)
	$(PYTEST) -q -n $(JOBS) --dist $(DIST) -m "not slow"

lint: $(STAMP)
	$(VENV)/bin/ruff check rasc tests experiments benchmarks examples

bench: $(STAMP)
	$(PY) benchmarks/bench_handeye.py
	$(PY) benchmarks/bench_plugins.py
	$(PY) benchmarks/compare_inverse.py
	$(PY) benchmarks/bench_pipeline.py
	$(PY) benchmarks/bench_sim_units.py
	$(PY) benchmarks/bench_refine.py
	$(PY) benchmarks/bench_study.py
	$(PY) benchmarks/bench_reproduce.py

# The site's Results pages (docs/results/*.md), written by the quick benchmarks themselves
# (every script in benchmarks/ takes --markdown FILE); run on a quiet machine, commit.
results: $(STAMP)
	$(PY) benchmarks/bench_handeye.py --markdown docs/results/handeye_speed.md
	$(PY) benchmarks/bench_plugins.py --markdown docs/results/plugin_overhead.md

# The documentation site, warnings as errors (docs/conf.py; the gallery's examples run).
# Open docs/_build/html/index.html.
docs: $(DOCS_STAMP)
	$(VENV)/bin/sphinx-build -W --keep-going -q -b html docs docs/_build/html

# Rewrite constraints.txt from a fresh resolve of pyproject.toml's ranges.
lock:
	rm -rf .venv-lock
	$(PYTHON) -m venv .venv-lock
	.venv-lock/bin/python -m pip install --quiet --upgrade pip
	.venv-lock/bin/python -m pip install --quiet '.[test,dask,docs]'
	{ grep "^#" constraints.txt; \
	  .venv-lock/bin/python -m pip freeze --all --exclude rasc --exclude pip; } > constraints.txt.new
	mv constraints.txt.new constraints.txt
	rm -rf .venv-lock

# Drift check: the newest versions the ranges allow, in their own venv, then the tests.
check-latest:
	rm -rf .venv-latest
	$(PYTHON) -m venv .venv-latest
	.venv-latest/bin/python -m pip install --quiet --upgrade pip
	.venv-latest/bin/python -m pip install --quiet --upgrade -e '.[test,dask]'
	grep -v '^#' constraints.txt > .venv-latest/locked.txt
	.venv-latest/bin/python -m pip freeze --all --exclude rasc --exclude pip | diff .venv-latest/locked.txt - \
	  && echo 'check-latest: the newest versions are the locked ones' || true
	.venv-latest/bin/python -m pytest -q -n $(JOBS)

clean:
	rm -rf $(VENV) .venv-latest $(OUT)
