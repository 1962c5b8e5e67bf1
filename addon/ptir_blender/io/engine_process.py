"""The persistent engine: a `ptir serve` child process and its line protocol, without bpy.

One process per Blender session holds the loaded scene (Gaussians, meshes, lights,
world, acceleration structure); the viewport and F12 send it requests and read
its replies (docs/engine_protocol.md). A native crash ends that process only:
Blender sees `alive()` turn false and starts a new one.

    engine = EngineProcess(cli_path, out_dir=folder)  # outputs only under `folder`
    rid = engine.send({"cmd": "load", "scene": "/tmp/x/scene.json"})
    reply = engine.wait(rid, timeout=60)            # {"ok": true, "gaussians": ...}
    rid = engine.send({"cmd": "render", "view": {...}, "spp": 1, "output": folder + "/p.raw"})
    engine.reply(rid)                               # None until it has come (non-blocking)

Requests are answered in order; a long render also sends interim progress lines
(`progress`, and `wait(..., on_progress=...)`). Bulk data never travels in the JSON line: the
request names a file (in /dev/shm when it exists) that the engine reads or writes.
Every request's bytes (the line plus bulk files written for it) are counted per
command in `sent_bytes`, so tests and benchmarks can show that an edit sends a delta.
"""

import json
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time

from ..errors import JobError
from .cli import wait_or_kill
from .pipe_lines import PipeLines


def _pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


def remove_stale_dirs(base, prefix):
    """Removes folders `prefix*` in base left by Blender sessions that ended without cleaning up
    (a crash, a kill): their owner.pid names a process that no longer exists."""
    try:
        names = [n for n in os.listdir(base) if n.startswith(prefix)]
    except OSError:
        return
    for name in names:
        folder = os.path.join(base, name)
        try:
            with open(os.path.join(folder, "owner.pid")) as f:
                pid = int(f.read().strip())
        except (OSError, ValueError):
            continue
        if not _pid_alive(pid):
            shutil.rmtree(folder, ignore_errors=True)


def bulk_dir(prefix="ptir_engine_"):
    """A fresh folder for request files: in shared memory (/dev/shm) when the system has it. It holds
    owner.pid (this process), so a later session can remove it if this one ends without cleaning up."""
    base = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else tempfile.gettempdir()
    remove_stale_dirs(base, prefix)
    folder = tempfile.mkdtemp(prefix=prefix, dir=base)
    with open(os.path.join(folder, "owner.pid"), "w") as f:
        f.write(str(os.getpid()))
    return folder


class EngineDied(JobError):
    pass


