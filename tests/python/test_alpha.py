"""Associated alpha in the files `ptir render` writes (docs/alpha.md).

A splat sphere (400 flat Gaussians, soft silhouette), a sun, and a constant environment K seen behind
it. The EXR's RGBA is associated (RGB premultiplied by A, as OpenEXR specifies and Cycles writes), so
  transparent film:  RGB + K (1 - A)  =  the opaque render, in which the renderer saw K behind the splat
(the same samples: equal to float rounding). That reference is the path tracer's own picture of the
background, not an alpha formula; a file that held straight colour (RGB / A), or kept the environment
in RGB with A = coverage (what F12 handed Blender before), misses it by far more on the silhouette.
OpenImageIO reads the files as associated (no "oiio:UnassociatedAlpha" in the header); the PNG holds
the straight colour, as PNG specifies.
"""

import json
import math
import shutil
import subprocess

import numpy as np
import pytest

from ptir_testing import fibonacci_sphere, quat_z_to, run_checked, write_splat_ply, write_transforms

K = (0.25, 0.35, 0.3)
SIZE = 48


def splat_scene(folder, environment=True):
    """The splat sphere 4 units in front of the camera, lit by a sun (and K from everywhere)."""
    p = fibonacci_sphere(400)
    spacing = math.sqrt(4 * math.pi / 400)
    write_splat_ply(folder / "g.ply", p + [0.0, 0.0, -4.0], (0.7 * spacing, 0.7 * spacing, 1e-3 * spacing),
                    quat=quat_z_to(p), colour=(0.8, 0.45, 0.2))
    cams = write_transforms(folder / "transforms.json", [np.eye(4)], fov_x=math.radians(40.0), size=(SIZE, SIZE))
    doc = {"gaussians": [{"file": "g.ply"}],
           "lights": [{"type": "sun", "direction": [0.3, 0.5, 1.0], "strength": 3.0}],
           "cameras": [{"transforms": cams.name, "width": SIZE, "height": SIZE}],
           "integrator": {"spp": 16, "bounces": 1, "seed": 3}}
    if environment:
        doc["environment"] = {"type": "color", "color": list(K), "strength": 1.0}
    path = folder / ("scene.json" if environment else "scene_dark.json")
    path.write_text(json.dumps(doc))
    return path


def render(cli, scene, out, *extra):
    """`ptir render` of a scene file (or, scene None, the flag form in extra) to out."""
    run_checked([cli, "render", *([scene] if scene else []), "-o", out, "-q", *extra], timeout=300)
    return out


def over(rgba, colour):
    """Associated RGBA over a constant colour."""
    return rgba[..., :3] + np.asarray(colour, np.float32) * (1.0 - rgba[..., 3:4])


def oiio_attributes(path):
    iinfo = shutil.which("iinfo")
    if iinfo is None:
        pytest.skip("OpenImageIO's iinfo is not installed")
    return subprocess.run([iinfo, "-v", str(path)], capture_output=True, text=True, timeout=60).stdout


# Every Gaussian hit is an interaction: no camera ray is absorbed by the chi_pass rule (a ray that
# meets too little opacity for an interaction is absorbed with probability 1 - T: black in the
# opaque film, no coverage in the transparent one; docs/alpha.md measures that difference).
EVERY_HIT = ("--tau-g", "0", "--no-geometric-criterion")


def test_transparent_exr_composites_like_the_renderers_own_background(ptir, cli, tmp_path):
    scene = splat_scene(tmp_path)
    x = ptir.read_image(str(render(cli, scene, tmp_path / "x.exr", "--transparent", *EVERY_HIT)))
    ref = ptir.read_image(str(render(cli, scene, tmp_path / "ref.exr", *EVERY_HIT)))
    a = x[..., 3]
    edge = (a > 0.02) & (a < 0.98)
    assert edge.sum() >= 40, "test design: a soft silhouette"
    assert np.all(ref[..., 3] == 1.0), "an opaque film that sees the environment is opaque"
    assert "UnassociatedAlpha" not in oiio_attributes(tmp_path / "x.exr")
    err = np.abs(over(x, K) - ref[..., :3])
    print("transparent EXR over K vs the opaque render: max %.2e over %d silhouette pixels" % (err.max(), edge.sum()))
    assert err.max() <= 1e-4
    # What the bound catches: straight colour, or the environment kept in RGB with A = coverage.
    straight = x.copy()
    straight[..., :3] = np.where(a[..., None] > 0, x[..., :3] / np.maximum(a[..., None], 1e-6), 0.0)
    env_kept = ref.copy()
    env_kept[..., 3] = a
    for wrong in (straight, env_kept):
        assert np.median(np.abs(over(wrong, K) - ref[..., :3]).sum(-1)[edge]) > 0.02


