"""The chest's turn shared down the spine and to the pelvis (``Settings.spine_share``,
``Settings.trunk_turn_max``; issue 41, "Table 1's rotation shared over pelvis, spine and
chest").

The planner turns the chest about the body's up axis through the chest bone's head, by the
angle Table 1 reads from the reach direction, and the bake keys that turn on the chest bone
alone: the whole twist at one joint. People spread an axial turn of the trunk over the
thoracolumbar spine; in White & Panjabi's representative segment values (1990) the segments
below the mid-thorax give a little under half of it (T7–S1 about 38°, T1–T7 about 49°).
And past the trunk's own range (about 33°) the pelvis turns over the feet
(:mod:`.pelvis_turn`).

**The bones** (:func:`share_of`) are the chest's ancestors below it, down to (not with) the
first that carries a leg (the hips, which the step keys), is the root, has a constraint, does
not take its parent's rotation, or has keys a user set (:func:`.own_keys.users_keys`). The
bone where that stops is the pelvis where it carries both legs. Where the body leans,
squats or steps nothing is shared: the lean's checks of the trunk's skin and of the
balance hold the trunk below the chest as one piece, and the step keys the hips. Rigify's
chest control is left alone: its own torso controls spread the turn over the spine.

**The turn** ``θ(f)`` is read on every baked frame from the chest's keys: their rotation since
the first baked frame. The pelvis takes ``φ(f)``, what ``θ`` goes past *Trunk turn*. Each
shared bone ``j`` turns by ``w_j (θ − φ)`` about the line from its head to the chest's head (so
the chest's head stays where it is), ``w_j`` the share times the bone's length over the
chain's; then the chest's channel is keyed again so that its turn in the armature is
exactly the one the plan keyed (:func:`chest_bases`), its head where it was but for the
fraction of a millimetre a straight leg brings the hips down (:data:`.pelvis_turn.DROP`):
the arm, the other arm and the head ride on it as planned, and only the trunk below the
chest bends its twist over more joints. What carries the chain cancels out of that
(:func:`chest_bases` never reads it).

**Checked** (:func:`_shared`): the skin below the chest, posed as keyed on every frame, keeps
the clearance from the obstacles (:func:`.pelvis_turn.below_chest_hit`). Where it would not,
the pelvis stays; where even the spine's share would not, the chest turns alone; the
report says which (``spine_note``). Where no one checker holds the obstacles of the whole
motion (a chase among obstacles that move, planned frame by frame) the chest turns alone.
This runs inside
:func:`.bake.bake`, before the instants between keys are checked, so those checks see it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from mathutils import Euler, Matrix, Quaternion, Vector

from ..core.gaze import axis_rotation
from . import balance, own_keys, pelvis_turn
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
    #: the pelvis that takes what goes past the trunk's range (:mod:`.pelvis_turn`), or None
    pelvis: pelvis_turn.Pelvis | None = None

    def key(self, context, armature, chest: str, first: int, last: int,
            checker=None) -> tuple:
        """Key the share on frames ``first``..``last`` (see the module docstring), the
        ``chest``'s keys made to hold its planned pose; ``checker``: the obstacles the
        skin below the chest is kept clear of (None: they move, and nothing is shared).
        Returns (report figures, the keyed
        channels as (data path, index) pairs)."""
        if not self.bones and self.pelvis is None:
            return ({"spine_note": self.note} if self.note else {}), []
        return _key(context, armature, self, chest, first, last, checker)


def share_of(armature, info, settings, legs, with_pelvis: bool = True) -> SpineShare:
    """The :class:`SpineShare` of ``info``'s chest on ``armature`` (see the module
    docstring); ``legs`` (:func:`.balance.find_legs`) bound the chain from below; with
    ``with_pelvis``, the pelvis below it turns too where it can (:mod:`.pelvis_turn`)."""
    share = float(settings.spine_share)
    if share <= 0.0:
        return SpineShare()
    if info.bones.key_chest:
        return SpineShare(note="the rig's own torso controls spread the chest's turn")
    bones = armature.data.bones
    chest = bones[info.bones.keyed_chest]
    if not _plain(armature, chest):
        return SpineShare(note=f"the chest '{chest.name}' does not simply follow its parent "
                          "(a constraint, or it keeps its own rotation or scale), and turns "
                          "alone")
    below = set()
    for leg in legs or ():
        if leg.hip[0] in bones:
            hip = bones[leg.hip[0]]
            below |= {hip.name} | {b.name for b in ancestors(hip)}
    chain, stop = [], None
    for b in ancestors(chest):
        if (b.name in below or b.parent is None or not _plain(armature, b)
                or own_keys.users_keys(armature, b.name)):
            stop = b
            break
        chain.append(b)
    pelvis, why = (None, None) if not with_pelvis else pelvis_turn.pelvis_of(
        armature, info, settings, legs)
    if pelvis is not None and (stop is None or pelvis.bone != stop.name):
        pelvis, why = None, f"the spine stops at '{stop.name if stop else chest.name}'"
    note = None if why is None else f"the pelvis stays: {why}"
    if not chain:
        note = "; ".join(n for n in ("no spine bone between the chest and the hips turns "
                                     "with it", note) if n)
        return SpineShare(note=note, pelvis=pelvis)
    chain = chain[::-1]
    lengths = np.array([max(b.length, 1e-9) for b in chain])
    weights = share * lengths / lengths.sum()
    return SpineShare(tuple(b.name for b in chain), tuple(float(w) for w in weights), note,
                      pelvis)


def _plain(armature, bone) -> bool:
    """Whether ``bone`` follows its parent as plain parenting does (no constraint that acts,
    its parent's rotation and scale inherited): what :func:`chest_bases` solves for."""
    return (not constrained(armature.pose.bones[bone.name]) and bone.use_inherit_rotation
            and getattr(bone, "inherit_scale", "FULL") == "FULL")


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


def chest_bases(offsets, bases, moved, chest_offset, chest_basis) -> np.ndarray:
    """The chest's channel matrices (F, 4, 4) that keep its armature-space pose where the
    chain below it turns: ``offsets`` (n, 4, 4) each chain bone's rest matrix relative to its
    parent's (lowest first), ``bases`` (n, 4, 4) their channel matrices before the turn,
    ``moved`` (F, n, 4, 4) after it, ``chest_offset`` (4, 4) and ``chest_basis`` (F, 4, 4)
    the chest's. With O = Π offset_j·basis_j and N = Π offset_j·moved_j (lowest first), the
    chest keeps ``O·chest_offset·chest_basis`` if its channel is
    (N·chest_offset)⁻¹·O·chest_offset·chest_basis; whatever carries the lowest bone
    multiplies both sides and cancels."""
    old = np.eye(4)
    for off, b in zip(offsets, bases):
        old = old @ off @ b
    old = old @ chest_offset
    out = np.empty_like(chest_basis)
    for f in range(len(chest_basis)):
        new = np.eye(4)
        for off, b in zip(offsets, moved[f]):
            new = new @ off @ b
        new = new @ chest_offset
        out[f] = np.linalg.inv(new) @ old @ chest_basis[f]
    return out


def _offset(bone) -> np.ndarray:
    if bone.parent is None:
        return np.array(bone.matrix_local)
    return np.linalg.inv(np.array(bone.parent.matrix_local)) @ np.array(bone.matrix_local)


def _solve(armature, share: SpineShare, chest: str, bases, rots, chest_basis,
           lower=None) -> tuple:
    """(the chest's turns (F,) since ``rots[0]``, its channel matrices (F, 4, 4) that keep
    its pose, the shared bones' channel matrices (F, n, 4, 4)) for the chest's rotations
    ``rots`` (F, 3, 3) and channel matrices ``chest_basis`` (F, 4, 4), the shared bones'
    channel matrices ``bases`` (n, 4, 4) before their turn. ``lower``: (the pelvis's turns
    (F,), its channel matrices before (4, 4) and turned (F, 4, 4)): the spine shares what
    is left of the chest's turn. The lines the bones turn about are read from the pose
    now: the chest's head keeps its place in each shared bone's axes, whatever they
    turned."""
    pose, bones = armature.pose.bones, armature.data.bones
    thetas, axis_c = turn_angles(rots)
    rest = thetas if lower is None else thetas - lower[0]
    mc = np.array(pose[chest].matrix)
    up = mc[:3, :3] @ axis_c          # the chest's turn axis in the armature
    head_c = mc[:3, 3]
    moved = np.repeat(np.asarray(bases, dtype=float).reshape(-1, 4, 4)[None], len(rots), 0)
    for j, (name, w) in enumerate(zip(share.bones, share.weights)):
        m = np.array(pose[name].matrix)
        line = head_c - m[:3, 3]
        local = np.linalg.solve(m[:3, :3], line)
        local /= np.linalg.norm(local)
        sign = 1.0 if line @ up >= 0.0 else -1.0
        for f, t in enumerate(rest):
            moved[f, j, :3, :3] = moved[f, j, :3, :3] @ axis_rotation(
                local, math.degrees(sign * w * t))
    names = list(share.bones)
    old = np.asarray(bases, dtype=float).reshape(-1, 4, 4)
    if lower is not None:
        names = [share.pelvis.bone] + names
        old = np.concatenate([lower[1][None], old])
        moved = np.concatenate([lower[2][:, None], moved], axis=1)
    offsets = np.array([_offset(bones[n]) for n in names])
    new_chest = chest_bases(offsets, old, moved, _offset(bones[chest]), chest_basis)
    return thetas, new_chest, moved[:, -len(share.bones):] if share.bones else moved[:, :0]


def _pelvis(context, armature, share: SpineShare, chest: str, rots) -> tuple:
    """(``lower`` for :func:`_solve` or None, the legs' channel matrices {bone: (F, 4, 4)}
    or {}, why the pelvis stays or None): the pelvis turned by what the chest's turn goes
    past the trunk's range (:mod:`.pelvis_turn`)."""
    thetas, axis_c = turn_angles(rots)
    phi = pelvis_turn.excess(thetas, share.pelvis.limit)
    if np.abs(phi).max(initial=0.0) < 1e-9:
        return None, {}, None
    mw = np.array(armature.matrix_world)
    up = mw[:3, :3] @ np.array(armature.pose.bones[chest].matrix)[:3, :3] @ axis_c   # world
    sign = 1.0 if pelvis_turn.turn_axis(armature, share.pelvis, chest)[1] @ up >= 0.0 else -1.0
    try:
        posed, why, phi = pelvis_turn.pose_frames(context, armature, share.pelvis, chest, phi,
                                                  sign)
    except ValueError as exc:        # a leg that cannot be solved (LegOverstretchedError too)
        return None, {}, f"its legs cannot follow ({exc})"
    if posed is None:
        return None, {}, why
    if np.abs(phi).max(initial=0.0) < 1e-9:
        return None, {}, "a leg standing straight would bring the hips down"
    before = np.array(armature.pose.bones[share.pelvis.bone].matrix_basis)
    lower = (phi, before, posed.pop(share.pelvis.bone))
    return lower, posed, None


def _shared(context, armature, share: SpineShare, chest: str, rots, chest_basis,
            checker) -> tuple:
    """(the chest's turns (F,), its channel matrices (F, 4, 4), the bases to key {bone:
    (F, 4, 4)} below it, the pelvis's turns (F,) or None, the report's note or None): the
    share with the pelvis where it turns, checked against the obstacles
    (:func:`.pelvis_turn.below_chest_hit`); without the pelvis where that touches; with
    nothing shared where even the spine's share touches or ``checker`` is None (obstacles
    that move)."""
    pose = armature.pose.bones
    if checker is None:
        return turn_angles(rots)[0], chest_basis, {}, None, (
            "the chest turns alone: the obstacles move during the reach")
    lower, legs, why = (None, {}, None) if share.pelvis is None else _pelvis(
        context, armature, share, chest, rots)
    bases = np.array([np.array(pose[n].matrix_basis) for n in share.bones])
    while True:
        thetas, new_chest, moved = _solve(armature, share, chest, bases, rots, chest_basis,
                                          lower)
        keyed = {n: moved[:, j] for j, n in enumerate(share.bones)}
        if lower is not None:
            keyed = {share.pelvis.bone: lower[2], **legs, **keyed}
        if not keyed:
            break
        lowest = share.pelvis.bone if lower is not None else share.bones[0]
        hit = pelvis_turn.below_chest_hit(context, armature, chest, lowest, keyed,
                                          share.pelvis.legs if lower is not None else (),
                                          checker, share.pelvis.ground if lower is not None else None)
        if hit is None:
            break
        if lower is None:
            return thetas, chest_basis, {}, None, (
                f"the chest turns alone: spreading its turn down the spine would bring the "
                f"{hit[0]} against '{hit[1]}'")
        lower, legs = None, {}
        why = f"turning the pelvis would bring the {hit[0]} against '{hit[1]}'"
    note = f"the pelvis stays: {why}" if why else share.note
    return thetas, new_chest, keyed, None if lower is None else lower[0], note


def pose_now(armature, share: SpineShare, start: dict, chest: str, chest_basis) -> np.ndarray:
    """Live's share of one pose: the shared bones posed (their ``matrix_basis``) for the
    chest's channel matrix ``chest_basis`` (4, 4), turned from ``start`` (bone → channel
    matrix at the session's start, the chest's among them). Returns the chest's channel
    matrix that keeps its pose."""
    def unit(m):
        return m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)

    rots = np.stack([unit(start[chest]), unit(chest_basis)])
    bases = np.array([start[n] for n in share.bones])
    _t, new_chest, moved = _solve(armature, share, chest, bases, rots,
                                  np.stack([start[chest], chest_basis]))
    for j, name in enumerate(share.bones):
        armature.pose.bones[name].matrix_basis = Matrix(moved[-1, j].tolist())
    return new_chest[-1]


