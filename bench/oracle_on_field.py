#!/usr/bin/env python3
"""The true materials on another field of the same object: each Gaussian of FIELD
takes the albedo, roughness and metallic of the nearest exact splat of a dataset's
oracle (oracle/gaussians.ply: one flat splat per face, the face's material), so a
fitted field gets the oracle it is fairly compared with (docs/fidelity.md).

    bench/oracle_on_field.py --dataset DIR --field FITTED.ply --out OUT

Writes OUT/gaussians.ply (FIELD's geometry and normals, the carried materials) and
OUT/env.exr (the dataset's training light): a result folder `ptir eval` reads.
"""
import argparse
import json
import os
import shutil
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dataset", required=True)
    p.add_argument("--field", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    a = p.parse_args()
    sys.path.insert(0, os.path.join(os.path.abspath(a.build), "python"))
    import ptir
    try:
        meta = json.load(open(os.path.join(a.dataset, "dataset.json")))
        env = os.path.join(a.dataset, meta["envmaps"][meta["train_env"]])
        oracle = ptir.load_gaussians(os.path.join(a.dataset, "oracle", "gaussians.ply"))
        field = ptir.load_gaussians(a.field)
    except (OSError, ValueError, KeyError, ptir.Error) as e:
        sys.exit("oracle_on_field: %s" % e)
    po, pf = oracle.position, field.position
    nearest = np.empty(len(field), dtype=np.int64)
    for i in range(0, len(field), 2048):  # brute force in blocks: fields of this size need no tree
        nearest[i:i + 2048] = ((pf[i:i + 2048, None, :] - po[None, :, :]) ** 2).sum(-1).argmin(1)
    field.albedo = oracle.albedo[nearest]
    field.roughness = oracle.roughness[nearest]
    field.metallic = oracle.metallic[nearest]
    os.makedirs(a.out, exist_ok=True)
    ptir.save_gaussians(os.path.join(a.out, "gaussians.ply"), field)
    shutil.copy(env, os.path.join(a.out, "env.exr"))
    print("%d Gaussians, mean distance to the nearest exact splat %.4f -> %s" % (
        len(field), float(np.sqrt(((pf - po[nearest]) ** 2).sum(-1)).mean()), a.out))


if __name__ == "__main__":
    main()
