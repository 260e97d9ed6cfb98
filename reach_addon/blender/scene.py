"""Scene → obstacles: every visible object with geometry (or one collection), evaluated,
in world space, as one BVH tree.

Geometry is read through the evaluated depsgraph, so modifiers, geometry nodes, curves,
text and collection instances count as the user sees them. Vertex positions and triangles
are pulled in bulk (``foreach_get``) and transformed with numpy; the tree is built once by
:meth:`reach_addon.core.Obstacles.from_triangles`.

Left out: the character's own meshes (deformed by or parented under the armature), the
targets, Reach's own visual feedback (the "Reach" collection), and hidden objects.
"""

from __future__ import annotations

import numpy as np

from ..core import Obstacles, ReachError

GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META"}
#: Custom property that marks objects Reach made (trajectory, markers): never obstacles.
VIZ_TAG = "reach_viz"


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


def _collection_objects(collection) -> set:
    return {ob.name for ob in collection.all_objects}


def gather_obstacles(context, exclude=(), collection=None, depsgraph=None) -> Obstacles:
    """One world-space BVH of the obstacles.

    ``exclude``: object names never to count (the character's meshes, the targets).
    ``collection``: if given, only objects in it (and its children) count; a collection
    whose objects have no faces is an error, since the user asked for those obstacles.
    """
    depsgraph = depsgraph or context.evaluated_depsgraph_get()
    exclude = set(exclude)
    allowed = _collection_objects(collection) if collection is not None else None
    viz = {ob.name for ob in context.scene.objects if ob.get(VIZ_TAG)}

    def wanted(original, parent_original):
        owner = parent_original if parent_original is not None else original
        name = original.name
        if owner.name in exclude or name in exclude or owner.name in viz or name in viz:
            return False
        if allowed is not None and owner.name not in allowed and name not in allowed:
            return False
        return owner.visible_get()

    verts, tris, owners, names = [], [], [], []
    offset = 0
    meshed_parents = set()
    pending = []
    for inst in depsgraph.object_instances:
        ob = inst.object
        if inst.is_instance and ob.type == "MESH" and inst.parent is not None:
            meshed_parents.add(inst.parent.original.name)
        if ob.type not in GEOMETRY_TYPES:
            continue
        parent = inst.parent.original if inst.is_instance and inst.parent is not None else None
        if not wanted(ob.original, parent):
            continue
        label = ob.original.name if parent is None else f"{parent.name}/{ob.original.name}"
        pending.append((ob, np.array(inst.matrix_world), label, inst.is_instance,
                        ob.original.name))

    for ob, matrix, label, is_instance, original_name in pending:
        if ob.type != "MESH" and not is_instance and original_name in meshed_parents:
            continue  # its evaluated geometry comes through as a mesh instance
        v, t = _triangles(ob)
        if len(t) == 0:
            continue
        verts.append(v @ matrix[:3, :3].T + matrix[:3, 3])
        tris.append(t + offset)
        owners.append(np.full(len(t), len(names)))
        names.append(label)
        offset += len(v)

    if not tris:
        if collection is not None:
            raise ReachError(
                f"the obstacle collection '{collection.name}' has no visible objects with "
                "faces; add meshes to it or plan against all visible objects")
        return Obstacles(None)
    return Obstacles.from_triangles(np.concatenate(verts), np.concatenate(tris),
                                    np.concatenate(owners), names)


def _triangles(ob):
    """Local-space vertices (N, 3) and triangles (M, 3) of an evaluated object."""
    mesh = ob.to_mesh() if ob.type != "MESH" else ob.data
    try:
        mesh.calc_loop_triangles()
        n_v, n_t = len(mesh.vertices), len(mesh.loop_triangles)
        verts = np.empty(n_v * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", verts)
        tris = np.empty(n_t * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", tris)
        return verts.reshape(-1, 3).astype(float), tris.reshape(-1, 3)
    finally:
        if ob.type != "MESH":
            ob.to_mesh_clear()
