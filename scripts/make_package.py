#!/usr/bin/env python3
"""Builds dist/ptir-<version>-linux-x64.zip: the Blender add-on with the `ptir` CLI and its libraries.

    scripts/make_package.py --cli build-package/bin/ptir [--out dist] [--stage build-package/package-stage]

One zip, two ways to install it:
  * Blender 4.2+: an Extension (Edit > Preferences > Get Extensions > Install from Disk). Blender
    finds `blender_manifest.toml` in the zip's single top folder and installs that folder's
    contents as the extension `ptir_blender`.
  * Blender 3.x: a legacy add-on (Edit > Preferences > Add-ons > Install). Blender extracts the
    zip into its add-ons folder: the top folder `ptir_blender/` is the add-on package (bl_info).

Layout inside the zip:
    ptir_blender/__init__.py ...       the add-on (addon/ptir_blender, without caches)
    ptir_blender/blender_manifest.toml the extension manifest (version: CMake's project VERSION)
    ptir_blender/bin/ptir              the CLI, stripped, RUNPATH $ORIGIN/../lib
    ptir_blender/lib/*.so*             every shared library it loads beyond glibc and GCC's
                                       runtime (libstdc++, libgcc_s), found with ldd, stripped,
                                       RUNPATH $ORIGIN, less what PRUNE removes (OpenCV, which
                                       Debian's OpenImageIO links for functions the engine never
                                       calls); lib/copyright/ has their Debian copyright files
The optional in-process Python module (ptir*.so) is not included: the add-on runs the CLI.

The script checks what it made: ldd of the staged CLI must resolve every library inside lib/
(or to glibc / GCC's runtime) and every symbol (ldd -r), and the staged CLI must run `--version`
with an empty environment. Needs ldd, ldconfig, strip, nm, objdump, c++filt, readelf, patchelf
and dpkg (Debian packages libc-bin, binutils, patchelf, dpkg).
"""

import argparse
import os
import re
import shutil
import stat
import struct
import subprocess
import sys
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON = os.path.join(ROOT, "addon", "ptir_blender")
PACKAGE = "ptir_blender"   # the top folder in the zip, the legacy add-on's module, the extension's id
PLATFORM = "linux-x64"

# Loaded from the machine that runs the CLI, never bundled: glibc's libraries (mixing another
# glibc's pieces with the host's breaks) and GCC's runtime, which every Linux with a C++
# program installed has (the CLI's symbol versions say which release it needs: see symbol_versions()).
BASELINE = re.compile(r"^(linux-vdso\.so|ld-linux-x86-64\.so|libc\.so|libm\.so|libmvec\.so|libpthread\.so|"
                      r"libdl\.so|librt\.so|libresolv\.so|libutil\.so|libanl\.so|libBrokenLocale\.so|"
                      r"libnss_|libthread_db\.so|libstdc\+\+\.so|libgcc_s\.so)")
# Loaded with dlopen (ldd cannot see them) from the folder of the library that loads them.
DLOPENED = ("libtbbmalloc.so.2",)   # TBB's scalable allocator (libtbb looks beside itself)

# Dependencies removed from a bundled library, with the symbols that are then left unresolved.
# Debian's OpenImageIO links OpenCV for ImageBufAlgo::to_OpenCV / from_OpenCV / capture_image only
# (no image format reader uses it; static init does not touch it), which the engine never calls;
# OpenCV brings GDAL and its geodata stack: 92 libraries, 108 MB. The dependency is removed and
# OpenImageIO's references to OpenCV's (unversioned) symbols are made weak, so that the loader binds
# them to 0 (OpenImageIO is linked with BIND_NOW and full RELRO: lazy binding is not an option).
# prune() checks that they are only called (jump slots, no data or address references), and
# check_staged() that nothing else is unresolved.
PRUNE = {
    "libOpenImageIO.so.2.4": {
        "needed": ("libopencv_core.so.406", "libopencv_imgproc.so.406", "libopencv_videoio.so.406"),
        "unresolved": re.compile(r"^(cv::|cv[A-Z])"),   # OpenCV's C++ namespace and its C API
        # The library's functions that reach those symbols: the CLI must not call any of them.
        "callers": re.compile(r"ImageBufAlgo::(to_OpenCV|from_OpenCV|to_IplImage|from_IplImage|capture_image)\b"),
    },
}

MANIFEST = """schema_version = "1.0.0"

id = "{id}"
version = "{version}"
name = "PTIR"
tagline = "Relight captured Gaussian splats with recovered materials"
maintainer = "PTIR contributors"
type = "add-on"
tags = ["Import-Export", "Render"]

blender_version_min = "4.2.0"

license = ["SPDX:GPL-3.0-or-later"]

# The bundled engine (bin/ptir with lib/) is built for x86-64 Linux.
platforms = ["{platform}"]

[permissions]
files = "Import and export splats, render and optimise through job files"
"""


