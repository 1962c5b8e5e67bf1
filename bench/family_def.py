"""The family of scenes the inversion's defaults are chosen on (docs/family.md): twelve objects made by
the dataset maker (scripts/make_dataset.py --shape ...), in six pairs of one kind each; a fixed seed
picks which member of each pair is in the tuning half, the other is held out. Plain Python (no bpy):
bench/make_family.py makes the sets, bench/family.py runs and scores them, the test member is
tests/blender/test_family_colour.py's.
"""

import random

SPLIT_SEED = 41  # random.Random(41).randrange(2) per pair in order: which member tunes (0: the first)

# Every member: 16 training and 6 test views, 64 Cycles spp, 4 bounces, relit under sunset and overcast.
COMMON = {"train": 16, "test": 6, "spp": 64, "bounces": 4, "relight_envs": "sunset,overcast"}

# (pair, what it stands for, light, texture kind, roughness range, metal fraction, resolution, Blender,
#  its two shapes).  Blender "3.4" makes principled-v1 sets, "4.5" principled-v2 sets (the CLI picks the
#  model from the set's "ptir_brdf").
PAIRS = [
    (1, "convex", "studio", "smooth", (0.1, 0.9), 0.0, 128, "4.5", ("blob", "facets")),
    (2, "concave, occlusion", "sunsky", "edges", (0.3, 0.9), 0.0, 128, "4.5", ("bowl", "monkey_torus")),
    (3, "thin parts", "coloured", "hifreq", (0.2, 0.7), 0.0, 128, "3.4", ("rods", "table")),
    (4, "several objects, interreflection", "dim", "perface", (0.1, 0.9), 0.0, 256, "3.4", ("cluster", "pillars")),
    (5, "metals", "studio", "smooth", (0.05, 0.5), 0.25, 128, "3.4", ("spheres", "twisted")),
    (6, "concave lathe, stacked", "tinted", "perface", (0.4, 1.0), 0.0, 128, "3.4", ("vase", "capsules")),
]


# The metal pair's metal: a few large regions per object (parts, as an artist paints metal), not the
# maker's small patches, whose borders the one-splat-per-polygon surface blurs (docs/family.md: the
# oracle's albedo 18-20 dB on the patches).
METAL_LAYOUT = "regions"


def members():
    """[{name, pair, half, shape, train_env, kind, roughness_range, metal_fraction, res, blender, seed}]."""
    rng = random.Random(SPLIT_SEED)
    pick = [rng.randrange(2) for _ in PAIRS]
    out = []
    for (pair, what, env, kind, rough, metal, res, blender, shapes), tuning in zip(PAIRS, pick):
        for k, shape in enumerate(shapes):
            out.append({"name": "%02d_%s" % (2 * pair - 1 + k, shape), "pair": pair, "what": what,
                        "half": "tuning" if k == tuning else "heldout", "shape": shape, "train_env": env,
                        "kind": kind, "roughness_range": rough, "metal_fraction": metal, "res": res,
                        "blender": blender, "seed": 10 * pair + k, "metal_layout": METAL_LAYOUT})
    return out


# The test's member (tests/blender/test_family_colour.py): a strongly coloured light on a neutral
# (grey) per-face pattern, small enough for a test.
COLOUR_TEST = {"name": "colour_test", "shape": "facets", "train_env": "coloured", "kind": "perface",
               "roughness_range": (0.2, 0.6), "metal_fraction": 0.0, "res": 64, "blender": "3.4", "seed": 3,
               "neutral": True, "train": 12, "test": 3, "spp": 32, "bounces": 4, "relight_envs": ""}


def dataset_args(m, out):
    """make_dataset.py's arguments for member m into folder out."""
    c = dict(COMMON, **{k: m[k] for k in ("train", "test", "spp", "bounces", "relight_envs") if k in m})
    args = ["--out", str(out), "--shape", m["shape"], "--textured", "--texture-kind", m["kind"],
            "--texture-seed", str(m["seed"]), "--roughness-range", "%g,%g" % tuple(m["roughness_range"]),
            "--metal-fraction", str(m["metal_fraction"]), "--train-env", m["train_env"], "--res", str(m["res"]),
            "--train", str(c["train"]), "--test", str(c["test"]), "--spp", str(c["spp"]),
            "--bounces", str(c["bounces"]), "--relight-envs", c["relight_envs"]]
    if m["metal_fraction"] > 0:
        args += ["--metal-layout", m.get("metal_layout", "patches")]
    if m.get("neutral"):
        args.append("--neutral")
    if m.get("capture_room"):  # also photographed as a capture on a floor before walls (scripts/dataset/room.py)
        args.append("--capture-room")
    return args


if __name__ == "__main__":
    for m in members():
        print("%-16s pair %d %-8s %-8s %-7s rough %.2f-%.2f metal %.2f %d^2 Blender %s" % (
            m["name"], m["pair"], m["half"], m["train_env"], m["kind"], *m["roughness_range"], m["metal_fraction"],
            m["res"], m["blender"]))
