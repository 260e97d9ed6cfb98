"""Sample geometry without Blender: furniture as triangle meshes and a standard adult figure.

Used by the core example (``python -m reach_addon demo --core``), the benchmark and the
tests. Pure numpy (no bpy); building :class:`~reach_addon.core.Obstacles` needs mathutils.

The standard figure stands at the world origin facing -Y, its right side toward -X, chest
at 1.40 m (as Blender characters usually stand). Its proportions are a 1.75 m adult's by
Drillis & Contini (upper arm 0.186 H, forearm 0.146 H, hand 0.108 H).
"""

from __future__ import annotations

import numpy as np

from .core import ArmConfig, ArmModel, Capsule, Obstacles

# Box corner k: bit i of k picks hi (1) or lo (0) on axis i. Faces wound outward.
_QUADS = ((0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5))

#: Chest height of the standard figure (m).
CHEST_Z = 1.40

#: The standard figure's arm hanging beside the body, elbow a little bent.
HANGING = ArmConfig(0.0, 10.0, 5.0, 0.0, 20.0)


def box(lo, hi):
    """Vertices (8, 3) and outward-facing triangles (12, 3) of an axis-aligned box."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    verts = np.array([[hi[i] if (k >> i) & 1 else lo[i] for i in range(3)] for k in range(8)])
    tris = []
    for a, b, c, d in _QUADS:
        tris += [(a, b, c), (a, c, d)]
    return verts, np.array(tris)


def table(center_xy, size_xy, height, top=0.04, leg=0.05):
    """A table as boxes (lo, hi): a top slab and four legs."""
    cx, cy = center_xy
    sx, sy = size_xy[0] / 2, size_xy[1] / 2
    parts = [((cx - sx, cy - sy, height - top), (cx + sx, cy + sy, height))]
    for dx in (-1, 1):
        for dy in (-1, 1):
            x, y = cx + dx * (sx - leg), cy + dy * (sy - leg)
            parts.append(((x - leg / 2, y - leg / 2, 0.0),
                          (x + leg / 2, y + leg / 2, height - top)))
    return parts


def shelf(center_xy, width, depth, heights, board=0.02, back_y_sign=-1):
    """A shelf as boxes: a back panel on the far side along y (``back_y_sign``) and boards
    whose top faces are at ``heights``."""
    cx, cy = center_xy
    top = max(heights) + 0.05
    back_y = cy + back_y_sign * depth / 2
    parts = [((cx - width / 2, min(back_y, back_y + back_y_sign * board), 0.0),
              (cx + width / 2, max(back_y, back_y + back_y_sign * board), top))]
    for h in heights:
        parts.append(((cx - width / 2, cy - depth / 2, h - board),
                      (cx + width / 2, cy + depth / 2, h)))
    return parts


def triangle_soup(named_parts):
    """(vertices, triangles, owner index per triangle, owner names) of {name: [boxes]}."""
    verts, tris, owners, names = [], [], [], []
    offset = 0
    for k, (name, parts) in enumerate(named_parts.items()):
        for lo, hi in parts:
            v, t = box(lo, hi)
            verts.append(v)
            tris.append(t + offset)
            owners += [k] * len(t)
            offset += len(v)
        names.append(name)
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), int), np.zeros(0, int), names
    return np.concatenate(verts), np.concatenate(tris), np.array(owners), names


def obstacles(named_parts) -> Obstacles:
    """Obstacles (one world-space BVH) from {name: [boxes]}."""
    verts, tris, owners, names = triangle_soup(named_parts)
    return Obstacles.from_triangles(verts, tris, owners, names)


def figure_transform(side="right", position=(0.0, 0.0, CHEST_Z)):
    """Canonical → world for the standard figure: x (toward the arm's side) is world -X for
    the right arm and +X for the left, forward is world -Y, up is +Z."""
    m = np.eye(4)
    m[:3, :3] = np.diag([-1.0 if side == "right" else 1.0, -1.0, 1.0])
    m[:3, 3] = position
    return m


def standard_arm(side="right", scale=1.0, position=(0.0, 0.0, CHEST_Z)) -> ArmModel:
    """The standard figure's arm, ``scale`` times as big, chest at ``position``."""
    k = scale
    caps = (
        Capsule("chest", (0, 0, -0.30 * k), (0, 0, 0.0), 0.13 * k, True),
        Capsule("pelvis", (0, 0, -0.65 * k), (0, 0, -0.30 * k), 0.14 * k, False),
        Capsule("head", (0, 0.02 * k, 0.15 * k), (0, 0.02 * k, 0.30 * k), 0.10 * k, True),
    )
    return ArmModel(
        sternum=np.array([0, 0.07, -0.02]) * k, shoulder=np.array([0.19, 0.0, 0.0]) * k,
        waist=np.array([0, 0, -0.45]) * k, upper_arm_length=0.325 * k,
        forearm_length=0.255 * k, hand_length=0.19 * k, upper_arm_radius=0.05 * k,
        forearm_radius=0.04 * k, hand_radius=0.035 * k,
        to_world=figure_transform(side, position), body_capsules=caps, side=side,
        name=f"{side} arm")


def _in_front(arm, parts):
    """World (vertices, triangles, owners, names) of {name: [boxes]} given in the arm's
    canonical frame relative to its shoulder, in arm lengths (x toward the arm's side, y
    forward, z up)."""
    length, shoulder = arm.arm_length, np.asarray(arm.shoulder, float)
    scaled = {name: [(shoulder + length * np.asarray(lo, float),
                      shoulder + length * np.asarray(hi, float)) for lo, hi in boxes]
              for name, boxes in parts.items()}
    verts, tris, owners, names = triangle_soup(scaled)
    return arm.to_world_points(verts), tris, owners, names


def plate_across_the_line(arm, start_config=HANGING):
    """A plate square across the straight line from the start wrist to a target in front
    of the shoulder, half way, sized by the arm: the straight path is blocked and the hand
    can go round the plate on any side. Returns (world vertices, triangles, world target)."""
    from .core.arm import pose_from_config

    length = arm.arm_length
    wrist = pose_from_config(arm, start_config).wrist
    target = arm.shoulder + length * np.array([0.15, 0.7, 0.05])     # canonical
    path = target - wrist
    span = np.linalg.norm(path)
    normal = path / span
    across = np.cross(normal, [0.0, 0.0, 1.0])
    across /= np.linalg.norm(across)
    rot = np.column_stack([across, np.cross(normal, across), normal])
    size = np.array([0.36 * span, 0.36 * span, 0.05 * length])
    verts, tris = box(-0.5 * size, 0.5 * size)
    world = arm.to_world_points(verts @ rot.T + wrist + 0.5 * path)
    return world, tris, arm.to_world_points(target)


#: Everyday reaches, in the arm's canonical frame relative to its shoulder, in arm lengths
#: (x toward the arm's side, y forward, z up): {name: ({obstacle: [boxes]}, target)}.
EVERYDAY = {
    # a port at the back of a monitor standing on a desk, reached round the monitor's side
    "behind a monitor": ({"Desk": [((-1.2, 0.25, -0.81), (1.2, 1.4, -0.75))],
                          "Monitor": [((-0.45, 0.45, -0.75), (0.25, 0.50, -0.30))]},
                         (0.35, 0.64, -0.55)),
    # into a drawer pulled out of a low cabinet: over its front wall and down inside
    "into a drawer": ({"Cabinet": [((-0.5, 0.75, -1.4), (0.7, 1.4, -0.55))],
                       "Drawer": [((-0.25, 0.30, -0.89), (0.45, 0.75, -0.86)),    # bottom
                                  ((-0.25, 0.30, -0.86), (0.45, 0.33, -0.62)),    # front
                                  ((-0.25, 0.33, -0.86), (-0.22, 0.75, -0.62)),   # sides
                                  ((0.42, 0.33, -0.86), (0.45, 0.75, -0.62)),
                                  ((-0.25, 0.72, -0.86), (0.45, 0.75, -0.62))]},  # back
                      (0.10, 0.50, -0.58)),
    # a cup on a shelf above a desk: up past the desk's front edge, under the shelf board
    "onto a shelf": ({"Desk": [((-1.2, 0.35, -0.81), (1.2, 1.4, -0.75))],
                      "Shelf": [((-0.8, 0.55, -0.02), (0.9, 1.4, 0.02)),
                                ((-0.8, 0.55, 0.30), (0.9, 1.4, 0.34))]},
                     (0.20, 0.72, 0.12)),
}


def everyday_scenes(arm, start_config=HANGING) -> dict:
    """The bench's everyday reaches around ``arm``, sized by its own arm and placed in its
    own body frame: {name: (world vertices, triangles, owners, owner names, world target)},
    the plate across the straight line (:func:`plate_across_the_line`) first, then
    :data:`EVERYDAY`."""
    verts, tris, target = plate_across_the_line(arm, start_config)
    out = {"past a plate": (verts, tris, np.zeros(len(tris), int), ["Plate"], target)}
    shoulder, length = np.asarray(arm.shoulder, float), arm.arm_length
    for name, (parts, target_c) in EVERYDAY.items():
        v, t, o, n = _in_front(arm, parts)
        out[name] = (v, t, o, n,
                     arm.to_world_points(shoulder + length * np.asarray(target_c, float)))
    return out