class PackageError(Exception):
    pass


def run(cmd, **kw):
    try:
        return subprocess.run(cmd, check=True, capture_output=True, text=True, **kw).stdout
    except FileNotFoundError as e:
        raise PackageError("'%s' is not installed (scripts/setup_debian.sh installs it)" % cmd[0]) from e
    except subprocess.CalledProcessError as e:
        raise PackageError("%s failed (exit %d): %s" % (" ".join(cmd), e.returncode, (e.stderr or e.stdout).strip()))


def project_version():
    """The VERSION of project(ptir ...) in the top CMakeLists.txt."""
    with open(os.path.join(ROOT, "CMakeLists.txt")) as f:
        m = re.search(r"project\s*\(\s*ptir\s+VERSION\s+([0-9]+\.[0-9]+\.[0-9]+)", f.read())
    if not m:
        raise PackageError("no 'project(ptir VERSION x.y.z ...)' in CMakeLists.txt")
    return m.group(1)


def ldd(path, env=None):
    """{soname: resolved path or None (not found)} of everything `path` loads, transitively."""
    out = run(["ldd", path], env=env)
    deps = {}
    for line in out.splitlines():
        line = line.strip()
        m = re.match(r"^(\S+)\s+=>\s+not found", line)
        if m:
            deps[m.group(1)] = None
            continue
        m = re.match(r"^(\S+)\s+=>\s+(\S+)\s+\(0x", line)
        if m:
            deps[m.group(1)] = m.group(2)
            continue
        m = re.match(r"^(\S+)\s+\(0x", line)   # the vdso and the dynamic loader
        if m:
            deps[os.path.basename(m.group(1))] = m.group(1)
    return deps


def find_library(soname):
    """Where the dynamic loader's cache says `soname` is."""
    for line in run(["ldconfig", "-p"]).splitlines():
        m = re.match(r"^\s*(\S+)\s+\(([^)]*)\)\s+=>\s+(\S+)$", line)
        if m and m.group(1) == soname and "x86-64" in m.group(2):
            return m.group(3)
    return None


def collect_libraries(cli):
    """{soname: path} of the libraries to bundle for `cli` (ldd's list plus DLOPENED, minus BASELINE)."""
    deps = ldd(cli)
    missing = sorted(n for n, p in deps.items() if p is None)
    if missing:
        raise PackageError("%s cannot find %s on this machine: build it where its libraries are installed"
                           % (cli, ", ".join(missing)))
    wanted = {n: p for n, p in deps.items() if not BASELINE.match(n)}
    for name in DLOPENED:
        path = find_library(name)
        if path and name not in wanted:
            wanted[name] = path
            wanted.update({n: p for n, p in ldd(path).items() if p and not BASELINE.match(n)})
    return wanted


def weaken_undefined(path, pattern):
    """Makes the undefined dynamic symbols of an x86-64 ELF whose demangled names match `pattern`
    weak: the loader then binds them to 0 instead of refusing to load. Returns their (mangled) names."""
    with open(path, "r+b") as f:
        data = bytearray(f.read())
        if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
            raise PackageError("%s: not a 64-bit little-endian ELF file" % path)
        shoff, = struct.unpack_from("<Q", data, 0x28)
        shentsize, shnum = struct.unpack_from("<HH", data, 0x3A)
        sections = [struct.unpack_from("<IIQQQQIIQQ", data, shoff + i * shentsize) for i in range(shnum)]
        dynsym = [sh for sh in sections if sh[1] == 11]   # SHT_DYNSYM
        if len(dynsym) != 1:
            raise PackageError("%s: expected one .dynsym section, found %d" % (path, len(dynsym)))
        _, _, _, _, sym_off, sym_size, link, _, _, entsize = dynsym[0]
        str_off = sections[link][4]
        undefined = []
        for entry in range(sym_off + entsize, sym_off + sym_size, entsize):   # entry 0 is the null symbol
            st_name, st_info, _, st_shndx = struct.unpack_from("<IBBH", data, entry)
            if st_shndx == 0 and st_info >> 4 == 1:   # SHN_UNDEF, STB_GLOBAL
                end = data.index(b"\0", str_off + st_name)
                undefined.append((entry, st_info, data[str_off + st_name:end].decode()))
        demangled = run(["c++filt"], input="\n".join(n for _, _, n in undefined)).split("\n")
        weakened = []
        for (entry, st_info, name), plain in zip(undefined, demangled):
            if pattern.match(plain):
                data[entry + 4] = (2 << 4) | (st_info & 0xF)   # STB_WEAK, same type
                weakened.append(name)
        f.seek(0)
        f.write(data)
    return weakened


