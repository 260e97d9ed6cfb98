"""The trunk's lean on a rig (:mod:`..core.whole_body`): the bone that leans it, its pivot,
the balance the lean leaves, and its keys.

**The lean bone** (:func:`lean_bone`) is the highest bone of the chest's chain (the keyed
chest, its parent, and so on up) that carries neither leg (:func:`.balance.find_legs`):
turning it turns the chest, both arms and the head and leaves the legs and feet where they
are. Its head is the lean's pivot. On most rigs it is the lowest spine bone above the
hips (the hips carry the legs); on a generated Rigify rig it is the chest control. A rig
without legs has none, and does not lean.

**Balance.** The hips do not move back yet, so a lean is refused where it would leave the
centre of mass past the feet (:func:`.balance.margin_now`), and farther past them than the
rig stands as posed: a template or a rig whose feet Reach reads poorly may stand past its
own feet, and is then held to that.

**Posing and keying** (:func:`lean_basis`): a lean is a rotation of the lean bone's pose
matrix ``M`` about its head, ``M' = T_h R T_h⁻¹ M``; its channel (basis) matrix is then
``B' = B M⁻¹ M'``, whatever the bone's parents, rotation mode or roll.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import bpy
import numpy as np
from mathutils import Matrix

from ..core import NEEDS_LEAN, Planner
from ..core import balance as core_balance
from ..core import hips as core_hips
from ..core.lean import TrunkSkin, skin_hit
from ..core.whole_body import LeanPhase, lean_then_reach
from . import balance, skin
from . import hips as hips_mod
from . import bake as bake_mod
from .bake import KeyedPlan
from .bone_matrices import channel_values
from .fcurves import Channels, ensure_action, write_channel
from .rig_detect import ancestors


def lean_bone(armature, bmap, legs) -> str | None:
    """The bone that leans the trunk (see the module docstring), or None without legs."""
    if not legs:
        return None
    bones = armature.data.bones
    hips = [bones[leg.hip[0]] for leg in legs]
    carried = {b.name for h in hips for b in [h] + ancestors(h)}
    chain = [bones[bmap.keyed_chest]] + ancestors(bones[bmap.keyed_chest])
    found = None
    for b in chain:
        if b.name in carried:
            break
        found = b.name
    return found


def pivot_world(armature, bone: str) -> np.ndarray:
    """The lean bone's head now (world): the lean's pivot."""
    mw = np.array(armature.matrix_world)
    return mw[:3, :3] @ np.array(armature.pose.bones[bone].head) + mw[:3, 3]


def lean_basis(armature, bone: str, rotations_world) -> np.ndarray:
    """The lean bone's channel (basis) matrices (F, 4, 4) for the world rotations
    ``rotations_world`` (F, 3, 3) of the trunk about its head, from its pose now (see the
    module docstring)."""
    pb = armature.pose.bones[bone]
    a = np.array(armature.matrix_world)[:3, :3]
    a_inv = np.linalg.inv(a)
    m = np.array(pb.matrix)
    basis = np.array(pb.matrix_basis)
    m_inv = np.linalg.inv(m)
    out = []
    for r in np.asarray(rotations_world, dtype=float):
        leaned = m.copy()
        leaned[:3, :3] = a_inv @ r @ a @ m[:3, :3]
        out.append(basis @ m_inv @ leaned)
    return np.array(out)


def world_rotations(info, lean, fractions) -> np.ndarray:
    """The trunk's world rotations (F, 3, 3) at ``fractions`` of ``lean``: the canonical
    lean (:meth:`~..core.lean.Lean.matrix`) carried into the world, ``M R M⁻¹`` with ``M``
    the arm's canonical-to-world rotation (a mirror for a left arm)."""
    m = np.asarray(info.arm.to_world, dtype=float)[:3, :3]
    return np.array([m @ lean.matrix(f)[:3, :3] @ m.T for f in fractions])


