"""Blender UI: properties, operators, presets and the sidebar panel, registered through
one explicit ``classes`` tuple (in registration order: property groups first)."""

import bpy

from . import operators, panels, presets, properties

classes = properties.classes + operators.classes + presets.classes + panels.classes


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    properties.register_properties()
    presets.register_paths()


def unregister():
    presets.unregister_paths()
    properties.unregister_properties()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
