"""Operators: Plan (preview), Bake, Clear, Detect bones, Live, Key Pose.

Plan and Bake run the pipeline. In the UI they are modal: the plan advances on a timer in
slices of about 30 ms, the panel shows progress, and Esc cancels with nothing baked or
drawn and no undo step: Esc lands between slices, at a yield of
:func:`~reach_addon.blender.pipeline.steps`, and the keys and drawing are made in its last
step, which does not yield (a cancelled operator pushes no undo step; the user's own
steps stay as they were). In background mode (``INVOKE_DEFAULT`` runs ``execute`` there)
they run synchronously. Every :class:`~reach_addon.core.ReachError` becomes
``self.report({'ERROR'}, ...)``.

Live toggles live mode (:mod:`reach_addon.blender.live`): while it is on the arm follows the
target; Key Pose (K in the 3D View while Live is on) keys the pose on screen at the current
frame. Live has no automatic undo step of its own: turning it off pushes one ("Reach Live"),
so one Ctrl+Z takes the arm back to where it was before Live. Key Pose is one undo step.
"""

from __future__ import annotations

import json
import time

import bpy

from ..blender import live, pipeline, rig, viz
from ..core import ReachError
from ..core.steps import drain
from .properties import BONE_PREFIX, last_result, request_from, set_live

SLICE_S = 0.03


def _poll(cls, context, need_target: bool = True):
    """Whether Reach can run now (the panel's inputs are set, nothing else running); else
    says why (``poll_message_set``). ``need_target``: the reach envelope needs none."""
    props = getattr(context.scene, "reach", None)
    if props is None:
        return False
    if props.running:
        cls.poll_message_set("Reach is already running; press Esc to stop it")
        return False
    if props.armature is None:
        cls.poll_message_set("Choose the character's armature in the Reach panel")
        return False
    if need_target and props.target is None and props.targets is None:
        cls.poll_message_set("Choose a target object (or a collection of targets)")
        return False
    if context.mode == "EDIT_ARMATURE":
        cls.poll_message_set("Leave Edit Mode first")
        return False
    return True


class _Run:
    """Shared body of Plan and Bake."""

    bake = False
    bl_options = {"REGISTER", "UNDO"}
    cancelled = "Reach cancelled: nothing was baked"

    @classmethod
    def poll(cls, context):
        return _poll(cls, context)

    def steps(self, context):
        """The work as a step generator (:func:`~reach_addon.blender.pipeline.steps`)."""
        return pipeline.steps(context, request_from(context.scene.reach), bake=self.bake)

    def execute(self, context):
        try:
            outcome = drain(self.steps(context))
        except ReachError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        return self._finish(context, outcome)

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        props = context.scene.reach
        try:
            self._steps = self.steps(context)
            self._advance(context)          # validation errors surface here, synchronously
        except ReachError as exc:
            self._steps = None
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        except StopIteration as done:
            return self._finish(context, done.value)
        props.running = True
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _advance(self, context):
        props = context.scene.reach
        end = time.perf_counter() + SLICE_S
        while time.perf_counter() < end:
            fraction, message = next(self._steps)
            props.progress, props.status = fraction, message

    def modal(self, context, event):
        props = context.scene.reach
        if event.type == "ESC":
            self._stop(context)
            self._steps.close()
            props.status = "cancelled"
            self.report({"WARNING"}, self.cancelled)
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            self._advance(context)
        except StopIteration as done:
            self._stop(context)
            return self._finish(context, done.value)
        except ReachError as exc:
            self._stop(context)
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        for area in context.screen.areas if context.screen else ():
            if area.type == "VIEW_3D":
                area.tag_redraw()
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        context.window_manager.event_timer_remove(self._timer)
        context.scene.reach.running = False
        context.scene.reach.progress = 0.0

    def _finish(self, context, outcome):
        props = context.scene.reach
        if outcome.failure:
            self.report({"ERROR"}, outcome.failure)
            return {"CANCELLED"}
        props.last_result = json.dumps(outcome.summary())
        props.status = ""
        first = next((r for r in outcome.results if not r.success), None)
        if first is None:
            verb = "Baked" if outcome.baked else "Planned"
            self.report({"INFO"}, f"{verb} {len(outcome.results)} reach(es) for "
                                  f"{outcome.rig.armature_name} ({outcome.rig.side} arm)")
        elif outcome.baked:
            self.report({"WARNING"}, f"{first.message} (closest approach baked)"
                        if self.bake and props.bake_closest else first.message)
        else:
            self.report({"WARNING"}, first.message)
        return {"FINISHED"}


class REACH_OT_plan(_Run, bpy.types.Operator):
    """Plan the reach and draw its trajectory, without keys"""

    bl_idname = "reach.plan"
    bl_label = "Plan Reach"
    bake = False


class REACH_OT_bake(_Run, bpy.types.Operator):
    """Plan the reach and bake it as keyframes from the start frame"""

    bl_idname = "reach.bake"
    bl_label = "Bake Reach"
    bake = True


class REACH_OT_clear(bpy.types.Operator):
    """Remove Reach's trajectory, markers and guiding nodes (the "Reach" collection)"""

    bl_idname = "reach.clear"
    bl_label = "Clear Reach Display"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        removed = viz.clear(context.scene)
        context.scene.reach.last_result = ""
        self.report({"INFO"}, f"Removed {removed} Reach object(s)")
        return {"FINISHED"}


