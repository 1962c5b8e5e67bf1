"""Panels and menu entries of the add-on (bpy)."""
