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

.PHONY: help env lock system-deps stl step cad test bench sweep clean

help: ## list the targets
	@grep -hE '^[a-zA-Z_-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN{FS=":.*## "}{printf "  make %-12s %s\n",$$1,$$2}'

# The environment is (re)made when pyproject.toml or the tested versions change: every extra
# ([all]), the ROS 2 wheels ([ros]: x86-64 Linux, Python 3.11/3.12 only, so not part of [all]) and the
# test tools, at the exact versions of constraints.txt (`make lock` renews it).
CONSTRAINTS ?= constraints.txt
$(BIN)/.installed: pyproject.toml $(CONSTRAINTS)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	@# opencv-python-headless (the earlier dependency) and opencv-contrib-python-headless share cv2/: remove both, reinstall one
	if $(BIN)/python -m pip show -q opencv-python-headless 2>/dev/null; then \
		$(BIN)/python -m pip uninstall -q -y opencv-python-headless opencv-contrib-python-headless; fi
	$(BIN)/python -m pip install -q -c $(CONSTRAINTS) -e ".[all,ros,test]"
	touch $@

lock: ## newest versions within pyproject.toml's bounds into constraints.txt (then: make test)
	rm -rf .venv-lock && $(PYTHON) -m venv .venv-lock
	.venv-lock/bin/python -m pip install -q --upgrade pip
	.venv-lock/bin/python -m pip install -q -e ".[all,ros,test]"
	{ sed -n '/^#/p' $(CONSTRAINTS); .venv-lock/bin/python -m pip freeze --all --exclude-editable \
		| grep -v -e '^pip==' -e '^-e' -e '^whisker'; } > $(CONSTRAINTS).tmp
	mv $(CONSTRAINTS).tmp $(CONSTRAINTS) && rm -rf .venv-lock

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
