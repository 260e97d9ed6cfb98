"""Reach: a rigged humanoid reaches for a target naturally and without hitting anything.

The planner lives in :mod:`reach_addon.core` (pure Python, no ``bpy``). Blender loads this
package as an extension (``blender_manifest.toml``) or, on Blender 3.4–4.1, as a legacy
add-on (``bl_info``); ``bpy`` is imported only when Blender registers it, so the core can
be imported on its own.
"""

bl_info = {
    "name": "Reach",
    "author": "Reach contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > Reach",
    "description": "Collision-free, strength-aware reaching for rigged humanoids",
    "category": "Animation",
}

__version__ = ".".join(map(str, bl_info["version"]))


_cli = []


def register():
    """Called by Blender when the add-on is enabled: the UI, and on Blender 4.2+ the
    ``blender --command reach`` command line."""
    import bpy

    from . import ui

    ui.register()
    # ``blender -c reach`` exists only in the Blender program. Blender as a Python module
    # (the bpy wheel, binary_path "") has no ``-c``, and there a command still registered
    # when Python exits crashes the interpreter (bpy 4.2 and 4.5: segmentation fault).
    if hasattr(bpy.utils, "register_cli_command") and bpy.app.binary_path:
        from .cli import blender_command

        _cli.append(bpy.utils.register_cli_command("reach", blender_command))


def unregister():
    import bpy

    from . import ui

    while _cli:
        bpy.utils.unregister_cli_command(_cli.pop())
    ui.unregister()


def ensure_registered() -> bool:
    """Register Reach's Blender classes unless Blender already has them (an enabled
    add-on or extension); True when this call registered them (the caller unregisters)."""
    import bpy

    if hasattr(bpy.types.Scene, "reach"):
        return False
    register()
    return True
