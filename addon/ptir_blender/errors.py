"""The add-on's errors: one base class, PtirError, and one subclass per kind of problem.

Every error the add-on raises for bad input or a failed job derives from PtirError, and
every operator and the render engine catch PtirError: whatever goes wrong (a malformed
splat PLY, a mesh that cannot be written, a scene that cannot be exported, a job that
failed) is reported with its message and the scene is left unchanged, never a traceback.
The message always names the file or object and the problem.

The subclasses keep the built-in base they had (ValueError for bad data, RuntimeError for
things that went wrong while doing something), so code catching those still works. They
live here, not in the modules raising them, so that the io/ modules (no bpy) and the
blender/ modules share them without import cycles; each module re-exports its own
(splat_ply.SplatPlyError, ...).
"""


class PtirError(Exception):
    """Base of every error the add-on reports to the user; the message says what is wrong."""


# io/ (no bpy)

class SplatPlyError(PtirError, ValueError):
    """A file that is not a readable splat PLY, or data that cannot be written; the message says why."""


class MeshPlyError(PtirError, ValueError):
    """A mesh that cannot be written or a file that cannot be read; the message names it."""


class SplatError(PtirError, ValueError):
    """Bad input for the surface-to-splats conversion or its writer; the message says what."""


class TransformError(PtirError, ValueError):
    """An object transform that cannot be folded into splats (singular, projective, non-finite)."""


class SceneFileError(PtirError, ValueError):
    """A scene that cannot be written as a scene file; the message says what."""


class DatasetError(PtirError, ValueError):
    """A dataset that cannot be read or written; the message names the file and the problem."""


class JobError(PtirError, RuntimeError):
    """A job that cannot start or that failed; the message says why (with the tool's own error line)."""


# blender/ (bpy)

class SplatObjectError(PtirError, RuntimeError):
    """An object that is not a usable splat object; the message names it and what is wrong."""


class ExportError(PtirError, RuntimeError):
    """Something in the Blender scene that cannot be exported; the message names it."""


class OptimizeError(PtirError, RuntimeError):
    """Optimiser inputs that cannot be prepared or outputs that cannot be used; the message says what."""
