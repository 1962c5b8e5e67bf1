"""A child process's output pipes, read as lines on the caller's own thread: no Python threads.

Why no reader threads: Blender 3.x releases Python's GIL while an operator called
from Python runs (bpy.ops), and inside a context override (temp_override) it then
decides whether it must take the GIL back by asking whether *any* thread holds it
(PyC_IsInterpreterActive reads the interpreter's current thread state). A Python
thread of ours that holds the GIL at that instant, reading a progress line, makes
Blender's main thread go on without it, and the next dictionary lookup crashes
Blender (seen as a segfault in _PyErr_Fetch under bpy.ops.ed.undo_push). So the
add-on reads its children's output when it polls them (modal timers, waits),
never on a thread of its own.

    pipes = PipeLines({"out": proc.stdout, "err": proc.stderr})
    for key, line in pipes.pump(timeout=0.05):   # waits up to 50 ms for the first bytes
        ...

Lines end at "\\n" or "\\r" (progress bars redraw with carriage returns); empty
lines are dropped. A pipe that reaches its end gives its unfinished last line.
"""

import os
import select
import time


class PipeLines:
    def __init__(self, streams):
        """streams: {key: a readable pipe (a file object of subprocess.Popen)}."""
        self._fds = {}
        self._buf = {}
        for key, stream in streams.items():
            fd = stream.fileno()
            os.set_blocking(fd, False)
            self._fds[fd] = key
            self._buf[fd] = b""

    @property
    def closed(self):
        """True when every pipe has reached its end."""
        return not self._fds

    def wait(self, timeout):
        """Blocks up to `timeout` seconds until a pipe has bytes (or its end) to read; once every pipe has
        ended, it just sleeps (so a caller's polling loop never spins)."""
        if timeout <= 0:
            return
        if not self._fds:
            time.sleep(timeout)
            return
        try:
            select.select(list(self._fds), [], [], timeout)
        except (OSError, ValueError):  # a pipe closed under us: the next read says so
            pass

    def read(self):
        """What has arrived, without blocking: a list of (key, line) in arrival order per pipe."""
        lines = []
        for fd in list(self._fds):
            key = self._fds[fd]
            while True:
                try:
                    chunk = os.read(fd, 1 << 16)
                except BlockingIOError:
                    break
                except OSError:
                    chunk = b""
                if not chunk:  # the end: the writer closed it (exited)
                    lines += [(key, l) for l in _split(self._buf.pop(fd), final=True)[0]]
                    del self._fds[fd]
                    break
                done, self._buf[fd] = _split(self._buf[fd] + chunk)
                lines += [(key, l) for l in done]
        return lines

    def pump(self, timeout=0.0):
        """wait(timeout), then read()."""
        self.wait(timeout)
        return self.read()


def _split(buf, final=False):
    """(complete lines decoded, the unfinished rest) of buf; final: the rest is a line too."""
    parts = buf.replace(b"\r", b"\n").split(b"\n")
    rest = b"" if final else parts.pop()
    lines = [p.decode("utf-8", errors="replace") for p in parts if p.strip()]
    return lines, rest
