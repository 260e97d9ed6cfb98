"""Bake a plan as keyframes: one key per frame on the bones that move.

From poses to bone rotations
----------------------------
A plan gives, per frame, joint positions, the forearm's bend direction, the hand's
direction and the chest rotation. Each keyed bone's armature-space matrix at frame *k* is
its matrix in the start pose turned by the rotation that carries the start frame of its
segment to the planned one:

* upper arm: (u, b, u × b), with u the upper arm direction and b the bend direction;
* forearm: (f, h, f × h), with h = u × b the elbow's hinge axis;
* hand: (d, g, d × g), with d the hand direction and g the hinge made perpendicular to d,
  turned by the pose's palm roll ψ about d (*Match orientation*,
  :mod:`reach_addon.core.orient`); the forearm's frame is turned by
  :data:`~reach_addon.core.orient.FOREARM_SHARE` of ψ about its own axis (neither moves a
  joint, so the hand's direction and every position stay the plan's);
* chest: the chest rotation about the body's up axis through the chest bone's head;
* clavicle: carried by the chest.

A hand of several sibling palm bones (:func:`.rig.hand_group`) is keyed as one rigid body:
every palm's target is its start matrix carried by the hand bone's own turn (the same
rotation about the wrist they share), so the palms keep their placement relative to each
other and their fingers follow them.

So bone rolls, rest poses and axis conventions cancel out: whatever the rig, the bones end
up where the plan puts them. A bone's local (channel) matrix is ``(M_p P⁻¹ B)⁻¹ D`` with
``B``/``P`` its own and its parent's rest matrices, ``D`` its target and ``M_p`` the
parent's target (a parent that is not keyed follows its nearest keyed ancestor rigidly).
Rotations are written in each bone's own rotation mode, quaternions kept continuous
(``make_compatible``), Eulers compatible with the previous frame.

Writing keys
------------
Keys are written in bulk (``keyframe_points.add`` + ``foreach_set``) through whichever API
the running Blender has — ``Action.fcurves`` (≤ 4.3), or slots + layers + strips +
channelbags (4.4+) — found by capability, not by version number. Existing keys of the baked
channels inside the baked frame range are replaced; every other key stays. With
``new_action`` the armature's action is copied first and the copy receives the keys.
New keys get the interpolation of the user's preferences; then the instants between them
are checked as Blender evaluates them, and a span that comes closer to an obstacle than
the planner allows is made linear (:func:`straighten`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import bpy
import numpy as np
from mathutils import Euler, Matrix, Quaternion, Vector

from ..core import ReachError
from ..core.arm import roll_frames
from ..core.orient import FOREARM_SHARE
from ..core.torso import spine_rotation_matrix
from .hand_reading import hand_group

ROLE_ORDER = ("chest", "clavicle", "upper_arm", "forearm", "hand")


@dataclass
class BakeResult:
    action: str
    bones: list            # keyed bone names, hierarchy order
    frames: tuple          # (first, last) frame written
    #: the largest distance left between a planned bone and where the keys put it, as a
    #: share of the arm's length (:func:`settle`; 0 for rigs that need no settling)
    residual: float = 0.0
    #: per plan, the spans between two keys made linear because Blender's curve between
    #: them came closer to an obstacle than the planner allows (:func:`straighten`)
    linear_spans: list = field(default_factory=list)
    #: per plan, the spans still closer than that after it (0 when every instant is clear)
    close_spans: list = field(default_factory=list)


# --- matrices ---------------------------------------------------------------------------

def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _frames(a, b):
    """Orthonormal frames (…, 3, 3) with columns a, b, a × b (b made perpendicular to a)."""
    a = _unit(a)
    b = _unit(b - np.einsum("...i,...i->...", b, a)[..., None] * a)
    return np.stack([a, b, np.cross(a, b)], -1)


def target_matrices(info, plan, start_world, chest_head_world):
    """World-space target matrices (F, 4, 4) per role for every frame of ``plan``.

    ``start_world``: role → the 4×4 world matrix of that role's reference bone in the
    start pose. ``chest_head_world``: the chest bone's head (the rotation pivot)."""
    arm = info.arm
    joints = plan.world_joints()                      # (F, 5, 3)
    bends = plan.world_bends()                        # (F, 3)
    m = arm.to_world[:3, :3]
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
    joint_of = {"upper_arm": 1, "forearm": 2, "hand": 3}
    out = {}
    n = len(plan.poses)
    for role, f in frames.items():
        if role not in start_world:
            continue
        rot = f @ np.swapaxes(f[0], -1, -2)[None]     # carries frame 0 to frame k
        s = start_world[role]
        d = np.repeat(s[None], n, 0)
        d[:, :3, :3] = rot @ s[:3, :3]
        d[:, :3, 3] = joints[:, joint_of[role]]
        out[role] = d
    body = np.array([p.config.body_rotation for p in plan.poses])
    body = body - body[0]
    chest_rot = m @ spine_rotation_matrix(body) @ m.T          # (F, 3, 3), world
    for role in ("chest", "clavicle"):
        if role in start_world:
            s = start_world[role]
            d = np.repeat(s[None], n, 0)
            d[:, :3, :3] = chest_rot @ s[:3, :3]
            d[:, :3, 3] = (chest_rot @ (s[:3, 3] - chest_head_world)) + chest_head_world
            out[role] = d
    return out


