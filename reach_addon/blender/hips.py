"""The hips moved on a rig with its feet planted (:mod:`..core.hips`; stage 3 of the
whole-body reach, ``docs/design/core.md``).

**The hips bone** (:func:`hips_bone`) is the lowest bone that carries both legs and the
lean bone (:func:`.lean.lean_bone`): moving it moves the trunk, both arms and the thighs.

**Posing a shift** (:func:`pose_shift`): the hips bone's pose matrix is translated by the
shift; then on each leg (:class:`.balance.Leg`), as forward kinematics, parent before
child: the thigh turns about the hip joint so the knee lies where the thigh and the shank
meet with the ankle where it was (:func:`~..core.hips.two_bone_knee`, bent the way the
knee is bent now); the shank turns about the knee so the ankle comes back to its place;
and the ankle's bone gets back its world matrix, so the foot keeps its place and its tilt.
Each turn is the least rotation between two directions, applied to the bone's pose matrix
about its head (armature space), whatever its parents, rotation mode or roll.
"""

from __future__ import annotations

import numpy as np

from ..core.hips import STRAIGHT_SHARE, hips_drop, two_bone_knee
from ..core.squat import Leg as LegJoints
from ..core.squat import knee_pole
from . import balance
from .rig_detect import ancestors


def hips_bone(armature, legs, lean: str) -> str | None:
    """The lowest bone that carries both legs' hip bones and the ``lean`` bone, or None."""
    bones = armature.data.bones
    chains = [[bones[n]] + ancestors(bones[n]) for n in (legs[0].hip[0], legs[1].hip[0])]
    chains.append(ancestors(bones[lean]))
    common = [b for b in chains[0] if all(b in c for c in chains[1:])]
    return common[0].name if common else None


def _least_rotation(a, b) -> np.ndarray:
    """The least rotation (3, 3) that takes direction ``a`` to direction ``b``."""
    a = np.asarray(a, dtype=float) / np.linalg.norm(a)
    b = np.asarray(b, dtype=float) / np.linalg.norm(b)
    v, c = np.cross(a, b), float(a @ b)
    if c < -1.0 + 1e-12:
        raise ValueError("opposite directions: no least rotation")
    k = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + k + k @ k / (1.0 + c)


def _turn(context, armature, bone: str, pivot_world, rotation_world) -> None:
    """Turn ``bone``'s pose about ``pivot_world`` by ``rotation_world`` (3, 3)."""
    from mathutils import Matrix

    mw = np.array(armature.matrix_world)
    a, a_inv = mw[:3, :3], np.linalg.inv(mw[:3, :3])
    pivot = a_inv @ (np.asarray(pivot_world, dtype=float) - mw[:3, 3])
    r = a_inv @ rotation_world @ a
    t = np.eye(4)
    t[:3, :3] = r
    t[:3, 3] = pivot - r @ pivot
    pb = armature.pose.bones[bone]
    pb.matrix = Matrix((t @ np.array(pb.matrix)).tolist())
    context.view_layer.update()


def _move(context, armature, bone: str, shift_world) -> None:
    """Translate ``bone``'s pose by ``shift_world``."""
    from mathutils import Matrix

    a_inv = np.linalg.inv(np.array(armature.matrix_world)[:3, :3])
    m = np.array(armature.pose.bones[bone].matrix)
    m[:3, 3] += a_inv @ np.asarray(shift_world, dtype=float)
    armature.pose.bones[bone].matrix = Matrix(m.tolist())
    context.view_layer.update()


def _below(armature, leg, joint) -> str | None:
    """The bone whose head is the leg's ``joint`` (a :class:`.balance.Leg` point): the
    point's own bone where it is a head, else the child of that bone on the way to the
    ankle or its foot (a joint read at a bone's tail); None where none hangs there (a
    Quaternius foot hangs from the root, not from the shank)."""
    name, end = joint
    if end == "head":
        return name
    for start in (leg.ankle[0],) + tuple(leg.foot_bones):
        b = armature.data.bones[start]
        while b.parent is not None and b.parent.name != name:
            b = b.parent
        if b.parent is not None and b.name != name:
            return b.name
    return None


