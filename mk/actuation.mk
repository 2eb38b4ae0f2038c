# Actuation, thermal guard and recording (issue 7). See docs/actuation.md.
#   make grasp-dry                  the paper's grasp on gpiozero mock pins (no hardware), 4 whiskers
#   make grasp-figure TRIALS=5          5 grasp recordings of the simulated sensor -> docs/images/fig8_sim.png
#   make bench-actuation                guard estimate vs an ODE reference, guard policies, recording cost
TRIALS ?= 5
FIG8_RUNS ?= $(OUT)/grasp-figure

.PHONY: grasp-dry grasp-figure bench-actuation

grasp-dry: $(BIN)/.installed ## the grasp sequence on mock pins (prints every phase and the coil temperatures)
	$(BIN)/whisker grasp $(DESIGN_ARGS) --backend mock --config every-second --retract-s 0.5 --hold-s 2 --release-s 0.5

grasp-figure: $(BIN)/.installed ## record TRIALS simulated grasps (render -> track) and plot the paper's Fig. 8
	rm -rf $(FIG8_RUNS)
	for k in $$(seq 1 $(TRIALS)); do \
	  $(BIN)/whisker record $(DESIGN_ARGS) --source sim --backend sim --grasp all --out $(FIG8_RUNS)/trial-$$k \
	    --retract-s 1 --hold-s 2 --release-s 1 --tail-s 1 --trial "sim $$k" -q || exit 1; done
	$(BIN)/whisker recplot $(FIG8_RUNS)/trial-* --out docs/images/fig8_sim.png --title "simulated sensor, 8 whiskers, $(TRIALS) trials"

bench-actuation: $(BIN)/.installed ## thermal guard accuracy vs update period, guard policies, recording cost -> benchmarks/results/actuation.md
	$(BIN)/python benchmarks/bench_actuation.py
