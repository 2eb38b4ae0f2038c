# Live whisker states (issue 16). See docs/states.md.
#   make states CSV=tracks.csv           label every frame of a tracks CSV (or the authors' Time,dx,dy file)
#   make states-demo                     the authors' demo CSV with both methods (needs WHISKER_PEER_DATA)
#   make bench-states                    authors' method vs adaptive on simulated labelled sequences
STATES_OUT ?= $(OUT)/states
STATES_METHOD ?= adaptive

.PHONY: states states-demo bench-states

states: $(BIN)/.installed ## label a tracks CSV (CSV=...) rest/contact/dynamic -> exports/states/states.csv
	@test -n "$(CSV)" || { echo "set CSV to a tracks CSV (whisker track/record output or Time,dx,dy)"; exit 2; }
	$(BIN)/whisker states $(CSV) --estimator $(STATES_METHOD) --out $(STATES_OUT)/states.csv > /dev/null

states-demo: $(BIN)/.installed ## the authors' airflow demo CSV, both methods (needs WHISKER_PEER_DATA)
	@test -n "$(WHISKER_PEER_DATA)" || { echo "set WHISKER_PEER_DATA to the authors' data folder"; exit 2; }
	$(BIN)/whisker states $(WHISKER_PEER_DATA)/airflow/airflowDemoData.csv --estimator authors --out $(STATES_OUT)/demo_authors.csv > /dev/null
	$(BIN)/whisker states $(WHISKER_PEER_DATA)/airflow/airflowDemoData.csv --estimator adaptive --out $(STATES_OUT)/demo_adaptive.csv > /dev/null

bench-states: $(BIN)/.installed ## state estimators + closed-loop latency -> benchmarks/results/states.md
	$(BIN)/python benchmarks/bench_states.py

# Closed-loop grasping (issue 16): the paper's five objects, 8/4/2 whiskers, same placements open vs closed.
CLOSED_ATTEMPTS ?= 20
CLOSED_FPS ?= 15
.PHONY: sim-grasp-closed
sim-grasp-closed: $(BIN)/.installed ## closed-loop vs open-loop grasp table (CLOSED_ATTEMPTS per cell) -> runs/grasp-closed/
	$(BIN)/whisker closedloop --attempts $(CLOSED_ATTEMPTS) --fps $(CLOSED_FPS) --out $(SIM_RUNS)/grasp-closed