def test_without_environment_the_opaque_film_is_the_transparent_one(ptir, cli, tmp_path):
    """Nothing is seen behind the splat: the plain render keeps A = coverage, associated as it stands."""
    scene = splat_scene(tmp_path, environment=False)
    y = ptir.read_image(str(render(cli, scene, tmp_path / "y.exr")))
    t = ptir.read_image(str(render(cli, scene, tmp_path / "t.exr", "--transparent")))
    assert ((y[..., 3] > 0.02) & (y[..., 3] < 0.98)).sum() >= 40
    assert np.array_equal(y, t)


def test_preview_exr_is_associated_and_png_straight(ptir, cli, tmp_path):
    """The flag form's default output (the preview AOV: the splats' SH colours composited as a 3DGS
    rasteriser does): every covered pixel's RGB / A is the splats' one colour, edges included; its
    PNG holds that straight colour, the EXR's colour over its alpha."""
    splat_scene(tmp_path)
    args = ["--gaussians", tmp_path / "g.ply", "--cameras", tmp_path / "transforms.json"]
    p = ptir.read_image(str(render(cli, None, tmp_path / "p.exr", *args)))
    assert "UnassociatedAlpha" not in oiio_attributes(tmp_path / "p.exr")
    a = p[..., 3]
    edge = (a > 0.05) & (a < 0.95)
    assert edge.sum() >= 40
    colour = np.array([0.8, 0.45, 0.2], np.float32)
    linear = np.where(colour <= 0.04045, colour / 12.92, ((colour + 0.055) / 1.055) ** 2.4)
    straight = p[..., :3][a > 0.05] / a[a > 0.05][:, None]
    assert np.abs(straight - linear).max() <= 2e-3
    from PIL import Image
    render(cli, None, tmp_path / "p.png", *args)
    png = np.asarray(Image.open(tmp_path / "p.png").convert("RGBA"), np.float32) / 255.0
    assert np.abs(png[..., 3] - a).max() <= 1.0 / 255.0 + 1e-6
    shown = png[..., :3][a > 0.05]
    assert np.abs(shown - colour).max() <= 1.5 / 255.0  # straight sRGB colour, not divided twice


def test_transparent_png_is_straight(ptir, cli, tmp_path):
    scene = splat_scene(tmp_path)
    x = ptir.read_image(str(render(cli, scene, tmp_path / "x.exr", "--transparent")))
    from PIL import Image
    render(cli, scene, tmp_path / "x.png", "--transparent")
    png = np.asarray(Image.open(tmp_path / "x.png").convert("RGBA"), np.float32) / 255.0
    a = x[..., 3]
    assert np.abs(png[..., 3] - a).max() <= 1.0 / 255.0 + 1e-6
    covered = a > 0.1
    s = np.clip(x[..., :3][covered] / a[covered][:, None], 0.0, 1.0)
    expect = np.where(s <= 0.0031308, 12.92 * s, 1.055 * s ** (1 / 2.4) - 0.055)
    assert np.abs(png[..., :3][covered] - expect).max() <= 1.0 / 255.0 + 1e-6


def test_png_reads_as_associated_and_writes_back_straight(ptir, tmp_path):
    """A PNG's straight colour is decoded, then multiplied by its alpha (the in-memory convention);
    writing that image back gives the PNG's bytes (OpenImageIO divides nothing a second time)."""
    from PIL import Image
    straight = np.array([[[188, 128, 64, 128], [188, 128, 64, 255], [188, 128, 64, 32]]], np.uint8)
    Image.fromarray(straight, "RGBA").save(tmp_path / "s.png")
    img = ptir.read_image(str(tmp_path / "s.png"))
    c = straight[..., :3] / 255.0
    a = straight[..., 3:] / 255.0
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    assert np.abs(img[..., :3] - a * linear).max() <= 1e-5
    assert np.abs(img[..., 3:] - a).max() <= 1e-6
    ptir.write_image(str(tmp_path / "back.png"), img)
    assert np.array_equal(np.asarray(Image.open(tmp_path / "back.png")), straight)
