"""The body Reach does not key: does the rig's own animation move it during a reach?

The planner plans in the world as it is on the start frame: the chest, the shoulder and
every obstacle where they are then (:mod:`reach_addon.core` knows nothing of time beyond its
own motion). The bake keys the arm's bones (upper arm, forearm, hand, the clavicle, the
chest when the plan turns it), and Blender carries them by their parents. If something
else moves those parents while the arm reaches — a walk cycle on the hips, an idle clip
on the spine, keys or a constraint on the armature object or on an object it is parented
to, an NLA strip — the baked arm is carried away from the planned one: the wrist misses
the target and the arm may pass through what the plan went round. Importers leave such
clips playing (the glTF sample CesiumMan walks 0.2 arm lengths in a fast reach).

:func:`check` measures it before anything is keyed. The *body* is the armature object
and the chain of bones from the root to the upper arm's parent, less the bones the bake
keys (and their Rigify ORG counterparts, whose place the plan describes): those are
replaced by Reach's keys over the reach, whatever they held. On every frame of every
motion to bake (``scene.frame_set``, so keys, NLA, drivers, constraints and parents all
count), the world matrix ``W_f`` of the upper arm's parent is composed from the armature's
world matrix and each body bone's matrix relative to its parent, the keyed bones held at
the start frame, where the rig was read (``W_0``: every plan assumes that body, a reach
baked after a failed one that is not keyed included). The arm planned for that frame
is carried by ``W_f W_0⁻¹``; how far its joints (sternum, shoulder, elbow, wrist, hand
end) move is the *drift*. A drift above the goal tolerance (``Settings.goal_tolerance``:
the baked wrist would miss the target), or a smaller one that carries the wrist farther
than the tolerance from its target on a frame the plan arrives there (the drift adds to
the plan's own error, itself up to the tolerance), refuses the bake with a
:class:`~reach_addon.core.ReachError` naming what moves, by how much and on which frame,
and what to do; nothing in the scene is changed.

Where the keyed chest turns and an unkeyed bone sits between it and the clavicle, the
composition holds the chest at its start: the drift is then measured about the start
pose, a fraction of a degree's difference for the chest turns the planner makes.

Cost: nothing on a rig nothing can move (:func:`may_move`, read from the animation data
alone); else one scene evaluation per frame of the motion.
"""

from __future__ import annotations

import numpy as np

from ..core import ReachError
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
    animation would carry off the plan by more than the goal tolerance, or carry a wrist
    that arrives at its target farther than the tolerance from it (see the module doc);
    returns the largest drift, world units (0 where nothing can move).
    ``frame_start``: the frame the rig was read at, whose body every plan assumes (a plan
    baked later, after a failed reach that is not baked, starts after it). The scene's
    frame is put back."""
    if not plans:
        return 0.0
    chain, held = body_bones(armature, info, plans)
    free = [n for n in chain if n not in held]
    if not may_move(armature, free):
        return 0.0
    scene = context.scene
    bones = armature.pose.bones
    length = info.arm.arm_length
    now = (scene.frame_current, scene.frame_subframe)

    def read():
        rel = []
        for n in chain:
            pb = bones[n]
            m = np.array(pb.matrix)
            rel.append(m if pb.parent is None else np.linalg.solve(np.array(pb.parent.matrix), m))
        return np.array(armature.matrix_world), rel

    def compose(mw, rel):
        w = mw
        for n, r, r0 in zip(chain, rel, start_rel):
            w = w @ (r0 if n in held else r)
        return w

    def changed(a, b, scale):
        """Whether matrix ``a`` differs from ``b``; ``scale``: world units per unit of
        their space."""
        d = a - b
        return (np.abs(d[:3, :3]).max() > MOVED * scale
                or np.linalg.norm(d[:3, 3]) * scale > MOVED * length)

    carrier = f" (carried by '{armature.parent.name}')" if armature.parent else ""
    first = frame_start
    try:
        scene.frame_set(first)
        start_mw, start_rel = read()
        scale = float(np.abs(np.linalg.det(start_mw[:3, :3])) ** (1 / 3))
        inv0 = np.linalg.inv(compose(start_mw, start_rel))
        worst, worst_frame, movers = 0.0, first, []
        miss = None     # (off, planned, frame, target, movers): the wrist carried off target
        tolerance = settings.goal_tolerance * length

        def moving(mw, rel):
            out = ([f"the armature object '{armature.name}'" + carrier]
                   if changed(mw, start_mw, 1.0) else [])
            return out + [f"bone '{n}'" for n, r, r0 in zip(chain, rel, start_rel)
                          if n not in held and changed(r, r0, scale)]

        for plan, frame0 in plans:
            joints = plan.world_joints()
            arrivals = {s.frame_end: s for s in plan.segments if s.success}
            for i in range(len(plan.poses)):
                f = frame0 + i
                scene.frame_set(f)
                mw, rel = read()
                carry = compose(mw, rel) @ inv0
                p = np.c_[joints[i], np.ones(len(joints[i]))]
                carried = (p @ carry.T)[:, :3]
                drift = float(np.linalg.norm(carried - joints[i], axis=1).max())
                if drift > worst:
                    worst, worst_frame, movers = drift, f, moving(mw, rel)
                seg = arrivals.get(i)
                if seg is not None and drift > MOVED * length:
                    # on a frame the wrist arrives, the drift adds to the plan's own error
                    off = float(np.linalg.norm(carried[3] - seg.target))
                    planned = float(np.linalg.norm(joints[i][3] - seg.target))
                    if off > tolerance and (miss is None or off > miss[0]):
                        miss = (off, planned, f, seg.name, moving(mw, rel))
    finally:
        scene.frame_set(now[0], subframe=now[1])
    if worst > tolerance or miss is not None:
        last = max(f0 + len(p.poses) - 1 for p, f0 in plans)
        if worst > tolerance:
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
        raise ReachError(
            f"armature '{armature.name}': its own animation moves the body the arm hangs "
            f"from while it reaches (frames {first}–{last}): {what} would {effect}. Reach "
            f"plans with the body holding its pose of frame {first}: mute or clear those "
            "keys over these frames (or mute the NLA track, or unassign the clip an importer "
            "left playing), or start the reach where the body holds still")
    return worst
