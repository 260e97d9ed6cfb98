"""From a plan's poses to bone matrices and rotation channels.

Each keyed bone's armature-space matrix at frame *k* is its matrix in the start pose
turned by the rotation that carries the start frame of its segment to the planned one:

* upper arm: (u, b, u × b), with u the upper arm direction and b the bend direction;
* forearm: (f, h, f × h), with h = u × b the elbow's hinge axis;
* hand: (d, g, d × g), with d the hand direction and g the hinge made perpendicular to d,
  turned by the pose's palm roll ψ about d (:mod:`reach_addon.core.orient`); the
  forearm's frame is turned by :data:`~reach_addon.core.orient.FOREARM_SHARE` of ψ about
  its own axis;
* chest: the chest rotation about the body's up axis through the chest bone's head;
* clavicle: carried by the chest; the hand's palm siblings (:func:`.hand_reading.hand_group`):
  carried rigidly by the hand.

A bone's local (channel) matrix is ``(M_p P⁻¹ B)⁻¹ D`` with ``B``/``P`` its own and its
parent's rest matrices, ``D`` its target and ``M_p`` the parent's target (a parent that is
not keyed follows its nearest keyed ancestor rigidly). Rotations are written in each
bone's own rotation mode, quaternions continuous, Eulers compatible with the frame before.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from mathutils import Euler, Matrix, Quaternion, Vector

from ..core.arm import roll_frames
from ..core.orient import FOREARM_SHARE
from ..core.torso import spine_rotation_matrix
from .hand_reading import hand_group

#: The keyed roles in hierarchy order.
ROLE_ORDER = ("chest", "clavicle", "upper_arm", "forearm", "hand")


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _frames(a, b):
    """Orthonormal frames (…, 3, 3) with columns a, b, a × b (b made perpendicular to a)."""
    a = _unit(a)
    b = _unit(b - np.einsum("...i,...i->...", b, a)[..., None] * a)
    return np.stack([a, b, np.cross(a, b)], -1)


def target_matrices(info, plan, start_world, chest_head_world, first=None):
    """World-space target matrices (F, 4, 4) per role for every frame of ``plan``.

    ``start_world``: role → the 4×4 world matrix of that role's reference bone in the
    start pose. ``chest_head_world``: the chest bone's head (the rotation pivot).
    ``first``: the plan whose first pose the rig stands in at the start, where ``plan``
    starts elsewhere (a reach after a ready reach and a lean: :func:`.lean.bake`); each
    segment is turned from that pose's frame, the chest from its turn."""
    arm = info.arm
    m = arm.to_world[:3, :3]
    joints = plan.world_joints()                      # (F, 5, 3)
    frames = _arm_frames(plan, m, joints)
    ref = frames if first is None or first is plan else _arm_frames(
        dataclasses.replace(first, poses=first.poses[:1]), m)
    joint_of = {"upper_arm": 1, "forearm": 2, "hand": 3}
    out = {}
    n = len(plan.poses)
    for role, f in frames.items():
        if role not in start_world:
            continue
        rot = f @ np.swapaxes(ref[role][0], -1, -2)[None]   # carries the start's frame to k
        s = start_world[role]
        d = np.repeat(s[None], n, 0)
        d[:, :3, :3] = rot @ s[:3, :3]
        d[:, :3, 3] = joints[:, joint_of[role]]
        out[role] = d
    body = np.array([p.config.body_rotation for p in plan.poses])
    body = body - (first or plan).poses[0].config.body_rotation
    chest_rot = m @ spine_rotation_matrix(body) @ m.T          # (F, 3, 3), world
    for role in ("chest", "clavicle"):
        if role in start_world:
            s = start_world[role]
            d = np.repeat(s[None], n, 0)
            d[:, :3, :3] = chest_rot @ s[:3, :3]
            d[:, :3, 3] = (chest_rot @ (s[:3, 3] - chest_head_world)) + chest_head_world
            out[role] = d
    return out


