"""The View3D sidebar tab "Reach". The main panel holds what every reach needs (armature,
arm, task, target, obstacles, Plan and Bake); the last result, timing, bake options, live
mode, bones and planner settings are sub-panels, all but the result collapsed by default.
Every label fits the sidebar at its default width: short labels, the rest in tooltips
(``tests/binary/test_gui_panel.py`` reads each label as Blender drew it)."""

from __future__ import annotations

import textwrap

import bpy

from ..blender import live
from ..core.settings import GROUPS, fields
from .operators import result_lines
from .properties import BONE_PREFIX, OVERRIDES, ROLE_LABELS, SIDES

#: Share of a sub-panel's row given to a property's label, the value taking the rest.
LABEL_SHARE = 0.6


class _Reach:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Reach"


def _row(layout, data, name, text=None):
    """One property as a row: a checkbox with its label across the row, or a label (right
    aligned, as Blender's own) beside its value."""
    prop = data.bl_rna.properties[name]
    text = prop.name if text is None else text
    if prop.type == "BOOLEAN":
        layout.prop(data, name, text=text)
        return
    split = layout.split(factor=LABEL_SHARE)
    label = split.row()
    label.alignment = "RIGHT"
    label.label(text=text)
    split.prop(data, name, text="")


def _chars(context):
    """About how many characters of label text fit across the sidebar."""
    scale = context.preferences.system.ui_scale
    pixels = context.region.width if context.region else 300
    return max(16, int((pixels - 40 * scale) / (5.9 * scale)))


def _wrapped(layout, lines, width):
    """Lines as labels, each wrapped to ``width`` characters (its continuation indented
    under it), so that none is clipped. The Result's and Live's text alike: labels with no
    icon, whose width :func:`_chars` is measured for (an icon beside them took the room
    of several characters, and Blender clipped the middle of Live's lines)."""
    col = layout.column(align=True)
    for line in lines:
        indent = " " * (len(line) - len(line.lstrip()))
        parts = textwrap.wrap(line.strip(), max(8, width - len(indent) - 2)) or [""]
        for j, part in enumerate(parts):
            col.label(text=indent + ("  " if j else "") + part)


class REACH_PT_main(_Reach, bpy.types.Panel):
    bl_label = "Reach"

    def draw(self, context):
        props = context.scene.reach
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column()
        col.prop(props, "armature")
        col.prop(props, "arm")
        col.prop(props, "task")
        if props.task in {"SEQUENCE", "GUIDED"}:
            col.prop(props, "targets")
            if props.targets is None:
                col.prop(props, "target")
        else:
            col.prop(props, "target")
        col.column(heading="Match").prop(props.settings, "match_orientation", text="Orientation")
        col.prop(props, "obstacles")
        if props.obstacles == "COLLECTION":
            col.prop(props, "obstacle_collection", text="Collection")

        if props.running:
            # The progress where the buttons were (they cannot run meanwhile), in a row as
            # high: the panel keeps its size, so the sidebar does not slide the panels
            # below it (several more redraws) when a run starts and ends.
            row = layout.split(factor=0.75, align=True)
            row.scale_y = 1.4
            text = props.status or "planning"
            if hasattr(row, "progress"):                      # Blender 4.0+
                row.progress(factor=props.progress, text=text)
            else:
                row.label(text=f"{props.progress * 100:.0f}% {text}")
            row.label(text="Esc", icon="CANCEL")
            return
        row = layout.row(align=True)
        row.scale_y = 1.4
        row.operator("reach.plan", text="Plan", icon="CURVE_PATH")
        row.operator("reach.bake", text="Bake", icon="KEYINGSET")
        row.operator("reach.clear", text="", icon="X")


class REACH_PT_result(_Reach, bpy.types.Panel):
    bl_label = "Result"
    bl_parent_id = "REACH_PT_main"

    @classmethod
    def poll(cls, context):
        return bool(getattr(context.scene, "reach", None) and context.scene.reach.last_result)

    def draw(self, context):
        _wrapped(self.layout, result_lines(context.scene.reach), _chars(context))


class REACH_PT_timing(_Reach, bpy.types.Panel):
    bl_label = "Timing"
    bl_parent_id = "REACH_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        props = context.scene.reach
        col = self.layout.column()
        _row(col, props, "use_current_frame")
        if not props.use_current_frame:
            _row(col, props, "frame_start")
        if props.task != "CHASE":
            _row(col, props, "auto_duration")
            if not props.auto_duration:
                _row(col, props, "duration")


