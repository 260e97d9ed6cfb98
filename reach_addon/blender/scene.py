"""Scene → obstacles: every visible object with faces (or one collection), evaluated, in
world space, as one BVH tree.

Geometry is read through the evaluated depsgraph, so modifiers, geometry nodes, curves,
text, metaballs, surfaces and every kind of instancing (collection instances, geometry-nodes
instances realized or not, particles drawn as objects) count as the user sees them.

What counts
-----------
Objects of the types in :data:`SURFACE_TYPES` give triangles: a mesh its evaluated mesh; a
curve, surface, text or metaball the mesh Blender evaluates for it (a curve without bevel
or extrusion has none and is skipped). Every other type has no faces and is skipped: grease
pencil (strokes), point clouds, volumes, hair curves, empties, cameras, lights, light
probes, speakers, lattices, armatures. Left out too: the character's own meshes (deformed
by or parented under the armature), the targets, Reach's own display (tagged
:data:`VIZ_TAG`), hidden objects, and — when a collection is given — objects outside it.

:func:`visit_obstacles` is the one place that walks ``depsgraph.object_instances``: every
instance is read inside its iteration step (it exists only then) and copied to numpy.
:class:`ObstacleCache` keeps one BVH and rebuilds it only when a cheap signature of the
obstacles changes (live mode, a chase's frames); :data:`KEPT` keeps the obstacles of Plan,
Bake and the envelope between runs, rebuilt only when the content of some piece changed.
Why, and what a first build costs: ``docs/design/blender.md``.
"""

from __future__ import annotations

import zlib
from collections import OrderedDict
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..core import Obstacles, ReachError, Settings
from ..core.arm import REACH_SLACK, reach_sphere
from ..core.sweep import obstacles_from_pieces as core_obstacles_from_pieces

#: Object types whose evaluated geometry can have faces.
SURFACE_TYPES = frozenset({"MESH", "CURVE", "SURFACE", "FONT", "META"})
#: Custom property that marks objects Reach made (trajectory, markers): never obstacles.
VIZ_TAG = "reach_viz"
#: Coordinates at least this large are taken as infinite: Blender keeps an infinite value
#: typed into a field as the largest single-precision float, 3.4e38 (times any parent's
#: scale), which is finite to numpy but overflows the rig's and the planner's arithmetic.
INFINITE = 1e30


def rounded_bytes(values, decimals: int) -> bytes:
    """``values`` rounded to ``decimals`` as bytes, for a signature: a matrix turned and
    turned back comes back within float rounding. Values too large to round (an infinite
    location, kept by Blender as 3.4e38) become inf without numpy's overflow warning; such
    objects are refused or left out before anything reads their geometry."""
    with np.errstate(over="ignore", invalid="ignore"):
        return np.round(np.asarray(values, dtype=float), decimals).tobytes()


def finite(values) -> bool:
    """Are all ``values`` numbers below :data:`INFINITE` in size (no NaN, no infinity)?"""
    a = np.asarray(values, dtype=float)
    return bool(np.isfinite(a).all() and (a.size == 0 or np.abs(a).max() < INFINITE))


def character_objects(armature, scene) -> set:
    """Names of the objects that belong to the character: the armature, objects parented (at
    any depth) under it, and objects deformed by it through an Armature modifier."""
    names = {armature.name}
    for ob in scene.objects:
        parent = ob.parent
        while parent is not None:
            if parent == armature:
                names.add(ob.name)
                break
            parent = parent.parent
        if any(m.type == "ARMATURE" and m.object == armature for m in getattr(ob, "modifiers", ())):
            names.add(ob.name)
    return names


@dataclass
class Piece:
    """One depsgraph instance that may be an obstacle, as plain data (safe to keep)."""

    owner: str               # what the user sees: the instancer, or the object itself
    name: str                # the original object the geometry comes from
    type: str                # Blender's object type of the evaluated instance
    is_instance: bool
    matrix: np.ndarray       # world matrix, 4×4

    @property
    def label(self) -> str:
        return self.owner if self.name == self.owner else f"{self.owner}/{self.name}"


