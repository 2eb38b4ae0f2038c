# Fuzz campaign (issue 22): every `whisker` command and option through hostile values, and every file
# reader through mutated files. The test suite runs a reduced budget of the same tests; this is the full one.
#   make fuzz     full walk (every case, 60 s each) + 400 mutants per reader; tables and a figure in
#                 benchmarks/results/fuzz_walk.md, fuzz_readers.md, fuzz_readers.png
FUZZ_EXAMPLES ?= 400

.PHONY: fuzz

fuzz: $(BIN)/.installed ## full CLI walk + reader fuzzing; results in benchmarks/results/fuzz_*.md
	WHISKER_WALK_BUDGET=full WHISKER_FUZZ_REPORT=benchmarks/results/fuzz_walk.md \
		$(BIN)/python -m pytest -q tests/test_cli_walk.py
	WHISKER_FUZZ_EXAMPLES=$(FUZZ_EXAMPLES) WHISKER_FUZZ_RANDOM=1 WHISKER_FUZZ_REPORT=benchmarks/results/fuzz_readers.md \
		$(BIN)/python -m pytest -q tests/test_fuzz_readers.py
