"""Collisions: the arm's capsules against the world-space obstacle BVH.

Obstacles are **in world space**: one :class:`mathutils.bvhtree.BVHTree` built by the
caller (the Blender layer from the evaluated depsgraph; tests with
:meth:`Obstacles.from_triangles`); arm poses are turned into world space before they are
tested. A capsule is a segment swept by its radius plus ``Settings.clearance``;
:class:`CollisionChecker` settles each one by distance bounds at its ends and bisection,
never missing a contact. Nearness to the surface is enough: the chain starts at the
sternum, checked to be outside every obstacle once per plan. Distances are in world units.
"""

from __future__ import annotations

import gc
import math
from typing import NamedTuple

import numpy as np

from .arm import shape_reach
from .errors import ReachError, require_finite


class ArmSegment(NamedTuple):
    """One capsule of the arm as the checker tests it: between joints ``a`` and ``b``
    (indices into a pose's joints), ``radius`` the part's radius plus the clearance,
    ``length`` its rest length, and the row of spheres that contains it for
    :meth:`CollisionChecker.first_hit`'s fallback: their centres' ``fractions`` along it
    ((n, 1)) and the radius ``cover`` of each."""

    name: str
    a: int
    b: int
    radius: float
    length: float
    fractions: np.ndarray
    cover: float

_AXES = ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0),
         (0.0, 0.0, 1.0), (0.0, 0.0, -1.0))


