"""The add-on's scene export (Blender -> scene file) and its pure-Python io helpers.

The io tests need no Blender. The export tests run tests/blender/scene_export_check.py
in each of the three Blenders (3.4, bpy 4.5, bpy 5.0: blenders.py) and check the file against
what Blender itself reports (evaluated mesh bounds, matrices, where the camera projects points)
and the material model of that Blender (principled v1 fields and socket names on 3.x, v2 on 4.0+,
a warning naming the material and the socket for every layer the engine does not render), then
load and render the exported scene with the native module (4.5 / 5.0: once the engine has
principled-v2, blenders.engine_has_v2()).
"""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import blenders

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "addon"))

from ptir_blender.io import mesh_ply, scene_file, surface_splats  # noqa: E402


# ---------------------------------------------------------------- io helpers (no Blender)

def test_horizontal_fov_follows_blender_sensor_fit():
    # 36 mm sensor, 50 mm lens: 2 atan(18/50) along the fitted dimension.
    base = 2.0 * math.atan(18.0 / 50.0)
    assert scene_file.horizontal_fov(50, 36, 24, "AUTO", 1920, 1080) == pytest.approx(base)
    assert scene_file.horizontal_fov(50, 36, 24, "HORIZONTAL", 1080, 1920) == pytest.approx(base)
    # AUTO, portrait: the sensor width spans the (larger) height.
    portrait = 2.0 * math.atan(18.0 / 50.0 * 1080 / 1920)
    assert scene_file.horizontal_fov(50, 36, 24, "AUTO", 1080, 1920) == pytest.approx(portrait)
    # VERTICAL: the sensor height spans the height.
    vert = 2.0 * math.atan(12.0 / 50.0 * 1920 / 1080)
    assert scene_file.horizontal_fov(50, 36, 24, "VERTICAL", 1920, 1080) == pytest.approx(vert)
    with pytest.raises(scene_file.SceneFileError):
        scene_file.horizontal_fov(0, 36, 24, "AUTO", 10, 10)


def test_render_size_and_matrix_rows():
    assert scene_file.render_size(1920, 1080, 50) == (960, 540)
    assert scene_file.render_size(301, 201, 50) == (150, 100)
    assert scene_file.matrix_rows(np.eye(4)) == [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]]
    with pytest.raises(scene_file.SceneFileError):
        scene_file.matrix_rows([[float("nan")] * 4] * 4)


def test_write_scene_checks_keys_and_is_valid_json(tmp_path):
    doc = {"meshes": [{"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "triangles": [[0, 1, 2]]}],
           "integrator": {"spp": 2}}
    p = scene_file.write_scene(str(tmp_path / "s.json"), doc)
    back = json.loads(Path(p).read_text())
    assert back["version"] == 1 and back["meshes"] == doc["meshes"]
    with pytest.raises(scene_file.SceneFileError, match="unknown scene keys"):
        scene_file.write_scene(str(tmp_path / "t.json"), {"mesh": []})
    with pytest.raises(scene_file.SceneFileError, match="unknown integrator keys"):
        scene_file.write_scene(str(tmp_path / "t.json"), {"integrator": {"samples": 3}})


def test_mesh_ply_round_trip_and_engine_load(tmp_path, ptir):
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.5]], np.float32)
    t = np.array([[0, 1, 2], [0, 2, 3]])
    p = mesh_ply.write_mesh_ply(str(tmp_path / "m.ply"), v, t, comment="test")
    v2, t2 = mesh_ply.read_mesh_ply(p)
    assert np.array_equal(v2, v) and np.array_equal(t2, t)
    m = ptir.load_mesh(p)
    assert m.triangle_count == 2 and np.allclose(m.vertices, v)
    with pytest.raises(mesh_ply.MeshPlyError, match="out of range"):
        mesh_ply.write_mesh_ply(str(tmp_path / "bad.ply"), v, [[0, 1, 4]])


