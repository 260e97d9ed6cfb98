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


def register():
    """Called by Blender when the add-on is enabled."""
    from . import ui

    ui.register()


def unregister():
    from . import ui

    ui.unregister()
