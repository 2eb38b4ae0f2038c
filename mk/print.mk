# Printing: slicer check + print report, and preview images (issue 3). See docs/printing.md.
#   make check-print                 slice every printable part of the default design (PrusaSlicer)
#   make check-print WHISKERS=12     the same for a 12-whisker design
#   make preview PREVIEW=docs/images/parts refresh the README's images (default design only)
#   make assembly-images             one picture per assembly step into docs/images/assembly + docs/assembly.md (default design only)
PREVIEW ?= $(OUT)/preview
ASSEMBLY_IMAGES ?= docs/images/assembly

.PHONY: check-print preview assembly-images

check-print: $(BIN)/.installed system-deps ## slice every printable part headless: time, grams, supports -> exports/print_report.md
	$(BIN)/whisker cad build $(DESIGN_ARGS) --out $(OUT) -q
	$(BIN)/whisker print check $(DESIGN_ARGS) --build $(OUT)

preview: $(BIN)/.installed ## PNG images of each printable part and the assembly (into $(PREVIEW))
	$(BIN)/whisker cad build $(DESIGN_ARGS) --out $(OUT) -q
	$(BIN)/whisker print preview $(DESIGN_ARGS) --build $(OUT) --images $(PREVIEW)

assembly-images: $(BIN)/.installed ## PNG per assembly step, exploded along its path (into $(ASSEMBLY_IMAGES)), the table in docs/assembly.md
	$(BIN)/whisker cad assembly-images $(DESIGN_ARGS) --out $(ASSEMBLY_IMAGES) --page docs/assembly.md
