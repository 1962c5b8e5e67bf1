"""The add-on in a real Blender window under Xvfb (checks in addon_ui_shot.py): the PTIR sidebar tab
during a modal optimisation (progress, Esc cancels, nothing changed), undo of a material edit, and the
screenshot of the panel. PTIR_UPDATE_SCREENSHOT=1 also copies it to docs/addon_panel.png (the
README's picture)."""

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import addon_common as ac

pytestmark = pytest.mark.skipif(not ac.have_blender() or shutil.which("xvfb-run") is None,
                                reason="needs blender and xvfb-run")


def test_panel_in_a_real_window(tmp_path):
    shot = tmp_path / "addon_panel.png"
    env = dict(os.environ, PTIR_CLI=str(ac.CLI), PTIR_TEST_REPO=str(ac.REPO),
               PTIR_TEST_MODULE_DIR=str(ac.MODULE_DIR))
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1280x800x24", ac.BLENDER, "--factory-startup",
           "--enable-event-simulate", "-noaudio", str(ac.REPO / "sample_blends" / "cornell_splats.blend"),
           "-P", str(ac.HERE / "addon_ui_shot.py"), "--", str(shot), str(tmp_path)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0 and "ADDON_CHECK: OK" in r.stdout, ac.output_of(r)
    line = next(l for l in r.stdout.splitlines() if l.startswith("UI_CHECK: "))
    info = json.loads(line[len("UI_CHECK: "):])
    print("UI: %s" % info)
    assert info["status_during_run"].startswith("iteration ")
    assert info["status_after_esc"] == "cancelled" and info["undo"] is True
    # No Python thread of the add-on's: one racing Blender's GIL check crashes it (io/pipe_lines.py).
    assert info["threads_during_run"] == ["MainThread"] and info["threads_at_end"] == ["MainThread"], info
    from skimage import io
    img = io.imread(shot)
    assert img.shape[:2] == (800, 1280)
    assert np.std(img[..., :3]) > 20, "the screenshot is blank"
    if os.environ.get("PTIR_UPDATE_SCREENSHOT"):
        shutil.copyfile(shot, ac.REPO / "docs" / "addon_panel.png")
