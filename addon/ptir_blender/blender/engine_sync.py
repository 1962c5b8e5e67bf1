"""Keeps the persistent engine's scene equal to Blender's, sending only what changed.

One EngineSession per Blender session (`session()`): the `ptir serve` child
process (io/engine_process.py) and what it holds, as fingerprints:

- membership: the visible objects (splats, meshes, lights) -> a change reloads
- geometry: per splat object a hash of its positions, scales, rotations,
  opacities and normals; per mesh object a hash of its evaluated world-space
  triangles -> a change re-exports the scene and sends "load"
- per splat object its world matrix -> a move (a similarity) sends
  "transform_splats" (new matrix times the inverse of the old; the engine
  rebuilds its acceleration structure, no file is read); F12 (exact=True)
  reloads moved splats so its image is the CLI's to the last bit
- per splat object a hash of its material attributes -> "splat_materials" with
  that object's range of Gaussians (a float32 file in /dev/shm); an edit of the
  material editor (note_material_edit) sends only what it changed: its channel,
  and the indices of the edited splats when fewer than all (no read-back, no hash)
- lights, world, integrator settings -> "update" with those scene-file parts
- mesh materials (material_params of each slot) -> "mesh_material" per mesh

sync(depsgraph, changed=...) compares and sends; `changed` (names of objects the
depsgraph reported as updated) limits the expensive hashes to those objects; a
full sync (F12, first draw) hashes everything. Requests are sent without waiting
(replies come in order); the caller waits on its render request, which the
engine answers after every delta sent before it.
"""

import hashlib
import json
import os
import shutil
import threading

import numpy as np

from ..errors import PtirError
from ..io import engine_client, engine_process
from ..io import splat_transform
from . import scene_bridge, scene_export, splat_object


def _hash_arrays(*arrays):
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def _matrix(obj):
    return np.array(obj.matrix_world, np.float64)


