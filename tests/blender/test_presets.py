"""Presets through Blender's preset system: bundled ones from the extension, users' own in
the user folder."""

from pathlib import Path

import bpy
import pytest


def menu_files(kind):
    out = {}
    for folder in bpy.utils.preset_paths(f"reach/{kind}"):
        for path in Path(folder).glob("*.py"):
            out[path.stem] = path
    return out


def run(kind, name):
    bpy.ops.script.execute_preset(filepath=str(menu_files(kind)[name]),
                                  menu_idname=f"REACH_MT_{kind}_presets")


def test_bundled_presets_are_visible(fresh, addon):
    assert {"Paper_Defaults", "Cautious", "Relaxed"} <= set(menu_files("strength"))
    assert {"AAOS_Adult", "Reduced_Mobility", "No_Body_Rotation", "Feet_Planted"} <= \
        set(menu_files("body"))
    assert {"Mixamo", "Unreal_Mannequin", "VRM_Humanoid"} <= set(menu_files("rigs"))


def test_every_bundled_preset_sets_every_setting_of_its_kind(fresh, addon):
    """A preset that leaves a setting out leaves it as the user had it: *AAOS Adult* would
    not reset a setting added after it was written."""
    presets = __import__(addon.__name__ + ".ui.presets", fromlist=["KINDS"])
    for kind, (_group, names) in presets.KINDS.items():
        for name, path in menu_files(kind).items():
            text = path.read_text()
            missing = [n for n in names if f"reach.{n} = " not in text]
            assert not missing, (kind, name, missing)


def test_strength_and_body_presets_set_the_planner_settings(fresh, addon):
    settings = bpy.context.scene.reach.settings
    defaults = addon.core.Settings()
    strength = addon.core.strength
    run("strength", "Cautious")
    assert settings.preferred_level_h == pytest.approx(strength.strength_horizontal(45.0), abs=1e-4)
    assert settings.preferred_level_v == pytest.approx(strength.strength_vertical(45.0), abs=1e-4)
    run("body", "No_Body_Rotation")
    assert settings.chest_rotation is False
    run("body", "Feet_Planted")             # the whole body: lean, hips back, squat, gaze
    assert settings.lean and settings.squat and settings.lean_hips_back and settings.gaze
    assert settings.chest_rotation is True
    run("strength", "Paper_Defaults")
    run("body", "AAOS_Adult")
    restored = addon.ui.properties.settings_from(settings)   # Blender keeps 32-bit floats
    for name, value in defaults.to_dict().items():
        expected = value if isinstance(value, (str, bool)) else pytest.approx(value, rel=1e-6)
        assert getattr(restored, name) == expected, name


def test_rig_map_preset_fills_the_bone_fields(fresh, addon):
    run("rigs", "Mixamo")
    props = bpy.context.scene.reach
    assert props.use_overrides
    assert props.bone_upper_arm_right == "mixamorig:RightArm"
    assert props.bone_hand_left == "mixamorig:LeftHand"


def test_user_presets_are_saved_in_the_user_folder_and_reload(fresh, addon, tmp_path):
    settings = bpy.context.scene.reach.settings
    settings.weight_gamma = 3.25
    settings.elbow_side = "prefer"
    assert bpy.ops.reach.strength_preset_add(name="Study 7") == {"FINISHED"}
    saved = menu_files("strength")["Study_7"]
    assert str(saved).startswith(bpy.utils.resource_path("USER"))
    settings.weight_gamma = 1.0
    settings.elbow_side = "require"
    run("strength", "Study_7")
    assert settings.weight_gamma == pytest.approx(3.25) and settings.elbow_side == "prefer"
    # and through the helper the command line uses
    settings.weight_gamma = 1.0
    addon.ui.presets.apply("strength", "Study 7")
    assert settings.weight_gamma == pytest.approx(3.25)