def visit_obstacles(context, read, exclude=(), collection=None, depsgraph=None) -> list:
    """Walk the depsgraph's instances once and call ``read(piece, evaluated_object)``,
    inside the iteration step, for every instance that may be an obstacle (a type of
    :data:`SURFACE_TYPES`, visible, not excluded, in ``collection`` if given). ``read``
    must copy what it needs and keep no reference to the object; it returns a value, or
    None to skip the piece. Returns [(piece, value)] in depsgraph order, without the
    curve, surface, text or metaball pieces whose evaluated mesh also came through as a
    mesh instance of the same owner (counted once, as the mesh)."""
    depsgraph = depsgraph or context.evaluated_depsgraph_get()
    exclude = set(exclude)
    allowed = {ob.name for ob in collection.all_objects} if collection is not None else None
    viz = {ob.name for ob in context.scene.objects if ob.get(VIZ_TAG)}
    wanted: dict[tuple, bool] = {}
    out, meshed = [], set()
    for inst in depsgraph.object_instances:
        ob = inst.object
        kind = ob.type
        if kind not in SURFACE_TYPES:
            continue
        is_instance = bool(inst.is_instance)
        original = ob.original
        parent = inst.parent.original if is_instance and inst.parent is not None else None
        owner = parent if parent is not None else original
        key = (owner.name, original.name)
        ok = wanted.get(key)
        if ok is None:
            names = set(key)
            ok = wanted[key] = (not names & exclude and not names & viz
                                and (allowed is None or bool(names & allowed))
                                and owner.visible_get())
        if not ok:
            continue
        if kind == "MESH" and is_instance:
            meshed.add(key)
        piece = Piece(key[0], key[1], kind, is_instance, np.array(inst.matrix_world))
        value = read(piece, ob)
        if value is not None:
            out.append((piece, value))
    return [(p, v) for p, v in out if p.type == "MESH" or (p.owner, p.name) not in meshed]


def gather_obstacles(context, exclude=(), collection=None, depsgraph=None) -> Obstacles:
    """One world-space BVH of the obstacles; each object (or instancer) is one owner, so
    :meth:`~reach_addon.core.Obstacles.triangle_counts` lists what was used.

    ``exclude``: object names never to count (the character's meshes, the targets).
    ``collection``: if given, only objects in it (and its children) count; a collection
    whose objects have no faces is an error, since the user asked for those obstacles.
    """
    return obstacles_from_pieces(gather_pieces(context, exclude, collection, depsgraph),
                                 collection)


def gather_pieces(context, exclude=(), collection=None, depsgraph=None, only=None) -> list:
    """The obstacles' geometry as it is now, as plain data: [(label, world vertices (N, 3),
    triangles (M, 3))] per piece, by the rules of :func:`visit_obstacles`. ``only``: if
    given, the owner or object names whose pieces are read (the others are skipped)."""
    cache: dict = {}

    def read(piece, ob):
        if only is not None and piece.owner not in only and piece.name not in only:
            return None
        v, t = _triangles(ob, cache)
        if len(t) == 0:
            return None
        m = piece.matrix
        world = v @ m[:3, :3].T + m[:3, 3]
        if not finite(world):
            raise ReachError(f"obstacle '{piece.label}' has NaN or infinite vertices (check "
                             "its transform and modifiers), or hide it")
        return world, t

    return [(piece.label, v, t) for piece, (v, t) in
            visit_obstacles(context, read, exclude, collection, depsgraph)]


def obstacles_from_pieces(pieces, collection=None) -> Obstacles:
    """One BVH of pieces [(label, world vertices, triangles)] (:func:`gather_pieces`; the
    same label may come several times, as one obstacle at several instants;
    :func:`reach_addon.core.sweep.obstacles_from_pieces`). Raises ReachError for no pieces
    from the obstacle ``collection`` (a Blender collection; None: all visible objects)."""
    if not pieces and collection is not None:
        raise ReachError(
            f"the obstacle collection '{collection.name}' has no visible objects with "
            "faces; add meshes to it or plan against all visible objects")
    return core_obstacles_from_pieces(pieces)


