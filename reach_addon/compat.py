"""Work-arounds for differences between the Blender versions Reach supports."""

from __future__ import annotations

import os
import sys


def module_exit_crashes() -> bool:
    """True where Blender as a Python module (the bpy wheel) crashes while Python shuts
    down once a property with a Python callback (``update``, ``get``/``set``, ``poll``)
    has been registered, even if it was unregistered again: bpy 4.2 and 4.5 (segmentation
    fault, exit status 139); fixed in 5.0. The Blender program is not affected."""
    import bpy

    return not bpy.app.binary_path and bpy.app.version < (5, 0, 0)


def exit_module_blender(code: int) -> None:
    """Exit with ``code``. Where :func:`module_exit_crashes`, streams are flushed and the
    process ends without Python's shutdown (``os._exit``), so the caller sees ``code``
    instead of the crash; the work is all written by then."""
    if module_exit_crashes():
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(int(code or 0))
    sys.exit(code)
