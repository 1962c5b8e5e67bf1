#!/usr/bin/env python3
"""Where the inversion loses quality: `ptir optimize` + `ptir eval` on one Cycles
dataset under a set of ablations, one table row each.

    bench/ablate_inversion.py --dataset out/sample_dataset [--build build] [--out out/ablate]
        [--iters 300] [--spp 8] [--rows base,gt_env,gt_normals,...] [--eval-spp 32]

Rows (each changes one thing against `base`, the given iterations x spp; the rows of
options since removed -- --env-adam, --lambda-env-smooth/-chroma,
--env-fine-warmup, --light-solve, --ssim-cross, --average-from, --huber-delta -- are at commit aa311c4, their tables in docs/inversion.md):
    base          ptir optimize with the defaults but --iters/--spp
    gt_env        the true training environment given and frozen (--env-init + --fix-env, its level kept: --env-align yaw)
    gt_normals    the true (face) normals in the PLY (oracle/gaussians.ply; its materials are not used)
    gt_both       both of the above
    spp4          4x the samples per pixel
    iters4        4x the iterations
    views4        4 views per iteration
    views4_eq     4 views per iteration at a quarter of the spp (the same samples per iteration)
    no_tv         edge-aware TV off (--lambda-tv 0)
    linear_loss   the image loss on linear values
    lr_decay      the learning rate decays to 0.1x over the second half (--lr-final 0.1)
    coarse        a 16x8 coarse level learnt with the 128x64 texels (--env-coarse 16)
    coarse8/32    the coarse level 8x4 / 32x16
    coarse_lr     coarse and lr_decay together
    sg            24 spherical Gaussians instead of texels (--env sg)
    warmup        light first: material rates ramp up over the first quarter (--albedo-warmup 0.25)
    tv_warmup     TV weight 10x at the start, falling to 1x at half the iterations (--tv-warmup 10)
    init_albedo3/5/7  the albedo starts at 0.3 (PTIR's, the default) / 0.5 / 0.7 (--init-albedo)
    balance       learn the light-albedo balance (--light-balance 1); no_balance: without it (--light-balance 0)
    balance10     the balance's rate 0.1 instead of 0.03 (--lr-balance 0.1)
    lr_env3       the environment's rate 3x (--lr-env 0.105)
    correlated    one set of samples for the loss and its replay (--decorrelate-adjoint 0)
    fine_rate25/50  the fine environment texels at 25 % / 50 % of the coarse level's rate (--env-fine-rate)
    no_ssim       the image loss without its D-SSIM term (--lambda-ssim 0, the default now); ssim: PTIR's 0.2
    no_blur       the render not blurred before the loss (--loss-blur 0); no_ssim_blur: both
    blur_both     the target blurred like the render (--loss-blur-target 1, the default now); blur_both_no_ssim: and no
                  D-SSIM; blur_render_only: the render alone blurred (--loss-blur-target 0, the default before)
    oracle        no optimisation: the true materials (the dataset's oracle/), the ceiling
Extra optimize flags for every row: --extra "...".

Prints a Markdown table (albedo PSNR foreground sRGB / linear and TensoIR's protocol,
relight PSNR, roughness MSE, normal MAE, albedo scale, minutes) and writes it to
OUT/ablation.md. Runs are kept in OUT/<row>/ and reused when their settings match.
"""

import argparse
import json
import os
import shlex
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

