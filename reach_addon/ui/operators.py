"""Operators: Plan (preview), Bake, Clear, Detect bones, Live, Key Pose.

Plan and Bake run the pipeline. In the UI they are modal: the plan advances on a timer in
slices of about 30 ms (100 ms while the user leaves the interface alone), the panel shows
progress, and Esc cancels with nothing baked or drawn and no undo step. Only the sidebar
is redrawn while they run, at most about 10 times a second (:data:`REDRAW_S`), and less
often where a redraw is slow (software OpenGL can take a fifth of a second for the
sidebar, a second for the viewport), so that the interface's share of the wait stays
small (:class:`_Clock`). The Result shows the pipeline's own time beside the wall time.
Esc lands between slices, at a yield of
:func:`~reach_addon.blender.pipeline.steps`, and the keys and drawing are made in its last
step, which does not yield (a cancelled operator pushes no undo step; the user's own
steps stay as they were). In background mode (``INVOKE_DEFAULT`` runs ``execute`` there)
they run synchronously. Every :class:`~reach_addon.core.ReachError`, and a Bake that keys
nothing, is a refusal (:meth:`_Run._refuse`): its whole reason goes to the Result panel, the
console and the Info log, and ``self.report({'ERROR'}, ...)`` pops up its first words and
where the rest is (a script calling the operator gets all of it in its RuntimeError).

Live toggles live mode (:mod:`reach_addon.blender.live`): while it is on the arm follows the
target; Key Pose (K in the 3D View while Live is on) keys the pose on screen at the current
frame. Live has no automatic undo step of its own: turning it off pushes one ("Reach Live"),
so one Ctrl+Z takes the arm back to where it was before Live. Key Pose is one undo step.
"""

from __future__ import annotations

import json
import time

import bpy

from ..blender import live, pipeline, rig_detect, viz
from ..blender.lean import SQUAT_REPORTED
from ..core import ReachError
from ..core.steps import drain
from .properties import BONE_PREFIX, last_result, request_from, set_live

#: How long the plan advances between two looks at the interface's events while the user
#: is using it (moving the pointer, pressing keys) ...
SLICE_S = 0.03
#: ... and when no event but the operator's timer came for :data:`IDLE_S`: Esc then waits
#: at most this long.
IDLE_SLICE_S = 0.1
IDLE_S = 0.5
#: Least time between two redraws of the progress while Plan or Bake runs (10 a second) ...
REDRAW_S = 0.1
#: ... and least time between the end of one redraw and the next, in multiples of what a
#: redraw takes: the redraws' share of the wait is then at most a fifth.
REDRAW_SHARE = 4.0
#: What the last redraw of the progress took (seconds; 0 until one was measured): the
#: next run waits long enough before its first.
_redraw = {"cost": 0.0}
#: Most characters of a refusal's reason shown in the error popup: Blender draws a report
#: in one line, which ran off the screen; the whole reason goes to the Result panel, the
#: Info log and the console (:meth:`_Run._refuse`).
POPUP_CHARS = 60