def local_matrices(armature, keyed, targets_arm, start_pose):
    """Channel (basis) matrices (F, 4, 4) of the keyed bones, hierarchy order.

    ``keyed``: role → bone name; ``targets_arm``: role → armature-space targets (F, 4, 4);
    ``start_pose``: bone name → armature-space pose matrix at the start (every bone). The
    keyed hand's palm siblings (:func:`.rig.hand_group`) are keyed too, right after it,
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
            targets = _palm_targets(armature, name, targets_arm[role], start_pose)
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


def _palm_targets(armature, hand, target, start_pose) -> dict:
    """The keyed hand's palm siblings (:func:`.rig.hand_group`), each carried rigidly by the
    hand's turn: palm → armature-space targets (F, 4, 4); the hand itself included."""
    carry = target @ np.linalg.inv(start_pose[hand])[None]
    out = {hand: target}
    for palm in hand_group(armature, hand)[1:]:
        out[palm] = carry @ start_pose[palm][None]
    return out


def _driven(armature, names) -> bool:
    """Whether any of ``names`` or their ancestors has a constraint or a driver: then what a
    bone's keys do depends on more than its parents' keys, and the pose must be evaluated."""
    bones = armature.pose.bones
    seen = set()
    for name in names:
        pb = bones[name]
        while pb is not None and pb.name not in seen:
            seen.add(pb.name)
            if any(c.enabled and c.influence > 0 for c in pb.constraints):
                return True
            pb = pb.parent
    ad = armature.animation_data
    drivers = ad.drivers if ad is not None else ()
    return any(d.data_path.startswith("pose.bones[") and
               d.data_path.split('"')[1] in seen for d in drivers if '"' in d.data_path)


#: Settling: corrections per bone and frame at most, and the turn (radians: the arm's
#: length times it, at the far end) it leaves.
SETTLE_ROUNDS = 4
SETTLE_TOLERANCE = 1e-4


def _turn_error(actual, target) -> float:
    """How far a bone's armature-space matrix is turned from its target (the spectral norm
    of the difference of their unit axes: about the angle, in radians). Only turns: keys
    on rotation channels cannot move a head."""
    ra = actual[:3, :3] / np.linalg.norm(actual[:3, :3], axis=0)
    rt = target[:3, :3] / np.linalg.norm(target[:3, :3], axis=0)
    return float(np.linalg.norm(ra - rt, 2))