ROWS = {
    "base": [],
    "gt_env": ["--env-init", "{env}", "--fix-env", "--env-align", "yaw"],
    "gt_normals": ["--gaussians", "{oracle_ply}"],
    "gt_both": ["--env-init", "{env}", "--fix-env", "--env-align", "yaw", "--gaussians", "{oracle_ply}"],
    "spp4": ["--spp", "{spp4}"],
    "iters4": ["--iters", "{iters4}"],
    "views4": ["--views-per-iter", "4"],
    "views4_eq": ["--views-per-iter", "4", "--spp", "{spp_quarter}"],
    "no_tv": ["--lambda-tv", "0"],
    "linear_loss": ["--loss-space", "linear"],
    "lr_decay": ["--lr-final", "0.1"],
    "coarse": ["--env-coarse", "16"],
    "no_coarse": ["--env-coarse", "0"],
    "coarse8": ["--env-coarse", "8"],
    "coarse32": ["--env-coarse", "32"],
    "coarse_lr": ["--env-coarse", "16", "--lr-final", "0.1"],
    "sg": ["--env", "sg"],
    "warmup": ["--albedo-warmup", "0.25"],
    "no_warmup": ["--albedo-warmup", "0"],
    "warmup50": ["--albedo-warmup", "0.5"],
    "warmup75": ["--albedo-warmup", "0.75"],
    "tv_warmup": ["--tv-warmup", "10"],
    "init_albedo3": ["--init-albedo", "0.3"],
    "init_albedo5": ["--init-albedo", "0.5"],
    "init_albedo7": ["--init-albedo", "0.7"],
    "balance": ["--light-balance", "1"],
    "no_balance": ["--light-balance", "0"],
    "balance3_s50": ["--light-balance", "1", "--lr-balance", "0.03", "--balance-start", "0.5"],
    "balance10": ["--lr-balance", "0.1"],
    "balance3_s25": ["--light-balance", "1", "--lr-balance", "0.03", "--balance-start", "0.25"],
    "lr_env3": ["--lr-env", "0.105"],
    "lr_env_half": ["--lr-env", "0.0175"],
    "lr_env_full": ["--lr-env", "0.035"],
    "lr_env_quarter": ["--lr-env", "0.00875"],
    "correlated": ["--decorrelate-adjoint", "0"],
    "bounces3": ["--bounces", "3"],
    "bounces4": ["--bounces", "4"],
    "fine_rate25": ["--env-fine-rate", "0.25"],
    "fine_rate50": ["--env-fine-rate", "0.5"],
    "no_ssim": ["--lambda-ssim", "0"],
    "blur_render_only": ["--loss-blur-target", "0"],
    "ssim": ["--lambda-ssim", "0.2"],
    "no_blur": ["--loss-blur", "0"],
    "blur_both": ["--loss-blur-target", "1"],
    "blur_both_no_ssim": ["--loss-blur-target", "1", "--lambda-ssim", "0"],
    "no_ssim_blur": ["--lambda-ssim", "0", "--loss-blur", "0"],
}


