"""What a pipeline run reports per target (:class:`TaskResult`), and the readings that
correct a plan's own account by what Blender shows: a start the skin shows clear
(:func:`start_as_it_shows`), the hand's orientation on the baked bones
(:func:`measure_orientation`), how natural the baked arm is (:func:`measure_naturalness`)
and whether the evaluated wrist arrives where the plan's did (:func:`measure_arrival`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import bpy
import numpy as np

from ..core import RIG_OFF_TARGET, START_HELD, START_IN_COLLISION, TARGET_MOVED
from ..core.arm import frame_angle
from ..core.elbow import chicken_wing
from ..core.orient import palm_frame, wanted_axes
from ..core.sweep import coming_into, obstacles_from_pieces
from . import balance, hand_reading
from .rig import rest_hand_axis
from .skin import skin_clearance


@dataclass
class TaskResult:
    """One target's outcome, as the report and the panel show it."""

    target: str
    arm: str
    success: bool
    reason: str | None
    message: str
    frame_start: int
    frame_end: int
    bones_keyed: list
    stats: dict
    #: what found the path: "best-first" (the paper's search), "sampling" (the fallback
    #: where it gave up) or "chase"
    method: str = "best-first"
    #: whether Arm: Auto chose ``arm`` (the message then names it, :func:`arm_note`)
    auto: bool = False

    def to_dict(self) -> dict:
        return dict(self.__dict__)


def arm_note(request, info) -> str:
    """What begins every message of a request whose arm Auto chose, naming that arm
    ("Left arm (Auto): "); "" when the user chose the arm."""
    return f"{info.side.capitalize()} arm (Auto): " if request.side == "auto" else ""


def task_results(info, plans, keyed, request, baked_result=None) -> list:
    """A :class:`TaskResult` per target of ``plans`` (:class:`.bake.KeyedPlan`, in order),
    for the arm of ``info`` (:class:`.rig.RigInfo`) and the ``request``
    (:class:`.pipeline.Request`); ``keyed``: the bones the bake keyed (each keyable
    plan's results list them). A failed one's message begins with the arm when Auto chose
    it (:func:`arm_note`). ``baked_result``: the bake's :class:`.bake.BakeResult`, in
    each baked task's statistics as ``rig_residual_arm_lengths`` (how far the rig put a
    planned joint, arm lengths), ``linear_spans`` (spans between keys made linear,
    :func:`.straighten.straighten`) and ``close_spans`` (spans still too close after it)."""
    out = []
    index = -1           # the plan's place among the baked ones
    for k in plans:
        plan, first, baked = k.plan, k.first_frame, k.keyable
        index += baked
        for seg in plan.segments:
            stats = seg.stats.to_dict()
            if baked and baked_result is not None:
                stats["rig_residual_arm_lengths"] = float(baked_result.residual)
                if index < len(baked_result.linear_spans):
                    stats["linear_spans"] = baked_result.linear_spans[index]
                    stats["close_spans"] = baked_result.close_spans[index]
            message = seg.message if seg.success else arm_note(request, info) + seg.message
            out.append(TaskResult(
                seg.name, info.side, seg.success, seg.reason, message,
                first + seg.frame_start, first + seg.frame_end,
                list(keyed) if baked else [], stats, seg.method, request.side == "auto"))
    return out


#: The words of a start refused as deeper in an obstacle than a start may touch
#: (:func:`~reach_addon.core.contact.depth_message`).
DEEP_START = "a start may touch (Start contact tolerance)"


