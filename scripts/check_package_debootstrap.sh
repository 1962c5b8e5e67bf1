#!/usr/bin/env bash
# Runs the release zip's CLI on a Linux with none of the build's packages: a minimal Debian root
# (debootstrap --variant=minbase: glibc, libstdc++, coreutils, apt; no Embree, TBB, OpenEXR,
# OpenImageIO, ...) into which only the zip's bin/ptir and lib/ are copied. Inside it (chroot,
# empty environment) the CLI renders a small scene: splats (a PLY), meshes, an area light and an
# HDR environment, to EXR and PNG (checked on the host with oiiotool); then with the environment as
# PNG, JPEG and TIFF, and with a truncated and a garbage image, which must give the CLI's own error.
#
#   scripts/check_package_debootstrap.sh [ZIP]     (default: dist/ptir-<CMake version>-linux-x64.zip)
#
# Needs root (debootstrap, chroot), debootstrap, python3 and oiiotool (scripts/setup_debian.sh), and
# Debian's mirror: the one apt is configured with (/etc/apt/sources.list*), or $PTIR_DEBIAN_MIRROR.
# The bare root is cached in $PTIR_DEBOOTSTRAP_ROOT (default ~/.cache/ptir/debootstrap-<suite>)
# and reused while it stays bare. Not part of `make test` (it downloads ~40 MB once, and needs root).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
die() { echo "check_package_debootstrap: error: $*" >&2; exit 1; }
say() { echo "check_package_debootstrap: $*"; }

[ "$(id -u)" -eq 0 ] || die "needs root (debootstrap and chroot)"
for tool in debootstrap chroot python3 oiiotool; do
  command -v "$tool" >/dev/null || die "'$tool' is not installed (run scripts/setup_debian.sh)"
done

VERSION="$(grep -m1 -o 'ptir VERSION [0-9.]*' "$ROOT/CMakeLists.txt" | cut -d' ' -f3)"
ZIP="$(realpath "${1:-$ROOT/dist/ptir-$VERSION-linux-x64.zip}")" || die "no zip"
[ -f "$ZIP" ] || die "no zip $ZIP (run 'make package')"

SUITE="$(. /etc/os-release && echo "${VERSION_CODENAME:-bookworm}")"
SUITE="${SUITE:-bookworm}"
# The mirror apt uses for the suite (deb822 .sources stanzas, then one-line sources.list entries).
MIRROR="${PTIR_DEBIAN_MIRROR:-$(python3 - "$SUITE" <<'EOF'
import glob, re, sys
suite = sys.argv[1]
for path in sorted(glob.glob("/etc/apt/sources.list.d/*.sources")):
    for stanza in re.split(r"\n\s*\n", open(path).read()):
        fields = dict(re.findall(r"^(\w[\w-]*):\s*(.*)$", stanza, re.M))
        if fields.get("Types", "deb").split()[0] == "deb" and suite in fields.get("Suites", "").split():
            print(fields["URIs"].split()[0]); sys.exit()
for path in ["/etc/apt/sources.list"] + sorted(glob.glob("/etc/apt/sources.list.d/*.list")):
    try:
        for line in open(path):
            m = re.match(r"^deb\s+(?:\[[^]]*\]\s+)?(\S+)\s+(\S+)", line)
            if m and m.group(2) == suite:
                print(m.group(1)); sys.exit()
    except OSError:
        pass
EOF
)}"
[ -n "$MIRROR" ] || die "no Debian mirror for '$SUITE' in /etc/apt/sources.list*; set PTIR_DEBIAN_MIRROR"

CHROOT="${PTIR_DEBOOTSTRAP_ROOT:-${XDG_CACHE_HOME:-$HOME/.cache}/ptir/debootstrap-$SUITE}"
# What the zip carries, never in the bare root (a root that has them proves nothing).
BUILD_LIBS=(libOpenImageIO.so.2.4 libembree3.so.3 libtbb.so.12 libOpenEXR-3_1.so.30 libImath-3_1.so.29
            libOpenColorIO.so.2.1 libpng16.so.16 libjpeg.so.62 libtiff.so.6)
bare() {
  local lib
  for lib in "${BUILD_LIBS[@]}"; do
    if [ -n "$(find "$CHROOT/usr/lib" "$CHROOT/usr/local" -name "$lib" -print -quit 2>/dev/null)" ]; then
      echo "$lib"; return 1
    fi
  done
}

if [ -f "$CHROOT/.ptir-bare-root" ] && found="$(bare)"; then
  say "reusing the bare $SUITE root $CHROOT"
else
  [ -f "$CHROOT/.ptir-bare-root" ] && say "the cached root has $found: making it again"
  rm -rf "$CHROOT"
  mkdir -p "$(dirname "$CHROOT")"
  say "debootstrap --variant=minbase $SUITE from $MIRROR (a few minutes)"
  debootstrap --variant=minbase "$SUITE" "$CHROOT" "$MIRROR" > "$CHROOT.log" 2>&1 \
    || die "debootstrap failed (log: $CHROOT.log)"
  touch "$CHROOT/.ptir-bare-root"
