"""The trunk's lean on a rig (:mod:`..core.whole_body`): the bone that leans it, the plan
(held to the balance, :mod:`.lean_balance`), its keys (posed by :mod:`.lean_pose`) and its
report.

**The lean bone** (:func:`lean_bone`) is the highest bone of the chest's chain (the bone
the arms hang from, its parent, and so on up) that carries neither leg
(:func:`.balance.find_legs`) and has no constraint of its own (:func:`.rig_detect.constrained`):
turning it turns the chest, both arms and the head rigidly about its head, which is the
lean's pivot, and leaves the legs and feet where they are; a key on it is what Blender
evaluates. On most rigs it is the lowest spine bone above the hips (the hips carry the
legs). On a generated Rigify rig it is the FK control ``spine_fk.002``: the ``chest``
control turns the spine through two constraints at half influence each, about two
joints, and a lean keyed on it put the shoulder 0.2 arm lengths off where a rigid turn
about its head puts it (fuzz seed 40071). A rig without legs has none, and does not lean.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import bpy
import numpy as np
from mathutils import Matrix

from ..core import Planner
from ..core.lean import TrunkSkin
from ..core.squat import leg_angles
from ..core.errors import NEEDS_STEP
from ..core.whole_body import (LeanPhase, body_held_back, body_target, lean_then_reach,
                               wants_body, wants_step)
from . import balance, own_keys, skin
from . import hips as hips_mod
from . import bake as bake_mod
from .bake import KeyedPlan
from .bone_matrices import channel_values
from .fcurves import Channels, ensure_action, write_channel
from .lean_balance import BalanceBody, BalanceCheck
from .lean_pose import (lean_basis, pivot_world, pose_lean, pose_leaned, shift_world,
                        world_rotations)
from .own_keys import users_keys
from .rig_detect import ancestors, constrained


def lean_bone(armature, bmap, legs) -> str | None:
    """The bone that leans the trunk (see the module docstring), or None without legs."""
    if not legs:
        return None
    bones = armature.data.bones
    hips = [bones[leg.hip[0]] for leg in legs]
    carried = {b.name for h in hips for b in [h] + ancestors(h)}
    chain = [bones[bmap.chest]] + ancestors(bones[bmap.chest])
    found = None
    for b in chain:
        if b.name in carried:
            break
        if not constrained(armature.pose.bones[b.name]):
            found = b.name
    return found


def hips_keyed(armature, hips: str, legs) -> str | None:
    """The first bone the hips' shift would key that has keys a user set (the hips bone's
    location, a leg bone's rotation: :func:`.own_keys.users_keys`), or None."""
    if users_keys(armature, hips, "location"):
        return hips
    return next((n for n in hips_mod.leg_bones(armature, legs) if users_keys(armature, n)),
                None)


@dataclass
class RigLean:
    """A lean planned on the rig: the core's ``phase`` (:class:`~..core.whole_body.
    LeanPhase`), the lean ``bone``, its channel matrices ``bases`` on the lean's frames
    (the first upright, the last the reach's first frame), the ``frame_start`` it starts
    on, and the centre of mass's ``margin`` over the feet at the full lean, the arm at its
    start (world units)."""

    phase: LeanPhase
    bone: str
    bases: np.ndarray
    frame_start: int
    margin: float
    #: the hips bone and the legs it moves where the lean moves the hips back, else None
    hips: str | None = None
    legs: tuple = ()
    #: the worst knee flexion, ankle dorsiflexion and thigh flexion over both legs at the
    #: full lean (degrees, :func:`~..core.squat.leg_angles`), where the hips move
    leg_angles: tuple | None = None
    #: the ready reach before the lean (:attr:`~..core.whole_body.LeanPhase.ready`) as the
    #: bake keys it: on the leaned trunk, checked on the upright one; None without one
    ready: KeyedPlan | None = None
    #: where the lean was taken instead of an upright reach that turned the chest past
    #: Table 1's (:func:`~..core.effort.twist_for_reach`), that twist (degrees), else None
    spared_twist: float | None = None
    #: the index, among the reaches after the upright ones (``phase.ready_reaches``), of the
    #: target that twist was at
    spared_at: int = 0

    @property
    def lean_first(self) -> int:
        """The lean's first frame (after the ready reach, where there is one)."""
        return self.frame_start + self.phase.ready_frames

    @property
    def reach_first(self) -> int:
        """The reach's first frame (the lean's last)."""
        return self.lean_first + self.phase.frames


