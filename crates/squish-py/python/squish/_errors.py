"""The exceptions of the package (raised by the native module ``squish._squish`` too)."""


class SquishError(Exception):
    """A failure of the deformer or of a run (the base of every exception of the package)."""


class ParameterError(SquishError, ValueError):
    """A parameter that cannot be set: unknown key, wrong kind, out of range, or an invalid
    combination. The message names the key with its prefix (``a.stiffness``), the value, what is
    valid and the default, as ``squish deform --set`` prints it."""


class InputError(SquishError, ValueError):
    """A mesh or a file that cannot be used: malformed arrays or files, meshes the deformer
    cannot process, scene files with mistakes. The message names the element and the fix."""
