# Every generated figure and table of docs/ and benchmarks/results/, regenerated and stamped (issue 30).
#   make docs            all of them; the long ones at a reduced but real setting (each stamp says how)
#   make docs-check      list what is not current (the test tests/test_docs_current.py does the same)
#   make docs-sweep ...  one group (see DOCS_GROUPS)
# Each group runs its generator, then `python -m whisker.data.provenance stamp` records in
# docs/generated.json the command, the design digest and the model numbers (turns, resistance,
# stiffness, full-scale voltage, guard thresholds ...) the files were made from, and their sha256.
# Scratch output goes to $(DOCS_RUNS) (not in git). Groups are independent: `make -k docs` goes on past a failure.
DOCS_RUNS ?= $(OUT)/docs
STAMP = $(BIN)/python -m whisker.data.provenance stamp
DOCS_GROUPS = docs-states docs-sim-time docs-stiffness docs-lens docs-sim-figures docs-tracking docs-sweep \
	docs-fuzz docs-bench
# the benchmarks `make docs` re-runs (bench_print needs PrusaSlicer; bench_classify the authors' data);
# bench_states runs in docs-states. Each stamps the files it wrote (newer than the run's start).
DOCS_BENCH ?= actuation bom coil magnetics tracking cad explore sim compliant grip classify print

.PHONY: docs docs-check $(DOCS_GROUPS)

docs: $(DOCS_GROUPS) ## regenerate and stamp every generated figure and table (reduced long runs; ~10 min, 2 cores)
	$(BIN)/python -m whisker.data.provenance check

docs-check: $(BIN)/.installed ## which generated figures/tables are stale (made from another design or model)
	$(BIN)/python -m whisker.data.provenance check

docs-states: $(BIN)/.installed
	$(BIN)/python benchmarks/bench_states.py --labels-only
	$(STAMP) --command "python benchmarks/bench_states.py --labels-only" \
		--reduced "the states table and plot re-run; the closed-loop latency and force sections kept from make bench-states" \
		benchmarks/results/states.md benchmarks/results/states.csv benchmarks/results/states.png

docs-sim-time: $(BIN)/.installed
	$(MAKE) grasp-figure TRIALS=3 FIG8_RUNS=$(DOCS_RUNS)/grasp-figure
	$(STAMP) --command "make grasp-figure TRIALS=3" --reduced "3 simulated trials instead of 5" \
		docs/images/fig8_sim.png docs/images/fig8_sim.csv

docs-stiffness: $(BIN)/.installed
	mkdir -p $(DOCS_RUNS)
	$(BIN)/whisker calibrate stiffness --backend sim --sim-set mechanics.rotational_stiffness=1.6 \
		--sim-set actuation.gap=2.3 --out $(DOCS_RUNS)/stiffness.toml
	cp $(DOCS_RUNS)/stiffness.stiffness.png docs/images/calibration/stiffness.png
	$(STAMP) --command "whisker calibrate stiffness --backend sim --sim-set mechanics.rotational_stiffness=1.6 --sim-set actuation.gap=2.3" \
		docs/images/calibration/stiffness.png

docs-lens: $(BIN)/.installed
	mkdir -p $(DOCS_RUNS)
	$(BIN)/whisker calibrate camera --source synthetic-board --out $(DOCS_RUNS)/lens.npz -q
	$(BIN)/python -c "import cv2, sys; cv2.imwrite(sys.argv[2], cv2.imread(sys.argv[1]), [cv2.IMWRITE_JPEG_QUALITY, 85])" \
		$(DOCS_RUNS)/lens.undistorted.png docs/images/calibration/undistorted.jpg
	$(STAMP) --command "whisker calibrate camera --source synthetic-board" docs/images/calibration/undistorted.jpg

docs-sim-figures: $(BIN)/.installed
	$(BIN)/whisker sim angle_vs_voltage --out $(DOCS_RUNS)/angle_vs_voltage -q
	cp $(DOCS_RUNS)/angle_vs_voltage/angle_vs_voltage.png docs/images/sim_angle_vs_voltage.png
	$(STAMP) --command "whisker sim angle_vs_voltage" docs/images/sim_angle_vs_voltage.png
	$(BIN)/whisker sim displacement --out $(DOCS_RUNS)/displacement -q
	cp $(DOCS_RUNS)/displacement/displacement.png docs/images/sim_displacement.png
	$(BIN)/python -c "import json, sys; print(json.dumps(json.load(open(sys.argv[1]))['displacement_mean_sd_px']))" \
		$(DOCS_RUNS)/displacement/summary.json > docs/images/sim_displacement_sd.json
	$(STAMP) --command "whisker sim displacement" docs/images/sim_displacement.png docs/images/sim_displacement_sd.json

docs-tracking: $(BIN)/.installed
	$(BIN)/python benchmarks/bench_tracking.py --docs-image docs/images/tracking_synthetic.png --image-only
	$(STAMP) --command "python benchmarks/bench_tracking.py --docs-image docs/images/tracking_synthetic.png --image-only" \
		docs/images/tracking_synthetic.png
	WHISKER_PEER_DATA=$(PEER_DATA) $(BIN)/python benchmarks/bench_tracking.py --real-table docs/tracking_real.md --image-only
	$(STAMP) --command "python benchmarks/bench_tracking.py --real-table docs/tracking_real.md --image-only" \
		docs/tracking_real.md

docs-sweep: $(BIN)/.installed
	$(BIN)/whisker cad sweep --radii 4..25:3 --out $(DOCS_RUNS)/sweep
	cp $(DOCS_RUNS)/sweep/sweep.png docs/images/sweep.png
	cp $(DOCS_RUNS)/sweep/sweep.md docs/sweep_table.md
	$(STAMP) --command "whisker cad sweep --radii 4..25:3" --reduced "radii every 3 mm (make sweep: every 1 mm)" \
		docs/images/sweep.png docs/sweep_table.md

docs-fuzz: $(BIN)/.installed
	WHISKER_WALK_COMMAND_S=20 WHISKER_WALK_TIME_LIMIT_S=30 WHISKER_FUZZ_REPORT=benchmarks/results/fuzz_walk.md \
		$(BIN)/python -m pytest -q -p no:cacheprovider tests/test_cli_walk.py -k hostile
	$(STAMP) --command "make docs-fuzz (tests/test_cli_walk.py, 20 s of cases per command)" \
		--reduced "20 s of cases per command, 30 s per invocation (make fuzz: every case, 60 s)" \
		benchmarks/results/fuzz_walk.md benchmarks/results/fuzz_walk.png

docs-bench: $(BIN)/.installed
	mkdir -p $(DOCS_RUNS)
	@for b in $(DOCS_BENCH); do echo "== bench_$$b"; touch $(DOCS_RUNS)/.bench-start; \
	  case $$b in sim) red="SIM_BENCH_QUICK=1 (make sim-bench: the full grid)";; \
	    compliant) red="COMPLIANT_ATTEMPTS=20 SENS_ATTEMPTS=5 (make sim-sensitivity: 100 and 20)";; *) red="";; esac; \
	  SIM_BENCH_QUICK=1 COMPLIANT_ATTEMPTS=20 SENS_ATTEMPTS=5 WHISKER_PEER_DATA=$(PEER_DATA) \
	    $(BIN)/python benchmarks/bench_$$b.py || exit 1; \
	  files=$$(find benchmarks/results docs/images -newer $(DOCS_RUNS)/.bench-start -type f ! -name '.*'); \
	  $(STAMP) --command "python benchmarks/bench_$$b.py" $${red:+--reduced "$$red"} $$files || exit 1; done