def shift_world(info, lean) -> np.ndarray:
    """The hips' shift of ``lean`` (canonical) in the world."""
    return np.asarray(info.arm.to_world, dtype=float)[:3, :3] @ np.asarray(lean.shift, float)


def pose_lean(context, armature, bone: str, basis) -> None:
    """Set the lean bone's channel matrix to ``basis`` (4, 4) and evaluate."""
    armature.pose.bones[bone].matrix_basis = Matrix(np.asarray(basis).tolist())
    context.view_layer.update()


def pose_leaned(context, armature, info, bone: str, basis, legs=(), hips=None,
                shift=None) -> None:
    """Pose the lean bone at ``basis`` and, where ``hips`` is given, the hips moved by the
    world ``shift`` with the feet planted (:func:`.hips.pose_shift`): the one way the
    balance, the lower body's test and the bake pose a lean."""
    pose_lean(context, armature, bone, basis)
    if hips is not None:
        hips_mod.pose_shift(context, armature, list(legs), hips, shift,
                            np.asarray(info.frame.up, float),
                            np.asarray(info.frame.forward, float))


def reaching_segments(armature, info, legs, target=None) -> list:
    """The body's segments now (:func:`.balance.body_segments`), the reaching arm held
    straight from its shoulder toward ``target`` (world), the wrist at most on it (an
    estimate of where the arm ends, for the hips' shift); as it is without a target."""
    out = balance.body_segments(armature, info.bones, legs)
    if target is None:
        return out
    k = 3 * list(info.bones.arms).index(info.side)
    (_u, s, e), (_f, _e, w), (_h, _w, tip) = out[k:k + 3]
    s = np.asarray(s, dtype=float)
    upper, fore, hand = (float(np.linalg.norm(np.asarray(b) - np.asarray(a)))
                         for a, b in ((s, e), (e, w), (w, tip)))
    d = np.asarray(target, dtype=float) - s
    u = d / max(float(np.linalg.norm(d)), 1e-12)
    w = s + min(float(np.linalg.norm(d)), upper + fore) * u
    e = s + upper / max(upper + fore, 1e-12) * (w - s)
    out[k:k + 3] = [("upper_arm", s, e), ("forearm", e, w), ("hand", w, w + hand * u)]
    return out


def posed_segments(segments, info, joints, turned=None) -> list:
    """``segments`` (:func:`.balance.body_segments`) with the reaching arm's at the core's
    ``joints`` (world: sternum, shoulder, elbow, wrist, hand's end), and the other arms'
    and the head's points mapped by ``turned`` (world points → where the chest's turn takes
    them) where given."""
    out = list(segments)
    k = 3 * list(info.bones.arms).index(info.side)
    if turned is not None:
        carried = [i for i in range(3 * len(info.bones.arms)) if not k <= i < k + 3]
        carried += [i for i, seg in enumerate(out) if seg[0] == "head_neck"]
        for i in carried:
            kind, a, b = out[i]
            a, b = turned(np.array([a, b], dtype=float))
            out[i] = (kind, a, b)
    s, e, w, tip = (np.asarray(p, dtype=float) for p in np.asarray(joints)[1:5])
    out[k:k + 3] = [("upper_arm", s, e), ("forearm", e, w), ("hand", w, tip)]
    return out


def margin_reaching(armature, info, legs, arm_world=None, turned=None) -> tuple:
    """(the centre of mass's least margin over the feet now, world units; the pose it is
    least on; the centre of mass there, world): the arm as it is (pose None) where
    ``arm_world`` is None, else on each of its poses (P, 5, 3), the chest turned by
    ``turned(points, k)`` (:func:`posed_segments`)."""
    up = np.asarray(info.frame.up, float)
    polygon = balance.support_now(armature, legs, up)[0]
    segments = balance.body_segments(armature, info.bones, legs)
    if arm_world is None:
        com = core_balance.centre_of_mass(segments)
        return core_balance.balance_margin(com, polygon, up), None, com
    coms = [core_balance.centre_of_mass(posed_segments(
        segments, info, joints, None if turned is None else lambda p, k=k: turned(p, k)))
        for k, joints in enumerate(np.asarray(arm_world, dtype=float))]
    margins = [core_balance.balance_margin(c, polygon, up) for c in coms]
    k = int(np.argmin(margins))
    return float(margins[k]), k, coms[k]


