"""Live mode in Blender: the arm follows its target while the user moves it.

One live session at a time. :func:`start` reads the scene through the pipeline (the same
validation, rig adapter and obstacles as a bake) into a core
:class:`~reach_addon.core.live.LiveSession`; :func:`update` is the one entry point every
caller uses — Blender's timer while Live is on, the tests, the benchmark. Each update:

1. re-reads what can change: the target's world position (so moving it with G, typing a
   location, a constraint, a parent or scrubbing an animated target all count), the
   obstacles (through :class:`.scene.ObstacleCache`, which rebuilds the BVH only when its cheap
   signature changes) and the armature's transform (a moved armature restarts the session
   from the pose on screen);
2. advances the core re-plan for at most the time budget (1/30 s by default);
3. when the core shows a new pose, writes it to the pose bones' rotation channels, without
   keys, through the bake's own matrices (:func:`~.bone_matrices.target_matrices`,
   :func:`~.bone_matrices.local_matrices`, :func:`~.bone_matrices.channel_values`), so a
   live pose and a baked frame of the same plan pose are the same.

Blender calls: a ``depsgraph_update_post`` and a ``frame_change_post`` handler only wake a
``bpy.app.timers`` timer (cheap, and never while it runs); the timer calls :func:`update`
and asks to run again soon while the core is busy, otherwise it stops until the next wake.
Handlers and the timer are removed when the session stops, on ``load_pre`` and when the
add-on is unregistered; none of them lets an exception reach Blender (an error stops the
session and the panel shows why).

Keys and undo: :func:`key_pose` keys the pose on screen at the current frame through
:func:`.bake.bake` (the "Key Pose" operator, K in the 3D View while Live is on). Stopping
a session pushes two undo steps (:func:`_undo_steps`): "Before Reach Live" (the scene as
it is, every bone Live posed back as it was when Live began), then "Reach Live" (the pose
on screen). An undo or redo while Live is on restarts the session from the restored pose.
Why: ``docs/design/blender.md``.
"""

from __future__ import annotations

import functools
import math
import time
import traceback
from dataclasses import dataclass, field

import bpy
import numpy as np
from mathutils import Matrix

from ..core import Plan, ReachError, Stats
from ..core.live import DEFAULT_BUDGET_S, LiveSession, LiveStatus
from . import bake as bake_mod
from . import bone_matrices, gaze, own_keys, pipeline, spine_share
from . import rig as rig_mod
from .fcurves import Channels, write_channel
from .settle import settle
from .scene import ObstacleCache, character_objects

#: Seconds between timer ticks while a re-plan is under way (Blender handles events between).
TICK_S = 0.005
UNDO_MESSAGE = "Reach Live"
#: The undo step pushed before :data:`UNDO_MESSAGE` when Live stops: the arm as before Live.
UNDO_BEFORE = "Before Reach Live"
#: The pose bone channels Live may write (rotations; locations and scales are put back as
#: they were, but a bone's matrix turns into channels with rounding).
CHANNELS = ("location", "rotation_quaternion", "rotation_euler", "rotation_axis_angle", "scale")


# --- the session ------------------------------------------------------------------------------

@dataclass
class UpdateReport:
    """What one :func:`update` did."""

    changed: bool                 # a new pose was written to the bones
    busy: bool                    # the re-plan is not finished: call again
    replanned: bool               # the target or the obstacles moved: a new re-plan began
    status: LiveStatus
    elapsed_s: float = 0.0


@dataclass
class LiveState:
    """The Blender side of a live session: names (Python references do not survive undo),
    the rig read at the start, the bones' start pose and the core session."""

    scene: str
    request: pipeline.Request
    armature: str
    target: str
    info: rig_mod.RigInfo
    session: LiveSession
    cache: ObstacleCache
    armature_matrix: np.ndarray
    armature_inverse: np.ndarray
    start_arm_pose: object         # the core Pose of the rig's start configuration
    start_pose: dict               # bone → armature-space matrix when the session began
    start_world: dict              # role → world matrix of its reference bone
    chest_head: np.ndarray
    keyed: dict                    # role → bone that receives the rotation
    reference: dict                # role → bone whose place the plan describes
    budget_s: float = DEFAULT_BUDGET_S
    message: str = ""              # a Blender-side problem (the target was deleted, …)
    rebuild: bool = False
    frame_changed: bool = False
    timings: list = field(default_factory=list)
    #: the neck as it stood before Live turned it, where the head looks at the target
    #: (``Settings.gaze``, :func:`.gaze.look_now`)
    neck: gaze.NeckFrame | None = None
    #: the spine bones that take a share of the chest's turn (:mod:`.spine_share`), and
    #: theirs and the chest's channel matrices at the start
    spine: spine_share.SpineShare = field(default_factory=spine_share.SpineShare)
    spine_start: dict = field(default_factory=dict)