def settle(context, armature, keyed, reference, targets_arm, locals_, start_pose) -> float:
    """Correct ``locals_`` (bone → channel matrices (F, 4, 4), from :func:`local_matrices`)
    by evaluating the rig, where its constraints or drivers make the keyed bones move the
    planned bones otherwise than by parenting (Rigify: the chest control turns the spine's
    ORG bones through constraints, so a clavicle keyed by parenting alone turned twice).

    Per frame, the keyed bones are posed from ``locals_``, the pose evaluated, and role by
    role in hierarchy order (chest, clavicle, upper arm, forearm, hand, palms) each
    reference bone is compared with its target; where it is turned from it by more than
    :data:`SETTLE_TOLERANCE` radians, its keyed bone is turned by the difference
    (``pose_bone.matrix``, which Blender turns into channels through the evaluated parent)
    and the pose evaluated again, up to :data:`SETTLE_ROUNDS` times. Only turns are keyed, so
    every bone keeps its own location throughout, as it will in the baked file. Where the
    rig moves a bone's head itself (Rigify's spine stretches a little as the chest turns:
    0.2% of the arm at 10°, 0.8% at 40°) the clavicle and the shoulder keep that offset,
    and upper arm and forearm are turned so the wrist still lands on the plan's
    (:func:`wrist_kept`; aiming each bone's tail at the planned tail instead left the joints
    further off). The pose the user had is restored, however this ends. Rigs without
    constraints or drivers on the keyed chain are left as computed: parenting alone is
    exact there.

    Returns the largest distance left between a planned joint (each reference bone's head,
    the hand's tail) and where the rig puts it, as a share of the arm's length (0 when
    unchecked)."""
    names = set(keyed.values()) | set(reference.values())
    if all(keyed[r] == reference[r] for r in keyed) and not _driven(armature, names):
        return 0.0
    bones = armature.pose.bones
    data = armature.data.bones
    length = data[reference["upper_arm"]].length + data[reference["forearm"]].length
    order = [r for r in ROLE_ORDER if r in keyed]
    touched = list(locals_)
    saved = {n: bones[n].matrix_basis.copy() for n in touched}
    frames = len(next(iter(locals_.values())))
    palms = {}
    if "hand" in keyed:
        palms = _palm_targets(armature, keyed["hand"], targets_arm["hand"], start_pose)
        palms.pop(keyed["hand"])
    hand_tail = np.array([0.0, data[reference["hand"]].length, 0.0, 1.0]) \
        if "hand" in reference else None
    # only turns are keyed: each bone keeps the location it has, here as in the baked file
    kept = {n: basis.to_translation() for n, basis in saved.items()}
    worst = 0.0
    try:
        for k in range(frames):
            for name in touched:
                bones[name].matrix_basis = Matrix(locals_[name][k].tolist())
                bones[name].location = kept[name]
            context.view_layer.update()
            goals = [(keyed[r], reference[r], targets_arm[r][k]) for r in order]
            goals += [(p, p, t[k]) for p, t in palms.items()]
            for i, (key, ref, target) in enumerate(goals):
                if order[i:i + 3] == ["upper_arm", "forearm", "hand"]:
                    # the rig has put the shoulder where it does (chest and clavicle are
                    # settled by now): turn upper arm and forearm so the wrist still lands
                    # where it was planned
                    shoulder = np.array(bones[ref].matrix)[:3, 3]
                    upper, fore = wrist_kept(shoulder, target, goals[i + 1][2],
                                             goals[i + 2][2][:3, 3])
                    goals[i + 1] = (*goals[i + 1][:2], fore)
                    target = upper
                for _round in range(SETTLE_ROUNDS + 1):
                    actual = np.array(bones[ref].matrix)
                    if _turn_error(actual, target) <= SETTLE_TOLERANCE or _round == SETTLE_ROUNDS:
                        break
                    now = np.array(bones[key].matrix)
                    bones[key].matrix = Matrix((target @ affine_inverse(actual) @ now).tolist())
                    bones[key].location = kept[key]
                    context.view_layer.update()
                locals_[key][k] = np.array(bones[key].matrix_basis)
            for role, ref in reference.items():
                target = targets_arm[role][k]
                actual = np.array(bones[ref].matrix)
                worst = max(worst, float(np.linalg.norm(actual[:3, 3] - target[:3, 3])))
                if role == "hand":
                    worst = max(worst, float(np.linalg.norm((actual @ hand_tail - target @ hand_tail)[:3])))
    finally:
        for name, basis in saved.items():
            bones[name].matrix_basis = basis
        context.view_layer.update()
    return worst / length


