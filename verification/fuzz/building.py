"""The fuzz campaign's scenes built in Blender, around a synthetic or a real rig.

:func:`build` makes a scene description (:func:`verification.fuzz.scenes.generate`) a
``.blend`` file: the rig (a synthetic humanoid or a test rig, :func:`verification.rig_builders`)
under the scene's stage transform, its targets and obstacles placed in the rig's own body
frame (:class:`Placement`) and sized by its own arm length, and returns the manifest the
checks need (:func:`verification.fuzz.checks.verify`, :func:`~verification.fuzz.checks.classify`):
which objects are obstacles by the README's rules (*What counts as an obstacle*), which
move, the targets, the names a refusal may give, and whether the input must be refused.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import rig_builders
from ..geometry import unit
from .scenes import NO_SURFACE, quat_matrix


def rig_proportions(rig: dict):
    """The ``proportions`` dict of a synthetic rig's shape (``synthetic.shape``), or None
    for the standard one (a spec without a shape: the campaigns before it)."""
    _rigs, synthetic = rig_builders()
    shape = rig.get("shape")
    if shape is None:
        return None
    return synthetic.shape(pose=shape["pose"], elbow_bend_deg=shape["elbow_bend_deg"],
                           elbow_bend_dir=shape["elbow_bend_dir"],
                           forearm_ratio=shape["forearm_ratio"])


def _bpy():
    import bpy

    return bpy


def _matrix(m):
    from mathutils import Matrix

    return Matrix(np.asarray(m, dtype=float).tolist())


def translation(p) -> np.ndarray:
    """The 4 × 4 matrix moving by ``p``."""
    m = np.eye(4)
    m[:3, 3] = p
    return m


def stage_matrix(stage: dict) -> np.ndarray:
    """The world transform every placed object and the rig are put under: translate ·
    rotate · uniform scale · mirror."""
    m = np.eye(4)
    rot = np.eye(3) if stage["rotation"] is None else quat_matrix(stage["rotation"])
    mirror = np.ones(3)
    if stage["mirror"] is not None:
        mirror[stage["mirror"]] = -1.0
    m[:3, :3] = rot @ np.diag(mirror) * stage["scale"]
    m[:3, 3] = np.asarray(stage["translate"], dtype=float) * stage["scale"]
    return m


_UNIT_BOX_VERTS = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
_UNIT_BOX_FACES = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
_UNIT_BOX_EDGES = [(0, 1), (1, 3), (3, 2), (2, 0), (4, 5), (5, 7), (7, 6), (6, 4), (0, 4), (1, 5),
                   (2, 6), (3, 7)]


def _geometry(o: dict):
    """(vertices, edges, faces) of an obstacle kind, in a unit cube round the origin."""
    kind = o["kind"]
    box_v, box_f = list(_UNIT_BOX_VERTS), list(_UNIT_BOX_FACES)
    if kind in ("box", "thin_wall", "zero_scale", "flat_scale", "linked_mesh"):
        return box_v, [], box_f
    if kind == "plane":
        return [(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)], [], [(0, 1, 2, 3)]
    if kind == "open_mesh":
        return box_v, [], [f for i, f in enumerate(box_f) if i not in o["drop_faces"]]
    if kind == "flipped_faces":
        return box_v, [], [tuple(reversed(f)) if i in o["flip_faces"] else f
                           for i, f in enumerate(box_f)]
    if kind == "tube":
        n = 8
        verts = [(0.5 * math.cos(2 * math.pi * k / n), 0.5 * math.sin(2 * math.pi * k / n), z)
                 for z in (-0.5, 0.5) for k in range(n)]
        return verts, [], [(k, (k + 1) % n, n + (k + 1) % n, n + k) for k in range(n)]
    if kind == "non_manifold":
        verts = box_v + [(0.5, 0.5, 1.2), (0.5, -0.5, 1.2),            # a fin on an edge
                         (-0.4, -0.4, 0), (0.4, -0.4, 0), (0.4, 0.4, 0), (-0.4, 0.4, 0),  # inner face
                         (0.9, 0.9, 0.9), (1.2, 1.2, 1.2), (-1.0, 0.0, 0.0)]  # loose edge, vertex
        faces = box_f + [(5, 7, 8, 9), (10, 11, 12, 13), box_f[0]]     # fin, inner, duplicate
        return verts, [(14, 15)], faces
    if kind == "collapsed_mesh":
        return [(0.0, 0.0, 0.0)] * 8, [], box_f
    if kind == "edges_only":
        return box_v, list(_UNIT_BOX_EDGES), []
    if kind == "empty_mesh":
        return [], [], []
    if kind == "dense_mesh":
        seg, rings = 16, 8
        verts = [(0.0, 0.0, -0.5)]
        for r in range(1, rings):
            phi = math.pi * r / rings - math.pi / 2
            verts += [(0.5 * math.cos(phi) * math.cos(2 * math.pi * k / seg),
                       0.5 * math.cos(phi) * math.sin(2 * math.pi * k / seg), 0.5 * math.sin(phi))
                      for k in range(seg)]
        verts.append((0.0, 0.0, 0.5))
        top = len(verts) - 1
        faces = [(0, 1 + (k + 1) % seg, 1 + k) for k in range(seg)]
        for r in range(rings - 2):
            a, b = 1 + r * seg, 1 + (r + 1) * seg
            faces += [(a + k, a + (k + 1) % seg, b + (k + 1) % seg, b + k) for k in range(seg)]
        last = 1 + (rings - 2) * seg
        faces += [(last + k, last + (k + 1) % seg, top) for k in range(seg)]
        return verts, [], faces
    if kind == "modifier":
        if o["modifier"] == "SOLIDIFY":
            return [(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)], [], [(0, 1, 2, 3)]
        if o["modifier"] == "MIRROR":
            return [(x * 0.4 + 0.3, y, z) for x, y, z in box_v], [], box_f
        return [(x * 0.4, y, z) for x, y, z in box_v], [], box_f
    raise ValueError(kind)


class Placement:
    """The rig's body frame at its base transform (before the stage): where body-frame
    points (arm lengths, x toward the reaching side) are in world space. Read with the rig
    adapter (:meth:`from_rig`) or, for a synthetic rig the adapter cannot read, from the
    synthetic construction itself (:meth:`from_synthetic`), so that the scene is still
    built and the bake's refusal is what is checked."""

    def __init__(self, armature, side, right, forward, up, origin, half, length, joints,
                 other_shoulder, hand_length, hand_radius, bones):
        s = 1.0 if side == "right" else -1.0
        self.side = side
        self.length = float(length)
        self.up, self.forward = unit(up), unit(forward)
        self.basis = np.column_stack([s * unit(right), self.forward, self.up])
        self.origin = np.asarray(origin, dtype=float)
        self.half = float(half)
        self.joints = {k: np.asarray(v, dtype=float) for k, v in joints.items()}
        self.other_shoulder = np.asarray(other_shoulder, dtype=float)
        self.hand_length, self.hand_radius = float(hand_length), float(hand_radius)
        self.bones = bones          # role -> bone name, for targets carried by a bone
        mw = np.array(armature.matrix_world)
        ends = np.array([mw[:3, :3] @ np.array(p) + mw[:3, 3] for b in armature.data.bones
                         for p in (b.head_local, b.tail_local)])
        self.floor = float(((ends - self.origin) @ self.up).min())      # world units, along up

    @classmethod
    def from_rig(cls, armature, side):
        from reach_addon.blender import rig as rig_mod

        info = rig_mod.build(armature, side)
        other = "left" if side == "right" else "right"
        other_info = rig_mod.build(armature, other)
        f, b = info.frame, info.bones
        hips = armature.data.bones[b.chest]
        while hips.parent is not None:
            hips = hips.parent
        bones = {"chest": b.chest, "neck": b.neck or b.chest, "hips": hips.name,
                 "other_hand": b.arms[other].hand, "own_hand": b.arms[side].hand,
                 "own_forearm": b.arms[side].forearm}
        return cls(armature, side, f.right, f.forward, f.up, f.origin, f.shoulder_half_width,
                   info.arm.arm_length, info.joints_world, other_info.joints_world["shoulder"],
                   info.arm.hand_length, info.arm.hand_radius, bones)

    @classmethod
    def from_synthetic(cls, armature, rig: dict, side):
        _rigs, synthetic = rig_builders()

        def world(p):
            return synthetic.to_world(p, facing=rig["facing"], lying=rig["lying"])

        tag, other = ("R", "L") if side == "right" else ("L", "R")
        proportions = rig_proportions(rig)
        joints = {k: world(v) for k, v in synthetic.arm_joints(tag, proportions).items()}
        names = synthetic.MAPS[rig["map"]]
        lengths = synthetic._proportions(proportions)["arm_lengths"]
        hand_length = 0.74 * lengths[1]
        palms = (rig.get("shape") or {}).get("palms", 0)

        def hand(t):    # sibling palms have no hand bone: the first palm carries a target
            return synthetic.palm_name(names, t, 1) if palms else names[f"hand_{t}"]

        bones = {"chest": names["chest"], "neck": names["neck"], "hips": names["hips"],
                 "other_hand": hand(other), "own_hand": hand(tag),
                 "own_forearm": names[f"forearm_{tag}"]}
        origin = world((0.0, 0.0, synthetic.SHOULDER_Z))
        return cls(armature, side, world((-1.0, 0, 0)), world((0, -1.0, 0)), world((0, 0, 1.0)),
                   origin, synthetic.SHOULDER_HALF_WIDTH, sum(lengths),
                   joints, world(synthetic.arm_joints(other, proportions)["shoulder"]), hand_length,
                   0.18 * hand_length, bones)

    def vector(self, v) -> np.ndarray:
        return self.length * (self.basis @ np.asarray(v, dtype=float))

    def body_point(self, name: str) -> np.ndarray:
        h, o, up, fw = self.half, self.origin, self.up, self.forward
        return {
            "shoulder": self.joints["shoulder"], "elbow": self.joints["elbow"],
            "wrist": self.joints["wrist"], "chest": o - 0.8 * h * up,
            "head": o + 1.2 * h * up + 0.1 * h * fw, "pelvis": o - 2.5 * h * up,
            "shoulder_other": self.other_shoulder,
            "chest_front": o - 0.8 * h * up + 0.68 * h * fw,
            "belly_front": o - 2.0 * h * up + 0.74 * h * fw,
        }[name]

    def target(self, t: dict) -> np.ndarray:
        return self.body_point(t["at"]) + self.vector(np.asarray(t["dir"]) * t["dist"])


