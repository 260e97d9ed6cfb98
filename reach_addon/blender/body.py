"""The body Reach does not key: does the rig's own animation move it during a reach?

:func:`check` measures it before anything is keyed. The *body* is the armature object and
the chain of bones from the root to the upper arm's parent, less the bones the bake keys
(and their Rigify ORG counterparts). On every frame of every motion to bake
(``scene.frame_set``: keys, NLA, drivers, constraints and parents all count), the world
matrix ``W_f`` of the upper arm's parent is composed from the armature's world matrix and
each body bone's matrix relative to its parent, the keyed bones held at the start frame
(``W_0``). The arm planned for that frame is carried by ``W_f W_0⁻¹``; how far its joints
(sternum, shoulder, elbow, wrist, hand end) move is the *drift*. Why: ``docs/design/
blender.md``.
"""

from __future__ import annotations

import numpy as np

from ..core import ReachError
from . import own_keys
from .bone_matrices import bone_roles, moves_chest

#: a bone or the armature counts as moving where its matrix changes by more than this
#: (translation as a share of the arm's length; rotation as the same share in radians)
MOVED = 1e-6


def body_bones(armature, info, plans) -> tuple:
    """(chain, held): the bones from the root to the reaching upper arm's parent (root
    first), and the names among them the bake keys or whose place the plan describes."""
    keyed, reference = bone_roles(info, moves_chest(plans))
    held = set(keyed.values()) | set(reference.values())
    chain = []
    pb = armature.pose.bones[reference["upper_arm"]].parent
    while pb is not None:
        chain.append(pb.name)
        pb = pb.parent
    return chain[::-1], held


def _varies(fc) -> bool:
    """Whether an F-curve takes more than one value (or has modifiers that may)."""
    if len(fc.modifiers):
        return True
    pts = fc.keyframe_points
    co = np.empty(2 * len(pts), np.float32)
    pts.foreach_get("co", co)
    values = co[1::2]
    return len(values) > 1 and float(values.max() - values.min()) > 0.0


def _animated(ob, seen=None) -> bool:
    """Whether anything may move object ``ob``: animation data (an action, an unmuted NLA
    strip, a driver) on it or its data, or on its parents and constraint targets, or a
    constraint of its own."""
    seen = set() if seen is None else seen
    if ob is None or ob.name in seen:
        return False
    seen.add(ob.name)
    for block in (ob, ob.data):
        ad = getattr(block, "animation_data", None) if block is not None else None
        if ad is not None and (ad.action is not None or len(ad.drivers) or any(
                not t.mute and len(t.strips) for t in ad.nla_tracks)):
            return True
    if any(c.enabled and c.influence > 0 for c in ob.constraints):
        return True
    return any(_animated(o, seen) for o in
               [ob.parent] + [getattr(c, "target", None) for c in ob.constraints])


def may_move(armature, free) -> bool:
    """Whether the armature's animation data can move it or any of the ``free`` bones (the
    body's bones the bake does not key), without evaluating the scene. The armature's
    own action is read curve by curve (it holds Reach's keys of earlier bakes): a curve on
    the object's transform or on a free bone that takes more than one value counts."""
    if armature.parent is not None and (_animated(armature.parent)
                                        or armature.parent_type == "BONE"):
        return True
    if any(c.enabled and c.influence > 0 for c in armature.constraints):
        return True
    bones = armature.pose.bones
    if any(c.enabled and c.influence > 0 for n in free for c in bones[n].constraints):
        return True
    ad = armature.animation_data
    if ad is None:
        return False
    if any(not t.mute and len(t.strips) for t in ad.nla_tracks):
        return True
    prefixes = tuple(f'pose.bones["{n}"]' for n in free)

    def body_path(path):
        return not path.startswith("pose.bones[") or path.startswith(prefixes)

    if any(body_path(d.data_path) for d in ad.drivers):
        return True
    if ad.action is None:
        return False
    return any(body_path(fc.data_path) and _varies(fc) for fc in _curves(ad.action))


def _curves(action) -> list:
    """Every F-curve of an action, without creating anything: ``Action.fcurves`` before
    slotted actions, else those of every channelbag (any slot: reading too many only
    costs the frames :func:`check` then evaluates)."""
    if hasattr(action, "layers"):
        return [fc for layer in action.layers for strip in layer.strips
                for bag in getattr(strip, "channelbags", ()) for fc in bag.fcurves]
    return list(action.fcurves)


def check(context, armature, info, plans, settings, frame_start) -> float:
    """Refuse (ReachError) a bake of ``plans`` [(Plan, first frame)] that the rig's own
    animation would carry off the plan by more than the goal tolerance
    (``settings.goal_tolerance`` arm lengths), or carry a wrist that arrives at its target
    farther than the tolerance from it; the message names what moves, by how much, on
    which frame, and what to do. Returns the largest drift, world units (0 where nothing
    can move, :func:`may_move`). ``info``: the :class:`.rig.RigInfo` the plans are for;
    ``frame_start``: the frame the rig was read at, whose body every plan assumes. The
    body's keys an earlier bake made on these frames (:mod:`.own_keys`) do not count: the
    bake replaces them. The scene's frame is put back."""
    if not plans:
        return 0.0
    chain, held = body_bones(armature, info, plans)
    last = max(first + len(plan.poses) - 1 for plan, first in plans)
    # the body's keys an earlier bake made over these frames: the bake clears them
    held |= set(own_keys.overlapping(armature, frame_start, last))
    free = [n for n in chain if n not in held]
    if not may_move(armature, free):
        return 0.0
    scene = context.scene
    now = (scene.frame_current, scene.frame_subframe)
    try:
        scene.frame_set(frame_start)
        body = _Body(armature, chain, held, info.arm.arm_length)
        worst, worst_frame, movers, miss = _drift(scene, body, plans, frame_start,
                                                  settings.goal_tolerance * info.arm.arm_length)
    finally:
        scene.frame_set(now[0], subframe=now[1])
    if worst > settings.goal_tolerance * info.arm.arm_length or miss is not None:
        raise ReachError(_refusal(armature, info, plans, settings, frame_start,
                                  (worst, worst_frame, movers), miss))
    return worst