def animated(armature, bone: str, channel: str = "rotation") -> bool:
    """Does the armature's action key ``bone``'s ``channel`` (``rotation``, ``location``:
    the lean would overwrite it)?"""
    ad = armature.animation_data
    action = ad.action if ad else None
    if action is None:
        return False
    prefix = f'pose.bones["{bone}"].{channel}'
    bag = Channels(armature, action).bag
    return any(fc.data_path.startswith(prefix) for fc in bag.fcurves)


def hips_keyed(armature, hips: str, legs) -> str | None:
    """The first bone the hips' shift would key that has keys of its own (the hips bone's
    location, a leg bone's rotation), or None."""
    if animated(armature, hips, "location"):
        return hips
    return next((n for n in hips_mod.leg_bones(armature, legs) if animated(armature, n)), None)


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


def plan(context, armature, info, planner, keyed):
    """Try a lean where ``keyed`` (the :class:`.bake.KeyedPlan` of a single reach) was refused
    as ``needs_lean`` and ``Settings.lean`` is on (:func:`~..core.whole_body.
    lean_then_reach`), among ``planner``'s obstacles and settings, each lean held to the
    balance (:class:`BalanceCheck`). Returns (:class:`RigLean`, the reach's KeyedPlan on
    the leaned trunk); or (None, ``keyed``) with its message saying why no lean was planned."""
    made = []

    def make_planner(arm):
        made.append(Planner(arm, planner.obstacles, planner.settings))
        return made[-1]

    failed, task = keyed.plan, keyed.plan.task
    if not planner.settings.lean or failed.reason != NEEDS_LEAN or task.kind != "reach":
        return None, keyed
    legs = balance.find_legs(armature, info.bones, info.frame)
    bone = lean_bone(armature, info.bones, legs)
    if bone is None:
        why = "Reach finds no legs on this rig, and leans only a body standing on its feet"
    elif animated(armature, bone):
        why = f"bone '{bone}', which leans the trunk, has keys of its own"
    else:
        pivot = info.arm.to_canonical_points(pivot_world(armature, bone))
        target = np.asarray(task.targets[0], dtype=float)
        check = BalanceCheck(context, armature, info, legs, bone, target,
                             planner.generator.checker)
        keyed_own = None if check.hips is None else hips_keyed(armature, check.hips, legs)
        body = None if check.hips is None or keyed_own else BalanceBody(
            context, armature, info, legs, bone, check.hips, planner.settings, check)
        phase, reach_or_why = lean_then_reach(planner, task, failed, pivot, make_planner, check,
                                              trunk_skin(armature, info, bone), body)
        if phase is not None:
            bases = lean_basis(armature, bone, world_rotations(info, phase.lean, phase.fractions))
            first = keyed.first_frame
            moved = bool(np.any(phase.lean.shift))
            return RigLean(phase, bone, bases, first, check.margins[-1],
                           check.hips if moved else None,
                           tuple(legs) if moved else ()), KeyedPlan(
                reach_or_why, first + phase.frames, (made[-1].generator.checker,), True)
        why = reach_or_why
        if keyed_own and planner.settings.lean_hips_back:
            why += f" (the hips stay: bone '{keyed_own}' has keys of its own)"
    for seg in failed.segments:
        if seg.reason == NEEDS_LEAN:
            seg.message += f"; with Lean on: {why}"
    return None, keyed


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


