"""Visual feedback in a "Reach" collection: the wrist trajectory as a red curve (as in the
paper's figures), green target markers, and optionally the workspace's valid guiding nodes
as orange wire cubes with the guiding nodes of the path as green spheres.

Everything here is tagged with :data:`~reach_addon.blender.scene.VIZ_TAG` so it is never
taken for an obstacle, and :func:`clear` removes it all (objects, their data, materials).
"""

from __future__ import annotations

import bmesh
import bpy
import numpy as np
from mathutils import Matrix

from .scene import VIZ_TAG

COLLECTION = "Reach"
RED = (0.9, 0.02, 0.02, 1.0)
GREEN = (0.1, 0.8, 0.1, 1.0)
ORANGE = (1.0, 0.45, 0.0, 1.0)
#: Radius of the drawn trajectory's tube, in arm lengths (6 mm on a 0.6 m arm; the target
#: markers are 0.04): it scales with the figure.
TUBE_RADIUS = 0.01


def collection(scene, create=True):
    """The scene's "Reach" collection (created and linked under the scene if missing)."""
    coll = next((c for c in scene.collection.children if c.get(VIZ_TAG) and c.name.startswith(COLLECTION)),
                None)
    if coll is None and create:
        coll = bpy.data.collections.new(COLLECTION)
        coll[VIZ_TAG] = True
        scene.collection.children.link(coll)
    return coll


def material(name, color):
    """Reach's material ``name`` (made once) in ``color``, solid viewport and renders."""
    mat = bpy.data.materials.get(name)
    if mat is None:
        mat = bpy.data.materials.new(name)
        mat[VIZ_TAG] = True
    mat.diffuse_color = color            # solid viewport and Workbench colour
    if mat.node_tree is None:            # before 5.0 new materials have no node tree
        mat.use_nodes = True
    if mat.node_tree is not None:
        bsdf = mat.node_tree.nodes.get("Principled BSDF")
        if bsdf is not None:
            bsdf.inputs["Base Color"].default_value = color
    return mat


def link(scene, ob, color):
    """Tag ``ob`` as Reach's display and link it into the "Reach" collection."""
    ob[VIZ_TAG] = True
    ob.color = color                     # viewport colour in "Object" colour mode
    ob.hide_select = True
    collection(scene).objects.link(ob)
    return ob


def remove(name):
    """Remove Reach's display object ``name`` (and its data, once unused), if there is one."""
    old = bpy.data.objects.get(name)
    if old is not None and old.get(VIZ_TAG):
        data = old.data
        bpy.data.objects.remove(old, do_unlink=True)
        if data is not None and data.users == 0:
            _remove_data(data)


def _remove_data(data):
    for coll in (bpy.data.curves, bpy.data.meshes):
        if data.name in coll and coll[data.name] == data:
            coll.remove(data)
            return


def trajectory(scene, points, radius, name="Reach Trajectory"):
    """A red poly curve through ``points`` (world, (n, 3)), bevelled to a tube of ``radius``
    (world units; the pipeline gives a share of the arm's length, :data:`TUBE_RADIUS`,
    so that it is as thin beside a small figure's hand as beside a tall one's) so that it
    shows in solid shading and in renders."""
    remove(name)
    points = np.asarray(points, dtype=float)
    curve = bpy.data.curves.new(name, "CURVE")
    curve[VIZ_TAG] = True
    curve.dimensions = "3D"
    curve.bevel_depth = radius
    curve.bevel_resolution = 2
    spline = curve.splines.new("POLY")
    spline.points.add(len(points) - 1)
    co = np.hstack([points, np.ones((len(points), 1))])
    spline.points.foreach_set("co", co.ravel())
    curve.materials.append(material("Reach Red", RED))
    return link(scene, bpy.data.objects.new(name, curve), RED)


def _spheres_mesh(name, centres, radius, segments=12, rings=6):
    """One mesh of UV spheres of ``radius`` at ``centres``: ``segments`` around, ``rings``
    from pole to pole (62 vertices a sphere: enough for markers)."""
    bm = bmesh.new()
    try:
        for c in np.atleast_2d(centres):
            bmesh.ops.create_uvsphere(bm, u_segments=segments, v_segments=rings, radius=radius,
                                      matrix=Matrix.Translation(c.tolist()))
        mesh = bpy.data.meshes.new(name)
        bm.to_mesh(mesh)
    finally:
        bm.free()
    mesh[VIZ_TAG] = True
    return mesh


def markers(scene, points, name="Reach Targets", radius=0.025, color=GREEN):
    """Green spheres at ``points`` (the paper's target markers)."""
    remove(name)
    mesh = _spheres_mesh(name, points, radius)
    mesh.materials.append(material("Reach Green", color))
    return link(scene, bpy.data.objects.new(name, mesh), color)


def wire_cubes(scene, centres, size, name="Reach Workspace"):
    """Orange wire cubes (edges only) centred at ``centres`` with edge lengths ``size``
    (3,), e.g. the workspace's valid guiding nodes."""
    remove(name)
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    edges = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7),
             (0, 4), (1, 5), (2, 6), (3, 7)]
    verts, all_edges = [], []
    for c in np.atleast_2d(centres):
        base = len(verts)
        verts += (corners * size + c).tolist()
        all_edges += [(base + a, base + b) for a, b in edges]
    mesh = bpy.data.meshes.new(name)
    mesh[VIZ_TAG] = True
    mesh.from_pydata(verts, all_edges, [])
    ob = bpy.data.objects.new(name, mesh)
    ob.display_type = "WIRE"
    mesh.materials.append(material("Reach Orange", ORANGE))
    return link(scene, ob, ORANGE)


def clear(scene) -> int:
    """Remove the Reach collection and everything in it; returns the number of objects
    removed. Materials Reach made are removed once nothing uses them."""
    coll = collection(scene, create=False)
    removed = 0
    if coll is not None:
        for ob in list(coll.all_objects):
            data = ob.data
            bpy.data.objects.remove(ob, do_unlink=True)
            removed += 1
            if data is not None and data.users == 0:
                _remove_data(data)
        bpy.data.collections.remove(coll)
    for mat in list(bpy.data.materials):
        if mat.get(VIZ_TAG) and mat.users == 0:
            bpy.data.materials.remove(mat)
    return removed


def draw_plans(scene, info, plans, planner, show_guides: bool) -> None:
    """Draw ``plans`` [(Plan, first frame)] of the arm of ``info`` (:class:`.rig.RigInfo`)
    in place of what was drawn before (:func:`clear`): the wrist trajectory, the target
    markers (a chase's last target), the guiding nodes and, with ``show_guides``, the
    valid cells of ``planner``'s workspace (built if it was not)."""
    clear(scene)
    length = info.arm.arm_length
    wrists = [p.wrist_trajectory() for p, _f in plans]
    if wrists:
        trajectory(scene, np.concatenate(wrists), TUBE_RADIUS * length)
    targets = np.concatenate([p.task.targets[-1:] if p.task.kind == "chase" else p.task.targets
                              for p, _f in plans])
    markers(scene, targets, radius=0.04 * length)
    guides = np.concatenate([p.guiding_nodes() for p, _f in plans] + [np.zeros((0, 3))])
    if len(guides):
        markers(scene, guides, name="Reach Guiding Nodes", radius=0.03 * length)
    if show_guides:
        ws = planner.workspace
        if ws.valid.any():
            centres = info.arm.to_world_points(ws.valid_centers())
            wire_cubes(scene, centres, np.abs(info.arm.to_world[:3, :3]) @ ws.cell,
                       name="Reach Workspace")
