"""The extension as a user gets it: built by ``make dist``, installed from the zip,
registered through one ``classes`` tuple, removed cleanly."""

import zipfile
from pathlib import Path

import bpy


def test_zip_holds_manifest_package_and_presets(addon_zip):
    names = set(zipfile.ZipFile(addon_zip).namelist())
    assert {"blender_manifest.toml", "__init__.py", "core/ik.py", "blender/bake.py",
            "ui/panels.py", "presets/reach/strength/Paper_Defaults.py"} <= names
    assert not any("__pycache__" in n or n.endswith(".pyc") for n in names)


def test_installed_as_an_extension_with_its_own_package_name(addon):
    assert addon.__name__ == "bl_ext.user_default.reach_addon"
    assert hasattr(bpy.types.Scene, "reach")
    # No module name is hard-coded: the code works under whatever name Blender gives it.
    src = Path(addon.__file__).parent
    for path in list(src.glob("ui/*.py")) + list(src.glob("blender/*.py")) + [src / "__init__.py"]:
        assert '"reach_addon' not in path.read_text(), path.name


def test_every_operator_is_searchable_and_undoable(addon):
    ops = [c for c in addon.ui.classes if issubclass(c, bpy.types.Operator)]
    ours = [c for c in ops if c.bl_idname in {"reach.plan", "reach.bake", "reach.clear",
                                              "reach.detect_bones"}]
    assert len(ours) == 4
    for cls in ours:
        assert cls.__name__.startswith("REACH_OT_")
        assert {"REGISTER", "UNDO"} <= set(cls.bl_options)
        assert "INTERNAL" not in cls.bl_options and cls.bl_label
        assert cls.__doc__, "the tooltip and F3 search text come from the docstring"
    for cls in addon.ui.classes:
        assert cls.is_registered, cls.__name__


def test_disabling_unregisters_everything(addon, fresh):
    module = addon.__name__
    classes = addon.ui.classes
    try:
        bpy.ops.preferences.addon_disable(module=module)
        assert not hasattr(bpy.types.Scene, "reach")
        assert [c.__name__ for c in classes if c.is_registered] == []
        assert not any("reach" in p for p in bpy.utils.preset_paths("reach/strength")
                       if "extensions" in p)
    finally:
        bpy.ops.preferences.addon_enable(module=module)
    assert hasattr(bpy.types.Scene, "reach")
    assert bpy.ops.reach.bake.poll() is False      # enabled again, waiting for input
