# dem_nerf: the README's commands. Everything builds into build/ (Release).
SHELL := /bin/bash
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
PYTHON ?= /usr/bin/python3
DATA ?=
CMAKE_ARGS ?=
# SANITIZE=address: an ASan + UBSan build of the ROS layer in build-asan, and `make test` runs the
# node tests only (test_ros_conversions and the dem_node_bad_input, nodes_advertise and
# nodes_fuzz rostests).
SANITIZE ?=
ifeq ($(SANITIZE),address)
BUILD_DIR := build-asan
override CMAKE_ARGS += -DDEMNERF_SANITIZE=address
export DEMNERF_TEST_SET := nodes
# roscpp keeps singletons until exit; leaks there are not ours. UBSan stops the process.
export ASAN_OPTIONS := detect_leaks=0:abort_on_error=1
export UBSAN_OPTIONS := print_stacktrace=1:halt_on_error=1
endif

.PHONY: setup build test demo bench clean

setup:
	@bash scripts/setup.sh

# /usr/bin/python3 for catkin: another python3 may come first on PATH.
build: setup
	@mkdir -p $(BUILD_DIR)
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=$(PYTHON) -DPython3_EXECUTABLE=$(PYTHON) \
	  -DCATKIN_ENABLE_TESTING=OFF $(CMAKE_ARGS) > $(BUILD_DIR)/configure.log 2>&1 \
	  || { tail -30 $(BUILD_DIR)/configure.log; echo "configure failed: see $(BUILD_DIR)/configure.log"; exit 1; }
	@cmake --build $(BUILD_DIR) -j$(JOBS)

test: build
	@bash scripts/run_tests.sh $(BUILD_DIR)

demo: build
	@bash scripts/demo.sh $(BUILD_DIR) "$(DATA)"

bench: setup
	@mkdir -p $(BUILD_DIR)
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=$(PYTHON) -DPython3_EXECUTABLE=$(PYTHON) \
	  -DCATKIN_ENABLE_TESTING=OFF -DDEMNERF_BUILD_BENCH=ON $(CMAKE_ARGS) > $(BUILD_DIR)/configure.log 2>&1
	@cmake --build $(BUILD_DIR) -j$(JOBS)
	@bash scripts/run_bench.sh $(BUILD_DIR)

clean:
	rm -rf $(BUILD_DIR)
