"""The instants between two keys: the planner checks the arm where Blender puts it.

On a linear span Blender blends each bone's quaternion channels and normalises them. The
planner's check between keys (``core.keys.between``) chains the segments' relative
rotations blended the same way. Here a fast reach is baked with linear keys on rigs with
their own bone rolls and rest poses (five: the synthetic Mixamo-like rig, CesiumMan,
Quaternius' FBX character, Rigify's metarig, GoMakeHuman), right arms and left (whose
canonical frame is mirrored). At three instants between every two keys the joints
Blender evaluates, read by the fuzz campaign's independent reader (bone heads, the
sternum, the hand's end and the ends of the hand shape's capsules carried by their
bones), must be the planner's, to round-off.
The straight line between the planner's seven angles, which the planner checked before,
parts from them by more than a millimetre's worth, so the comparison can tell the two
apart."""

import bpy
import numpy as np
import pytest
import rigs
import synthetic

from reach_addon.blender import rig as rig_mod
from verification.fuzz.checks import ArmReader

INSTANTS = (0.25, 0.5, 0.75)


@pytest.fixture
def linear_keys():
    edit = bpy.context.preferences.edit
    was = edit.keyframe_new_interpolation_type
    edit.keyframe_new_interpolation_type = "LINEAR"
    yield
    edit.keyframe_new_interpolation_type = was


@pytest.mark.parametrize("kind, side", [("synthetic", "right"), ("synthetic", "left"),
                                        ("cesium", "right"), ("quaternius", "left"),
                                        ("metarig", "left"), ("gomakehuman", "right")])
def test_blender_puts_the_arm_between_keys_where_the_planner_checked_it(fresh, addon,
                                                                        linear_keys, kind, side):
    arm = synthetic.humanoid(synthetic.MIXAMO, name="Rig") if kind == "synthetic" \
        else rigs.load(kind)
    # the imported rigs come with animations of their own, which would move the arm's
    # parents under the keys: here only the keys the bake writes move it
    arm.animation_data_clear()
    for bone in arm.pose.bones:
        bone.matrix_basis.identity()
    info = rig_mod.build(arm, side)
    f, length = info.frame, info.arm.arm_length
    out = f.right if side == "right" else -f.right
    # up and across the body, fast: the forearm and hand turn tens of degrees a frame
    target = rigs.add_target("Cup", info.joints_world["shoulder"]
                             + length * (0.45 * f.forward - 0.35 * out + 0.55 * f.up))
    pipeline = addon.blender.pipeline
    # the chest turning alone: the planner's model of the instants between keys is of the
    # bones it plans (the spine's share of the turn, blended bone by bone, adds up to 1.4e-5
    # arm lengths: test_spine_share)
    outcome = pipeline.run(bpy.context, pipeline.Request(
        armature=arm.name, targets=[target.name], side=side, duration_s=0.3,
        settings=addon.core.Settings().replace(spine_share=0.0)))
    assert outcome.success, outcome.results[0].message
    plan, first = outcome.plans[0]
    scene = bpy.context.scene
    scene.frame_set(first)
    reader = ArmReader(arm, rig_mod.build(arm, side))
    model = plan.arm
    keys, sampling = addon.core.keys, addon.core.sampling
    t = np.array(INSTANTS)
    exact, straight, turn = 0.0, 0.0, 0.0
    for k in range(len(plan.poses) - 1):
        a, b = plan.poses[k], plan.poses[k + 1]
        planned, _bends, _body = keys.between(model, a, b, t)
        rows = (1.0 - t)[:, None] * sampling.pose_row(a) + t[:, None] * sampling.pose_row(b)
        lines = sampling.joints_of(model, rows)
        turn = max(turn, float(np.degrees(np.arccos(np.clip(
            np.dot(*[(p.joints[4] - p.joints[3]) / model.hand_length for p in (a, b)]),
            -1.0, 1.0)))))
        for i, s in enumerate(INSTANTS):
            scene.frame_set(first + k, subframe=s)
            real = reader.joints(arm)
            exact = max(exact, float(np.linalg.norm(
                model.to_world_points(planned[i]) - real, axis=1).max()))
            straight = max(straight, float(np.linalg.norm(
                model.to_world_points(lines[i]) - real[:5], axis=1).max()))
    print(f"{side}: {len(plan.poses)} keys, hand turning up to {turn:.1f} deg a frame; "
          f"planner's instants off by {exact / length:.2e}, the angles' straight line by "
          f"{straight / length:.2e} arm lengths")
    assert turn > 10.0
    assert exact <= 1e-5 * length
    assert straight >= 1e-3 * length