_state: LiveState | None = None
_last_status = ""                  # why the last session ended, for the panel
_in_update = False
_drawn: tuple = ()                 # the status last drawn
#: Since Live was turned on (kept while a session restarts for another target, an undo or a
#: moved armature), per armature: every pose bone's channels (:data:`CHANNELS`) as they were
#: when Live first posed it, the bones Live has written since, and the IK/FK switches it
#: turned, with their values before. :func:`_undo_steps` puts them back for its first step.
_before: dict = {}


def state() -> LiveState | None:
    return _state


def is_active(scene=None) -> bool:
    return _state is not None and (scene is None or scene.name == _state.scene)


def _open(context, request: pipeline.Request, budget_s: float) -> LiveState:
    """Read the scene into a new :class:`LiveState` (raises ReachError on bad input)."""
    armature, targets, collection = pipeline.validate(context, request, bake=True)
    scene = context.scene
    context.view_layer.update()
    target = targets[0]
    info = rig_mod.build(armature, request.side, request.overrides,
                         target=np.array(target.matrix_world.translation))
    exclude = character_objects(armature, scene) | {t.name for t in targets}
    cache = ObstacleCache(exclude, collection.name if collection is not None else None)
    obstacles, _ = cache.get(context, geometry=True)
    session = LiveSession(info.arm, obstacles, request.settings, info.start, target.name,
                          info.start_hand)

    bmap = info.bones
    keyed, reference = bone_matrices.bone_roles(info, chest=True)
    for name in keyed.values():
        if name not in armature.pose.bones:
            raise ReachError(f"bone '{name}' is missing from armature '{armature.name}'")
    mw = np.array(armature.matrix_world)
    start_pose = {pb.name: np.array(pb.matrix) for pb in armature.pose.bones}
    start_world = {role: mw @ start_pose[ref] for role, ref in reference.items()}
    chest_head = (mw @ start_pose[bmap.keyed_chest])[:3, 3]
    spine = spine_share.for_rig(armature, info, request.settings, leaning=False,
                                with_pelvis=False)
    spine_start = {n: np.array(armature.pose.bones[n].matrix_basis)
                   for n in (*spine.bones, bmap.keyed_chest)}
    return LiveState(scene.name, request, armature.name, target.name, info, session, cache,
                     mw, np.linalg.inv(mw), session.pose,
                     start_pose, start_world, chest_head, keyed, reference, budget_s,
                     neck=_neck_reference(context, armature, info, request.settings,
                                          [target]), spine=spine, spine_start=spine_start)


def _neck_reference(context, armature, info, settings, targets):
    """The :class:`.gaze.NeckFrame` the head turns from in Live (``Settings.gaze``): read
    with the neck as it was before Live turned it (a session reopened after an undo or a
    moved armature finds it turned on screen), or None."""
    if not settings.gaze:
        return None
    neck, _why = gaze.neck_of(armature, info, targets)
    if neck is None:
        return None
    pb = armature.pose.bones[neck]
    was = (_before.get(armature.name) or {}).get("channels", {}).get(neck)
    now = _channels(pb)
    try:
        for channel, value in (was or {}).items():
            setattr(pb, channel, value)
        context.view_layer.update()
        return gaze.neck_frame(armature, info, neck)
    finally:
        for channel, value in now.items():
            setattr(pb, channel, value)
        context.view_layer.update()


def start(context, request: pipeline.Request, budget_s: float | None = None) -> LiveState:
    """Begin live mode for ``request`` (its armature, arm, first target, obstacles,
    settings and bone overrides); the arm is posed on the following updates. Raises
    :class:`~reach_addon.core.ReachError` for bad input, leaving nothing running."""
    global _state, _last_status
    if not stop(push_undo=False):
        _before.clear()              # Live was off: what it changes is counted from now
    st = _open(context, request, DEFAULT_BUDGET_S if budget_s is None else float(budget_s))
    armature = bpy.data.objects[st.armature]
    if st.armature not in _before:
        _before[st.armature] = {"channels": {pb.name: _channels(pb)
                                             for pb in armature.pose.bones},
                                "posed": set(), "switches": {}}
    _state = st
    _last_status = ""
    _install()
    return st