class EngineProcess:
    """`ptir serve` as a child: send() returns a request id; its replies and log are read whenever they
    are asked for (reply, wait, send), on the asking thread, never on a thread of its own (pipe_lines.py
    says why). The lock makes that safe from two threads (the viewport's and a final render's)."""

    def __init__(self, cli_path, threads=0, log_path=None, start_timeout=30.0, out_dir=None):
        """out_dir: the folder the engine writes its render outputs in (`serve --out`): requests name files
        under it, and the engine replaces only files it wrote itself (default: the working directory)."""
        args = [cli_path, "serve"]
        if threads > 0:
            args += ["--threads", str(int(threads))]
        if out_dir:
            args += ["--out", str(out_dir)]
        self.args = args
        self._lock = threading.Lock()
        self._replies = {}
        self._next_id = 1
        self._stderr_tail = []
        self.progress = {}    # request id -> fraction done (long renders report it)
        self.sent_bytes = {}  # command -> bytes sent (request lines + bulk files)
        self.requests = {}    # command -> number sent
        self._log = open(log_path, "a") if log_path else None
        try:
            self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=subprocess.PIPE, bufsize=0)
        except OSError as e:
            raise JobError("cannot start the PTIR engine %s: %s" % (cli_path, e.strerror or e))
        self._pipes = PipeLines({"reply": self.proc.stdout, "log": self.proc.stderr})
        self._ready = False
        deadline = time.monotonic() + start_timeout
        while not self._ready and self.proc.poll() is None and time.monotonic() < deadline:
            self._pump(0.05)
        self._pump()
        if not self._ready:
            raise EngineDied("the PTIR engine did not start: %s" % self.death_message())

    # ---------------------------------------------------------------- reading

    def _pump(self, timeout=0.0):
        """Reads what the engine has written (waiting up to `timeout` s for it): replies and progress
        into their tables, log lines into the tail and the log file."""
        self._pipes.wait(timeout)
        with self._lock:
            for key, line in self._pipes.read():
                if key == "log":
                    self._stderr_tail.append(line)
                    del self._stderr_tail[:-50]
                    if self._log:
                        self._log.write(line + "\n")
                        self._log.flush()
                    continue
                try:
                    reply = json.loads(line)
                except ValueError:
                    continue
                if reply.get("ready"):
                    self._ready = True
                elif "progress" in reply and "ok" not in reply:
                    self.progress[reply.get("id")] = float(reply["progress"])  # interim line of a render
                elif "id" in reply:
                    self._replies[reply["id"]] = reply

    def _pump_to_end(self, seconds=2.0):
        """After the process has ended: its last lines (the pipes end once it has gone)."""
        end = time.monotonic() + seconds
        while not self._pipes.closed and time.monotonic() < end:
            self._pump(0.05)

    # ---------------------------------------------------------------- requests

    def alive(self):
        return self.proc.poll() is None

    def send(self, request, bulk_bytes=0):
        """Sends one request (a dict; an "id" is added); returns the id. bulk_bytes: the size of the
        files written for it (counted in sent_bytes)."""
        self._pump()  # keeps the pipes drained, so the engine never waits on a full one
        with self._lock:
            rid = self._next_id
            self._next_id += 1
        line = (json.dumps(dict(request, id=rid), separators=(",", ":")) + "\n").encode()
        cmd = request.get("cmd", "?")
        with self._lock:
            self.sent_bytes[cmd] = self.sent_bytes.get(cmd, 0) + len(line) + int(bulk_bytes)
            self.requests[cmd] = self.requests.get(cmd, 0) + 1
        try:
            self.proc.stdin.write(line)
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError, ValueError):
            raise EngineDied(self.death_message())
        return rid

    def cancel(self, rid):
        """Stops request rid if it is running or still queued (its reply says "cancelled")."""
        try:
            self.send({"cmd": "cancel", "target": int(rid)})
        except EngineDied:
            pass

    def reply(self, rid, pop=True):
        """The reply to rid, or None while it has not come. Raises EngineDied when the process ended
        without answering."""
        self._pump()
        with self._lock:
            r = self._replies.pop(rid, None) if pop else self._replies.get(rid)
        if r is None and not self.alive():
            self._pump_to_end()  # its last lines may still be in the pipe
            with self._lock:
                r = self._replies.pop(rid, None) if pop else self._replies.get(rid)
            if r is None:
                raise EngineDied(self.death_message())
        return r

    def wait(self, rid, timeout=None, should_cancel=None, kill_after=5.0, on_progress=None):
        """Blocks until the reply to rid comes (EngineDied if the process ends first, JobError on
        timeout). should_cancel: polled every 50 ms; when it returns True the request is cancelled,
        and when the engine has not stopped it `kill_after` seconds later, the process is killed
        (the reply is then {"ok": false, "cancelled": true, "killed": true}). on_progress(fraction):
        called on each poll while the request reports progress."""
        deadline = None if timeout is None else time.monotonic() + timeout
        cancelled = None
        while True:
            self._pump(0.05)
            with self._lock:
                r = self._replies.pop(rid, None)
            if r is not None:
                self.progress.pop(rid, None)
                return r
            if on_progress is not None and rid in self.progress:
                on_progress(self.progress[rid])
            if cancelled is not None and time.monotonic() - cancelled > kill_after and self.alive():
                self.proc.kill()
                self.proc.wait()
                return {"id": rid, "ok": False, "cancelled": True, "killed": True}
            if not self.alive():
                return self.reply(rid)
            if should_cancel is not None and cancelled is None and should_cancel():
                self.cancel(rid)
                cancelled = time.monotonic()
            if deadline is not None and time.monotonic() > deadline:
                raise JobError("the PTIR engine did not answer within %.0f s" % timeout)

    def call(self, request, timeout=None, bulk_bytes=0, should_cancel=None):
        """send + wait; raises JobError with the engine's message when the reply is an error."""
        r = self.wait(self.send(request, bulk_bytes), timeout, should_cancel)
        if not r.get("ok") and not r.get("cancelled"):
            raise JobError("PTIR engine: %s" % r.get("error", "request failed"))
        return r

    def death_message(self):
        rc = self.proc.poll()
        if rc is not None:
            self._pump_to_end()
        with self._lock:
            tail = [l for l in self._stderr_tail if l.strip()][-2:]
        if rc is None:
            what = "not responding"
        elif rc < 0:
            try:
                what = "died (%s)" % signal.Signals(-rc).name
            except ValueError:
                what = "died (signal %d)" % -rc
        else:
            what = "exited (status %d)" % rc
        return "the PTIR engine process %s%s" % (what, (": " + " | ".join(tail)) if tail else "")

    def close(self, grace=2.0):
        if self.alive():
            try:
                self.proc.stdin.write(b'{"cmd":"quit"}\n')
                self.proc.stdin.flush()
                self.proc.stdin.close()
            except (OSError, ValueError):
                pass
            wait_or_kill(self.proc, grace)
        if self._log:
            self._log.close()
            self._log = None