class ObstacleCache:
    """The obstacles of one scene, rebuilt only when they change.

    The signature lists, for every piece :func:`~.scene.visit_obstacles` finds (the walk
    and the rules :func:`~.scene.gather_obstacles` uses: visible, with geometry, not the
    character, the targets or Reach's own display, inside the obstacle collection if one is
    given): its owner and name, world matrix, data
    block and vertex count, a counter of geometry edits seen by the depsgraph handler
    (:meth:`note_geometry`), and — when ``geometry`` is asked for, as after a frame change
    — a checksum of the evaluated vertices of objects whose shape can change without a
    transform (modifiers, shape keys, edit mode). Reading matrices costs microseconds per
    object; the BVH is rebuilt only when the signature differs."""

    def __init__(self, exclude=(), collection: str | None = None):
        self.exclude = set(exclude)
        self.collection = collection
        self.signature = None
        self.obstacles = None
        self.builds = 0
        self._edits: dict[str, int] = {}

    def note_geometry(self, name: str) -> None:
        if name not in self.exclude:
            self._edits[name] = self._edits.get(name, 0) + 1

    def _collection(self):
        if self.collection is None:
            return None
        coll = bpy.data.collections.get(self.collection)
        if coll is None:
            raise ReachError(f"obstacle collection '{self.collection}' no longer exists; "
                             "choose another or plan against all visible objects")
        return coll

    def compute_signature(self, context, depsgraph=None, geometry: bool = False) -> tuple:
        edits = self._edits

        def read(piece, ob):
            # Inside the depsgraph's iteration step (see scene.visit_obstacles): copy only.
            original = ob.original
            data = ob.data
            count = len(data.vertices) if piece.type == "MESH" else 0
            entry = (piece.owner, piece.name, rounded_bytes(piece.matrix, 9),
                     getattr(original.data, "name", ""), count, edits.get(piece.name, 0))
            if geometry and count and _deformable(original):
                co = np.empty(count * 3, dtype=np.float32)
                data.vertices.foreach_get("co", co)
                entry += (zlib.crc32(co.tobytes()),)
            return entry

        pieces = visit_obstacles(context, read, self.exclude, self._collection(), depsgraph)
        return tuple(entry for _piece, entry in pieces)

    def get(self, context, depsgraph=None, geometry: bool = False):
        """(obstacles, rebuilt?) for the scene as it is now."""
        depsgraph = depsgraph or context.evaluated_depsgraph_get()
        sig = self.compute_signature(context, depsgraph, geometry)
        if not geometry and self.signature is not None and len(sig) == len(self.signature):
            # Without checksums, keep the ones taken last time for objects that did not move.
            sig = tuple(s + old[len(s):] if s == old[:len(s)] else s
                        for s, old in zip(sig, self.signature))
        if self.obstacles is not None and sig == self.signature:
            return self.obstacles, False
        self.obstacles = gather_obstacles(context, self.exclude, self._collection(), depsgraph)
        self.signature = sig
        self.builds += 1
        return self.obstacles, True


@dataclass
class _Kept:
    signature: tuple
    pieces: list
    obstacles: Obstacles
    by_entry: dict = field(default_factory=dict)


