"""Test geometry: the sample furniture and figure, and an independent collision check.

The furniture (``reach_addon.samples``) is ordinary closed triangle meshes in world space,
metres; the planner sees them through a real ``mathutils`` BVHTree. The check below shares no
code with the planner: it samples each arm segment densely and measures exact
point-to-triangle distances with numpy.
"""

from __future__ import annotations

import math

import numpy as np

from reach_addon.samples import (CHEST_Z, HANGING, box, figure_transform, obstacles, shelf,
                                 standard_arm, table, triangle_soup)

__all__ = ["CHEST_Z", "HANGING", "box", "figure_transform", "obstacles", "shelf", "standard_arm",
           "table", "triangles_of", "arm_penetration", "segment_clearance",
           "point_triangle_distance", "point_triangle_pairs", "segment_triangle_distance",
           "segment_triangle_distances"]


def triangles_of(named_parts):
    """All triangles (T, 3, 3) of a scene of {name: [boxes]}, for the independent check."""
    verts, tris, _owners, _names = triangle_soup(named_parts)
    return verts[tris]


# --- independent checks ----------------------------------------------------------------

def point_triangle_distance(points, tris):
    """Exact distances (P, T) from points (P, 3) to triangles (T, 3, 3): the nearest point is
    inside the face (plane distance) or on one of its edges."""
    p = points[:, None, :]
    a, b, c = tris[None, :, 0], tris[None, :, 1], tris[None, :, 2]
    n = np.cross(b - a, c - a)
    n_len = np.linalg.norm(n, axis=-1, keepdims=True)
    n = n / np.where(n_len > 0, n_len, 1)
    dist_plane = np.einsum("ptk,ptk->pt", p - a, n)
    proj = p - dist_plane[..., None] * n

    def inside_edge(x, y):
        return np.einsum("ptk,ptk->pt", np.cross(y - x, proj - x), n) >= 0

    inside = inside_edge(a, b) & inside_edge(b, c) & inside_edge(c, a)

    def edge_distance(x, y):
        xy = y - x
        t = np.clip(np.einsum("ptk,ptk->pt", p - x, xy) / np.einsum("ptk,ptk->pt", xy, xy), 0, 1)
        return np.linalg.norm(p - (x + t[..., None] * xy), axis=-1)

    edges = np.minimum(np.minimum(edge_distance(a, b), edge_distance(b, c)), edge_distance(c, a))
    return np.where(inside, np.abs(dist_plane), edges)


def point_triangle_pairs(points, tris):
    """Exact distances (...) from points (..., 3) to triangles (..., 3, 3), pair by pair
    (broadcast): the nearest point is inside the face (plane distance) or on one of its
    edges. A triangle of no area (a sliver of an evaluated mesh) is measured by its
    edges."""
    p = np.asarray(points, dtype=float)
    tris = np.asarray(tris, dtype=float)
    a, b, c = tris[..., 0, :], tris[..., 1, :], tris[..., 2, :]
    n = np.cross(b - a, c - a)
    n_len = np.linalg.norm(n, axis=-1, keepdims=True)
    flat = n_len[..., 0] <= 1e-12 * np.maximum(np.abs(tris).max(axis=(-1, -2)), 1.0) ** 2
    n = n / np.where(n_len > 0, n_len, 1.0)
    dist_plane = np.sum((p - a) * n, axis=-1)
    proj = p - dist_plane[..., None] * n

    def inside_edge(x, y):
        return np.sum(np.cross(y - x, proj - x) * n, axis=-1) >= 0

    inside = inside_edge(a, b) & inside_edge(b, c) & inside_edge(c, a) & ~flat

    def edge_distance(x, y):
        xy = y - x
        t = np.clip(np.sum((p - x) * xy, axis=-1) / np.maximum(np.sum(xy * xy, axis=-1), 1e-300),
                    0.0, 1.0)
        return np.linalg.norm(p - (x + t[..., None] * xy), axis=-1)

    edges = np.minimum(np.minimum(edge_distance(a, b), edge_distance(b, c)), edge_distance(c, a))
    return np.where(inside, np.abs(dist_plane), edges)


