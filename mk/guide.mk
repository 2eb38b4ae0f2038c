# Build guide (docs/build.md) from hw/build_steps.toml, with its pictures.
#   make guide                    regenerate every picture the guide names and its step sections

.PHONY: guide
guide: assembly-images preview ## build guide: pictures + docs/build.md's steps from hw/build_steps.toml
	$(BIN)/python -c "from whisker.cad.guide import update_page; update_page('docs/build.md')"