def test_surface_splats_of_a_square(tmp_path, ptir):
    # One quad in the plane z = 1, counter-clockwise seen from +z.
    loops = np.array([[0, 0, 1], [2, 0, 1], [2, 1, 1], [0, 1, 1]], float)
    g = surface_splats.polygons_to_gaussians(loops, np.array([0]), np.array([4]))
    assert np.allclose(g["position"], [[1.0, 0.5, 1.0]])
    assert np.allclose(g["normal"], [[0, 0, 1]])
    assert np.allclose(g["scale"], [[0.6 * 2.0, 0.6 * 1.0, 1e-3 * 1.2]])
    ply = surface_splats.write_gaussians_ply(str(tmp_path / "g.ply"), g, opacity=0.9, albedo=(0.25, 0.5, 0.75),
                                             roughness=0.4, metallic=0.2)
    f = ptir.load_gaussians(ply)
    assert len(f) == 1 and f.normals_from_file
    assert np.allclose(f.normal, [[0, 0, 1]], atol=1e-6)
    assert np.allclose(f.albedo, [[0.25, 0.5, 0.75]], atol=1e-6)
    assert f.roughness[0] == pytest.approx(0.4) and f.metallic[0] == pytest.approx(0.2)
    assert f.opacity[0] == pytest.approx(0.9, abs=1e-6)
    assert np.allclose(f.scale, g["scale"], rtol=1e-5)
    # The Gaussian's local z axis (rotation) is the polygon normal.
    w, x, y, z = f.rotation[0]
    local_z = [2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)]
    assert np.allclose(local_z, [0, 0, 1], atol=1e-6)


def test_triangles_to_gaussians_quaternions_are_proper_rotations():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(60, 3))
    t = rng.integers(0, 60, size=(100, 3))
    t = t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])]
    g = surface_splats.triangles_to_gaussians(v, t)
    q = g["rotation"]
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0) and np.all(q[:, 0] >= 0)
    w, x, y, z = q.T
    local_z = np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], 1)
    assert np.allclose(local_z, g["normal"], atol=1e-9)
    assert np.allclose(g["position"], v[t].mean(axis=1))


# ---------------------------------------------------------------- export in Blender

@pytest.fixture(scope="module", params=blenders.params())
def exported(request, tmp_path_factory, ptir):
    version = request.param
    out = tmp_path_factory.mktemp("export_" + version.replace(".", ""))
    # A small Gaussian file for the custom-property holder.
    g = surface_splats.triangles_to_gaussians(np.array([[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0]], float),
                                              np.array([[0, 1, 2]]))
    ply = surface_splats.write_gaussians_ply(str(out / "holder.ply"), g, albedo=(0.5, 0.5, 0.5), roughness=0.5,
                                             metallic=0.0)
    cmd = blenders.command(version, REPO / "tests" / "blender" / "scene_export_check.py", [out, ply])
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    line = next(l for l in r.stdout.splitlines() if l.startswith("PTIR_EXPORT_JSON: "))
    info = json.loads(line.split(": ", 1)[1])
    info["doc"] = json.loads(Path(info["scene"]).read_text())
    info["dir"] = out
    info["version"] = version
    return info


def test_export_meshes_and_materials(exported):
    doc, out = exported["doc"], exported["dir"]
    meshes = {m["name"]: m for m in doc["meshes"]}
    # "Hidden" (hide_render) is skipped
    assert sorted(meshes) == ["Cube_0", "Cube_1", "Lamp plane", "Layered"]
    matte, shiny, glow = meshes["Cube_0"]["material"], meshes["Cube_1"]["material"], meshes["Lamp plane"]["material"]
    # Diffuse BSDF -> the engine's Oren-Nayar with the node's roughness (default 0: Lambert).
    assert matte["base_color"] == pytest.approx([0.2, 0.4, 0.6]) and matte["roughness"] == 0.0
    # A new Principled BSDF is GGX in 3.x, Multiscatter GGX from 4.0 on: the shader follows the node.
    assert exported["distributions"]["shiny"] == ("GGX" if exported["version"] == "3.4" else "MULTI_GGX")
    assert matte["shader"] == "diffuse"
    assert shiny["shader"] == ("principled" if exported["version"] == "3.4" else "principled-multiscatter")
    assert matte["metallic"] == 0.0 and matte["emission"] == [0, 0, 0]
    assert shiny["base_color"] == pytest.approx([0.9, 0.8, 0.1]) and shiny["roughness"] == pytest.approx(0.35)
    assert shiny["metallic"] == 1.0 and shiny["emission"] == pytest.approx([2.0, 1.0, 0.5])
    assert glow["emission"] == pytest.approx([2.0, 4.0, 1.0]) and glow["base_color"] == [0, 0, 0]
    # Geometry: evaluated (Simple subdivision: each face -> 4 quads -> 8 triangles), world space.
    v0, t0 = mesh_ply.read_mesh_ply(str(out / meshes["Cube_0"]["file"]))
    v1, t1 = mesh_ply.read_mesh_ply(str(out / meshes["Cube_1"]["file"]))
    assert [len(t0), len(t1)] == exported["cube_tris"] == [40, 8]
    allv = np.concatenate([v0, v1])
    lo, hi = exported["cube_bbox"]
    assert np.allclose(allv.min(0), lo, atol=1e-5) and np.allclose(allv.max(0), hi, atol=1e-5)