def wrist_kept(shoulder, upper, fore, wrist):
    """Turn targets for the upper arm and the forearm (armature-space matrices, their
    heads at the planned shoulder and elbow) that keep the planned ``wrist`` where the
    rig has put the shoulder instead (Rigify's spine stretches as the chest turns, moving
    it by up to 0.8 % of the arm): the elbow goes to the point of the circle of elbows
    between ``shoulder`` and ``wrist`` (the bones' own lengths) nearest the planned one,
    and each bone turns by the least rotation onto its new direction. Where the wrist is
    beyond the arm's reach from there the arm points straight at it. Returns the two
    matrices, their heads at the new shoulder and elbow."""
    elbow = fore[:3, 3]
    a = float(np.linalg.norm(elbow - upper[:3, 3]))
    b = float(np.linalg.norm(wrist - elbow))
    axis = wrist - shoulder
    d = float(np.linalg.norm(axis))
    if a < 1e-12 or b < 1e-12 or d < 1e-12:
        return upper, fore
    axis = axis / d
    d = min(max(d, abs(a - b)), a + b)
    along = (a * a - b * b + d * d) / (2.0 * d)       # the elbow circle's centre ...
    radius = math.sqrt(max(a * a - along * along, 0.0))    # ... and radius
    side = (elbow - shoulder) - np.dot(elbow - shoulder, axis) * axis
    n = float(np.linalg.norm(side))
    new_elbow = shoulder + along * axis + (radius * side / n if n > 1e-12 else 0.0)

    def turned(m, head, old_dir, new_dir):
        out = m.copy()
        least = Vector(old_dir).rotation_difference(Vector(new_dir)).to_matrix()
        out[:3, :3] = np.array(least) @ m[:3, :3]
        out[:3, 3] = head
        return out

    return (turned(upper, shoulder, elbow - upper[:3, 3], new_elbow - shoulder),
            turned(fore, new_elbow, wrist - elbow, wrist - new_elbow))


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


# --- keyframes --------------------------------------------------------------------------

def _assign(armature, action):
    ad = armature.animation_data or armature.animation_data_create()
    if ad.action != action:
        if armature.pose is None:
            # Re-assigning an armature's action before its pose exists crashes 4.5 and 5.0.
            bpy.context.view_layer.update()
        ad.action = action
    return ad


def _slot_free(slot, armature) -> bool:
    users = slot.users() if hasattr(slot, "users") else []
    return all(u == armature for u in users)


def ensure_slot(armature, action):
    """On slotted actions (4.4+), make sure the armature has a slot of ``action`` and return
    it: the one Blender picked, else one named for the object or last used by it, else an
    unused one, else a new slot. A slot another ID uses is never taken over."""
    ad = _assign(armature, action)
    if not hasattr(action, "slots"):
        return None
    if ad.action_slot is not None:
        return ad.action_slot
    wanted = {"OB" + armature.name, getattr(ad, "last_slot_identifier", "") or ""} - {""}
    usable = [s for s in action.slots if s.target_id_type in {"OBJECT", "UNSPECIFIED"}
              and _slot_free(s, armature)]
    slot = next((s for s in usable if s.identifier in wanted), None)
    if slot is None and len(action.slots) == 1 and usable:
        slot = usable[0]
    if slot is None:
        slot = action.slots.new(id_type="OBJECT", name=armature.name)
    ad.action_slot = slot
    return slot


def ensure_action(armature, new_action: bool):
    """The action to write into: the armature's own; a new one if it has none; with
    ``new_action``, a copy of its own (the original keeps a fake user, so saving the file
    loses nothing)."""
    ad = armature.animation_data
    action = ad.action if ad else None
    if action is None:
        action = bpy.data.actions.new(f"{armature.name} Reach")
        if hasattr(action, "slots"):
            action.slots.new(id_type="OBJECT", name=armature.name)
    elif new_action:
        original = action
        action = original.copy()
        action.name = f"{original.name} Reach"
        original.use_fake_user = True
    ensure_slot(armature, action)
    return action


class Channels:
    """The F-curves of one action for one armature, whatever the API: ``Action.fcurves``
    before slotted actions, else the channelbag of the armature's slot (created if
    needed). Curves are grouped by bone, as Blender groups pose channels."""

    def __init__(self, armature, action):
        if not hasattr(action, "slots"):
            self.bag = action
            return
        slot = ensure_slot(armature, action)
        try:
            from bpy_extras.anim_utils import action_ensure_channelbag_for_slot
            self.bag = action_ensure_channelbag_for_slot(action, slot)
        except ImportError:  # 4.4 / 4.5
            layer = action.layers[0] if action.layers else action.layers.new("Layer")
            strip = layer.strips[0] if layer.strips else layer.strips.new(type="KEYFRAME")
            self.bag = strip.channelbag(slot, ensure=True)

    def curve(self, path, index, group):
        fc = self.bag.fcurves.find(path, index=index)
        if fc is None:
            fc = self.bag.fcurves.new(path, index=index)
        if fc.group is None:
            fc.group = self.bag.groups.get(group) or self.bag.groups.new(group)
        return fc


