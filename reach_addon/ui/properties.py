"""Blender properties: the planner settings (generated from
:class:`~reach_addon.core.Settings`, so defaults, ranges and descriptions have one source)
and the per-scene Reach inputs (armature, arm, targets, obstacles, task, bake options,
bone overrides, last result, live mode), with what they describe: :func:`request_from`
(the pipeline request of Plan and Bake) and :func:`set_live` (live mode on or off, for the
Live operator and the ``live`` property's setter)."""

from __future__ import annotations

import json

import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty,
                       StringProperty)

from ..blender import live, pipeline
from ..blender.scene import VIZ_TAG
from ..core import ReachError, Settings
from ..core.live import DEFAULT_BUDGET_S
from ..core.settings import fields

ROLE_LABELS = {
    "chest": "Chest",
    "clavicle": "Clavicle",
    "upper_arm": "Upper arm",
    "forearm": "Forearm",
    "hand": "Hand",
}
SIDES = ("right", "left")
#: The bone override properties are this prefix and the role they name (bone_chest, ...).
BONE_PREFIX = "bone_"
#: Names of the bone override properties: chest, then each arm role per side.
OVERRIDES = [BONE_PREFIX + "chest"] + [f"{BONE_PREFIX}{role}_{side}" for side in SIDES
                                       for role in ("clavicle", "upper_arm", "forearm", "hand")]


def _settings_annotations():
    out = {}
    for f in fields():
        meta = f.metadata
        # The unit goes into the tooltip: the label must fit the sidebar.
        unit = {"deg": "degrees", "s": "seconds", "m": "metres"}.get(meta["unit"], meta["unit"])
        doc = meta["doc"] + (f" (in {unit})" if unit else "")
        kw = {"name": meta["label"], "description": doc, "default": f.default}
        if "choices" in meta:
            out[f.name] = EnumProperty(
                items=[(c, c.capitalize(), meta["doc"]) for c in meta["choices"]], **kw)
        elif isinstance(f.default, bool):
            out[f.name] = BoolProperty(**kw)
        elif isinstance(f.default, int):
            out[f.name] = IntProperty(min=meta["min"], max=meta["max"], **kw)
        else:
            out[f.name] = FloatProperty(min=meta["min"], max=meta["max"],
                                        precision=4 if 0 < abs(f.default) < 0.1 else 2, **kw)
    return out


REACH_PG_settings = type("REACH_PG_settings", (bpy.types.PropertyGroup,), {
    "__annotations__": _settings_annotations(),
    "__doc__": "Planner settings (see reach_addon.core.Settings)",
})


def settings_from(group) -> Settings:
    """The core Settings of a REACH_PG_settings group."""
    return Settings(**{f.name: getattr(group, f.name) for f in fields()})


def settings_to(group, settings: Settings) -> None:
    for f in fields():
        setattr(group, f.name, getattr(settings, f.name))


def _is_armature(_self, ob):
    return ob.type == "ARMATURE"


#: Object types the Target field leaves out: a character's rig, and the scene's cameras,
#: lights and speakers are never what a hand reaches for (reach for an Empty instead,
#: parented to a bone if it must move with one).
NOT_TARGETS = frozenset({"ARMATURE", "CAMERA", "LIGHT", "LIGHT_PROBE", "SPEAKER"})


def _is_target(_self, ob):
    """What the Target field offers: any object but armatures, cameras, lights, speakers
    and Reach's own display (its trajectory, markers, guiding nodes)."""
    return ob.type not in NOT_TARGETS and not ob.get(VIZ_TAG)


def _not_reach_display(_self, coll):
    """What the collection fields offer: any collection but Reach's own display."""
    return not coll.get(VIZ_TAG)


def _live_get(self):
    return live.is_active(self.id_data)


def _live_set(self, value):
    """Scripts may set ``scene.reach.live``; errors cannot be reported from a setter, so
    they go to the console and the panel's Live status."""
    if bool(value) == live.is_active(self.id_data):
        return
    try:
        set_live(bpy.context, bool(value))
    except Exception as exc:       # a setter must not raise into Blender
        live.note_error(f"Live: {exc}" if isinstance(exc, ReachError) else
                        f"Live stopped by an internal error: {exc}")
        print(f"Reach Live: {exc}")


def _live_inputs_update(self, context):
    """A new armature, arm or target while Live is on: Live follows the new one (the pose on
    screen stays)."""
    if live.is_active(self.id_data):
        try:
            set_live(context, True)
        except Exception as exc:   # an update callback must not raise into Blender
            live.stop(push_undo=True)
            live.note_error(f"Live stopped: {exc}")


def _live_budget_update(self, _context):
    st = live.state()
    if st is not None and st.scene == self.id_data.name:
        st.budget_s = self.live_budget_ms / 1000.0


