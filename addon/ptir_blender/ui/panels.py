"""Panels: the render engine's settings (Render Properties) and the PTIR tab of the 3D viewport sidebar
(Splats, Material Editing, Optimise)."""

import bpy

from ..blender import optimize_estimate, optimize_job, splat_object


class _RenderPropertiesPanel:
    """Render Properties panels shown only when PTIR is the render engine."""
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {"PTIR"}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class RENDER_PT_ptir_sampling(_RenderPropertiesPanel, bpy.types.Panel):
    bl_label = "PTIR Path Tracing"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.ptir_render
        col = layout.column()
        col.prop(s, "spp")
        col.prop(s, "bounces")
        col.prop(s, "interaction")
        col.prop(s, "tau_g")
        col.prop(s, "seed")
        col.prop(s, "threads")
        col = layout.column(heading="Viewport")
        col.prop(s, "viewport_samples", text="Samples")
        col.prop(s, "viewport_pixel_size", text="Pixel Size")
        layout.prop(s, "aov_passes")


class RENDER_PT_ptir_film(_RenderPropertiesPanel, bpy.types.Panel):
    """Film under PTIR (Blender 3.x has no engine-neutral Film panel; Eevee's shows settings PTIR ignores)."""
    bl_label = "Film"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(context.scene.render, "film_transparent", text="Transparent")
        cy = getattr(context.scene, "cycles", None)
        if cy is not None and hasattr(cy, "pixel_filter_type"):
            layout.prop(cy, "pixel_filter_type", text="Pixel Filter")
            layout.prop(cy, "filter_width", text="Width")


class _SidebarPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "PTIR"


class VIEW3D_PT_ptir_splats(_SidebarPanel, bpy.types.Panel):
    bl_label = "Splats"

    def draw(self, context):
        layout = self.layout
        row = layout.row(align=True)
        row.operator("import_scene.gaussian_splat_ply", text="Import", icon="IMPORT")
        row.operator("export_scene.gaussian_splat_ply", text="Export", icon="EXPORT")
        obj = context.active_object
        if not splat_object.is_splat_object(obj):
            layout.label(text="Active object: not a splat object", icon="INFO")
            return
        mesh = obj.data
        sh = 0
        for k, deg in ((24, 4), (15, 3), (8, 2), (3, 1)):
            if mesh.attributes.get("radiance:sh_%d" % (k - 1)) is not None:
                sh = deg
                break
        box = layout.box()
        box.label(text=obj.name, icon="OUTLINER_OB_POINTCLOUD")
        box.label(text="%s splats, SH degree %d" % (format(len(mesh.vertices), ","), sh))
        s = obj.ptir_splat
        col = layout.column()
        col.use_property_split = False  # the sidebar is narrow: a split cuts the labels
        col.use_property_decorate = False
        col.prop(s, "display")
        col.prop(s, "display_size")
        col.prop(s, "display_limit")


class VIEW3D_PT_ptir_materials(_SidebarPanel, bpy.types.Panel):
    bl_label = "Material Editing"

    @classmethod
    def poll(cls, context):
        return splat_object.is_splat_object(context.active_object)

    def draw(self, context):
        layout = self.layout
        obj = context.active_object
        s = context.scene.ptir_edit
        col = layout.column()
        col.use_property_split = False
        col.use_property_decorate = False
        col.prop(s, "channel")
        col.prop(s, "operation")
        if s.channel == "ALBEDO" and s.operation in ("SET", "TINT"):
            col.prop(s, "color")
        else:
            col.prop(s, "value")
        col.prop_search(s, "vertex_group", obj, "vertex_groups", text="Vertex Group")
        if s.vertex_group:
            target = "group '%s'" % s.vertex_group
        elif obj.mode == "EDIT":
            target = "selected splats"
        else:
            target = "all splats"
        layout.label(text="Applies to " + target, icon="RESTRICT_SELECT_OFF")
        op = layout.operator("ptir.edit_material", text="Apply", icon="BRUSH_DATA")
        op.channel, op.operation, op.color, op.value, op.vertex_group = (s.channel, s.operation, s.color, s.value,
                                                                         s.vertex_group)


