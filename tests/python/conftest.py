"""Fixtures of the Python tests; the helpers live in ptir_testing.py (a module name of its own:
tests/blender has a conftest.py too, and `from ptir_testing import` would pick whichever came first)."""

from ptir_testing import cli, ptir, wall_scene  # noqa: F401  (pytest finds fixtures here)
