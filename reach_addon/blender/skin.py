"""The skin an armature moves: which bones move it, where its vertices are, how thick it
is round a segment, and how close the reaching arm's skin is to the obstacles.

Skin is the meshes whose Armature modifier uses the armature (vertices weighted to a
bone's vertex group) and the rigid parts parented to its bones (every vertex of the part).
Positions are world space, as Blender evaluates them at the current frame.
"""

from __future__ import annotations

import bpy
import numpy as np


def deformed_by(ob, armature) -> bool:
    """Is ``ob`` a mesh whose Armature modifier uses ``armature`` (its skin)?"""
    return ob.type == "MESH" and any(m.type == "ARMATURE" and m.object == armature
                                     for m in ob.modifiers)


def rigid_part(ob, armature) -> str | None:
    """The bone a mesh is parented to, if it is a rigid part of ``armature`` (a robot's or
    a prop-built character's body: no skin, each part carried by one bone), else None."""
    if ob.type == "MESH" and ob.parent == armature and ob.parent_type == "BONE" and \
            ob.parent_bone in armature.data.bones and not deformed_by(ob, armature):
        return ob.parent_bone
    return None


def skin_bones(armature) -> set:
    """Names of bones that move skin: vertex groups with weighted vertices in meshes whose
    Armature modifier uses this armature, and bones that carry rigid parts (meshes
    parented to them)."""
    out = set()
    for ob in scene_objects(armature):
        bone = rigid_part(ob, armature)
        if bone is not None and len(ob.data.vertices):
            out.add(bone)
        if not deformed_by(ob, armature):
            continue
        names = {vg.index: vg.name for vg in ob.vertex_groups}
        weighted = set()
        for v in ob.data.vertices:
            for g in v.groups:
                if g.weight > 0.0:
                    weighted.add(g.group)
        out |= {names[i] for i in weighted if i in names}
    return out


def _chosen(ob, armature, bone_names, weight: float, share: bool) -> np.ndarray:
    """Which vertices of ``ob`` (a mesh the armature deforms) ``bone_names`` move: weighted
    at least ``weight`` to one of their vertex groups, or with ``share`` whose weights on
    those groups add up to at least ``weight`` of their weights on all the armature's bones
    (a vertex shared by a hand's bones and its fingers, 0.3 and 0.3, is the hand's)."""
    idx = {vg.index for vg in ob.vertex_groups if vg.name in bone_names}
    out = np.zeros(len(ob.data.vertices), dtype=bool)
    if not idx:
        return out
    bones = {vg.index for vg in ob.vertex_groups if vg.name in armature.data.bones}
    for v in ob.data.vertices:
        if share:
            total = sum(g.weight for g in v.groups if g.group in bones)
            mine = sum(g.weight for g in v.groups if g.group in idx)
            out[v.index] = total > 0.0 and mine >= weight * total
        else:
            out[v.index] = any(g.group in idx and g.weight >= weight for g in v.groups)
    return out