fi
rm -rf "$CHROOT/opt/ptir" "$CHROOT/work"
found="$(bare)" || die "the root $CHROOT has $found, which the zip should bring"
say "root: $(chroot "$CHROOT" dpkg-query -W -f '${Package}\n' | wc -l) Debian packages, $(du -sh "$CHROOT" | cut -f1)," \
    "glibc $(chroot "$CHROOT" dpkg-query -W -f '${Version}' libc6)," \
    "libstdc++6 $(chroot "$CHROOT" dpkg-query -W -f '${Version}' libstdc++6)"

# Only the zip's CLI and libraries go in (not the add-on).
mkdir -p "$CHROOT/opt/ptir" "$CHROOT/work"
python3 - "$ZIP" "$CHROOT/opt/ptir" <<'EOF'
import os, sys, zipfile
zip_path, dest = sys.argv[1:]
n = 0
with zipfile.ZipFile(zip_path) as z:
    for info in z.infolist():
        parts = info.filename.split("/")
        if len(parts) >= 3 and parts[0] == "ptir_blender" and parts[1] in ("bin", "lib") and not info.is_dir():
            out = os.path.join(dest, *parts[1:])
            os.makedirs(os.path.dirname(out), exist_ok=True)
            with open(out, "wb") as f:
                f.write(z.read(info))
            os.chmod(out, (info.external_attr >> 16) & 0o777 or 0o644)
            n += 1
if not os.path.isfile(os.path.join(dest, "bin", "ptir")):
    sys.exit("the zip has no ptir_blender/bin/ptir")
print("check_package_debootstrap: copied %d files (bin/ptir, lib/) from %s" % (n, os.path.basename(zip_path)))
EOF

# The scene: 25 splats in a wall (an INRIA 3DGS PLY), a floor and a box (meshes), an area light,
# the sample sky (HDR environment).
cp "$ROOT/sample_blends/sky.hdr" "$CHROOT/work/sky.hdr"
python3 - "$CHROOT/work" <<'EOF'
import json, math, os, struct, sys
work = sys.argv[1]
names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"] + ["f_rest_%d" % i for i in range(45)] \
    + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
rows = []
for i in range(5):
    for j in range(5):
        x, z = -0.8 + 0.4 * i, 0.2 + 0.4 * j
        q = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)   # thin axis along y
        rows.append([x, 0.5, z, 0, -1, 0, 1.2, -0.6, -1.2] + [0.0] * 45 + [4.0, math.log(0.25), math.log(0.25),
                                                                            math.log(0.002)] + list(q))
with open(os.path.join(work, "wall.ply"), "wb") as f:
    f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % len(rows)
             + "".join("property float %s\n" % n for n in names) + "end_header\n").encode())
    for r in rows:
        f.write(struct.pack("<%df" % len(names), *r))

def look_at(eye, target):
    f = [t - e for t, e in zip(target, eye)]; n = math.sqrt(sum(c * c for c in f)); f = [c / n for c in f]
    r = [f[1], -f[0], 0.0]; n = math.sqrt(sum(c * c for c in r)); r = [c / n for c in r]
    u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]]
    return [[r[0], u[0], -f[0], eye[0]], [r[1], u[1], -f[1], eye[1]], [r[2], u[2], -f[2], eye[2]], [0, 0, 0, 1]]

box = [[x, y, z] for z in (0, 0.6) for y in (-0.9, -0.3) for x in (0.4, 1.0)]
box_tris = [[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4], [2, 6, 7], [2, 7, 3],
            [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]]
scene = {
    "gaussians": [{"file": "wall.ply"}],
    "meshes": [
        {"name": "floor", "vertices": [[-3, -3, 0], [3, -3, 0], [3, 3, 0], [-3, 3, 0]],
         "triangles": [[0, 1, 2], [0, 2, 3]], "material": {"base_color": [0.6, 0.6, 0.6], "roughness": 0.7}},
        {"name": "box", "vertices": box, "triangles": box_tris,
         "material": {"base_color": [0.2, 0.4, 0.8], "roughness": 0.3}},
    ],
    "lights": [{"type": "area", "shape": "square", "size": 1.0, "power": 80,
                "transform": [[1, 0, 0, 0], [0, 1, 0, -0.5], [0, 0, 1, 2.5], [0, 0, 0, 1]]}],
    "environment": {"type": "latlong", "file": "sky.hdr", "strength": 0.5},
    "cameras": [{"name": "cam", "transform": look_at([2.5, -4.0, 1.8], [0.0, 0.0, 0.6]), "fov_x": 0.8,
                 "width": 96, "height": 64}],
    "integrator": {"spp": 16, "bounces": 2, "seed": 1},
}
json.dump(scene, open(os.path.join(work, "scene.json"), "w"), indent=1)
EOF