class BalanceCheck:
    """``check(lean, arm_world=None, turned=None)``: why a lean (:class:`~..core.lean.
    Lean`) may not be taken, or None: the centre of mass's margin over the feet with the
    trunk at the full lean (the hips moved back by the lean's shift) may not fall below 0
    nor below the rig's own as it stands (see the module docstring): the arm at its start,
    or on each pose of the reach planned after the lean (``arm_world``, ``turned``:
    :func:`margin_reaching`). ``margins``: each lean's margin, in turn.

    ``correction``: where the reach after a lean (its hips not moved) was weighed, its
    least-balanced pose's centre of mass less :class:`BalanceBody`'s estimate for the same
    lean (the arm straight toward ``target``, the chest unturned): the estimate's error,
    which :class:`BalanceBody` adds, so the hips move back by what the planned arm needs
    (on the Quaternius alien the estimate put the centre of mass 0.04 arm lengths too far
    forward: its chest turns 55° and brings the other arm back)."""

    def __init__(self, context, armature, info, legs, bone, target=None, checker=None):
        self.context, self.armature, self.info, self.legs, self.bone = \
            context, armature, info, legs, bone
        self.target = None if target is None else np.asarray(target, dtype=float)
        self.checker = checker
        self.standing = balance.margin_now(armature, info.bones, legs,
                                           np.asarray(info.frame.up, float))
        self.hips = hips_mod.hips_bone(armature, legs, bone)
        self.margins = []
        self.correction = None

    def __call__(self, lean, arm_world=None, turned=None):
        basis = lean_basis(self.armature, self.bone, world_rotations(self.info, lean, [1.0]))[0]
        moved = bool(np.any(lean.shift))
        bones = [self.bone] + ([self.hips] + hips_mod.leg_bones(self.armature, self.legs)
                               if moved else [])
        with hips_mod.Posed(self.context, self.armature, bones):
            pose_leaned(self.context, self.armature, self.info, self.bone, basis, self.legs,
                        self.hips if moved else None, shift_world(self.info, lean))
            margin, pose, com = margin_reaching(self.armature, self.info, self.legs,
                                                arm_world, turned)
            if pose is not None and not moved and self.target is not None:
                self.correction = com - core_balance.centre_of_mass(
                    reaching_segments(self.armature, self.info, self.legs, self.target))
        self.margins.append(margin)
        length = self.info.arm.arm_length
        if margin >= min(0.0, self.standing):
            hit = None if not moved or arm_world is not None else self.lower_hit(lean)
            return None if hit is None else (
                f"leaning {lean.angle:.0f}° with the hips "
                f"{np.linalg.norm(np.asarray(lean.shift)[:2]) / length:.2f} arm lengths back, "
                f"the {hit[0]} would touch '{hit[1]}'")
        why = (f"leaning {lean.angle:.0f}° would carry the centre of mass "
               + ("" if pose is None else f"(the arm on the reach's frame {pose}) ")
               + f"{-margin / length:.3f} arm lengths past the feet"
               + ("" if moved else ", the hips not moved back"))
        if self.standing < 0.0:
            why += f" (the rig as posed stands {-self.standing / length:.3f} arm lengths past them)"
        return why

    def lower_hit(self, lean):
        """(part, obstacle) where the skin below the trunk (the hips bone's and every bone
        it carries that the lean bone does not: the pelvis and the legs, :func:`.hips.
        lower_bones`) would come within the clearance of an obstacle as the lean moves the
        hips back (:data:`LOWER_SAMPLES` instants of it, posed as the bake poses them, then
        :func:`~..core.lean.skin_hit`, exact about crossing between them), else None.
        A wall just behind the hips is what this finds (the knees come forward little: the
        legs stay near straight, :data:`~..core.hips.STRAIGHT_SHARE`)."""
        if self.checker is None or self.hips is None:
            return None
        fractions = np.linspace(0.0, 1.0, LOWER_SAMPLES)
        bases = lean_basis(self.armature, self.bone, world_rotations(self.info, lean, fractions))
        names = hips_mod.lower_bones(self.armature, self.hips, self.bone)
        moved = [self.bone, self.hips] + hips_mod.leg_bones(self.armature, self.legs)
        world = []
        for basis, fraction in zip(bases, fractions):
            with hips_mod.Posed(self.context, self.armature, moved):
                pose_leaned(self.context, self.armature, self.info, self.bone, basis,
                            self.legs, self.hips, fraction * shift_world(self.info, lean))
                world.append(skin.skin_points(self.armature, names, 0.5, True))
        if not len(world[0]):
            return None
        hit = skin_hit(np.array(world), self.checker)
        return None if hit is None else ("lower body", hit[1])


