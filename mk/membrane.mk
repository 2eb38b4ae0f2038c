# The membrane's stiffness from material data (issue 27). See docs/membrane.md.
#   make membrane          the shipped table hw/materials/membrane_stiffness.json (default design + the paper's 16 mm)
#   make bench-membrane    mesh convergence and cost -> benchmarks/results/membrane.md

.PHONY: membrane bench-membrane

membrane: $(BIN)/.installed ## membrane model results shipped for the core install -> hw/materials/membrane_stiffness.json
	$(BIN)/python -m whisker.mechanics.membrane

bench-membrane: $(BIN)/.installed ## membrane FEM: stiffness vs mesh size, error vs the finest mesh, seconds
	$(BIN)/python benchmarks/bench_membrane.py