# Keyframe attributes (enums as their integer values for foreach_get/set).
_PAIRS = ("co", "handle_left", "handle_right")
_FLOATS = {"back": 1.70158, "amplitude": 0.8, "period": 4.1}      # a fresh key's values
_ENUMS = ("interpolation", "handle_left_type", "handle_right_type", "type", "easing")
_BOOLS = ("select_control_point", "select_left_handle", "select_right_handle")


def _new_key_enums():
    """Enum values a key inserted by the user would get (their preferences)."""
    edit = bpy.context.preferences.edit
    props = bpy.types.Keyframe.bl_rna.properties
    wanted = {"interpolation": edit.keyframe_new_interpolation_type,
              "handle_left_type": edit.keyframe_new_handle_type,
              "handle_right_type": edit.keyframe_new_handle_type,
              "type": "KEYFRAME", "easing": "AUTO"}
    return {k: props[k].enum_items[v].value for k, v in wanted.items()}


def write_channel(channels, path, values, frames, group):
    """Replace the keys of ``path`` (each array index) inside [frames[0], frames[-1]] by
    ``values`` (F, k). The curve is read in bulk, merged in frame order and written back
    (``clear`` + ``add`` + ``foreach_set``): keys outside the range keep every attribute,
    new keys get every attribute a user's key would get — ``add`` after a ``remove`` would
    otherwise hand back stale key settings — and ``update`` has nothing to sort."""
    lo, hi = frames[0] - 0.5, frames[-1] + 0.5
    enums = _new_key_enums()
    nn = len(frames)
    for index in range(values.shape[1]):
        fc = channels.curve(path, index, group)
        pts = fc.keyframe_points
        n = len(pts)
        old = {}
        for a in _PAIRS:
            old[a] = np.empty(2 * n, np.float32)
            pts.foreach_get(a, old[a])
            old[a] = old[a].reshape(n, 2)
        for a in _FLOATS:
            old[a] = np.empty(n, np.float32)
            pts.foreach_get(a, old[a])
        for a in _ENUMS:
            old[a] = np.empty(n, np.int32)
            pts.foreach_get(a, old[a])
        for a in _BOOLS:
            old[a] = np.empty(n, bool)
            pts.foreach_get(a, old[a])
        x = old["co"][:, 0]
        before, after = x < lo, x > hi
        new_co = np.column_stack([frames, values[:, index]]).astype(np.float32)

        def merged(arr, new, before=before, after=after):
            return np.concatenate([arr[before], new, arr[after]])

        pts.clear()
        pts.add(int(before.sum()) + nn + int(after.sum()))
        for a in _PAIRS:       # new keys' handles are recomputed by update()
            pts.foreach_set(a, merged(old[a], new_co).ravel())
        for a, v in _FLOATS.items():
            pts.foreach_set(a, merged(old[a], np.full(nn, v, np.float32)))
        for a in _ENUMS:
            pts.foreach_set(a, merged(old[a], np.full(nn, enums[a], np.int32)))
        for a in _BOOLS:
            pts.foreach_set(a, merged(old[a], np.zeros(nn, bool)))
        fc.update()


