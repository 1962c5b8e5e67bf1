"""The add-on reads its children's output on the polling thread, never on a Python thread of its own
(addon/ptir_blender/io/pipe_lines.py says why: a thread of ours holding the GIL while Blender runs an
operator called from Python inside a context override crashes Blender 3.x). Real child processes: the
lines come whole and in order across carriage returns, chunk boundaries and an unfinished last line;
more output than a pipe holds does not stall the child; the exit status and the last lines survive;
and neither the job nor the persistent engine starts a thread."""

import math
import sys
import threading
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "addon"))
from ptir_blender.io import cli as cli_mod  # noqa: E402
from ptir_blender.io.engine_process import EngineProcess  # noqa: E402
from ptir_blender.io.pipe_lines import _split  # noqa: E402


def test_split_lines():
    assert _split(b"a\r\nb\rc") == (["a", "b"], b"c")
    assert _split(b"a\r\nb\rc", final=True) == (["a", "b", "c"], b"")
    assert _split(b"\n\n  \n") == ([], b"")


def test_child_job_reads_everything_without_a_thread():
    # 300,000 progress redraws (~7 MB): 100 pipe buffers' worth, then a log line with no newline.
    script = ("import sys\n"
              "for i in range(300000): sys.stdout.write('\\rstep %d' % i)\n"
              "sys.stdout.write('\\nlast words'); sys.stdout.flush(); sys.exit(3)\n")
    seen = []

    def parse(line, progress):
        if line.startswith("step "):
            seen.append((progress, int(line[5:])))
            return True
        return False

    threads = threading.active_count()
    job = cli_mod.ChildJob([sys.executable, "-c", script], parse=parse)
    assert threading.active_count() == threads
    assert job.wait(timeout=120) == 3
    assert threading.active_count() == threads
    assert job.lines[-1] == "last words" and job.lines[-2] == "step 299999"
    assert len(job.lines) <= 200
    steps = [n for p, n in seen if p is job.progress]  # (the job also parses its kept line)
    assert steps == list(range(300000))  # each line once, whole, in order


def test_child_job_cancel_and_timeout():
    job = cli_mod.ChildJob([sys.executable, "-c", "import time\nprint('up', flush=True)\ntime.sleep(60)"])
    assert job.wait(timeout=0.5) is None and job.poll() is None
    for _ in range(200):  # its first line (a loaded machine may take a while to start Python)
        if job.lines:
            break
        job.wait(timeout=0.05)
    rc = job.cancel(grace=5.0)
    assert rc is not None and rc != 0 and job.lines[:1] == ["up"]


def test_engine_without_a_thread(cli, tmp_path):
    threads = threading.active_count()
    engine = EngineProcess(str(cli))
    try:
        assert threading.active_count() == threads
        r = engine.wait(engine.send({"cmd": "load", "scene": str(tmp_path / "missing.json")}), timeout=30)
        assert not r["ok"] and "missing.json" in r["error"]
        assert engine.alive() and threading.active_count() == threads
    finally:
        engine.close()
    assert not engine.alive()


def test_optimize_progress_of_a_real_capture_names_its_subject():
    """The capture stage's event (`ptir fit` and `ptir optimize --progress json` on a real capture) names
    the subject for the Optimise panel; the iterations' progress is read after it."""
    p = cli_mod.Progress()
    assert cli_mod.parse_optimize_progress('{"event":"target","stage":"capture","view":21,"total":84,"elapsed_s":9.5}', p)
    assert p.text == "capture: photo 21/84 measured against the splat" and not p.targets and p.fraction == 0.0
    assert cli_mod.parse_optimize_progress('{"event":"subject","subject":"object","covered":0.21}', p)
    assert p.subject == "object against a background"
    cli_mod.parse_optimize_progress('{"event":"iteration","stage":"optimize","iteration":1,"total":2,"loss":0.10163,'
                                    '"image":0.10163,"tv":0.0,"prior":0.0,"s_per_iter":1.99,"eta_s":2.0,"eta":"2.0s",'
                                    '"views":"IMG_3510"}', p)
    assert abs(p.fraction - 0.5) < 1e-9 and p.subject == "object against a background"
    q = cli_mod.Progress()
    cli_mod.parse_optimize_progress('{"event":"subject","subject":"scene","covered":0.97}', q)
    assert q.subject == "scene"


def test_optimize_progress_events():
    """The engine's own JSON lines (an estimate, radiance targets, iterations with a NaN loss, the end,
    an error) as the Optimise panel reads them; text lines are the log, not progress."""
    p = cli_mod.Progress()
    assert not cli_mod.parse_optimize_progress("optimize: surface model principled-v2", p)
    assert not cli_mod.parse_optimize_progress("iter 1/2  loss 0.1  1.99 s/iter  ETA 2.0s", p)
    assert not cli_mod.parse_optimize_progress('{"estimate": {"setup_s": 1.0}}', p)  # --estimate's stdout line
    cli_mod.parse_optimize_progress('{"event":"target","stage":"radiance","view":12,"total":24,"elapsed_s":3.0}', p)
    assert p.targets and abs(p.fraction - 0.05) < 1e-9 and "view 12/24" in p.text
    cli_mod.parse_optimize_progress('{"event":"estimate","s_per_iter":0.5,"iterations":400,"eta_s":200.0,'
                                    '"eta":"3m20s"}', p)
    assert p.estimate == "3m20s" and "400 iterations" in p.text
    cli_mod.parse_optimize_progress('{"event":"iteration","stage":"optimize","iteration":200,"total":400,"loss":null,'
                                    '"s_per_iter":0.5,"eta_s":100.0,"eta":"1m40s"}', p)
    assert math.isnan(p.loss) and abs(p.fraction - 0.55) < 1e-9 and p.eta == "1m40s" and p.iteration == 200
    assert cli_mod.parse_optimize_progress('{"event":"done","stage":"optimize","status":"finished","iterations":400,'
                                           '"out":"/o"}', p)
    assert cli_mod.parse_optimize_progress('{"event":"error","message":"/d: no such folder"}', p)
    assert p.error == "/d: no such folder"
