# topo_gaussian: `make demo` runs the main job on an embedded default, `make test` runs every test.
# Both install the Debian packages they need (scripts/install_deps.sh) and build into build/.
SHELL := /bin/bash
export PATH := /usr/bin:$(PATH)
BUILD ?= build
JOBS ?= $(shell nproc)
DEMO_DIR ?= $(BUILD)/demo

.PHONY: all deps configure build test demo bench core clean

all: build

deps:
	@./scripts/install_deps.sh

configure: deps
	@cmake -S . -B $(BUILD) -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON >/dev/null

build: configure
	@cmake --build $(BUILD) -j$(JOBS)
	@echo "[make build] done: source $(BUILD)/devel/setup.bash, then rosrun/roslaunch topo_gaussian ..."

test: build
	@./scripts/run_tests.sh $(BUILD)

demo: build
	@mkdir -p $(DEMO_DIR)
	$(BUILD)/devel/lib/topo_gaussian/topo generate --shape torus --size 0.1 --output $(DEMO_DIR)/torus.obj
	$(BUILD)/devel/lib/topo_gaussian/topo fill --input $(DEMO_DIR)/torus.obj --output $(DEMO_DIR)/torus_volume.ply \
	    --png $(DEMO_DIR)/torus_volume.png --json
	@echo "[make demo] volume: $(DEMO_DIR)/torus_volume.ply  picture: $(DEMO_DIR)/torus_volume.png"

bench: build
	@./bench/fill $(BUILD)
	@./bench/infer $(BUILD)
	@./bench/track $(BUILD)
	@./bench/soft $(BUILD)

# The ROS-free physics/topology core alone (what the GPU machines build).
core:
	@cmake -S . -B build-core -DTOPO_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release >/dev/null
	@cmake --build build-core -j$(JOBS)
	@cd build-core && ctest --output-on-failure

clean:
	rm -rf $(BUILD) build-core
