"""Obstacles kept between Plans (``scene.KEPT``): a Plan, a Bake or an envelope on obstacles
that did not change builds no BVH, and every kind of change to an obstacle gives a new one
with the new geometry — the same as gathering afresh — never the old tree."""

import bmesh
import bpy
import numpy as np
import pytest
import rigs
from mathutils import Matrix, Vector

#: Points round the boxes where the kept and the fresh obstacles are compared.
PROBES = [Vector(p) for p in np.stack(np.meshgrid(*[np.linspace(-1.5, 1.5, 5)] * 3),
                                      -1).reshape(-1, 3)]


def geometry(obstacles):
    """What the planner would see: triangles per obstacle, and the nearest surface point
    from every probe (None for no obstacles)."""
    if obstacles.tree is None:
        return obstacles.triangle_counts(), None
    near = [obstacles.tree.find_nearest(p) for p in PROBES]
    return obstacles.triangle_counts(), np.array([list(n[0]) for n in near])


def same(a, b) -> bool:
    if a[0] != b[0] or (a[1] is None) != (b[1] is None):
        return False
    return a[1] is None or np.allclose(a[1], b[1], atol=1e-6)


def add_box(name, center=(0.0, 0.0, 0.0), size=0.5):
    return rigs.add_box(name, center, (size, size, size))


def _nothing(box):
    pass


def _with_modifier(box):
    box.modifiers.new("Displace", "DISPLACE").strength = 0.0


def _with_shape_key(box):
    box.shape_key_add(name="Basis")
    key = box.shape_key_add(name="Key 1")
    key.value = 0.0
    for point in key.data:
        point.co = point.co * 1.6


def _with_animation(box):
    box.keyframe_insert("location", frame=1)
    box.location.z += 0.5
    box.keyframe_insert("location", frame=20)
    bpy.context.scene.frame_set(1)


def _move(scene, box, props):
    box.location.x += 0.3


def _edit_mode_same_count(scene, box, props):
    bpy.context.view_layer.objects.active = box
    bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(box.data)
    bm.verts.ensure_lookup_table()
    bm.verts[0].co += Vector((0.0, 0.0, 0.4))
    bmesh.update_edit_mesh(box.data)


def _modifier(scene, box, props):
    box.modifiers["Displace"].strength = 0.3


def _shape_key(scene, box, props):
    box.data.shape_keys.key_blocks["Key 1"].value = 1.0


def _animated(scene, box, props):
    scene.frame_set(10)


def _hidden(scene, box, props):
    box.hide_set(True)


def _added(scene, box, props):
    props.objects.link(bpy.data.objects.new("Added", box.data))


def _deleted(scene, box, props):
    bpy.data.objects.remove(bpy.data.objects["Other"])


def _collection(scene, box, props):
    props.objects.unlink(box)
    scene.collection.objects.link(box)


def _mesh_swapped(scene, box, props):
    other = box.data.copy()
    other.transform(Matrix.Scale(1.5, 4))
    box.data = other


def _vertices_written(scene, box, props):
    co = np.empty(len(box.data.vertices) * 3, np.float32)
    box.data.vertices.foreach_get("co", co)
    co[2] += 0.2
    box.data.vertices.foreach_set("co", co)
    box.data.update()


def _face_deleted(scene, box, props):
    # The same vertices, one face fewer.
    bpy.context.view_layer.objects.active = box
    bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(box.data)
    bm.faces.ensure_lookup_table()
    bmesh.ops.delete(bm, geom=[bm.faces[0]], context="FACES_ONLY")
    bmesh.update_edit_mesh(box.data)
    bpy.ops.object.mode_set(mode="OBJECT")


#: Each kind of change: (how the box is set up first, the change).
CHANGES = {"moved": (_nothing, _move),
           "edited in edit mode, same vertex count": (_nothing, _edit_mode_same_count),
           "modifier changed": (_with_modifier, _modifier),
           "shape key": (_with_shape_key, _shape_key),
           "animated, frame changed": (_with_animation, _animated),
           "hidden": (_nothing, _hidden), "added": (_nothing, _added),
           "deleted": (_nothing, _deleted),
           "left the obstacle collection": (_nothing, _collection),
           "mesh swapped": (_nothing, _mesh_swapped),
           "vertices written": (_nothing, _vertices_written),
           "a face deleted": (_nothing, _face_deleted)}