class KeptObstacles:
    """The obstacles of Plan, Bake and the envelope, kept between runs: a second Plan on a
    scene whose obstacles did not change builds no BVH (1M triangles: 15–30 ms to find that
    out, against 2–4 s to gather and build on the bench machine).

    Kept per (scene, objects left out, obstacle collection), the last :attr:`size` of them.
    Each run walks the obstacles as :func:`gather_pieces` does and signs every piece by
    its content: owner, object, type, exact world matrix, and for its geometry the sizes
    and checksums of its evaluated positions, corners and triangulation
    (:func:`_content`). Anything that changes what the planner would see — a move, an edit
    (in edit mode too, the vertex count kept), a modifier, a shape key, an animation on a
    new frame, hiding, adding, deleting, a change of collection — changes some piece's
    entry or the list of pieces, and the BVH is built again; pieces whose entry did not
    change keep the world-space arrays read last time. Nothing relies on handlers or on
    names alone, so a stale tree cannot survive an undo or a file reload."""

    def __init__(self, size: int = 4):
        self.size = size
        self.builds = 0
        self._kept: OrderedDict = OrderedDict()

    def clear(self) -> None:
        self._kept.clear()

    def get(self, context, exclude=(), collection=None, depsgraph=None, within=None):
        """(pieces, obstacles, rebuilt?) for the scene as it is now: ``pieces`` as
        :func:`gather_pieces` gives them (arrays read-only, shared with later calls),
        ``obstacles`` their BVH, as :func:`gather_obstacles` would build it.

        ``within``: (centre, radius, points) in world space, or None for every piece. A
        piece whose world bounding box lies farther than ``radius`` from ``centre``
        (:func:`reach_addon.core.arm.reach_sphere`: where no pose of the arm can be) and
        holds none of ``points`` (the targets, so that a target inside a far object is
        still found inside it) is left out whole, without its geometry being read: its
        entry in the signature is its transform and bounding box, so it comes in again
        the moment it moves or grows into reach. Objects are kept or left out whole, never
        cut, so a closed obstacle stays closed for the inside tests."""
        key = (context.scene.name, frozenset(exclude),
               None if collection is None else collection.name)
        old = self._kept.get(key)
        before = old.by_entry if old is not None else {}
        by_entry: dict = {}
        shared: dict = {}
        meshes: dict = {}
        beyond = [0]

        def read(piece, ob):
            # Inside the depsgraph's iteration step (see visit_obstacles): copy only.
            if within is not None:
                box = _beyond(piece, ob, within)
                if box is not None:
                    beyond[0] += 1
                    return (piece.owner, piece.name, piece.type, piece.matrix.tobytes(),
                            "beyond reach", box), None
            content, arrays = _content(ob, meshes, shared)
            entry = (piece.owner, piece.name, piece.type, piece.matrix.tobytes(), content)
            if entry in by_entry or entry in before:
                found = by_entry.get(entry, before.get(entry))
            else:
                v, t = arrays if arrays is not None else _triangles(ob, shared)
                found = None
                if len(t):
                    m = piece.matrix
                    world = v @ m[:3, :3].T + m[:3, 3]
                    if not finite(world):
                        raise ReachError(f"obstacle '{piece.label}' has NaN or infinite "
                                         "vertices (check its transform and modifiers), or "
                                         "hide it")
                    world.flags.writeable = False
                    found = (world, t)
            by_entry[entry] = found
            return entry, found

        visited = visit_obstacles(context, read, exclude, collection, depsgraph)
        signature = tuple(entry for _piece, (entry, _found) in visited)
        self._kept.pop(key, None)
        if old is not None and old.signature == signature:
            old.by_entry = by_entry
            self._kept[key] = old
            return old.pieces, old.obstacles, False
        pieces = [(piece.label, *found) for piece, (_entry, found) in visited
                  if found is not None]
        # a collection whose objects all lie beyond reach is not an empty collection
        obstacles = obstacles_from_pieces(pieces, None if beyond[0] else collection)
        self.builds += 1
        self._kept[key] = _Kept(signature, pieces, obstacles, by_entry)
        while len(self._kept) > self.size:
            self._kept.popitem(last=False)
        return pieces, obstacles, True


#: Plan's, Bake's and the envelope's obstacles, kept between runs (:class:`KeptObstacles`).
KEPT = KeptObstacles()


