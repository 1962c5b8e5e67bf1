"""The add-on and real-capture folders, in blender -b (checks in addon_capture_check.py).

The capture: addon_optimize_data's six 32 x 32 views (a sphere of splats on a floor) rewritten by
the dataset maker's layout writer (scripts/dataset/capture.py) as a COLMAP binary model with an
OPENCV lens and distorted photos (no masks: the floor is in every photo). Blender imports the capture's cameras (each with its
photo as background) and optimises from the COLMAP folder directly, then with the splat object
moved (the cameras follow it through `ptir cameras`).
"""

import json
import math

import numpy as np
import pytest

import addon_common as ac
import blenders

pytestmark = pytest.mark.skipif(not ac.have_blender(), reason="blender not installed")


@pytest.fixture(scope="module")
def capture_dir(ptir, tmp_path_factory):
    import addon_optimize_data as data
    from dataset import capture
    if not ac.CLI.exists():
        pytest.fail("no CLI at %s (run 'make build' or set PTIR_BUILD_DIR)" % ac.CLI)
    root = tmp_path_factory.mktemp("capture")
    d = data.make_dataset(str(root / "nerf"), ac.CLI)
    views = []
    for i, m in enumerate(d["cameras"]):
        img = ptir.read_image(str(root / "nerf" / "train" / ("r_%d.png" % i)))
        views.append(("r_%d" % i, m, img[..., :3], np.ones(img.shape[:2])))  # RGB renders (a floor behind)
    f = 0.5 * data.SIZE / math.tan(0.5 * data.FOV_X)
    made = capture.write_capture_layouts(root / "layouts", views, (f, f, data.SIZE / 2, data.SIZE / 2),
                                         layouts_wanted=("colmap_bin",), masks=False)
    return {"colmap": made["colmap_bin"], "input": d["input"], "f": f, "size": data.SIZE,
            "distortion": list(capture.DEFAULT_DISTORTION), "cameras": [m.tolist() for m in d["cameras"]]}


def _check_stats(script, marker, capture_dir, tmp_path, blender="3.4"):
    """Runs the Blender check `script` on the capture (its spec as JSON) and returns its `marker` stats."""
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({k: str(v) if not isinstance(v, (int, float, list)) else v
                                for k, v in capture_dir.items()}))
    return ac.blender_result(script, marker, spec, tmp_path, timeout=600, blender=blender)


@pytest.mark.parametrize("blender", blenders.params(needs=blenders.v2_needs()))
def test_import_capture_cameras_and_optimise_from_colmap(blender, capture_dir, tmp_path):
    stats = _check_stats("addon_capture_check.py", "CAPTURE_STATS", capture_dir, tmp_path, blender)
    print("capture: %s" % stats)
    assert stats["cameras"] == 6
    assert stats["max_projection_error_px"] < 0.02


def test_optimise_fits_the_geometry_of_a_capture(capture_dir, tmp_path):
    """The geometry stage in the optimise flow (addon_fit_check.py): on by default for the COLMAP
    capture, cancellable, the fitted splats replace the object's (also when it is moved)."""
    stats = _check_stats("addon_fit_check.py", "FIT_STATS", capture_dir, tmp_path)
    print("fit in the optimise flow: %s" % stats)
    for name in ("identity", "moved"):
        assert stats[name]["loss_last_epoch"] < 0.9 * stats[name]["loss_first_epoch"]
        assert stats[name]["position_error"] < 1e-4
