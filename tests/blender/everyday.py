"""Everyday scenes built round any rig: in its own body frame, sized by its own arm.

Each builder takes the rig as Reach reads it (``RigInfo``: the reaching shoulder, the body's
forward, outward and up axes, the arm's length) and adds obstacles (boxes) and targets
(empties) to the current scene. Positions are (forward, outward, up) from the reaching
shoulder in arm lengths, so a scene means the same on a 20 cm figure and a 5 m giant,
facing any way. :data:`SCENES` names them; :func:`build` makes one.

- ``wall``: a wall in front of the body, its top 0.35 arm lengths below the shoulder and its
  near face 0.04 arm lengths beyond the farthest point of the hand's skin (or 0.62 arm
  lengths, if that is farther), and a target just beyond its top.
"""

from __future__ import annotations

import bpy
import numpy as np
import rigs

SCENES = ("wall",)


def body_axes(info):
    """The reaching shoulder (world), the body's forward, outward (the reaching arm's side)
    and up, and the arm's length."""
    f = info.frame
    out = f.right if info.side == "right" else -f.right
    return info.joints_world["shoulder"], f.forward, out, f.up, info.arm.arm_length


def at(info, forward, outward, up):
    """The world point (forward, outward, up) arm lengths from the reaching shoulder."""
    s, fwd, out, u, length = body_axes(info)
    return s + length * (forward * fwd + outward * out + up * u)


def box(info, name, lo, hi):
    """A box between the corners ``lo`` and ``hi``, each (forward, outward, up) in arm
    lengths from the shoulder, its edges along the body's axes."""
    _s, fwd, out, up, length = body_axes(info)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    centre = at(info, *(0.5 * (lo + hi)))
    return rigs.add_box(name, centre, length * np.abs(hi - lo), np.column_stack([fwd, out, up]))


def skin_front(armature, info) -> float:
    """How far in front of the shoulder (arm lengths) the skin of the reaching hand reaches
    at the current frame: the farthest vertex weighted to the hand's bones, or the hand's
    far end where the hand has no skin."""
    s, fwd, _out, _up, length = body_axes(info)
    hands = set(info.hand_bones) | {c.name for h in info.hand_bones
                                    for c in armature.pose.bones[h].children_recursive}
    dg = bpy.context.evaluated_depsgraph_get()
    far = None
    for ob in bpy.context.scene.objects:
        if ob.type != "MESH":
            continue
        if ob.parent == armature and ob.parent_type == "BONE" and ob.parent_bone in hands:
            ev = ob.evaluated_get(dg)
            pts = [ev.matrix_world @ v.co for v in ev.data.vertices]
        elif any(m.type == "ARMATURE" and m.object == armature for m in ob.modifiers):
            groups = {vg.index for vg in ob.vertex_groups if vg.name in hands}
            ev = ob.evaluated_get(dg)
            if not groups or len(ev.data.vertices) != len(ob.data.vertices):
                continue
            pts = [ev.matrix_world @ ve.co for v, ve in zip(ob.data.vertices, ev.data.vertices)
                   if any(g.group in groups and g.weight >= 0.3 for g in v.groups)]
        else:
            continue
        for p in pts:
            ahead = float((np.array(p) - s) @ fwd) / length
            far = ahead if far is None else max(far, ahead)
    if far is None:
        mw = np.array(armature.matrix_world)
        tips = [mw[:3, :3] @ np.array(armature.pose.bones[h].tail) + mw[:3, 3]
                for h in info.hand_bones]
        far = max(float((t - s) @ fwd) / length for t in tips)
    return far


def build(name, info, armature):
    """Add scene ``name`` (:data:`SCENES`) round the rig; returns its target(s), in order."""
    if name == "wall":
        near = max(0.62, skin_front(armature, info) + 0.04)
        box(info, "Wall", (near, -0.9, -1.6), (near + 0.04, 0.9, -0.35))
        return [rigs.add_target("Target", at(info, near + 0.18, 0.10, -0.15))]
    raise ValueError(f"unknown scene {name!r}")
