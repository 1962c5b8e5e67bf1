#!/usr/bin/env bash
# Test dependency only: PyPI's `bpy` (Blender as a Python module, headless, Cycles included) for the
# Blender releases artists run today, each in its own venv on Debian's python3.11 (the product never
# needs them). Cached per machine: a venv that already imports the pinned version is kept.
#   scripts/setup_bpy.sh            -> prints nothing but progress; venvs under $PTIR_BPY_CACHE
#   scripts/setup_bpy.sh --print    -> one line per release: "<version> <venv python>"
set -euo pipefail

BPY_VERSIONS=(4.5.15 5.0.1)   # 4.5 LTS and 5.0: the last ones built for CPython 3.11
CACHE="${PTIR_BPY_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/ptir}"

venv_of() { echo "$CACHE/bpy-$1"; }

if [ "${1:-}" = "--print" ]; then
  for v in "${BPY_VERSIONS[@]}"; do
    py="$(venv_of "$v")/bin/python"
    [ -x "$py" ] && echo "$v $py"
  done
  exit 0
fi

mkdir -p "$CACHE"
for v in "${BPY_VERSIONS[@]}"; do
  dir="$(venv_of "$v")"
  if [ -x "$dir/bin/python" ] && "$dir/bin/python" -c "import importlib.metadata as m, sys; sys.exit(m.version('bpy') != '$v')" 2>/dev/null; then
    echo "setup_bpy: bpy $v present ($dir)"
    continue
  fi
  echo "setup_bpy: installing bpy $v into $dir"
  rm -rf "$dir.tmp"
  /usr/bin/python3.11 -m venv --system-site-packages "$dir.tmp"
  "$dir.tmp/bin/python" -m pip install -q --disable-pip-version-check "bpy==$v" "numpy<2"
  rm -rf "$dir" && mv "$dir.tmp" "$dir"
  # A venv's scripts name their folder: rewrite after the move.
  sed -i "s|$dir.tmp|$dir|g" "$dir"/bin/* 2>/dev/null || true
done