def _skin_meshes(armature, bone_names, weight: float, share: bool, chosen=None):
    """(evaluated mesh, its world vertices (V, 3), which of them ``bone_names`` move (a
    boolean mask; all of a rigid part's)) of each mesh that moves with those bones
    (:func:`skin_points`' choice), as Blender evaluates it now. A mesh whose evaluated
    vertices do not match its own (a modifier that adds geometry) is left out. ``chosen``:
    a dict (object name → mask) that keeps the masks for the next call with the same bones,
    where the skin is read frame after frame (the choice walks every vertex's weights)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for ob in scene_objects(armature):
        rigid = rigid_part(ob, armature)
        if rigid is None and not deformed_by(ob, armature):
            continue
        if rigid is not None and rigid not in bone_names:
            continue
        ev = ob.evaluated_get(depsgraph)
        mesh = ev.data
        if len(mesh.vertices) != len(ob.data.vertices) or not len(mesh.vertices):
            continue
        mine = None if chosen is None else chosen.get(ob.name)
        if mine is None:
            mine = np.ones(len(mesh.vertices), dtype=bool) if rigid is not None else \
                _chosen(ob, armature, bone_names, weight, share)
            if chosen is not None:
                chosen[ob.name] = mine
        if not mine.any():
            continue
        co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
        mw = np.array(ev.matrix_world)
        yield mesh, co.reshape(-1, 3).astype(float) @ mw[:3, :3].T + mw[:3, 3], mine


def skin_points(armature, bone_names, weight: float = 0.5, share: bool = False,
                chosen=None) -> np.ndarray:
    """World positions (n, 3) of the skin that ``bone_names`` move, as Blender evaluates it
    now: the vertices weighted at least ``weight`` to their vertex groups (``share``: by the
    share of their weights, :func:`_chosen`) in the meshes the armature deforms, and every
    vertex of the rigid parts parented to them. Empty (0, 3) where these bones move no
    skin. ``chosen``: see :func:`_skin_meshes` (pass the same dict on every frame)."""
    out = [co[mine] for _mesh, co, mine in _skin_meshes(armature, bone_names, weight, share,
                                                        chosen)]
    return np.concatenate(out) if out else np.zeros((0, 3))


def skin_triangles(armature, bone_names, weight: float = 0.5, share: bool = False) -> np.ndarray:
    """World triangles (T, 3, 3) of the skin that ``bone_names`` move, as Blender evaluates
    it now: the triangles of the meshes the armature deforms whose three vertices are all
    chosen as :func:`skin_points` chooses them, and every triangle of the rigid parts
    parented to them. Empty (0, 3, 3) where there are none."""
    out = []
    for mesh, co, mine in _skin_meshes(armature, bone_names, weight, share):
        mesh.calc_loop_triangles()
        tri = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
        mesh.loop_triangles.foreach_get("vertices", tri)
        tri = tri.reshape(-1, 3)
        out.append(co[tri[mine[tri].all(axis=1)]])
    return np.concatenate(out) if out else np.zeros((0, 3, 3))


def surface_samples(triangles, spacing: float) -> np.ndarray:
    """Points (N, 3) on triangles (T, 3, 3): each one's corners and a barycentric grid
    fine enough that no two neighbours are more than ``spacing`` apart along an edge."""
    tris = np.asarray(triangles, dtype=float).reshape(-1, 3, 3)
    if not len(tris):
        return np.zeros((0, 3))
    edges = np.linalg.norm(tris - np.roll(tris, 1, axis=1), axis=2).max(axis=1)
    out = [tris.reshape(-1, 3)]
    for n in np.unique(np.ceil(edges / max(spacing, 1e-12)).astype(int)):
        if n < 2:
            continue
        grid = np.array([(i, j, n - i - j) for i in range(n + 1) for j in range(n + 1 - i)],
                        dtype=float) / n                                  # barycentric
        pick = tris[np.ceil(edges / max(spacing, 1e-12)).astype(int) == n]
        out.append(np.einsum("gk,tkx->tgx", grid, pick).reshape(-1, 3))
    return np.concatenate(out)


def scene_objects(armature):
    scenes = armature.users_scene
    return scenes[0].objects if scenes else [armature]


def skin_radius(armature, group_names, a, b, fallback):
    """75th percentile distance from segment a-b (world) of the skin the bones
    ``group_names`` move (:func:`skin_points`: weighted ≥ 0.5, or rigid parts parented to
    them); ``fallback`` if there is no such skin."""
    pts = skin_points(armature, set(group_names))
    if not len(pts):
        return fallback
    ab = b - a
    t = np.clip((pts - a) @ ab / max(ab @ ab, 1e-12), 0, 1)
    return float(np.percentile(np.linalg.norm(pts - (a + t[:, None] * ab), axis=1), 75))


def skin_clearance(info, armature, obstacles, horizon: float, clavicle: bool = False) -> float:
    """The least distance (figure units) between the reaching arm's skin as Blender shows it
    now and ``obstacles`` (:class:`~reach_addon.core.Obstacles`), looking no farther than
    ``horizon`` (figure units).

    ``info``: the :class:`.rig.RigInfo` whose arm is measured: the skin of its upper arm,
    forearm and hand bones and of every bone below the hand, weighted 0.5 or more
    (:func:`skin_points`). Returns ``horizon`` where nothing is that near or the arm has
    no skin, and 0 where a point of the skin is inside a closed obstacle. ``clavicle``:
    the clavicle bone's skin too (where the claim is about the whole start pose)."""
    tree = getattr(obstacles, "tree", None)
    bones = info.bones.arms[info.side]
    names = {bones.upper_arm, bones.forearm} | set(info.hand_bones or (bones.hand,))
    names |= {b.name for h in tuple(names - {bones.upper_arm, bones.forearm})
              for b in armature.pose.bones[h].children_recursive}
    if clavicle and bones.clavicle:
        names.add(bones.clavicle)
    if tree is None:
        return horizon
    points = skin_points(armature, names)
    if any(obstacles.point_inside(p) for p in points):
        return 0.0                                   # the skin is inside a closed obstacle
    near = [tree.find_nearest(p.tolist(), horizon) for p in points]
    return min((hit[3] for hit in near if hit[0] is not None), default=horizon)
