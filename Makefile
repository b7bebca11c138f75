# Two entry points for a fresh machine (see README):  make demo  |  make test
# Both create .venv/ at the repository root when it is missing. The demo needs only
# pdmkit's core install (no torch, no Dask: pyproject.toml's extras); the tests take
# the dev extra, which holds every extra, so that the whole suite runs.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
CORE_STAMP := $(VENV)/.installed-core-stamp
DEV_STAMP := $(VENV)/.installed-dev-stamp
PIP_E := $(BIN)/python -m pip install --quiet -e

.PHONY: demo test lint venv clean

$(BIN)/python:
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(CORE_STAMP): pyproject.toml | $(BIN)/python
	$(PIP_E) .
	touch $(CORE_STAMP)

$(DEV_STAMP): pyproject.toml | $(BIN)/python
	$(PIP_E) ".[dev]"
	touch $(DEV_STAMP) $(CORE_STAMP)

venv: $(DEV_STAMP)

demo: $(CORE_STAMP)
	$(BIN)/pdmkit demo --out results/demo

# bytecode is written even where the environment says not to (PYTHONDONTWRITEBYTECODE):
# every test worker and every child process would otherwise compile pdmkit again
test: $(DEV_STAMP)
	PYTHONDONTWRITEBYTECODE= $(BIN)/python -m pytest -q -n auto --dist worksteal --durations=60

lint: $(DEV_STAMP)
	$(BIN)/ruff check . && $(BIN)/ruff format --check .

clean:
	rm -rf $(VENV) results .pytest_cache
