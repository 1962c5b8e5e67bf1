# PTIR: the two commands of the README.
#   make demo  -- install everything, build, run the main job on the bundled sample
#   make test  -- install everything, build, run every test (gtest, pytest, blender -b)
# Other targets: setup, build, install-addon, bench, clean.

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

.PHONY: all setup build install-addon demo test test-native test-python bench clean

all: build

setup:
	./scripts/setup_debian.sh

build: setup
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE=/usr/bin/python3.11
	cmake --build $(BUILD) -j $(JOBS)

install-addon: build
	./scripts/install_addon.sh $(BUILD)

# The demo builds only what it runs -- the ptir tool and the Python module the add-on
# carries -- not the test and benchmark binaries (a later `make test` builds those in
# the same folder, reusing these objects).
demo: setup
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE=/usr/bin/python3.11
	cmake --build $(BUILD) -j $(JOBS) --target ptir_cli ptir_python
	./scripts/install_addon.sh $(BUILD)
	./scripts/demo.sh $(BUILD)

test-native: build
	# Serial: some test fixtures share folders under build/test_tmp.
	cd $(BUILD) && ctest --output-on-failure

test-python: build install-addon
	$(PYTHON) -m pytest -q tests/python tests/blender

test: test-native test-python

bench: build
	$(PYTHON) bench/bench_all.py --build $(BUILD)

clean:
	rm -rf $(BUILD)