def bake(context, armature, info, plans, new_action=False, checkers=None) -> BakeResult:
    """Write keys for ``plans`` [(Plan, first frame)] on ``armature`` (see the module doc).
    ``checkers``: per plan, the collision checkers of its obstacles (one per pose, or one
    for all; their margin is not used); with them the instants between keys are checked
    as Blender interpolates them (:func:`straighten`)."""
    bmap = info.bones
    pose = armature.pose.bones
    mw = np.array(armature.matrix_world)
    mw_inv = np.linalg.inv(mw)
    start_pose = {pb.name: np.array(pb.matrix) for pb in pose}

    keyed, reference = bone_roles(info, moves_chest(plans))
    for name in keyed.values():
        if name not in pose:
            raise ReachError(f"bone '{name}' is missing from armature '{armature.name}'")

    start_world = {role: mw @ start_pose[ref] for role, ref in reference.items()}
    chest_head = (mw @ start_pose[bmap.keyed_chest])[:3, 3]

    first = plans[0][1]
    # the FK/IK switch first: the arm's controls only move it in FK, and settling evaluates
    switches = [(bone_name, prop) for side, (bone_name, prop) in bmap.ik_fk.items()
                if side == info.side]
    for bone_name, prop in switches:
        pose[bone_name][prop] = 1.0
        armature.update_tag()
    # every plan's channel matrices, settled against the evaluated rig before the action is
    # touched (a newly assigned action or new keys would be evaluated over the pose being
    # measured)
    baked, residual = [], 0.0
    for plan, frame0 in plans:
        targets = target_matrices(info, plan, start_world, chest_head)
        targets_arm = {role: mw_inv[None] @ m for role, m in targets.items()}
        locals_ = local_matrices(armature, keyed, targets_arm, start_pose)
        residual = max(residual, settle(context, armature, keyed, reference, targets_arm,
                                        locals_, start_pose))
        baked.append((locals_, frame0 + np.arange(len(plan.poses), dtype=float)))
    action = ensure_action(armature, new_action)
    channels = Channels(armature, action)
    last = first
    curves = []
    for locals_, frames in baked:
        for name, mats in locals_.items():
            path, values = channel_values(pose[name], mats)
            full = f'pose.bones["{name}"].{path}'
            write_channel(channels, full, values, frames, name)
            curves += [(full, i) for i in range(values.shape[1])]
        last = max(last, int(frames[-1]))
    for bone_name, prop in switches:
        write_channel(channels, f'pose.bones["{bone_name}"]["{prop}"]',
                      np.ones((2, 1)), np.array([first, last], float), bone_name)
    context.view_layer.update()
    order = [n for r in ROLE_ORDER if r in keyed
             for n in (hand_group(armature, keyed[r]) if r == "hand" else (keyed[r],))]
    result = BakeResult(action.name, order, (first, last), residual)
    if checkers is not None:
        curves = [channels.bag.fcurves.find(path, index=i) for path, i in dict.fromkeys(curves)]
        result.linear_spans, result.close_spans = straighten(
            context, armature, info, plans, checkers, curves, reference)
    return result


def _carriers(info, reference) -> tuple:
    """The bone that carries each of the arm's five joints (sternum, shoulder, elbow,
    wrist, hand end): the chest, upper arm, forearm, hand, hand (reference bones)."""
    return (info.bones.keyed_chest, reference["upper_arm"], reference["forearm"],
            reference["hand"], reference["hand"])


def straighten(context, armature, info, plans, checkers, curves, reference) -> tuple:
    """Check the instants between keys as Blender interpolates them, and make linear the
    spans that come too close.

    The planner checks its motion at ``Settings.instants_per_frame`` instants between two
    keys, where Blender puts the arm on a linear span (:func:`reach_addon.core.keys.
    between`), against half the clearance
    (:meth:`~reach_addon.core.generator.ConfigurationGenerator.between_keys`). Blender
    interpolates each keyed channel by its own curve: with the user's default, Bézier, a
    span bows away from the linear one. With a margin that bow stays
    inside the half of the clearance the keys do not use; with no clearance it can dip
    into an obstacle (fuzz seeds 799, 849, 901: 0.001–0.005 arm lengths in at a sub-frame
    instant).

    So each span of each plan is evaluated by Blender at the same instants
    (``scene.frame_set(f, subframe=s)``); the arm's joints are carried by their bones
    (:func:`_carriers`) from where the plan puts them at the two keys, blended by ``s``,
    and measured against the plan's own obstacles (``checkers``: per plan, one per pose
    or one for all; each span against those of both its keys) to within
    :data:`STRAIGHTEN_TOLERANCE` (:meth:`~reach_addon.core.collision.CollisionChecker.
    pose_clearance`). A span must keep the planner's margin between keys where both of
    its keys keep it, and must not touch where they are within it (a motion leaving a
    start in contact); a span with a key in contact is the planner's own and is not
    changed. A span that comes too close gets linear interpolation on every keyed
    channel (the key at its start decides; neighbouring spans keep their shape): Blender
    then follows the linear span, which the planner checked. If that comes too close as
    well (bones in an Euler mode, whose angles interpolate otherwise; a rig whose
    constraints move the arm), the user's interpolation is put back and the span counted.

    Cost: spans whose keys turn the arm too little to come that close (a bound read from
    the curves, :func:`_turn_reader`) are not evaluated; the rest cost a scene
    evaluation per instant (about 0.1 s a task on the demo's character).

    Returns per plan (spans made linear, spans still too close after it)."""
    scene = context.scene
    bones = armature.pose.bones
    mw = np.array(armature.matrix_world)
    carriers = _carriers(info, reference)
    # every curve's keys by frame, to find the key that starts a span
    keys = []
    for fc in curves:
        pts = fc.keyframe_points
        co = np.empty(2 * len(pts), np.float32)
        pts.foreach_get("co", co)
        keys.append((pts, {int(round(x)): i for i, x in enumerate(co[0::2].tolist())}))

    def carried(frame, sub=0.0):
        scene.frame_set(frame, subframe=sub)
        return [mw @ np.array(bones[c].matrix) for c in carriers]

    def local(mats, joints):
        return [np.linalg.solve(m, np.append(p, 1.0))[:3] for m, p in zip(mats, joints)]

    turned = _turn_reader(armature, curves, carriers)
    chest_head = (mw @ np.array(bones[carriers[0]].matrix))[:3, 3]
    now = (scene.frame_current, scene.frame_subframe)
    try:
        return _straighten_plans(plans, checkers, keys, carried, local, turned, chest_head)
    finally:
        scene.frame_set(now[0], subframe=now[1])