def plan(context, armature, info, planner, keyed, aim: int | None = None,
         ceiling: float | None = None):
    """Try a lean where ``keyed`` (the :class:`.bake.KeyedPlan` of a single reach, a
    sequence or a guided reach) was refused as ``needs_lean`` (or as ``out_of_reach`` below
    the arm, for a squat) and ``Settings.lean`` is on, toward the target
    :func:`~..core.whole_body.body_target` picks (:func:`~..core.whole_body.
    lean_then_reach`), among ``planner``'s obstacles and
    settings, each lean held to the balance (:class:`.lean_balance.BalanceCheck`). Returns
    (:class:`RigLean`, the reach's KeyedPlan on the leaned trunk); or (None, ``keyed``)
    with its message saying why no lean was planned. ``aim``: where ``keyed`` reached a
    target with the chest turned past Table 1's (:func:`~..core.effort.twist_for_reach`),
    the index of the target to lean toward instead, and ``ceiling`` the upright reach's
    trunk effort per arrival from there on, which a lean must stay below
    (:func:`~..core.whole_body.lean_then_reach`);
    ``keyed`` is then returned as it is where no lean is planned."""
    made = []

    def make_planner(arm, settings=None):
        made.append(Planner(arm, planner.obstacles, settings or planner.settings))
        return made[-1]

    failed, task = keyed.plan, keyed.plan.task
    aim = body_target(planner.settings, task, failed, info.arm) if aim is None else aim
    if aim is None:
        held_back, helped = body_held_back(planner.settings, task, failed, info.arm)
        for seg in helped:
            seg.message += f"; with Lean on: {held_back}"
        return None, keyed
    legs = balance.find_legs(armature, info.bones, info.frame)
    bone = lean_bone(armature, info.bones, legs)
    standing = None if bone is None else balance.standing_why_not(
        armature, legs, info.frame.ground, "lean")
    if bone is None:
        why = "Reach finds no legs on this rig, and leans only a body standing on its feet"
    elif standing is not None:
        why = standing
    elif users_keys(armature, bone):
        why = f"bone '{bone}', which leans the trunk, has keys of its own"
    else:
        pivot = info.arm.to_canonical_points(pivot_world(armature, bone))
        target = np.asarray(task.targets[aim], dtype=float)
        check = BalanceCheck(context, armature, info, legs, bone, target,
                             planner.generator.checker)
        keyed_own = None if check.hips is None else hips_keyed(armature, check.hips, legs)
        body = None if check.hips is None or keyed_own else BalanceBody(
            context, armature, info, legs, bone, check.hips, planner.settings, check)
        phase, reach_or_why = lean_then_reach(planner, task, failed, pivot, make_planner, check,
                                              trunk_skin(armature, info, bone), body,
                                              split=bone != info.bones.keyed_chest, aim=aim,
                                              ceiling=ceiling)
        if phase is not None:
            bases = lean_basis(armature, bone, world_rotations(info, phase.lean, phase.fractions))
            first = keyed.first_frame
            moved = bool(np.any(phase.lean.shift))
            angles = None if not moved or body is None else tuple(float(a) for a in np.max(
                [leg_angles(j, shift_world(info, phase.lean), np.asarray(info.frame.ground, float))
                 for j in body.leg_joints], axis=0))
            checker = planner.generator.checker
            ready = None if phase.ready is None else KeyedPlan(
                dataclasses.replace(phase.ready, arm=phase.arm), first, (checker,), True,
                moving=phase.ready)
            lean = RigLean(phase, bone, bases, first, check.margins[-1],
                           check.hips if moved else None, tuple(legs) if moved else (), angles,
                           ready)
            return lean, KeyedPlan(reach_or_why, lean.reach_first,
                                   (made[-1].generator.checker,), True)
        why = reach_or_why
        if keyed_own and planner.settings.lean_hips_back:
            why += f" (the hips stay: bone '{keyed_own}' has keys of its own)"
    if failed.success:
        return None, keyed
    for seg in failed.segments:
        if seg.reason == failed.reason:
            seg.message += f"; with Lean on: {why}"
    return None, keyed


