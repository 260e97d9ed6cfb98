"""The pelvis's share of the chest's turn, over planted feet (``Settings.trunk_turn_max``;
issue 41: *Table 1's rotation is shared over pelvis, spine and chest*).

Table 1 turns the chest up to 60° against the feet (``chest_rotation_max``); a trunk turns
on its pelvis about 33° (standing people turning to reach: trunk 32.6°, pelvis 63.8°,
Montgomery et al. 2011). Where the chest's turn goes past *Trunk turn*, the pelvis takes
the rest: the hips bone (the lowest bone that carries both legs and the chest) turns about
the vertical through the chest's head (:func:`turn_axis`), so the chest's head stays where
the planner has it, and each leg is solved again with its foot planted (:func:`.hips.pose_shift`: the
thigh and shank turned so the knee meets them, bent as it was, the foot given back its
place and tilt; the hips come down where a straight leg would otherwise have to stretch,
by a fraction of a millimetre). The spine and the chest share what is left
(:mod:`.spine_share`).

**Checked on every frame**, as the legs are posed for the keys: each ankle stays within
:data:`~.lean_balance.FEET_SLIDE` arm lengths of where it stood; and, with the spine's
share, the skin below the chest keeps the clearance from the obstacles
(:func:`below_chest_hit`, the feet held to a share of it). Where either fails, or the rig has no
legs, stands tilted, is leaning or stepping, has keys a user set on its hips or legs, or
a constraint on them, the pelvis stays and the report says why (``spine_note``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mathutils import Matrix

from ..core.gaze import axis_rotation
from ..core.lean import skin_hit
from . import balance, skin
from . import hips as hips_mod
from .lean_balance import FEET_SLIDE, lower_body_hit
from .own_keys import users_keys
from .rig_detect import ancestors, constrained


@dataclass(frozen=True)
class Pelvis:
    """The bone that turns the pelvis (``bone``), the ``legs`` (:class:`.balance.Leg`)
    solved under it, and the trunk's ``limit`` (radians) past which it turns."""

    bone: str
    legs: tuple
    limit: float
    ground: np.ndarray        # the ground's normal (world)
    forward: np.ndarray       # the body's forward (world): the knees bend toward it
    arm_length: float


def pelvis_of(armature, info, settings, legs) -> tuple:
    """(:class:`Pelvis`, None), or (None, why the pelvis does not turn) for ``info``'s
    chest on ``armature`` with its ``legs`` (:func:`.balance.find_legs`)."""
    if settings.trunk_turn_max >= settings.chest_rotation_max:
        return None, None
    if len(legs or ()) != 2:
        return None, "Reach finds no legs on this rig"
    why = balance.standing_why_not(armature, legs, info.frame.ground, "turn")
    if why is not None:
        return None, why
    bones = armature.data.bones
    chains = [[bones[leg.hip[0]]] + ancestors(bones[leg.hip[0]]) for leg in legs]
    chest = bones[info.bones.keyed_chest]
    common = [b for b in ancestors(chest) if all(b in c for c in chains)]
    if not common:
        return None, "no bone carries both legs and the chest"
    hips = common[0].name
    moved = [hips] + hips_mod.leg_bones(armature, list(legs))
    for name in moved:
        if constrained(armature.pose.bones[name]):
            return None, f"'{name}' has a constraint"
        if users_keys(armature, name) or (name == hips and users_keys(armature, name,
                                                                      "location")):
            return None, f"'{name}' has keys of your own"
    return Pelvis(hips, tuple(legs), math.radians(settings.trunk_turn_max),
                  np.asarray(info.frame.ground, dtype=float),
                  np.asarray(info.frame.forward, dtype=float), float(info.arm.arm_length)), None


def excess(thetas, limit: float) -> np.ndarray:
    """The pelvis's turns (radians) for the chest's ``thetas``: what goes past ``limit``
    either way."""
    thetas = np.asarray(thetas, dtype=float)
    return np.sign(thetas) * np.maximum(0.0, np.abs(thetas) - limit)


#: How far (arm lengths) the pelvis's turn may bring the hips down: a leg standing straight
#: asks for more length as its hip joint turns away from over the ankle, and the hips come
#: down by about the square of that move over twice the leg. The chest's head, and the arm
#: with it, comes down as much, which the planner did not see: the turn is held to where it
#: stays within this (a far reach that turned the Male Base Mesh's chest 60° brought its
#: wrist 0.006 arm lengths off the target at 27° of pelvis).
DROP = 5e-4


