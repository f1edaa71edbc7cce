# Regenerates the README's picture of the Cornell box solution:
#   make docs/cornell.png
# (needs a Vulkan driver, or Mesa's lavapipe: apt-get install mesa-vulkan-drivers)

BIN := target/release
TOOLS := ugplanar ugvlmerge ugflip ugisect ugcopl ugclean ugcut ugrad ugview

.PHONY: pictures tools
pictures: docs/cornell.png docs/cornell-mesh.png

tools:
	cargo build --release $(addprefix -p ,$(TOOLS))

target/cornell-lit.ug: fixtures/cornell-box.ug tools
	$(BIN)/ugplanar $< | $(BIN)/ugvlmerge | $(BIN)/ugflip | $(BIN)/ugisect \
	  | $(BIN)/ugcopl | $(BIN)/ugclean | $(BIN)/ugcut -l 50 \
	  | $(BIN)/ugrad --visibility ray --converge 1e-3 -q -o $@

docs/cornell.png: target/cornell-lit.ug
	$(BIN)/ugview $< --size 512x512 -o $@

docs/cornell-mesh.png: target/cornell-lit.ug
	$(BIN)/ugview $< --size 512x512 --mesh -o $@