def _beyond(piece, ob, within):
    """The world bounding box of an evaluated object (bytes), if it lies wholly beyond
    ``within`` = (centre, radius, points) and holds none of the points; else None (keep
    it). Only a mesh with faces in object mode may be left out: a curve, text or metaball
    is read, as is a mesh in edit mode (its box may not follow its edits), a mesh without
    faces (an obstacle collection of nothing else is refused) and a box that is not
    :func:`finite` (its vertices are refused by name). The box is the object's local box
    (``bound_box``, after modifiers) carried by the piece's world matrix: it holds every
    vertex."""
    if not _mesh_data(ob) or not len(ob.data.polygons):
        return None
    corners = np.array(ob.bound_box, dtype=float)
    if corners.shape != (8, 3):
        return None
    m = piece.matrix
    world = corners @ m[:3, :3].T + m[:3, 3]
    if not finite(world):
        return None             # read, and refused by name
    lo, hi = world.min(0), world.max(0)
    centre, radius, points = within
    gap = np.linalg.norm(np.maximum(0.0, np.maximum(lo - centre, centre - hi)))
    if not gap > radius:
        return None
    if len(points) and bool(np.any(np.all((points >= lo) & (points <= hi), axis=1))):
        return None
    return np.concatenate([lo, hi]).tobytes()


def _content(ob, meshes, shared) -> tuple:
    """(signature, arrays): what an evaluated object's triangles are made of, as sizes and
    checksums: for a mesh its positions, its corners' vertices and the polygon of each
    triangle (which, with the corners, fixes every face's size); for a curve, surface,
    text or metaball the mesh Blender evaluates for it, whose (vertices, triangles) come
    back as ``arrays`` (they had to be read to be signed; None for a mesh). Read inside
    the depsgraph's iteration step; meshes shared by instances are read once (``meshes``,
    keyed like :func:`_triangles`'s ``shared``)."""
    if not _mesh_data(ob):
        v, t = _triangles(ob, shared)
        return ("tessellated", len(v), len(t), zlib.crc32(np.ascontiguousarray(v)),
                zlib.crc32(np.ascontiguousarray(t))), (v, t)
    mesh = ob.data
    key = (mesh.as_pointer(), len(mesh.vertices), len(mesh.loops))
    if key not in meshes:
        meshes[key] = _mesh_content(mesh)
    return meshes[key], None


def _mesh_content(mesh) -> tuple:
    mesh.calc_loop_triangles()
    n_v, n_c, n_t = len(mesh.vertices), len(mesh.loops), len(mesh.loop_triangles)
    co = _positions(mesh)
    corners = mesh.attributes.get(".corner_vert")
    faces = getattr(mesh, "loop_triangle_polygons", None)
    if corners is not None and corners.data_type == "INT" and faces is not None:
        cv = np.empty(n_c, dtype=np.int32)
        corners.data.foreach_get("value", cv)
        tp = np.empty(n_t, dtype=np.int32)
        faces.foreach_get("value", tp)
        return ("mesh", n_v, n_c, n_t, zlib.crc32(co), zlib.crc32(cv), zlib.crc32(tp))
    # Blender before 4.0: the triangles themselves (slower: ~150 ms for 1M triangles).
    tris = np.empty(n_t * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", tris)
    return ("mesh", n_v, n_c, n_t, zlib.crc32(co), zlib.crc32(tris))


def _positions(mesh) -> np.ndarray:
    """The vertices' positions, flat float32: through the ``position`` attribute where
    Blender has one (3.5 and later; 0.7 ms for 500k vertices, against 23 ms through
    ``vertices``)."""
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    attr = mesh.attributes.get("position")
    if attr is not None and attr.data_type == "FLOAT_VECTOR" and attr.domain == "POINT":
        attr.data.foreach_get("vector", co)
    else:
        mesh.vertices.foreach_get("co", co)
    return co


def _mesh_data(ob) -> bool:
    """Can an evaluated object's geometry be read from its mesh data directly (a mesh, not
    in edit mode)?"""
    return ob.type == "MESH" and ob.original.mode != "EDIT"


def _deformable(ob) -> bool:
    data = ob.data
    return bool(len(ob.modifiers) or getattr(data, "shape_keys", None) is not None
                or ob.mode == "EDIT" or (data is not None and data.animation_data is not None))


def _triangles(ob, cache):
    """Local-space vertices (N, 3) and triangles (M, 3) of an evaluated object, read now.
    Meshes shared by many instances (geometry-nodes scatters, particles) are read once per
    gather: ``cache`` is keyed by the mesh's address and sizes, valid while the depsgraph
    holds its evaluated geometry (the whole walk). Types that cannot give a mesh give none.
    A mesh in edit mode is read through ``to_mesh`` too: its evaluated mesh wraps the edit
    mesh and shows no vertices."""
    if _mesh_data(ob):
        mesh = ob.data
        key = (mesh.as_pointer(), len(mesh.vertices), len(mesh.loops))
        if key not in cache:
            cache[key] = _mesh_arrays(mesh)
        return cache[key]
    try:
        mesh = ob.to_mesh()
    except RuntimeError:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int32)
    try:
        return _mesh_arrays(mesh) if mesh is not None else (np.zeros((0, 3)),
                                                            np.zeros((0, 3), np.int32))
    finally:
        ob.to_mesh_clear()