def pose_frames(context, armature, pelvis: Pelvis, chest: str, angles, sign: float) -> tuple:
    """(the channel matrices {bone: (F, 4, 4)} of the hips bone and the legs' bones with
    the pelvis turned by each of ``angles`` (radians; ``sign`` orients them as the chest's
    turn about :func:`turn_axis`) and the feet planted, the pose put back after, or None;
    None, or why it is None (a foot would slide); the turns taken, held to where the hips
    come down at most :data:`DROP` (:func:`.hips.turn_drop`)). Raises ValueError where a
    leg cannot be solved."""
    pose = armature.pose.bones
    pivot, axis = turn_axis(armature, pelvis, chest)
    up, forward = pelvis.ground, pelvis.forward
    angles = np.asarray(angles, dtype=float)
    cap = _cap(armature, pelvis, pivot, axis, sign, float(np.abs(angles).max(initial=0.0)))
    angles = np.clip(angles, -cap, cap)
    legs = list(pelvis.legs)
    names = [pelvis.bone] + hips_mod.leg_bones(armature, legs)
    ankles0 = np.array([balance.point_of(armature, leg.ankle) for leg in legs])
    out = {n: [] for n in names}
    slid = 0.0
    for angle in angles:
        with hips_mod.Posed(context, armature, names):
            if abs(angle) > 1e-12:
                turn = axis_rotation(axis, math.degrees(sign * float(angle)))
                hips_mod.pose_shift(context, armature, legs, pelvis.bone, np.zeros(3), up,
                                    forward, turn=(pivot, turn), as_it_stands=True)
            for n in names:
                out[n].append(np.array(pose[n].matrix_basis))
            ankles = np.array([balance.point_of(armature, leg.ankle) for leg in legs])
            slid = max(slid, float(np.linalg.norm(ankles - ankles0, axis=1).max()))
    if slid > FEET_SLIDE * pelvis.arm_length:
        return None, (f"turning the pelvis would slide a foot "
                      f"{slid / pelvis.arm_length:.3f} arm lengths"), angles
    return {n: np.array(v) for n, v in out.items()}, None, angles


def _cap(armature, pelvis: Pelvis, pivot, axis, sign: float, most: float) -> float:
    """The largest turn (radians, up to ``most``) whose drop of the hips stays within
    :data:`DROP` (bisection: the drop grows with the turn)."""
    limit = DROP * pelvis.arm_length

    def drop(angle):
        turn = axis_rotation(axis, math.degrees(sign * angle))
        return hips_mod.turn_drop(armature, list(pelvis.legs), pivot, turn, pelvis.ground)

    if most <= 0.0 or drop(most) <= limit:
        return most
    lo, hi = 0.0, most
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if drop(mid) <= limit else (lo, mid)
    return lo


def below_chest_hit(context, armature, chest: str, lowest: str, bases: dict, legs,
                    checker, ground) -> tuple | None:
    """(part, obstacle) where the skin of the bones ``lowest`` carries, but for the chest and
    what it carries, posed with their channel matrices ``bases`` {bone: (F, 4, 4)} frame
    by frame, comes within ``checker``'s clearance of an obstacle (:func:`.lean_balance.
    lower_body_hit`; ``legs`` tell the feet, held to a share of it), else None. The
    chest's pose is the plan's, whatever turns below it, so what this reads is all that
    the spine's and the pelvis's share move."""
    bones = armature.data.bones
    names = ({lowest} | {b.name for b in bones[lowest].children_recursive}) - (
        {chest} | {b.name for b in bones[chest].children_recursive})
    pose = armature.pose.bones
    count = len(next(iter(bases.values())))
    world, chosen = [], {}
    with hips_mod.Posed(context, armature, list(bases)):
        for f in range(count):
            for n, mats in bases.items():
                pose[n].matrix_basis = Matrix(mats[f].tolist())
            context.view_layer.update()
            world.append(skin.skin_points(armature, names, 0.5, True, chosen))
    if legs:
        return lower_body_hit(armature, list(legs), world, checker, ground)
    hit = skin_hit(np.array(world), checker) if len(world[0]) else None
    return None if hit is None else ("trunk", hit[1])


def turn_axis(armature, pelvis: Pelvis, chest: str) -> tuple:
    """(pivot, unit axis), world: the line the pelvis turns about. The vertical through the
    chest's head, where the hips bone may move (it is not connected to a parent): the hip
    joints then move level, and a straight leg needs the hips to come down by the square
    of that only (about the line to the chest's head, tilted 10° or so, the metarig's hips
    came down 2 mm for 4.4° of turn, the wrist with them). Else the line from the hips'
    head to the chest's head, which the bone can turn about in place. Either keeps the
    chest's head where it is."""
    mw = np.array(armature.matrix_world)
    pose = armature.pose.bones
    top = (mw @ np.append(np.array(pose[chest].head), 1.0))[:3]
    if not armature.data.bones[pelvis.bone].use_connect:
        return top, pelvis.ground / np.linalg.norm(pelvis.ground)
    head = (mw @ np.append(np.array(pose[pelvis.bone].head), 1.0))[:3]
    return top, (top - head) / np.linalg.norm(top - head)