#: The instants of a lean at which the skin below the trunk is read for its obstacle test
#: (:meth:`BalanceCheck.lower_hit`); between them the test adds its own where a point
#: moves more than the clearance allows.
LOWER_SAMPLES = 9


class BalanceBody:
    """The rig's balance for :func:`~..core.hips.shifted_lean` (world frame): the centre of
    mass with the trunk leaned (the lean bone posed, measured, put back; the arm straight
    toward the target, corrected by the ``check``'s :attr:`BalanceCheck.correction` where
    it has one), the support polygon and up as the rig stands, the planted share, the
    margin to keep (``Settings.balance_margin`` arm lengths over the ``floor``: 0, or the
    rig's own where that is below 0), and how far the hips come down for a shift."""

    def __init__(self, context, armature, info, legs, lean_bone, hips, settings,
                 check: BalanceCheck):
        self.target, self.check = check.target, check
        self.context, self.armature, self.info, self.legs = context, armature, info, legs
        self.lean_bone, self.hips = lean_bone, hips
        self.up = np.asarray(info.frame.up, dtype=float)
        self.polygon = balance.support_now(armature, legs, self.up)[0]
        self.planted_share = hips_mod.PLANTED_SHARE
        self.floor = min(0.0, check.standing)
        self.margin = self.floor + settings.balance_margin * info.arm.arm_length

    def com(self, lean) -> np.ndarray:
        """The centre of mass (world) with the trunk leaned by ``lean`` (its turn only)."""
        basis = lean_basis(self.armature, self.lean_bone,
                           world_rotations(self.info, lean, [1.0]))[0]
        with hips_mod.Posed(self.context, self.armature, [self.lean_bone]):
            pose_lean(self.context, self.armature, self.lean_bone, basis)
            com = core_balance.centre_of_mass(
                reaching_segments(self.armature, self.info, self.legs, self.target))
        return com if self.check.correction is None else com + self.check.correction

    def drop(self, shift_world) -> float:
        """How far the hips come down for ``shift_world`` (:func:`~..core.hips.hips_drop`)."""
        point = balance._point
        shift = np.asarray(shift_world, dtype=float)
        out = 0.0
        for leg in self.legs:
            h, k, a = (point(self.armature, p) for p in (leg.hip, leg.knee, leg.ankle))
            out = max(out, core_hips.hips_drop(h + shift, a, float(np.linalg.norm(k - h)),
                                     float(np.linalg.norm(a - k)), self.up))
        return out