def stop(push_undo: bool = True) -> bool:
    """End live mode, leaving the pose as it is on screen. With ``push_undo`` the pose
    becomes one undo step. Returns True if a session was running."""
    global _state
    was = _state is not None
    _state = None
    _uninstall()
    if was and push_undo:
        _undo_steps()
    return was


def _channels(pose_bone) -> dict:
    return {c: tuple(getattr(pose_bone, c)) for c in CHANNELS}


def _undo_steps():
    """The two undo steps of stopping Live (see the module doc): the bones Live posed, and
    the IK/FK switches it turned, put back as they were before Live for "Before Reach
    Live", then the pose on screen restored for "Reach Live". Nothing is redrawn or
    evaluated between the two, so the viewport never shows the first."""
    shown = []
    for name, before in _before.items():
        armature = bpy.data.objects.get(name)
        if armature is None or armature.type != "ARMATURE":
            continue
        bones = armature.pose.bones
        posed = [b for b in sorted(before["posed"]) if b in bones and b in before["channels"]]
        now = {b: _channels(bones[b]) for b in posed}
        switches = {(b, p): bones[b].get(p) for b, p in before["switches"] if b in bones}
        shown.append((armature, now, switches))
        for b in posed:
            for channel, value in before["channels"][b].items():
                setattr(bones[b], channel, value)
        for (b, p), value in before["switches"].items():
            if b not in bones:
                continue
            if value is None:
                bones[b].pop(p, None)
            else:
                bones[b][p] = value
        armature.update_tag()
    _undo_push(UNDO_BEFORE)
    for armature, now, switches in shown:
        bones = armature.pose.bones
        for b, channels in now.items():
            for channel, value in channels.items():
                setattr(bones[b], channel, value)
        for (b, p), value in switches.items():
            if value is not None:
                bones[b][p] = value
        armature.update_tag()
    _undo_push(UNDO_MESSAGE)
    _before.clear()


def _undo_push(message):
    try:
        if bpy.ops.ed.undo_push.poll():
            bpy.ops.ed.undo_push(message=message)
    except (RuntimeError, AttributeError):
        pass  # no undo stack (e.g. while Blender is loading a file)


def _objects(st: LiveState):
    scene = bpy.data.scenes.get(st.scene)
    armature = bpy.data.objects.get(st.armature)
    target = bpy.data.objects.get(st.target)
    for ob, what, name in ((armature, "armature", st.armature), (target, "target", st.target)):
        if ob is None or scene is None or ob.name not in scene.objects:
            raise ReachError(f"the {what} '{name}' is gone from the scene; Live stopped")
    return scene, armature, target


def update(context=None, budget_s: float | None = None) -> UpdateReport:
    """One live update (what the timer runs): notice what moved, advance the re-plan for
    at most ``budget_s`` seconds (the session's budget if None) and pose the arm if the
    core shows a new pose. Without a session it does nothing."""
    global _in_update
    t0 = time.perf_counter()
    st = _state
    if st is None:
        return UpdateReport(False, False, False, LiveStatus(message=_last_status or "Live is off"))
    context = context or bpy.context
    _in_update = True
    try:
        scene, armature, target = _objects(st)
        wait = None
        if armature.mode == "EDIT":
            wait = f"armature '{armature.name}' is in Edit Mode; Live waits"
        elif context.scene != scene:
            wait = f"Live waits for scene '{scene.name}' to be shown"
        elif getattr(getattr(scene, "reach", None), "running", False):
            wait = "a plan or bake is running; Live waits"
        if wait is not None:
            st.message = wait
            return UpdateReport(False, False, False, st.session.status, time.perf_counter() - t0)
        view_layer = context.view_layer
        view_layer.update()
        if st.rebuild or not np.allclose(np.array(armature.matrix_world), st.armature_matrix,
                                         atol=1e-9):
            st = _reopen(context, st)
        st.message = ""
        depsgraph = context.evaluated_depsgraph_get()
        obstacles, _rebuilt = st.cache.get(context, depsgraph, geometry=st.frame_changed)
        st.frame_changed = False
        replanned = st.session.set_obstacles(obstacles)
        replanned |= st.session.set_target(np.array(target.matrix_world.translation), target.name)
        changed = st.session.advance(st.budget_s if budget_s is None else budget_s)
        if changed:
            _apply(st, armature)
        elapsed = time.perf_counter() - t0
        st.timings.append(elapsed)
        del st.timings[:-1000]
        return UpdateReport(changed, st.session.busy, replanned, st.session.status, elapsed)
    finally:
        _in_update = False