def segment_triangle_distances(p, q, tris, horizon=np.inf):
    """Exact least distances (S,) from the segments p[i]-q[i] ((S, 3) each) to the
    triangles (T, 3, 3), each at most ``horizon`` (segment-triangle pairs whose bounding
    boxes are farther apart than that are not measured).

    Not by samples along the segment: the distance from a point to a triangle (a convex
    set) is a convex function of the point, so along a segment, s ↦ d(p + s (q - p)) is
    convex on [0, 1] and a golden-section search finds its minimum, for every pair at once,
    to 0.618⁴⁸ (below 10⁻⁹) of the segment's length."""
    p = np.asarray(p, dtype=float).reshape(-1, 3)
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    out = np.full(len(p), float(horizon))
    if len(tris) == 0 or len(p) == 0:
        return out
    mid, half = 0.5 * (p + q), 0.5 * np.linalg.norm(q - p, axis=1)
    gap = np.maximum(np.maximum(tris.min(axis=1)[None] - mid[:, None], mid[:, None]
                                - tris.max(axis=1)[None]), 0.0)                  # (S, T, 3)
    si, ti = np.nonzero(np.linalg.norm(gap, axis=2) <= (half + horizon)[:, None])
    if len(si) == 0:
        return out
    a, d, tri = p[si], (q - p)[si], tris[ti]

    def f(s):
        return point_triangle_pairs(a + s[:, None] * d, tri)

    golden = (math.sqrt(5.0) - 1.0) / 2.0
    lo, hi = np.zeros(len(si)), np.ones(len(si))
    s1, s2 = hi - golden * (hi - lo), lo + golden * (hi - lo)
    f1, f2 = f(s1), f(s2)
    for _ in range(48):
        left = f1 <= f2                       # the minimum is in [lo, s2]
        hi = np.where(left, s2, hi)
        lo = np.where(left, lo, s1)
        s_new = np.where(left, hi - golden * (hi - lo), lo + golden * (hi - lo))
        f_new = f(s_new)
        s1, s2, f1, f2 = (np.where(left, s_new, s2), np.where(left, s1, s_new),
                          np.where(left, f_new, f2), np.where(left, f1, f_new))
    best = np.minimum(np.minimum(f1, f2), np.minimum(f(np.zeros(len(si))), f(np.ones(len(si)))))
    np.minimum.at(out, si, best)
    return out


def segment_triangle_distance(p, q, tris, horizon=np.inf):
    """Exact least distance from the segment p-q to the triangles (T, 3, 3), or ``horizon``
    when none is nearer (:func:`segment_triangle_distances`)."""
    return float(segment_triangle_distances(p, q, tris, horizon)[0])


def segment_clearance(p, q, tris, spacing=0.002):
    """Least distance from the segment p-q to the triangles, to within ``spacing`` / 2."""
    n = max(2, int(np.ceil(np.linalg.norm(q - p) / spacing)) + 1)
    pts = p + np.linspace(0, 1, n)[:, None] * (q - p)
    return float(point_triangle_distance(pts, tris).min())


def arm_penetration(arm, world_joints, tris, include_hand=True):
    """For one pose, the worst (distance - radius) over the arm's segments; negative means a
    segment passes through an obstacle."""
    radii = [arm.upper_arm_radius, arm.upper_arm_radius, arm.forearm_radius, arm.hand_radius]
    worst = np.inf
    for k, r in enumerate(radii):
        if k == 3 and not include_hand:
            continue
        worst = min(worst, segment_clearance(world_joints[k], world_joints[k + 1], tris) - r)
    return worst


def segment_crosses(p, q, tris) -> bool:
    """Does the segment p-q pass through any of the triangles (T, 3, 3)? Möller–Trumbore."""
    p, q, tris = np.asarray(p, float), np.asarray(q, float), np.asarray(tris, float)
    d = q - p
    e1, e2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    h = np.cross(d, e2)
    a = np.einsum("ij,ij->i", e1, h)
    ok = np.abs(a) > 1e-12
    f = np.where(ok, 1.0 / np.where(ok, a, 1.0), 0.0)
    s = p - tris[:, 0]
    u = f * np.einsum("ij,ij->i", s, h)
    qv = np.cross(s, e1)
    v = f * (qv @ d)
    t = f * np.einsum("ij,ij->i", e2, qv)
    return bool((ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)).any())


def angle_deg(a, b):
    """Angle between two vectors, in degrees."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    return math.degrees(math.acos(float(np.clip(a @ b, -1.0, 1.0))))


def run_steps(steps):
    """(everything a step generator yielded, the value it returned)."""
    yielded = []
    while True:
        try:
            yielded.append(next(steps))
        except StopIteration as done:
            return yielded, done.value
