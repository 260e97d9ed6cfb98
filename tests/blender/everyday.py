"""Everyday scenes built round any rig: in its own body frame, sized by its own arm.

Each builder takes the rig as Reach reads it (``RigInfo``: the reaching shoulder, the body's
forward, outward and up axes, the arm's length) and adds obstacles (boxes) and targets
(empties) to the current scene. Positions are (forward, outward, up) from the reaching
shoulder in arm lengths, so a scene means the same on a 20 cm figure and a 5 m giant,
facing any way. :data:`SCENES` names them; :func:`build` makes one.

Where a scene has something in front of the body, its near face is 0.04 arm lengths beyond
the farthest point of the hand's skin and of the arm's capsules as the planner models them
at the start (:func:`near`; a capsule can be fuller than the skin: GoMakeHuman's hanging
hand's reached 0.01 into a wall placed by the skin alone), over what lies within the
thing's cross-section and 0.04 round it (a T-posed hand at shoulder height does not push
the wall, whose top is 0.35 below the shoulder, out of the arm's reach) — or a least
distance given by the scene, if that is farther. So no rest pose, T, A or hanging, starts
inside the margin, and a hand that hangs far forward beside a shelf does not push the
shelf away.

- ``wall``: a wall in front of the body, its top 0.35 arm lengths below the shoulder and its
  near face at :func:`near` (at least 0.62 arm lengths), and a target just beyond its top.
- ``shelf``: a shelf compartment open toward the body (bottom, top, back and two side
  boards 0.04 thick), its opening centred 0.1 outward and 0.15 below the shoulder, its near
  face at :func:`near` (at least 0.5), and a target in the middle of the opening 0.22 in
  from it. The opening is sized to the arm as the rig adapter reads it
  (:func:`shelf_opening`): its half-height and half-width are at least 2.5 and 3 times the
  thickest of the forearm's and the hand's radii (0.25 and 0.35 arm lengths at least), and
  the back board stands the hand's length and radius plus 0.08 beyond the target, so a
  hand pointing straight in fits.
- ``sequence``: three targets in turn (task ``"sequence"``) — in front at chest height
  (0.65, 0.1, -0.15), to the side (0.2, 0.75, -0.1) and low in front over a table (0.6,
  0.25, 0.25 above its top) — with the table (top 0.75 below the shoulder, near edge at
  :func:`near`, at least 0.5) and a small crate on it (0.25 × 0.2 × 0.2, from 0.05 beyond
  the table's near edge) 0.35 inward of the low target.
- ``chase``: a target moving with linear keys across the front, from (0.6, 0.45, -0.1) at
  frame 1 to (0.6, -0.2, -0.1) at :data:`CHASE_FRAMES` (task ``"chase"``), over a table
  (top 0.6 below the shoulder, near edge at :func:`near`, at least 0.45).
"""

from __future__ import annotations

import bpy
import clearance
import numpy as np
import rigs

SCENES = ("wall", "shelf", "sequence", "chase")
#: The Blender task each scene is planned as.
TASKS = {"wall": "reach", "shelf": "reach", "sequence": "sequence", "chase": "chase"}
#: The chase's last frame (its target moves from frame 1 to this one: 48 frames).
CHASE_FRAMES = 49


def gravity_up() -> np.ndarray:
    """Up as the scene's gravity has it (Blender's default: −Z down): balance and the
    ground are measured along it, whichever way a figure's spine leans."""
    g = -np.asarray(bpy.context.scene.gravity, dtype=float)
    return g / np.linalg.norm(g)


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


def skin_front(armature, info, within=None) -> float:
    """How far in front of the shoulder (arm lengths) the skin of the reaching hand reaches
    at the current frame: the farthest vertex weighted to the hand's bones, or the hand's
    far end where the hand has no skin. ``within``: (outward, up) bounds (lo, hi), arm
    lengths, of the cross-section of something in front of the body: only the points
    whose outward and up lie within them count (-inf if none does)."""
    s, fwd, out, up, length = body_axes(info)
    hands = set(info.hand_bones) | {c.name for h in info.hand_bones
                                    for c in armature.pose.bones[h].children_recursive}
    dg = bpy.context.evaluated_depsgraph_get()
    pts = []
    for ob in bpy.context.scene.objects:
        if ob.type != "MESH":
            continue
        if ob.parent == armature and ob.parent_type == "BONE" and ob.parent_bone in hands:
            ev = ob.evaluated_get(dg)
            pts += [ev.matrix_world @ v.co for v in ev.data.vertices]
        elif any(m.type == "ARMATURE" and m.object == armature for m in ob.modifiers):
            groups = {vg.index for vg in ob.vertex_groups if vg.name in hands}
            ev = ob.evaluated_get(dg)
            if not groups or len(ev.data.vertices) != len(ob.data.vertices):
                continue
            pts += [ev.matrix_world @ ve.co for v, ve in zip(ob.data.vertices, ev.data.vertices)
                    if any(g.group in groups and g.weight >= 0.3 for g in v.groups)]
    if not pts:
        mw = np.array(armature.matrix_world)
        pts = [mw[:3, :3] @ np.array(armature.pose.bones[h].tail) + mw[:3, 3]
               for h in info.hand_bones]
    rel = (np.array([tuple(p) for p in pts], float) - s) / length
    keep = np.ones(len(rel), bool)
    if within is not None:
        (o_lo, o_hi), (u_lo, u_hi) = within
        o, u = rel @ out, rel @ up
        keep = (o >= o_lo) & (o <= o_hi) & (u >= u_lo) & (u <= u_hi)
    return float((rel[keep] @ fwd).max()) if keep.any() else -np.inf