def _key(context, armature, share: SpineShare, chest: str, first: int, last: int,
         checker) -> tuple:
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
    thetas, new_chest, keyed_bases, phi, note = _shared(context, armature, share, chest, rots,
                                                        basis_c, checker)
    figures = {} if note is None else {"spine_note": note}
    keyed = []
    for name, mats in keyed_bases.items():
        keyed += _write(channels, pose[name], mats, frames,
                        location=share.pelvis is not None and name == share.pelvis.bone)
    p, v = channel_values(pc, new_chest)
    write_channel(channels, full, v, frames, chest)
    # the chest's keys are solved against the bones below it: a bake again clears them
    # with those (own_keys.clear_overlapping), not leaving them turned for a spine that is gone
    own_keys.record(channels.action, list(keyed_bases) + ([chest] if keyed_bases else []),
                    first, last)
    context.view_layer.update()
    if phi is not None:
        figures["spine_pelvis_bone"] = share.pelvis.bone
        figures["spine_pelvis_deg"] = round(math.degrees(float(np.abs(phi).max())), 1)
    if share.bones and keyed_bases:
        rest = thetas if phi is None else thetas - phi
        carried = float(np.abs(rest).max(initial=0.0)) * sum(share.weights)
        figures["spine_bones"] = ", ".join(share.bones)
        figures["spine_turn_deg"] = round(math.degrees(carried), 1)
    return figures, keyed


