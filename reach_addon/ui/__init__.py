"""Blender UI: properties, operators, presets and the sidebar panel, registered through
one explicit ``classes`` tuple (in registration order: property groups first), plus the
``blender --command reach`` command line on Blender 4.2+."""

import bpy

from . import operators, panels, presets, properties

classes = properties.classes + operators.classes + presets.classes + panels.classes
_cli = []


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    properties.register_properties()
    presets.register_paths()
    # ``blender -c reach`` exists only in the Blender program. Blender as a Python module
    # (the bpy wheel, binary_path "") has no ``-c``, and there a command still registered
    # when Python exits crashes the interpreter (bpy 4.2 and 4.5: segmentation fault).
    if hasattr(bpy.utils, "register_cli_command") and bpy.app.binary_path:
        from ..cli import blender_command

        _cli.append(bpy.utils.register_cli_command("reach", blender_command))


def unregister():
    while _cli:
        bpy.utils.unregister_cli_command(_cli.pop())
    presets.unregister_paths()
    properties.unregister_properties()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