class Obstacles:
    """World-space obstacle geometry behind one BVHTree.

    ``owners`` (optional) names the object each triangle came from, so messages can say
    *which* obstacle a target is inside. ``tree=None`` is an empty scene.
    """

    def __init__(self, tree=None, *, triangle_owner=None, owner_names=(), bounds=None,
                 triangle_count=0, triangles=None, triangle_part=None, vertices=None):
        self.tree = tree
        self.triangle_owner = None if triangle_owner is None else np.asarray(triangle_owner)
        self.owner_names = list(owner_names)
        self.triangle_count = int(triangle_count)
        #: vertex indices (M, 3) of the triangles, for :meth:`part_closed`; None: unknown,
        #: every part read as closed
        self.triangles = triangles
        #: the world-space vertices (N, 3) the triangles index (for
        #: :func:`~reach_addon.core.obstacle_union.union`); None: unknown
        self.vertices = vertices
        #: which part (one obstacle at one instant: one piece) each triangle belongs to;
        #: None: the owner is the part
        self.triangle_part = (self.triangle_owner if triangle_part is None
                              else np.asarray(triangle_part))
        self._closed: dict = {}
        if bounds is None:
            bounds = (np.full(3, -1.0), np.full(3, 1.0))
        self.bounds = (np.asarray(bounds[0], float), np.asarray(bounds[1], float))
        self.size = float(np.linalg.norm(self.bounds[1] - self.bounds[0])) or 1.0

    @classmethod
    def from_triangles(cls, vertices, triangles, owners=None, owner_names=(), parts=None):
        """Build the BVH from world-space ``vertices`` (N, 3) and ``triangles`` (M, 3) of
        vertex indices. ``owners`` (M,) indexes ``owner_names``; ``parts`` (M,) says which
        piece each triangle is of (one obstacle at one instant of a sweep; default: the
        owner), the unit :meth:`point_inside` reads an inside of. Needs ``mathutils`` (in
        Blender, or after ``import bpy`` with the bpy wheel)."""
        from mathutils.bvhtree import BVHTree

        verts = require_finite("obstacle vertices", vertices).reshape(-1, 3)
        tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        if len(tris) == 0:
            return cls(None)
        if tris.min() < 0 or tris.max() >= len(verts):
            raise ReachError("obstacle triangles index vertices that do not exist")
        # Python's cyclic collector paused while the millions of small lists FromPolygons
        # takes are made: it ran over and over, and was most of what tolist took (1M
        # triangles: ~1.8 s with it, ~0.3-0.6 s without).
        collecting = gc.isenabled()
        gc.disable()
        try:
            tree = BVHTree.FromPolygons(verts.tolist(), tris.tolist(), all_triangles=True)
        finally:
            if collecting:
                gc.enable()
        return cls(tree, triangle_owner=owners, owner_names=owner_names,
                   bounds=(verts.min(0), verts.max(0)), triangle_count=len(tris),
                   triangles=tris, triangle_part=parts, vertices=verts)

    @property
    def empty(self) -> bool:
        return self.tree is None

    def triangle_counts(self) -> list:
        """[(obstacle name, triangle count)] for every owner, in owner order (what the report
        and the panel list as the obstacles used)."""
        if self.tree is None:
            return []
        if self.triangle_owner is None or not self.owner_names:
            return [("obstacle", self.triangle_count)]
        counts = np.bincount(self.triangle_owner, minlength=len(self.owner_names))
        return [(name, int(n)) for name, n in zip(self.owner_names, counts)]

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
        """Is ``point`` inside a closed obstacle? :meth:`enclosing_parts` is not empty."""
        return bool(self.enclosing_parts(point))

    def enclosing_parts(self, point) -> list:
        """The parts (pieces: one obstacle at one instant) that enclose ``point``, in
        order: closed parts (:meth:`part_closed`) whose own triangles the axis rays from
        the point cross an odd number of times along at least four of the six directions
        (a majority, robust to a ray grazing an edge). Parity is read per part, since two
        overlapping solids (or one obstacle at two instants of a sweep) cross twice as
        often; and only closed parts count, since an open mesh encloses nothing: a point
        in an open-ended tube or a box without a lid is crossed oddly along four or five
        axes, yet lies in air (fuzz seed 5413: a hand in an open mesh refused as inside
        it)."""
        if self.tree is None:
            return []
        votes: dict = {}
        for hits in self._crossings(point):
            if self.triangle_part is None:
                odd = {0} if len(hits) % 2 else set()
            else:
                counts: dict = {}
                for i in hits:
                    k = int(self.triangle_part[int(i)])
                    counts[k] = counts.get(k, 0) + 1
                odd = {k for k, n in counts.items() if n % 2}
            for k in odd:
                votes[k] = votes.get(k, 0) + 1
        return sorted(k for k, n in votes.items() if n >= 4 and self.part_closed(k))

    def part_closed(self, part: int) -> bool:
        """Is the part closed, so that it has an inside: every undirected edge of its
        triangles used by an even number of them (two; or pairs of faces doubled)? Edges
        by vertex index, as the mesh shares its vertices. Read when first asked, then
        kept. True where the triangles are not known."""
        if part not in self._closed:
            tris = self.triangles
            if tris is None:
                self._closed[part] = True
            else:
                if self.triangle_part is not None:
                    tris = tris[self.triangle_part == part]
                edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]],
                                                tris[:, [2, 0]]]), axis=1)
                _keys, counts = np.unique(edges, axis=0, return_counts=True)
                self._closed[part] = bool(len(tris)) and bool(np.all(counts % 2 == 0))
        return self._closed[part]

    def _crossings(self, point) -> list:
        """The triangle indices each of the six axis rays from ``point`` crosses, in order."""
        p = require_finite("point", point)
        reach = 2.0 * self.size + float(np.abs(p).max())
        # past a face before casting on: the BVH works in 32-bit floats, whose step near a
        # coordinate x is about 1.2e-7 |x|, so a nudge of the scene's size alone (1e-7 of
        # a 28 cm box standing a metre from the origin) lands on the face just crossed and
        # counts it again and again
        nudge = 1e-6 * (self.size + float(np.abs(p).max()))
        out = []
        for direction in _AXES:
            origin = p.copy()
            hits = []
            travelled = 0.0
            for _ in range(10000):
                loc, _n, index, dist = self.tree.ray_cast(tuple(origin), direction,
                                                          reach - travelled)
                if loc is None:
                    break
                hits.append(index)
                travelled += dist + nudge
                origin = np.asarray(loc) + np.asarray(direction) * nudge
            out.append(hits)
        return out

    def enclosing_owner(self, point) -> str:
        """Name of the obstacle that encloses ``point`` (the first of
        :meth:`enclosing_parts`), else of the obstacle nearest to it (for messages)."""
        if self.tree is not None and self.triangle_owner is not None and self.owner_names:
            inside = self.enclosing_parts(point)
            if inside:
                first = int(np.flatnonzero(self.triangle_part == inside[0])[0])
                return self.owner_names[int(self.triangle_owner[first])]
        hit = self.nearest(point, 10.0 * self.size)
        return self.owner(None if hit is None else hit[2])


