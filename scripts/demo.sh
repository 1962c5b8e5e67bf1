#!/usr/bin/env bash
# The main job on the bundled sample: every AOV of two test views, rendered by
# the `ptir` CLI from a 3DGS splat file plus a triangle floor.
#   scripts/demo.sh [BUILD_DIR]        (default: build; `make demo` runs it)
# Makes out/sample/ with Blender when it is missing, writes out/demo/ and prints
# what it wrote with timings.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-build}"
[[ "$BUILD" = /* ]] || BUILD="$PWD/$BUILD"
PTIR="$BUILD/bin/ptir"
SAMPLE="$ROOT/out/sample"
OUT="$ROOT/out/demo"
FRAMES=(0 1)  # front view and a three-quarter view
AOVS=(preview opacity depth normal albedo roughness metallic)

if [ ! -x "$PTIR" ]; then
  echo "demo: error: $PTIR not found (run 'make build')" >&2
  exit 1
fi

now() { date +%s.%N; }
secs() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", b - a }'; }

# 1. The sample scene (procedural, a few seconds).
if [ ! -s "$SAMPLE/gaussians.ply" ] || [ ! -s "$SAMPLE/floor.ply" ] || [ ! -s "$SAMPLE/transforms_test.json" ]; then
  echo "demo: making the sample scene in $SAMPLE"
  t0=$(now)
  blender -b --factory-startup -noaudio --python-exit-code 1 -P "$ROOT/scripts/make_sample_splat.py" -- \
    --out "$SAMPLE" | grep -E "^make_sample_splat" || { echo "demo: error: sample generation failed" >&2; exit 1; }
  echo "demo: sample made in $(secs "$t0" "$(now)") s"
fi

mkdir -p "$OUT"
LOG="$(mktemp)"
trap 'rm -f "$LOG"' EXIT

# 2. Every AOV as EXR (linear float) and PNG (8-bit) with the CLI.
SUMMARY=()
total0=$(now)
for frame in "${FRAMES[@]}"; do
  for aov in "${AOVS[@]}"; do
    for ext in exr png; do
      file="$OUT/frame${frame}_${aov}.${ext}"
      t0=$(now)
      if ! "$PTIR" render --gaussians "$SAMPLE/gaussians.ply" --mesh "$SAMPLE/floor.ply" \
          --cameras "$SAMPLE/transforms_test.json" --frame "$frame" --aov "$aov" -o "$file" 2>"$LOG"; then
        cat "$LOG" >&2
        echo "demo: error: rendering $file failed" >&2
        exit 1
      fi
      # The CLI's last line: "wrote FILE (WxH, aov, N Gaussians, H hits/ray, S s)".
      hits=$(sed -n 's/.* \([0-9.]*\) hits\/ray.*/\1/p' "$LOG" | tail -n 1)
      SUMMARY+=("$(printf '%-28s %6ss  %5s hits/ray' "$(basename "$file")" "$(secs "$t0" "$(now)")" "${hits:-?}")")
    done
  done

  # 3. Viewable versions of the data AOVs: the 8-bit files hold raw values
  # (depth in scene units saturates at 1, negative normal components clip).
  depth="$OUT/frame${frame}_depth.exr"
  # Nearest covered depth: push the background (A = 0) far away before taking the minimum.
  near=$(oiiotool "$depth" --ch A --mulc -1e6 --addc 1e6 "$depth" --ch Z --add --printstats \
         | sed -n 's/.*Stats Min: \([0-9.eE+-]*\).*/\1/p')
  far=$(oiiotool "$depth" --ch Z --printstats | sed -n 's/.*Stats Max: \([0-9.eE+-]*\).*/\1/p')
  # Disparity (near / Z) spreads the grey levels where the object is, not over the far floor.
  k=$(awk -v n="$near" -v f="$far" 'BEGIN { r = (f > n) ? n / f : 0; printf "%.6g %.6g", r, 1.0 / (1.0 - r) }')
  read -r offset gain <<<"$k"
  oiiotool "$depth" --ch Z --powc -1 --mulc "$near" --subc "$offset" --mulc "$gain" --clamp:min=0:max=1 \
    "$depth" --ch A --mul -o "$OUT/frame${frame}_depth_vis.png"
  normal="$OUT/frame${frame}_normal.exr"
  oiiotool "$normal" --ch X,Y,Z --mulc 0.5 --addc 0.5 "$normal" --ch A --chappend \
    -o "$OUT/frame${frame}_normal_vis.png"
  SUMMARY+=("$(printf '%-28s disparity, depth %.2f..%.2f -> white..black' "frame${frame}_depth_vis.png" "$near" "$far")")
  SUMMARY+=("$(printf '%-28s normal 0.5 + 0.5 n' "frame${frame}_normal_vis.png")")
done

# 4. Summary.
n_gauss=$(sed -n 's/.*, \([0-9]*\) Gaussians,.*/\1/p' "$LOG" | tail -n 1)
echo
echo "demo: ${n_gauss:-?} Gaussians + floor mesh, frames ${FRAMES[*]}, AOVs ${AOVS[*]}"
printf '  %s\n' "${SUMMARY[@]}"
echo "demo: ${#SUMMARY[@]} files in $OUT ($(secs "$total0" "$(now)") s; each CLI run loads, builds the BVH, orients normals, renders)"
