"""Shared fixtures of the Blender and add-on tests.

ptir: the native module from the build folder ($PTIR_BUILD_DIR, else <repo>/build); a test that
needs it fails (not skips) when it has not been built.
"""

import sys

import pytest

import addon_common as ac


@pytest.fixture(scope="module")
def ptir():
    if not any(ac.MODULE_DIR.glob("ptir*.so")):
        pytest.fail("no native module in %s (run 'make build' or set PTIR_BUILD_DIR)" % ac.MODULE_DIR)
    sys.path.insert(0, str(ac.MODULE_DIR))
    import ptir as module
    return module
