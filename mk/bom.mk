# Bill of materials and coil-driver wiring, generated from the design (docs/bom.md, docs/wiring.md).
#   make bom                      hw/bom.csv for the default design (kept in git, a test checks it)
#   make pcb                      pin map, pinout, wiring diagram, SKiDL netlist + ERC into hw/pcb/generated/
#   make bom WHISKERS=6           another design: into $(OUT)/bom.csv, never over the tracked hw/bom.csv
#   make bom WHISKERS=6 BOM_OUT=/tmp/bom6.csv     somewhere else
BOM_OUT ?= $(if $(strip $(DESIGN_ARGS)),$(OUT)/bom.csv,hw/bom.csv)
PCB_OUT ?= $(if $(strip $(DESIGN_ARGS)),$(OUT)/pcb,hw/pcb/generated)

.PHONY: bom pcb

bom: $(BIN)/.installed ## bill of materials from the design -> hw/bom.csv (BOM_OUT=...)
	$(BIN)/whisker hw bom $(DESIGN_ARGS) --out $(BOM_OUT)

pcb: $(BIN)/.installed ## driver pin map, pinout, wiring diagram, KiCad netlist; fails on ERC errors (PCB_OUT=...)
	$(BIN)/whisker hw pcb $(DESIGN_ARGS) --out $(PCB_OUT)
