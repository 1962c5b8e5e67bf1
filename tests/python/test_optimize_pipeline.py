"""The optimise pipeline as one engine layer (src/ptir/pipeline/optimize_pipeline.h): the
Python module's ptir.optimize_pipeline runs what `ptir optimize` runs (same options, same
outputs to the bit), and the progress comes as JSON lines (--progress json) or as the same
events to a callback. On the tiny sphere set of test_optimize_cli.py (6 views of 32x32,
2 spp, 1 thread)."""

import json
import subprocess

import numpy as np
import pytest

from test_optimize_cli import dataset, optimize  # noqa: F401  (the module's fixture and runner)

# What optimize() passes besides its arguments, as keywords (its small defaults).
SMALL = dict(spp=2, threads=1, env_size="16x8")


def _same_outputs(ptir, a, b, fit=False):
    assert (a / "gaussians.ply").read_bytes() == (b / "gaussians.ply").read_bytes()
    ea, eb = ptir.read_image(str(a / "env.exr")), ptir.read_image(str(b / "env.exr"))
    assert ea.shape == eb.shape and np.array_equal(ea, eb)
    losses = [[line.split(",")[:6] for line in (d / "log.csv").read_text().splitlines()] for d in (a, b)]
    assert losses[0] == losses[1] and len(losses[0]) > 1
    if fit:
        assert (a / "fit" / "gaussians.ply").read_bytes() == (b / "fit" / "gaussians.ply").read_bytes()


def _json_lines(text):
    return [json.loads(line) for line in text.splitlines() if line.startswith("{")]


def test_pipeline_writes_what_the_command_writes(ptir, cli, dataset, tmp_path):  # noqa: F811
    """Both stages (a geometry fit of 3 iterations, then 4 of the inversion) from Python and
    from the command line: the same gaussians.ply, fit/gaussians.ply and log losses, byte
    for byte, and the same env.exr pixels."""
    by_cli = tmp_path / "cli"
    optimize(cli, dataset, by_cli, "--iters", 4, "--fit-iters", 3, "--seed", 5)
    by_py = tmp_path / "py"
    events = []
    status = ptir.optimize_pipeline(dataset=dataset, gaussians=dataset / "g.ply", out=str(by_py), iters=4, fit_iters=3,
                                    seed=5, quiet=True, progress_callback=lambda e: events.append(e), **SMALL)
    assert status == "finished"
    _same_outputs(ptir, by_cli, by_py, fit=True)
    # The events: the fit's 3 iterations and its end, the inversion's 4 and its end.
    its = [(e["stage"], e["iteration"], e["total"]) for e in events if e["event"] == "iteration"]
    assert its == [("fit", i, 3) for i in (1, 2, 3)] + [("optimize", i, 4) for i in (1, 2, 3, 4)]
    done = [e for e in events if e["event"] == "done"]
    assert [(d["stage"], d["status"], d["iterations"]) for d in done] == [("fit", "finished", 3), ("optimize", "finished", 4)]
    assert all(isinstance(e["loss"], float) and e["loss"] > 0 for e in events if e["event"] == "iteration")


def test_callback_stops_the_pipeline_and_resume_finishes_it_bit_for_bit(ptir, cli, dataset, tmp_path):  # noqa: F811
    whole = tmp_path / "whole"
    optimize(cli, dataset, whole, "--iters", 5, "--checkpoint-every", 2)
    out = tmp_path / "stopped"

    def stop_after_two(event):
        return not (event["event"] == "iteration" and event["iteration"] == 2)

    assert ptir.optimize_pipeline(dataset=dataset, gaussians=dataset / "g.ply", out=out, iters=5, fit_iters=0,
                                  checkpoint_every=2, quiet=True, progress_callback=stop_after_two, **SMALL) == "cancelled"
    assert len((out / "log.csv").read_text().splitlines()) == 3  # the header and 2 iterations
    assert ptir.optimize_pipeline(dataset=dataset, gaussians=dataset / "g.ply", out=out, iters=5, fit_iters=0,
                                  checkpoint_every=2, quiet=True, resume=True, **SMALL) == "finished"
    _same_outputs(ptir, whole, out)


