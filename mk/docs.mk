# Every generated figure and table of docs/ and benchmarks/results/, regenerated and stamped (issue 30).
#   make docs            all of them, one group after the other, each group's wall time printed and
#                        summed at the end (also in $(DOCS_RUNS)/times.txt); the long ones at a reduced
#                        but real setting (each stamp says how)
#   make docs-check      list what is not current (the test tests/test_docs_current.py does the same)
#   make docs-sweep ...  one group (see DOCS_GROUPS); docs-bench-NAME runs benchmarks/bench_NAME.py
# Each group runs its generator, then `python -m whisker.data.provenance stamp` records in
# docs/generated.json the command, the design digest and the model numbers (turns, resistance,
# stiffness, full-scale voltage, guard thresholds ...) the files were made from, and their sha256.
# Scratch output goes to $(DOCS_RUNS) (not in git). Groups are independent: `make -k docs` goes on past a failure.
DOCS_RUNS ?= $(OUT)/docs
DOCS_CLOSED_ATTEMPTS ?= 3
DOCS_EXPLORE_ATTEMPTS ?= 5
DOCS_GRASP_ATTEMPTS ?= 20
DOCS_JOBS ?= 2
# the sweep's reduced grid (make sweep: radii 4..25 mm every 1 mm); every count 2..16 is kept
DOCS_SWEEP_RADII ?= 4,10,16,22
STAMP = $(BIN)/python -m whisker.data.provenance stamp
# every benchmark, each its own group docs-bench-NAME (the list is checked against benchmarks/bench_*.py
# by tests/test_docs_current.py); bench_states runs in docs-states
DOCS_BENCH ?= actuation bom cad classify coil compliant driver explore grip hat locate locate_noise magnetics membrane \
	print ros sim subpixel thermal tolerance tracking
DOCS_GROUPS = docs-states docs-closedloop docs-sim-grasp docs-sim-time docs-stiffness docs-lens docs-sim-figures docs-tracking \
	docs-parts docs-assembly docs-guide docs-ros-frames docs-explore docs-sweep docs-fuzz $(addprefix docs-bench-,$(DOCS_BENCH))

# The files each benchmark writes (benchmarks/results/ unless a path is given), and its reduced setting.
DOCS_BENCH_FILES_actuation = actuation.md actuation_guard.csv actuation_guard.png actuation_guard_policies.csv actuation_recording.csv
DOCS_BENCH_FILES_bom = bom.md bom.csv
DOCS_BENCH_FILES_cad = cad.md cad_tessellation.csv cad_tessellation.png
DOCS_BENCH_FILES_classify = classify.md classify.csv classify.png classify_beyond.csv classify_confusion.json classify_models.csv \
	classify_pairing.csv classify_protocols.csv classify_sim.csv classify_trials.csv docs/images/confusion_*.png
DOCS_BENCH_FILES_coil = coil.md coil.csv
DOCS_BENCH_FILES_compliant = sim_compliant.md sim_compliant.csv
DOCS_BENCH_FILES_driver = driver.md driver.csv
DOCS_BENCH_FILES_explore = explore.md
DOCS_BENCH_FILES_grip = sim_grip.md
DOCS_BENCH_FILES_hat = hat.md hat.csv
DOCS_BENCH_FILES_locate = locate.md locate.csv locate_tradeoff.csv locate.png
DOCS_BENCH_FILES_locate_noise = locate_noise.md locate_noise.csv locate_noise_coverage.csv locate_noise.png
DOCS_BENCH_FILES_magnetics = magnetics.md magnetics.csv magnetics.png
DOCS_BENCH_FILES_membrane = membrane.md membrane.csv
DOCS_BENCH_FILES_print = print.md print.csv
DOCS_BENCH_FILES_ros = ros.md ros.csv states.md
DOCS_BENCH_FILES_sim = sim.md sim.csv sim.png
DOCS_BENCH_FILES_subpixel = subpixel.md subpixel.csv
DOCS_BENCH_FILES_thermal = thermal.md thermal.csv thermal_protocol.png
DOCS_BENCH_FILES_tolerance = tolerance.md tolerance_options.csv tolerance_sobol.csv
DOCS_BENCH_FILES_tracking = tracking.md tracking.csv tracking.png
DOCS_BENCH_ENV_sim = SIM_BENCH_QUICK=1
DOCS_BENCH_REDUCED_sim = SIM_BENCH_QUICK=1 (make sim-bench: the full grid)
DOCS_BENCH_ENV_compliant = COMPLIANT_ATTEMPTS=20 SENS_ATTEMPTS=5
DOCS_BENCH_REDUCED_compliant = COMPLIANT_ATTEMPTS=20 SENS_ATTEMPTS=5 (make sim-sensitivity: 100 and 20)
DOCS_BENCH_ARGS_membrane = --reuse
DOCS_BENCH_REDUCED_membrane = reuse: the mesh-refinement rows (4 to 1.5 mm, the 1.5 mm solve about 8 min) from the last full run's membrane.csv, everything else recomputed (without --reuse: all)
DOCS_BENCH_ENV_ros = WHISKER_BENCH_ROS_S=6
DOCS_BENCH_REDUCED_ros = 6 s of frames per tracker (make bench-ros: 12 s)