def _turn_reader(armature, curves, carriers):
    """A bound on how far the keys turn the arm between two keys, read from the keyed
    curves alone (``FCurve.evaluate``, no scene evaluation): ``turned(f, s)`` gives, for
    the instant ``f`` + ``s``, the sum over the keyed bones of the angle (radians) each
    bone's own rotation has turned from key ``f`` and from key ``f`` + 1. No joint moves
    farther than that sum times the distance from the chest to the hand's end (each
    bone turns the joints it carries about its own head, and none is farther from it).
    None on a rig whose keyed bones also move through constraints or drivers, where the
    curves do not tell the whole motion."""
    groups = {}
    for fc in sorted(curves, key=lambda c: c.array_index):
        name = fc.data_path.split('"')[1]
        mode = fc.data_path.rsplit(".", 1)[-1]
        groups.setdefault((name, mode), []).append(fc)
    if _driven(armature, {name for name, _m in groups} | set(carriers)):
        return None

    def rotation(mode, values):
        if mode == "rotation_quaternion":
            return Quaternion(values).normalized()
        return Quaternion(values[1:], values[0]).normalized()       # axis-angle

    def values(x):
        return [[c.evaluate(x) for c in fcs] for fcs in groups.values()]

    at_key = {}             # the curves at each key, read once for all its instants

    def turned(f, s):
        out = [0.0, 0.0]
        now = values(f + s)
        for i, key in enumerate((f, f + 1)):
            if key not in at_key:
                at_key[key] = values(key)
            for (_name, mode), a, b in zip(groups, now, at_key[key]):
                if mode == "rotation_euler":
                    # each channel an angle: their sum bounds the whole turn
                    out[i] += sum(abs(x - y) for x, y in zip(a, b))
                else:
                    out[i] += rotation(mode, a).rotation_difference(rotation(mode, b)).angle
        return out
    return turned


#: how exactly :func:`straighten` measures clearances, as a share of the arm's length
STRAIGHTEN_TOLERANCE = 1e-4
#: ... and the clearance of keys well clear of the margin (only a bound for the instants)
KEY_TOLERANCE = 2e-3


def _span_touches(carried, f, n, a, b, checkers, need, settings, keys) -> bool:
    """Does the arm come closer than ``need`` to the obstacles (of any of ``checkers``)
    at one of the ``n`` - 1 instants Blender evaluates between keys ``f`` and ``f`` + 1?
    Each joint is carried by its bone from its place at either key (``a``, ``b``:
    bone-local points), blended by the instant. ``keys``: ((joints, clearance) of both
    keys): no joint moves farther than δ from a key's place, so no capsule comes nearer
    than that key's clearance - δ; only instants this bound leaves open are measured."""
    for i in range(1, n):
        s = i / n
        mats = carried(f, s)
        world = np.array([(m @ np.append((1.0 - s) * p + s * q, 1.0))[:3]
                          for m, p, q in zip(mats, a, b)])
        bound = max(c - float(np.linalg.norm(world - j, axis=1).max()) for j, c in keys)
        if bound >= need:
            continue
        if _pose_clearance(checkers, world, settings, need) < need:
            return True
    return False


