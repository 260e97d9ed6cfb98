"""The View3D sidebar tab "Reach": inputs, buttons, last result; bones and planner
settings in sub-panels, collapsed by default."""

from __future__ import annotations

import textwrap

import bpy

from ..blender import live
from ..core.settings import GROUPS, fields
from .operators import result_lines
from .properties import OVERRIDES


class _Reach:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Reach"


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
        col.prop(props.settings, "match_orientation")
        col.prop(props, "obstacles")
        if props.obstacles == "COLLECTION":
            col.prop(props, "obstacle_collection", text="Collection")
        col.separator()
        col.prop(props, "use_current_frame")
        if not props.use_current_frame:
            col.prop(props, "frame_start")
        if props.task != "CHASE":
            col.prop(props, "auto_duration")
            if not props.auto_duration:
                col.prop(props, "duration")
        col.prop(props, "new_action")
        col.prop(props, "bake_closest")
        col.prop(props, "show_guides")

        row = layout.row(align=True)
        row.scale_y = 1.4
        row.operator("reach.plan", text="Plan", icon="CURVE_PATH")
        row.operator("reach.bake", text="Bake", icon="KEYINGSET")
        row.operator("reach.clear", text="", icon="X")
        if props.running:
            box = layout.box()
            if hasattr(box, "progress"):                      # Blender 4.0+
                box.progress(factor=props.progress, text=props.status or "planning")
            else:
                box.label(text=f"{props.progress * 100:.0f}% {props.status}")
            box.label(text="Esc to cancel", icon="CANCEL")

        box = layout.box()
        on = live.is_active(context.scene)
        row = box.row(align=True)
        row.scale_y = 1.2
        row.operator("reach.live", text="Live", icon="REC" if on else "PLAY", depress=on)
        sub = row.row(align=True)
        sub.enabled = on
        sub.operator("reach.key_pose", text="Key (K)", icon="KEY_HLT")
        box.prop(props, "live_budget_ms")
        lines = live.status_lines() if on or not live.is_active() else []
        scale = context.preferences.system.ui_scale
        pixels = context.region.width if context.region else 300
        width = max(16, int((pixels - 50 * scale) / (7.4 * scale)))     # characters per line
        col = box.column(align=True)
        for k, line in enumerate(lines):
            for j, part in enumerate(textwrap.wrap(line, width) or [""]):
                col.label(text=part, icon="INFO" if k == 0 and j == 0 else "BLANK1")


class REACH_PT_result(_Reach, bpy.types.Panel):
    bl_label = "Result"
    bl_parent_id = "REACH_PT_main"

    @classmethod
    def poll(cls, context):
        return bool(getattr(context.scene, "reach", None) and context.scene.reach.last_result)

    def draw(self, context):
        col = self.layout.column(align=True)
        for line in result_lines(context.scene.reach):
            col.label(text=line)


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
        for name in OVERRIDES:
            if arm is not None and arm.type == "ARMATURE":
                col.prop_search(props, name, arm.data, "bones")
            else:
                col.prop(props, name)


def _settings_panel(group, label, preset_kind=None):
    names = [f.name for f in fields() if f.metadata["group"] == group]

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        if preset_kind:
            row = layout.row(align=True)
            row.menu(f"REACH_MT_{preset_kind}_presets", text=f"{preset_kind.capitalize()} presets")
            row.operator(f"reach.{preset_kind}_preset_add", text="", icon="ADD")
            row.operator(f"reach.{preset_kind}_preset_add", text="",
                         icon="REMOVE").remove_active = True
        settings = context.scene.reach.settings
        for n in names:
            layout.prop(settings, n)

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
           "body": ("Body Rotation", "body"), "ik": ("Inverse Kinematics", None),
           "collision": ("Collisions", None), "search": ("Search", None),
           "workspace": ("Workspace", None), "motion": ("Motion", None),
           "orientation": ("Orientation", "orientation")}

classes = (REACH_PT_main, REACH_PT_result, REACH_PT_bones, REACH_PT_settings) + tuple(
    _settings_panel(g, *_LABELS[g]) for g in GROUPS)