#: How far (arm lengths) :meth:`CollisionChecker.least_clearance` may err; it errs low.
CLEARANCE_TOLERANCE = 1e-4
#: The least margin (arm lengths) a pose is kept clear by, whatever ``Settings.clearance``
#: asks (the keys and the instants between them): with none, Blender's evaluated bones
#: between two keys stood up to 1e-4 arm lengths into a box this model called clear (fuzz
#: seed 4880, a chase with the clearance 0, at frame 17.5).
MIN_CLEARANCE = 1e-3


class CollisionChecker:
    """Tests arm poses (world-space joints) against the obstacles with a clearance margin.

    Segments: sternum→shoulder (clavicle, upper-arm radius), shoulder→elbow, elbow→wrist,
    and wrist→hand end (if ``Settings.check_hand``; tested on its own by
    :meth:`hand_hit`, since the generator turns the hand at the wrist to clear things).
    Sample fractions are fixed per segment (segment lengths do not change).

    A segment is settled by the cheapest test that can settle it:

    1. **Distance bounds at its ends.** The distance to the nearest surface is
       1-Lipschitz: a point ``t`` along a segment of length ``L`` whose ends are at least
       ``d_p`` and ``d_q`` from every surface is at least ``max(d_p - t, d_q - (L - t))``
       from it, so the whole axis is at least ``(d_p + d_q - L) / 2`` away. The capsule
       (radius ``R`` = its radius + the clearance) is clear when that is ``≥ R``, and
       touches when an end is closer than ``R``. The generator measures each joint once
       (one bounded ``find_nearest``) and shares it between the segments meeting there
       and between all the candidate poses of one wrist position.
    2. Otherwise **bisection**: the middle is measured and each half settled by test 1
       or split again; a piece no longer than ``R`` is settled by one sphere around it
       (radius √(R² + (length/2)²), which may report a contact up to ~12% of R early but
       never misses one). A segment that runs close along a surface costs a few queries
       near the contact instead of the whole row of spheres of the module docstring.

    Both tests are exact about clear capsules, so a pose's verdict is the same whichever
    caller asks (:meth:`first_hit`, :meth:`collides` or the generator's shared path).
    """

    SEGMENTS = (("clavicle", 0, 1), ("upper arm", 1, 2), ("forearm", 2, 3), ("hand", 3, 4))

    def __init__(self, arm, obstacles: Obstacles, settings):
        self.arm = arm
        self.obstacles = obstacles
        margin = max(float(settings.clearance), MIN_CLEARANCE) * arm.arm_length
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
        # the hand as skinned (core.hand_shape): its capsules' ends follow the joints
        self.hand_shape = tuple(arm.hand_shape) if self.check_hand else ()
        self.segments = []
        self.by_name = {}
        for name, a, b in self.SEGMENTS:
            segment = self._segment(name, a, b, radii[name] + margin, lengths[name])
            self.by_name[name] = segment
            if name == "hand" and (not self.check_hand or self.hand_shape):
                continue
            self.segments.append(segment)
        self.hand_segments = [self._segment("hand", 5 + 2 * i, 6 + 2 * i, r + margin,
                                            math.dist(a, b))
                              for i, (a, b, r) in enumerate(self.hand_shape)] or \
            [self.by_name["hand"]]
        if self.hand_shape:
            self.segments += self.hand_segments
        self.rows = 5 + 2 * len(self.hand_shape)     # rows a pose's joints must have
        self._arm_segments = [seg for seg in self.segments if seg.name != "hand"]
        self._max_cover = max(seg.cover for seg in self.segments)
        # how far :meth:`clearance`'s row of points may over-read: half its widest spacing
        self._row_slack = max(0.5 * seg.length / (len(seg.fractions) - 1) for seg in self.segments)
        # Query bounds of the joint distances: far enough to clear every segment that meets
        # at the joint from that end alone (see the class docstring).
        rad = {name: seg.radius for name, seg in self.by_name.items()}
        self.bound_sternum = lengths["clavicle"] + rad["clavicle"]
        self.bound_shoulder = max(lengths["clavicle"], lengths["upper arm"]) + rad["upper arm"]
        self.bound_elbow = max(lengths["upper arm"] + rad["upper arm"],
                               lengths["forearm"] + rad["forearm"])
        self.bound_wrist = max(lengths["forearm"] + rad["forearm"],
                               lengths["hand"] + rad["hand"])
        self.bound_hand = lengths["hand"] + rad["hand"]
        # the query bound at each joint a segment meets: far enough to clear every segment
        # that meets there from that end alone
        self._bounds = [self.bound_sternum, self.bound_shoulder, self.bound_elbow,
                        self.bound_wrist, self.bound_hand]
        if self.hand_shape:
            self.hand_reach = shape_reach(self.hand_shape) + margin
            self.bound_wrist = max(lengths["forearm"] + rad["forearm"], self.hand_reach)
            self._bounds[3] = self.bound_wrist
            self._bounds += [seg.length + seg.radius for seg in self.hand_segments
                             for _end in (0, 1)]
        else:
            self.hand_reach = self.bound_hand
        used = sorted({i for seg in self.segments for i in (seg.a, seg.b)})
        self._rows_used = (used, [i for i in used if i < 4])

    def _segment(self, name, a, b, r, length) -> ArmSegment:
        """An :class:`ArmSegment` of radius ``r`` (the clearance included) and ``length``:
        its spheres at most one radius apart (never zero apart, for zero radii), each big
        enough that together they contain the capsule."""
        n = max(2, int(math.ceil(length / max(r, 1e-3 * self.arm.arm_length))) + 1)
        spacing = length / (n - 1)
        cover = math.sqrt(r * r + 0.25 * spacing * spacing)
        return ArmSegment(name, a, b, r, length, np.linspace(0.0, 1.0, n)[:, None], cover)

    def _rows(self, j, include_hand: bool) -> None:
        """Refuse joints without the hand shape's rows (:func:`.hand_shape.with_shape`)
        where the hand is tested: a caller that left them out would test no hand."""
        if include_hand and self.hand_shape and len(j) < self.rows:
            raise ValueError(f"a pose of {len(j)} rows where the hand's shape needs "
                             f"{self.rows} (core.hand_shape.with_shape)")

    def distance(self, point, bound: float) -> float:
        """Distance from a world point (3 floats) to the nearest obstacle surface, or
        ``bound`` when nothing is within ``bound`` (a lower bound either way)."""
        tree = self.obstacles.tree
        if tree is None:
            return bound
        hit = tree.find_nearest(point, bound)
        return bound if hit[0] is None else hit[3]

    def segment_clear(self, p, q, d_p: float, d_q: float, r: float, length: float) -> bool:
        """Is the capsule p-q (world points as 3 floats) of radius ``r`` (the clearance
        included) and length ``length`` clear, given lower bounds ``d_p``, ``d_q`` of the
        obstacle distance at its ends? Test 1, then test 2 of the class docstring."""
        if d_p < r or d_q < r:
            return False
        if d_p + d_q - length >= 2.0 * r:
            return True
        tree = self.obstacles.tree
        return tree is None or self._bisect(tree, list(p), list(q), d_p, d_q, length, r)

    def _bisect(self, tree, p, q, d_p, d_q, length, r) -> bool:
        """Test 2 of the class docstring on a piece p-q (its ends ``≥ r`` from every
        surface, not settled by test 1): measure the middle (bounded by half the length +
        r, enough to settle both halves if nothing is found) and settle each half by
        test 1 or recursively; a piece no longer than ``r`` is settled by one sphere of
        radius √(r² + (length/2)²) around it, which contains it (at most ~12% early)."""
        half = 0.5 * length
        m = [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])]
        if length <= r:
            return tree.find_nearest(m, math.sqrt(r * r + half * half))[0] is None
        hit = tree.find_nearest(m, half + r)
        if hit[0] is None:
            return True
        d_m = hit[3]
        if d_m < r:
            return False
        return ((d_p + d_m - half >= 2.0 * r or self._bisect(tree, p, m, d_p, d_m, half, r))
                and (d_m + d_q - half >= 2.0 * r or self._bisect(tree, m, q, d_m, d_q, half, r)))

    def _segment_hit(self, tree, p, q, segment, bounded: bool = True):
        """Triangle index of a contact of one capsule p-q by the row of spheres, or None.
        ``bounded``: first one query around the whole segment."""
        length, fractions, cover = segment.length, segment.fractions, segment.cover
        if bounded and tree.find_nearest((0.5 * (p + q)).tolist(), 0.5 * length + cover)[0] is None:
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
        j = np.asarray(world_joints, dtype=float)
        self._rows(j, include_hand)
        segments = self.segments if include_hand else self._arm_segments
        rows = self._rows_used[0 if include_hand else 1]
        points = j.tolist()
        # one query around the box of the joints first (on floats: numpy's per-call cost
        # is most of a clear pose's test)
        xs, ys, zs = zip(*(points[i] for i in rows))
        lo, hi = (min(xs), min(ys), min(zs)), (max(xs), max(ys), max(zs))
        dx, dy, dz = hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]
        if tree.find_nearest([0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]),
                              0.5 * (lo[2] + hi[2])],
                             math.sqrt(dx * dx + dy * dy + dz * dz) * 0.5
                             + self._max_cover)[0] is None:
            return None
        bounds = self._bounds
        dist = {i: self.distance(points[i], bounds[i]) for i in rows}
        for segment in segments:
            a, b = segment.a, segment.b
            if self.segment_clear(points[a], points[b], dist[a], dist[b], segment.radius,
                                  segment.length):
                continue
            index = self._segment_hit(tree, j[a], j[b], segment, bounded=False)
            if index is None:   # the sphere row missed what the bisection found: the nearest
                index = tree.find_nearest((0.5 * (j[a] + j[b])).tolist())[2]
            return segment.name, self.obstacles.owner(index)
        return None

    def touches(self, world_joints, name: str) -> bool:
        """Does the segment ``name`` (of :attr:`SEGMENTS`) of the pose with these world
        joints (5, 3) come nearer an obstacle than its radius and the clearance?"""
        tree = self.obstacles.tree
        if tree is None:
            return False
        j = np.asarray(world_joints, dtype=float)
        segments = [self.by_name[name]]
        if name == "hand":
            self._rows(j, True)
            segments = self.hand_segments
        return any(self._segment_hit(tree, j[seg.a], j[seg.b], seg) is not None
                   for seg in segments)

    def capsule_clear(self, p, q, radius: float) -> bool:
        """Is the capsule from world point ``p`` to ``q`` of ``radius`` (plus the
        clearance) clear of the obstacles? The two tests of the class docstring."""
        if self.obstacles.tree is None:
            return True
        p = [float(v) for v in p]
        q = [float(v) for v in q]
        r = radius + self.margin
        length = math.dist(p, q)
        bound = length + 2.0 * r
        return self.segment_clear(p, q, self.distance(p, bound), self.distance(q, bound), r, length)

    def collides(self, world_joints, include_hand: bool = True) -> bool:
        """Does a pose (world joints, (5, 3)) come within the clearance of an obstacle?"""
        return self.first_hit(world_joints, include_hand) is not None

    def axis_distance(self, p, q, horizon: float, tolerance: float) -> float:
        """Least distance from the segment p-q (world points) to the obstacles' surfaces,
        to within ``tolerance`` (never more than ``tolerance`` above it), or ``horizon``
        when nothing is that close. Branch and bound on the distance's 1-Lipschitz bound
        (the class docstring's test 1): a piece whose ends are ``d_a`` and ``d_b`` away
        and ``l`` apart is nowhere nearer than (``d_a`` + ``d_b`` - ``l``) / 2, so only
        pieces that could hold a nearer point are split."""
        tree = self.obstacles.tree
        if tree is None:
            return horizon
        p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
        length = float(np.linalg.norm(q - p))
        bound = horizon + length

        def d(t):
            hit = tree.find_nearest((p + (q - p) * t).tolist(), bound)
            return bound if hit[0] is None else hit[3]

        d0, d1 = d(0.0), d(1.0)
        best = min(d0, d1)
        pieces = [(0.0, 1.0, d0, d1)]
        while pieces:
            a, b, da, db = pieces.pop()
            if 0.5 * (da + db - (b - a) * length) >= min(best, horizon) - tolerance:
                continue
            m = 0.5 * (a + b)
            dm = d(m)
            best = min(best, dm)
            pieces += [(a, m, da, dm), (m, b, dm, db)]
        return min(best, horizon)

    def pose_clearance(self, world_joints, horizon: float, tolerance: float,
                       include_hand: bool = True) -> float:
        """Least distance between a pose's capsule surfaces (no margin) and the
        obstacles, to within ``tolerance`` (:meth:`axis_distance`), at most ``horizon``;
        negative where a capsule is in contact, by how deep."""
        j = np.asarray(world_joints, dtype=float)
        self._rows(j, include_hand)
        segments = self.segments if include_hand else self._arm_segments
        best = horizon
        for seg in segments:
            r = seg.radius - self.margin
            best = min(best, self.axis_distance(j[seg.a], j[seg.b], best + r, tolerance) - r)
        return best

    def least_clearance(self, world_joints, horizon: float) -> float:
        """The least distance between the pose's capsule surfaces (no margin) and the
        obstacles, ``inf`` where nothing is within ``horizon``, read so that its sign is
        certain: where :meth:`clearance`'s row of points, less the most it may over-read
        (half its spacing), keeps the margin, that reading (over by at most half the
        spacing, as the row's always was); nearer, a lower bound: :meth:`pose_clearance` to
        within :data:`CLEARANCE_TOLERANCE` arm lengths, less that tolerance, so a pose it
        calls clear (``≥ 0``) is clear by any exact measure, and one in contact is never
        called clear. Where a contact's sign matters (leaving a start in contact, a key's
        contact), this is the measure: the row alone can miss an edge between two of its
        points. The row first, because the bound's search costs ten to thirty times as
        much and most keys are far from everything."""
        row = self.clearance(world_joints, horizon)
        if row - self._row_slack >= self.margin:
            return row
        tolerance = CLEARANCE_TOLERANCE * self.arm.arm_length
        cap = horizon + tolerance
        c = self.pose_clearance(world_joints, cap, tolerance)
        return math.inf if c >= cap else c - tolerance

    def clearance(self, world_joints, search_radius, include_hand: bool = True) -> float:
        """Least distance between the arm's capsule surfaces (without the clearance margin)
        and any obstacle, looking no farther than ``search_radius``; ``inf`` if nothing is
        that close. Measured from the sample points on each segment's axis, so it may
        over-report by up to half a sample spacing."""
        tree = self.obstacles.tree
        if tree is None:
            return math.inf
        j = np.asarray(world_joints)
        self._rows(j, include_hand)
        best = math.inf
        for _name, a, b, r, _length, fractions, _cover in (self.segments if include_hand
                                                            else self._arm_segments):
            for centre in (j[a] + (j[b] - j[a]) * fractions).tolist():
                hit = tree.find_nearest(centre, search_radius + r)
                if hit[0] is not None:
                    best = min(best, hit[3] - (r - self.margin))
        return best