@pytest.mark.parametrize("change", sorted(CHANGES))
def test_every_change_to_an_obstacle_gives_its_new_geometry(fresh, addon, change):
    scene_mod = addon.blender.scene
    scene = bpy.context.scene
    props = bpy.data.collections.new("Props")
    scene.collection.children.link(props)
    box = add_box("Box")
    other = add_box("Other", (0.0, -0.8, 0.0), 0.3)
    for ob in (box, other):
        for c in list(ob.users_collection):
            c.objects.unlink(ob)
        props.objects.link(ob)
    setup, change_it = CHANGES[change]
    setup(box)
    bpy.context.view_layer.update()

    kept = scene_mod.KeptObstacles()
    for collection in (None, props):
        kept.clear()
        _pieces, first, built = kept.get(bpy.context, (), collection)
        _pieces, again, built_again = kept.get(bpy.context, (), collection)
        assert built and not built_again and again is first
    before = geometry(first)

    change_it(scene, box, props)
    bpy.context.view_layer.update()
    builds = kept.builds
    _pieces, after, built = kept.get(bpy.context, (), props)
    assert built and kept.builds == builds + 1
    new = geometry(after)
    assert not same(new, before)
    assert same(new, geometry(scene_mod.gather_obstacles(bpy.context, (), props)))
    _pieces, again, built = kept.get(bpy.context, (), props)
    assert not built and again is after
    if bpy.context.object is not None and bpy.context.object.mode == "EDIT":
        bpy.ops.object.mode_set(mode="OBJECT")


def test_a_triangle_mesh_is_read_as_its_own_triangulation(fresh, addon):
    """A mesh of triangles only is read through its corners, not its loop triangles; the
    result is the same triangles."""
    box = add_box("Box")
    bpy.context.view_layer.objects.active = box
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.quads_convert_to_tris()
    bpy.ops.object.mode_set(mode="OBJECT")
    mesh = box.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", tris)
    _v, read = addon.blender.scene._mesh_arrays(mesh)
    assert sorted(map(sorted, read.tolist())) == sorted(map(sorted, tris.reshape(-1, 3).tolist()))


def _plate_plan(addon):
    """The metarig at rest before a plate, and a request to reach past it: (the kept
    obstacles, the rig's info, the target, the pipeline, the request)."""
    arm = rigs.load("metarig")
    rigs.rest_still(arm)
    info = addon.blender.rig.build(arm, "right")
    target, _plate = rigs.plate_scene(info, arm)
    pipeline = addon.blender.pipeline
    request = pipeline.Request(armature=arm.name, targets=[target.name], side="right",
                               frame_start=1)
    return addon.blender.scene.KEPT, info, target, pipeline, request


def test_plans_reuse_the_obstacles_until_one_changes(fresh, addon):
    """Plan twice and compute the envelope on an unchanged scene: one build. Then a box
    round the target: built again, and the reach that was clear is blocked; moved away,
    clear again; hidden round the target, clear."""
    kept, info, target, pipeline, request = _plate_plan(addon)

    def reach():
        return pipeline.run(bpy.context, request, bake=False).results[0]

    kept.clear()
    builds = kept.builds
    first = reach()
    assert first.success, first.message
    second = reach()
    assert second.success and kept.builds == builds + 1
    pipeline.envelope(bpy.context, request, world=[list(target.matrix_world.translation)])
    assert kept.builds == builds + 1

    cage = add_box("Cage", np.array(target.matrix_world.translation),
                   0.3 * info.arm.arm_length)
    assert not reach().success and kept.builds == builds + 2
    assert not reach().success and kept.builds == builds + 2
    cage.location.x += 3 * info.arm.arm_length
    assert reach().success and kept.builds == builds + 3
    cage.location = target.matrix_world.translation
    assert not reach().success and kept.builds == builds + 4
    cage.hide_set(True)
    assert reach().success and kept.builds == builds + 5


def test_objects_beyond_reach_are_left_out_until_they_come_near(fresh, addon):
    """A set-dressed scene: a Plan builds its BVH from the objects within the body's reach
    (core.arm.reach_sphere, grown by the lean's and the steps' reach with Lean on, the
    default: ``scene.reach_bounds``; the far box stands 30 arm lengths off); a far object is
    neither read nor built, an edit to it builds nothing, and it counts again the moment
    it moves near — or holds a target."""
    kept, info, target, pipeline, request = _plate_plan(addon)
    length = info.arm.arm_length
    chest = info.joints_world["shoulder"]
    far = add_box("Far", chest + 30 * length * info.frame.forward, length)

    def plan():
        outcome = pipeline.run(bpy.context, request, bake=False)
        return outcome.results[0], [name for name, _n in outcome.obstacles]

    kept.clear()
    builds = kept.builds
    result, names = plan()
    assert result.success and names == ["Plate"] and kept.builds == builds + 1
    _vertices_written(bpy.context.scene, far, None)
    result, names = plan()
    assert result.success and kept.builds == builds + 1
    # the far box comes round the target: it blocks, and is listed
    far.location = target.matrix_world.translation
    far.scale = (0.3, 0.3, 0.3)
    result, names = plan()
    assert not result.success and "Far" in names and kept.builds == builds + 2
    # a target inside a far closed box is still found inside it
    far.scale = (1.0, 1.0, 1.0)
    far.location = chest + 30 * length * info.frame.forward
    target.location = far.location
    bpy.context.view_layer.update()
    result, names = plan()
    assert not result.success and result.reason == "target_in_obstacle", result.message
    assert "Far" in names
