"""Perturb a 3DGS PLY the way the geometry stage's tests start (issue 12):
jittered positions, scales multiplied or divided by 1.5 per axis, a random
rotation about each Gaussian's shortest axis (its normal), opacities 0.5.

    /usr/bin/python3 scripts/perturb_splats.py IN.ply OUT.ply [--jitter 0.5] [--seed 0]

--jitter: position noise standard deviation as a multiple of each Gaussian's
largest scale (isotropic). Reads binary little-endian PLYs whose vertex
properties are all float32 (what trainers and the dataset maker write).
"""

import argparse
import sys

import numpy as np


def read_ply(path):
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline()
            if not line:
                sys.exit(f"{path}: truncated header")
            line = line.decode("ascii").strip()
            header.append(line)
            if line == "end_header":
                break
        body = f.read()
    if "format binary_little_endian 1.0" not in header:
        sys.exit(f"{path}: only binary little-endian PLY is supported")
    names, count = [], 0
    for line in header:
        parts = line.split()
        if parts[:2] == ["element", "vertex"]:
            count = int(parts[2])
        elif parts[0] == "element":
            sys.exit(f"{path}: unexpected element {parts[1]}")
        elif parts[0] == "property":
            if parts[1] != "float":
                sys.exit(f"{path}: property {parts[-1]} is {parts[1]}, expected float")
            names.append(parts[2])
    data = np.frombuffer(body, dtype="<f4", count=count * len(names)).reshape(count, len(names)).copy()
    return names, data, [h for h in header if h.startswith("comment")]


def write_ply(path, names, data, comments=()):
    lines = ["ply", "format binary_little_endian 1.0", *comments, f"element vertex {len(data)}"]
    lines += [f"property float {n}" for n in names] + ["end_header"]
    with open(path, "wb") as f:
        f.write(("\n".join(lines) + "\n").encode("ascii"))
        f.write(np.ascontiguousarray(data, dtype="<f4").tobytes())


def quat_mul(a, b):
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)


def perturb(names, data, jitter=0.5, seed=0):
    rng = np.random.default_rng(seed)
    col = {n: i for i, n in enumerate(names)}
    out = data.copy()
    log_s = data[:, [col["scale_0"], col["scale_1"], col["scale_2"]]]
    smax = np.exp(log_s.max(axis=1))
    for k, n in enumerate("xyz"):
        out[:, col[n]] += rng.normal(size=len(data)) * jitter * smax
    # Scales x or / 1.5 per axis.
    for k in range(3):
        out[:, col[f"scale_{k}"]] += np.log(1.5) * rng.choice([-1.0, 1.0], size=len(data))
    # A rotation about the local shortest axis: q' = q * (cos a/2, sin a/2 e_k).
    q = data[:, [col["rot_0"], col["rot_1"], col["rot_2"], col["rot_3"]]]
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    k = log_s.argmin(axis=1)
    a = rng.uniform(-np.pi, np.pi, size=len(data))
    r = np.zeros((len(data), 4), dtype=np.float32)
    r[:, 0] = np.cos(a / 2)
    r[np.arange(len(data)), 1 + k] = np.sin(a / 2)
    qn = quat_mul(q, r)
    for j in range(4):
        out[:, col[f"rot_{j}"]] = qn[:, j]
    out[:, col["opacity"]] = 0.0  # logit(0.5)
    # Normals in the file would survive the perturbation: clear them.
    for n in ("nx", "ny", "nz"):
        if n in col:
            out[:, col[n]] = 0.0
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("input")
    p.add_argument("output")
    p.add_argument("--jitter", type=float, default=0.5)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args()
    names, data, comments = read_ply(a.input)
    write_ply(a.output, names, perturb(names, data, a.jitter, a.seed), comments)


if __name__ == "__main__":
    main()