def _reopen(context, st: LiveState) -> LiveState:
    """The armature moved or an undo restored another pose: read the rig again from the
    pose on screen, keeping the request and the budget."""
    global _state
    new = _open(context, st.request, st.budget_s)
    _state = new
    return new


def _apply(st: LiveState, armature) -> None:
    """Write the session's pose to the bones' rotation channels (no keys)."""
    plan = Plan(None, st.info.arm, st.session.settings, [st.start_arm_pose, st.session.pose],
                [], Stats())
    targets = bone_matrices.target_matrices(st.info, plan, st.start_world, st.chest_head)
    targets_arm = {role: st.armature_inverse[None] @ m[1:] for role, m in targets.items()}
    pose = armature.pose.bones
    before = _before.get(armature.name)
    for side, (bone_name, prop) in st.info.bones.ik_fk.items():
        if side == st.info.side and pose[bone_name].get(prop) != 1.0:
            if before is not None:
                before["switches"].setdefault((bone_name, prop), pose[bone_name].get(prop))
            pose[bone_name][prop] = 1.0
            armature.update_tag()
    locals_ = bone_matrices.local_matrices(armature, st.keyed, targets_arm, st.start_pose)
    if before is not None:
        before["posed"].update(locals_)
    for name in st.spine.bones:       # as at the start, which the keys are solved against
        pose[name].matrix_basis = Matrix(st.spine_start[name].tolist())
    settle(bpy.context, armature, st.keyed, st.reference, targets_arm, locals_, st.start_pose)
    chest = st.keyed.get("chest")
    if st.spine.bones and chest in locals_:       # the chest's turn spread down the spine
        locals_[chest] = locals_[chest].copy()
        locals_[chest][-1] = spine_share.pose_now(armature, st.spine, st.spine_start, chest,
                                                  locals_[chest][-1])
        if before is not None:
            before["posed"].update(st.spine.bones)
    for name, mats in locals_.items():
        path, values = bone_matrices.channel_values(pose[name], mats)
        setattr(pose[name], path, tuple(float(v) for v in values[-1]))
    if st.neck is not None:
        bpy.context.view_layer.update()
        target = bpy.data.objects[st.target].matrix_world.translation
        gaze.look_now(bpy.context, armature, st.neck, np.array(target), st.session.settings,
                      st.session.planner.generator.checker)
        if before is not None:
            before["posed"].add(st.neck.name)


def key_pose(context=None) -> bake_mod.BakeResult:
    """Key the pose on screen at the current frame, through :func:`.bake.bake` (the chest
    too when Live turned it, and the spine bones sharing its turn, and the head): the
    body's keys are recorded as Reach's own (:func:`.own_keys.record`), as a bake's are.
    Raises ReachError when Live is off."""
    st = _state
    if st is None:
        raise ReachError("Live is off: turn on Live in the Reach panel, then key the pose")
    context = context or bpy.context
    scene, armature, _target = _objects(st)
    pose = st.session.pose
    _apply(st, armature)
    context.view_layer.update()
    frame = scene.frame_current
    names = [*st.spine.bones, st.info.bones.keyed_chest]
    # as Live shows them: the bake's keys are evaluated over the pose (a rig with NLA tracks
    # has its action assigned again when a curve is made, and is evaluated at once)
    shown = {n: armature.pose.bones[n].matrix_basis.copy() for n in names}
    plan = Plan(None, st.info.arm, st.session.settings, [pose], [], Stats())
    result = bake_mod.bake(context, armature, st.info, [bake_mod.KeyedPlan(plan, frame)],
                           new_action=False)
    start = st.info.start.body_rotation
    body = []        # the body's keys, Reach's own (a bake's own_keys.record, for its body)
    if abs(pose.config.body_rotation - start) > 1e-9:
        for name in names:
            armature.pose.bones[name].matrix_basis = shown[name]
            _key_as_posed(armature, name, frame)
        result.bones = names + [b for b in result.bones if b not in names]
        body += list(st.spine.bones) + ([names[-1]] if st.spine.bones else [])
    if st.neck is not None:                  # the head, turned toward the target
        _key_as_posed(armature, st.neck.name, frame)
        result.bones = result.bones + [st.neck.name]
        body.append(st.neck.name)
    if body:
        # so a later bake shares its turn down the spine (and turns the head) again, as
        # after a bake, instead of taking these keys for a user's and leaving them be
        own_keys.record(armature.animation_data.action, body, frame, frame)
    context.view_layer.update()
    return result