def note_moving(plan, moving) -> None:
    """Say, in the message of ``plan`` (a single reach refused for a target the body could
    reach, or step toward), that the body does not lean or step among obstacles that move
    during the reach (``moving``: their names): the body's checks hold the scene still."""
    names = ", ".join(f"'{n}'" for n in moving[:3]) + (" ..." if len(moving) > 3 else "")
    _note_still(plan, f"among obstacles that hold still, and {names} move during the reach")


def note_carried(plan, target: str, bone: str) -> None:
    """Say, in the message of ``plan`` (as :func:`note_moving`'s), that the body does not
    lean or step toward a ``target`` its own ``bone`` carries: the move would carry the
    target on (fuzz seed 193: a step toward a target on the other hand left the wrist
    0.55 arm lengths from it)."""
    _note_still(plan, f"toward a target it does not carry, and '{target}' is carried by its "
                      f"bone '{bone}' (parent the target to something that stays still)")


def note_several(plans) -> None:
    """Say, in the message of each of ``plans`` (the reaches of one run to several targets,
    planned one after another) that the body would help, that a reach to several targets
    does not lean, step or squat: a sequence leans and squats
    (:func:`~..core.whole_body.body_target`); only a reach to one target steps."""
    for plan in plans:
        hint = "reach it on its own" if plan.reason == NEEDS_STEP else \
            "the sequence task reaches them in turn with a lean"
        _note_still(plan, f"in a reach to one target, and this run reaches {len(plans)} "
                          f"targets one after another ({hint})")


def _note_still(plan, clause: str) -> None:
    stepping = plan.reason == NEEDS_STEP and wants_step(plan.settings, plan.task, plan,
                                                         plan.arm)
    if not stepping and not wants_body(plan.settings, plan.task, plan, plan.arm):
        return
    for seg in plan.segments:
        if seg.reason == plan.reason:
            seg.message += (f"; with Lean on: the body {'steps' if stepping else 'leans'} "
                            f"only {clause}")


def trunk_skin(armature, info, bone) -> TrunkSkin | None:
    """The trunk as skinned, as Blender evaluates it now (:class:`~..core.lean.TrunkSkin`,
    canonical frame of ``info``'s arm): every vertex whose heaviest group is a bone the lean
    ``bone`` carries (it included), less the reaching arm's (the upper arm and below: the
    search checks the arm as it models it), and every vertex of a rigid part parented to
    such a bone; ``turns`` marks those the keyed chest carries. None where there is none
    (a rig without skin: the chest's and head's capsules stand in)."""
    bones = armature.data.bones
    a = info.bones.arms[info.side]
    arm = {a.upper_arm} | {b.name for b in bones[a.upper_arm].children_recursive}
    leaned = ({bone} | {b.name for b in bones[bone].children_recursive}) - arm
    chest = {info.bones.keyed_chest} | {b.name for b in bones[info.bones.keyed_chest].children_recursive}
    depsgraph = bpy.context.evaluated_depsgraph_get()
    points, turns = [], []
    for ob in skin.scene_objects(armature):
        if ob.type != "MESH":
            continue
        rigid = skin.rigid_part(ob, armature)
        if rigid is None and not skin.deformed_by(ob, armature):
            continue
        ev = ob.evaluated_get(depsgraph)
        if len(ev.data.vertices) != len(ob.data.vertices) or not len(ob.data.vertices):
            continue
        if rigid is not None:
            if rigid not in leaned:
                continue
            owners = [rigid] * len(ob.data.vertices)
        else:
            names = {vg.index: vg.name for vg in ob.vertex_groups}
            owners = [names.get(max(v.groups, key=lambda g: g.weight).group) if v.groups else None
                      for v in ob.data.vertices]
        keep = np.array([o in leaned for o in owners], bool)
        if not keep.any():
            continue
        co = np.empty(len(ev.data.vertices) * 3)
        ev.data.vertices.foreach_get("co", co)
        mw = np.array(ev.matrix_world)
        points.append(co.reshape(-1, 3)[keep] @ mw[:3, :3].T + mw[:3, 3])
        turns.append(np.array([o in chest for o, k in zip(owners, keep) if k], bool))
    if not points:
        return None
    return TrunkSkin(info.arm.to_canonical_points(np.concatenate(points)), np.concatenate(turns))


