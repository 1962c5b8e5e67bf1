# PTIR: the two commands of the README.
#   make demo  -- install everything, build, run the main job on the bundled sample
#   make test  -- install everything, build, run every test (gtest, pytest, blender -b; the headless add-on
#                 tests in Debian's Blender 3.4 and in PyPI's bpy 4.5 LTS and 5.0: tests/blender/blenders.py)
# Other targets: setup, setup-bpy, build, install-addon, package, bench, clean, fuzz-smoke, fuzz.
#   make package -- dist/ptir-<version>-linux-x64.zip: the add-on with the CLI and its libraries
#                   (a Blender 4.2+ Extension; a legacy add-on zip on 3.x): docs/install.md

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

.PHONY: all setup setup-bpy build install-addon package package-cli demo test test-native test-python bench clean fuzz-build fuzz-smoke fuzz

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

# The package's CLI: its own build folder, without MPI (whose plugins cannot travel in a zip),
# without tests or the Python module. The zip is remade when the CLI, the add-on or the script change.
PKG_BUILD ?= $(BUILD)-package
VERSION := $(shell grep -m1 -o 'ptir VERSION [0-9.]*' CMakeLists.txt | cut -d' ' -f3)
PACKAGE_ZIP := dist/ptir-$(VERSION)-linux-x64.zip
export PTIR_PACKAGE_ZIP := $(abspath $(PACKAGE_ZIP))

package: $(PACKAGE_ZIP)

package-cli: setup
	cmake -S . -B $(PKG_BUILD) -DCMAKE_BUILD_TYPE=Release -DPTIR_WITH_MPI=OFF -DPTIR_BUILD_TESTS=OFF \
	  -DPTIR_BUILD_PYTHON=OFF -DPython_EXECUTABLE=/usr/bin/python3.11
	cmake --build $(PKG_BUILD) -j $(JOBS) --target ptir_cli

$(PKG_BUILD)/bin/ptir: package-cli ;

$(PACKAGE_ZIP): $(PKG_BUILD)/bin/ptir scripts/make_package.py $(shell find addon/ptir_blender -name '*.py')
	$(PYTHON) scripts/make_package.py --cli $(PKG_BUILD)/bin/ptir --out dist

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

test-python: build install-addon package setup-bpy
	$(PYTHON) -m pytest -q tests/python tests/blender

test: test-native test-python

# Fuzz harnesses (tests/fuzz/README.md): libFuzzer + ASan/UBSan, clang, in their own build folder.
# fuzz-smoke (part of `make test`): each target FUZZ_SMOKE_RUNS inputs from its committed seeds and a fixed
# random seed (the same inputs every run: the smoke fails on a change, never by chance);
# fuzz: each target FUZZ_SECONDS, its new inputs kept in $(FUZZ_BUILD)/corpus/<target>.
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 600
FUZZ_SMOKE_RUNS ?= 5000
FUZZ_TARGETS := serve scene_json ply colmap nerfstudio image texture cameras_json orbit budget

fuzz-build: setup
	CC=clang CXX=clang++ cmake -S . -B $(FUZZ_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPTIR_FUZZ=ON \
	  -DPython_EXECUTABLE=/usr/bin/python3.11
	cmake --build $(FUZZ_BUILD) -j $(JOBS) --target $(addprefix fuzz_,$(FUZZ_TARGETS))

fuzz-smoke: fuzz-build
	./tests/fuzz/run_fuzz.sh $(FUZZ_BUILD) runs=$(FUZZ_SMOKE_RUNS) $(FUZZ_TARGETS)

fuzz: fuzz-build
	./tests/fuzz/run_fuzz.sh $(FUZZ_BUILD) $(FUZZ_SECONDS) $(FUZZ_TARGETS)

test: fuzz-smoke

bench: build
	$(PYTHON) bench/bench_all.py --build $(BUILD)

clean:
	rm -rf $(BUILD) $(PKG_BUILD) dist
