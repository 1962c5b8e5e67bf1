"""Helpers of scripts/make_dataset.py (the Blender dataset maker).

exr, png and envmaps are pure numpy (usable in plain Python and in Blender);
scene and splat need Blender's bpy.
"""