def start_as_it_shows(armature, info, plans, obstacles, sweep=None) -> None:
    """Turn, in place, each segment of ``plans`` (core Plans) refused as touching an
    obstacle at its start (``start_in_collision``, "already touches", or deeper than the
    start contact tolerance, :data:`DEEP_START`) into ``start_held``, saying so, where the
    arm's skin (the clavicle's too where the model's clavicle is what touches) as Blender
    shows it now touches nothing (:func:`.skin.skin_clearance` against ``obstacles``,
    looking half an arm length out): the refusal is then a claim about Reach's model of the
    arm, not about what the user sees. Likewise, with ``sweep`` (the pipeline's
    ``_sweep(f0, f1)``), a start an animated obstacle moves into on a later frame
    (:func:`~reach_addon.core.sweep.coming_into`) where the skin, clavicle included, stays
    clear of it on that frame. The character's own body, an enclosed chest and an
    obstacle moving into a chase are left as they are."""
    length = info.arm.arm_length
    skins = {}           # the skin's clearance, without and with the clavicle's
    for plan in plans:
        for seg in plan.segments:
            if seg.reason != START_IN_COLLISION:
                continue
            coming = coming_into(seg.message) if sweep is not None else None
            if coming is not None:
                _moving_in_as_it_shows(armature, info, seg, coming, sweep)
                continue
            deep = DEEP_START in seg.message
            if "already touches" not in seg.message and not deep:
                continue
            clavicle = "(at the clavicle)" in seg.message
            if clavicle not in skins:
                skins[clavicle] = skin_clearance(info, armature, obstacles, 0.5 * length,
                                                 clavicle=clavicle)
            skin = skins[clavicle]
            if skin <= 0.0:
                continue
            clear = (f"{seg.message.split(';')[0]} as Reach models the arm (one capsule per "
                     f"segment, fuller than the skin there), although its skin is "
                     f"{100.0 * skin * info.arm.metres_per_unit:.1f} cm "
                     f"({skin / length:.3f} arm lengths) clear")
            seg.reason = START_HELD
            seg.message = clear + (
                ": Reach does not plan from a start its model holds that deep in an obstacle; "
                "move the arm or the obstacle a little apart, or raise the start contact "
                "tolerance" if deep else
                ", and no move of the model leaves it: the arm cannot move from its start pose; "
                "move the arm or the obstacle a little apart, or lower the clearance")


def _moving_in_as_it_shows(armature, info, seg, coming, sweep) -> None:
    """``start_held`` for a segment refused because ``coming`` = (obstacle, frame) moves
    into its start pose, where the skin as it starts (clavicle included) stays clear of
    that obstacle at every instant the planner sampled on that frame."""
    name, frame = coming
    pieces = [p for ps in sweep(frame, frame).get(frame, []) for p in ps if p[0] == name]
    if not pieces:
        return
    length = info.arm.arm_length
    skin = skin_clearance(info, armature, obstacles_from_pieces(pieces), 0.5 * length,
                          clavicle=True)
    if skin <= 0.0:
        return
    at = re.search(r"start pose (\(at the [^)]*\))", seg.message)
    lasts = re.search(r"while the reach .*?clear\)", seg.message)
    seg.reason = START_HELD
    seg.message = (
        f"'{name}' comes to the arm's start pose{' ' + at.group(1) if at else ''} on frame "
        f"{frame} as Reach models the arm (one capsule per segment, fuller than the skin "
        f"there), although its skin stays {100.0 * skin * info.arm.metres_per_unit:.1f} cm "
        f"({skin / length:.3f} arm lengths) clear"
        f"{', ' + lasts.group(0) if lasts else ''}: Reach moves the arm, not the body, so "
        "the body cannot get out of its way; stop its animation during the reach, move the "
        "character a little, or lower the clearance")


def measure_orientation(context, armature, info, results, settings) -> None:
    """Replace, in place, the planned ``orientation_error_deg`` and ``orientation_met`` of
    each baked result of ``results`` (:class:`TaskResult`) that has them by what
    Blender's evaluated bones show at its last frame: the fingers' direction
    (:func:`.hand_reading.finger_axis`) and the palm (:func:`.hand_reading.palm_normal`),
    read as they were read from the start pose, against the target's axes
    (:func:`~reach_addon.core.orient.wanted_axes`; degrees, met within
    ``settings.orientation_tolerance``). Changes the scene's frame (to each result's last)."""
    scene = context.scene
    hands = info.hand_bones or (info.bones.arms[info.side].hand,)
    to_world = info.arm.to_world[:3, :3]
    for r in results:
        if r.stats.get("orientation_error_deg") is None or not r.bones_keyed:
            continue
        target = bpy.data.objects.get(r.target)
        if target is None:
            continue
        scene.frame_set(r.frame_end)
        axis, _l, _s = hand_reading.hand_shape(armature, hands[0], info.arm.forearm_length, hands)
        d = hand_reading.finger_axis(armature, hands, axis)
        n, _source = hand_reading.palm_normal(armature, hands, axis, info.frame.up, to_world.T)
        finger, palm = wanted_axes(np.array(target.matrix_world)[:3, :3], settings.finger_axis,
                                   settings.palm_axis)
        error = float(frame_angle(palm_frame(d, to_world @ n), palm_frame(finger, palm)))
        r.stats["orientation_error_deg"] = error
        r.stats["orientation_met"] = error <= settings.orientation_tolerance


def measure_baked(context, armature, info, results, settings, obstacles, plans=()) -> None:
    """What Blender's evaluated bones show of each baked result of ``results``, put into
    its stats in place: the wrist's arrival on the target (:func:`measure_arrival`, with
    ``plans``), the orientation (:func:`measure_orientation`), the naturalness
    (:func:`measure_naturalness`) and the balance (:func:`.balance.measure`)."""
    measure_arrival(context, armature, info, results, plans, settings)
    measure_orientation(context, armature, info, results, settings)
    measure_naturalness(context, armature, info, results, settings, obstacles)
    balance.measure(context, armature, info, results)