def _write(channels, pb, mats, frames, location: bool = False) -> list:
    """Key ``pb``'s rotation (and ``location``) from its channel matrices ``mats`` on
    ``frames``; returns the keyed rotation channels as (data path, index) pairs (the ones
    :func:`.straighten.straighten` reads)."""
    p, v = channel_values(pb, mats)
    path = f'pose.bones["{pb.name}"].{p}'
    write_channel(channels, path, v, frames, pb.name)
    if location:
        write_channel(channels, f'pose.bones["{pb.name}"].location',
                      np.array([m[:3, 3] for m in mats]), frames, pb.name)
    return [(path, i) for i in range(v.shape[1])]


def for_rig(armature, info, settings, leaning: bool, with_pelvis: bool = True) -> SpineShare:
    """:func:`share_of` with the rig's legs found as the lean finds them; nothing shared
    where the body is ``leaning`` or stepping (see the module docstring); ``with_pelvis``:
    the pelvis turns too where it can."""
    if leaning and settings.spine_share > 0.0:
        return SpineShare(note="the body leans or steps: its checks hold the trunk below "
                          "the chest as one piece, and the chest turns alone")
    if settings.spine_share <= 0.0:        # nothing shared, the pelvis neither
        return SpineShare()
    return share_of(armature, info, settings, balance.find_legs(armature, info.bones,
                                                                info.frame), with_pelvis)
