"""Makes the family's datasets (bench/family_def.py, docs/family.md) with the dataset maker in the
member's Blender (3.4: Debian's `blender`; 4.5: PyPI bpy, tests/blender/blenders.py), one at a time.
A bench step, not part of `make test`:

    python3 bench/make_family.py [--out out/family] [--only NAME,...] [--half tuning|heldout]
                                 [--threads N] [--force] [--colour-test]

A member whose folder already holds dataset.json is kept (--force remakes it). Each set lands in
OUT/<name>/ with the maker's log beside it (OUT/<name>.log).
"""

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(REPO / "tests" / "blender"))

import blenders  # noqa: E402
import family_def  # noqa: E402

MAKER = REPO / "scripts" / "make_dataset.py"


def make(member, out, threads=0, force=False):
    """Makes member's set into out/<name>; returns (folder, seconds, made)."""
    folder = Path(out) / member["name"]
    if (folder / "dataset.json").exists() and not force:
        return folder, 0.0, False
    if not blenders.available(member["blender"]):
        raise RuntimeError(blenders.why_missing(member["blender"]))
    args = family_def.dataset_args(member, folder) + ["--threads", str(threads)]
    cmd = blenders.command(member["blender"], MAKER, args)
    t0 = time.time()
    with open(str(folder) + ".log", "w") as log:
        rc = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT).returncode
    if rc != 0 or not (folder / "dataset.json").exists():
        raise RuntimeError("making %s failed (exit %d): see %s.log" % (member["name"], rc, folder))
    return folder, time.time() - t0, True


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default=str(REPO / "out" / "family"))
    p.add_argument("--only", default="", help="comma-separated member names")
    p.add_argument("--half", choices=("tuning", "heldout"))
    p.add_argument("--threads", type=int, default=0, help="Cycles threads (0: all)")
    p.add_argument("--force", action="store_true")
    p.add_argument("--colour-test", action="store_true", help="the test's member only")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    todo = [family_def.COLOUR_TEST] if a.colour_test else family_def.members()
    if a.only:
        todo = [m for m in todo if m["name"] in a.only.split(",")]
    if a.half:
        todo = [m for m in todo if m.get("half") == a.half]
    for m in todo:
        folder, secs, made = make(m, a.out, a.threads, a.force)
        print("%-16s %s %s" % (m["name"], "made in %.0f s" % secs if made else "kept", folder), flush=True)


if __name__ == "__main__":
    main()
