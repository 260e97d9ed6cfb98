"""Which keys of the body's bones are Reach's own: the frames a bake keyed on a bone it
keys only for the whole body (the lean bone, the hips and legs, the neck), recorded on the
action, so that a bake again over them replaces them (:func:`clear_overlapping`: the
earlier motion's keys on those bones from where the new bake starts) while keys a user set
on those bones are kept, and refused (:func:`users_keys`). A key inside a span Reach keyed
counts as Reach's (a user's edit of a baked key included).

The record is a custom property of the action (:data:`PROPERTY`, JSON: bone → list of
[first, last] frame ranges): it is saved with the file, copied with the action (a bake into
a new action keeps it) and undone with the rest of the bake.
"""

from __future__ import annotations

import json

import numpy as np

from .fcurves import Channels

#: The action's custom property that holds the record.
PROPERTY = "reach_own_keys"


def _record(action) -> dict:
    try:
        return json.loads(action.get(PROPERTY, "{}"))
    except (TypeError, ValueError):
        return {}


def record(action, bones, first: int, last: int) -> None:
    """Note that Reach keyed ``bones`` on the frames ``first``..``last`` of ``action``."""
    data = _record(action)
    for bone in bones:
        spans = data.setdefault(bone, [])
        spans.append([int(first), int(last)])
        spans.sort()
        merged = [spans[0]]
        for a, b in spans[1:]:
            if a <= merged[-1][1] + 1:
                merged[-1][1] = max(merged[-1][1], b)
            else:
                merged.append([a, b])
        data[bone] = merged
    action[PROPERTY] = json.dumps(data, sort_keys=True)


def users_keys(armature, bone: str, channel: str = "rotation") -> bool:
    """Whether the armature's action keys ``bone``'s ``channel`` (``rotation``,
    ``location``) on a frame Reach did not key it on: a key a user set, which a bake for
    the whole body would overwrite."""
    ad = armature.animation_data
    action = ad.action if ad else None
    if action is None:
        return False
    spans = _record(action).get(bone, [])
    prefix = f'pose.bones["{bone}"].{channel}'
    for fc in Channels(armature, action).bag.fcurves:
        if not fc.data_path.startswith(prefix):
            continue
        pts = fc.keyframe_points
        co = np.empty(2 * len(pts), np.float32)
        pts.foreach_get("co", co)
        for frame in co[0::2]:
            if not any(a - 0.5 <= frame <= b + 0.5 for a, b in spans):
                return True
    return False


def overlapping(armature, lo: float, hi: float) -> dict:
    """{bone: [[first, last], ...]}: the spans Reach keyed on the armature's action that
    meet the frames ``lo``..``hi``."""
    ad = armature.animation_data
    action = ad.action if ad else None
    if action is None:
        return {}
    out = {}
    for bone, spans in _record(action).items():
        hit = [[a, b] for a, b in spans if a <= hi and b >= lo]
        if hit:
            out[bone] = hit
    return out


def clear_overlapping(armature, lo: float, hi: float) -> dict:
    """Delete the keys of the spans Reach keyed that meet ``lo``..``hi`` from ``lo`` on
    (every channel of those bones, after frame ``lo`` to each span's end, past ``hi`` too:
    an earlier lean's tail would hold the trunk in a lean the new bake does not plan, where
    other bones keep their keys after ``hi``) and forget those frames. The keys up to
    ``lo`` stay, as the keys of every other bone do
    (:func:`.fcurves.write_channel` replaces keys only on the frames it writes): a bake
    that starts part way through an earlier lean keeps that lean's frames before it, with
    which the earlier reach's arm keys were planned, and, where it does not key a bone of
    the earlier lean, holds it at frame ``lo`` as it was planned from (the key on ``lo``
    stays; the new bake overwrites it where it keys the bone). Returns the spans met
    (:func:`overlapping`)."""
    spans = overlapping(armature, lo, hi)
    if not spans:
        return spans
    action = armature.animation_data.action
    bag = Channels(armature, action).bag
    for fc in list(bag.fcurves):
        hit = next((h for bone, h in spans.items()
                    if fc.data_path.startswith(f'pose.bones["{bone}"]')), None)
        if hit is None:
            continue
        pts = fc.keyframe_points
        for i in range(len(pts) - 1, -1, -1):
            if any(max(a - 0.5, lo + 0.5) < pts[i].co[0] <= b + 0.5 for a, b in hit):
                pts.remove(pts[i], fast=True)
        if len(pts):
            fc.update()
        else:
            bag.fcurves.remove(fc)          # an empty curve would hold its channel at 0
    data = _record(action)
    for bone, hit in spans.items():
        kept = [s for s in data.get(bone, []) if s not in hit]
        kept += [[a, int(np.floor(lo))] for a, _b in hit if a <= lo]
        data[bone] = sorted(kept)
        if not data[bone]:
            del data[bone]
    action[PROPERTY] = json.dumps(data, sort_keys=True)
    return spans
