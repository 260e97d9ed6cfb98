"""Bad input: each case gets a clear message naming the object and the fix, and nothing in
the file changes."""

import json

import addon_utils
import bpy
import numpy as np
import pytest
import rigs
from test_bake import snapshot_keys


def fingerprint():
    """Everything a bake could touch: objects, transforms, poses, every action's keys,
    collections, materials, the current frame. (Transforms are read after a depsgraph
    update and compared as text, so NaN equals NaN.)"""
    bpy.context.view_layer.update()
    out = {"frame": bpy.context.scene.frame_current,
           "collections": sorted((c.name, tuple(sorted(o.name for o in c.objects)))
                                 for c in bpy.data.collections),
           "materials": sorted(m.name for m in bpy.data.materials),
           "actions": {}}
    for ob in bpy.data.objects:
        out[ob.name] = (ob.type, str(np.round(np.array(ob.matrix_world), 6).tolist()),
                        ob.data.name if ob.data else None)
        if ob.type == "ARMATURE" and ob.pose is not None:
            out[ob.name + " pose"] = [np.round(np.array(pb.matrix_basis), 6).tolist()
                                      for pb in ob.pose.bones]
        if ob.animation_data and ob.animation_data.action:
            out["actions"][ob.name] = (ob.animation_data.action.name, snapshot_keys(ob))
    return out


def expect_error(*needles, **props):
    """Run Bake with ``props`` set and expect an error mentioning ``needles``; the file must
    not change."""
    scene = bpy.context.scene
    for k, v in props.items():
        setattr(scene.reach, k, v)
    before = fingerprint()
    with pytest.raises(RuntimeError) as err:
        bpy.ops.reach.bake()
    for needle in needles:
        assert needle in str(err.value), str(err.value)
    assert fingerprint() == before
    return str(err.value)


@pytest.fixture
def metarig(fresh):
    arm = rigs.load("metarig")
    arm.pose.bones["spine.006"].keyframe_insert("rotation_quaternion", frame=3)
    return arm


def target_at(addon, arm, offset_arm_lengths=(0.0, 0.7, 0.0), name="Cup"):
    """A target placed in the rig's own body axes, in arm lengths from the right shoulder."""
    info = addon.blender.rig.build(arm, "right")
    f, length = info.frame, info.arm.arm_length
    x, y, z = offset_arm_lengths
    p = info.joints_world["shoulder"] + length * (x * f.right + y * f.forward + z * f.up)
    return rigs.add_target(name, p), info


def test_no_armature(fresh):
    target = rigs.add_target("Cup", (0, -0.5, 1.2))
    expect_error("Choose the character's armature", target=target)


def test_no_target(metarig):
    expect_error("Choose a target", armature=metarig)


def test_armature_without_arms(fresh):
    data = bpy.data.armatures.new("Tail")
    ob = bpy.data.objects.new("Tail", data)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    parent = None
    for i in range(3):
        b = data.edit_bones.new(f"Bone{i}")
        b.head, b.tail = (0, 0, i * 0.3), (0, 0, (i + 1) * 0.3)
        b.parent = parent
        parent = b
    bpy.ops.object.mode_set(mode="OBJECT")
    target = rigs.add_target("Cup", (0, -0.5, 1.2))
    expect_error("armature 'Tail'", "no recognisable", "set upper_arm_right", "--bone ROLE=BONE",
                 armature=ob, target=target)


def test_target_is_the_armature(metarig):
    expect_error("is the armature itself", armature=metarig, target=metarig)


def test_target_inside_an_obstacle(addon, metarig):
    target, info = target_at(addon, metarig, (0.1, 0.6, 0.0))
    rigs.add_box("Cabinet", np.array(target.location), (0.3, 0.3, 0.3))
    expect_error("inside obstacle 'Cabinet'", "Cup", "nothing was baked",
                 armature=metarig, target=target)


