"""The head's gaze on a rig (:mod:`..core.gaze`): once the motion is keyed, the neck bone
is keyed so the head looks at each target in turn (``Settings.gaze``).

**The bone** is the rig's neck (:attr:`.rig_detect.BoneMap.neck`, the spine above the
chest): turning it carries the head and everything on it, the cervical spine taken as one
joint at its base. On a generated Rigify rig it is the ``head`` control, which the
``ORG-`` and ``DEF-`` head follow through constraints: its ``neck`` control does not turn
the head unless *Head Follow* is on (the head keeps the torso's orientation), and the
head control turns it whichever way that is set; it turns about the top of the neck.
That it turns the head is read as Blender evaluates it (:func:`_turns_the_head`). Not
keyed, with the reason in the report: a rig without a neck, a neck with keys a user set
(:func:`.own_keys.users_keys`: a bake again over Reach's own keys replaces them), a Rigify
head control that is missing, constrained or does not turn the head.

**The aim** is read on every frame as Blender evaluates the keyed motion (the lean, the
chest's turn): the neck's forward and up are the body's at the start frame, carried by the
neck's turn since (keys of an earlier bake left out: the neck at its channels on the
first frame);
the eyes are taken :data:`EYES` of the way from the neck's base to the
top of the head (the highest point of its skin, else the farthest bone end above the
neck), and the aim is the one whose line of sight from there meets the target
(:func:`~..core.gaze.gaze_angles`). Each frame looks at the target of the plan's segment it belongs
to (a chase's target at that frame; the first target through a lean before the reach).

**Clear of obstacles**: the head's skin (the vertices the neck's bones move) is carried by
the neck's turn on every frame and checked against the obstacles as a lean's trunk is
(:func:`~..core.lean.skin_hit`); where the turn brings it within the clearance, the turn
is halved, then left out (said in the report).
"""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from ..core.gaze import clip_gaze, gaze_angles, gaze_blend, gaze_rotation
from ..core.lean import skin_hit
from .bone_matrices import channel_values
from . import own_keys
from .carried import carrying_bone, under
from .fcurves import Channels, ensure_action, write_channel
from .own_keys import users_keys
from .rig_detect import constrained, followers
from .skin import skin_points

#: Where the eyes are, as a share of the way from the neck's base to the top of the head.
EYES = 0.6
#: The shares of the aimed turn tried in turn where the head's skin would touch.
SHARES = (1.0, 0.5)


def neck_of(armature, info, targets=()) -> tuple:
    """(the neck bone's name, None), or (None, why the head does not turn): among the
    reasons, one of ``targets`` (objects) carried by the neck or a bone it carries, which
    the turn would move (:func:`.carried.carrying_bone`)."""
    neck = info.bones.neck
    if neck is None or neck not in armature.pose.bones:
        return None, "Reach finds no neck on this rig"
    if info.bones.key_chest:                 # a generated Rigify rig: its head control
        pb = armature.pose.bones.get(RIGIFY_HEAD)
        if pb is None or constrained(pb):
            return None, f"this Rigify rig has no free '{RIGIFY_HEAD}' control to turn"
        if not _turns_the_head(armature, RIGIFY_HEAD, neck):
            return None, f"turning its '{RIGIFY_HEAD}' control does not turn the head"
        neck = RIGIFY_HEAD
    if users_keys(armature, neck):
        return None, f"bone '{neck}' has keys of its own"
    for t in targets:
        bone = carrying_bone(t, armature)
        if bone is not None and under(armature, bone, {neck}):
            return None, (f"target '{t.name}' is carried by bone '{bone}', which the head's "
                          "turn would move")
    return neck, None


#: The head control of a generated Rigify rig, the bone the gaze keys there.
RIGIFY_HEAD = "head"
#: The test turn (radians) by which :func:`_turns_the_head` reads whether the head follows.
TEST_TURN = 0.2


def _turns_the_head(armature, control: str, neck: str) -> bool:
    """Whether turning ``control`` turns the head by as much, as Blender evaluates it:
    the head, the last bone of ``neck``'s connected chain, is read before and after a test
    turn of :data:`TEST_TURN` about the control's own x axis, then the pose is put back."""
    pbs = armature.pose.bones
    head = pbs[neck]
    while any(c.bone.use_connect for c in head.children):
        head = next(c for c in head.children if c.bone.use_connect)
    pb = pbs[control]
    kept = pb.matrix_basis.copy()

    def turn_of_head():
        m = np.array(head.matrix)[:3, :3]
        return m / np.linalg.norm(m, axis=0)

    before = turn_of_head()
    try:
        from mathutils import Matrix
        pb.matrix_basis = kept @ Matrix.Rotation(TEST_TURN, 4, "X")
        bpy.context.view_layer.update()
        after = turn_of_head()
    finally:
        pb.matrix_basis = kept
        bpy.context.view_layer.update()
    angle = np.arccos(np.clip((np.trace(after @ before.T) - 1.0) / 2.0, -1.0, 1.0))
    return abs(float(angle) - TEST_TURN) <= 0.05 * TEST_TURN