def bake(context, armature, info, lean: RigLean, plans, new_action: bool = False,
         spine=None):
    """Key the ready reach where there is one, the lean, then the reach on the leaned trunk
    (:func:`.bake.bake`, for ``info``'s arm on the leaned trunk): the plans are baked with
    the lean bone posed at the full lean (the ready reach's poses, relative to the trunk,
    key the same local rotations on either trunk); then, before the instants between keys
    are checked, the lean bone is keyed on the lean's frames (continuous with what the bake
    keyed on it, where it keyed it: the chest may be the lean bone), upright before them and
    held at the full lean through the reach, and every bone and switch the bake keyed holds
    its key at the reach's first frame through the lean (:func:`_key_lean`); ``spine`` as
    :func:`.bake.bake` takes it. Returns the
    bake's :class:`.bake.BakeResult`, its frame range from the first frame keyed."""
    pb = armature.pose.bones[lean.bone]
    before = pb.matrix_basis.copy()
    upright = {b.name: np.array(b.matrix) for b in armature.pose.bones}
    hips_keys = _hips_bases(context, armature, info, lean)
    pose_lean(context, armature, lean.bone, lean.bases[-1])
    for name, bases in hips_keys.items():
        armature.pose.bones[name].matrix_basis = Matrix(bases[-1].tolist())
    context.view_layer.update()
    ready = [] if lean.ready is None else [lean.ready]
    try:
        result = bake_mod.bake(context, armature, dataclasses.replace(info, arm=lean.phase.arm),
                               ready + list(plans), new_action,
                               then=lambda r: _key_lean(context, armature, info, lean, r,
                                                        hips_keys),
                               start_pose=carried_start(armature, lean.bone, upright),
                               spine=spine)
    except Exception:
        pb.matrix_basis = before
        context.view_layer.update()
        raise
    result.frames = (lean.frame_start, result.frames[1])
    return result


def carried_start(armature, bone: str, upright: dict) -> dict | None:
    """Every bone's armature-space pose matrix with the trunk at the full lean as the plan
    has it: the ``bone`` (the lean bone, posed now) and every bone it carries at their
    ``upright`` matrices (read before the lean) carried by the lean bone's move, the rest
    as posed now. A bone a constraint drives is not always carried by its parents: a
    Rigify arm in IK keeps its hand where its IK control is as the trunk leans, and the
    keys of a reach planned from the arm's start on the leaned trunk were turned from
    that instead (0.18 arm lengths off on the generated rig). None where no bone the lean
    bone carries has a constraint (:func:`.rig_detect.constrained`): parenting carries them, and the
    pose as it is now is that, to float32 (7e-7 on the demo's rig; the bake reads it so,
    as before, and keys it identically)."""
    carried = armature.data.bones[bone].children_recursive
    if not any(constrained(armature.pose.bones[b.name]) for b in carried):
        return None
    now = {b.name: np.array(b.matrix) for b in armature.pose.bones}
    carry = now[bone] @ np.linalg.inv(upright[bone])
    for b in carried:
        now[b.name] = carry @ upright[b.name]
    return now


def _key_lean(context, armature, info, lean: RigLean, result, hips_keys) -> None:
    """:func:`bake`'s keys of the lean, once the plans are keyed (``result``)."""
    pb = armature.pose.bones[lean.bone]
    last, lean_first, reach_first = result.frames[1], lean.lean_first, lean.reach_first
    channels = Channels(armature, ensure_action(armature, False))
    switches = [b for side, (b, _prop) in info.bones.ik_fk.items() if side == info.side]
    _hold(channels, set(result.bones) | set(switches), lean.bone, lean_first, reach_first)
    path, values = _channel_values_into(pb, channels, lean.bases, reach_first)
    full = f'pose.bones["{lean.bone}"].{path}'
    frames = lean_first + np.arange(len(lean.bases), dtype=float)
    write_channel(channels, full, values, frames, lean.bone)
    if last > reach_first and lean.bone not in result.bones:
        write_channel(channels, full, values[[-1, -1]], np.array([reach_first, last], float),
                      lean.bone)
    if lean.bone in result.bones and lean_first > lean.frame_start:
        # the chest is the lean bone and the ready reach keyed it on the leaned trunk:
        # upright there (the ready reach holds the chest)
        ready = np.arange(lean.frame_start, lean_first, dtype=float)
        write_channel(channels, full, values[[0] * len(ready)], ready, lean.bone)
    for name, bases in hips_keys.items():
        key_bone(channels, armature.pose.bones[name], bases, frames,
                  [reach_first, last] if last > reach_first else [], name == lean.hips)
    own_keys.record(channels.action, [lean.bone, *hips_keys], lean.frame_start, last)
    context.view_layer.update()