def _scene_annotations():
    ann = {
        "armature": PointerProperty(name="Armature", type=bpy.types.Object, poll=_is_armature,
                                    description="The character to pose",
                                    update=_live_inputs_update),
        "arm": EnumProperty(name="Arm", default="AUTO", update=_live_inputs_update, items=[
            ("AUTO", "Auto", "The arm nearer the (first) target"),
            ("RIGHT", "Right", "The character's right arm"),
            ("LEFT", "Left", "The character's left arm")]),
        "task": EnumProperty(name="Task", default="REACH", items=[
            ("REACH", "Reach", "Collision-free reach to the target (each target on its own)"),
            ("SEQUENCE", "Sequence", "Several targets in order, each from where the last ended"),
            ("GUIDED", "Guided", "Reach through the guiding nodes of the workspace grid"),
            ("CHASE", "Chase", "Follow an animated target over its frame range")]),
        "target": PointerProperty(name="Target", type=bpy.types.Object, poll=_is_target,
                                  description="The object the wrist reaches for (not an "
                                              "armature, camera or light)",
                                  update=_live_inputs_update),
        "targets": PointerProperty(name="Targets", type=bpy.types.Collection,
                                   poll=_not_reach_display,
                                   description="Several targets, reached in order of their names"),
        "obstacles": EnumProperty(name="Obstacles", default="VISIBLE", items=[
            ("VISIBLE", "All visible", "Every visible object with geometry except the character"),
            ("COLLECTION", "Collection", "Only the objects of one collection")]),
        "obstacle_collection": PointerProperty(name="Obstacle collection", type=bpy.types.Collection,
                                               poll=_not_reach_display),
        "use_current_frame": BoolProperty(name="From current frame", default=True,
                                          description="Start at the frame on screen (off: at "
                                                      "Start frame)"),
        "frame_start": IntProperty(name="Start frame", default=1,
                                   description="The frame the (first) reach starts at"),
        "auto_duration": BoolProperty(name="Automatic duration", default=True,
                                      description="Duration from the path length"),
        "duration": FloatProperty(name="Seconds", default=1.0, min=0.05, max=60.0,
                                  description="Duration of each reach, in seconds"),
        "new_action": BoolProperty(name="Bake into a new action", default=False,
                                   description="Copy the armature's action and bake into the copy"),
        "bake_closest": BoolProperty(name="Bake closest approach", default=False,
                                     description="When a target cannot be reached, bake the "
                                                 "motion that gets closest to it"),
        "show_guides": BoolProperty(name="Show guiding nodes", default=False,
                                    description="Draw the workspace's valid guiding nodes as "
                                                "orange wire cubes"),
        "use_overrides": BoolProperty(name="Set bones by hand", default=False,
                                      description="Use the bones named below instead of detecting them"),
        "settings": PointerProperty(type=REACH_PG_settings),
        "last_result": StringProperty(name="Last result", default="",
                                      description="JSON summary of the last plan or bake"),
        "progress": FloatProperty(name="Progress", default=0.0, min=0.0, max=1.0, subtype="FACTOR"),
        "running": BoolProperty(name="Running", default=False),
        "status": StringProperty(name="Status", default=""),
        "live": BoolProperty(
            name="Live", get=_live_get, set=_live_set,
            description="The arm follows the target while you move it, without keys (the "
                        "state of this Blender session, not saved in the file)"),
        "live_budget_ms": FloatProperty(
            name="Budget (ms)", default=round(DEFAULT_BUDGET_S * 1000.0, 2), min=1.0,
            max=1000.0, update=_live_budget_update,
            description="Longest time one live update may plan before Blender gets control "
                        "back; the search continues on the next update"),
    }
    for name in OVERRIDES:
        parts = name.split("_")
        label = "Chest" if name == BONE_PREFIX + "chest" else \
            f"{ROLE_LABELS['_'.join(parts[1:-1])]} ({parts[-1]})"
        ann[name] = StringProperty(name=label, default="", description="Bone name (blank: detect)")
    return ann


REACH_PG_scene = type("REACH_PG_scene", (bpy.types.PropertyGroup,), {
    "__annotations__": _scene_annotations(),
    "__doc__": "Reach inputs and last result of a scene",
})


def bone_overrides(props) -> dict:
    """{role: bone name} of the filled-in bone overrides (when enabled), as the pipeline
    and the rig take them (``chest``, ``hand_right``, ...)."""
    if not props.use_overrides:
        return {}
    return {name.removeprefix(BONE_PREFIX): getattr(props, name) for name in OVERRIDES
            if getattr(props, name)}


def request_from(props) -> pipeline.Request:
    """The pipeline request described by the scene's Reach properties."""
    if props.task in {"SEQUENCE", "GUIDED"} and props.targets is not None:
        targets = sorted(ob.name for ob in props.targets.all_objects)
    elif props.target is not None:
        targets = [props.target.name]
    elif props.targets is not None:
        targets = sorted(ob.name for ob in props.targets.all_objects)[:1]
    else:
        targets = []
    return pipeline.Request(
        armature=props.armature.name if props.armature else "",
        targets=targets,
        task=props.task.lower(),
        side=props.arm.lower(),
        obstacles=(props.obstacle_collection.name
                   if props.obstacles == "COLLECTION" and props.obstacle_collection else None),
        frame_start=None if props.use_current_frame else props.frame_start,
        duration_s=None if props.auto_duration else props.duration,
        settings=settings_from(props.settings),
        overrides=bone_overrides(props),
        new_action=props.new_action,
        bake_closest=props.bake_closest,
        show_guides=props.show_guides,
    )


def live_request(props) -> pipeline.Request:
    """The request live mode follows: the panel's, reaching for its first target."""
    request = request_from(props)
    request.targets = request.targets[:1]
    request.task = "reach"
    return request


def set_live(context, on: bool) -> None:
    """Turn live mode on (from the panel's inputs) or off (one undo step). Raises
    ReachError for bad input."""
    props = context.scene.reach
    if not on:
        live.stop(push_undo=True)
        return
    if props.running:
        raise ReachError("a plan or bake is running; wait for it or press Esc first")
    live.start(context, live_request(props), budget_s=props.live_budget_ms / 1000.0)


def last_result(props) -> dict:
    try:
        return json.loads(props.last_result) if props.last_result else {}
    except ValueError:
        return {}


classes = (REACH_PG_settings, REACH_PG_scene)


def register_properties():
    bpy.types.Scene.reach = PointerProperty(type=REACH_PG_scene)


def unregister_properties():
    del bpy.types.Scene.reach
