# Contact distance by active whisking (issue 31). See docs/locate.md.
#   make locate-demo                 whisker locate on a simulated sweep (contact 35 mm) -> $(OUT)/locate/
#   make bench-locate                accuracy (rigid / compliant / slip), vs amplitude, duration, fps and heat,
#                                    ablation, full pipeline -> benchmarks/results/locate.md, locate.png
#   make bench-locate-noise          accuracy vs tracker noise -> benchmarks/results/locate_noise.md
.PHONY: locate-demo bench-locate bench-locate-noise

locate-demo: $(BIN)/.installed ## whisker locate on a simulated sweep (rendered frames, real tracker) -> $(OUT)/locate/
	$(BIN)/whisker locate $(DESIGN_ARGS) --simulate 35 --out $(OUT)/locate

bench-locate: $(BIN)/.installed ## contact distance by active whisking: accuracy vs sweep and heat -> benchmarks/results/locate.md
	$(BIN)/python benchmarks/bench_locate.py

bench-locate-noise: $(BIN)/.installed ## contact distance vs tracker noise -> benchmarks/results/locate_noise.md
	$(BIN)/python benchmarks/bench_locate_noise.py
