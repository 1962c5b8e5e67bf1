# PTIR: the two commands of the README.
#   make demo  -- install everything, build, run the main job on the bundled sample
#   make test  -- install everything, build, run every test (gtest, pytest, blender -b)
# Other targets: setup, build, install-addon, bench, clean, fuzz-smoke, fuzz.

BUILD ?= build
JOBS ?= $(shell nproc)
PYTHON := /usr/bin/python3
export PTIR_BUILD_DIR := $(abspath $(BUILD))
# ccache when present: paths under the checkout are hashed relative to it, so a fresh
# clone elsewhere on the same machine (CI) reuses the objects of the last build.
ifneq ($(shell command -v ccache 2>/dev/null),)
export CMAKE_CXX_COMPILER_LAUNCHER := ccache
export CCACHE_BASEDIR := $(abspath .)
export CCACHE_NOHASHDIR := 1
endif

.PHONY: all setup build install-addon demo test test-native test-python bench clean fuzz-build fuzz-smoke fuzz

all: build

setup:
	./scripts/setup_debian.sh

build: setup
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE=/usr/bin/python3.11
	cmake --build $(BUILD) -j $(JOBS)

install-addon: build
	./scripts/install_addon.sh $(BUILD)

demo: build install-addon
	./scripts/demo.sh $(BUILD)

test-native: build
	# Serial: some test fixtures share folders under build/test_tmp.
	cd $(BUILD) && ctest --output-on-failure

test-python: build install-addon
	$(PYTHON) -m pytest -q tests/python tests/blender

test: test-native test-python

# Fuzz harnesses (tests/fuzz/README.md): libFuzzer + ASan/UBSan, clang, in their own build folder.
# fuzz-smoke (part of `make test`): each target FUZZ_SMOKE_SECONDS from its committed seeds;
# fuzz: each target FUZZ_SECONDS, its new inputs kept in $(FUZZ_BUILD)/corpus/<target>.
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 600
FUZZ_SMOKE_SECONDS ?= 15
FUZZ_TARGETS := serve scene_json ply colmap nerfstudio image

fuzz-build: setup
	CC=clang CXX=clang++ cmake -S . -B $(FUZZ_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPTIR_FUZZ=ON \
	  -DPython_EXECUTABLE=/usr/bin/python3.11
	cmake --build $(FUZZ_BUILD) -j $(JOBS) --target $(addprefix fuzz_,$(FUZZ_TARGETS))

fuzz-smoke: fuzz-build
	./tests/fuzz/run_fuzz.sh $(FUZZ_BUILD) $(FUZZ_SMOKE_SECONDS) $(FUZZ_TARGETS)

fuzz: fuzz-build
	./tests/fuzz/run_fuzz.sh $(FUZZ_BUILD) $(FUZZ_SECONDS) $(FUZZ_TARGETS)

test: fuzz-smoke

bench: build
	$(PYTHON) bench/bench_all.py --build $(BUILD)

clean:
	rm -rf $(BUILD)