# Inside the root, with /proc as on any running Linux (the loader reads /proc/self/exe to expand the
# CLI's RUNPATH $ORIGIN): what the CLI loads (ldd), its version, and the render.
mount -t proc proc "$CHROOT/proc"
trap 'umount "$CHROOT/proc" 2>/dev/null || umount -l "$CHROOT/proc" 2>/dev/null || true' EXIT
say "inside the root: ldd /opt/ptir/bin/ptir, libraries not from /opt/ptir/lib:"
chroot "$CHROOT" /usr/bin/env -i PATH=/usr/bin:/bin ldd /opt/ptir/bin/ptir | grep -v "/opt/ptir/bin/../lib/" | sed 's/^/    /'
if chroot "$CHROOT" /usr/bin/env -i PATH=/usr/bin:/bin ldd /opt/ptir/bin/ptir | grep -q "not found"; then
  die "the CLI misses libraries inside the root (above)"
fi
chroot "$CHROOT" /usr/bin/env -i PATH=/usr/bin:/bin /opt/ptir/bin/ptir --version
chroot "$CHROOT" /usr/bin/env -i PATH=/usr/bin:/bin HOME=/work sh -c \
  'cd /work && /opt/ptir/bin/ptir render scene.json -o render.exr --stats-json stats.json &&
   /opt/ptir/bin/ptir render scene.json -o render.png -q' || die "ptir render failed inside the root"

# The environment read from each image format the engine meets (PNG, JPEG, TIFF: converted on the
# host), and two broken files, which must end in the CLI's own error message (exit 1), not a crash.
for ext in png jpg tif; do
  oiiotool "$CHROOT/work/sky.hdr" -o "$CHROOT/work/sky.$ext" >/dev/null || die "oiiotool cannot write sky.$ext"
done
head -c 3000 "$CHROOT/work/sky.hdr" > "$CHROOT/work/truncated.hdr"
printf 'not an image' > "$CHROOT/work/garbage.png"
cp "$CHROOT/work/garbage.png" "$CHROOT/work/garbage.xyz"   # no reader by name: OpenImageIO tries every one
for env in sky.png sky.jpg sky.tif truncated.hdr garbage.png garbage.xyz; do
  sed "s/\"sky.hdr\"/\"$env\"/" "$CHROOT/work/scene.json" > "$CHROOT/work/scene_$env.json"
  set +e
  msg="$(chroot "$CHROOT" /usr/bin/env -i PATH=/usr/bin:/bin sh -c \
    "cd /work && /opt/ptir/bin/ptir render scene_$env.json -o env_$env.exr -q --spp 2" 2>&1)"
  rc=$?
  set -e
  case "$env" in
    sky.*) [ $rc -eq 0 ] || die "rendering with the environment $env failed (exit $rc): $msg"
           say "environment $env: rendered" ;;
    *) { [ $rc -eq 1 ] && [[ "$msg" == *"ptir: error: "*"$env"* ]]; } \
         || die "a broken $env must give the CLI's error and exit 1, got exit $rc: $msg"
       say "environment $env: exit 1, '$msg'" ;;
  esac
done

# On the host: both images exist, are finite, and show the scene (not black, not flat).
for img in render.exr render.png; do
  [ -s "$CHROOT/work/$img" ] || die "no $img"
done
stats="$(oiiotool --stats "$CHROOT/work/render.exr")"
python3 - "$stats" "$CHROOT/work/stats.json" <<'EOF' || die "the render is not a picture of the scene (stats above)"
import json, re, sys
text, stats_json = sys.argv[1], sys.argv[2]
def values(label):
    m = re.search(r"%s:\s*([-0-9.e+ infa]+)" % label, text)
    return [float(v) for v in m.group(1).split()] if m else None
lo, hi, avg, dev = values("Stats Min"), values("Stats Max"), values("Stats Avg"), values("Stats StdDev")
nan = re.search(r"NanCount:\s*([0-9 ]+)", text)
s = json.load(open(stats_json))
print("check_package_debootstrap: render.exr %s; RGB mean %s, std dev %s, max %s; %s Gaussians, %s triangles"
      % (re.search(r"(\d+\s*x\s*\d+)", text).group(1), avg[:3], dev[:3], hi[:3], s.get("gaussians"),
         s.get("triangles")))
ok = (nan is None or all(int(v) == 0 for v in nan.group(1).split())) and min(avg[:3]) > 0.01 \
    and min(dev[:3]) > 0.01 and s.get("gaussians") == 25 and s.get("triangles") == 14
sys.exit(0 if ok else 1)
EOF
cp "$CHROOT/work/render.png" "$ROOT/dist/debootstrap_render.png" 2>/dev/null || true
say "OK: the zip's CLI rendered inside a bare Debian $SUITE root (dist/debootstrap_render.png)"