def capsules_front(armature, info, within=None) -> float:
    """How far in front of the shoulder (arm lengths) the arm's capsules as the planner
    models them (``clearance.Arm``: upper arm, forearm, hand, each with its radius) reach
    at the current frame; ``within`` as for :func:`skin_front`, a capsule's point counting
    where its round section reaches into the bounds (-inf if none does)."""
    s, fwd, out, up, length = body_axes(info)
    far = -np.inf
    for _part, p, q, r in clearance.Arm(armature, info, clearance=0.0).capsules():
        for k in np.linspace(0.0, 1.0, 21):
            x = (p + k * (q - p) - s) / length
            r_ = r / length
            if within is not None:
                (o_lo, o_hi), (u_lo, u_hi) = within
                if not (o_lo - r_ <= x @ out <= o_hi + r_ and u_lo - r_ <= x @ up <= u_hi + r_):
                    continue
            far = max(far, float(x @ fwd) + r_)
    return far


def near(armature, info, least, within=None) -> float:
    """The near face of what stands in front of the body (arm lengths ahead of the
    shoulder): 0.04 beyond the hand's skin and beyond the arm's capsules as the planner
    models them (:func:`capsules_front`: a capsule can be fuller than the skin), at the
    current frame (within ``within``, the thing's (outward, up) cross-section, 0.04 added
    round it, if given), or ``least`` if farther."""
    if within is not None:
        within = tuple((lo - 0.04, hi + 0.04) for lo, hi in within)
    return max(least, skin_front(armature, info, within) + 0.04,
               capsules_front(armature, info, within) + 0.04)


def shelf_opening(info) -> tuple:
    """(half-height, half-width, depth behind the target) of the shelf's opening, arm
    lengths: comfortably more than the forearm and hand as the rig adapter reads them —
    2.5 and 3 times the thicker of their radii across (at least 0.25 and 0.35), and the
    hand's length and radius plus 0.08 behind the target."""
    a = info.arm
    length = a.arm_length
    thick = max(a.forearm_radius, a.hand_radius) / length
    return (max(0.25, 2.5 * thick), max(0.35, 3.0 * thick),
            (a.hand_length + a.hand_radius) / length + 0.08)


def animate_linear(ob, frames_points):
    """Key ``ob``'s location at each (frame, world point), linear between keys."""
    for frame, p in frames_points:
        ob.location = tuple(p)
        ob.keyframe_insert("location", frame=frame)
    for fc in rigs.fcurves(ob.animation_data.action):
        for k in fc.keyframe_points:
            k.interpolation = "LINEAR"


def build(name, info, armature):
    """Add scene ``name`` (:data:`SCENES`) round the rig at the current frame; returns its
    target(s), in order (several for a sequence). A chase sets the scene's end frame to
    :data:`CHASE_FRAMES` and goes back to frame 1."""
    if name == "wall":
        f0 = near(armature, info, 0.62, ((-0.9, 0.9), (-1.6, -0.35)))
        box(info, "Wall", (f0, -0.9, -1.6), (f0 + 0.04, 0.9, -0.35))
        return [rigs.add_target("Target", at(info, f0 + 0.18, 0.10, -0.15))]
    if name == "shelf":
        h, w, behind = shelf_opening(info)
        t, o, u = 0.04, 0.1, -0.15                  # the opening's centre
        f0 = near(armature, info, 0.5, ((o - w - t, o + w + t), (u - h - t, u + h + t)))
        tf = f0 + 0.22                              # the target, in the middle of the opening
        f1 = tf + behind                            # the back board's front
        box(info, "Shelf bottom", (f0, o - w - t, u - h - t), (f1, o + w + t, u - h))
        box(info, "Shelf top", (f0, o - w - t, u + h), (f1, o + w + t, u + h + t))
        box(info, "Shelf back", (f1, o - w - t, u - h - t), (f1 + t, o + w + t, u + h + t))
        box(info, "Shelf inner side", (f0, o - w - t, u - h), (f1, o - w, u + h))
        box(info, "Shelf outer side", (f0, o + w, u - h), (f1, o + w + t, u + h))
        return [rigs.add_target("Target", at(info, tf, o, u))]
    if name == "sequence":
        top = -0.75
        f0 = near(armature, info, 0.5, ((-0.5, 0.8), (top - 0.05, top + 0.2)))
        box(info, "Table", (f0, -0.5, top - 0.05), (f0 + 0.8, 0.8, top))
        box(info, "Crate", (f0 + 0.05, -0.3, top), (f0 + 0.3, -0.1, top + 0.2))
        return [rigs.add_target("Front", at(info, 0.65, 0.1, -0.15)),
                rigs.add_target("Side", at(info, 0.2, 0.75, -0.1)),
                rigs.add_target("Low", at(info, 0.6, 0.25, top + 0.25))]
    if name == "chase":
        top = -0.6
        f0 = near(armature, info, 0.45, ((-0.6, 0.8), (top - 0.05, top)))
        box(info, "Table", (f0, -0.6, top - 0.05), (f0 + 0.8, 0.8, top))
        target = rigs.add_target("Target", at(info, 0.6, 0.45, -0.1))
        animate_linear(target, ((1, at(info, 0.6, 0.45, -0.1)),
                                (CHASE_FRAMES, at(info, 0.6, -0.2, -0.1))))
        bpy.context.scene.frame_end = CHASE_FRAMES
        bpy.context.scene.frame_set(1)
        return [target]
    raise ValueError(f"unknown scene {name!r}")
