# One command each, from a fresh clone (see README.md). Everything goes into ./.venv.
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin

.PHONY: demo test lint bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

demo: $(BIN)/python            ## install with the demo extra and run the demo
	$(BIN)/pip install --quiet -e '.[demo,xacro]'
	$(BIN)/kinematics demo

test: $(BIN)/python            ## install what the tests need and run the whole suite
	$(BIN)/pip install --quiet -e '.[test,lint]'
	$(BIN)/ruff check kinematics_node msg_adapters test benchmarks
	$(BIN)/mypy
	$(BIN)/python -m pytest -q

bench: $(BIN)/python           ## side-by-side speed comparison with installed peers
	$(BIN)/pip install --quiet -e '.[bench]'
	$(BIN)/python -W ignore benchmarks/fk_benchmark.py
	$(BIN)/python -W ignore benchmarks/ik_benchmark.py --targets 2000

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache
