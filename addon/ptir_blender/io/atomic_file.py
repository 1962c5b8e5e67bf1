"""Writing a file atomically: to a temporary name next to it, then renamed into place.

A reader (the engine, Blender, another job) never sees a half-written file, and a
failed write leaves the old file (if any) as it was and no temporary behind. The
Python side of the engine's ptir/io/atomic_file.h, with its temporary naming
(".<stem>.ptir-tmp-<pid><ext>" beside the target), so the engine's clean-up of stale
temporaries covers the add-on's too.
"""

import os


def write_atomic(path, parts, error):
    """Writes the bytes objects `parts` one after the other to `path`; returns path.

    error: the PtirError subclass raised (naming the file) when the file cannot be written.
    """
    path = os.fspath(path)
    folder, name = os.path.split(path)
    stem, ext = os.path.splitext(name)
    tmp = os.path.join(folder, ".%s.ptir-tmp-%d%s" % (stem, os.getpid(), ext))
    try:
        with open(tmp, "wb") as f:
            for part in parts:
                f.write(part)
        os.replace(tmp, path)
    except OSError as e:
        try:
            os.remove(tmp)
        except OSError:
            pass
        raise error("%s: cannot write (%s)" % (path, e.strerror or e)) from e
    return path
