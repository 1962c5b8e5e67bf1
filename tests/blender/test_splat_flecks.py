"""A splat twin without normals against Cycles' mesh render: interior PSNR and dark flecks (issue #36).

tests/blender/splat_fleck_scene.py builds a smooth torus tilted toward the camera (its inner ring
seen) under a subdivided Suzanne (eye sockets, chin: concave parts), renders it with Cycles 3.4 at
SPP samples (Box 1 px, no denoising, adaptive sampling or clamping, 2 bounces), and writes the
objects as flat Gaussians (one per polygon, 12480) with their true materials and zero normals, as
a trainer's PLY comes: the engine must find which side of each splat faces the light.

The twin is rendered at SPP through the paths an artist uses: the add-on (the PLY imported with
File > Import, the meshes hidden, F12 with the PTIR engine: `ptir serve` with the scene's one
camera), the native module (the same engine in-process) and `ptir render scene.json` (the CLI),
and compared with Cycles inside the mesh's silhouette (coverage 1 in a 5 x 5 neighbourhood):
PSNR, and flecks = the fraction of those pixels darker than 0.8x Cycles (mean of RGB). A third
check orients the stored normals from 16 other cameras (flipping 1/5 of them) and asks for the
same image bit for bit: the normal rule does not depend on which cameras a command has.

Measured (Blender 3.4.1, 128 x 128, 256 spp, 3862 interior pixels; 2 shared cores):
                                                   interior   flecks (< 0.8x Cycles)
  before: stored signs voted by the cameras the path has, away from the centroid where none votes
    add-on F12 (its serve session's scene has no camera)  19.76 dB  21.08 %
    module, `ptir render scene.json` (the scene's camera) 30.45 dB   5.41 %
    the PLY oriented by a 16-view ring (a dataset's)      36.32 dB   0.83 %
  after: two-sided splats (normals summed on one side seen from the ray; the surface left skipped
    relative to the vertex's side), every path and orientation alike:
    the interaction at the hits' w-weighted mean depth (the paper's D)  35.53 dB   0.39 %
    the interaction at the median depth (where O first reaches 1/2)     36.30 dB   0.05 %
  the engine's own render of the mesh (smooth normals)                  42.83 dB   0.00 %
The flecks under the mean depth were systematic (the same pixels across seeds), on the upper rim of
the right eye and the torus' inner edge: where the eyeball's splats let a few per cent through, the
socket's splats behind it dragged the mean depth 0.03 below the eyeball's surface, and the vertex's
shadow rays started inside the eyeball (the eyes as meshes, or the head as meshes: 0.13 % / 0.03 %).
Bounds: interior >= 33 dB (issue #36; before: 19.76-30.45), flecks < 0.3 % (issue #36; measured
0.05 % with seeds 3 and 7; the mean depth: 0.39-0.49 %, before the two-sided rule 5.41-21.08 %), and
the image bit-identical under re-orientation (before: it changed).
Runtime: about 1-2 minutes (Cycles 15 s, four 256-spp renders of the twin at 128 px).
"""

import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

import addon_common as ac

SCRIPT = "splat_fleck_scene.py"
BLENDER = shutil.which(os.environ.get("BLENDER", "blender"))
RES, SPP = 128, 256

pytestmark = pytest.mark.skipif(BLENDER is None, reason="blender not installed")


@pytest.fixture(scope="module")
def fleck_scene():
    with tempfile.TemporaryDirectory(prefix="ptir_splat_flecks_") as tmp:
        info = ac.blender_result(SCRIPT, "PTIR_SPLAT_FLECK_JSON", "--out-dir", tmp, "--res", RES, "--samples", SPP,
                                 "--addon-f12", timeout=1500)
        info["dir"] = Path(tmp)
        yield info


def interior(coverage, r=2):
    """Pixels whose (2r+1)^2 neighbourhood is fully covered."""
    m = coverage > 0.999
    inner = m.copy()
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            inner &= np.roll(np.roll(m, dy, 0), dx, 1)
    return inner


def score(img, cycles, inner):
    """(interior PSNR in dB, fraction of interior pixels darker than 0.8x Cycles)."""
    mse = float(((img - cycles) ** 2)[inner].mean())
    ratio = img.mean(-1) / np.maximum(cycles.mean(-1), 1e-6)
    return 10.0 * np.log10(1.0 / mse), float(((ratio < 0.8) & inner).sum() / inner.sum())


def look_at(eye):
    eye = np.asarray(eye, np.float64)
    back = eye / np.linalg.norm(eye)
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(back, right), back, eye
    return m


def test_splat_twin_without_normals_matches_cycles(ptir, fleck_scene):
    d = fleck_scene["dir"]
    export = Path(fleck_scene["scene"]).parent
    doc = json.loads((export / "scene.json").read_text())
    sdoc = dict(doc, meshes=[], gaussians=[{"file": str(d / "gaussians.ply")}])
    (export / "splats.json").write_text(json.dumps(sdoc))
    cycles = np.load(d / "cycles_seed1.npy")
    mesh = ptir.scene_from_dict(doc, str(export))
    inner = interior(mesh.render_aov(mesh.cameras[0], "opacity", spp=1)[..., -1])
    assert inner.sum() > 3000, "test design: the silhouette must hold enough pixels"

    # The add-on's path: the module (as `ptir serve`) with the scene's one camera.
    splat = ptir.scene_from_dict(sdoc, str(export))
    module_img = splat.render(spp=SPP, seed=7)[..., :3]
    # The CLI's path.
    out = d / "cli.exr"
    subprocess.run([str(ac.CLI), "render", str(export / "splats.json"), "-o", str(out), "--spp", str(SPP), "-q"],
                   check=True, timeout=900)
    cli_img = np.asarray(ptir.read_image(str(out)), np.float32)[..., :3]
    # Normals oriented from 16 other views: the same image, bit for bit.
    cams = []
    for j in range(16):
        el, az = np.radians(15.0 if j % 2 == 0 else 45.0), np.radians(22.5 * j)
        eye = 4.0 * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        cams.append(ptir.Camera(look_at(eye).reshape(-1).astype(np.float32), 0.69, RES, RES))
    flipped, _ = splat.orient_normals(cams)
    assert flipped > 1000, "test design: the other views must flip many stored signs"
    ring_img = splat.render(spp=SPP, seed=7)[..., :3]

    f12_img = np.load(d / "addon_f12.npy")  # the add-on: File > Import of the PLY, F12 with the PTIR engine
    results = {name: score(img, cycles, inner) for name, img in
               (("module/serve", module_img), ("cli", cli_img), ("other orientation", ring_img),
                ("add-on F12", f12_img))}
    for name, (db, flecks) in results.items():
        print("\n%-18s interior %.2f dB, flecks (< 0.8x Cycles) %.2f %% of %d px" % (name, db, 100 * flecks, inner.sum()))
    assert np.array_equal(module_img, ring_img), "the image depends on the stored signs of the normals"
    for name, (db, flecks) in results.items():
        assert db >= 33.0, "%s: interior %.2f dB against Cycles" % (name, db)
        assert flecks < 0.003, "%s: %.2f %% of the interior darker than 0.8x Cycles" % (name, 100 * flecks)