def measure_naturalness(context, armature, info, results, settings, obstacles=None) -> None:
    """Put, in place, into each baked result of ``results`` (:class:`TaskResult`) what
    Blender's evaluated bones show over its frames: ``mean_wrist_bend_deg`` and
    ``max_wrist_bend_deg``, the angle between the hand's axis
    (:func:`.hand_reading.hand_shape`) and where the rig's rest pose would hold it on the
    forearm as it is (:func:`.rig.rest_hand_axis`), replacing the plan's own figures;
    ``chicken_wing_frames``, the frames with the elbow more than ``settings.wing_margin``
    arm lengths above the shoulder and the wrist more than that below it (along the body's
    up axis, :func:`~reach_addon.core.elbow.chicken_wing`); and with ``obstacles`` (the
    run's :class:`~reach_addon.core.collision.Obstacles`) ``forced_bend_frames``, the
    frames bent more than :data:`FORCED_FROM` where the hand held at its rest alignment,
    or turned straight back to it, would come within ``settings.clearance`` (arm
    lengths, which a keyed pose keeps) of an obstacle (:func:`relaxed_hand_hits`), and
    ``bend_forced_by``, the obstacle it meets most often (None without any). Changes the scene's frame."""
    scene = context.scene
    bones = info.bones.arms[info.side]
    hands = info.hand_bones or (bones.hand,)
    up, length = np.asarray(info.frame.up, dtype=float), info.arm.arm_length
    mw = np.array(armature.matrix_world)
    pb = armature.pose.bones
    for r in results:
        if not r.bones_keyed or r.frame_end < r.frame_start:
            continue
        bends, wings, forced = [], [], []
        for f in range(r.frame_start, r.frame_end + 1):
            scene.frame_set(f)
            axis, _l, _s = hand_reading.hand_shape(armature, hands[0], info.arm.forearm_length,
                                                   hands)
            rest = rest_hand_axis(armature, bones, axis)
            bends.append(float(np.degrees(np.arccos(np.clip(axis @ rest, -1.0, 1.0)))))
            s, e, w = (mw[:3, :3] @ np.array(pb[n].head) + mw[:3, 3]
                       for n in (bones.upper_arm, bones.forearm, bones.hand))
            if chicken_wing(float(s @ up), float(e @ up), float(w @ up), length,
                            settings.wing_margin):
                wings.append(f)
            if obstacles is not None and bends[-1] > FORCED_FROM:
                hit = relaxed_hand_hits(obstacles, info.arm, w, rest, settings.clearance * length,
                                        axis)
                if hit is not None:
                    forced.append(hit)
        r.stats["mean_wrist_bend_deg"] = float(np.mean(bends))
        r.stats["max_wrist_bend_deg"] = float(np.max(bends))
        r.stats["chicken_wing_frames"] = len(wings)
        if obstacles is not None:
            r.stats["forced_bend_frames"] = len(forced)
            r.stats["bend_forced_by"] = max(set(forced), key=forced.count) if forced else None


#: Degrees of wrist bend from which a frame's bend is asked whether an obstacle forced it
#: (RULA scores a wrist beyond 15° from neutral as a risk).
FORCED_FROM = 15.0


def relaxed_hand_hits(obstacles, arm, wrist, rest_axis, margin: float = 0.0, axis=None):
    """The obstacle (name) the hand held at its rest alignment at ``wrist`` (world) would
    come within ``margin`` (figure units; the planner's clearance) of: its capsule from
    the wrist along ``rest_axis`` for the hand's length, with the hand's radius
    (:class:`~reach_addon.core.arm.ArmModel`), sampled every half radius; with ``axis``
    (the hand's axis now) also on the way there, the hand turned straight from ``axis``
    toward ``rest_axis`` in steps of at most :data:`SWEEP_STEP_DEG` (a hand bent past a
    shelf's edge whose rest alignment is clear cannot turn back through the shelf); None
    if it keeps that margin throughout."""
    radius, length = arm.hand_radius, arm.hand_length
    n = max(2, int(np.ceil(length / (0.5 * max(radius, 1e-9)))) + 1)
    for direction in _turn_toward(axis, rest_axis):
        for t in np.linspace(0.0, 1.0, n):
            hit = obstacles.nearest(wrist + t * length * direction, radius + margin)
            if hit is not None:
                return obstacles.owner(hit[2])
    return None


#: The step (degrees) of :func:`relaxed_hand_hits`' turn back to the rest alignment.
SWEEP_STEP_DEG = 5.0


