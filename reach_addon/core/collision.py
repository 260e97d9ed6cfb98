"""Collisions: the arm's capsules against the world-space obstacle BVH, and geometry helpers.

Obstacles are **in world space**: one :class:`mathutils.bvhtree.BVHTree` built by the
caller (the Blender layer builds it from the evaluated depsgraph; tests build it from
triangles with :meth:`Obstacles.from_triangles`). Arm poses are turned into world space
before they are tested, so the tree is never rebuilt when the figure moves.

A capsule (segment swept by a radius ``r``, plus ``Settings.clearance``) is tested as a
row of spheres along its axis, ``n`` of them spaced at most ``r`` apart, each of radius
``R = √(r² + (spacing/2)²)``: the union of these spheres contains the capsule, so the test
never misses a contact (it may report one up to ~0.12 r early). Each sphere is one bounded
``find_nearest`` query (a few µs). Cheaper tests come first: one sphere around the whole
arm, then one around each segment.

A segment cannot lie wholly inside a closed obstacle without crossing its surface somewhere
along the chain, because the chain starts at the sternum, which is outside every obstacle
(checked once per plan); so surface proximity is enough.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import ReachError, require_finite
from .numeric import ARRAY, SCALAR

_AXES = ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0),
         (0.0, 0.0, 1.0), (0.0, 0.0, -1.0))


def segment_distance(p1, q1, p2, q2):
    """Shortest distance between segments p1-q1 and p2-q2, broadcasting over leading axes
    of (..., 3) arrays. See :func:`segment_distance_xyz`."""
    p1, q1, p2, q2 = (np.asarray(x, dtype=float) for x in (p1, q1, p2, q2))
    return segment_distance_xyz(*(tuple(np.moveaxis(v, -1, 0)) for v in (p1, q1, p2, q2)),
                                m=ARRAY)


def segment_distance_xyz(p1, q1, p2, q2, m=SCALAR):
    """Shortest distance between segments p1-q1 and p2-q2 given as (x, y, z) component
    tuples — floats with ``m`` = SCALAR, arrays with ``m`` = ARRAY.

    Closest points by minimising |p1 + s d1 - p2 - t d2| over s, t ∈ [0, 1]
    (Ericson, *Real-Time Collision Detection*, §5.1.9), degenerate segments included.
    """
    d1 = (q1[0] - p1[0], q1[1] - p1[1], q1[2] - p1[2])
    d2 = (q2[0] - p2[0], q2[1] - p2[1], q2[2] - p2[2])
    r = (p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2])
    a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]
    e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]
    b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]
    c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2]
    f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2]
    eps = 1e-18
    point1, point2 = a <= eps, e <= eps
    a_s = m.maximum(a, eps)
    e_s = m.maximum(e, eps)
    denom = a * e - b * b
    skew = denom > 1e-12 * a * e
    s = m.where(skew, m.clip((b * f - c * e) / m.maximum(denom, eps), 0.0, 1.0), 0.0)
    t = (b * s + f) / e_s
    s = m.where(t < 0.0, m.clip(-c / a_s, 0.0, 1.0),
                m.where(t > 1.0, m.clip((b - c) / a_s, 0.0, 1.0), s))
    t = m.clip(t, 0.0, 1.0)
    s = m.where(point1, 0.0, m.where(point2, m.clip(-c / a_s, 0.0, 1.0), s))
    t = m.where(point2, 0.0, m.where(point1, m.clip(f / e_s, 0.0, 1.0), t))
    dx = r[0] + d1[0] * s - d2[0] * t
    dy = r[1] + d1[1] * s - d2[1] * t
    dz = r[2] + d1[2] * s - d2[2] * t
    return m.sqrt(dx * dx + dy * dy + dz * dz)


class Obstacles:
    """World-space obstacle geometry behind one BVHTree.

    ``owners`` (optional) names the object each triangle came from, so messages can say
    *which* obstacle a target is inside. ``tree=None`` is an empty scene.
    """

    def __init__(self, tree=None, *, triangle_owner=None, owner_names=(), bounds=None,
                 triangle_count=0):
        self.tree = tree
        self.triangle_owner = None if triangle_owner is None else np.asarray(triangle_owner)
        self.owner_names = list(owner_names)
        self.triangle_count = int(triangle_count)
        if bounds is None:
            bounds = (np.full(3, -1.0), np.full(3, 1.0))
        self.bounds = (np.asarray(bounds[0], float), np.asarray(bounds[1], float))
        self.size = float(np.linalg.norm(self.bounds[1] - self.bounds[0])) or 1.0

    @classmethod
    def from_triangles(cls, vertices, triangles, owners=None, owner_names=()):
        """Build the BVH from world-space ``vertices`` (N, 3) and ``triangles`` (M, 3) of
        vertex indices. ``owners`` (M,) indexes ``owner_names``. Needs ``mathutils`` (in
        Blender, or after ``import bpy`` with the bpy wheel)."""
        from mathutils.bvhtree import BVHTree

        verts = require_finite("obstacle vertices", vertices).reshape(-1, 3)
        tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        if len(tris) == 0:
            return cls(None)
        if tris.min() < 0 or tris.max() >= len(verts):
            raise ReachError("obstacle triangles index vertices that do not exist")
        tree = BVHTree.FromPolygons(verts.tolist(), tris.tolist(), all_triangles=True)
        return cls(tree, triangle_owner=owners, owner_names=owner_names,
                   bounds=(verts.min(0), verts.max(0)), triangle_count=len(tris))

    @property
    def empty(self) -> bool:
        return self.tree is None

    def owner(self, index) -> str:
        """Name of the object a triangle index belongs to ('obstacle' if unknown)."""
        if self.triangle_owner is None or index is None or not self.owner_names:
            return "obstacle"
        return self.owner_names[int(self.triangle_owner[int(index)])]

    def nearest(self, point, max_distance):
        """(location, normal, triangle index, distance) of the nearest surface within
        ``max_distance`` of ``point``, or None."""
        if self.tree is None:
            return None
        hit = self.tree.find_nearest(tuple(map(float, point)), float(max_distance))
        return None if hit[0] is None else hit

    def distance(self, point, max_distance) -> float:
        """Distance to the nearest surface, or ``math.inf`` if none within ``max_distance``."""
        hit = self.nearest(point, max_distance)
        return math.inf if hit is None else float(hit[3])

    def point_inside(self, point) -> bool:
        """Is ``point`` inside a closed obstacle? Ray parity along the six axis directions,
        majority vote (≥ 4 odd): robust to open meshes (a plane is crossed by at most one
        axis ray) and to rays grazing an edge."""
        if self.tree is None:
            return False
        p = require_finite("point", point)
        odd = 0
        reach = 2.0 * self.size + float(np.abs(p).max())
        nudge = 1e-7 * self.size
        for direction in _AXES:
            origin = p.copy()
            crossings = 0
            travelled = 0.0
            for _ in range(10000):
                loc, _n, _i, dist = self.tree.ray_cast(tuple(origin), direction, reach - travelled)
                if loc is None:
                    break
                crossings += 1
                travelled += dist + nudge
                origin = np.asarray(loc) + np.asarray(direction) * nudge
            odd += crossings % 2
        return odd >= 4

    def enclosing_owner(self, point) -> str:
        """Name of the obstacle nearest to ``point`` (for messages)."""
        hit = self.nearest(point, 10.0 * self.size)
        return self.owner(None if hit is None else hit[2])


class CollisionChecker:
    """Tests arm poses (world-space joints) against the obstacles with a clearance margin.

    Segments: sternum→shoulder (clavicle, upper-arm radius), shoulder→elbow, elbow→wrist,
    and wrist→hand end (if ``Settings.check_hand``; tested on its own by
    :meth:`hand_hit`, since the generator turns the hand at the wrist to clear things).
    Sample fractions are fixed per segment (segment lengths do not change).
    """

    SEGMENTS = (("clavicle", 0, 1), ("upper arm", 1, 2), ("forearm", 2, 3), ("hand", 3, 4))

    def __init__(self, arm, obstacles: Obstacles, settings):
        self.arm = arm
        self.obstacles = obstacles
        margin = settings.clearance * arm.arm_length
        self.margin = margin
        lengths = {
            "clavicle": float(np.linalg.norm(arm.shoulder - arm.sternum)),
            "upper arm": arm.upper_arm_length,
            "forearm": arm.forearm_length,
            "hand": arm.hand_length,
        }
        radii = {
            "clavicle": arm.upper_arm_radius,
            "upper arm": arm.upper_arm_radius,
            "forearm": arm.forearm_radius,
            "hand": arm.hand_radius,
        }
        self.check_hand = bool(settings.check_hand and arm.hand_length > 0)
        self.segments = []
        for name, a, b in self.SEGMENTS:
            if name == "hand" and not self.check_hand:
                continue
            r = radii[name] + margin
            length = lengths[name]
            # Spheres at most one radius apart (never zero apart, for zero radii), each
            # big enough that together they contain the capsule.
            n = max(2, int(math.ceil(length / max(r, 1e-3 * arm.arm_length))) + 1)
            spacing = length / (n - 1)
            cover = math.sqrt(r * r + 0.25 * spacing * spacing)
            self.segments.append((name, a, b, r, length, np.linspace(0.0, 1.0, n)[:, None], cover))
        self._arm_segments = [seg for seg in self.segments if seg[0] != "hand"]
        self._hand_segment = next((seg for seg in self.segments if seg[0] == "hand"), None)
        self._max_cover = max(seg[6] for seg in self.segments)

    def _segment_hit(self, tree, p, q, segment):
        """Triangle index of a contact of one capsule p-q, or None."""
        _name, _a, _b, _r, length, fractions, cover = segment
        if tree.find_nearest((0.5 * (p + q)).tolist(), 0.5 * length + cover)[0] is None:
            return None
        for centre in (p + (q - p) * fractions).tolist():
            hit = tree.find_nearest(centre, cover)
            if hit[0] is not None:
                return hit[2]
        return None

    def first_hit(self, world_joints, include_hand: bool = True):
        """None if the pose is clear, else (segment name, obstacle name)."""
        tree = self.obstacles.tree
        if tree is None:
            return None
        j = np.asarray(world_joints)
        segments = self.segments if include_hand else self._arm_segments
        last = 5 if include_hand else 4
        lo, hi = j[:last].min(0), j[:last].max(0)
        if tree.find_nearest((0.5 * (lo + hi)).tolist(),
                             float(np.linalg.norm(hi - lo)) * 0.5 + self._max_cover)[0] is None:
            return None
        for segment in segments:
            index = self._segment_hit(tree, j[segment[1]], j[segment[2]], segment)
            if index is not None:
                return segment[0], self.obstacles.owner(index)
        return None

    def collides(self, world_joints, include_hand: bool = True) -> bool:
        """Does a pose (world joints, (5, 3)) come within the clearance of an obstacle?"""
        return self.first_hit(world_joints, include_hand) is not None

    def hand_hit(self, world_wrist, world_hand_end) -> bool:
        """Does the hand capsule wrist → hand end touch an obstacle?"""
        tree = self.obstacles.tree
        if tree is None or self._hand_segment is None:
            return False
        return self._segment_hit(tree, np.asarray(world_wrist), np.asarray(world_hand_end),
                                 self._hand_segment) is not None

    def point_clear(self, world_point, radius) -> bool:
        """Is a sphere of ``radius`` (plus the clearance) at ``world_point`` clear?"""
        tree = self.obstacles.tree
        if tree is None:
            return True
        return tree.find_nearest(list(map(float, world_point)), radius + self.margin)[0] is None

    def clearance(self, world_joints, search_radius) -> float:
        """Least distance between the arm's capsule surfaces (without the clearance margin)
        and any obstacle, looking no farther than ``search_radius``; ``inf`` if nothing is
        that close. Measured from the sample points on each segment's axis, so it may
        over-report by up to half a sample spacing."""
        tree = self.obstacles.tree
        if tree is None:
            return math.inf
        j = np.asarray(world_joints)
        best = math.inf
        for _name, a, b, r, _length, fractions, _cover in self.segments:
            for centre in (j[a] + (j[b] - j[a]) * fractions).tolist():
                hit = tree.find_nearest(centre, search_radius + r)
                if hit[0] is not None:
                    best = min(best, hit[3] - (r - self.margin))
        return best