def _mesh_arrays(mesh):
    """Vertices (N, 3) and triangles (M, 3) of a mesh. A mesh of triangles only is its own
    triangulation: its corners' vertices, read through the ``.corner_vert`` attribute
    (1M triangles: ~1 ms against 150–180 ms through ``loop_triangles``)."""
    mesh.calc_loop_triangles()
    n_t = len(mesh.loop_triangles)
    verts = _positions(mesh)
    corners = mesh.attributes.get(".corner_vert")
    if (corners is not None and corners.data_type == "INT" and len(mesh.polygons) == n_t
            and len(mesh.loops) == 3 * n_t):
        tris = np.empty(n_t * 3, dtype=np.int32)
        corners.data.foreach_get("value", tris)
    else:
        tris = np.empty(n_t * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", tris)
    return verts.reshape(-1, 3).astype(float), tris.reshape(-1, 3)


def reach_bounds(arm, settings: Settings, targets, body_extent: float = 0.0) -> tuple:
    """(centre, radius, target positions), world space: what :meth:`.scene.KeptObstacles.get`
    keeps obstacles within — the arm's reach sphere (:func:`~reach_addon.core.arm.reach_sphere`)
    with :data:`~reach_addon.core.arm.REACH_SLACK` and the clearance to spare, and any
    object holding a target. With *Lean* on the body moves the shoulder, and the sphere
    grows by twice ``body_extent`` (:func:`body_extent`: every posture keeps the shoulder
    tied to the planted feet by the body between, so it stays within that of where it
    was, and the body itself within it of the shoulder); with *Step* on, by as far as the
    steps may take it (``steps_max`` × ``step_length`` leg lengths, a leg no longer than
    ``body_extent``)."""
    centre, radius = reach_sphere(arm, REACH_SLACK + settings.clearance)
    if settings.lean:
        radius += 2.0 * float(body_extent)
    if settings.lean and settings.stepping:
        radius += settings.steps_max * settings.step_length * float(body_extent)
    return centre, radius, np.array([np.array(t.matrix_world.translation) for t in targets])


def body_extent(armature, shoulder) -> float:
    """The farthest any bone's head or tail lies from the ``shoulder`` (world), as the rig
    stands: a bound on the body's reach from the shoulder through its own chain."""
    mw = np.array(armature.matrix_world)
    pts = np.array([p for pb in armature.pose.bones for p in (pb.head, pb.tail)], dtype=float)
    if not len(pts):
        return 0.0
    world = pts @ mw[:3, :3].T + mw[:3, 3]
    return float(np.linalg.norm(world - np.asarray(shoulder, dtype=float), axis=1).max())