def _key_as_posed(armature, name, frame) -> None:
    """Key bone ``name``'s rotation channels at ``frame`` as they are posed now."""
    pb = armature.pose.bones[name]
    channels = Channels(armature, armature.animation_data.action)
    path, values = bone_matrices.channel_values(pb, [np.array(pb.matrix_basis)])
    write_channel(channels, f'pose.bones["{name}"].{path}', values, np.array([float(frame)]),
                  name)


# --- status for the panel --------------------------------------------------------------------

def note_error(message: str) -> None:
    """Show ``message`` in the panel's Live status (an error that could not be reported)."""
    global _last_status
    _last_status = message


def status_lines() -> list:
    """Lines the panel shows while Live is on (or why it stopped): the target's state, with
    the arm when Auto chose it, and why it cannot be reached."""
    st = _state
    if st is None:
        return [_last_status] if _last_status else []
    s = st.session.status
    lines = [st.message] if st.message else []
    head = {"idle": "waiting", "searching": "searching", "moving": "moving",
            "reached": "on target", "closest": "closest approach",
            "blocked": "blocked"}.get(s.state, s.state)
    distance = "" if not math.isfinite(s.distance) else f", {s.distance:.3f} arm lengths away"
    arm = f" ({st.info.side} arm, Auto)" if st.request.side == "auto" else ""
    lines.append(f"{st.target}{arm}: {head}{distance}")
    if s.reason is not None:
        lines.append(s.message)
    if st.timings:
        recent = np.array(st.timings[-60:]) * 1000
        lines.append(f"update {np.median(recent):.1f} ms, {st.session.updates} poses")
    return lines


# --- handlers and the timer ----------------------------------------------------------------

def _tick():
    """The timer: one budgeted update; again soon while busy, else sleep until woken."""
    global _last_status
    if _state is None:
        return None
    try:
        report = update(bpy.context)
    except ReachError as exc:
        _last_status = f"Live stopped: {exc}"
        stop(push_undo=True)
        _redraw()
        return None
    except Exception as exc:  # never into Blender's event loop
        traceback.print_exc()
        _last_status = f"Live stopped by an internal error: {exc}"
        stop(push_undo=True)
        _redraw()
        return None
    global _drawn
    shown = (report.status.state, report.status.message, _state.message if _state else "")
    if report.changed or shown != _drawn:      # redraw only when there is something new
        _drawn = shown
        _redraw()
    return TICK_S if report.busy else None


def _wake():
    if _state is not None and not _in_update and not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=0.0)


def _handler(fn):
    """A Blender handler of ``fn``: an exception is printed, never raised into Blender."""
    @functools.wraps(fn)
    def handler(*args):
        try:
            fn(*args)
        except Exception:
            traceback.print_exc()
    return handler


@_handler
def _on_depsgraph(scene, depsgraph=None):
    st = _state
    if st is None or _in_update:
        return
    if depsgraph is not None:
        for u in depsgraph.updates:
            if u.is_updated_geometry and isinstance(u.id, bpy.types.Object):
                st.cache.note_geometry(u.id.name)
    _wake()


@_handler
def _on_frame(*_args):
    if _state is not None:
        _state.frame_changed = True
        _wake()


@_handler
def _on_undo(*_args):
    if _state is not None:
        _state.rebuild = True
        _wake()


@_handler
def _on_load_pre(*_args):
    global _last_status
    if stop(push_undo=False):
        _last_status = "Live stopped: another file was opened"


_HANDLERS = (("depsgraph_update_post", _on_depsgraph), ("frame_change_post", _on_frame),
             ("undo_post", _on_undo), ("redo_post", _on_undo), ("load_pre", _on_load_pre))


def _install():
    for name, fn in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if fn not in handlers:
            handlers.append(fn)
    if not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=0.0)


def _uninstall():
    for name, fn in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        while fn in handlers:
            handlers.remove(fn)
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)


def installed() -> bool:
    """Are any of live mode's handlers or its timer registered?"""
    return any(fn in getattr(bpy.app.handlers, name) for name, fn in _HANDLERS) or \
        bpy.app.timers.is_registered(_tick)


def shutdown() -> None:
    """For the add-on's unregister: stop without an undo step and remove everything."""
    global _last_status
    stop(push_undo=False)
    _uninstall()
    _last_status = ""


def _redraw():
    wm = getattr(bpy.context, "window_manager", None)
    for window in wm.windows if wm is not None else ():
        for area in window.screen.areas if window.screen else ():
            if area.type == "VIEW_3D":
                area.tag_redraw()