def test_export_records_the_principled_model_of_its_blender(exported):
    """3.x: principled v1 (specular, specular_tint); 4.0+: v2 (ior, specular_ior_level, specular_tint_color,
    diffuse_roughness), read by this Blender's socket names; every layer the engine does not render is
    named in a warning with its material."""
    doc, version, layered = exported["doc"], exported["version"], exported["layered"]
    m = {e["name"]: e["material"] for e in doc["meshes"]}["Layered"]
    assert m["shader"] == "principled" and m["base_color"] == pytest.approx([0.3, 0.6, 0.2])
    assert m["roughness"] == pytest.approx(0.45) and m["metallic"] == pytest.approx(0.25)
    if version == "3.4":
        # (3.x scenes name their model: a scene without "brdf" renders principled-v2)
        assert doc["brdf"] == "principled-v1"
        assert m["specular"] == pytest.approx(0.7) and m["specular_tint"] == pytest.approx(0.3)
        assert not {"ior", "specular_ior_level", "specular_tint_color", "diffuse_roughness"} & set(m)
        unrendered = ["Clearcoat", "Sheen", "Transmission", "Subsurface"]
    else:
        assert doc["brdf"] == "principled-v2"
        assert m["ior"] == pytest.approx(1.33) and m["specular_ior_level"] == pytest.approx(0.7)
        assert m["specular_tint_color"] == pytest.approx([0.9, 0.5, 0.2])
        assert m["diffuse_roughness"] == pytest.approx(layered.get("Diffuse Roughness", 0.0))
        assert not {"specular", "specular_tint"} & set(m)
        unrendered = ["Coat Weight", "Sheen Weight", "Transmission Weight", "Subsurface Weight"]
        # Materials left at a new node's defaults: v2's IOR 1.5, level 0.5, white tint.
        shiny = {e["name"]: e["material"] for e in doc["meshes"]}["Cube_1"]
        assert (shiny["ior"], shiny["specular_ior_level"], shiny["specular_tint_color"]) == (
            pytest.approx(1.5), pytest.approx(0.5), pytest.approx([1, 1, 1]))
    for socket in unrendered:
        assert any("material 'layered'" in w and "'%s'" % socket in w and "not rendered" in w
                   for w in exported["warnings"]), (socket, exported["warnings"])
    # ... and nothing else about "layered" (no silent drop, no spurious warning)
    assert len([w for w in exported["warnings"] if "'layered'" in w]) == len(unrendered)


