# Build guide (docs/build.md) from hw/build_steps.toml, with every picture it names.
#   make guide                    regenerate the pictures and the guide's step sections (slow: renders)

.PHONY: guide
guide: assembly-images ## build guide: every picture it names + docs/build.md's steps from hw/build_steps.toml
	$(BIN)/whisker cad build $(DESIGN_ARGS) --out $(OUT) -q
	$(BIN)/whisker print preview $(DESIGN_ARGS) --out $(OUT) --images docs/images/parts
	$(BIN)/python -c "from whisker.design import load_design; from whisker.cad import guide_images, guide; \
		guide_images.write_guide_images(load_design(), 'docs/images/build'); guide.update_page('docs/build.md')"
