"""The other arm keeps its direction as the trunk leans (``Settings.lean_other_arm``): once
a lean is keyed, the arm that does not reach keeps the direction it had in the world on
the lean's first frame instead of riding on the trunk (which, in a deep bend with the
chest turned, swings it back along the trunk and up behind the back). A hanging arm goes
on hanging; a T-pose arm stays out to the side, as the user posed it.

**The turn.** On every frame from the lean's first, as Blender evaluates the keyed motion,
the other upper arm is turned about its head by the least rotation that takes its
direction back to the one it had on the lean's first frame (the forearm and hand carried,
the elbow as it was), by ``Settings.lean_other_arm`` of it; keyed on its rotation channels.

**Held to what the lean was held to.** The other arm's skin (the vertices its bones move),
carried by the turned upper arm, is checked against the obstacles on every frame as the
lean's trunk is (:func:`~..core.lean.skin_hit`); and the centre of mass's margin over the
feet, read on every frame as Blender evaluates it, may not fall below what it was with the
arm riding (nor below 0 where it was above). Where either fails, the turn is halved, then
left out; the report says which (``lean_other_arm``, ``other_arm_note``).

Not turned: a rig without a second arm, an other arm whose upper arm has keys a user set
(:func:`.own_keys.users_keys`) or that has an IK/FK switch (a Rigify arm in IK would not
follow its FK bone).
"""

from __future__ import annotations

import numpy as np

from ..core.gaze import axis_rotation
from ..core.lean import skin_hit
from . import balance, own_keys
from .bone_matrices import channel_values
from .fcurves import Channels, ensure_action, write_channel
from .own_keys import users_keys
from .skin import skin_points

#: The shares of ``Settings.lean_other_arm`` tried in turn where the arm would touch or tip.
SHARES = (1.0, 0.5)


def other_arm(armature, info) -> tuple:
    """(the other arm's upper arm bone, None), or (None, why it does not hang)."""
    sides = [s for s in info.bones.arms if s != info.side]
    if not sides:
        return None, "the rig has no other arm"
    side = sides[0]
    if side in info.bones.ik_fk:
        return None, f"the {side} arm has an IK/FK switch"
    bone = info.bones.arms[side].upper_arm
    if bone not in armature.pose.bones:
        return None, f"bone '{bone}' is missing"
    if users_keys(armature, bone):
        return None, f"bone '{bone}' has keys of its own"
    return bone, None


def key(context, armature, info, first: int, last: int, settings, checker) -> dict:
    """Key the other arm hanging over the frames ``first`` (the lean's first) to ``last``
    (see the module docstring). Returns the report's figures: ``lean_other_arm`` (the share
    keyed, 0 where none) and, where less than asked, ``other_arm_note``."""
    if settings.lean_other_arm <= 0.0:
        return {}
    bone, why = other_arm(armature, info)
    if bone is None:
        return {"lean_other_arm": 0.0, "other_arm_note": why}
    scene = context.scene
    now = (scene.frame_current, scene.frame_subframe)
    pb = armature.pose.bones[bone]
    legs = balance.find_legs(armature, info.bones, info.frame)
    mw = np.array(armature.matrix_world)
    try:
        riding = balance.margins_over(scene, armature, info, legs, first, last)[0] \
            if legs else None
        mats, bases = [], []
        for f in range(first, last + 1):
            scene.frame_set(f)
            mats.append(np.array(pb.matrix))
            bases.append(np.array(pb.matrix_basis))
        scene.frame_set(first)
        names = {bone} | {b.name for b in pb.children_recursive}
        pts = skin_points(armature, names, share=True)
        local = None if not len(pts) else pts @ np.linalg.inv(mw @ mats[0])[:3, :3].T \
            + np.linalg.inv(mw @ mats[0])[:3, 3]
        frames = np.arange(first, last + 1, dtype=float)
        full = [_hang(m, mats[0]) for m in mats]
        why = None
        for share in SHARES:
            share *= float(settings.lean_other_arm)
            turned = [_turned(m, r, share) for m, r in zip(mats, full)]
            if local is not None:
                world = np.array([(local @ (mw @ t)[:3, :3].T) + (mw @ t)[:3, 3] for t in turned])
                hit = skin_hit(world, checker)
                if hit is not None:
                    why = f"it would touch '{hit[1]}'"
                    continue
            new = [b @ np.linalg.inv(m) @ t for b, m, t in zip(bases, mats, turned)]
            _write(armature, bone, new, frames)
            tipped = _tips(scene, armature, info, legs, riding, first) if legs else None
            if tipped is None:
                own_keys.record(armature.animation_data.action, [bone], first, last)
                out = {"lean_other_arm": round(share, 3)}
                if share < settings.lean_other_arm:
                    out["other_arm_note"] = f"hung {share:.0%} of the way: fully {why}"
                return out
            why = tipped
            _write(armature, bone, bases, frames)          # back to riding
            # those keys (the arm riding) are Reach's: a bake again replaces them
            own_keys.record(armature.animation_data.action, [bone], first, last)
        return {"lean_other_arm": 0.0, "other_arm_note": why}
    finally:
        scene.frame_set(now[0], subframe=now[1])


def _hang(m, m0) -> tuple:
    """(axis, angle in degrees) of the least rotation (armature space) that takes the
    bone's direction in ``m`` (its armature-space matrix) back to its direction in ``m0``."""
    a, b = _unit(m[:3, 1]), _unit(m0[:3, 1])
    v = np.cross(a, b)
    s = float(np.linalg.norm(v))
    if s < 1e-12:
        return np.array([1.0, 0.0, 0.0]), 0.0
    return v / s, float(np.degrees(np.arctan2(s, float(a @ b))))


def _turned(m, hang, share) -> np.ndarray:
    """``m`` turned about its head by ``share`` of the rotation ``hang`` (:func:`_hang`)."""
    out = m.copy()
    out[:3, :3] = axis_rotation(hang[0], share * hang[1]) @ m[:3, :3]
    return out


def _write(armature, bone, bases, frames) -> None:
    pb = armature.pose.bones[bone]
    channels = Channels(armature, ensure_action(armature, False))
    path, values = channel_values(pb, np.array(bases))
    write_channel(channels, f'pose.bones["{bone}"].{path}', values, frames, bone)


def _tips(scene, armature, info, legs, riding, first) -> str | None:
    """Why the keyed turn tips the body (the centre of mass's margin on a frame below what
    it was riding, ``riding``, and below 0 where that was above), or None."""
    length = info.arm.arm_length
    now = balance.margins_over(scene, armature, info, legs, first, first + len(riding) - 1)[0]
    for k, (before, margin) in enumerate(zip(riding, now)):
        if margin < min(before, 0.0) - 1e-4 * length:
            return (f"it would carry the centre of mass {-margin / length:.3f} arm lengths past "
                    f"the feet on frame {first + k}")
    return None


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / max(float(np.linalg.norm(v)), 1e-12)
