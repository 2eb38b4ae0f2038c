# Object classification from whisker contacts (issue 9). See docs/classification.md.
#   make classify-eval               the paper's MLP under every split protocol, 10 seeds, 10 objects
#   make classify-eval OBJECTS=paper the paper's 5 objects
#   make classify-train              train on all 10 objects (trial split reported) -> $(OUT)/classify/model.joblib
#   make bench-classify              protocols, hidden x epochs cost grid, other models, models beyond the paper,
#                                    rotation pairing -> benchmarks/results/classify.md (--reuse: sections 5-6 only)
PEER_DATA ?= $(or $(WHISKER_PEER_DATA),../shared/data/peer-whisker-2025)
OBJECTS ?=
CLASSIFY_OUT ?= $(OUT)/classify

.PHONY: classify-eval classify-train bench-classify

classify-eval: $(BIN)/.installed ## accuracy (mean +- std, 10 seeds) of the paper's MLP under each protocol -> $(OUT)/classify/
	$(BIN)/whisker classify evaluate $(DESIGN_ARGS) --data $(PEER_DATA) $(if $(OBJECTS),--objects $(OBJECTS)) --seeds 10 --out $(CLASSIFY_OUT)/eval

classify-train: $(BIN)/.installed ## train the paper's MLP on the authors' data, save model + per-class report
	$(BIN)/whisker classify train $(DESIGN_ARGS) --data $(PEER_DATA) $(if $(OBJECTS),--objects $(OBJECTS)) --protocol trial --out $(CLASSIFY_OUT)/model.joblib --report $(CLASSIFY_OUT)/report

bench-classify: $(BIN)/.installed ## classification accuracy vs training/inference time -> benchmarks/results/classify.md
	WHISKER_PEER_DATA=$(PEER_DATA) $(BIN)/python benchmarks/bench_classify.py
