# Bill of materials and coil-driver wiring, generated from the design (docs/bom.md, docs/wiring.md).
#   make bom                      hw/bom.csv for the default design (kept in git, a test checks it)
#   make pcb                      pin map, pinout, wiring diagram, SKiDL netlist + ERC into hw/pcb/generated/,
#                                 and the driver HAT into hw/pcb/generated/hat/ (make hat alone)
#   make bom WHISKERS=6 BOM_OUT=/tmp/bom6.csv     another design, somewhere else
BOM_OUT ?= hw/bom.csv
PCB_OUT ?= hw/pcb/generated

.PHONY: bom pcb

bom: $(BIN)/.installed ## bill of materials from the design -> hw/bom.csv (BOM_OUT=...)
	$(BIN)/whisker hw bom $(DESIGN_ARGS) --out $(BOM_OUT)

pcb: $(BIN)/.installed ## driver pin map, pinout, wiring diagram, KiCad netlist; fails on ERC errors (PCB_OUT=...)
	$(BIN)/whisker hw pcb $(DESIGN_ARGS) --out $(PCB_OUT)
	$(BIN)/whisker hw hat $(DESIGN_ARGS) --out $(PCB_OUT)/hat $(HAT_ROUTE)

# The driver HAT (docs/wiring.md): routed board, Gerbers, drill, JLCPCB BOM/CPL, renders -> hw/pcb/generated/hat/.
# Needs KiCad 9 (scripts/system-deps installs it); HAT_ROUTE=--no-route for circuit, ERC and placement only.
HAT_OUT ?= $(PCB_OUT)/hat
HAT_ROUTE ?= --no-route   # routing (freeroute) does not yet reach DRC 0/0 on this board: docs/wiring.md
.PHONY: hat
hat: $(BIN)/.installed ## driver HAT: routed KiCad board, DRC gate, Gerbers/drill/BOM/CPL (HAT_OUT=..., HAT_ROUTE=--no-route)
	$(BIN)/whisker hw hat $(DESIGN_ARGS) --out $(HAT_OUT) $(HAT_ROUTE)