class _Clock:
    """A modal run's time: ``work``, spent in the pipeline's steps; ``wall``, since the
    operator was invoked (what the user waits); and when to redraw the progress. A redraw
    is asked for at most every :data:`REDRAW_S`, and no sooner than :data:`REDRAW_SHARE`
    times what a redraw takes after the last one (or after the start): its cost is
    measured as the time from the end of the slice that asked for it to the next timer
    event (the interface redrawing, and handling its events), and kept for the next run."""

    def __init__(self):
        self.start = self.input = time.perf_counter()
        self.work = 0.0
        self._asked = False
        self._returned = None
        self._next = self.start + self._wait()

    @staticmethod
    def _wait() -> float:
        return max(REDRAW_S, REDRAW_SHARE * _redraw["cost"])

    @property
    def wall(self) -> float:
        return time.perf_counter() - self.start

    def slice(self) -> float:
        """How long the next slice may run: longer when the user has left the interface
        alone for a while (no event but the timer's)."""
        return IDLE_SLICE_S if time.perf_counter() - self.input > IDLE_S else SLICE_S

    def resumed(self):
        """A timer event: the interface is done with what it did since the last slice."""
        if self._asked:
            now = time.perf_counter()
            _redraw["cost"] = now - self._returned
            self._next = now + self._wait()
            self._asked = False

    def redraw_due(self) -> bool:
        """After a slice: whether to redraw the progress now."""
        self._returned = now = time.perf_counter()
        if now < self._next:
            return False
        self._asked = True
        self._next = now + self._wait()
        return True

    def times(self) -> dict:
        """What the Result shows: the pipeline's own time and the wall time, in seconds."""
        return {"planner_s": self.work, "wall_s": self.wall}


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

    #: Whether the run was started from the interface (``invoke``): its refusals then pop
    #: up short, the whole reason in the Result panel (:meth:`_refuse`).
    _popup = False

    def execute(self, context):
        self._clock = _Clock()
        try:
            outcome = drain(self.steps(context))
        except ReachError as exc:
            return self._refuse(context, str(exc))
        self._clock.work = self._clock.wall
        return self._finish(context, outcome)

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        props = context.scene.reach
        self._popup = True
        self._clock = _Clock()
        self._progress = (0.0, "")
        try:
            self._steps = self.steps(context)
            self._advance(context)          # validation errors surface here, synchronously
        except ReachError as exc:
            self._steps = None
            return self._refuse(context, str(exc))
        except StopIteration as done:
            return self._finish(context, done.value)
        props.running = True
        props.progress, props.status = self._progress     # shown when the sidebar next draws
        self._show_progress(context)
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _advance(self, context):
        clock = self._clock
        t0 = time.perf_counter()
        end = t0 + clock.slice()
        try:
            while time.perf_counter() < end:
                self._progress = next(self._steps)
        finally:
            clock.work += time.perf_counter() - t0

    def _show_progress(self, context):
        """The progress into the panel, and the sidebars showing it redrawn, when the clock
        says so (the 3D view itself is not: nothing in it changes until the plan is done)."""
        if not self._clock.redraw_due():
            return
        props = context.scene.reach
        props.progress, props.status = self._progress
        for area in context.screen.areas if context.screen else ():
            if area.type == "VIEW_3D":
                for region in area.regions:
                    if region.type == "UI":
                        region.tag_redraw()

    def modal(self, context, event):
        props = context.scene.reach
        if event.type == "ESC":
            self._stop(context)
            self._steps.close()
            props.status = "cancelled"
            self.report({"WARNING"}, self.cancelled)
            return {"CANCELLED"}
        if event.type != "TIMER":
            self._clock.input = time.perf_counter()
            return {"PASS_THROUGH"}
        self._clock.resumed()
        try:
            self._advance(context)
        except StopIteration as done:
            self._stop(context)
            return self._finish(context, done.value)
        except ReachError as exc:
            self._stop(context)
            return self._refuse(context, str(exc))
        self._show_progress(context)
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        context.window_manager.event_timer_remove(self._timer)
        context.scene.reach.running = False
        context.scene.reach.progress = 0.0

    def _refuse(self, context, message, summary=None):
        """Stop with nothing done, saying why: the whole ``message`` in the Result panel
        (kept in the last result as ``refused``, beside the plan's ``summary`` if there is
        one), on the console (stdout) and in the Info log; started from the interface, the
        error popup shows its first :data:`POPUP_CHARS` characters and where the rest is
        (a script's ``bpy.ops`` call gets the whole message in its RuntimeError)."""
        verb = "Bake" if self.bake else "Plan"
        props = context.scene.reach
        props.last_result = json.dumps({**(summary or {}), "refused": message,
                                        "operation": verb, "time": self._clock.times()})
        props.status = ""
        print(f"Reach: {verb} refused: {message}", flush=True)
        if not self._popup:
            self.report({"ERROR"}, message)
            return {"CANCELLED"}
        self.report({"INFO"}, f"{verb} refused: {message}")
        self.report({"ERROR"}, popup_text(verb, message))
        return {"CANCELLED"}

    def _finish(self, context, outcome):
        props = context.scene.reach
        if outcome.failure:
            return self._refuse(context, outcome.failure, outcome.summary())
        props.last_result = json.dumps({**outcome.summary(), "time": self._clock.times()})
        props.status = ""
        first = next((r for r in outcome.results if not r.success), None)
        if first is None and outcome.warnings:
            self.report({"WARNING"}, outcome.warnings[0])
        elif first is None:
            verb = "Baked" if outcome.baked else "Planned"
            chosen = ", chosen by Auto" if outcome.request.side == "auto" else ""
            self.report({"INFO"}, f"{verb} {len(outcome.results)} reach(es) for "
                                  f"{outcome.rig.armature_name} ({outcome.rig.side} arm{chosen})")
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
            bmap = rig_detect.detect_bones(props.armature)
        except ReachError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        for key, name in bmap.to_dict().items():
            setattr(props, BONE_PREFIX + key, name or "")
        props.use_overrides = True
        self.report({"INFO"}, f"Bones of {props.armature.name}: " +
                    ", ".join(f"{k}={v}" for k, v in bmap.to_dict().items() if v))
        return {"FINISHED"}


def popup_text(verb: str, message: str) -> str:
    """The error popup of a refused Plan or Bake: the start of ``message``, cut at a word
    within :data:`POPUP_CHARS` characters, and where the whole of it is."""
    head = message
    if len(message) > POPUP_CHARS:
        head = message[:POPUP_CHARS + 1].rsplit(" ", 1)[0].rstrip(" ,;:(") + " …"
    return f"{verb} refused: {head} (all of it: Reach › Result, Info log)"