class _Body:
    """The armature object and its ``chain`` of body bones (root first) as they are now,
    and as they were when made (the start frame): the bones of ``held`` (keyed by the
    bake, or whose place the plan describes) count as held at the start."""

    def __init__(self, armature, chain, held, length):
        self.armature, self.chain, self.held, self.length = armature, chain, held, length
        self.carrier = f" (carried by '{armature.parent.name}')" if armature.parent else ""
        self.start_mw, self.start_rel = self.read()
        self.scale = float(np.abs(np.linalg.det(self.start_mw[:3, :3])) ** (1 / 3))
        self.inv0 = np.linalg.inv(self.compose(self.start_mw, self.start_rel))

    def read(self):
        """(the armature's world matrix, each chain bone's matrix relative to its parent)."""
        bones = self.armature.pose.bones
        rel = []
        for n in self.chain:
            pb = bones[n]
            m = np.array(pb.matrix)
            rel.append(m if pb.parent is None else np.linalg.solve(np.array(pb.parent.matrix), m))
        return np.array(self.armature.matrix_world), rel

    def compose(self, mw, rel):
        """The world matrix of the upper arm's parent, the held bones at the start."""
        w = mw
        for n, r, r0 in zip(self.chain, rel, self.start_rel):
            w = w @ (r0 if n in self.held else r)
        return w

    def carry(self, mw, rel):
        """The matrix that carries the start's body to this one (world)."""
        return self.compose(mw, rel) @ self.inv0

    def _changed(self, a, b, scale):
        """Whether matrix ``a`` differs from ``b``; ``scale``: world units per unit of
        their space."""
        d = a - b
        return (np.abs(d[:3, :3]).max() > MOVED * scale
                or np.linalg.norm(d[:3, 3]) * scale > MOVED * self.length)

    def moving(self, mw, rel) -> list:
        """What moves the body now, against the start: the armature object, free bones."""
        out = ([f"the armature object '{self.armature.name}'" + self.carrier]
               if self._changed(mw, self.start_mw, 1.0) else [])
        return out + [f"bone '{n}'" for n, r, r0 in zip(self.chain, rel, self.start_rel)
                      if n not in self.held and self._changed(r, r0, self.scale)]


def _drift(scene, body, plans, first, tolerance):
    """Every frame of every plan evaluated (``frame_set``): (the largest drift of a planned
    joint, world units; its frame; what moved then; the worst miss or None). A miss,
    (off, planned, frame, target name, movers), is a frame a wrist arrives on, carried
    farther than ``tolerance`` (world units) from its target."""
    worst, worst_frame, movers = 0.0, first, []
    miss = None
    for plan, frame0 in plans:
        joints = plan.world_joints()
        arrivals = {s.frame_end: s for s in plan.segments if s.success}
        for i in range(len(plan.poses)):
            f = frame0 + i
            scene.frame_set(f)
            mw, rel = body.read()
            carry = body.carry(mw, rel)
            p = np.c_[joints[i], np.ones(len(joints[i]))]
            carried = (p @ carry.T)[:, :3]
            drift = float(np.linalg.norm(carried - joints[i], axis=1).max())
            if drift > worst:
                worst, worst_frame, movers = drift, f, body.moving(mw, rel)
            seg = arrivals.get(i)
            if seg is not None and drift > MOVED * body.length:
                # on a frame the wrist arrives, the drift adds to the plan's own error
                off = float(np.linalg.norm(carried[3] - seg.target))
                planned = float(np.linalg.norm(joints[i][3] - seg.target))
                if off > tolerance and (miss is None or off > miss[0]):
                    miss = (off, planned, f, seg.name, body.moving(mw, rel))
    return worst, worst_frame, movers, miss


def _refusal(armature, info, plans, settings, first, drift, miss) -> str:
    """The message of :func:`check`'s refusal: ``drift`` (worst, frame, movers) when it is
    over the tolerance, else ``miss`` (:func:`_drift`)."""
    length = info.arm.arm_length
    worst, worst_frame, movers = drift
    last = max(f0 + len(p.poses) - 1 for p, f0 in plans)
    if worst > settings.goal_tolerance * length:
        cm = 100 * worst * info.arm.metres_per_unit
        effect = (f"carry the {info.side} arm {cm:.1f} cm away from its plan on frame "
                  f"{worst_frame} ({worst / length:.2f} arm lengths), so the hand would "
                  "miss the target and may pass through obstacles")
    else:
        off, planned, worst_frame, target, movers = miss
        cm = 100 * off * info.arm.metres_per_unit
        effect = (f"carry the {info.side} wrist {cm:.1f} cm from target '{target}' on "
                  f"frame {worst_frame} ({off / length:.4f} arm lengths, more than the goal "
                  f"tolerance of {settings.goal_tolerance:g}; the plan leaves it "
                  f"{planned / length:.4f} away)")
    what = ", ".join(movers[:4]) + (f" and {len(movers) - 4} more" if len(movers) > 4
                                    else "") if movers else "the rig's own animation"
    return (f"armature '{armature.name}': its own animation moves the body the arm hangs "
            f"from while it reaches (frames {first}–{last}): {what} would {effect}. Reach "
            f"plans with the body holding its pose of frame {first}: mute or clear those "
            "keys over these frames (or mute the NLA track, or unassign the clip an importer "
            "left playing), or start the reach where the body holds still")
