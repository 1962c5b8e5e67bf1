# PTIR: the two commands of the README.
#   make demo  -- install everything, build, run the main job on the bundled sample
#   make test  -- install everything, build, run every test (gtest, pytest, blender -b; the headless add-on
#                 tests in Debian's Blender 3.4 and in PyPI's bpy 4.5 LTS and 5.0: tests/blender/blenders.py)
# Other targets: setup, setup-bpy, build, install-addon, bench, clean.

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

.PHONY: all setup setup-bpy build install-addon demo test test-native test-python bench clean

all: build

setup:
	./scripts/setup_debian.sh

# Test dependency only: bpy 4.5 / 5.0 in cached venvs (the Blenders artists run; headless).
setup-bpy: setup
	./scripts/setup_bpy.sh

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

test-python: build install-addon setup-bpy
	$(PYTHON) -m pytest -q tests/python tests/blender

test: test-native test-python

bench: build
	$(PYTHON) bench/bench_all.py --build $(BUILD)

clean:
	rm -rf $(BUILD)
