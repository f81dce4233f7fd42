# A fresh clone needs nothing but python3: every target that runs code depends on the venv.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: venv demo test bench lint clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m turn_eval.demo --out-dir demo-output

# The habits a maintainer relies on gate the tests: lint first, then the suite.
test: lint
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

# ruff's rules, its formatting (checked, never rewritten here), and the packages' types
# (they ship py.typed; mypy's settings are in pyproject.toml).
lint: $(STAMP)
	$(BIN)/ruff check turn_datasets turn_eval tests benchmarks
	$(BIN)/ruff format --check turn_datasets turn_eval tests benchmarks
	$(BIN)/mypy

clean:
	rm -rf $(VENV) demo-output .pytest_cache
