"""Keys in bulk on an armature's action, through whichever API the running Blender has:
``Action.fcurves`` (≤ 4.3) or slots, layers, strips and channelbags (4.4+), found by
capability, not by version number.

:func:`write_channel` replaces a channel's keys inside a frame range and keeps every other
key; new keys get the interpolation and handles of the user's preferences.
"""

from __future__ import annotations

import bpy
import numpy as np


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
        self.action = action
        self.armature = armature
        self.added = False           # a curve was made since the last :meth:`refresh`
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
            self.added = True
        if fc.group is None:
            fc.group = self.bag.groups.get(group) or self.bag.groups.new(group)
        return fc


    def refresh(self) -> None:
        """Have Blender evaluate the curves made since the last call. On an object with NLA
        tracks, Blender (4.2–5.0) goes on evaluating its action as it was when assigned: a
        curve added to it since is not evaluated (a glTF import's muted walk track and a key
        the user set first left every baked key unseen). Assigning the action again, its slot
        kept, makes it evaluate them."""
        ad = self.armature.animation_data
        if not self.added or ad is None or not len(ad.nla_tracks) or ad.use_tweak_mode:
            self.added = False
            return
        slot = getattr(ad, "action_slot", None)
        ad.action = None
        ad.action = self.action
        if slot is not None and ad.action_slot != slot:
            ad.action_slot = slot
        self.added = False


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
    channels.refresh()
