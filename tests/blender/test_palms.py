"""A hand of several sibling palm bones: no single hand bone, but ``Palm1.R`` … ``Palm3.R``
directly under the forearm, each carrying a finger (a robot's rigid hand).

The rig adapter takes the group as one hand (``hand_reading.hand_group``,
``hand_reading.hand_shape``) and the bake keys every palm with the same turn. Checked on
Blender's evaluated bones after a baked reach whose wrist bends: at every keyed frame the
palms' heads stay on the forearm's tail and their rotations relative to each other stay
the rest ones (the hand does not split), and the hand points where the plan put it. Rigs
with one hand bone are groups of one, so their bakes are as before (``test_bake.py``).
"""

from __future__ import annotations

import bpy
import clearance
import numpy as np
import pytest
import rigs
import synthetic as syn
from geometry import angle_deg
from test_bake import triangles

# name maps for the palm rigs: the hand's bones are Palm1.R … (or Palm1R … for the robot's)
PALM_MAPS = {"plain": syn.PLAIN, "mixamo": syn.MIXAMO, "robot": syn.ROBOT_NAMES}


@pytest.fixture
def rig(addon):
    return addon.blender.rig


@pytest.fixture
def rig_detect(addon):
    return addon.blender.rig_detect


@pytest.fixture
def hand_reading(addon):
    return addon.blender.hand_reading


def palm_rig(key, **kw):
    names = PALM_MAPS[key]
    arm = syn.humanoid(names, palms=3, fingers=2, **kw)
    palms = {side: tuple(syn.palm_name(names, tag, i) for i in (1, 2, 3))
             for side, tag in (("right", "R"), ("left", "L"))}
    return arm, names, palms


def rotation(armature, name, rest=False):
    """Armature-space rotation (3×3) of a bone: evaluated pose, or its rest."""
    m = armature.data.bones[name].matrix_local if rest else armature.pose.bones[name].matrix
    return np.array(m)[:3, :3]


def world(armature, p):
    return np.array(armature.matrix_world @ p)


# --- detection ----------------------------------------------------------------------------

@pytest.mark.parametrize("key", PALM_MAPS)
def test_the_palms_are_one_hand(fresh, rig, rig_detect, hand_reading, key):
    arm, names, palms = palm_rig(key)
    bmap = rig_detect.detect_bones(arm)
    for side in ("right", "left"):
        hand = bmap.arms[side].hand
        assert hand in palms[side]
        group = hand_reading.hand_group(arm, hand)
        assert group[0] == hand and sorted(group) == sorted(palms[side])
    info = rig.build(arm, "right")
    assert set(info.hand_bones) == set(palms["right"])
    # the wrist is the palms' common head, the forearm's tail
    np.testing.assert_allclose(info.joints_world["wrist"], syn.arm_joints("R")["wrist"], atol=1e-4)
    # the hand: from that wrist toward the middle of all the fingers — the symmetric fan's
    # middle palm, straight on from the forearm (both wrist angles 0) ...
    assert np.abs(info.start_hand).max() < 1e-3
    # ... to the farthest fingertip (0.09 m, below 0.4 forearm: the hand's least length)
    assert info.arm.hand_length == pytest.approx(0.4 * syn.ARM_LENGTHS[1], rel=1e-4)


def test_a_long_palm_hand_reaches_to_the_fingertips(fresh, rig):
    """On the robot (a hand half the forearm long) the hand's length is the middle finger's
    tip, not the palms' tails (0.6 of it)."""
    arm, _names, _palms = palm_rig("robot", proportions="robot")
    info = rig.build(arm, "right")
    assert info.arm.hand_length == pytest.approx(syn.ROBOT["hand_length"], rel=1e-4)
    assert np.abs(info.start_hand).max() < 1e-3


@pytest.mark.parametrize("key", ("mixamo", "unreal", "makehuman", "numbered"))
def test_a_hand_bone_is_a_group_of_one(fresh, rig_detect, hand_reading, key):
    """Twist bones beside the hand (Unreal's) or decoys do not join it."""
    names = syn.MAPS[key]
    for kw in ({"twist": True}, {"decoy": "driver"}):
        if key == "numbered" and "decoy" in kw:
            continue
        bpy.ops.wm.read_homefile(use_empty=True)
        arm = syn.humanoid(names, clavicle=key != "numbered", **kw)
        for side, a in rig_detect.detect_bones(arm).arms.items():
            for hand in {a.hand, a.keyed("hand")}:
                assert hand_reading.hand_group(arm, hand) == (hand,), (key, kw, side)


@pytest.mark.parametrize("kind", rigs.RIGS)
def test_real_rigs_have_one_hand_bone(addon, rig_detect, hand_reading, kind):
    arm = rigs.load(kind)
    for side, a in rig_detect.detect_bones(arm).arms.items():
        for hand in {a.hand, a.keyed("hand")}:
            assert hand_reading.hand_group(arm, hand) == (hand,), (kind, side)


# --- the bake ------------------------------------------------------------------------------

def bake_reach(addon, arm, info, target):
    pipeline = addon.blender.pipeline
    request = pipeline.Request(arm.name, [target.name], side=info.side, frame_start=1,
                               draw=False)
    outcome = pipeline.run(bpy.context, request, bake=True)
    task = outcome.results[0]
    assert task.success, task.message
    return outcome, task


