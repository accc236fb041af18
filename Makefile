# Every target creates .venv and installs the package if needed, so each works on a fresh machine.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
TARGET ?= emulator

.PHONY: conformance test test-long test-all bench lint clean wheel-check

$(STAMP): pyproject.toml setup.py
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

## Run the conformance suite against the built-in emulator (or TARGET=...): a new run folder under
## reports/runs/, with reports/latest, reports/junit.xml and reports/index.html following it.
conformance: $(STAMP)
	$(VENV)/bin/buildhat-conformance run --target $(TARGET)

## The project's own tests, in parallel (pytest-xdist): many of them wait on a child process or a pty,
## so more workers than cores pay off. Tests sharing a module-scoped fixture stay on one worker
## (tests/conftest.py marks them xdist_group). TEST_WORKERS=0 runs them in this process, one by one.
## The long tier (tests/conftest.py LONG_TESTS: whole-suite runs, campaigns and histories on a firmware
## in the loop) is left out to keep the quick tier, which CI runs, well under ten minutes; `make test-long`
## runs it alone (about ten minutes here), `make test-all` both.
TEST_WORKERS ?= 3
test: $(STAMP)
	$(PY) -m pytest tests -n $(TEST_WORKERS) --dist loadgroup -m "not long"

test-long: $(STAMP)
	$(PY) -m pytest tests -n $(TEST_WORKERS) --dist loadgroup -m long

test-all: $(STAMP)
	$(PY) -m pytest tests -n $(TEST_WORKERS) --dist loadgroup

## Benchmarks: prints each figure next to its goal; never fails on wall-clock numbers.
bench: $(STAMP)
	$(VENV)/bin/buildhat-conformance bench

## Static checks: ruff, and pyright (basedpyright, basic mode) over the package and the tests, imports
## included. The tests import `buildhat_conformance.<folder>`, which only the editable install's import
## hook maps to the top-level folders; pyright reads no hooks, so it gets the same mapping as a tree of
## symlinks, build/pyright/buildhat_conformance/ (one per folder with an __init__.py, and the root
## package's modules), on its extraPaths in pyrightconfig.json.
PYRIGHT_TREE := build/pyright/buildhat_conformance
lint: $(STAMP)
	$(VENV)/bin/ruff check .
	rm -rf $(PYRIGHT_TREE) && mkdir -p $(PYRIGHT_TREE)
	for f in buildhat_conformance/*.py; do ln -s "$(CURDIR)/$$f" $(PYRIGHT_TREE)/; done
	for d in $(patsubst %/__init__.py,%,$(filter-out buildhat_conformance/%,$(wildcard */__init__.py))); do \
	  ln -s "$(CURDIR)/$$d" $(PYRIGHT_TREE)/$$d; done
	$(VENV)/bin/basedpyright

## The package as a user gets it: build sdist + wheel, twine check, install the wheel in a fresh venv
## and run `make conformance`'s command from an empty directory (about two minutes).
wheel-check: $(STAMP)
	$(PY) tests/wheel_check.py

clean:
	rm -rf $(VENV) reports/*.xml reports/*.html reports/fuzz build *.egg-info