def prune(exe, lib_dir):
    """Applies PRUNE to the staged libraries, then deletes those the CLI no longer loads."""
    for name, rule in PRUNE.items():
        path = os.path.join(lib_dir, name)
        if not os.path.isfile(path):
            continue
        args = ["patchelf"]
        for dep in rule["needed"]:
            args += ["--remove-needed", dep]
        run(args + [path])
        weakened = set(weaken_undefined(path, rule["unresolved"]))
        if not weakened:
            raise PackageError("%s: no symbol matches %s: PRUNE is out of date" % (name, rule["unresolved"].pattern))
        # A weak symbol bound to 0 is harmless only where it is called (through a jump slot) by code
        # that never runs; a data or address reference would be read as 0 by code that may run.
        for line in run(["readelf", "-rW", path]).splitlines():
            fields = line.split()
            if len(fields) >= 5 and fields[4].split("@")[0] in weakened and fields[2] != "R_X86_64_JUMP_SLOT":
                raise PackageError("%s refers to %s by %s, not a call: it cannot be dropped"
                                   % (name, fields[4], fields[2]))
    keep = set(ldd(exe, env={"PATH": "/usr/bin:/bin"})) | set(DLOPENED)
    for name in DLOPENED:
        if os.path.isfile(os.path.join(lib_dir, name)):
            keep |= set(ldd(os.path.join(lib_dir, name), env={"PATH": "/usr/bin:/bin"}))
    for name in os.listdir(lib_dir):
        if os.path.isfile(os.path.join(lib_dir, name)) and name not in keep:
            os.remove(os.path.join(lib_dir, name))


def copyright_files(paths):
    """{debian package: its /usr/share/doc/<pkg>/copyright} for the packages that own `paths`."""
    real = sorted({os.path.realpath(p) for p in paths})
    out = subprocess.run(["dpkg", "-S"] + real, capture_output=True, text=True).stdout
    packages = {line.split(":", 1)[0] for line in out.splitlines() if ":" in line}
    return {p: "/usr/share/doc/%s/copyright" % p for p in sorted(packages)
            if os.path.isfile("/usr/share/doc/%s/copyright" % p)}


def copy_addon(dest):
    def ignore(folder, names):
        # Never the in-process module or a CLI some local install put in the source tree.
        skip = {n for n in names if n == "__pycache__" or n.endswith((".pyc", ".so")) or n.startswith(".")}
        if os.path.abspath(folder) == ADDON:
            skip |= {n for n in names if n in ("bin", "lib", "blender_manifest.toml")}
        return skip
    shutil.copytree(ADDON, dest, ignore=ignore)


def stage(cli, stage_dir, version):
    """Fills stage_dir/ptir_blender; returns {soname: size in bytes} of the bundled libraries."""
    top = os.path.join(stage_dir, PACKAGE)
    if os.path.exists(stage_dir):
        shutil.rmtree(stage_dir)
    copy_addon(top)
    with open(os.path.join(top, "blender_manifest.toml"), "w") as f:
        f.write(MANIFEST.format(id=PACKAGE, version=version, platform=PLATFORM))

    bin_dir, lib_dir = os.path.join(top, "bin"), os.path.join(top, "lib")
    os.makedirs(bin_dir)
    os.makedirs(lib_dir)
    exe = os.path.join(bin_dir, "ptir")
    shutil.copyfile(cli, exe)
    os.chmod(exe, 0o755)
    run(["strip", exe])
    run(["patchelf", "--set-rpath", "$ORIGIN/../lib", exe])

    libs = collect_libraries(cli)
    for name, path in sorted(libs.items()):
        dest = os.path.join(lib_dir, name)
        shutil.copyfile(os.path.realpath(path), dest)   # under its soname: what the loader looks for
        os.chmod(dest, 0o755)
        run(["strip", "--strip-unneeded", dest])
        run(["patchelf", "--set-rpath", "$ORIGIN", dest])
    prune(exe, lib_dir)
    sizes = {name: os.path.getsize(os.path.join(lib_dir, name)) for name in os.listdir(lib_dir)}

    notices = os.path.join(lib_dir, "copyright")
    os.makedirs(notices)
    for package, path in copyright_files([p for n, p in libs.items() if n in sizes]).items():
        shutil.copyfile(path, os.path.join(notices, package))
    return sizes


