"""The real-capture path against known materials (issue 51; docs/captures.md, "Synthetic captures: the
same path against known materials"; bench/bench_capture_truth.py is the full-size bench).

A family member (02_facets) made by Cycles 3.4 at 48^2 as a NeRF set and as a capture photographed on
a floor before two walls (scripts/dataset/room.py: JPEGs with EXIF, photos 2 and 10 at x0.5, 5 and 13
at x2, no masks); the user's splat is the set's object splats with their radiance refitted to those
photos (`ptir fit --sh-only`), the floor and walls not in it. `ptir optimize` on the capture at short
settings must
  - classify it as an object against a background, its coverage masks close to the object's true
    coverage (IoU),
  - bring every photo to its true exposure relative to the others (EXIF x the per-photo gain, within
    GAIN_TOL; the bracketed ones at x0.5 and x2 included),
  - recover an albedo whose scale-aligned sRGB PSNR on the set's ground truth is above ALBEDO_MIN_DB,
  - show the held-out photos' whole frame (the room behind the object, from the learnt light) above
    FRAME_MIN_DB.

Measured at this setting (120 iterations x 4 spp, --fit-iters 0), the background supervising the light
and its seen texels learning at the coarse level (--background-loss, --env-seen coarse: the defaults for
an object): albedo 27.11 / 27.29 / 27.07 dB (seeds 0 / 1 / 2), held-out frame 25.80 / 25.72 / 25.74 dB,
every photo's exposure within 1.8 %, mask IoU 0.958. With the loss on the coverage masks only
(--background-loss off, the previous default): albedo 25.24 / 25.34 dB (seeds 0 / 1), frame 19.94 /
19.01 dB; both bounds fail it. The same object as the masked NeRF set (transparent film,
no background to learn the light from) lands at 22.38 / 22.36 dB (seeds 1 / 2). The user's splat refitted for 300
iterations instead of 1000 (its radiance not yet the photos') puts same-exposure photos up to 20 %
apart (the gains then absorb shading): GAIN_TOL catches that. A variant that "should lose" does not:
--subject scene (no mask: the floor and walls seen directly supervise the environment) scores 28.4-28.5
dB, 1.5 dB above the default (docs/captures.md), so no such assertion is made.
"""

import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

import blenders

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))
import bench_capture_truth as truth  # noqa: E402

GAIN_TOL = 0.10       # the bar on the relative exposures (measured within 0.002)
IOU_MIN = 0.85        # measured 0.958
ALBEDO_MIN_DB = 26.0  # measured 27.07-27.29 dB; the loss on the masks only 25.2-25.3, the NeRF set 22.4
FRAME_MIN_DB = 24.0   # measured 25.72-25.80 dB; the loss on the masks only 19.0-19.9

pytestmark = pytest.mark.skipif(not blenders.available("3.4"), reason=blenders.why_missing("3.4"))


def test_synthetic_capture_is_an_object_with_its_exposures_and_albedo(tmp_path):
    member = truth.capture_member("02_facets", res=48, train=12, test=2, spp=16)
    data = truth.make(member, tmp_path)
    work = tmp_path / "runs"
    splat = truth.user_splat(data, work, iters=1000)
    a = SimpleNamespace(iters=120, spp=4, seed=0, threads=0, eval_spp=8)
    room = truth.run_variant("room", "room", [], data, work, splat, a)
    d = room["decision"]
    print("subject %s, mask IoU %.3f, bracketed photos %s, worst exposure error %.3f, albedo %.2f dB" % (
        d["subject"], d["mask_iou"], {k: round(v, 3) for k, v in d["relative"].items()}, d["gain_error_all"],
        room["albedo_psnr"]))
    assert d["subject"] == "object"
    assert d["mask_iou"] >= IOU_MIN, d["mask_iou"]
    assert d["exif_applied"]
    assert d["gain_error_all"] <= GAIN_TOL, d["gain_error"]
    assert room["albedo_psnr"] >= ALBEDO_MIN_DB, room["albedo_psnr"]
    assert room["held_out"]["frame"] >= FRAME_MIN_DB, room["held_out"]