class REACH_PT_options(_Reach, bpy.types.Panel):
    bl_label = "Options"
    bl_parent_id = "REACH_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        props = context.scene.reach
        col = self.layout.column()
        for name in ("new_action", "bake_closest", "show_guides"):
            _row(col, props, name)


class REACH_PT_live(_Reach, bpy.types.Panel):
    bl_label = "Live"
    bl_parent_id = "REACH_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        props = context.scene.reach
        layout = self.layout
        on = live.is_active(context.scene)
        row = layout.row(align=True)
        row.scale_y = 1.2
        row.operator("reach.live", text="Live", icon="REC" if on else "PLAY", depress=on)
        sub = row.row(align=True)
        sub.enabled = on
        sub.operator("reach.key_pose", text="Key (K)", icon="KEY_HLT")
        _row(layout, props, "live_budget_ms")
        lines = live.status_lines() if on or not live.is_active() else []
        _wrapped(layout, lines, _chars(context))


class REACH_PT_bones(_Reach, bpy.types.Panel):
    bl_label = "Bones"
    bl_parent_id = "REACH_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        props = context.scene.reach
        layout = self.layout
        row = layout.row(align=True)
        row.menu("REACH_MT_rigs_presets", text="Rig maps")
        row.operator("reach.rigs_preset_add", text="", icon="ADD")
        row.operator("reach.rigs_preset_add", text="", icon="REMOVE").remove_active = True
        layout.operator("reach.detect_bones", icon="VIEWZOOM")
        layout.prop(props, "use_overrides")
        col = layout.column()
        col.enabled = props.use_overrides
        arm = props.armature
        bones = arm.data if arm is not None and arm.type == "ARMATURE" else None
        for name in OVERRIDES:
            role = name.removeprefix(BONE_PREFIX)
            side = next((s for s in SIDES if role.endswith("_" + s)), None)
            if side and role.startswith("clavicle"):
                col.label(text=f"{side.capitalize()} arm")
            text = ROLE_LABELS[role.removesuffix("_" + side) if side else role]
            split = col.split(factor=LABEL_SHARE - 0.15)
            label = split.row()
            label.alignment = "RIGHT"
            label.label(text=text)
            if bones is not None:
                split.prop_search(props, name, bones, "bones", text="")
            else:
                split.prop(props, name, text="")


def _settings_panel(group, label, preset_kind=None):
    names = [f.name for f in fields() if f.metadata["group"] == group]

    def draw(self, context):
        layout = self.layout
        if preset_kind:
            row = layout.row(align=True)
            row.menu(f"REACH_MT_{preset_kind}_presets", text=f"{preset_kind.capitalize()} presets")
            row.operator(f"reach.{preset_kind}_preset_add", text="", icon="ADD")
            row.operator(f"reach.{preset_kind}_preset_add", text="",
                         icon="REMOVE").remove_active = True
        settings = context.scene.reach.settings
        col = layout.column()
        for n in names:
            _row(col, settings, n)

    return type(f"REACH_PT_settings_{group}", (_Reach, bpy.types.Panel), {
        "bl_label": label,
        "bl_parent_id": "REACH_PT_settings",
        "bl_options": {"DEFAULT_CLOSED"},
        "draw": draw,
    })


class REACH_PT_settings(_Reach, bpy.types.Panel):
    bl_label = "Planner Settings"
    bl_parent_id = "REACH_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        self.layout.label(text="Lengths are in arm lengths")


_LABELS = {"strength": ("Strength", "strength"), "limits": ("Joint Limits", "body"),
           "body": ("Body Rotation", "body"), "step": ("Stepping", None),
           "ik": ("Inverse Kinematics", None),
           "collision": ("Collisions", None), "search": ("Search", None),
           "workspace": ("Workspace", None), "motion": ("Motion", None),
           "orientation": ("Orientation", "orientation")}

classes = (REACH_PT_main, REACH_PT_result, REACH_PT_timing, REACH_PT_options, REACH_PT_live,
           REACH_PT_bones, REACH_PT_settings) + tuple(
    _settings_panel(g, *_LABELS[g]) for g in GROUPS)