def _arm_frames(plan, m, joints=None) -> dict:
    """The upper arm's, forearm's and hand's world frames (F, 3, 3) on ``plan``'s poses, as
    :func:`target_matrices` turns the bones by; ``m``: the arm model's rotation to the
    world; ``joints``: ``plan.world_joints()`` where already read."""
    joints = plan.world_joints() if joints is None else joints    # (F, 5, 3)
    bends = plan.world_bends()                        # (F, 3)
    upper = joints[:, 2] - joints[:, 1]
    fore = joints[:, 3] - joints[:, 2]
    hand = joints[:, 4] - joints[:, 3]
    hinge = np.cross(_unit(upper), bends)
    frames = {
        "upper_arm": _frames(upper, bends),
        "forearm": _frames(fore, hinge),
        "hand": _frames(hand, hinge),
    }
    rolls = np.array([p.roll for p in plan.poses])
    if rolls.any():
        # the plan's roll is about d in the canonical frame; a world frame's third column
        # (a cross product) flips where the canonical frame is mirrored (a left arm), and
        # the roll with it: F_w R_x(det(M) ψ)
        sign = float(np.sign(np.linalg.det(m)))
        frames["hand"] = roll_frames(frames["hand"], sign * rolls)
        frames["forearm"] = roll_frames(frames["forearm"], sign * FOREARM_SHARE * rolls)
    return frames


def local_matrices(armature, keyed, targets_arm, start_pose):
    """Channel (basis) matrices (F, 4, 4) of the keyed bones, hierarchy order.

    ``keyed``: role → bone name; ``targets_arm``: role → armature-space targets (F, 4, 4);
    ``start_pose``: bone name → armature-space pose matrix at the start (every bone). The
    keyed hand's palm siblings (:func:`.hand_reading.hand_group`) are keyed too, right after it,
    each carried rigidly by the hand's turn."""
    bones = armature.data.bones
    name_to_role = {name: role for role, name in keyed.items()}
    out = {}
    for role in ROLE_ORDER:
        name = keyed.get(role)
        if name is None:
            continue
        targets = {name: targets_arm[role]}
        if role == "hand":
            targets = palm_targets(armature, name, targets_arm[role], start_pose)
        for bone_name, target in targets.items():
            bone = bones[bone_name]
            rest = np.array(bone.matrix_local)
            if bone.parent is None:
                parent_now = np.repeat(np.eye(4)[None], len(target), 0)
                parent_rest = np.eye(4)
            else:
                parent_now = _parent_target(bone.parent, name_to_role, targets_arm, start_pose,
                                            len(target))
                parent_rest = np.array(bone.parent.matrix_local)
            offset = np.linalg.inv(parent_rest) @ rest
            out[bone_name] = affine_inverse(parent_now @ offset) @ target
    return out


def moves_chest(plans) -> bool:
    """Whether any of ``plans`` [(Plan, first frame)] turns the chest (then it is keyed)."""
    return any(abs(p.config.body_rotation - plan.poses[0].config.body_rotation) > 1e-9
               for plan, _f in plans for p in plan.poses)


def bone_roles(info, chest: bool) -> tuple:
    """(keyed, reference): role → the bone that receives the keys, and role → the bone
    whose place the plan describes (a Rigify FK control and its ORG bone; the same bone on
    a plain rig). ``chest``: include the chest (only when the plan turns it)."""
    bmap = info.bones
    arm_bones = bmap.arms[info.side]
    keyed = {role: arm_bones.keyed(role) for role in ("upper_arm", "forearm", "hand")}
    reference = {"upper_arm": arm_bones.upper_arm, "forearm": arm_bones.forearm,
                 "hand": arm_bones.hand}
    if arm_bones.clavicle:
        keyed["clavicle"] = arm_bones.keyed("clavicle")
        reference["clavicle"] = arm_bones.clavicle
    if chest:
        keyed["chest"] = reference["chest"] = bmap.keyed_chest
    return keyed, reference