.PHONY: docs docs-check $(DOCS_GROUPS)

docs: $(BIN)/.installed ## regenerate and stamp every generated figure and table (reduced long runs; about an hour on 2 shared cores: README lists each group's time)
	@mkdir -p $(DOCS_RUNS); : > $(DOCS_RUNS)/times.txt; failed=0; \
	for g in $(DOCS_GROUPS); do s=$$(date +%s); \
	  $(MAKE) --no-print-directory $$g || { failed=1; echo "$$g FAILED" >> $(DOCS_RUNS)/times.txt; }; \
	  e=$$(date +%s); echo "$$g $$((e - s)) s" | tee -a $(DOCS_RUNS)/times.txt; done; \
	echo "== group times (s):"; cat $(DOCS_RUNS)/times.txt; \
	awk '$$3 == "s" {t += $$2} END {printf "total %d s (%.1f min)\n", t, t / 60}' $(DOCS_RUNS)/times.txt; \
	$(BIN)/python -m whisker.data.provenance check && test $$failed = 0

docs-check: $(BIN)/.installed ## which generated figures/tables are stale (made from another design or model)
	$(BIN)/python -m whisker.data.provenance check

docs-states: $(BIN)/.installed
	mkdir -p $(DOCS_RUNS)
	WHISKER_PEER_DATA=$(PEER_DATA) $(BIN)/python benchmarks/bench_states.py
	$(STAMP) --command "python benchmarks/bench_states.py" benchmarks/results/states.md benchmarks/results/states.csv \
		benchmarks/results/states.png benchmarks/results/states_closed_loop_latency.csv benchmarks/results/states_force.csv

docs-closedloop: $(BIN)/.installed
	$(BIN)/whisker closedloop --attempts $(DOCS_CLOSED_ATTEMPTS) --jobs $(DOCS_JOBS) -q --out $(DOCS_RUNS)/closed
	$(BIN)/whisker closedloop --attempts $(DOCS_CLOSED_ATTEMPTS) --jobs $(DOCS_JOBS) --bare-open -q --out $(DOCS_RUNS)/closed-bare
	{ echo "# Closed-loop vs open-loop grasp tables (whisker closedloop; docs/states.md)"; echo; \
	  echo "Generated by \`make docs-closedloop\`: $(DOCS_CLOSED_ATTEMPTS) placements per cell (make sim-grasp-closed: 20)."; echo; \
	  echo "## Default: both loops through the same thermal guard"; echo; cat $(DOCS_RUNS)/closed/closed_loop.md; echo; \
	  echo "## Reference: the bare paper protocol without a guard against the guarded closed loop (--bare-open)"; echo; \
	  cat $(DOCS_RUNS)/closed-bare/closed_loop.md; } > benchmarks/results/states_closed_loop.md
	$(STAMP) --command "make docs-closedloop" --reduced "$(DOCS_CLOSED_ATTEMPTS) placements per cell instead of 20" \
		benchmarks/results/states_closed_loop.md

# the paper's grasp table (Table I) in the simulator, rigid contacts as tests/test_sim_paper.py, with each
# tip's pressing force (docs/sim.md, Scene 2); make sim-grasp runs the scene's compliant default at 100
docs-sim-grasp: $(BIN)/.installed
	$(BIN)/whisker sim grasp --scene-set fidelity.compliance=off --attempts $(DOCS_GRASP_ATTEMPTS) --jobs $(DOCS_JOBS) -q \
		--out $(DOCS_RUNS)/grasp
	{ echo "# Simulated grasp table beside the paper's Table I (whisker sim grasp; docs/sim.md, Scene 2)"; echo; \
	  echo "Generated by \`make docs-sim-grasp\`: rigid contacts (--scene-set fidelity.compliance=off), $(DOCS_GRASP_ATTEMPTS) common placements per cell, the paper's count (make sim-grasp: 100)."; echo; \
	  cat $(DOCS_RUNS)/grasp/grasp_table.md; } > docs/sim_grasp_table.md
	$(STAMP) --command "whisker sim grasp --scene-set fidelity.compliance=off --attempts $(DOCS_GRASP_ATTEMPTS)" \
		--reduced "$(DOCS_GRASP_ATTEMPTS) placements per cell instead of 100 (make sim-grasp)" docs/sim_grasp_table.md

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