def targets_by_frame(plans, first: int, last: int) -> tuple:
    """(world target (F, 3), the frame index its target was taken up on (F,)) for the
    frames ``first``..``last`` of ``plans`` (:class:`.bake.KeyedPlan`, in frame order):
    each segment's target over its frames, a chase's target at each frame; frames before a
    plan (a lean) look at its first target, frames after its last segment keep to that."""
    n = last - first + 1
    target, start = np.zeros((n, 3)), np.zeros(n, dtype=int)
    marks = []                                   # (frame index, target or chase targets)
    for keyed in plans:
        plan, f0 = keyed.plan, keyed.first_frame
        if plan.task.kind == "chase":
            marks.append((f0 - first, np.asarray(plan.task.targets, dtype=float)))
            continue
        for seg in plan.segments:
            marks.append((f0 + seg.frame_start - first, np.asarray(seg.target, dtype=float)))
    marks.sort(key=lambda m: m[0])
    for i, (at, aim) in enumerate(marks):
        lo = 0 if i == 0 else max(0, at)
        hi = n if i + 1 == len(marks) else max(lo, min(n, marks[i + 1][0]))
        if aim.ndim == 2:
            k = np.clip(np.arange(lo, hi) - at, 0, len(aim) - 1)
            target[lo:hi] = aim[k]
        else:
            target[lo:hi] = aim
        start[lo:hi] = lo
    return target, start


def key(context, armature, info, plans, frames, settings, checker, fps: float,
        targets=()) -> dict:
    """Key the neck over ``frames`` (first, last) so the head looks at the targets of
    ``plans`` (see the module docstring), the head's skin kept clear by ``checker``;
    ``targets``: the target objects (one the neck carries keeps it still, :func:`neck_of`).
    Returns the report's figures: ``gaze_bone``, ``gaze_deg`` (the largest turn keyed),
    ``gaze_share`` (of the aimed turn), or ``gaze_note`` where the head does not turn."""
    neck, why = neck_of(armature, info, targets)
    if neck is None:
        return {"gaze_note": why}
    first, last = int(frames[0]), int(frames[1])
    scene = context.scene
    now = (scene.frame_current, scene.frame_subframe)
    try:
        aims, starts, mats, ref = _aims(context, armature, info, neck, plans, first, last,
                                        settings)
    finally:
        scene.frame_set(now[0], subframe=now[1])
    turns = gaze_blend(aims, starts, fps, settings)
    pb = armature.pose.bones[neck]
    forward, up, skin = ref.forward, ref.up, ref.skin
    mw = np.array(armature.matrix_world)
    for share in SHARES:
        rotations = np.array([gaze_rotation(forward, up, *(share * t)) for t in turns])
        hit = None if skin is None else skin_hit(_carried(skin, mats, rotations, mw), checker)
        if hit is None:
            break
    else:
        return {"gaze_note": f"turning the head would bring it against '{hit[1]}' on the "
                f"motion's frame {first + hit[0]}"}
    basis = ref.basis
    bases = np.repeat(basis[None], len(rotations), 0)
    bases[:, :3, :3] = basis[:3, :3] @ rotations
    channels = Channels(armature, ensure_action(armature, False))
    path, values = channel_values(pb, bases)
    write_channel(channels, f'pose.bones["{neck}"].{path}', values,
                  np.arange(first, last + 1, dtype=float), neck)
    own_keys.record(channels.action, [neck], first, last)
    context.view_layer.update()
    return {"gaze_bone": neck, "gaze_share": share,
            "gaze_deg": round(float(np.abs(share * turns).max(initial=0.0)), 1)}


@dataclass(frozen=True)
class NeckFrame:
    """The neck as it stands at a reference pose (the motion's first frame, or Live's
    start): its ``name``, its channel matrix ``basis`` and armature-space matrix ``matrix``
    then, the body's ``forward`` and ``up`` and the ``eyes`` in its own axes, and the head's
    ``skin`` (:func:`_head_skin`, its own axes; None without skin)."""

    name: str
    basis: np.ndarray
    matrix: np.ndarray
    forward: np.ndarray
    up: np.ndarray
    eyes: np.ndarray
    skin: np.ndarray | None


def neck_frame(armature, info, neck) -> NeckFrame:
    """The :class:`NeckFrame` of ``neck`` as the rig is evaluated now."""
    pb = armature.pose.bones[neck]
    to_arm = np.linalg.inv(np.array(armature.matrix_world))
    m0 = np.array(pb.matrix)
    r0 = m0[:3, :3] / np.linalg.norm(m0[:3, :3], axis=0)
    up = r0.T @ _unit(to_arm[:3, :3] @ np.asarray(info.frame.up, dtype=float))
    forward = r0.T @ _unit(to_arm[:3, :3] @ np.asarray(info.frame.forward, dtype=float))
    forward = _unit(forward - (forward @ up) * up)
    skin = _head_skin(armature, neck, m0)
    top = _head_top(armature, neck, m0, skin, up)
    eyes = np.linalg.solve(m0, np.append(m0[:3, 3] + EYES * (top - m0[:3, 3]), 1.0))[:3]
    return NeckFrame(neck, np.array(pb.matrix_basis), m0, forward, up, eyes, skin)


