"""The chest's turn shared down the spine (``Settings.spine_share``; issue 41, "Table 1's
rotation shared over pelvis, spine and chest").

The planner turns the chest about the body's up axis through the chest bone's head, by the
angle Table 1 reads from the reach direction, and the bake keys that turn on the chest bone
alone: the whole twist at one joint. People spread an axial turn of the trunk over the
thoracolumbar spine; in White & Panjabi's representative segment values (1990) the segments
below the mid-thorax give a little under half of it (T7–S1 about 38°, T1–T7 about 49°).

**The bones** (:func:`share_of`) are the chest's ancestors below it, down to (not with) the
first that carries a leg (the hips, which the step keys), is the root, has a constraint, does
not take its parent's rotation, or has keys a user set (:func:`.own_keys.users_keys`).
Where the body leans or squats nothing is shared: the lean's checks of the trunk's skin
and of the balance hold the trunk below the chest as one piece, and a twist they did not
see could bring the belly against the table leaned over. Rigify's chest control is left
alone: its own torso controls spread the turn over the spine.

**The turn** ``θ(f)`` is read on every baked frame from the chest's keys: their rotation since
the first baked frame. Each shared bone ``j`` turns by ``w_j θ(f)`` about the line from its head
to the chest's head (so the chest's head stays where it is), ``w_j`` the share times the
bone's length over the chain's; then the chest's channel is keyed again so that its pose in
the armature is exactly the one the plan keyed (:func:`chest_bases`): the arm, the other arm
and the head ride on it as planned, and only the spine below the chest bends its twist over
more joints. What the lean, the hips and the step key below the chain cancels out of that
(:func:`chest_bases` never reads it). This runs inside :func:`.bake.bake`, before the
instants between keys are checked, so those checks see it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from mathutils import Euler, Matrix, Quaternion, Vector

from . import balance, own_keys
from .bone_matrices import channel_values
from .fcurves import Channels, ensure_action, write_channel
from .rig_detect import ancestors, constrained


@dataclass(frozen=True)
class SpineShare:
    """The bones that share the chest's turn (``bones``, lowest first) and their ``weights``
    (shares of the turn), or an empty chain and the ``note`` that says why."""

    bones: tuple = ()
    weights: tuple = ()
    note: str | None = None

    def key(self, context, armature, chest: str, first: int, last: int) -> tuple:
        """Key the share on frames ``first``..``last`` (see the module docstring), the
        ``chest``'s keys made to hold its planned pose. Returns (report figures, the keyed
        channels as (data path, index) pairs)."""
        if not self.bones:
            return ({"spine_note": self.note} if self.note else {}), []
        return _key(context, armature, self, chest, first, last)


def share_of(armature, info, settings, legs) -> SpineShare:
    """The :class:`SpineShare` of ``info``'s chest on ``armature`` (see the module
    docstring); ``legs`` (:func:`.balance.find_legs`) bound the chain from below."""
    share = float(settings.spine_share)
    if share <= 0.0:
        return SpineShare()
    if info.bones.key_chest:
        return SpineShare(note="the rig's own torso controls spread the chest's turn")
    bones = armature.data.bones
    chest = bones[info.bones.keyed_chest]
    below = set()
    for leg in legs or ():
        if leg.hip[0] in bones:
            hip = bones[leg.hip[0]]
            below |= {hip.name} | {b.name for b in ancestors(hip)}
    chain = []
    for b in ancestors(chest):
        if (b.name in below or b.parent is None or constrained(armature.pose.bones[b.name])
                or not b.use_inherit_rotation or own_keys.users_keys(armature, b.name)):
            break
        chain.append(b)
    if not chain:
        return SpineShare(note="no spine bone between the chest and the hips turns with it")
    chain = chain[::-1]
    lengths = np.array([max(b.length, 1e-9) for b in chain])
    weights = share * lengths / lengths.sum()
    return SpineShare(tuple(b.name for b in chain), tuple(float(w) for w in weights))


def _rotation(pb, values) -> np.ndarray:
    """The rotation (3, 3) of ``pb``'s rotation channel ``values`` in its rotation mode."""
    mode = pb.rotation_mode
    if mode == "QUATERNION":
        m = Quaternion(values).normalized().to_matrix()
    elif mode == "AXIS_ANGLE":
        m = Quaternion(Vector(values[1:]).normalized(), values[0]).to_matrix()
    else:
        m = Euler(values, mode).to_matrix()
    return np.array(m)