def check_staged(top):
    """The staged CLI loads only bundled libraries (and the baseline) and runs with an empty environment."""
    exe = os.path.join(top, "bin", "ptir")
    lib_dir = os.path.realpath(os.path.join(top, "lib"))
    env = {"PATH": "/usr/bin:/bin"}
    for name, path in ldd(exe, env=env).items():
        if BASELINE.match(name):
            continue
        if path is None or os.path.dirname(os.path.realpath(path)) != lib_dir:
            raise PackageError("the staged CLI loads %s from %s, not from its lib/" % (name, path or "nowhere"))
    # Every relocation resolves (`ldd -r`: data and functions; PRUNE's weakened symbols do not count).
    out = subprocess.run(["ldd", "-r", exe], capture_output=True, text=True, env=env)
    missing = sorted(set(re.findall(r"undefined symbol: (\S+)", out.stdout + out.stderr)))
    if missing:
        raise PackageError("the staged CLI has unresolved symbols: %s" % ", ".join(missing[:10]))
    out = run([exe, "--version"], env={})
    if not out.strip():
        raise PackageError("the staged CLI printed nothing for --version")
    return out.strip()


def symbol_versions(top):
    """The newest GLIBC_ and GLIBCXX_ symbol versions the staged files need."""
    newest = {}
    for folder in ("bin", "lib"):
        d = os.path.join(top, folder)
        for name in os.listdir(d):
            path = os.path.join(d, name)
            if not os.path.isfile(path):
                continue
            for m in re.finditer(r"\b(GLIBC|GLIBCXX|CXXABI)_([0-9.]+)\b", run(["objdump", "-T", path])):
                key, ver = m.group(1), tuple(int(x) for x in m.group(2).split("."))
                newest[key] = max(newest.get(key, ver), ver)
    return {k: ".".join(map(str, v)) for k, v in newest.items()}


def write_zip(stage_dir, zip_path):
    """Deterministic order; Unix modes recorded (unzip keeps them; Blender's installer does not)."""
    tmp = zip_path + ".tmp"
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=6) as z:
        for folder, dirs, files in os.walk(stage_dir):
            dirs.sort()
            for name in sorted(files):
                path = os.path.join(folder, name)
                arc = os.path.relpath(path, stage_dir).replace(os.sep, "/")
                info = zipfile.ZipInfo(arc, date_time=(2020, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                mode = 0o755 if os.stat(path).st_mode & stat.S_IXUSR else 0o644
                info.external_attr = (stat.S_IFREG | mode) << 16
                with open(path, "rb") as f:
                    z.writestr(info, f.read(), compresslevel=6)
    os.replace(tmp, zip_path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cli", required=True, help="the built ptir executable (build without MPI)")
    ap.add_argument("--out", default=os.path.join(ROOT, "dist"), help="output folder (default: dist)")
    ap.add_argument("--stage", default=None, help="staging folder (default: <cli's build>/package-stage)")
    args = ap.parse_args(argv)

    cli = os.path.abspath(args.cli)
    if not (os.path.isfile(cli) and os.access(cli, os.X_OK)):
        raise PackageError("no executable CLI at %s (build the ptir_cli target first)" % cli)
    called = run(["c++filt"], input=run(["nm", "-D", "--undefined-only", cli])).splitlines()
    for name, rule in PRUNE.items():
        bad = [c.split()[-1] for c in called if rule["callers"].search(c)]
        if bad:
            raise PackageError("%s calls %s, which needs what PRUNE removes from %s" % (cli, ", ".join(bad), name))
    if "libmpi" in " ".join(ldd(cli)):
        raise PackageError("%s is linked with MPI: package a build configured with -DPTIR_WITH_MPI=OFF" % cli)
    version = project_version()
    stage_dir = os.path.abspath(args.stage or os.path.join(os.path.dirname(os.path.dirname(cli)), "package-stage"))

    sizes = stage(cli, stage_dir, version)
    top = os.path.join(stage_dir, PACKAGE)
    cli_version = check_staged(top)

    os.makedirs(args.out, exist_ok=True)
    zip_path = os.path.join(os.path.abspath(args.out), "ptir-%s-%s.zip" % (version, PLATFORM))
    write_zip(stage_dir, zip_path)

    unpacked = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(stage_dir) for f in fs)
    needs = symbol_versions(top)
    print("package: %s" % zip_path)
    print("package: %.1f MB zipped, %.1f MB unpacked; CLI %.1f MB + %d libraries %.1f MB"
          % (os.path.getsize(zip_path) / 1e6, unpacked / 1e6, os.path.getsize(os.path.join(top, "bin", "ptir")) / 1e6,
             len(sizes), sum(sizes.values()) / 1e6))
    print("package: the CLI says '%s'; it needs glibc >= %s and libstdc++ >= GLIBCXX_%s on the host"
          % (cli_version, needs.get("GLIBC", "?"), needs.get("GLIBCXX", "?")))
    if os.environ.get("PTIR_PACKAGE_VERBOSE"):
        for name, size in sorted(sizes.items(), key=lambda kv: -kv[1]):
            print("  %8.2f MB  %s" % (size / 1e6, name))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except PackageError as e:
        print("make_package: error: %s" % e, file=sys.stderr)
        sys.exit(1)