def pose_shift(context, armature, legs, hips: str, shift_world, up, forward,
               feet_world=None, turn=None, as_it_stands: bool = False) -> float:
    """Pose the hips moved by ``shift_world`` (and down as far as the legs need,
    :func:`~..core.hips.hips_drop`) with both feet where they are (see the module
    docstring), or moved by ``feet_world`` ((legs, 3) world offsets: a step, the foot's
    bones carried with it, :func:`foot_bones`). The knees bend the way they are bent where
    that is forward of the leg
    (``forward``: the body's), else straight forward: a leg held straight has no bend of its
    own to follow, and a knee bends only forward (the Knight, in a T-pose, bent its knees
    backward until this). ``turn``: (pivot, rotation (3, 3)), both world: the hips also
    turned about the pivot (moved with them) after the shift (the pelvis's share of the
    chest's turn, :mod:`.pelvis_turn`). ``as_it_stands``: a leg standing straighter than
    :data:`~..core.hips.STRAIGHT_SHARE` may stay as straight (else the hips come down to
    that share before anything else: 1.2 mm on the metarig). Returns how far the hips came
    down (world units)."""
    point = balance.point_of
    up = np.asarray(up, dtype=float)
    feet = [_below(armature, leg, leg.ankle) for leg in legs]
    offsets = np.zeros((len(legs), 3)) if feet_world is None else np.asarray(feet_world, float)
    a_inv = np.linalg.inv(np.array(armature.matrix_world)[:3, :3])
    carried = [[(n, np.array(armature.pose.bones[n].matrix)) for n in foot_bones(armature, leg, up)]
               if feet_world is not None and np.any(off) else []
               for leg, off in zip(legs, offsets)]
    ends = [_shank_end(armature, leg) for leg in legs]
    before = [(point(armature, leg.hip), point(armature, leg.knee),
               point(armature, end[1]) + off,
               None if foot is None else np.array(armature.pose.bones[foot].matrix))
              for leg, foot, off, end in zip(legs, feet, offsets, ends)]
    for b, off in zip(before, offsets):
        if b[3] is not None:
            b[3][:3, 3] += a_inv @ off
    shift = np.asarray(shift_world, dtype=float)

    def turned(p):
        return p if turn is None else turn[1] @ (p - turn[0]) + turn[0]

    shares = [_straight(h, k, a, as_it_stands) for h, k, a, _m in before]
    drop = max(hips_drop(turned(h) + shift, a, float(np.linalg.norm(k - h)),
                         float(np.linalg.norm(a - off - k)), up, s)
               for (h, k, a, _m), off, s in zip(before, offsets, shares))
    _move(context, armature, hips, shift - drop * up)
    if turn is not None:
        _turn(context, armature, hips, np.asarray(turn[0], float) + shift - drop * up, turn[1])
    for leg, name, (h, k, a, foot), off, end, s in zip(legs, feet, before, offsets, ends,
                                                       shares):
        thigh, shank = float(np.linalg.norm(k - h)), float(np.linalg.norm(a - off - k))
        hip_now = point(armature, leg.hip)
        # the knee bends the way it bends as the leg stands (a moved foot's offset from
        # the knee would turn it sideways)
        knee = two_bone_knee(hip_now, a, thigh, shank, knee_pole(h, k, a - off, forward), s)
        _turn(context, armature, leg.hip[0], hip_now,
              _least_rotation(point(armature, leg.knee) - hip_now, knee - hip_now))
        knee_now = point(armature, leg.knee)
        _turn(context, armature, end[0], knee_now,
              _least_rotation(point(armature, end[1]) - knee_now, a - knee_now))
        if foot is not None:           # the foot keeps its place and its tilt
            from mathutils import Matrix
            armature.pose.bones[name].matrix = Matrix(foot.tolist())
            context.view_layer.update()
    for leg_carried, off in zip(carried, offsets):
        _carry(context, armature, leg_carried, a_inv @ off)
    return float(drop)


def _straight(h, k, a, as_it_stands: bool) -> float:
    """The share of its length a leg (hip ``h``, knee ``k``, ankle ``a``) is solved up to:
    :data:`~..core.hips.STRAIGHT_SHARE`, or, ``as_it_stands``, as straight as it stands
    where that is straighter."""
    if not as_it_stands:
        return STRAIGHT_SHARE
    return max(STRAIGHT_SHARE, min(1.0, float(np.linalg.norm(a - h)) / float(
        np.linalg.norm(k - h) + np.linalg.norm(a - k))))


def turn_drop(armature, legs, pivot, rotation, up) -> float:
    """How far (world) :func:`pose_shift` with no shift, ``turn=(pivot, rotation)`` and
    ``as_it_stands`` brings the hips down, read from the legs as they stand without posing
    anything: a hip joint turned away from over its ankle asks a straight leg for more
    length than it has."""
    point = balance.point_of
    out = 0.0
    for leg in legs:
        end = _shank_end(armature, leg)
        h, k, a = point(armature, leg.hip), point(armature, leg.knee), point(armature, end[1])
        out = max(out, hips_drop(rotation @ (h - pivot) + pivot, a, float(np.linalg.norm(k - h)),
                                 float(np.linalg.norm(a - k)), up, _straight(h, k, a, True)))
    return out


