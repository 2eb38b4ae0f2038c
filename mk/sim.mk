# Scene simulator (issue 8). See docs/sim.md. Run folders go to runs/<scene>/ (not in git).
#   make sim-angle                  scene 1: whisker tilt against coil voltage (paper Fig. 4 shape)
#   make sim-grasp ATTEMPTS=100    scene 2: the grasp table beside the paper's (5 objects x 8/4/2 whiskers)
#   make sim-displacement TRIALS=5         scene 3: marker displacement against time, foam ball and pinecone
#   make sim-dataset TRIALS=5      scene 4: classification dataset (runs/classification/dataset/<object>.csv)
#   make sim-camera                end to end: frames -> tracker -> geometry, tip RMS error
#   make sim-paper                 all of the above;  make sim-bench: accuracy vs cost table
#   make sim-sensitivity           compliant contact: grasp table rigid vs compliant vs paper, each cell across
#                                  each material parameter's published range, cost (COMPLIANT_ATTEMPTS, SENS_ATTEMPTS)
SIM_SCENES := software/whisker/sim/scenes
SIM_RUNS ?= runs
ATTEMPTS ?= 100
TRIALS ?= 5

.PHONY: sim-angle sim-grasp sim-displacement sim-dataset sim-camera sim-paper sim-bench sim-sensitivity
COMPLIANT_ATTEMPTS ?= 100
SENS_ATTEMPTS ?= 20

sim-angle: $(BIN)/.installed ## simulated angle vs voltage (paper Fig. 4) -> runs/angle-vs-voltage/
	$(BIN)/whisker sim $(SIM_SCENES)/angle_vs_voltage.toml $(foreach s,$(SET),--set $(s)) --out $(SIM_RUNS)/angle-vs-voltage

sim-grasp: $(BIN)/.installed ## simulated grasp table (ATTEMPTS per cell) beside the paper's -> runs/grasp/
	$(BIN)/whisker sim $(SIM_SCENES)/grasp.toml $(foreach s,$(SET),--set $(s)) --attempts $(ATTEMPTS) --out $(SIM_RUNS)/grasp

sim-displacement: $(BIN)/.installed ## simulated displacement vs time, mean and band over TRIALS (paper Fig. 8) -> runs/displacement/
	$(BIN)/whisker sim $(SIM_SCENES)/displacement.toml $(foreach s,$(SET),--set $(s)) --trials $(TRIALS) --out $(SIM_RUNS)/displacement

sim-dataset: $(BIN)/.installed ## simulated classification dataset, authors' 128-value layout -> runs/classification/dataset/
	$(BIN)/whisker sim $(SIM_SCENES)/classification.toml $(foreach s,$(SET),--set $(s)) --trials $(TRIALS) --out $(SIM_RUNS)/classification

sim-camera: $(BIN)/.installed ## scene -> rendered frames -> tracker -> geometry, tip RMS error -> runs/camera-e2e/
	$(BIN)/whisker sim $(SIM_SCENES)/camera_e2e.toml $(foreach s,$(SET),--set $(s)) --out $(SIM_RUNS)/camera-e2e

sim-paper: sim-angle sim-grasp sim-displacement sim-dataset sim-camera ## every paper experiment in simulation

sim-bench: $(BIN)/.installed ## simulator accuracy vs cost -> benchmarks/results/sim.{md,csv,png}
	$(BIN)/python benchmarks/bench_sim.py

sim-sensitivity: $(BIN)/.installed ## compliant vs rigid grasp table, material sensitivity, cost -> benchmarks/results/sim_compliant.{md,csv}
	COMPLIANT_ATTEMPTS=$(COMPLIANT_ATTEMPTS) SENS_ATTEMPTS=$(SENS_ATTEMPTS) nice $(BIN)/python benchmarks/bench_compliant.py