def bake(context, armature, info, lean: RigLean, plans, new_action: bool = False):
    """Key the lean, then the reach on the leaned trunk (:func:`.bake.bake`, for ``info``'s
    arm on the leaned trunk): the reach is baked with the lean bone posed at the full lean;
    then the lean bone is keyed on the lean's frames (continuous with what the bake keyed
    on it, where it keyed it: the chest may be the lean bone) and held at the full lean
    through the reach, and every bone and switch the bake keyed holds its first key through
    the lean. Returns the bake's :class:`.bake.BakeResult`, its frame range from the lean's
    first frame."""
    pb = armature.pose.bones[lean.bone]
    before = pb.matrix_basis.copy()
    hips_keys = _hips_bases(context, armature, info, lean)
    pose_lean(context, armature, lean.bone, lean.bases[-1])
    for name, bases in hips_keys.items():
        armature.pose.bones[name].matrix_basis = Matrix(bases[-1].tolist())
    context.view_layer.update()
    try:
        result = bake_mod.bake(context, armature, dataclasses.replace(info, arm=lean.phase.arm),
                               plans, new_action)
    except Exception:
        pb.matrix_basis = before
        context.view_layer.update()
        raise
    first, last = lean.frame_start, result.frames[1]
    reach_first = first + lean.phase.frames
    channels = Channels(armature, ensure_action(armature, False))
    switches = [b for side, (b, _prop) in info.bones.ik_fk.items() if side == info.side]
    _hold(channels, set(result.bones) | set(switches), lean.bone, first, reach_first)
    path, values = _channel_values_into(pb, channels, lean.bases, reach_first)
    frames = first + np.arange(len(lean.bases), dtype=float)
    write_channel(channels, f'pose.bones["{lean.bone}"].{path}', values, frames, lean.bone)
    if last > reach_first and lean.bone not in result.bones:
        write_channel(channels, f'pose.bones["{lean.bone}"].{path}', values[[-1, -1]],
                      np.array([reach_first, last], float), lean.bone)
    for name, bases in hips_keys.items():
        _key_bone(channels, armature.pose.bones[name], bases, frames,
                  [reach_first, last] if last > reach_first else [], name == lean.hips)
    context.view_layer.update()
    result.frames = (first, last)
    return result


def _hips_bases(context, armature, info, lean: RigLean) -> dict:
    """Where the lean moves the hips back: the channel matrices (F, 4, 4) of the hips bone
    and the legs' bones (:func:`.hips.pose_shift`) on each frame of the lean, the shift
    growing with the lean's fraction; the pose is put back after. {} otherwise."""
    if lean.hips is None:
        return {}
    shift = shift_world(info, lean.phase.lean)
    names = [lean.hips] + hips_mod.leg_bones(armature, list(lean.legs))
    out: dict = {n: [] for n in names}
    for basis, fraction in zip(lean.bases, lean.phase.fractions):
        with hips_mod.Posed(context, armature, [lean.bone] + names):
            pose_leaned(context, armature, info, lean.bone, basis, lean.legs, lean.hips,
                        float(fraction) * shift)
            for n in names:
                out[n].append(np.array(armature.pose.bones[n].matrix_basis))
    return {n: np.array(v) for n, v in out.items()}


def _key_bone(channels, pb, bases, frames, hold, location: bool) -> None:
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


def report(results, lean: RigLean | None, length: float) -> None:
    """Put the lean into the reach's result (:class:`.results.TaskResult`), in place: its
    ``stats`` gain ``lean_deg``, ``lean_frames``, ``lean_bone``, ``lean_hips_back`` (arm
    lengths) and ``lean_com_margin`` (arm lengths: the least :class:`BalanceCheck` weighed
    for the lean taken, over the reach's poses), its message says so, and its frames start
    with the lean's."""
    if lean is None:
        return
    for r in results:
        r.frame_start = lean.frame_start
        back = float(np.linalg.norm(np.asarray(lean.phase.lean.shift, float)[:2])) / \
            lean.phase.arm.arm_length
        r.stats.update(lean_deg=round(float(lean.phase.lean.angle), 2),
                       lean_frames=lean.phase.frames, lean_bone=lean.bone,
                       lean_com_margin=round(lean.margin / length, 4),
                       lean_hips_back=round(back, 4))
        r.message += f", leaning the trunk {lean.phase.lean.angle:.0f}° at the hips first" + (
            f", the hips {back:.2f} arm lengths back" if back > 0.0 else "")
