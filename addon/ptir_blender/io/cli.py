"""The engine's command-line tool as a child process, without bpy.

Long jobs (final renders, optimisations) run in `ptir` child processes so that a
crash in the native engine can never take Blender (and the artist's unsaved
work) down. A ChildJob starts the command, reads its output whenever it is polled and
parses progress lines into a small state object that the caller (a modal
operator's timer, a render engine loop, or a blocking loop in blender -b) polls:

    job = ChildJob([cli, "render", "scene.json", "-o", "out.exr"], parse=parse_render_progress)
    while job.poll() is None:
        print(job.progress.fraction, job.progress.text)
        time.sleep(0.1)

Progress formats:
    render:   "\\rrender rgb [#####     ]  45.0%  1.2s  ETA 1.5s"  (carriage-return redraws)
    optimize, fit (--progress json, src/ptir/pipeline/progress_printer.h; docs/engine_protocol.md):
              {"event":"iteration","stage":"optimize","iteration":12,"total":800,"loss":0.04321,...}
"""

import json
import os
import re
import shutil
import signal
import subprocess
import time

from ..errors import JobError
from .pipe_lines import PipeLines

_ADDON_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def wait_or_kill(proc, grace):
    """Waits up to `grace` seconds for a process told to stop, then kills it."""
    try:
        proc.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def bundled_cli():
    """The copy of `ptir` inside the add-on (bin/ptir, with its libraries in lib/), or None.

    Blender installs an extension or a legacy add-on zip with Python's zipfile, which drops the
    files' permissions: the first call gives the bundled binary back its execute bit.
    """
    path = os.path.join(_ADDON_DIR, "bin", "ptir")
    if not os.path.isfile(path):
        return None
    if not os.access(path, os.X_OK):
        try:
            os.chmod(path, os.stat(path).st_mode | 0o755)
        except OSError as e:
            raise JobError("the add-on's own ptir command '%s' is not executable and cannot be made so (%s): "
                           "reinstall the add-on, or set the command in the add-on preferences" % (path, e)) from e
    return path


def find_cli(preferred=""):
    """The `ptir` executable: the preference, the copy inside the add-on (bin/ptir), $PTIR_CLI, PATH.

    The first that is an executable file wins (looked at in that order, so a preference that
    names one overrides the bundled copy).
    """
    candidates = []
    if preferred:
        candidates.append(lambda: os.path.expanduser(preferred))
    candidates.append(bundled_cli)
    candidates.append(lambda: os.environ.get("PTIR_CLI"))
    candidates.append(lambda: shutil.which("ptir"))
    for candidate in candidates:
        path = candidate()
        if path and os.path.isfile(path) and os.access(path, os.X_OK):
            return os.path.abspath(path)
    if preferred:
        raise JobError("the ptir command '%s' (add-on preference) is not an executable file" % preferred)
    raise JobError("cannot find the engine's command-line tool 'ptir': not in %s, $PTIR_CLI or PATH "
                   "(reinstall the add-on from its zip, run scripts/install_addon.sh, or set it in the "
                   "add-on preferences)" % os.path.join(_ADDON_DIR, "bin"))


class Progress:
    """What the job reported last: fraction in [0, 1], a one-line text, and parsed numbers."""

    def __init__(self):
        self.fraction = 0.0
        self.text = ""
        self.iteration = None
        self.iterations = None
        self.loss = None
        self.seconds_per_iteration = None
        self.eta = ""
        self.targets = False   # optimize without --dataset: radiance targets were rendered first
        self.estimate = ""     # optimize's own duration estimate ("4m05s"), once printed
        self.subject = ""      # a real capture's splat: "object against a background" or "scene"
        self.error = ""        # the engine's error message (its "error" event), once reported


_RENDER_RE = re.compile(r"\]\s*([0-9.]+)%\s+([0-9.]+)s\s+ETA\s+([0-9.]+)s")
TARGET_SHARE = 0.1  # of the progress bar, for the radiance targets (no --dataset) before the iterations
SUBJECTS = {"object": "object against a background", "scene": "scene"}


def parse_render_progress(line, progress):
    """Updates progress from one render progress redraw; returns True when it was one."""
    m = _RENDER_RE.search(line)
    if not m:
        return False
    progress.fraction = min(1.0, float(m.group(1)) / 100.0)
    progress.eta = m.group(3) + " s"
    progress.text = "%.0f%%, %s s elapsed, ETA %s s" % (float(m.group(1)), m.group(2), m.group(3))
    return True


