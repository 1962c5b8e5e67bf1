"""A real capture through the add-on (the plush dog, ../shared/data/captures/plushdog; checks in
addon_real_capture_check.py): the Optimise panel's geometry stage and inversion read the capture as the
command line does (the splat an object against the photos' background), the panel says so, and the
results come back. Test data only: skipped with a message when it is absent."""

import pytest

import addon_common as ac

DOG = ac.REPO.parent / "shared" / "data" / "captures" / "plushdog"
PLY = DOG / "point_cloud_29999_clean.ply"
pytestmark = [pytest.mark.skipif(not ac.have_blender(), reason="blender not installed"),
              pytest.mark.skipif(not PLY.exists(), reason="../shared/data/captures/plushdog is absent (real-capture "
                                                          "test data beside the checkout; ../shared/data/README.md)")]


def test_the_optimise_panel_reads_a_real_capture_as_the_command_line_does(tmp_path):
    r = ac.blender_result("addon_real_capture_check.py", "REAL_CAPTURE", str(DOG), str(PLY), str(tmp_path),
                          timeout=1800)
    assert r["fit_stage"], r
    assert r["subject"] == "object against a background" and r["cli_subject"] == "object", r
    assert r["fit_subject"] == "object", r
    assert r["albedo_changed"] > 0.01, r
