"""Targets the character carries: a target parented or constrained to one of the rig's own
bones moves with it, so the arm that carries it cannot reach it and a chest that carries it
must keep still (:func:`carried_targets`, read by the pipeline when it reads the rig)."""

from __future__ import annotations

from ..core import ReachError
from . import rig as rig_mod


def carrying_bone(ob, armature, seen=None):
    """The bone of ``armature`` that carries ``ob``: the bone it (or a parent of it, at any
    depth, or the target of one of their constraints) is parented to or constrained to;
    None if no bone of ``armature`` moves it."""
    seen = set() if seen is None else seen
    while ob is not None and ob.name not in seen:
        seen.add(ob.name)
        for c in getattr(ob, "constraints", ()):
            other = getattr(c, "target", None)
            if c.mute or c.influence <= 0.0 or other is None:
                continue
            if other == armature:
                if getattr(c, "subtarget", ""):
                    return c.subtarget
            else:
                bone = carrying_bone(other, armature, seen)
                if bone is not None:
                    return bone
        if ob.parent == armature:
            return ob.parent_bone if ob.parent_type == "BONE" and ob.parent_bone else None
        ob = ob.parent
    return None


def under(armature, bone_name, names) -> bool:
    """Is bone ``bone_name`` one of ``names`` or below one of them?"""
    bone = armature.data.bones.get(bone_name)
    while bone is not None:
        if bone.name in names:
            return True
        bone = bone.parent
    return False


def carried_targets(armature, targets, info, request, first):
    """The rig and settings for ``targets`` carried by the character's own bones: one on
    a bone of the reaching arm (upper arm, forearm, hand or below) would move with the
    hand, so that arm is refused (ReachError; with ``auto``, the other arm's rig is taken
    if it carries none); one on a bone the chest carries (the neck, the head, the other
    arm) would move as the chest turns, so chest rotation is turned off. ``info``: the
    rig read for the request; ``first``: the first target's world position. Returns
    (info, settings, note): the note for the results when the chest is kept still, else
    None."""
    settings = request.settings
    carried = [(t, b) for t in targets if (b := carrying_bone(t, armature)) is not None]
    if not carried:
        return info, settings, None

    def on_arm(rig):
        a = rig.bones.arms[rig.side]
        names = {a.upper_arm, a.forearm, a.hand} | {a.keyed(r) for r in ("upper_arm", "forearm",
                                                                          "hand")}
        return [(t, b) for t, b in carried if under(armature, b, names)]

    if on_arm(info) and request.side == "auto":
        other = rig_mod.build(armature, "left" if info.side == "right" else "right",
                              request.overrides, target=first)
        if not on_arm(other):
            info = other
    held = on_arm(info)
    if held:
        t, b = held[0]
        raise ReachError(f"target '{t.name}' is carried by bone '{b}' of the {info.side} arm, "
                         "which the reach moves, so the hand could never arrive on it; parent "
                         "it to something that stays still, or reach with the other arm")
    a = info.bones.arms[info.side]
    chest = {info.bones.chest, info.bones.keyed_chest, a.clavicle, a.keyed("clavicle")} - {None}
    on_chest = [(t, b) for t, b in carried if under(armature, b, chest)]
    if settings.chest_rotation and on_chest:
        t, b = on_chest[0]
        return info, settings.replace(chest_rotation=False), (
            f"the chest was kept still: target '{t.name}' is carried by bone '{b}', which "
            "turns with the chest, so turning the chest would move it; parent the target to "
            "something that stays still to let the chest turn")
    return info, settings, None