def _channel(pb) -> tuple:
    mode = pb.rotation_mode
    if mode == "QUATERNION":
        return "rotation_quaternion", 4
    if mode == "AXIS_ANGLE":
        return "rotation_axis_angle", 4
    return "rotation_euler", 3


def axis_rotation(axis, angle: float) -> np.ndarray:
    """The rotation (3, 3) by ``angle`` (radians) about the unit ``axis``."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


def turn_angles(rotations) -> tuple:
    """(signed angles (F,), unit axis (3,)): each of ``rotations`` (F, 3, 3) relative to the
    first, as an angle about the axis of the largest (its sign that axis's); the axis in the
    first's own frame."""
    rel = np.einsum("ji,fjk->fik", rotations[0], rotations)
    quats = np.array([tuple(Matrix(r.tolist()).to_quaternion()) for r in rel])
    quats *= np.where(quats[:, :1] < 0.0, -1.0, 1.0)
    sines = np.linalg.norm(quats[:, 1:], axis=1)
    k = int(np.argmax(sines))
    if sines[k] < 1e-9:
        return np.zeros(len(rotations)), np.array([0.0, 0.0, 1.0])
    axis = quats[k, 1:] / sines[k]
    return 2.0 * np.arctan2(quats[:, 1:] @ axis, quats[:, 0]), axis


def chest_bases(offsets, bases, turns, chest_offset, chest_basis) -> np.ndarray:
    """The chest's channel matrices (F, 4, 4) that keep its armature-space pose where the
    chain below it turns: ``offsets`` (n, 4, 4) each chain bone's rest matrix relative to its
    parent's (lowest first), ``bases`` (n, 4, 4) their channel matrices before the turn,
    ``turns`` (F, n, 3, 3) each one's added turn in its own axes, ``chest_offset`` (4, 4) and
    ``chest_basis`` (F, 4, 4) the chest's. With O = Π offset_j·basis_j and N = Π offset_j·
    basis_j·turn_j (lowest first), the chest keeps ``O·chest_offset·chest_basis`` if its
    channel is (N·chest_offset)⁻¹·O·chest_offset·chest_basis; whatever carries the lowest
    bone multiplies both sides and cancels."""
    old = np.eye(4)
    for off, b in zip(offsets, bases):
        old = old @ off @ b
    old = old @ chest_offset
    out = np.empty_like(chest_basis)
    for f in range(len(chest_basis)):
        new = np.eye(4)
        for j, (off, b) in enumerate(zip(offsets, bases)):
            t = np.eye(4)
            t[:3, :3] = turns[f, j]
            new = new @ off @ b @ t
        new = new @ chest_offset
        out[f] = np.linalg.inv(new) @ old @ chest_basis[f]
    return out


def _offset(bone) -> np.ndarray:
    return np.linalg.inv(np.array(bone.parent.matrix_local)) @ np.array(bone.matrix_local)


def _solve(armature, share: SpineShare, chest: str, bases, rots, chest_basis) -> tuple:
    """(the chest's turns (F,) since ``rots[0]``, its channel matrices (F, 4, 4) that keep
    its pose, the shared bones' turns (F, n, 3, 3) in their own axes) for the chest's
    rotations ``rots`` (F, 3, 3) and channel matrices ``chest_basis`` (F, 4, 4), the shared
    bones' channel matrices ``bases`` (n, 4, 4) before their turn. The lines the bones turn
    about are read from the pose now: the chest's head keeps its place in each shared
    bone's axes, whatever they turned."""
    pose, bones = armature.pose.bones, armature.data.bones
    thetas, axis_c = turn_angles(rots)
    mc = np.array(pose[chest].matrix)
    up = mc[:3, :3] @ axis_c          # the chest's turn axis in the armature
    head_c = mc[:3, 3]
    turns = np.empty((len(rots), len(share.bones), 3, 3))
    for j, (name, w) in enumerate(zip(share.bones, share.weights)):
        m = np.array(pose[name].matrix)
        line = head_c - m[:3, 3]
        local = np.linalg.solve(m[:3, :3], line)
        local /= np.linalg.norm(local)
        sign = 1.0 if line @ up >= 0.0 else -1.0
        for f, t in enumerate(thetas):
            turns[f, j] = axis_rotation(local, sign * w * t)
    offsets = np.array([_offset(bones[n]) for n in share.bones])
    return thetas, chest_bases(offsets, bases, turns, _offset(bones[chest]), chest_basis), turns


def pose_now(armature, share: SpineShare, start: dict, chest: str, chest_basis) -> np.ndarray:
    """Live's share of one pose: the shared bones posed (their ``matrix_basis``) for the
    chest's channel matrix ``chest_basis`` (4, 4), turned from ``start`` (bone → channel
    matrix at the session's start, the chest's among them). Returns the chest's channel
    matrix that keeps its pose."""
    def unit(m):
        return m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)

    rots = np.stack([unit(start[chest]), unit(chest_basis)])
    bases = np.array([start[n] for n in share.bones])
    _t, new_chest, turns = _solve(armature, share, chest, bases, rots,
                                  np.stack([start[chest], chest_basis]))
    for j, name in enumerate(share.bones):
        b = bases[j].copy()
        b[:3, :3] = b[:3, :3] @ turns[-1, j]
        armature.pose.bones[name].matrix_basis = Matrix(b.tolist())
    return new_chest[-1]