def test_target_out_of_reach_and_baking_the_closest_approach(addon, metarig):
    bpy.context.scene.reach.settings.lean = False      # the arm alone (Lean steps to it)
    target, info = target_at(addon, metarig, (0.0, 1.6, 0.0), name="Lamp")
    expect_error("'Lamp' is out of reach", "Bake closest approach", armature=metarig,
                 target=target)
    bpy.context.scene.reach.bake_closest = True
    assert bpy.ops.reach.bake() == {"FINISHED"}          # asked for: baked, and said so
    keys = snapshot_keys(metarig)
    assert ('pose.bones["upper_arm.R"].rotation_quaternion', 0) in keys


def test_a_target_just_beyond_the_arm_says_leaning_would_reach_it_in_scene_units(addon, metarig):
    # 1.45 arm lengths straight ahead of the shoulder: beyond the arm even with the chest
    # turned its 60° (which brings the shoulder forward), by what the geometry gives
    target, info = target_at(addon, metarig, (0.0, 1.45, 0.0), name="Lamp")
    settings = bpy.context.scene.reach.settings
    assert settings.lean                              # on by default: it leans (below)
    settings.lean = False
    arm = info.arm
    s = np.asarray(arm.shoulder, dtype=float)
    turns = np.radians([-60.0, 60.0])                # the turn's ends, about the spine (z)
    turned = np.stack([s[0] * np.cos(turns) - s[1] * np.sin(turns),
                       s[0] * np.sin(turns) + s[1] * np.cos(turns), np.full(2, s[2])], -1)
    goal = arm.to_canonical_points(np.array(target.location))
    beyond_cm = 100 * (np.linalg.norm(turned - goal, axis=1).min() - arm.arm_length)
    text = expect_error("'Lamp' is out of reach by", f"{beyond_cm:.1f} cm", "leaning",
                        armature=metarig, target=target)
    assert "arm lengths" in text
    # a scene whose unit is a centimetre: the same distance is a hundredth as many cm
    bpy.context.scene.unit_settings.scale_length = 0.01
    expect_error(f"{beyond_cm / 100:.1f} cm", armature=metarig, target=target)
    # with the default, Lean on, the same Bake leans the trunk and reaches it
    settings.lean = True
    assert bpy.ops.reach.bake() == {"FINISHED"}
    task = json.loads(bpy.context.scene.reach.last_result)["tasks"][0]
    assert task["success"] and task["stats"]["lean_deg"] > 0.0, task


def test_zero_scale_armature(addon, metarig):
    target, _info = target_at(addon, metarig)
    metarig.scale = (1.0, 0.0, 1.0)
    bpy.context.view_layer.update()
    expect_error("armature 'metarig'", "zero scale", armature=metarig, target=target)


def test_nan_target(addon, metarig):
    target, _info = target_at(addon, metarig)
    target.location = (float("nan"), 0.0, 1.0)
    bpy.context.view_layer.update()
    expect_error("target 'Cup'", "NaN", armature=metarig, target=target)


def test_obstacle_collection_without_faces(addon, metarig):
    target, _info = target_at(addon, metarig)
    coll = bpy.data.collections.new("Props")
    bpy.context.scene.collection.children.link(coll)
    mesh = bpy.data.meshes.new("Wire")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0)], [(0, 1)], [])
    coll.objects.link(bpy.data.objects.new("Wire", mesh))
    expect_error("collection 'Props'", "no visible objects with faces", armature=metarig,
                 target=target, obstacles="COLLECTION", obstacle_collection=coll)


def test_armature_in_edit_mode(addon, metarig):
    target, _info = target_at(addon, metarig)
    bpy.context.view_layer.objects.active = metarig
    bpy.ops.object.mode_set(mode="EDIT")
    scene = bpy.context.scene
    scene.reach.armature, scene.reach.target = metarig, target
    with pytest.raises(RuntimeError, match="Edit Mode"):
        bpy.ops.reach.bake()
    bpy.ops.object.mode_set(mode="OBJECT")


def _library(tmp_path):
    """A library file holding the metarig with an action."""
    rigs.load("metarig")
    arm = bpy.data.objects["metarig"]
    arm.pose.bones["upper_arm.R"].keyframe_insert("rotation_quaternion", frame=1)
    path = tmp_path / "library.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    bpy.ops.wm.read_homefile(use_empty=True)
    return path


