#!/usr/bin/env bash
# Installs the PTIR add-on into the user's Blender: addon/ptir_blender plus the
# native module built in BUILD_DIR (build/python/ptir*.so) and the engine's
# command-line tool (build/bin/ptir, which the render engine and the optimiser
# run as a child process) copied inside it (ptir_blender/bin/ptir).
#   scripts/install_addon.sh [BUILD_DIR]      (default: build)
# Idempotent. The new copy is staged in a temp folder next to the old one and
# renamed into place, so a Blender starting meanwhile never sees a half-copied
# add-on (at worst, for an instant, none).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-build}"
[[ "$BUILD" = /* ]] || BUILD="$PWD/$BUILD"
BLENDER="${BLENDER:-blender}"

shopt -s nullglob
modules=("$BUILD"/python/ptir*.so)
if [ ${#modules[@]} -ne 1 ]; then
  echo "install_addon: error: expected one native module $BUILD/python/ptir*.so, found ${#modules[@]} (run 'make build')" >&2
  exit 1
fi

# Ask Blender itself where user add-ons live (differs per version and platform).
ADDONS="$("$BLENDER" -b --factory-startup -noaudio --python-expr \
  "import bpy;print('ADDONS=' + bpy.utils.user_resource('SCRIPTS', path='addons', create=True))" 2>/dev/null \
  | sed -n 's/^ADDONS=//p' | tail -n 1)"
if [ -z "$ADDONS" ] || [ ! -d "$ADDONS" ]; then
  echo "install_addon: error: could not find Blender's user add-ons folder (is '$BLENDER' installed?)" >&2
  exit 1
fi

DEST="$ADDONS/ptir_blender"
STAGE="$(mktemp -d "$ADDONS/.ptir_blender.new.XXXXXX")"
OLD="$ADDONS/.ptir_blender.old.$$"
cleanup() { rm -rf "$STAGE" "$OLD"; }
trap cleanup EXIT

cp -R "$ROOT/addon/ptir_blender/." "$STAGE/"
find "$STAGE" -name __pycache__ -prune -exec rm -rf {} +
cp "${modules[0]}" "$STAGE/"
if [ -x "$BUILD/bin/ptir" ]; then
  mkdir -p "$STAGE/bin"
  cp "$BUILD/bin/ptir" "$STAGE/bin/ptir"
else
  echo "install_addon: warning: no $BUILD/bin/ptir: F12 renders and optimisation need the CLI (run 'make build')" >&2
fi
chmod 755 "$STAGE"

# Swap: move the old copy aside, rename the new one in, then drop the old one.
if [ -e "$DEST" ]; then mv "$DEST" "$OLD"; fi
mv "$STAGE" "$DEST"

echo "install_addon: installed $DEST ($(basename "${modules[0]}")$([ -x "$DEST/bin/ptir" ] && echo ", bin/ptir"))"

# Enable it in the user's preferences (saved), so sample files open with the PTIR engine
# instead of silently falling back to Eevee. PTIR_NO_ENABLE=1 leaves the preferences alone.
if [ -z "${PTIR_NO_ENABLE:-}" ]; then
  if "$BLENDER" -b -noaudio --python-expr "
import addon_utils, bpy, sys
mod = addon_utils.enable('ptir_blender', default_set=True, persistent=True)
if mod is None: sys.exit(1)
bpy.ops.wm.save_userpref()
print('PTIR_ENABLED')" 2>/dev/null | grep -q PTIR_ENABLED; then
    echo "install_addon: enabled PTIR in Blender's preferences"
  else
    echo "install_addon: warning: could not enable the add-on; enable it in Edit > Preferences > Add-ons > PTIR" >&2
  fi
fi
