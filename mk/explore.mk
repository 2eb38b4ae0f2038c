# Design explorer (issue 14). See docs/explore.md. Results go to runs/explore/ (not in git).
#   make explore                                   the docs' study: count x ring radius x grasp voltage
#   make explore VARY="whiskers.count=6,8 coil.turns=400:600:100" ATTEMPTS=20
#   make explore WORKERS=4                         on a Dask LocalCluster of 4 worker processes
#   make explore SCHEDULER=tcp://10.0.0.5:8786     on an existing Dask cluster
#   make bench-explore                             attempts/s and designs/s at 1 and 2 workers
EXPLORE_OUT ?= runs/explore
VARY ?= whiskers.count=4,6,8 whiskers.ring_radius=8:16:2 actuation.voltage=2,3
# ATTEMPTS given on the command line wins; otherwise 20 (sim.mk's ATTEMPTS default, 100, is for sim-grasp)
EXPLORE_ATTEMPTS ?= $(if $(filter command line environment,$(origin ATTEMPTS)),$(ATTEMPTS),20)
EXPLORE_CAD ?= evaluate

.PHONY: explore bench-explore

explore: $(BIN)/.installed ## design explorer: grasp, force, heat, resolution per design; Pareto designs -> runs/explore/
	$(BIN)/whisker explore $(if $(DESIGN),--design $(DESIGN)) $(foreach s,$(SET),--set $(s)) \
		$(foreach v,$(VARY),--vary $(v)) --attempts $(EXPLORE_ATTEMPTS) \
		--cad $(EXPLORE_CAD) $(if $(WORKERS),--workers $(WORKERS)) $(if $(SCHEDULER),--scheduler $(SCHEDULER)) \
		--out $(EXPLORE_OUT)

bench-explore: $(BIN)/.installed ## explorer throughput at 1 and 2 workers, cost of a 1000-design study -> benchmarks/results/explore.md
	$(BIN)/python benchmarks/bench_explore.py
