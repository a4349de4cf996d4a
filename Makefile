# topo_gaussian: `make demo` runs the full lab loop headless on the digital twins (RIG=tumbler|finger|all),
# `make test` runs every test binary and rostest without the slow cases (test/slow_tests.txt),
# `make test-full` everything (what CI runs).
# Both install the Debian packages they need (scripts/install_deps.sh) and build into build/.
SHELL := /bin/bash
export PATH := /usr/bin:$(PATH)
BUILD ?= build
JOBS ?= $(shell nproc)
DEMO_DIR ?= $(BUILD)/demo
RIG ?= all  # make demo RIG=tumbler|finger|all

.PHONY: all deps configure build test test-full demo bench core clean

all: build

deps:
	@./scripts/install_deps.sh

configure: deps
	@cmake -S . -B $(BUILD) -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON >/dev/null

build: configure
	@cmake --build $(BUILD) -j$(JOBS)
	@echo "[make build] done: source $(BUILD)/devel/setup.bash, then rosrun/roslaunch topo_gaussian ..."

test: build
	@./scripts/run_tests.sh $(BUILD) quick

test-full: build
	@./scripts/run_tests.sh $(BUILD) full

demo: build
	@RIG=$(RIG) ./scripts/demo.sh $(BUILD) $(DEMO_DIR)

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