def result_lines(props) -> list:
    """Lines the panel shows for the last result. A refused run: "Bake refused:" and the
    whole reason (after the reaches' lines when it planned and keyed nothing). A reach
    that succeeded: its head (with
    the arm when Auto chose it), then its statistics. One that failed: its head, its
    message (which names the arm Auto chose), then only the statistics that describe
    something: a failure with no motion (the search never left the start) has no frames,
    path or strength to show, and one that searched nothing no node counts."""
    res = last_result(props)
    lines = []
    refused = res.get("refused")
    if refused and not res.get("tasks"):
        lines.append(f"{res.get('operation', 'Reach')} refused:")
        lines.append("  " + refused)
    for t in res.get("tasks", []):
        st = t["stats"]
        ok = t["success"]
        head = f"{t['target']}: " + ("reached" if ok else t["reason"].replace("_", " "))
        if ok and t.get("method") == "sampling":
            head += " (sampling planner)"
        if ok and t.get("auto"):
            head += f" with the {t['arm']} arm (Auto)"
        lines.append(head)
        if not ok:
            lines.append("  " + t["message"])
        moved = ok or (t["frame_end"] > t["frame_start"]
                       and st["path_length_arm_lengths"] > 0)
        if moved:
            lines.append(f"  frames {t['frame_start']}–{t['frame_end']}, "
                         f"search {st['search_time_s'] * 1000:.0f} ms")
        elif st["nodes_searched"]:
            lines.append(f"  search {st['search_time_s'] * 1000:.0f} ms")
        if ok or st["nodes_searched"]:
            lines.append(f"  nodes {st['nodes_searched']} searched, "
                         f"{st['nodes_in_solution']} in path")
        if st.get("sampling_states"):
            lines.append(f"  sampling: {st['sampling_states']} states tested")
        if not moved:
            continue
        lines.append(f"  path {st['path_length_arm_lengths']:.2f} arm lengths, "
                     f"mean f_R {st['mean_f_r']:.2f}")
        if "mean_wrist_bend_deg" in st:
            lines.append(f"  wrist bend {st['mean_wrist_bend_deg']:.0f}° mean, "
                         f"{st['max_wrist_bend_deg']:.0f}° max; turn ≤ "
                         f"{st['max_wrist_turn_deg_per_frame']:.0f}°/frame")
            if st.get("bend_forced_by"):
                lines.append(f"  wrist bent by '{st['bend_forced_by']}' on "
                             f"{st['forced_bend_frames']} frame(s)")
            if st.get("chicken_wing_frames"):
                lines.append(f"  elbow lifted over a low hand on {st['chicken_wing_frames']} "
                             "frame(s)")
            if st.get("touching_transitions") or st.get("unbounded_hand_turns"):
                lines.append(f"  hand: {st['touching_transitions']} frame(s) touching between "
                             f"keys, {st['unbounded_hand_turns']} turn(s) over the limit")
        lines += body_lines(st)
        if st.get("com_margin_min") is not None:
            lines.append(f"  balance: centre of mass {st['com_margin_min']:.2f} arm lengths "
                         "inside the feet at least" if st["com_margin_min"] >= 0.0 else
                         f"  balance: centre of mass {-st['com_margin_min']:.2f} arm lengths "
                         "outside the feet")
        if st.get("orientation_error_deg") is not None:
            lines.append(f"  palm {st['orientation_error_deg']:.0f}° from the target's axes"
                         + ("" if st["orientation_met"] else " (over tolerance)"))
    if refused and res.get("tasks"):
        lines.append(f"{res.get('operation', 'Reach')} refused: nothing was baked (turn on "
                     "'Bake closest approach' under Options to bake the motion that gets "
                     "closest)")
    lines += [f"Warning: {w}" for w in res.get("warnings", ())]
    if res.get("time"):
        lines.append(f"Time: planner {res['time']['planner_s'] * 1000:.0f} ms, "
                     f"wall {res['time']['wall_s'] * 1000:.0f} ms")
    return lines + obstacle_lines(res)


def body_lines(stats: dict) -> list:
    """What the body did for a reach, from its result's ``stats``: the steps (how many,
    how far, arm lengths), then the lean (the trunk's angle; the hips back and, in a
    squat, down, as the message says it: :data:`.blender.lean.SQUAT_REPORTED`; the knees'
    bend). None where the arm reached alone."""
    lines = []
    if stats.get("step_count"):
        n = stats["step_count"]
        lines.append(f"  body: {n} step{'s' if n > 1 else ''}, "
                     f"{stats['step_distance']:.2f} arm lengths toward it")
    if stats.get("lean_deg") is not None:
        text = f"  trunk leaned {stats['lean_deg']:.0f}°"
        if stats.get("lean_hips_down", 0.0) >= SQUAT_REPORTED:
            text += (f", squatting: hips {stats['lean_hips_down']:.2f} down, "
                     f"{stats['lean_hips_back']:.2f} back")
        elif stats.get("lean_hips_back", 0.0) > 0.0:
            text += f", hips {stats['lean_hips_back']:.2f} back"
        if stats.get("lean_knee_deg") is not None:
            text += f", knees {stats['lean_knee_deg']:.0f}°"
        lines.append(text)
    return lines


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