def check_rigid_hand(arm, forearm, palms, length):
    """At the current frame: every palm's head on the forearm's tail, and every palm turned
    relative to the first as at rest. Returns the first palm's rotation relative to the
    forearm."""
    tail = world(arm, arm.pose.bones[forearm].tail)
    for p in palms:
        gap = np.linalg.norm(world(arm, arm.pose.bones[p].head) - tail)
        assert gap <= 1e-5 * length, f"{p}'s head is {gap / length:.2e} arm lengths off the wrist"
    first, first_rest = rotation(arm, palms[0]), rotation(arm, palms[0], rest=True)
    for p in palms[1:]:
        now = first.T @ rotation(arm, p)
        rest = first_rest.T @ rotation(arm, p, rest=True)
        assert np.abs(now - rest).max() < 1e-4, f"{p} turned against {palms[0]}"
    return rotation(arm, forearm).T @ first


def bend_hand(arm, forearm, palms, degrees):
    """Pose the hand bent at the wrist about the elbow's hinge, every palm by the same turn."""
    from mathutils import Matrix

    fore = arm.pose.bones[forearm]
    upper = fore.parent
    hinge = np.cross(np.array(upper.tail - upper.head), np.array(fore.tail - fore.head))
    wrist = np.array(fore.tail)
    turn = np.eye(4)
    turn[:3, :3] = np.array(Matrix.Rotation(np.radians(degrees), 3, hinge.tolist()))
    turn[:3, 3] = wrist - turn[:3, :3] @ wrist
    for p in palms:
        pb = arm.pose.bones[p]
        pb.matrix = Matrix((turn @ np.array(pb.matrix)).tolist())
    bpy.context.view_layer.update()


@pytest.mark.parametrize("key, proportions, bent", (("plain", None, 0.0), ("mixamo", None, 30.0),
                                                    ("robot", "robot", 30.0)))
def test_the_palms_turn_together(fresh, addon, key, proportions, bent):
    """A reach round a plate; on two rigs from a hand bent 30° at the start (the plan
    brings it back toward neutral as it goes), on the other as straight as it is built (the
    plate makes it bend). The arm and the hand of three palms keep clear of the plate by
    their radii at every instant (``clearance``)."""
    rig = addon.blender.rig
    arm, names, palms = palm_rig(key, proportions=proportions)
    if bent:
        bend_hand(arm, names["forearm_R"], palms["right"], bent)
    info = rig.build(arm, "right")
    forearm = info.bones.arms["right"].forearm
    length = info.arm.arm_length
    target, plate = rigs.plate_scene(info, arm)
    outcome, task = bake_reach(addon, arm, info, target)
    plan, frame0 = outcome.plans[0]
    planned = plan.world_joints()
    fingers = [b for p in palms["right"] for b in arm.pose.bones[p].children_recursive]

    bends = []
    for f in range(task.frame_start, task.frame_end + 1):
        bpy.context.scene.frame_set(f)
        relative = check_rigid_hand(arm, forearm, palms["right"], length)
        if not bends:
            start = relative
        bends.append(angle_deg(start @ np.array([0.0, 1.0, 0.0]), relative @ np.array([0.0, 1.0, 0.0])))
        # the hand points where the plan put it: wrist → the mean of the finger joints
        wrist = world(arm, arm.pose.bones[forearm].tail)
        joints = np.array([world(arm, p) for b in fingers for p in (b.head, b.tail)])
        j = planned[f - frame0]
        assert angle_deg(joints.mean(0) - wrist, j[4] - j[3]) < 0.5, f"frame {f}"
    assert max(bends) > 10.0, "the wrist bends during the reach"
    capsules = clearance.Arm(arm, info)
    capsules.check_instants(triangles(plate), range(task.frame_start, task.frame_end + 1))
    print(f"{key}: worst margins (arm lengths): {capsules.report()}")
    assert set(palms["right"]) <= set(task.bones_keyed)
    bpy.context.scene.frame_set(task.frame_end)
    wrist = world(arm, arm.pose.bones[palms["right"][0]].head)
    assert np.linalg.norm(wrist - np.array(target.location)) <= 0.005 * length


def test_live_poses_every_palm(fresh, addon):
    """Live poses the hand through the bake's matrices: all palms, rigidly, from a hand
    bent at the start (the plan turns it back toward neutral); K keys them all."""
    live, rig = addon.blender.live, addon.blender.rig
    arm, names, palms = palm_rig("plain")
    bend_hand(arm, names["forearm_R"], palms["right"], 30.0)
    info = rig.build(arm, "right")
    forearm, length = info.bones.arms["right"].forearm, info.arm.arm_length
    target, _plate = rigs.plate_scene(info, arm)
    props = bpy.context.scene.reach
    props.armature, props.target, props.arm = arm, target, "RIGHT"
    start = rotation(arm, palms["right"][1])
    assert bpy.ops.reach.live() == {"FINISHED"}
    for _ in range(10000):
        if not live.update(bpy.context).busy:
            break
    bpy.context.view_layer.update()
    wrist = world(arm, arm.pose.bones[forearm].tail)
    assert np.linalg.norm(wrist - np.array(target.location)) <= 0.005 * length
    assert np.abs(rotation(arm, palms["right"][1]) - start).max() > 0.1, "the palms moved"
    check_rigid_hand(arm, forearm, palms["right"], length)
    assert bpy.ops.reach.key_pose() == {"FINISHED"}
    action = arm.animation_data.action
    curves = rigs.fcurves(action)
    assert set(palms["right"]) <= {fc.data_path.split('"')[1] for fc in curves}
    live.stop(push_undo=False)
