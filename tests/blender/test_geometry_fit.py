"""The geometry stage (`ptir fit`) on a Cycles dataset from the project's dataset
maker (scripts/make_dataset.py: the bundled Suzanne-on-a-pedestal sample at
subdivision 1, 80x80, 10 training + 3 test views, 16 spp), starting from its
splats perturbed as issue 12 asks (scripts/perturb_splats.py: positions jittered
by 0.5 x each Gaussian's largest scale, scales x or / 1.5 per axis, a random
rotation about the normal, opacities 0.5).

Scores (scripts/fit_quality.py, the `ptir eval` protocol): NVS PSNR of the
ray-traced SH render over white on the test views, normal MAE over the
foreground (normals rendered with 16 samples through the dataset's box filter,
as `ptir eval`). Measured at 600 iterations, seed 0 (the module about 75 s on 2 busy cores):
PSNR 20.5 -> 27.2 dB (the dataset's own splats, whose SH is the albedo and not
the radiance: 21.7 dB); normal MAE 17.6 -> 9.2 degrees (16.3 without the depth
distortion, the default since: the photometric loss alone leaves a cloud of
semi-transparent splats whose pixels blend normals from several depths; the
normals are the shortest axes, which the perturbation keeps: what improves is
which splats a ray sees and which way their normals face; the pseudo-normal term
is off by default, see the README's geometry-stage notes).
The bounds: PSNR up by >= 4 dB, normals >= 5 degrees better than before (the
fit without the distortion term gains 1.3 and fails it).

Also: `--resume` from a checkpoint written mid-run gives the same PLY, byte for
byte, as an uninterrupted run (same thread count), through a densification step.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("PTIR_BUILD_DIR", REPO / "build")).resolve()
CLI = BUILD / "bin" / "ptir"
BLENDER = [os.environ.get("BLENDER", "blender"), "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1"]
sys.path.insert(0, str(REPO / "scripts"))
import fit_quality  # noqa: E402
import perturb_splats  # noqa: E402

pytestmark = pytest.mark.skipif(shutil.which(BLENDER[0]) is None, reason="blender not installed")

PSNR_GAIN_MIN = 4.0
NORMAL_GAIN_MIN = 5.0


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    data = tmp_path_factory.mktemp("fit") / "data"
    r = subprocess.run([*BLENDER, "-P", str(REPO / "scripts" / "make_dataset.py"), "--", "--out", str(data), "--res", "80",
                        "--train", "10", "--test", "3", "--spp", "16", "--relight-envs", "", "--subdiv", "1"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    names, values, comments = perturb_splats.read_ply(str(data / "gaussians.ply"))
    perturb_splats.write_ply(str(data.parent / "perturbed.ply"), names, perturb_splats.perturb(names, values), comments)
    return data


def fit(dataset, out, *extra):
    r = subprocess.run([str(CLI), "fit", "--dataset", str(dataset), "--gaussians", str(dataset.parent / "perturbed.ply"),
                        "--out", str(out), "--threads", "2", *extra], capture_output=True, text=True, timeout=300)
    return r


def test_fit_improves_perturbed_splats(ptir, dataset, tmp_path):
    assert CLI.exists(), f"no CLI at {CLI}"
    out = tmp_path / "fit"
    r = fit(dataset, out, "--iters", "600", "-q")
    assert r.returncode == 0, r.stderr[-3000:]
    before = fit_quality.score(ptir, CLI, dataset, dataset.parent / "perturbed.ply", tmp_path)
    after = fit_quality.score(ptir, CLI, dataset, out / "gaussians.ply", tmp_path)
    print(f"NVS PSNR {before[0]:.2f} -> {after[0]:.2f} dB, normal MAE {before[1]:.2f} -> {after[1]:.2f} deg")
    assert after[0] >= before[0] + PSNR_GAIN_MIN
    assert after[1] <= before[1] - NORMAL_GAIN_MIN
    # The output is a standard 3DGS PLY with normals that the loader reads back.
    g = ptir.load_gaussians(str(out / "gaussians.ply"))
    log = (out / "log.csv").read_text().splitlines()
    assert len(log) == 601 and log[0].startswith("iteration,loss")
    assert abs(len(g.opacity) - int(log[-1].split(",")[5])) == 0


def test_resume_is_bit_identical(dataset, tmp_path):
    # 30 iterations with densification at 10 and 20 (the resumed part crosses one).
    common = ("--densify-grad", "1e-5", "--densify-every", "10", "--densify-from", "10", "--densify-until", "30", "-q")
    a, b = tmp_path / "a", tmp_path / "b"
    r = fit(dataset, a, "--iters", "30", *common)
    assert r.returncode == 0, r.stderr[-3000:]
    r = fit(dataset, b, "--iters", "15", "--checkpoint-every", "5", *common)
    assert r.returncode == 0, r.stderr[-3000:]
    r = fit(dataset, b, "--iters", "30", "--resume", *common)
    assert r.returncode == 0, r.stderr[-3000:]
    assert (a / "gaussians.ply").read_bytes() == (b / "gaussians.ply").read_bytes()
