# Bill of materials and coil-driver wiring, generated from the design (docs/bom.md, docs/wiring.md).
#   make bom                      hw/bom.csv for the default design (kept in git, a test checks it)
#   make pcb                      pin map, pinout, wiring diagram, SKiDL netlist + ERC into hw/pcb/generated/,
#                                 and the routed driver HAT into hw/pcb/generated/hat/ (make hat alone;
#                                 make hat-sizes for 6 and 12 coils)
#   make bom WHISKERS=6           another design: into $(OUT)/bom.csv, never over the tracked hw/bom.csv
#   make bom WHISKERS=6 BOM_OUT=/tmp/bom6.csv     somewhere else
BOM_OUT ?= $(if $(strip $(DESIGN_ARGS)),$(OUT)/bom.csv,hw/bom.csv)
PCB_OUT ?= $(if $(strip $(DESIGN_ARGS)),$(OUT)/pcb,hw/pcb/generated)

.PHONY: bom pcb

bom: $(BIN)/.installed ## bill of materials from the design -> hw/bom.csv (BOM_OUT=...)
	$(BIN)/whisker hw bom $(DESIGN_ARGS) --out $(BOM_OUT)

pcb: $(BIN)/.installed ## driver pin map, pinout, wiring diagram, KiCad netlist; fails on ERC errors (PCB_OUT=...)
	$(BIN)/whisker hw pcb $(DESIGN_ARGS) --out $(PCB_OUT)
	$(BIN)/whisker hw hat $(DESIGN_ARGS) --out $(PCB_OUT)/hat $(HAT_ROUTE)

# The driver HAT (docs/wiring.md): routed board, Gerbers, drill, JLCPCB BOM/CPL, renders, schematic -> hw/pcb/generated/hat/.
# Needs KiCad 9 (scripts/system-deps installs it); HAT_ROUTE=--no-route for circuit, ERC and placement only.
HAT_OUT ?= $(PCB_OUT)/hat
HAT_ROUTE ?=
.PHONY: hat hat-sizes bench-hat
hat: $(BIN)/.installed ## driver HAT: routed KiCad board, DRC gate, Gerbers/drill/BOM/CPL, schematic SVG/PDF (HAT_OUT=..., HAT_ROUTE=--no-route)
	$(BIN)/whisker hw hat $(DESIGN_ARGS) --out $(HAT_OUT) $(HAT_ROUTE)

# The HAT for 6 and for 12 coils (12 needs the PCA9685s, above the INA3221s' 0x40-0x43), routed and
# DRC-gated like the default one, into $(OUT)/hat-6 and $(OUT)/hat-12 (not tracked); their summaries
# (DRC counts, design digest, the Gerbers' sha256), DRC reports and top renders are kept in
# hw/pcb/generated/hat6/ and hat12/ (tests/test_hat_routed.py checks them against the design).
HAT_SIZES_KEEP = hat_summary.json drc.json hat_top.png
hat-sizes: $(BIN)/.installed ## the HAT for 6 and 12 coils: routed, DRC gate -> $(OUT)/hat-6, -12; summaries -> hw/pcb/generated/hat6, hat12
	$(BIN)/whisker hw hat --set whiskers.count=6 --out $(OUT)/hat-6
	$(BIN)/whisker hw hat --set whiskers.count=12 --set 'wiring.expander="pca9685"' \
		--set wiring.pca9685_address=0x44 --out $(OUT)/hat-12
	for n in 6 12; do mkdir -p hw/pcb/generated/hat$$n && \
		for f in $(HAT_SIZES_KEEP); do cp $(OUT)/hat-$$n/$$f hw/pcb/generated/hat$$n/$$f; done; done

bench-hat: $(BIN)/.installed ## the HAT for 6/8/12 coils built again: nets routed, passes, route time, DRC, pin map on copper, Gerbers as committed -> benchmarks/results/hat.md
	$(BIN)/python benchmarks/bench_hat.py
