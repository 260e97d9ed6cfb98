"""Blender UI: properties, operators, presets and the sidebar panel, registered through
one explicit ``classes`` tuple (in registration order: property groups first)."""

import bpy

from . import envelope, operators, panels, presets, properties

classes = (properties.classes + envelope.property_groups + operators.classes + presets.classes
           + panels.classes + envelope.classes)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    properties.register_properties()
    envelope.register_properties()
    presets.register_paths()


def unregister():
    presets.unregister_paths()
    envelope.unregister_properties()
    properties.unregister_properties()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
