# Two commands do all the set-up on a fresh machine with Python 3.11 and a C compiler:
#   make demo   - reference-ship logs -> identification -> FMU -> scenarios -> report
#   make test   - the whole test suite, ruff and mypy
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

.PHONY: demo test lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	$(PY) -m scenarios warm-up --quiet
	touch $(STAMP)

demo: $(STAMP)
	$(PY) -m scenarios demo --out build/demo

lint: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .
	$(PY) -m mypy

test: lint
	$(PY) -m pytest -n 2 --dist worksteal -q

bench: $(STAMP)
	$(PY) benchmarks/fmu_step.py
	$(PY) benchmarks/identify.py
	$(PY) benchmarks/batch.py
	$(PY) benchmarks/uncertainty.py
	$(PY) benchmarks/fidelity.py
	$(PY) benchmarks/sensitivity.py
	$(PY) benchmarks/coverage.py

clean:
	rm -rf $(VENV) build
