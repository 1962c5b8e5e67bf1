#!/usr/bin/env bash
# Installs the Debian 12 packages PTIR needs (build, tests, Blender). Idempotent:
# does nothing when everything is already installed. Needs root (or sudo).
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git ccache python3-venv
  patchelf  # make package: the bundled CLI and libraries find each other ($ORIGIN RUNPATH)
  debootstrap  # scripts/check_package_debootstrap.sh: the zip's CLI in a bare Debian root
  libembree-dev libtbb-dev libopenexr-dev libimath-dev
  libopenimageio-dev openimageio-tools
  pybind11-dev python3-dev python3-numpy python3-pytest python3-skimage
  nlohmann-json3-dev libcli11-dev libgtest-dev
  blender xvfb libgl1-mesa-dri
  clang libclang-rt-14-dev  # tests only: the libFuzzer harnesses (make fuzz-smoke, make fuzz; tests/fuzz)
  colmap  # tests only: model_converter as an independent reference for the COLMAP reader
  libopenmpi-dev openmpi-bin  # optional: `mpirun -np N ptir ...` data-parallel runs (CMake PTIR_WITH_MPI=AUTO)
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all Debian packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