class REACH_OT_detect_bones(bpy.types.Operator):
    """Fill the bone fields with the bones Reach finds in the armature"""

    bl_idname = "reach.detect_bones"
    bl_label = "Detect Bones"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        props = getattr(context.scene, "reach", None)
        if props is None or props.armature is None:
            cls.poll_message_set("Choose the character's armature in the Reach panel")
            return False
        return True

    def execute(self, context):
        props = context.scene.reach
        try:
            bmap = rig.detect_bones(props.armature)
        except ReachError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        for key, name in bmap.to_dict().items():
            setattr(props, BONE_PREFIX + key, name or "")
        props.use_overrides = True
        self.report({"INFO"}, f"Bones of {props.armature.name}: " +
                    ", ".join(f"{k}={v}" for k, v in bmap.to_dict().items() if v))
        return {"FINISHED"}


def result_lines(props) -> list:
    """Lines the panel shows for the last result."""
    res = last_result(props)
    lines = []
    for t in res.get("tasks", []):
        st = t["stats"]
        head = f"{t['target']}: " + ("reached" if t["success"] else t["reason"].replace("_", " "))
        if t["success"] and t.get("method") == "sampling":
            head += " (sampling planner)"
        lines.append(head)
        lines.append(f"  frames {t['frame_start']}–{t['frame_end']}, "
                     f"search {st['search_time_s'] * 1000:.0f} ms")
        lines.append(f"  nodes {st['nodes_searched']} searched, {st['nodes_in_solution']} in path")
        if st.get("sampling_states"):
            lines.append(f"  sampling: {st['sampling_states']} states tested")
        lines.append(f"  path {st['path_length_arm_lengths']:.2f} arm lengths, "
                     f"mean f_R {st['mean_f_r']:.2f}")
        if "mean_wrist_bend_deg" in st:
            lines.append(f"  wrist bend {st['mean_wrist_bend_deg']:.0f}° mean, "
                         f"{st['max_wrist_bend_deg']:.0f}° max; turn ≤ "
                         f"{st['max_wrist_turn_deg_per_frame']:.0f}°/frame")
            if st.get("touching_transitions") or st.get("unbounded_hand_turns"):
                lines.append(f"  hand: {st['touching_transitions']} frame(s) touching between "
                             f"keys, {st['unbounded_hand_turns']} turn(s) over the limit")
        if st.get("orientation_error_deg") is not None:
            lines.append(f"  palm {st['orientation_error_deg']:.0f}° from the target's axes"
                         + ("" if st["orientation_met"] else " (over tolerance)"))
        if not t["success"]:
            lines.append("  " + t["message"])
    return lines + obstacle_lines(res)


#: The panel names at most this many obstacles (the report has them all).
SHOWN_OBSTACLES = 12


def obstacle_lines(res: dict) -> list:
    """What the last plan used as obstacles: a count, then each with its triangles."""
    obstacles = res.get("obstacles")
    if obstacles is None:
        return []
    if not obstacles:
        return ["Obstacles: none"]
    total = sum(o["triangles"] for o in obstacles)
    lines = [f"Obstacles: {len(obstacles)}, {total} triangles"]
    lines += [f"  {o['name']}: {o['triangles']}" for o in obstacles[:SHOWN_OBSTACLES]]
    if len(obstacles) > SHOWN_OBSTACLES:
        lines.append(f"  … and {len(obstacles) - SHOWN_OBSTACLES} more (see the report)")
    return lines


class REACH_OT_live(bpy.types.Operator):
    """Live: the arm follows the target while you move it (G, typing a location, scrubbing
    an animated target); K keys the pose. Click again to stop"""

    bl_idname = "reach.live"
    bl_label = "Live Reach"
    bl_options = {"REGISTER"}     # turning Live off pushes its own undo step

    @classmethod
    def poll(cls, context):
        if live.is_active():
            return True
        return _poll(cls, context)

    def execute(self, context):
        try:
            set_live(context, not live.is_active())
        except ReachError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        if live.is_active():
            self.report({"INFO"}, "Live on: move the target; K keys the pose")
        else:
            self.report({"INFO"}, "Live off")
        return {"FINISHED"}

    # Blender calls these when the class is registered / unregistered: the K shortcut lives
    # and dies with the add-on, and unregistering never leaves a handler or timer behind.
    @classmethod
    def register(cls):
        wm = bpy.context.window_manager
        kc = wm.keyconfigs.addon if wm is not None else None
        if kc is not None:
            km = kc.keymaps.new(name="3D View", space_type="VIEW_3D")
            _keymaps.append((km, km.keymap_items.new("reach.key_pose", "K", "PRESS")))

    @classmethod
    def unregister(cls):
        live.shutdown()
        while _keymaps:
            km, kmi = _keymaps.pop()
            km.keymap_items.remove(kmi)


_keymaps = []


class REACH_OT_key_pose(bpy.types.Operator):
    """Key the live pose at the current frame (K in the 3D View while Live is on)"""

    bl_idname = "reach.key_pose"
    bl_label = "Key Live Pose"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if not live.is_active():
            cls.poll_message_set("Turn on Live first")
            return False
        return True

    def execute(self, context):
        try:
            result = live.key_pose(context)
        except ReachError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Keyed {len(result.bones)} bone(s) at frame {result.frames[0]}")
        return {"FINISHED"}


classes = (REACH_OT_plan, REACH_OT_bake, REACH_OT_clear, REACH_OT_detect_bones, REACH_OT_live,
           REACH_OT_key_pose)