def splat_geometry_hash(obj):
    """Hash of the object-space splat geometry (the world matrix is tracked apart: a move is a delta)."""
    mesh = obj.data
    n = len(mesh.vertices)
    co = np.empty(n * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    parts = [co]
    for name, width in (("scale", 3), ("rotation", 4), ("opacity", 1), ("ptir_normal", 3)):
        a = splat_object._get_attribute(mesh, name, width, required=False, what=obj.name)
        parts.append(np.zeros(0) if a is None else a)
    return _hash_arrays(*parts)


def splat_materials(obj):
    """float32 albedo (n x 3), roughness (n), metallic (n) of a splat object, as one flat array."""
    albedo, roughness, metallic = splat_object.read_material_attributes(obj.data, "object '%s'" % obj.name)
    return np.concatenate([np.asarray(albedo, np.float32).reshape(-1), np.asarray(roughness, np.float32).reshape(-1),
                           np.asarray(metallic, np.float32).reshape(-1)])


def mesh_geometry_hash(obj, depsgraph):
    co, tris, mat, normals, uvs, _ = scene_export._evaluated_triangles(obj, depsgraph, ("", False), [])
    # Smooth shading and UV edits re-export too.
    extra = tuple(a.astype(np.float32) for a in (normals, uvs) if a is not None)
    return _hash_arrays(co.astype(np.float32), tris, mat, *extra)


def mesh_materials(obj, warnings=None):
    """{scene mesh name: material params} as export_mesh_object names them (one per slot); what the
    conversion approximates or leaves out goes to `warnings`."""
    slots = obj.material_slots
    if len(slots) <= 1:
        return {obj.name: scene_export.material_params(slots[0].material if len(slots) else None, warnings)}
    return {obj.name + "_%d" % i: scene_export.material_params(s.material, warnings) for i, s in enumerate(slots)}


def _texture_layout(mats):
    """Which meshes' materials read textures, and which a normal map (what their PLYs must carry)."""
    uses = scene_export.material_export.texture_export.uses_textures
    return {name: (uses(m), "normal_map" in m) for name, m in mats.items()}


class EngineSession:
    """The engine process and the state of the scene it holds (see the module notes)."""

    def __init__(self):
        self.engine = None
        self.lock = threading.RLock()
        self.folder = None        # bulk files and scene exports of this process
        self.state = None         # fingerprints of what the engine holds (None: nothing loaded)
        self.loads = 0            # "load" requests sent (full exports)
        self.warnings = []
        self._material_warnings = []
        self._seq = 0
        self._material_only = {}  # object name -> its PTIR material edits since the last sync (note_material_edit)
        self._bulk = []  # (request id, files written for it): removed once the engine has answered

    # ------------------------------------------------------------ process

    def ensure(self, cli_path, threads=0):
        """Starts the engine when there is none or it died; returns True when a new one started."""
        with self.lock:
            if self.engine is not None and self.engine.alive():
                return False
            self.stop()
            self.folder = engine_process.bulk_dir()
            self.engine = engine_process.EngineProcess(cli_path, threads=threads,
                                                       log_path=os.path.join(self.folder, "engine.log"),
                                                       out_dir=self.folder)  # its renders go here only
            self.state = None
            return True

    def alive(self):
        return self.engine is not None and self.engine.alive()

    def stop(self):
        with self.lock:
            if self.engine is not None:
                self.engine.close()
                self.engine = None
            if self.folder and not os.environ.get("PTIR_KEEP_FILES"):
                shutil.rmtree(self.folder, ignore_errors=True)
            self.folder = None
            self.state = None
            self._bulk = []

    def note_material_edit(self, name, edit=None):
        """The material editor changed only material attributes of object `name`: the next sync skips
        its geometry check (hashing a 1M-splat object's geometry costs ~0.4 s) and sends the edit
        (material_ops.MaterialEdit: channel, indices or None for all, new values) as it is, without
        reading the attributes back; None: an unknown change (all three channels are sent)."""
        self._material_only.setdefault(name, []).append(edit)

    def push_material_edit(self, name, edit, update_follows=True):
        """Sends a material edit of object `name` to the engine now (the operator calls this, so the engine
        works while Blender evaluates its depsgraph); returns False when it cannot (no scene loaded, the
        object not in it, an unknown edit): the edit is then noted for the next sync. update_follows: the
        operator tags the mesh for a depsgraph update, whose sync must then neither send the edit again
        nor hash the object's geometry (a mark that only that next sync consumes)."""
        with self.lock:
            st = self.state
            if edit is None or st is None or not self.alive() or name not in st["splats"]:
                self.note_material_edit(name, edit)
                return False
            try:
                self._send_edit(st, name, edit)
            except engine_process.EngineDied:
                self.note_material_edit(name, edit)
                return False
            if update_follows:
                self._material_only.setdefault(name, [])  # the coming update of it: material only, already sent
            return True

    def file(self, name):
        self._seq += 1
        return os.path.join(self.folder, "%06d_%s" % (self._seq, name))

    def _send_bulk(self, request, files):
        """Sends a request that reads `files`; they are removed when its reply has come (_reap)."""
        rid = self.engine.send(request, bulk_bytes=sum(os.path.getsize(f) for f in files))
        self._bulk.append((rid, files))
        return rid

    def _reap(self):
        """Removes the bulk files of answered requests (a 1M-splat albedo edit is 12 MB of /dev/shm); a
        failed delta's error becomes a warning."""
        keep = []
        for rid, files in self._bulk:
            try:
                reply = self.engine.reply(rid) if self.engine is not None else {}
            except engine_process.EngineDied:
                reply = {}
            if reply is None:
                keep.append((rid, files))
                continue
            if reply and not reply.get("ok") and not reply.get("cancelled"):
                self.warnings.append("PTIR engine: %s" % reply.get("error", "request failed"))
            for f in files:
                try:
                    os.remove(f)
                except OSError:
                    pass
        self._bulk = keep

    # ------------------------------------------------------------ sync

    def _membership(self, depsgraph):
        layer = scene_bridge._RenderLayer(depsgraph)
        objs = list(scene_bridge._visible(depsgraph.scene, layer.objects))
        splats = [o for o in objs if splat_object.is_splat_object(o)]
        meshes = [o for o in objs if not splat_object.is_splat_object(o)
                  and o.type in ("MESH", "CURVE", "SURFACE", "META", "FONT")]
        lights = [o for o in objs if o.type == "LIGHT"]
        refs = [o for o in objs if "ptir_gaussians" in o]
        key = tuple(sorted((o.name, o.type, splat_object.is_splat_object(o)) for o in objs
                           if o.type in ("MESH", "CURVE", "SURFACE", "META", "FONT", "LIGHT") or "ptir_gaussians" in o))
        return key, splats, meshes, lights, refs

    def _fingerprints(self, depsgraph, splats, meshes, refs, changed, data_changed=None):
        old = self.state or {}
        geo, mats = {}, {}
        data = changed if data_changed is None else data_changed
        for o in splats:
            known = o.name in old.get("geo", {})
            if known and changed is not None and o.name in self._material_only:
                geo[o.name] = old["geo"][o.name]
            elif changed is None or o.name in data or not known:  # (a move alone: matrices, in sync)
                geo[o.name] = splat_geometry_hash(o)
            else:
                geo[o.name] = old["geo"][o.name]
        for o in meshes + refs:
            if changed is None or o.name in changed or o.name not in old.get("geo", {}):
                geo[o.name] = (mesh_geometry_hash(o, depsgraph) if "ptir_gaussians" not in o
                               else _hash_arrays(_matrix(o)) + str(o["ptir_gaussians"]))
            else:
                geo[o.name] = old["geo"][o.name]
        self._material_warnings = []
        for o in meshes:
            if "ptir_gaussians" not in o:
                mats.update(mesh_materials(o, self._material_warnings))
        return geo, mats

    def _parts(self, depsgraph, integrator, lights):
        warnings = []
        light_entries = [e for e in (scene_export.light_entry(o, warnings) for o in lights) if e is not None]
        return {"lights": light_entries,
                "integrator": {**scene_export.cycles_integrator(depsgraph.scene), **(integrator or {})}}

    def sync(self, depsgraph, integrator, changed=None, world_changed=True, exact=False, data_changed=None):
        """Brings the engine's scene up to date; returns {"load": bool, "sent": [commands]}.

        changed: names of objects whose data or transform changed (None: check everything);
        data_changed: those whose data changed (None: all of `changed`); only these get their material
        attributes compared.
        world_changed: recompute the world (a latlong image may be written on export).
        exact: the engine must hold exactly what a fresh export gives (F12: the CLI's image); splats
        moved by "transform_splats" deltas (float rounding of the relative matrix) are then reloaded."""
        with self.lock:
            self._reap()
            key, splats, meshes, lights, refs = self._membership(depsgraph)
            geo, mats = self._fingerprints(depsgraph, splats, meshes, refs, changed, data_changed)
            st = self.state
            # A material that gains or loses its textures needs the mesh written with (or without) UVs.
            if (st is None or st["key"] != key or st["geo"] != geo or (exact and st["moved"])
                    or _texture_layout(st["mats"]) != _texture_layout(mats)):
                self._material_only.clear()
                return self._load(depsgraph, integrator, key, geo, mats, splats)
            sent = []
            for o in splats:
                new = _matrix(o)
                offset, count, _ = st["splats"][o.name]
                old = st["xf"][o.name]
                if np.array_equal(new, old):
                    continue
                rel = new @ np.linalg.inv(old)
                if not splat_transform.is_similarity(rel):  # the engine's rule: similarities only
                    return self._load(depsgraph, integrator, key, geo, mats, splats)
                self.engine.send(engine_client.transform_splats_request(offset, count, rel.reshape(-1)))
                st["xf"][o.name] = new
                st["moved"] = True
                sent.append("transform_splats")
            parts = self._parts(depsgraph, integrator, lights)
            delta = {k: v for k, v in parts.items() if st["parts"].get(k) != v}
            if world_changed:
                env = scene_export.world_entry(depsgraph.scene.world, st["folder"], [])
                if env != st["parts"].get("environment"):
                    delta["environment"] = env
            if delta:
                self.engine.send(engine_client.update_request(delta))
                st["parts"].update(delta)
                sent.append("update")
            for name, m in mats.items():
                if st["mats"].get(name) != m:
                    self.engine.send(engine_client.mesh_material_request(name, m))
                    st["mats"][name] = m
                    sent.append("mesh_material")
                    # (what the edited material's conversion leaves out is reported with the next render)
                    self.warnings += [w for w in self._material_warnings if w not in self.warnings]
            data = changed if data_changed is None else data_changed
            for o in splats:
                edits = self._material_only.get(o.name)
                if edits is not None and not edits:
                    continue  # pushed by the operator (push_material_edit)
                if edits and all(e is not None for e in edits):
                    for e in edits:  # what the material editor changed, as it changed it
                        self._send_edit(st, o.name, e)
                        sent.append("splat_materials")
                    continue
                if data is not None and o.name not in data and not edits:
                    continue
                values = splat_materials(o)
                h = None if edits else _hash_arrays(values)  # a noted edit is sent without comparing
                offset, count, old = st["splats"][o.name]
                if edits or h != old:
                    path = self.file("splat_materials.f32")
                    values.tofile(path)
                    self._send_bulk(engine_client.splat_materials_request(offset, count, path), [path])
                    st["splats"][o.name] = (offset, count, h)
                    sent.append("splat_materials")
            self._material_only.clear()
            return {"load": False, "sent": sent}

    def _send_edit(self, st, name, edit):
        """One material edit as a partial "splat_materials": its channel, for the edited splats (by index
        when fewer than all; at most 4 bytes more per edited splat than the whole channel)."""
        offset, count, _ = st["splats"][name]
        values = np.ascontiguousarray(edit.values, np.float32)
        files = [self.file("splat_materials.f32")]
        values.tofile(files[0])
        if edit.indices is not None:
            files.append(self.file("splat_indices.u32"))
            np.ascontiguousarray(edit.indices, np.uint32).tofile(files[1])
        request = engine_client.splat_materials_request(offset, count, files[0], channels=[edit.channel],
                                                        indices=files[1] if len(files) > 1 else None)
        self._send_bulk(request, files)
        st["splats"][name] = (offset, count, None)  # the next unnoted sync compares afresh

    def _load(self, depsgraph, integrator, key, geo, mats, splats):
        folder = os.path.join(self.folder, "scene_%d" % self.loads)
        shutil.rmtree(folder, ignore_errors=True)
        warnings = []
        path, info = scene_bridge.export_engine_scene(out_dir=folder, depsgraph=depsgraph, integrator=integrator,
                                                      warnings=warnings, include_cameras=False)
        size = sum(os.path.getsize(os.path.join(folder, f)) for f in os.listdir(folder))
        rid = self.engine.send(engine_client.load_request(path), bulk_bytes=size)
        reply = self.engine.wait(rid)
        if not reply.get("ok"):
            self.state = None
            raise PtirError("PTIR engine: %s" % reply.get("error", "load failed"))
        # Splat objects come last in the engine's field, in export order.
        counts = [(name, c) for name, _, c in info["splats"]]
        offset = int(reply.get("gaussians", 0)) - sum(c for _, c in counts)
        ranges = {}
        for name, c in counts:
            obj = depsgraph.scene.objects[name]
            ranges[name] = (offset, c, _hash_arrays(splat_materials(obj)))
            offset += c
        with open(path) as f:
            doc = json.load(f)
        parts = {"lights": doc.get("lights", []), "integrator": doc.get("integrator", {}),
                 "environment": doc.get("environment")}
        xf = {o.name: _matrix(o) for o in splats}
        self.state = {"key": key, "geo": geo, "mats": mats, "splats": ranges, "parts": parts, "folder": folder,
                      "xf": xf, "moved": False}
        self.loads += 1
        self.warnings = warnings
        # The previous export is no longer read by the engine.
        old = os.path.join(self.folder, "scene_%d" % (self.loads - 2))
        if self.loads >= 2 and not os.environ.get("PTIR_KEEP_FILES"):
            shutil.rmtree(old, ignore_errors=True)
        return {"load": True, "sent": ["load"], "bytes": size}


_SESSION = EngineSession()


def session():
    return _SESSION


def shutdown():
    _SESSION.stop()