def _hips_bases(context, armature, info, lean: RigLean) -> dict:
    """Where the lean moves the hips back: the channel matrices (F, 4, 4) of the hips bone
    and the legs' bones (:func:`.hips.pose_shift`) on each frame of the lean, the shift
    growing with the lean (:meth:`~..core.lean.Lean.shift_at`); the pose is put back after. {} otherwise."""
    if lean.hips is None:
        return {}
    names = [lean.hips] + hips_mod.leg_bones(armature, list(lean.legs))
    # a leg bone a constraint drives (a generated Rigify rig's DEF bones, which follow its
    # IK legs) is posed for the measure, not keyed: its keys would do nothing
    keyed = [n for n in names if not constrained(armature.pose.bones[n])]
    out: dict = {n: [] for n in keyed}
    for basis, fraction in zip(lean.bases, lean.phase.fractions):
        with hips_mod.Posed(context, armature, [lean.bone] + names):
            pose_leaned(context, armature, info, lean.bone, basis, lean.legs, lean.hips,
                        shift_world(info, lean.phase.lean, float(fraction)))
            for n in keyed:
                out[n].append(np.array(armature.pose.bones[n].matrix_basis))
    return {n: np.array(v) for n, v in out.items()}


def key_bone(channels, pb, bases, frames, hold, location: bool) -> None:
    """Key ``pb``'s rotation (and ``location``) from its channel matrices ``bases`` on
    ``frames``, and hold the last on the frames ``hold`` (the reach's first and last)."""
    path, values = channel_values(pb, bases)
    keyed = [(f'pose.bones["{pb.name}"].{path}', values)]
    if location:
        keyed.append((f'pose.bones["{pb.name}"].location', np.array([b[:3, 3] for b in bases])))
    for p, v in keyed:
        write_channel(channels, p, v, frames, pb.name)
        if hold:
            write_channel(channels, p, v[[-1, -1]], np.array(hold, float), pb.name)


def _channel_values_into(pb, channels, bases, frame):
    """The lean bone's channel values for ``bases`` (:func:`.bone_matrices.channel_values`),
    continuous with what the action holds on ``frame`` (the last of them), where it keys
    the bone: walked from the last back, from the bone set to that value."""
    path = {"QUATERNION": "rotation_quaternion", "AXIS_ANGLE": "rotation_axis_angle"}.get(
        pb.rotation_mode, "rotation_euler")
    full = f'pose.bones["{pb.name}"].{path}'
    held = [channels.bag.fcurves.find(full, index=i) for i in range(4 if path != "rotation_euler" else 3)]
    if all(fc is not None and len(fc.keyframe_points) for fc in held):
        setattr(pb, path, [fc.evaluate(frame) for fc in held])
    path, values = channel_values(pb, bases[::-1])
    return path, values[::-1]


def _hold(channels, bones, lean_bone, frame_from, frame_to) -> None:
    """Every curve of ``bones`` (but the lean bone's) keyed on ``frame_to`` holds that value
    on the frames from ``frame_from`` up to it."""
    frames = np.arange(frame_from, frame_to, dtype=float)
    if not len(frames):
        return
    curves: dict = {}
    for fc in channels.bag.fcurves:
        for name in bones - {lean_bone}:
            if fc.data_path.startswith(f'pose.bones["{name}"]'):
                curves.setdefault((fc.data_path, name), []).append(fc)
    for (path, name), fcs in curves.items():
        fcs = sorted(fcs, key=lambda fc: fc.array_index)
        values = np.array([[fc.evaluate(frame_to) for fc in fcs]] * len(frames))
        write_channel(channels, path, values, frames, name)