def test_pipeline_errors(ptir, dataset, tmp_path):  # noqa: F811
    with pytest.raises(TypeError, match="no_such_option"):
        ptir.optimize_pipeline(out=tmp_path / "x", no_such_option=1)
    with pytest.raises(ValueError, match="dataset"):
        ptir.optimize_pipeline(out=tmp_path / "x", quiet=True)
    with pytest.raises(ptir.Error, match="--env-size"):
        ptir.optimize_pipeline(dataset=dataset, gaussians=dataset / "g.ply", out=tmp_path / "y", iters=1, fit_iters=0,
                               quiet=True, spp=2, threads=1, env_size="16by8")

    def fails(event):
        raise RuntimeError("from the callback")

    out = tmp_path / "z"
    with pytest.raises(RuntimeError, match="from the callback"):
        ptir.optimize_pipeline(dataset=dataset, gaussians=dataset / "g.ply", out=out, iters=3, fit_iters=0, quiet=True,
                               progress_callback=fails, **SMALL)
    assert (out / "checkpoint.bin").is_file()  # stopped as Ctrl-C stops: the outputs written


def test_progress_json_lines(cli, dataset, tmp_path):  # noqa: F811
    """--progress json: one object per iteration of each stage instead of the text lines, and the end."""
    r = optimize(cli, dataset, tmp_path / "j", "--iters", 3, "--fit-iters", 2, "--progress", "json")
    assert not [line for line in r.stderr.splitlines() if line.startswith("iter ")]
    events = _json_lines(r.stderr)
    its = [(e["stage"], e["iteration"], e["total"]) for e in events if e["event"] == "iteration"]
    assert its == [("fit", 1, 2), ("fit", 2, 2), ("optimize", 1, 3), ("optimize", 2, 3), ("optimize", 3, 3)]
    first = next(e for e in events if e["event"] == "iteration" and e["stage"] == "optimize")
    for key in ("loss", "image", "tv", "prior", "s_per_iter", "eta_s", "eta", "views"):
        assert key in first, key
    est = [e for e in events if e["event"] == "estimate"]
    assert len(est) == 1 and est[0]["iterations"] == 3 and est[0]["s_per_iter"] > 0
    assert events[-1]["event"] == "done" and events[-1]["status"] == "finished" and events[-1]["iterations"] == 3
    assert "wrote " in r.stderr  # the log lines stay text
    # An error: its JSON line beside the text one.
    r = optimize(cli, dataset, tmp_path / "k", "--iters", 1, "--env-size", "16by8", "--progress", "json", check=False)
    assert r.returncode != 0
    err = [e for e in _json_lines(r.stderr) if e["event"] == "error"]
    assert len(err) == 1 and "--env-size" in err[0]["message"] and "ptir: error:" in r.stderr
    r = optimize(cli, dataset, tmp_path / "m", "--progress", "xml", check=False)
    assert r.returncode != 0 and "--progress must be text or json" in r.stderr


def test_fit_progress_json_lines(cli, dataset, tmp_path):  # noqa: F811
    cmd = [str(cli), "fit", "--dataset", str(dataset), "--gaussians", str(dataset / "g.ply"), "--out", str(tmp_path / "f"),
           "--threads", "1", "--iters", "3", "--progress", "json"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    events = _json_lines(r.stderr)
    assert [(e["stage"], e["iteration"]) for e in events if e["event"] == "iteration"] == [("fit", i) for i in (1, 2, 3)]
    assert all("gaussians" in e for e in events if e["event"] == "iteration")
    assert events[-1] == {"event": "done", "stage": "fit", "status": "finished", "iterations": 3,
                          "out": str(tmp_path / "f")}