def parse_optimize_progress(line, progress):
    """Updates progress from one progress line of `ptir optimize` or `ptir fit` run with --progress json
    (one JSON object per line, docs/engine_protocol.md "Progress lines": a real capture's subject, the
    radiance targets, the duration estimate, the iterations, the end or the error); returns True when it
    was one. Other lines are the log."""
    if not line.startswith('{"event"'):
        return False
    try:
        e = json.loads(line)
    except ValueError:
        return False
    kind = e.get("event")
    if kind == "subject":
        progress.subject = SUBJECTS.get(e.get("subject"), e.get("subject", ""))
        progress.text = "capture: " + progress.subject
    elif kind == "target" and e.get("stage") == "capture":
        done, total = int(e["view"]), int(e["total"])
        progress.text = "capture: photo %d/%d measured against the splat" % (done, total)
    elif kind == "target":
        done, total = int(e["view"]), int(e["total"])
        progress.targets = True
        progress.fraction = TARGET_SHARE * done / max(1, total)
        progress.text = "rendering the splats' radiance: view %d/%d" % (done, total)
    elif kind == "estimate":
        progress.estimate = e["eta"]
        progress.text = "estimated %s for %d iterations" % (e["eta"], e["iterations"])
    elif kind == "iteration":
        it, total = int(e["iteration"]), int(e["total"])
        progress.iteration, progress.iterations = it, total
        progress.loss = float("nan") if e.get("loss") is None else float(e["loss"])
        progress.seconds_per_iteration = float(e.get("s_per_iter") or 0.0)
        progress.eta = e.get("eta", "?")
        progress.fraction = min(1.0, it / max(1, total))
        if progress.targets:
            progress.fraction = TARGET_SHARE + (1.0 - TARGET_SHARE) * progress.fraction
        progress.text = "iteration %d/%d, loss %.5f, %.2f s/iter, ETA %s" % (it, total, progress.loss,
                                                                           progress.seconds_per_iteration, progress.eta)
    elif kind == "error":
        progress.error = e.get("message", "")
    return True


class ChildJob:
    """A `ptir` child process whose output (stdout and stderr together) is read when it is polled.

    poll(): None while running, else the exit status. cancel(): asks it to stop
    (SIGINT: the optimiser finishes its iteration and exits 130; other commands
    end at once), then kills it after `grace` seconds. Lines are kept (the last
    200) for error messages; `echo` prints each progress/log line as it comes
    (blender -b shows the progress on its console). The output is read on the
    caller's thread by poll() and wait(), never on a thread of its own
    (pipe_lines.py says why), so `progress` is as new as the last poll.
    """

    def __init__(self, args, parse=None, cwd=None, echo=False, log_path=None, env=None):
        self.args = [str(a) for a in args]
        self.progress = Progress()
        self.lines = []
        self.cancelled = False
        self._parse = parse
        self._echo = echo
        self._log = open(log_path, "w") if log_path else None
        try:
            self.proc = subprocess.Popen(self.args, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                         stderr=subprocess.STDOUT, env=env)
        except OSError as e:
            if self._log:
                self._log.close()
            raise JobError("cannot start %s: %s" % (self.args[0], e.strerror or e))
        self.started = time.monotonic()
        self._pipes = PipeLines({"out": self.proc.stdout})

    def _pump(self, timeout=0.0):
        for _, line in self._pipes.pump(timeout):
            self._line(line)

    def _line(self, line):
        is_progress = self._parse(line, self.progress) if self._parse else False
        if not is_progress or not self.lines or not self._parse(self.lines[-1], Progress()):
            self.lines.append(line)
        else:
            self.lines[-1] = line  # keep one line per redrawn progress bar
        del self.lines[:-200]
        if self._log:
            self._log.write(line + "\n")
            self._log.flush()
        if self._echo:
            print("ptir: " + line, flush=True)

    def poll(self):
        self._pump()
        rc = self.proc.poll()
        if rc is not None:
            end = time.monotonic() + 5.0  # its last lines: the pipe ends when the process has gone
            while not self._pipes.closed and time.monotonic() < end:
                self._pump(0.05)
            if self._log and not self._log.closed:
                self._log.close()
        return rc

    def wait(self, timeout=None):
        """Waits for the end (reading the output meanwhile); the exit status, or None after `timeout` s."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.proc.poll() is None:
            left = 0.05 if deadline is None else min(0.05, deadline - time.monotonic())
            if left <= 0:
                return None
            self._pump(left)
            if self._pipes.closed:  # nothing more to read: the process is ending
                try:
                    self.proc.wait(timeout=max(left, 0.001))
                except subprocess.TimeoutExpired:
                    pass
        return self.poll()

    def cancel(self, grace=10.0):
        """Stops the job: SIGINT, then SIGKILL after `grace` seconds; returns the exit status."""
        self.cancelled = True
        if self.proc.poll() is None:
            try:
                self.proc.send_signal(signal.SIGINT)
            except OSError:
                pass
            if self.wait(timeout=grace) is None:
                self.proc.kill()
                self.proc.wait()
        return self.poll()

    def error_message(self):
        """The tool's own error line ("ptir: error: ...") or the last lines it printed."""
        lines = list(self.lines)
        errors = [l for l in lines if "error" in l.lower()]
        if errors:
            return errors[-1].strip()
        tail = " | ".join(l.strip() for l in lines[-3:])
        rc = self.proc.returncode
        if rc is not None and rc < 0:
            try:
                name = signal.Signals(-rc).name
            except ValueError:
                name = "signal %d" % -rc
            return "the engine process died (%s)%s" % (name, (": " + tail) if tail else "")
        return tail or "exit status %s" % rc

    def run_blocking(self, on_progress=None, interval=0.5, should_cancel=None):
        """Waits for the end, calling on_progress(progress) every `interval` seconds; returns the exit status."""
        last = None
        while True:
            rc = self.wait(timeout=interval)
            if rc is not None:
                return rc
            if should_cancel is not None and should_cancel():
                return self.cancel()
            if on_progress is not None and self.progress.text != last:
                last = self.progress.text
                on_progress(self.progress)
