# Coil calculator (issue 4). See docs/coil.md.
#   make coil                       report for the default design + JSON + plots into exports/coil/
#   make coil SET=coil.turns=411    the same for another winding (any --set override)
#   make bench-magnetics            only the magnetics accuracy-vs-cost benchmark
COIL_OUT ?= $(OUT)/coil

.PHONY: coil bench-magnetics

coil: $(BIN)/.installed ## coil report: fits?, resistance, force vs gap, deflection, heating, driver -> exports/coil/
	$(BIN)/whisker coil report $(DESIGN_ARGS) --out $(COIL_OUT)

bench-magnetics: $(BIN)/.installed ## coil-magnet force models: error vs magpylib/converged reference, time per call
	$(BIN)/python benchmarks/bench_magnetics.py