docs-parts: $(BIN)/.installed
	$(BIN)/whisker print preview --build $(DOCS_RUNS)/build --images docs/images/parts
	$(STAMP) --command "whisker print preview --images docs/images/parts" docs/images/parts/*.png

docs-assembly: $(BIN)/.installed
	$(BIN)/whisker cad assembly-images --out docs/images/assembly --page docs/assembly.md
	$(STAMP) --command "whisker cad assembly-images --out docs/images/assembly --page docs/assembly.md" \
		docs/images/assembly/*.png

docs-explore: $(BIN)/.installed
	$(BIN)/whisker explore --vary whiskers.count=4,6,8 --vary whiskers.ring_radius=8:16:2 --vary actuation.voltage=2,3 \
		--attempts $(DOCS_EXPLORE_ATTEMPTS) --cad evaluate -q --out $(DOCS_RUNS)/explore
	cp $(DOCS_RUNS)/explore/pareto_heat.png docs/images/explore_heat.png
	cp $(DOCS_RUNS)/explore/pareto_resolution.png docs/images/explore_resolution.png
	{ echo "# Explorer grid: grasp success by whisker count, ring radius and grasp voltage (docs/explore.md)"; echo; \
	  echo "Generated by \`make docs-explore\`: $(DOCS_EXPLORE_ATTEMPTS) attempts per object and configuration (make explore: 20). A cell: every whisker driven [Wilson 95 %] / every second one / one opposite pair, % pooled over the five objects (8 / 4 / 2 whiskers for an 8-whisker design; the paper: 87 / 54 / 31)."; echo; \
	  cat $(DOCS_RUNS)/explore/grid.md; } > docs/explore_grid.md
	$(STAMP) --command "whisker explore --vary whiskers.count=4,6,8 --vary whiskers.ring_radius=8:16:2 --vary actuation.voltage=2,3 --attempts $(DOCS_EXPLORE_ATTEMPTS)" \
		--reduced "$(DOCS_EXPLORE_ATTEMPTS) grasp attempts per design instead of 20 (make explore)" \
		docs/images/explore_heat.png docs/images/explore_resolution.png docs/explore_grid.md

docs-sweep: $(BIN)/.installed
	$(BIN)/whisker cad sweep --radii $(DOCS_SWEEP_RADII) --out $(DOCS_RUNS)/sweep
	cp $(DOCS_RUNS)/sweep/sweep.png docs/images/sweep.png
	cp $(DOCS_RUNS)/sweep/sweep.md docs/sweep_table.md
	$(STAMP) --command "whisker cad sweep --radii $(DOCS_SWEEP_RADII)" --reduced "radii $(DOCS_SWEEP_RADII) mm (make sweep: 4..25 every 1 mm)" \
		docs/images/sweep.png docs/sweep_table.md

docs-fuzz: $(BIN)/.installed
	WHISKER_WALK_COMMAND_S=20 WHISKER_WALK_TIME_LIMIT_S=30 WHISKER_FUZZ_REPORT=benchmarks/results/fuzz_walk.md \
		$(BIN)/python -m pytest -q -p no:cacheprovider tests/test_cli_walk.py -k hostile
	$(STAMP) --command "make docs-fuzz (tests/test_cli_walk.py, 20 s of cases per command)" \
		--reduced "20 s of cases per command, 30 s per invocation (make fuzz: every case, 60 s)" \
		benchmarks/results/fuzz_walk.md benchmarks/results/fuzz_walk.png
	WHISKER_FUZZ_EXAMPLES=100 WHISKER_FUZZ_RANDOM=1 WHISKER_FUZZ_REPORT=benchmarks/results/fuzz_readers.md \
		$(BIN)/python -m pytest -q -p no:cacheprovider tests/test_fuzz_readers.py
	$(STAMP) --command "make docs-fuzz (tests/test_fuzz_readers.py, 100 mutants per reader)" \
		--reduced "100 mutants per reader (make fuzz: 400)" benchmarks/results/fuzz_readers.md benchmarks/results/fuzz_readers.png

docs-guide: $(BIN)/.installed
	$(BIN)/python -c "from whisker.design import load_design; from whisker.cad import guide_images; \
		guide_images.write_guide_images(load_design(), 'docs/images/build')"
	$(STAMP) --command "make guide (whisker.cad.pictures.guide_images.write_guide_images)" docs/images/build/*.png

docs-ros-frames: $(BIN)/.installed
	mkdir -p $(DOCS_RUNS)
	$(BIN)/whisker ros --urdf $(DOCS_RUNS)/whisker_array.urdf --frames-png docs/images/ros_frames.png
	$(STAMP) --command "whisker ros --urdf FILE --frames-png docs/images/ros_frames.png" docs/images/ros_frames.png

$(addprefix docs-bench-,$(DOCS_BENCH)): docs-bench-%: $(BIN)/.installed
	@test -f benchmarks/bench_$*.py || { echo "no benchmarks/bench_$*.py"; exit 2; }
	$(DOCS_BENCH_ENV_$*) WHISKER_PEER_DATA=$(PEER_DATA) $(BIN)/python benchmarks/bench_$*.py $(DOCS_BENCH_ARGS_$*)
	$(STAMP) --command "$(strip python benchmarks/bench_$*.py $(DOCS_BENCH_ARGS_$*))" \
		$(if $(DOCS_BENCH_REDUCED_$*),--reduced "$(DOCS_BENCH_REDUCED_$*)") \
		$(foreach f,$(DOCS_BENCH_FILES_$*),$(if $(findstring /,$(f)),$(f),benchmarks/results/$(f)))