class VIEW3D_PT_ptir_optimize(_SidebarPanel, bpy.types.Panel):
    bl_label = "Optimise"

    def draw(self, context):
        layout = self.layout
        s = context.scene.ptir_optimize
        if s.running:
            row = layout.row()
            if hasattr(row, "progress"):  # Blender 4.0+
                row.progress(factor=s.progress, type="BAR", text="%.0f%%" % (100 * s.progress))
            else:
                row.prop(s, "progress", text="Progress", slider=True)
            box = layout.box()
            if s.capture_subject:
                box.label(text="Capture: %s" % s.capture_subject, icon="CAMERA_DATA")
            for part in (s.status or "starting").split(", "):
                box.label(text=part)
            layout.operator("ptir.optimize_cancel", text="Cancel (Esc)", icon="CANCEL")
        else:
            problem = optimize_estimate.dataset_problem(s)
            if problem:
                layout.label(text=problem, icon="ERROR")
            layout.operator("ptir.optimize", text="Optimise", icon="PLAY")
            # One click, photos or not (the dataset folder when set, else the splats' own radiance).
            layout.operator("ptir.make_relightable", icon="LIGHT_SUN")
            layout.prop(s, "preset")
            total = optimize_estimate.seconds(context, s)
            measured = bool(s.estimate_key) and s.estimate_key == optimize_estimate.key(context, s)
            if total is not None and s.preset != "CUSTOM":
                box = layout.box()
                box.label(text="Ends within %s" % optimize_estimate.duration_text(total), icon="TIME")
                if measured and s.estimate_s_per_iter > 0.0:  # at the samples the engine planned for it
                    share = 1.0 - (optimize_job.FIT_SHARE if s.estimate_fit_s_per_iter > 0.0 else 0.0)
                    n = max(0, int((share * total - s.estimate_setup_s) / s.estimate_s_per_iter))
                    box.label(text="about %d iterations of %.2f s" % (n, s.estimate_s_per_iter))
            elif total is not None:
                box = layout.box()
                box.label(text="Estimated: %s" % optimize_estimate.duration_text(total), icon="TIME")
                box.label(text="%d × %.2f s + %.0f s setup" % (s.iterations, s.estimate_s_per_iter, s.estimate_setup_s))
                if s.estimate_fit_s_per_iter > 0.0:
                    box.label(text="+ fit %d × %.3f s" % (s.fit_iterations, s.estimate_fit_s_per_iter))
            if not measured and not problem and (total is None or s.preset != "CUSTOM"):
                layout.operator("ptir.optimize_estimate", icon="TIME")
            if s.status:
                layout.label(text=s.status, icon="INFO")
            if s.capture_subject:
                layout.label(text="Capture: %s" % s.capture_subject, icon="CAMERA_DATA")
        meshes = [o for o in context.visible_objects if o.type == "MESH" and not splat_object.is_splat_object(o)]
        if meshes:
            layout.label(text="%d visible mesh%s take part (shadows, bounces)" % (len(meshes), "es" if len(meshes) > 1 else ""),
                         icon="INFO")
        col = layout.column()
        col.use_property_split = False
        col.use_property_decorate = False
        col.enabled = not s.running
        col.prop(s, "source")
        if s.source == "DATASET":
            col.prop(s, "dataset_dir")
            col.operator("ptir.import_capture_cameras", icon="OUTLINER_OB_CAMERA")
        col.prop(s, "split")
        col.prop_search(s, "splat_object", context.scene, "objects", text="Splats")
        col.prop(s, "light")
        col.prop(s, "env")
        if s.env == "latlong":
            row = col.row(align=True)
            row.prop(s, "env_width", text="Size")
            row.prop(s, "env_height", text="")
        if s.env == "none":  # scene lights only: nothing to put into the World
            if not any(optimize_job.is_scene_light(o) for o in context.visible_objects):
                col.label(text="No visible lamp or emissive mesh", icon="ERROR")
        else:
            col.prop(s, "write_environment")
        col.prop(s, "optimize_metallic")
        col.prop(s, "learn_exposure")
        col.prop(s, "optimize_meshes")
        if s.optimize_meshes:
            mats = sorted({slot.material for o in context.scene.objects if o.type == "MESH" and not o.hide_render
                           and not splat_object.is_splat_object(o) for slot in o.material_slots
                           if slot.material is not None}, key=lambda m: m.name)
            box = col.box()
            if not mats:
                box.label(text="No mesh materials in the scene")
            for m in mats:
                box.prop(m.ptir, "optimize", text=m.name)
        col.separator()
        col.prop(s, "fit_geometry")
        if s.fit_geometry != "OFF":
            col.prop(s, "fit_iterations")
        if s.preset == "CUSTOM":  # a time preset plans them
            col.prop(s, "iterations")
            col.prop(s, "spp")
        col.prop(s, "bounces")
        if s.preset == "CUSTOM":  # a time preset takes the engine's batch
            col.prop(s, "views_per_iter")
            col.prop(s, "crop")
        col.prop(s, "seed")
        col.prop(s, "output_dir")


classes = (RENDER_PT_ptir_sampling, RENDER_PT_ptir_film, VIEW3D_PT_ptir_splats, VIEW3D_PT_ptir_materials, VIEW3D_PT_ptir_optimize)