def test_linked_armature(fresh, tmp_path):
    path = _library(tmp_path)
    with bpy.data.libraries.load(str(path), link=True) as (src, dst):
        dst.objects = ["metarig"]
    arm = dst.objects[0]
    bpy.context.scene.collection.objects.link(arm)
    target = rigs.add_target("Cup", np.array(arm.matrix_world.translation) + [-0.3, -0.45, 1.3])
    expect_error("armature 'metarig' is linked", "library override", armature=arm, target=target)


def test_linked_action(addon, fresh, tmp_path):
    path = _library(tmp_path)
    with bpy.data.libraries.load(str(path), link=True) as (src, dst):
        dst.actions = list(src.actions)
    addon_utils.enable("rigify", default_set=True)
    bpy.ops.object.armature_human_metarig_add()
    arm = bpy.context.object
    bpy.ops.object.mode_set(mode="OBJECT")
    arm.animation_data_create().action = dst.actions[0]
    bpy.context.view_layer.update()
    target, _info = target_at(addon, arm)
    expect_error("is linked from a library", "Bake into a new action", armature=arm, target=target)
    bpy.context.scene.reach.new_action = True
    assert bpy.ops.reach.bake() == {"FINISHED"}
    assert arm.animation_data.action.library is None


@pytest.mark.parametrize("scale", [(1.0, 1.3, 0.8), (1.3, 1.0, 1.0), (-1.0, 1.02, 1.0)])
def test_non_uniform_scale_is_refused_and_applying_it_as_told_bakes(addon, metarig, scale):
    """A non-uniformly scaled armature cannot be baked right (its bones would stretch as
    they turn: measured 0.17-0.30 arm lengths off at (1, 1.3, 0.8) and (1.3, 1, 1)), so
    Bake refuses it, naming the armature, its scale and the fix; after the fix (Ctrl+A >
    Scale, here its operator; for a mirrored one, the same size on every axis) the same
    request bakes and the evaluated wrist reaches the target."""
    metarig.scale = scale
    bpy.context.view_layer.update()
    target = rigs.add_target("Cup", (0.0, 0.0, 0.0))
    msg = expect_error("armature 'metarig'", "non-uniform scale", "Ctrl+A > Scale",
                       "same size on every axis", armature=metarig, target=target)
    assert ", ".join(f"{v:g}" for v in scale) in msg, msg
    if min(scale) < 0:
        metarig.scale = [np.sign(v) for v in scale]
    else:
        for ob in bpy.context.view_layer.objects:
            ob.select_set(ob == metarig)
        bpy.context.view_layer.objects.active = metarig
        bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    bpy.context.view_layer.update()
    target, info = target_at(addon, metarig, name="Cup2")
    bpy.context.scene.reach.target = target
    assert bpy.ops.reach.bake() == {"FINISHED"}
    task = json.loads(bpy.context.scene.reach.last_result)["tasks"][0]
    assert task["success"], task
    bpy.context.scene.frame_set(task["frame_end"])
    hand = metarig.matrix_world @ metarig.pose.bones["hand.R"].head
    assert (hand - target.location).length <= 0.01 * info.arm.arm_length


def test_non_uniform_scale_of_a_parent_is_refused_naming_the_parent(addon, metarig):
    target, _info = target_at(addon, metarig)
    stage = bpy.data.objects.new("Stage", None)
    bpy.context.scene.collection.objects.link(stage)
    stage.scale = (1.0, 1.25, 1.0)
    metarig.parent = stage
    metarig.rotation_euler = (0.0, 0.0, 0.6)       # sheared: no scale of its own fixes it
    bpy.context.view_layer.update()
    expect_error("armature 'metarig'", "its parent 'Stage'", "Alt+P", armature=metarig,
                 target=target)


def test_uniform_and_mirrored_scale_within_the_tolerance_still_bake(addon, metarig):
    """Scale noise below the tolerance (as FBX imports leave: 0.01 vs 0.0100001) is not
    refused."""
    metarig.scale = (-0.5, 0.5 * (1 + 1e-5), 0.5)
    bpy.context.view_layer.update()
    target, _info = target_at(addon, metarig)
    scene = bpy.context.scene
    scene.reach.armature, scene.reach.target = metarig, target
    assert bpy.ops.reach.bake() == {"FINISHED"}
