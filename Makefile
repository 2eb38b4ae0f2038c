# whisker-array: every job from one design file (hw/sensor.toml).
#   make stl                      build the default design into exports/
#   make stl WHISKERS=6 RADIUS=10 the same with 6 whiskers on a 10 mm ring
#   make stl DESIGN=my_sensor.toml your own design file
#   make test | bench | sweep | help
SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= exports

# Design selection shared by every target.
DESIGN_ARGS := $(if $(DESIGN),--design $(DESIGN)) \
	$(if $(WHISKERS),--set whiskers.count=$(WHISKERS)) \
	$(if $(RADIUS),--set whiskers.ring_radius=$(RADIUS)) \
	$(foreach s,$(SET),--set $(s))

.PHONY: help env system-deps stl step cad test bench sweep clean

help: ## list the targets
	@grep -hE '^[a-zA-Z_-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN{FS=":.*## "}{printf "  make %-12s %s\n",$$1,$$2}'

# The environment is (re)made when pyproject.toml changes.
$(BIN)/.installed: pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e ".[test]"
	touch $@

env: $(BIN)/.installed ## create the Python environment in .venv

stl: $(BIN)/.installed ## build, check and export every part (STL + STEP + manifest) into exports/
	$(BIN)/whisker cad build $(DESIGN_ARGS) --out $(OUT)

step: stl ## the same build (STEP files and the assembly come with every build)

cad: stl

sweep: $(BIN)/.installed ## feasibility sweep over whisker counts 2..16 and radii 4..25 mm (all cores)
	$(BIN)/whisker cad sweep $(DESIGN_ARGS) --out $(OUT)/sweep

system-deps: ## install the Debian packages the checks need (.ci/apt-packages: slicer, admesh, fonts)
	scripts/system-deps

test: $(BIN)/.installed system-deps ## run the test suite
	$(BIN)/python -m pytest -q

bench: $(BIN)/.installed ## accuracy-vs-time benchmarks; tables and plots in benchmarks/results/
	@for b in benchmarks/bench_*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean: ## remove build outputs (not the environment)
	rm -rf $(OUT) .pytest_cache

-include mk/*.mk