def _turn_toward(axis, rest_axis) -> list:
    """Unit directions between ``axis`` and ``rest_axis`` along the great circle, at most
    :data:`SWEEP_STEP_DEG` apart, ``rest_axis`` first, ``axis`` itself (the hand as it
    is, which the planner keeps clear) left out; ``[rest_axis]`` without ``axis``."""
    b = np.asarray(rest_axis, dtype=float)
    b = b / np.linalg.norm(b)
    if axis is None:
        return [b]
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    angle = float(np.arccos(np.clip(a @ b, -1.0, 1.0)))
    steps = int(np.ceil(np.degrees(angle) / SWEEP_STEP_DEG))
    if steps == 0 or np.sin(angle) < 1e-9:
        return [b]
    out = [b]
    for t in np.linspace(1.0, 0.0, steps + 1)[1:-1]:
        d = (np.sin((1.0 - t) * angle) * a + np.sin(t * angle) * b) / np.sin(angle)
        out.append(d / np.linalg.norm(d))
    return out


#: How much farther than the goal tolerance (arm lengths) the evaluated wrist may end from
#: its target: float32 round-off in Blender's matrices only.
ARRIVAL_SLACK = 1e-4


def measure_arrival(context, armature, info, results, plans, settings) -> None:
    """Put, in place, into each result of ``results`` that reached its target and was
    keyed ``wrist_gap_arm_lengths``: how far the wrist (the hand bone's head, as Blender
    evaluates the keys) is from the target its plan arrived at, on the frame it arrived
    (``plans``: the run's :class:`.bake.KeyedPlan` list, whose segments ``results``
    follow in order; a chase, whose target moves on, is left out). Where that is more than
    the goal tolerance (``Settings.goal_tolerance``, plus :data:`ARRIVAL_SLACK`) the result
    is no success: reason ``rig_off_target``, its message saying how far off and which
    bones were keyed. The target object is read there too, as Blender evaluates it on that
    frame: where it has moved from where the plan took it (its keys, a parent, a
    constraint, the character carrying it) and the wrist is off it by more than the
    tolerance, the reason is ``target_moved`` (:func:`moved_message`). The keys stay (the
    user sees what the rig does with them). Changes the scene's frame."""
    segments = [(k.plan, seg) for k in plans for seg in k.plan.segments]
    if len(segments) != len(results):
        return
    scene = context.scene
    hand = info.bones.arms[info.side].hand
    mw = np.array(armature.matrix_world)
    length = info.arm.arm_length
    tolerance = settings.goal_tolerance + ARRIVAL_SLACK
    for r, (plan, seg) in zip(results, segments):
        if not r.success or not r.bones_keyed or plan.task.kind == "chase":
            continue
        scene.frame_set(r.frame_end)
        wrist = mw[:3, :3] @ np.array(armature.pose.bones[hand].head) + mw[:3, 3]
        planned = np.asarray(seg.target, dtype=float)
        gap = float(np.linalg.norm(wrist - planned)) / length
        r.stats["wrist_gap_arm_lengths"] = round(gap, 6)
        target = bpy.data.objects.get(r.target)
        if target is not None:
            where = np.array(target.matrix_world.translation)
            moved = float(np.linalg.norm(where - planned)) / length
            off = float(np.linalg.norm(wrist - where)) / length
            if moved > tolerance and off > tolerance:
                r.success, r.reason = False, TARGET_MOVED
                r.message = moved_message(r, moved, off, plan.task.kind)
                continue
        if gap <= tolerance:
            continue
        r.success, r.reason = False, RIG_OFF_TARGET
        r.message = (f"planned to reach '{r.target}', but the keys put the wrist {gap:.3f} "
                     f"arm lengths from it on frame {r.frame_end}: the rig's constraints "
                     f"move the keyed bones ({', '.join(r.bones_keyed[:6])}) otherwise than "
                     "Reach models them; the keys are left for you to see (please report "
                     "the rig)")


def moved_message(r, moved: float, off: float, kind: str) -> str:
    """The message of a ``target_moved`` result ``r``: the target went ``moved`` arm
    lengths from where the plan took it, and the wrist ends ``off`` from it."""
    return (f"planned to reach '{r.target}' where it stood on the frame Reach planned "
            f"from, but on frame {r.frame_end}, when the wrist arrives, the target is "
            f"{moved:.3f} arm lengths from there (its keys, a parent or a constraint move "
            f"it) and the wrist {off:.3f} from it: a {kind} goes to a target that stands "
            "still; use the chase task to follow a moving target, or keep it still while "
            "the reach lasts; the keys are left for you to see")