def palm_targets(armature, hand, target, start_pose) -> dict:
    """The keyed hand's palm siblings (:func:`.hand_reading.hand_group`), each carried rigidly by the
    hand's turn: palm → armature-space targets (F, 4, 4); the hand itself included."""
    carry = target @ np.linalg.inv(start_pose[hand])[None]
    out = {hand: target}
    for palm in hand_group(armature, hand)[1:]:
        out[palm] = carry @ start_pose[palm][None]
    return out


def affine_inverse(m):
    """Inverses of affine matrices (..., 4, 4) (bottom row 0 0 0 1): the 3×3 part by its
    adjugate over its determinant, the translation by −M⁻¹t. Much faster than a general
    inverse on a stack of a thousand frames."""
    a = m[..., :3, :3]
    c0 = np.cross(a[..., :, 1], a[..., :, 2])
    c1 = np.cross(a[..., :, 2], a[..., :, 0])
    c2 = np.cross(a[..., :, 0], a[..., :, 1])
    det = np.einsum("...i,...i->...", a[..., :, 0], c0)
    inv3 = np.stack([c0, c1, c2], axis=-2) / det[..., None, None]
    out = np.zeros_like(m)
    out[..., :3, :3] = inv3
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", inv3, m[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def _parent_target(parent, name_to_role, targets_arm, start_pose, n):
    """The parent's armature-space matrix per frame: its own target if keyed, else carried
    rigidly by its nearest keyed ancestor, else its start pose."""
    if parent.name in name_to_role:
        return targets_arm[name_to_role[parent.name]]
    anc = parent.parent
    while anc is not None and anc.name not in name_to_role:
        anc = anc.parent
    s_p = start_pose[parent.name]
    if anc is None:
        return np.repeat(s_p[None], n, 0)
    a_target = targets_arm[name_to_role[anc.name]]
    return a_target @ (np.linalg.inv(start_pose[anc.name]) @ s_p)[None]


def _compatible_quaternions(rotations, previous):
    """The unit quaternion of each rotation matrix, each in the hemisphere of the one before
    it (the first in that of ``previous``, the bone's current value): no 360° spins.
    ``previous`` must be of unit length: ``make_compatible`` gives its result the length of
    the quaternion it is made compatible with."""
    prev = previous
    for r in rotations:
        q = r.to_quaternion()
        q.make_compatible(prev)
        yield q
        prev = q


def channel_values(pose_bone, locals_):
    """Rotation channel values (F, k) and the data path for a bone's rotation mode, from its
    local matrices (F, 4, 4) with the scale divided out, each frame continuous with the one
    before (the first with the bone's current value)."""
    mode = pose_bone.rotation_mode
    rotations = [Matrix(m.tolist()).to_3x3().normalized() for m in locals_]
    if mode == "QUATERNION":
        qs = _compatible_quaternions(rotations, pose_bone.rotation_quaternion.normalized())
        return "rotation_quaternion", np.array([tuple(q) for q in qs])
    if mode == "AXIS_ANGLE":
        # The channel's own quaternion: mathutils' Quaternion(axis, angle) wraps an angle of
        # 180° or more into ±180°, which is the other hemisphere.
        angle, *axis = pose_bone.rotation_axis_angle
        current = Quaternion((math.cos(angle / 2), *(math.sin(angle / 2) * Vector(axis).normalized())))
        out = []
        for q in _compatible_quaternions(rotations, current):
            q_axis, q_angle = q.to_axis_angle()
            out.append((q_angle, *q_axis))
        return "rotation_axis_angle", np.array(out)
    prev = pose_bone.rotation_euler.copy()
    out = []
    for r in rotations:
        e = r.to_euler(mode, prev)
        out.append(tuple(e))
        prev = Euler(e, mode)
    return "rotation_euler", np.array(out)