def aim_from(ref: NeckFrame, matrix, target_arm, settings) -> tuple:
    """The clipped (yaw, pitch) toward ``target_arm`` (armature space) from the neck at the
    armature-space ``matrix`` (its reference turn, without a gaze)."""
    local = np.linalg.solve(matrix, np.append(np.asarray(target_arm, dtype=float), 1.0))[:3]
    return clip_gaze(*gaze_angles(local, ref.forward, ref.up, ref.eyes), settings)


def _aims(context, armature, info, neck, plans, first, last, settings) -> tuple:
    """The clipped aim (yaw, pitch) on each frame (F, 2), its target's start frames, the
    neck's armature-space matrices (F, 4, 4) and its :class:`NeckFrame` at the first frame,
    each frame evaluated as keyed."""
    scene = context.scene
    pb = armature.pose.bones[neck]
    to_arm = np.linalg.inv(np.array(armature.matrix_world))
    target_w, starts = targets_by_frame(plans, first, last)
    targets = target_w @ to_arm[:3, :3].T + to_arm[:3, 3]
    scene.frame_set(first)
    ref = neck_frame(armature, info, neck)
    aims, mats = [], []
    for k, f in enumerate(range(first, last + 1)):
        scene.frame_set(f)
        # the neck at its first frame's channels (M = A B: A B_ref = M B⁻¹ B_ref), so an
        # earlier bake's keys, which these replace, do not turn the aim
        m = np.array(pb.matrix) @ np.linalg.inv(np.array(pb.matrix_basis)) @ ref.basis
        aims.append(aim_from(ref, m, targets[k], settings))
        mats.append(m)
    return np.array(aims), starts, np.array(mats), ref


def look_now(context, armature, ref: NeckFrame, target_world, settings, checker) -> float:
    """Live: turn the neck (its rotation channels, no keys) so the head looks at
    ``target_world`` from the pose on screen, the head's skin held clear as a bake holds
    it (the turn halved, then none, where it would touch). Returns the share taken."""
    pb = armature.pose.bones[ref.name]
    mw = np.array(armature.matrix_world)
    # the neck's matrix without the turn it has now: M = A B, so A B_ref = M B⁻¹ B_ref
    m = np.array(pb.matrix) @ np.linalg.inv(np.array(pb.matrix_basis)) @ ref.basis
    target = np.linalg.solve(mw, np.append(np.asarray(target_world, dtype=float), 1.0))[:3]
    aim = np.array(aim_from(ref, m, target, settings))
    mats = np.array([m, m])
    share = 0.0
    for tried in SHARES:
        turn = gaze_rotation(ref.forward, ref.up, *(tried * aim))
        if ref.skin is None or skin_hit(_carried(ref.skin, mats, [np.eye(3), turn], mw),
                                        checker) is None:
            share = tried
            break
    basis = ref.basis.copy()
    basis[:3, :3] = ref.basis[:3, :3] @ gaze_rotation(ref.forward, ref.up, *(share * aim))
    path, values = channel_values(pb, basis[None])
    setattr(pb, path, tuple(float(v) for v in values[-1]))
    return share


def _head_top(armature, neck, m0, skin, up) -> np.ndarray:
    """The top of the head (armature space, as posed at the first frame, ``m0`` the neck's
    matrix then): the highest point of its skin along ``up`` (the neck's own axes), else
    the farthest bone end from the neck's base among the neck's bones (a head's bones may
    reach well past its skin: the Alien's do)."""
    if skin is not None:
        local = skin[int(np.argmax(skin @ up))]
        return m0[:3, :3] @ local + m0[:3, 3]
    pbs = [armature.pose.bones[neck]] + list(armature.pose.bones[neck].children_recursive)
    base = np.array(pbs[0].head)
    return max((np.array(b.tail) for b in pbs), key=lambda t: float(np.linalg.norm(t - base)))


def _head_skin(armature, neck, m0) -> np.ndarray | None:
    """The head's skin (the vertices the neck's bones move, and the bones that follow them
    through constraints: :func:`.rig_detect.followers`) in the neck's own axes at the
    first frame (``m0``, its armature-space matrix then), or None where it has none."""
    names = followers(armature, {neck})
    pts = skin_points(armature, names, share=True)
    if not len(pts):
        return None
    mw = np.array(armature.matrix_world)
    local = np.linalg.inv(mw @ m0)
    return pts @ local[:3, :3].T + local[:3, 3]


def _carried(skin, mats, rotations, mw) -> np.ndarray:
    """The head's skin (neck axes) on each frame (F, n, 3, world): turned by the gaze in the
    neck's axes, carried by the neck's matrix at that frame."""
    out = []
    for m, r in zip(mats, rotations):
        w = mw @ m
        out.append((skin @ r.T) @ w[:3, :3].T + w[:3, 3])
    return np.array(out)


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / max(float(np.linalg.norm(v)), 1e-12)
