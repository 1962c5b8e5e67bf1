"""Operators of the add-on (bpy): import/export, material editing, optimisation; and the render engine."""