def foot_bones(armature, leg, up) -> list:
    """The bones a step carries with the foot (parent first): those of the leg's foot
    (:attr:`.balance.Leg.foot_bones`) whose head lies no higher above the ground (``up``:
    world) than the ankle (the foot, its toes and heel; a foot that hangs from the root, as
    Quaternius' does, included), and the leg's IK controls (:func:`ik_controls`)."""
    point = balance.point_of
    up = np.asarray(up, dtype=float)
    ankle = float(point(armature, leg.ankle) @ up)
    slack = 0.02 * float(np.linalg.norm(point(armature, leg.hip) - point(armature, leg.ankle)))
    names = [n for n in leg.foot_bones
             if float(point(armature, (n, "head")) @ up) <= ankle + slack]
    names += [n for n in ik_controls(armature, leg) if n not in names]
    depth = {n: len(ancestors(armature.data.bones[n])) for n in names}
    return sorted(names, key=lambda n: (depth[n], n))


def ik_controls(armature, leg) -> list:
    """The bones of the armature that the leg's IK constraints aim at, target and pole
    (Quaternius' Foot and PoleTarget): a step carries them with the foot, else the
    constraint pulls the leg back to them, or twists the knee toward a pole left behind.
    On a generated Rigify rig, whose leg bones follow an IK chain of their own through
    constraints, its leg's IK control and pole (``foot_ik`` and ``thigh_ik_target``, by
    Rigify's names like the rest of its map, :func:`.rig_detect.detect_bones`)."""
    out = []
    bones = armature.pose.bones
    if "rig_id" in armature.data.keys():      # a generated Rigify rig: its leg's controls
        suffix = leg.hip[0][-2:]
        out += [n for n in (f"foot_ik{suffix}", f"thigh_ik_target{suffix}") if n in bones]
    chain = [leg.hip[0], leg.knee[0], leg.ankle[0]] + list(leg.foot_bones)
    for name in dict.fromkeys(chain):
        for c in bones[name].constraints if name in bones else ():
            if c.type != "IK" or c.mute or getattr(c, "target", None) != armature:
                continue
            for sub in (c.subtarget, getattr(c, "pole_subtarget", "")):
                if sub and sub in bones and sub not in out:
                    out.append(sub)
    return out


def _carry(context, armature, carried, offset_local) -> None:
    """Set each bone of ``carried`` [(name, its matrix before)] to its matrix before moved by
    ``offset_local`` (armature space), parent first."""
    from mathutils import Matrix

    if not carried:
        return
    for name, m in carried:
        moved = m.copy()
        moved[:3, 3] += offset_local
        armature.pose.bones[name].matrix = Matrix(moved.tolist())
        context.view_layer.update()


def _shank_end(armature, leg) -> tuple:
    """(the shank's bone, the point it is turned to bring back to the ankle: a bone point,
    :class:`.balance.Leg`): the leg's ankle where the shank carries it, else the shank's
    own tail (a
    Quaternius foot hangs from the root, and turning the shank toward it turns nothing
    that reaches it)."""
    shank = _below(armature, leg, leg.knee)
    if shank is None:
        raise ValueError(f"no bone below the knee '{leg.knee[0]}'")
    bone = armature.data.bones[leg.ankle[0]]
    if bone.name == shank or any(b.name == shank for b in ancestors(bone)):
        return shank, leg.ankle
    return shank, (shank, "tail")


def leg_joints(armature, legs, forward) -> list:
    """Each leg's joints as it stands now (:class:`~..core.squat.Leg`, world), its knee's
    pole as :func:`pose_shift` bends it."""
    point = balance.point_of
    out = []
    for leg in legs:
        h, k, a = (point(armature, p) for p in (leg.hip, leg.knee, leg.ankle))
        out.append(LegJoints(h, k, a, knee_pole(h, k, a, forward)))
    return out


#: The share of the body's mass the hips' shift leaves in place: both shanks and feet
#: (:data:`~..core.balance.WINTER`: 2 × (0.0465 + 0.0145)).
PLANTED_SHARE = 2 * (0.0465 + 0.0145)


def leg_bones(armature, legs) -> list:
    """The bones :func:`pose_shift` turns, parent before child: each leg's thigh, shank
    and (where the shank carries it) foot."""
    out = []
    for leg in legs:
        for name in (leg.hip[0], _below(armature, leg, leg.knee), _below(armature, leg, leg.ankle)):
            if name is not None and name not in out:
                out.append(name)
    return out


def lower_bones(armature, hips: str, lean: str) -> set:
    """The bones whose skin the hips' shift moves and the lean does not carry: the hips
    bone and every bone it carries, less the ``lean`` bone and what it carries."""
    bones = armature.data.bones
    below = {hips} | {b.name for b in bones[hips].children_recursive}
    return below - ({lean} | {b.name for b in bones[lean].children_recursive})


class Posed:
    """A context manager that puts back the channel matrices of ``bones`` on exit."""

    def __init__(self, context, armature, bones):
        self.context, self.armature, self.bones = context, armature, list(bones)

    def __enter__(self):
        pbs = self.armature.pose.bones
        self.kept = [(n, pbs[n].matrix_basis.copy()) for n in self.bones]
        return self

    def __exit__(self, *exc):
        for n, m in self.kept:
            self.armature.pose.bones[n].matrix_basis = m
        self.context.view_layer.update()
        return False