def run(cmd, log):
    with open(log, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        sys.exit("ablate: failed (%s), see %s" % (" ".join(cmd[:2]), log))


def optimise(a, row, out_dir, meta):
    env = os.path.join(a.dataset, meta["envmaps"][meta["train_env"]])
    subst = {"env": env, "oracle_ply": os.path.join(a.dataset, "oracle", "gaussians.ply"),
             "spp4": str(4 * a.spp), "spp_quarter": str(max(1, a.spp // 4)), "iters4": str(4 * a.iters)}
    row_flags = [f.format(**subst) for f in ROWS[row]] + shlex.split(a.extra)
    # The row's own --iters / --spp replace the run's (the CLI takes each once).
    flags = [f for opt, val in (("--iters", a.iters), ("--spp", a.spp)) if opt not in row_flags for f in (opt, str(val))]
    flags += row_flags
    if "--gaussians" not in flags:
        flags += ["--gaussians", os.path.join(a.dataset, "gaussians.ply")]
    cmd = [a.ptir, "optimize", "--dataset", a.dataset, "--out", os.path.join(out_dir, "result"), "--seed", str(a.seed),
           "-q", "--force"] + flags
    stamp = os.path.join(out_dir, "command.txt")
    if os.path.exists(os.path.join(out_dir, "result", "eval", "metrics.json")) and \
            os.path.exists(stamp) and open(stamp).read() == " ".join(cmd):
        return json.load(open(os.path.join(out_dir, "minutes.json")))["minutes"]
    os.makedirs(out_dir, exist_ok=True)
    t = time.time()
    run(cmd, os.path.join(out_dir, "optimize.log"))
    minutes = (time.time() - t) / 60
    json.dump({"minutes": minutes}, open(os.path.join(out_dir, "minutes.json"), "w"))
    evaluate(a, os.path.join(out_dir, "result"), meta, os.path.join(out_dir, "eval.log"))
    open(stamp, "w").write(" ".join(cmd))
    return minutes


def evaluate(a, result, meta, log):
    relight = []
    for name in meta.get("relight_envs", []):
        relight += ["--relight", "%s=%s" % (name, os.path.join(a.dataset, meta["envmaps"][name]))]
    run([a.ptir, "eval", "--dataset", a.dataset, "--result", result, "--spp", str(a.eval_spp), "-q", "--force",
         "--sheet-views", "4"] + relight, log)


def fmt(v, d):
    return "n/a" if v is None else ("%%.%df" % d) % v


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dataset", required=True)
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    p.add_argument("--out", default=os.path.join(ROOT, "out", "ablate"))
    p.add_argument("--iters", type=int, default=300)
    p.add_argument("--spp", type=int, default=8)
    p.add_argument("--eval-spp", type=int, default=32)
    p.add_argument("--seed", type=int, default=0, help="optimisation seed (run-to-run spread: run twice)")
    p.add_argument("--rows", default="oracle,base,gt_env,gt_normals,gt_both,spp4,iters4,views4,no_tv")
    p.add_argument("--extra", default="", help="more optimize flags for every row")
    a = p.parse_args()
    a.dataset = os.path.abspath(a.dataset)
    a.ptir = os.path.join(os.path.abspath(a.build), "bin", "ptir")
    meta = json.load(open(os.path.join(a.dataset, "dataset.json")))
    rows = [r for r in a.rows.split(",") if r]
    for r in rows:
        if r != "oracle" and r not in ROWS:
            p.error("unknown row '%s' (choose from oracle, %s)" % (r, ", ".join(ROWS)))
    table = ["| row | albedo fg sRGB / linear | albedo TensoIR | relight | NVS | rough MSE | normal MAE | albedo scale | min |",
             "|---|---:|---:|---:|---:|---:|---:|---|---:|"]
    for r in rows:
        out_dir = os.path.join(a.out, r)
        if r == "oracle":
            result = os.path.join(a.dataset, "oracle")
            os.makedirs(out_dir, exist_ok=True)
            evaluate(a, result, meta, os.path.join(out_dir, "eval.log"))
            minutes = 0.0
        else:
            minutes = optimise(a, r, out_dir, meta)
            result = os.path.join(out_dir, "result")
        m = json.load(open(os.path.join(result, "eval", "metrics.json")))
        rel = [v["psnr"] for v in m.get("relight", {}).values()]
        table.append("| %s | %s / %s | %s | %s | %s | %s | %s | %s | %.1f |" % (
            r, fmt(m.get("albedo_psnr"), 2), fmt(m.get("albedo_psnr_linear"), 2), fmt(m.get("albedo_psnr_tensoir"), 2),
            fmt(sum(rel) / len(rel) if rel else None, 2), fmt(m.get("nvs_psnr"), 2), fmt(m.get("roughness_mse"), 4),
            fmt(m.get("normal_mae_deg"), 2), " ".join("%.2f" % s for s in (m.get("albedo_scale") or [])), minutes))
        print(table[-1] if len(table) > 3 else "\n".join(table), flush=True)
    head = "dataset %s; optimise %d iterations x %d spp (+ row changes); eval %d spp\n\n" % (
        a.dataset, a.iters, a.spp, a.eval_spp)
    open(os.path.join(a.out, "ablation.md"), "w").write(head + "\n".join(table) + "\n")
    print("\n" + head + "\n".join(table))


if __name__ == "__main__":
    main()
