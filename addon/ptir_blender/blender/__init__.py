"""Blender-data code of the add-on (uses bpy): plain functions, no operators.

Modules:
    scene_export  the current Blender scene -> a PTIR scene file (docs/scene_format.md)
"""