def _key(context, armature, share: SpineShare, chest: str, first: int, last: int) -> tuple:
    frames = np.arange(first, last + 1, dtype=float)
    pose = armature.pose.bones
    channels = Channels(armature, ensure_action(armature, False))
    pc = pose[chest]
    path, size = _channel(pc)
    full = f'pose.bones["{chest}"].{path}'
    curves = [channels.bag.fcurves.find(full, index=i) for i in range(size)]
    values = np.array([[pc.path_resolve(path)[i] if c is None else c.evaluate(f)
                        for i, c in enumerate(curves)] for f in frames])
    rots = np.array([_rotation(pc, v) for v in values])
    basis_c = np.repeat(np.array(pc.matrix_basis)[None], len(frames), 0)   # T·R·S
    basis_c[:, :3, :3] = rots * np.array(pc.scale)[None, None, :]
    bases = np.array([np.array(pose[n].matrix_basis) for n in share.bones])
    thetas, new_chest, turns = _solve(armature, share, chest, bases, rots, basis_c)
    keyed = []
    for j, name in enumerate(share.bones):
        b = np.repeat(bases[j][None], len(frames), 0)
        b[:, :3, :3] = b[:, :3, :3] @ turns[:, j]
        p, v = channel_values(pose[name], b)
        write_channel(channels, f'pose.bones["{name}"].{p}', v, frames, name)
        keyed += [(f'pose.bones["{name}"].{p}', i) for i in range(v.shape[1])]
    p, v = channel_values(pc, new_chest)
    write_channel(channels, full, v, frames, chest)
    own_keys.record(channels.action, list(share.bones), first, last)
    context.view_layer.update()
    carried = float(np.abs(thetas).max(initial=0.0)) * sum(share.weights)
    return ({"spine_bones": ", ".join(share.bones),
             "spine_turn_deg": round(math.degrees(carried), 1)}, keyed)


def for_rig(armature, info, settings, leaning: bool) -> SpineShare:
    """:func:`share_of` with the rig's legs found as the lean finds them; nothing shared
    where the body is ``leaning`` (see the module docstring)."""
    if leaning and settings.spine_share > 0.0:
        return SpineShare(note="the body leans: its checks hold the trunk below the chest "
                          "as one piece, and the chest turns alone")
    return share_of(armature, info, settings, balance.find_legs(armature, info.bones,
                                                                info.frame))