def _pose_clearance(checkers, joints, settings, horizon, share=STRAIGHTEN_TOLERANCE) -> float:
    """A pose's least clearance (figure units, no margin) against each of ``checkers``'
    obstacles, to ``share`` of the arm's length above it at most, looking no farther than
    ``horizon`` (beyond it: at least ``horizon``)."""
    tolerance = share * checkers[0].arm.arm_length
    return min(c.pose_clearance(joints, horizon + tolerance, tolerance,
                                bool(settings.check_hand)) for c in checkers)


def _straighten_plans(plans, checkers, keys, carried, local, turned, chest_head) -> tuple:
    """:func:`straighten`'s loop over every span of every plan."""
    linear, close = [], []
    for (plan, frame0), own in zip(plans, checkers):
        linear.append(0)
        close.append(0)
        own = list(own)
        settings = plan.settings
        n = max(2, int(settings.instants_per_frame))
        joints = plan.world_joints()
        length = plan.arm.arm_length
        margin = 0.5 * settings.clearance * length     # the planner's, between keys
        ends = [None] * len(joints)                     # each key's clearance, once
        before = None
        # keys farther than this need no exact clearance: the bound of _span_touches
        horizon = margin + 0.25 * length
        # the farthest any joint is from the head of a bone that carries it: the chest's,
        # or the clavicle's, upper arm's, ... (at most the chain's length from it)
        reach = max(float(np.linalg.norm(joints - chest_head, axis=2).max()),
                    float(np.linalg.norm(joints[0, 1] - joints[0, 0])) + length
                    + plan.arm.hand_length)
        coarse = KEY_TOLERANCE * length
        for k in range(len(plan.poses) - 1):
            pair = list({id(c): c for c in (own[min(k, len(own) - 1)],
                                            own[min(k + 1, len(own) - 1)])}.values())
            for i in (k, k + 1):
                if ends[i] is None or len(pair) > 1:
                    # coarsely first: a key clear of the margin by more than that
                    # tolerance needs no more (its clearance only bounds the instants
                    # near it, from below); one nearer is measured exactly
                    ends[i] = _pose_clearance(pair, joints[i], settings, horizon,
                                              KEY_TOLERANCE) - coarse
                    if ends[i] < margin:
                        ends[i] = _pose_clearance(pair, joints[i], settings, horizon)
            if min(ends[k], ends[k + 1]) < 0.0:
                # a key in contact: a start in contact being left, the planner's own
                before = None
                continue
            # the planner's margin between keys where both keys keep it; elsewhere (a
            # motion leaving a start in contact) no contact
            need = (margin if min(ends[k], ends[k + 1]) >= margin else 0.0) \
                - STRAIGHTEN_TOLERANCE * length
            f = frame0 + k
            if turned is not None and all(
                    max(ends[k] - ta * reach, ends[k + 1] - tb * reach) >= need
                    for ta, tb in (turned(f, i / n) for i in range(1, n))):
                before = None      # the keys turn the arm too little to come that close
                continue
            a = before if before is not None else local(carried(f), joints[k])
            b = local(carried(f + 1), joints[k + 1])
            before = b

            def touches(span=(f, n, a, b, pair, need, settings,
                              ((joints[k], ends[k]), (joints[k + 1], ends[k + 1])))):
                return _span_touches(carried, *span)

            if not touches():
                continue
            starts = [(pts[i], pts[i].interpolation) for pts, at in keys
                      if (i := at.get(int(f))) is not None]
            for point, _was in starts:
                point.interpolation = "LINEAR"
            if touches():
                # the straight line comes too close as well (the planner's angles and the
                # bones' rotations part between keys): the user's interpolation stays
                for point, was in starts:
                    point.interpolation = was
                close[-1] += 1
            else:
                linear[-1] += 1
    return linear, close