def test_export_lights_world_gaussians_integrator(exported):
    doc, out = exported["doc"], exported["dir"]
    lights = {l["name"]: l for l in doc["lights"]}
    assert sorted(lights) == ["Bulb", "Panel", "Sun"]  # the spot light is skipped...
    assert any("Spot" in w and "not supported" in w for w in exported["warnings"])  # ...with a warning
    # Ray Visibility > Camera is exported (off by default in Blender 3.4) and honoured by the engine.
    assert lights["Panel"]["visible_camera"] is False
    b = lights["Bulb"]
    assert b["type"] == "point" and b["position"] == pytest.approx([1, -2, 3]) and b["power"] == 120
    assert b["color"] == pytest.approx([1.0, 0.8, 0.6]) and b["radius"] == pytest.approx(0.2)
    s = lights["Sun"]
    # From 4.0 on an angled sun's Strength is its irradiance (3.x: 2 (1/cos(a/2) - 1) / tan^2(a/2) of it)
    # and area lights emit 4/pi more for their Power: the scene file keeps 3.x's units
    # (io/light_units.py; measured against each Cycles in tests/python/test_light_units.py).
    v4 = exported["version"] != "3.4"
    half = 0.05
    sun_factor = math.tan(half) ** 2 / (2 * (1 / math.cos(half) - 1)) if v4 else 1.0
    assert s["type"] == "sun" and s["strength"] == pytest.approx(2.5 * sun_factor, rel=1e-9)
    assert s["angle"] == pytest.approx(0.1)
    assert [row[2] for row in s["transform"][:3]] == pytest.approx(exported["sun_z"])
    p = lights["Panel"]
    assert p["type"] == "area" and p["shape"] == "ellipse" and p["size"] == 0.5 and p["size_y"] == 0.25
    assert p["power"] == pytest.approx(55 * (4 / math.pi if v4 else 1.0), rel=1e-9)
    assert np.allclose(p["transform"], exported["panel_matrix"], atol=1e-6)
    env = doc["environment"]
    assert env["type"] == "latlong" and env["strength"] == pytest.approx(1.75)
    assert env["rotation_z"] == pytest.approx(1.25) and (out / env["file"]).exists()
    assert len(doc["gaussians"]) == 1 and doc["gaussians"][0]["file"] == "holder.ply"
    assert np.allclose(doc["gaussians"][0]["transform"], exported["splats_matrix"], atol=1e-6)
    # The caller's settings plus the film's pixel filter (factory settings: Blackman-Harris 1.5 px).
    assert doc["integrator"] == {"spp": 3, "bounces": 1, "pixel_filter": "blackman_harris", "filter_width": 1.5,
                                 "min_light_bounces": 0}


def test_export_camera_projects_like_blender(exported):
    cams = exported["doc"]["cameras"]
    assert [c["name"] for c in cams] == ["Main", "Other"]
    c = cams[0]
    assert (c["width"], c["height"]) == (150, 250)  # 300 x 500 at 50 %
    m = np.array(c["transform"])
    assert np.allclose(m[:3, 3], exported["main_location"])
    assert np.allclose(np.linalg.norm(m[:3, :3], axis=0), 1.0)  # object scale removed
    # Our pinhole (looks down -z, square pixels, fov_x) vs Blender's world_to_camera_view.
    tan_half = math.tan(0.5 * c["fov_x"])
    for p, (bx, by, _) in zip(exported["probes"], exported["projected"]):
        q = np.linalg.inv(m) @ np.array([*p, 1.0])
        x = (q[0] / -q[2]) / tan_half
        y = (q[1] / -q[2]) / (tan_half * c["height"] / c["width"])
        assert 0.5 + 0.5 * x == pytest.approx(bx, abs=1e-5)
        assert 0.5 + 0.5 * y == pytest.approx(by, abs=1e-5)


def test_exported_scene_loads_and_renders(exported, ptir):
    if exported["version"] in blenders.MODULE_VERSIONS and not blenders.engine_has_v2():
        pytest.skip(blenders.V2_ENGINE)
    scene = ptir.load_scene(exported["scene"])
    assert scene.camera_names == ["Main", "Other"]
    assert len(scene.gaussians) == 1 and scene.light_count == 3 and scene.environment == "latlong"
    # The holder's uniform scale 2 reached the Gaussian.
    src = ptir.load_gaussians(str(exported["dir"] / "holder.ply"))
    assert np.allclose(scene.gaussians.scale, 2.0 * src.scale, rtol=1e-5)
    img = scene.render("Other", spp=1)
    assert img.shape == (250, 150, 4) and np.all(np.isfinite(img)) and img[..., :3].max() > 0
