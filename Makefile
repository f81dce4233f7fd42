# A fresh clone needs nothing but python3: every target that runs code depends on the venv.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# A second environment with the optional `video` extra (mediapipe 0.10.21, which pins
# numpy < 2): `make test` runs the whole suite there too, so the core is tested on numpy
# 1.26 as well as 2.x, and the video tests, which skip in .venv, must run (and not skip).
# Both environments have the `server` extra (FastAPI, SQLAlchemy, ...), so the scoring
# server's tests run on both numpy versions.
VENV_VIDEO := .venv-video
VBIN := $(VENV_VIDEO)/bin
VSTAMP := $(VENV_VIDEO)/.installed

.PHONY: venv venv-video demo test test-core test-video bench lint clean

venv: $(STAMP)

venv-video: $(VSTAMP)

# The installs are quiet (pip's output is long); each step says what it does first.
$(STAMP): pyproject.toml
	@echo "make: creating $(VENV) (numpy 2.x)"
	$(PYTHON) -m venv $(VENV)
	@echo "make: upgrading pip in $(VENV)"
	$(BIN)/python -m pip install --quiet --upgrade pip
	@echo "make: installing turnbench[test,dev,server] into $(VENV) (a minute or two on a cold cache)"
	$(BIN)/python -m pip install --quiet -e '.[test,dev,server]'
	touch $(STAMP)

$(VSTAMP): pyproject.toml
	@echo "make: creating $(VENV_VIDEO) (numpy 1.26, mediapipe)"
	$(PYTHON) -m venv $(VENV_VIDEO)
	@echo "make: upgrading pip in $(VENV_VIDEO)"
	$(VBIN)/python -m pip install --quiet --upgrade pip
	@echo "make: installing turnbench[test,video,server] into $(VENV_VIDEO) (mediapipe: about a minute)"
	$(VBIN)/python -m pip install --quiet -e '.[test,video,server]'
	touch $(VSTAMP)

demo: $(STAMP)
	$(BIN)/python -m turn_eval.demo --out-dir demo-output

# The habits a maintainer relies on gate the tests: lint first, then the suite in .venv
# (numpy 2.x), then the whole suite again in .venv-video (numpy 1.26, the video tests).
test: lint test-core test-video

test-core: $(STAMP)
	@echo "make: the suite in $(VENV) (numpy 2.x)"
	$(BIN)/python -m pytest -q

# TURNBENCH_REQUIRE_VIDEO turns a skipped video test into a failure (tests/conftest.py).
test-video: $(VSTAMP)
	@echo "make: the suite in $(VENV_VIDEO) (numpy 1.26, the video tests)"
	TURNBENCH_REQUIRE_VIDEO=1 $(VBIN)/python -m pytest -q -p no:cacheprovider

# The estimate benchmark needs mediapipe: skipped in .venv, run in .venv-video.
bench: $(STAMP) $(VSTAMP)
	$(BIN)/python benchmarks/run.py
	$(VBIN)/python benchmarks/run.py --only estimate

# ruff's rules, its formatting (checked, never rewritten here), and the packages' types
# (they ship py.typed; mypy's settings are in pyproject.toml).
lint: $(STAMP)
	@echo "make: ruff check"
	$(BIN)/ruff check turn_datasets turn_eval tests benchmarks
	@echo "make: ruff format --check"
	$(BIN)/ruff format --check turn_datasets turn_eval tests benchmarks
	@echo "make: mypy (about half a minute)"
	$(BIN)/mypy

clean:
	rm -rf $(VENV) $(VENV_VIDEO) demo-output .pytest_cache