#: How far the hips come down (arm lengths) before the report calls a lean a squat (a
#: lean with the hips back lowers them a little: the legs straighten no further).
SQUAT_REPORTED = 0.05


def reported(plans, lean: RigLean | None) -> list:
    """The run's :class:`.bake.KeyedPlan` list whose segments its results follow: ``plans``,
    after the ready reach where that reaches the task's first targets (a sequence's
    upright part, :attr:`~..core.whole_body.LeanPhase.ready_reaches`), as the bake keys
    them."""
    if lean is None or lean.ready is None or not lean.phase.ready_reaches:
        return list(plans)
    return [lean.ready] + list(plans)


def report(results, lean: RigLean | None, length: float) -> None:
    """Put the lean into the reach's result (:class:`.results.TaskResult`), in place: its
    ``stats`` gain ``lean_deg``, ``lean_frames``, ``lean_bone``, ``lean_hips_back`` and
    ``lean_hips_down`` (arm lengths), ``lean_com_margin`` (arm lengths: the least
    :class:`.lean_balance.BalanceCheck` weighed for the lean taken, over the reach's poses)
    and, where the hips move, ``lean_knee_deg``, ``lean_ankle_deg`` and ``lean_thigh_deg``
    (the worst leg's flexion, dorsiflexion and thigh flexion at the full lean), and
    ``lean_spared_twist_deg`` where the lean was taken instead of a twist; its message
    says so, and its frames start with the lean's. In a sequence the lean comes before the
    first target refused upright, or the first reached upright only by a twist it replaces
    (:func:`~..core.whole_body.upright_part`; the targets
    before it, reached upright, are left as they are): the later targets' frames are their
    own, and their messages say the body held its lean."""
    if lean is None:
        return
    upright = lean.phase.ready_reaches      # reached before the lean: as they were
    results = results[upright:]
    ready = lean.phase.ready
    # after a sequence's upright part: from its last arrival (the arm may rise first)
    after = None if not upright else lean.frame_start + ready.segments[upright - 1].frame_end
    rise = 0 if ready is None else lean.lean_first - (after if upright else lean.frame_start)
    raised = rise > 0
    for k, r in enumerate(results):
        if k == 0:      # a step may come before
            r.frame_start = after if upright else min(r.frame_start, lean.frame_start)
        shift = np.asarray(lean.phase.lean.shift, float) / lean.phase.arm.arm_length
        back, down = float(np.linalg.norm(shift[:2])), max(0.0, -float(shift[2]))
        r.stats.update(lean_deg=round(float(lean.phase.lean.angle), 2),
                       lean_frames=lean.phase.frames, lean_bone=lean.bone,
                       lean_ready_frames=rise,
                       lean_com_margin=round(lean.margin / length, 4),
                       lean_hips_back=round(back, 4), lean_hips_down=round(down, 4))
        if lean.leg_angles is not None:
            knee, ankle, thigh = (round(a, 1) for a in lean.leg_angles)
            r.stats.update(lean_knee_deg=knee, lean_ankle_deg=ankle, lean_thigh_deg=thigh)
        angle = lean.phase.lean.angle
        # after a step (its report comes first): "…, then leaning …"
        then, first = (", then ", "") if "step_count" in r.stats else (", ", " first")
        if k > 0:
            r.message += (f", the body still {'squatting' if down >= SQUAT_REPORTED else 'leaning'}"
                          f" as for '{results[0].target}' (the trunk {angle:.0f}°)")
        elif down >= SQUAT_REPORTED:
            r.message += (f"{then}squatting{first}: the hips {down:.2f} arm lengths down and "
                          f"{back:.2f} back, leaning the trunk {angle:.0f}°") + (
                "" if lean.leg_angles is None else
                f", the knees bent {lean.leg_angles[0]:.0f}°")
        else:
            r.message += f"{then}leaning the trunk {angle:.0f}° at the hips{first}" + (
                f", the hips {back:.2f} arm lengths back" if back > 0.0 else "")
        if raised and k == 0:
            r.message += ", the arm raised toward it before the lean"
        if lean.spared_twist is not None and k == lean.spared_at:
            r.stats.update(lean_spared_twist_deg=round(lean.spared_twist, 1))
            r.message += (f" (instead of turning the chest {lean.spared_twist:.0f}° past "
                          "Table 1's, which costs the trunk more)")