def make_library(path: Path):
    """A library file: collection FzLib holding FzLibBox (mesh FzLibMesh, a unit cube)."""
    bpy = _bpy()
    bpy.ops.wm.read_homefile(use_empty=True)
    mesh = bpy.data.meshes.new("FzLibMesh")
    mesh.from_pydata(_UNIT_BOX_VERTS, [], _UNIT_BOX_FACES)
    ob = bpy.data.objects.new("FzLibBox", mesh)
    coll = bpy.data.collections.new("FzLib")
    bpy.context.scene.collection.children.link(coll)
    coll.objects.link(ob)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))


class RigCache:
    """The real rigs, loaded once per worker process and saved as plain .blend files
    (importing FBX or generating Rigify every scene would dominate the time)."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.files: dict = {}

    def open(self, kind: str):
        bpy = _bpy()
        rigs, _synthetic = rig_builders()
        if kind not in self.files:
            arm = rigs.load(kind)
            rigs.rest_still(arm)
            path = self.folder / f"rig-{kind}.blend"
            bpy.ops.wm.save_as_mainfile(filepath=str(path))
            self.files[kind] = (path, arm.name)
        path, name = self.files[kind]
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
        return bpy.data.objects[name]


def _load_rig(spec, cache: RigCache, workdir: Path):
    """The rig of the scene, in an otherwise empty file; returns the armature."""
    bpy = _bpy()
    _rigs, synthetic = rig_builders()
    rig = spec["rig"]
    if rig["kind"] == "synthetic":
        bpy.ops.wm.read_homefile(use_empty=True)
        shape = rig.get("shape") or {}
        hand = shape.get("hand", "bone")
        arm = synthetic.humanoid(synthetic.MAPS[rig["map"]], facing=rig["facing"],
                                 scale=rig["own_scale"], lying=rig["lying"],
                                 skin=rig["skin"] and not shape.get("rigid", False),
                                 decoy=rig["decoy"], clavicle=rig["clavicle"], twist=rig["twist"],
                                 name="FzRig", skin_radius=rig["skin_radius"],
                                 proportions=rig_proportions(rig),
                                 hand="bone" if hand == "palms" else hand,
                                 palms=shape.get("palms", 0), fingers=shape.get("fingers", 1),
                                 roll=shape.get("roll"),
                                 hand_roll_deg=shape.get("hand_roll_deg", 0.0),
                                 rigid=shape.get("rigid", False))
    else:
        arm = cache.open(rig["kind"])
    if spec["linked_armature"]:
        lib = workdir / "rig-library.blend"
        name = arm.name
        bpy.ops.wm.save_as_mainfile(filepath=str(lib))
        bpy.ops.wm.read_homefile(use_empty=True)
        with bpy.data.libraries.load(str(lib), link=True, relative=False) as (src, dst):
            dst.objects = list(src.objects)
        for ob in dst.objects:
            if ob is not None:
                bpy.context.scene.collection.objects.link(ob)
        arm = bpy.data.objects[name]
    bpy.context.view_layer.update()
    return arm


def _new_object(name, data, collection, parent=None, local=None):
    bpy = _bpy()
    ob = bpy.data.objects.new(name, data)
    collection.objects.link(ob)
    if parent is not None:
        ob.parent = parent
        ob.matrix_parent_inverse = _matrix(np.eye(4))
    if local is not None:
        ob.matrix_basis = _matrix(local)
    return ob


def _key_motion(ob, frame0: int, frames: int, delta, spin_deg: float):
    """Keys on ``ob``'s location (and its turn about its local z) from ``frame0`` to
    ``frame0 + frames``."""
    loc0 = np.array(ob.location)
    rot0 = np.array(ob.rotation_euler)
    ob.keyframe_insert("location", frame=frame0)
    ob.keyframe_insert("rotation_euler", frame=frame0)
    ob.location = (loc0 + np.asarray(delta)).tolist()
    ob.rotation_euler = (rot0 + np.array([0.0, 0.0, math.radians(spin_deg)])).tolist()
    ob.keyframe_insert("location", frame=frame0 + frames)
    ob.keyframe_insert("rotation_euler", frame=frame0 + frames)
    ob.location, ob.rotation_euler = loc0.tolist(), rot0.tolist()


def build(spec: dict, cache: RigCache, workdir: Path, library: Path) -> dict:
    """Build the scene description ``spec`` in Blender and save it as
    ``workdir/input.blend`` (``cache``: the real rigs; ``library``: the file
    :func:`make_library` wrote, linked by the linked obstacles). Returns the manifest (JSON
    values): ``input`` (the file) and ``files`` (it and the libraries it links: a bake must
    leave them unchanged), ``armature``, ``targets`` (``name``; ``ref``, where the wrist
    must end: the target at the first frame, ``start``, or where it is at the last,
    ``end``; ``nan``), ``solids`` (the obstacles that count, by the README's rules) and
    ``movers`` (those that move), ``names`` (every object and collection), ``culprits``
    (the names a refusal may give), ``must_refuse`` (the input is bad: exit status 2
    expected) and ``arm_length`` (world units)."""
    bpy = _bpy()
    from reach_addon.core import ReachError

    arm = _load_rig(spec, cache, workdir)
    scene = bpy.context.scene
    fs = spec["frame_current"]
    side = spec["side"]
    try:
        place = Placement.from_rig(arm, side)
    except ReachError:
        if spec["rig"]["kind"] != "synthetic":
            raise
        place = Placement.from_synthetic(arm, spec["rig"], side)
    L = place.length
    G = stage_matrix(spec["stage"])
    culprits: set = set()       # names a refusal may give
    must_refuse = False         # the input is bad: exit 2 expected
    root = scene.collection

    # the rig under the stage transform
    rig_roots = [ob for ob in scene.objects if ob.parent is None]
    rig_parent = None
    if spec["armature_parented"]:
        rig_parent = _new_object("FzRigParent", None, root)
        pm = G.copy()
        if spec["non_uniform"] and spec["non_uniform"]["on"] == "parent":
            pm[:3, :3] = pm[:3, :3] @ np.diag(spec["non_uniform"]["scale"])
            culprits |= {"FzRigParent", arm.name}
            must_refuse = True
        rig_parent.matrix_world = _matrix(pm)
    if not spec["linked_armature"]:
        for ob in rig_roots:
            base = np.array(ob.matrix_world)
            if rig_parent is not None:
                ob.parent = rig_parent
                ob.matrix_parent_inverse = _matrix(np.eye(4))
                ob.matrix_basis = _matrix(base)
            else:
                ob.matrix_world = _matrix(G @ base)
        if spec["non_uniform"] and spec["non_uniform"]["on"] == "armature":
            arm.scale = (np.array(arm.scale) * np.array(spec["non_uniform"]["scale"])).tolist()
            culprits.add(arm.name)
            must_refuse = True
    else:
        culprits.add(arm.name)
        must_refuse = True
    stage = _new_object("FzStage", None, root)
    stage.matrix_world = _matrix(G)
    bpy.context.view_layer.update()

    collections = {}

    def collection(name):
        if name not in collections:
            c = bpy.data.collections.new(name)
            root.children.link(c)
            collections[name] = c
        return collections[name]

    # the targets
    targets_w = []
    manifest_targets = []
    deferred_bone_targets = []
    for t in spec["targets"]:
        p = place.target(t)
        targets_w.append(p)
        parent = t["parent"]
        name = t["name"]
        ref = "end" if spec["task"] == "chase" else "start"
        if parent is None:
            ob = _new_object(name, None, root, stage, translation(p))
        elif parent["kind"] == "moving":
            offset = place.vector([0.1, 0.0, 0.0])
            carrier = _new_object(f"FzCarrier{t['index']}", None, root, stage, translation(p - offset))
            carrier.rotation_mode = "XYZ"
            _key_motion(carrier, fs, parent["frames"], place.vector(parent["delta"]),
                        parent["spin_deg"])
            ob = _new_object(name, None, root, carrier, translation(offset))
        else:
            ob = _new_object(name, None, root)
            deferred_bone_targets.append((ob, parent["role"], p))
            ref = "end"
        ob.empty_display_type = "SPHERE"
        ob.empty_display_size = 0.02 * L
        manifest_targets.append({"name": ob.name, "ref": ref, "nan": t["nan"]})
        if t["nan"]:
            culprits.add(ob.name)
            must_refuse = True
        if parent is not None and parent["kind"] == "bone" and parent["role"].startswith("own"):
            culprits.add(ob.name)   # carried by the reaching arm: refused, naming it
        if spec["task"] == "chase" and (parent is None or parent["kind"] != "moving"):
            culprits.add(ob.name)   # nothing moves it: a chase is refused, naming it
    bpy.context.view_layer.update()
    for ob, role, p in deferred_bone_targets:
        name = place.bones[role]
        ob.parent = arm
        ob.parent_type = "BONE"
        ob.parent_bone = name
        bpy.context.view_layer.update()
        ob.matrix_world = _matrix(G @ translation(p))
    bpy.context.view_layer.update()

    # the obstacles
    solids, movers = [], []
    nan_vertex = []             # still obstacles with a NaN vertex
    use_collection = spec["obstacle_collection"]
    linked = None
    wrist = place.joints["wrist"]
    hand_dir = wrist - place.joints["elbow"]
    hand_dir /= np.linalg.norm(hand_dir)
    for o in spec["obstacles"]:
        i = o["index"]
        name = f"Fz{o['kind'].title().replace('_', '')}{i}"
        tgt = targets_w[o["target"]]
        size = np.asarray(o["size"], dtype=float)
        rot = place.basis @ (np.eye(3) if o["rotation"] is None else quat_matrix(o["rotation"]))
        if o["placement"] == "across":
            centre = wrist + o["t"] * (tgt - wrist) + place.vector(o["jitter"])
            path = tgt - wrist
            if o["face_path"] and np.linalg.norm(path) > 1e-6 * L:
                normal = path / np.linalg.norm(path)
                across = np.cross(normal, place.up)
                if np.linalg.norm(across) < 1e-6:
                    across = np.cross(normal, place.forward)
                across /= np.linalg.norm(across)
                rot = np.column_stack([across, np.cross(normal, across), normal])
        elif o["placement"] == "near_target":
            rot = place.basis
            centre = tgt - place.up * L * (0.06 + 0.5 * min(size[2], 0.3)) + place.vector(
                np.array(o["jitter"]) * [1, 1, 0])
        elif o["placement"] == "around":
            centre = place.joints["shoulder"] + place.vector(o["around"])
        else:   # under the hand: its top just below the wrist, touching the hand's capsule
            rot = place.basis
            size = size * [1, 1, 0.5]
            tip = wrist + hand_dir * place.hand_length
            low = min((wrist - place.origin) @ place.up, (tip - place.origin) @ place.up)
            top = low - 0.5 * place.hand_radius
            centre = 0.5 * (wrist + tip)
            centre = centre + place.up * (top - (centre - place.origin) @ place.up - 0.5 * size[2] * L)
        scale = size * L
        if o["kind"] == "zero_scale":
            scale = np.zeros(3)
        elif o["kind"] == "flat_scale":
            scale[2] = 0.0
        local = np.eye(4)
        local[:3, :3] = rot @ np.diag(scale)
        local[:3, 3] = centre

        vis = o["visibility"]
        if vis == "excluded_collection":
            coll = collection("FzExcluded")
        elif vis == "hidden_collection":
            coll = collection("FzHiddenCollection")
        elif use_collection and i % 2 == 0:
            coll = collection("FzObstacles")
        else:
            coll = root
        parent = stage
        if o["animated"] and o["animated"]["kind"] == "parent":
            parent = _new_object(f"FzMover{i}", None, root, stage, np.eye(4))
            parent.rotation_mode = "XYZ"
        if o["kind"] == "linked_instance":
            if linked is None:
                with bpy.data.libraries.load(str(library), link=True, relative=True) as (src, dst):
                    dst.collections = ["FzLib"]
                    dst.meshes = ["FzLibMesh"]
                linked = bpy.data.collections["FzLib"]
            ob = _new_object(name, None, coll, parent, local)
            ob.instance_type = "COLLECTION"
            ob.instance_collection = linked
        elif o["kind"] == "linked_mesh":
            if linked is None:
                with bpy.data.libraries.load(str(library), link=True, relative=True) as (src, dst):
                    dst.collections = ["FzLib"]
                    dst.meshes = ["FzLibMesh"]
                linked = bpy.data.collections["FzLib"]
            ob = _new_object(name, bpy.data.meshes["FzLibMesh"], coll, parent, local)
        else:
            verts, edges, faces = _geometry(o)
            mesh = bpy.data.meshes.new(name)
            mesh.from_pydata(verts, edges, faces)
            if o["nan"] == "vertex":
                mesh.vertices[0].co = (float("nan"), 0.0, 0.0)
            ob = _new_object(name, mesh, coll, parent, local)
            if o["kind"] == "modifier":
                mod = ob.modifiers.new("FzModifier", o["modifier"])
                if o["modifier"] == "SOLIDIFY":
                    mod.thickness = 0.05
                elif o["modifier"] == "ARRAY":
                    mod.count = 3
                elif o["modifier"] == "SUBSURF":
                    mod.levels = 1
        if o["animated"]:
            a = o["animated"]
            mover = parent if a["kind"] == "parent" else ob
            if a["kind"] == "keys":
                ob.rotation_mode = "XYZ"
            _key_motion(mover, fs, a["frames"], place.vector(a["delta"]), a["spin_deg"])
        if vis == "hidden":
            ob.hide_set(True)
        elif vis == "disabled":
            ob.hide_viewport = True
        elif vis == "render_hidden":
            ob.hide_render = True
        counts = vis in ("visible", "render_hidden") and (not use_collection or coll.name == "FzObstacles")
        if o["nan"] in ("nan", "inf"):
            value = float("nan") if o["nan"] == "nan" else float("inf")
            ob.location = (value, 0.0, 0.0)
        keyed = o["animated"] is not None and o["animated"]["kind"] == "keys"
        if keyed and o["nan"] in ("nan", "inf"):
            pass    # its location is animated: the keys set it on every frame, NaN or not
        elif counts and o["nan"] == "vertex" and o["kind"] not in ("edges_only", "empty_mesh"):
            # A Plan does not read an object whose box lies beyond the arm's reach (the
            # README's "Only what the arm can reach"; Blender's box skips the NaN vertex).
            # Within 1.5 arm lengths of the shoulder it is surely read, hence refused (see
            # below); farther, the bake may go on, and then the check holds the arm to its
            # finite faces (solid_triangles drops the NaN ones). A mesh with no faces is no
            # obstacle at all (seeds 4456, 8867: bare edges): nothing is read, nothing
            # refused.
            culprits.add(ob.name)
            if not o["animated"]:
                nan_vertex.append(ob)
        elif counts and o["nan"] and o["kind"] not in ("edges_only", "empty_mesh"):
            culprits.add(ob.name)
            must_refuse = True
        if counts and o["kind"] not in NO_SURFACE and o["nan"] in (None, "vertex"):
            solids.append(ob.name)
            if o["animated"]:
                movers.append(ob.name)
    if "FzHiddenCollection" in collections:
        collections["FzHiddenCollection"].hide_viewport = True
    if "FzExcluded" in collections:
        bpy.context.view_layer.layer_collection.children["FzExcluded"].exclude = True
    if use_collection:
        coll = collection("FzObstacles")
        culprits.add(coll.name)
    if spec["floor"] or spec["room"]:
        up_level = place.floor
        if spec["floor"]:
            local = np.eye(4)
            local[:3, :3] = place.basis @ np.diag([8 * L, 8 * L, 1.0])
            local[:3, 3] = place.origin + place.up * up_level
            mesh = bpy.data.meshes.new("FzFloor")
            mesh.from_pydata([(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)], [],
                             [(0, 1, 2, 3)])
            ob = _new_object("FzFloor", mesh, root, stage, local)
            if not use_collection:
                solids.append(ob.name)
        if spec["room"]:
            height = place.length * 1.5 - up_level
            local = np.eye(4)
            local[:3, :3] = place.basis @ np.diag([5 * L, 5 * L, height + 0.4 * L])
            local[:3, 3] = place.origin + place.up * (up_level - 0.2 * L + 0.5 * (height + 0.4 * L))
            mesh = bpy.data.meshes.new("FzRoom")
            mesh.from_pydata(_UNIT_BOX_VERTS, [], _UNIT_BOX_FACES)
            ob = _new_object("FzRoom", mesh, root, stage, local)
            if not use_collection:
                solids.append(ob.name)

    if spec.get("euler_bones"):
        for pb in arm.pose.bones:          # Blender converts the pose to the new order
            pb.rotation_mode = spec["euler_bones"]
    moves = spec.get("body_moves")
    mover = None
    if moves:
        # the armature (or what carries it) walks off while the arm reaches: the bake
        # must refuse naming it, fail with a reason, or be verified on target as it is
        mover = rig_parent if rig_parent is not None else arm
        _key_motion(mover, fs, moves["frames"],
                    place.vector(moves["delta"]) * moves["arm_lengths"], moves["spin_deg"])
    if spec["new_action"]:
        root_bone = next(b for b in arm.pose.bones if b.parent is None)
        root_bone.keyframe_insert("location", frame=fs)
    if spec["armature_nan"] and not spec["linked_armature"]:
        value = float("nan") if spec["armature_nan"] == "nan" else float("inf")
        arm.location = (value, arm.location[1], arm.location[2])
        # where the armature's own location is keyed (body_moves), its curves put a finite
        # location back on every frame: the input is not bad then
        if mover is not arm:
            culprits.add(arm.name)
            must_refuse = True
    for t, m in zip(spec["targets"], manifest_targets):
        if t["nan"]:
            ob = bpy.data.objects[m["name"]]
            ob.location = (float("nan") if t["nan"] == "nan" else float("inf"), 0.0, 0.0)
    scene.frame_current = fs
    bpy.context.view_layer.update()
    if nan_vertex and _near_shoulder(nan_vertex, G, place, 1.5):
        must_refuse = True
    scene.frame_start = min(fs, scene.frame_start)
    scene.frame_end = max(scene.frame_end, fs + 60)
    bpy.context.view_layer.update()
    path = workdir / "input.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), relative_remap=True)
    files = [path] + ([library] if linked is not None else [])
    if spec["linked_armature"]:
        files.append(workdir / "rig-library.blend")
    return {"input": str(path), "files": [str(f) for f in files], "armature": arm.name,
            "targets": manifest_targets, "solids": solids, "movers": movers,
            "names": sorted({ob.name for ob in bpy.data.objects} | set(collections)),
            "culprits": sorted(culprits), "must_refuse": must_refuse,
            "arm_length": L * spec["stage"]["scale"]}


def _near_shoulder(objects, G, place, reach: float) -> bool:
    """Whether the box of any object's finite vertices (world, evaluated now) comes within
    ``reach`` arm lengths of the reaching shoulder in its start pose. Any point within
    1.5 arm lengths of the shoulder lies inside the arm's reach sphere (its radius is at
    least the shoulder's distance from the spine plus arm, hand and half an arm), so such
    an object is read by a Plan."""
    bpy = _bpy()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    shoulder = G[:3, :3] @ place.joints["shoulder"] + G[:3, 3]
    length = place.length * np.linalg.norm(G[:3, 0])
    for ob in objects:
        ev = ob.evaluated_get(depsgraph)
        co = np.array([v.co for v in ev.data.vertices], dtype=float).reshape(-1, 3)
        co = co[np.isfinite(co).all(axis=1)]
        if not len(co):
            continue
        m = np.array(ev.matrix_world)
        world = co @ m[:3, :3].T + m[:3, 3]
        lo, hi = world.min(0), world.max(0)
        if np.linalg.norm(np.maximum(0.0, np.maximum(lo - shoulder, shoulder - hi))) <= reach * length:
            return True
    return False
