"""Scenes the fuzz campaign (``bench/fuzz.py``) found wrong, fixed in the pipeline: an
obstacle animated across a reach, and targets carried by the character's own bones. Each
bake is checked on Blender's evaluated bones by the tests' independent clearance check
(``clearance``), at every frame and three instants between."""

import bpy
import clearance
import numpy as np
import pytest
import rigs
import synthetic
from test_bake import triangles

from reach_addon.blender import rig as rig_mod


def humanoid():
    arm = synthetic.humanoid(synthetic.MIXAMO, name="Rig")
    info = rig_mod.build(arm, "right")
    return arm, info


def point(info, forward, side, up):
    """World point from the right shoulder, in arm lengths along the body's axes (side:
    toward the right arm)."""
    f, length = info.frame, info.arm.arm_length
    return info.joints_world["shoulder"] + length * (forward * f.forward + side * f.right
                                                     + up * f.up)


def bake(addon, arm, targets, **kw):
    pipeline = addon.blender.pipeline
    request = pipeline.Request(armature=arm.name, targets=[t.name for t in targets], **kw)
    return pipeline.run(bpy.context, request)


def check_clear(arm, side, result, solids, overrides=None):
    """Assert the reaching arm's capsules (upper arm, forearm, hand) keep clear of
    ``solids`` (object names, where Blender has them at each instant) by their radii at
    every frame of ``result`` and three instants between; returns the wrist at the last
    frame and the arm length."""
    scene = bpy.context.scene
    scene.frame_set(result.frame_start)
    info = rig_mod.build(arm, side, overrides)
    capsules = clearance.Arm(arm, info)

    def tris():
        return np.concatenate([np.zeros((0, 3, 3))]
                              + [triangles(bpy.data.objects[name]) for name in solids])

    capsules.check_instants(tris, range(result.frame_start, result.frame_end + 1))
    print(f"{solids}: worst margins (arm lengths): {capsules.report()}")
    scene.frame_set(result.frame_end)
    return capsules.wrist(), info.arm.arm_length


def slide(ob, start, end, frame):
    """Key ``ob`` moving from ``start`` (frame 1) to ``end`` (``frame``); the scene on frame 1."""
    ob.location = tuple(start)
    ob.keyframe_insert("location", frame=1)
    ob.location = tuple(end)
    ob.keyframe_insert("location", frame=frame)
    bpy.context.scene.frame_set(1)

def test_a_reach_stays_clear_of_an_obstacle_that_moves_into_its_path(fresh, addon):
    arm, info = humanoid()
    target = rigs.add_target("Cup", point(info, 0.75, 0.1, -0.15))
    wrist = info.joints_world["wrist"]
    path = np.array(target.location) - wrist
    normal = path / np.linalg.norm(path)
    across = np.cross(normal, info.frame.up)
    across /= np.linalg.norm(across)
    rot = np.column_stack([across, np.cross(normal, across), normal])
    length = info.arm.arm_length
    # a plate square across the straight path, half way; on frame 1 it is far to the side
    plate = rigs.add_box("Plate", wrist + 0.5 * path, (0.3 * length, 0.3 * length,
                                                       0.04 * length), rot)
    across_path = np.array(plate.location)
    slide(plate, across_path + 1.5 * length * info.frame.right, across_path, 4)

    outcome = bake(addon, arm, [target])
    result = outcome.results[0]
    assert result.success, result.message
    wrist_end, _ = check_clear(arm, "right", result, ["Plate"])
    assert np.linalg.norm(wrist_end - np.array(target.location)) <= 0.006 * length


def test_a_sequence_whose_first_target_fails_keeps_the_next_reach_clear_of_a_moving_obstacle(
        fresh, addon):
    """Fuzz seed 2689: a sequence baked with "bake closest", whose first reach failed: the
    second reach succeeded but was planned among the obstacles of its start frame only,
    and an animated obstacle then cut through the baked hand. The reaches that succeed
    are planned against every place the moving obstacles take, whether or not another
    reach of the plan failed."""
    arm, info = humanoid()
    length = info.arm.arm_length
    far = rigs.add_target("Far", point(info, 0.3, 0.2, 3.0))          # out of reach, above
    target = rigs.add_target("Cup", point(info, 0.75, 0.1, -0.15))
    # where the first (failed) reach ends, from a bake without the obstacle
    first = bake(addon, arm, [far, target], task="sequence", bake_closest=True).results[0]
    assert not first.success and first.reason in addon.core.REASONS
    bpy.context.scene.frame_set(first.frame_end)
    start = rig_mod.build(arm, "right").joints_world["wrist"]
    bpy.context.scene.frame_set(1)
    # a plate across the second reach's straight path, half way; on frame 1 it is far to
    # the side, on frame 4 in place
    path = np.array(target.location) - start
    normal = path / np.linalg.norm(path)
    across = np.cross(normal, info.frame.forward)
    across /= np.linalg.norm(across)
    rot = np.column_stack([across, np.cross(normal, across), normal])
    plate = rigs.add_box("Plate", start + 0.5 * path, (0.3 * length, 0.3 * length,
                                                       0.04 * length), rot)
    across_path = np.array(plate.location)
    slide(plate, across_path + 1.5 * length * info.frame.right, across_path, 4)

    outcome = bake(addon, arm, [far, target], task="sequence", bake_closest=True,
                   new_action=True)
    first, second = outcome.results
    assert not first.success and first.reason in addon.core.REASONS
    assert second.success, second.message
    wrist_end, _ = check_clear(arm, "right", second, ["Plate"])
    assert np.linalg.norm(wrist_end - np.array(target.location)) <= 0.006 * length


def test_a_motion_an_obstacle_cannot_miss_fails_with_its_name(fresh, addon):
    """A plate that comes down onto the hanging forearm at frame 3: no motion gets out of
    its way in time, so the reach fails naming it (it succeeded, touched, before)."""
    arm, info = humanoid()
    target = rigs.add_target("Cup", point(info, 0.6, 0.3, 0.1))
    length = info.arm.arm_length
    elbow, wrist = info.joints_world["elbow"], info.joints_world["wrist"]
    plate = rigs.add_box("Lid", 0.5 * (elbow + wrist), (0.5 * length, 0.5 * length,
                                                       0.04 * length))
    low = np.array(plate.location)
    slide(plate, low + 1.2 * length * info.frame.up, low, 3)

    result = bake(addon, arm, [target]).results[0]
    assert not result.success
    assert result.reason in addon.core.REASONS and "'Lid'" in result.message


def test_a_target_carried_by_the_reaching_hand_is_refused(fresh, addon):
    arm, info = humanoid()
    target = rigs.add_target("Ring", info.joints_world["wrist"])
    hand = info.bones.arms["right"].hand
    target.parent, target.parent_type, target.parent_bone = arm, "BONE", hand
    bpy.context.view_layer.update()
    target.matrix_world.translation = point(info, 0.6, 0.2, 0.0).tolist()
    with pytest.raises(addon.core.ReachError, match=f"'Ring' is carried by bone '{hand}'"):
        bake(addon, arm, [target], side="right")
    # 'auto' takes the arm that does not carry it
    outcome = bake(addon, arm, [target], side="auto")
    assert outcome.rig.side == "left"


def test_a_target_carried_by_the_other_hand_stays_put(fresh, addon):
    """A cup held up by the left hand, out to the right, where a reach would turn the chest
    (by 24°): the chest, which carries the left arm, is kept still, so the cup is where the
    wrist arrives."""
    arm, info = humanoid()
    where = point(info, 0.0, 0.9, 0.2)
    cup = rigs.add_target("Cup", where)
    cup.parent, cup.parent_type = arm, "BONE"
    cup.parent_bone = info.bones.arms["left"].hand
    bpy.context.view_layer.update()
    cup.matrix_world.translation = where.tolist()
    bpy.context.view_layer.update()

    result = bake(addon, arm, [cup], side="right").results[0]
    assert result.success, result.message
    assert "the chest was kept still: target 'Cup' is carried by bone" in result.message
    wrist_end, length = check_clear(arm, "right", result, [])
    gap = np.linalg.norm(wrist_end - np.array(cup.matrix_world.translation))
    assert gap <= 0.006 * length, f"the wrist is {gap / length:.3f} arm lengths from the cup"


@pytest.mark.parametrize("what", ["target", "armature", "obstacle"])
def test_an_infinite_location_is_refused_naming_the_object(fresh, addon, what):
    """Blender keeps an infinite value typed into a field as 3.4e38: finite to numpy, it
    overflowed the rig's arithmetic ('body capsule 'chest' is not finite', naming nothing)
    or was planned for as a far target; it is refused as NaN is."""
    arm, info = humanoid()
    target = rigs.add_target("Cup", point(info, 0.6, 0.2, 0.0))
    box = rigs.add_box("Crate", point(info, 0.6, 0.8, -0.5), (0.2, 0.2, 0.2))
    ob = {"target": target, "armature": arm, "obstacle": box}[what]
    ob.location = (float("inf"), 0.0, 0.0)
    bpy.context.view_layer.update()
    assert np.isfinite(np.array(ob.matrix_world)).all()      # Blender made it 3.4e38
    with pytest.raises(addon.core.ReachError, match=f"'{ob.name}' has (a )?NaN or infinite"):
        bake(addon, arm, [target])


def test_an_obstacle_at_an_infinite_location_is_signed_without_a_warning(fresh, addon):
    """Fuzz seed 3638 (a chase): the obstacle cache's signature rounded the object's
    matrix, and rounding 3.4e38 overflowed with numpy's RuntimeWarning. The signature is
    read without one, is the same when read again, and changes when the object comes
    back."""
    import warnings

    scene_mod = addon.blender.scene
    arm, info = humanoid()
    box = rigs.add_box("Crate", point(info, 0.6, 0.8, -0.5), (0.2, 0.2, 0.2))
    cache = scene_mod.ObstacleCache(scene_mod.character_objects(arm, bpy.context.scene))
    box.location = (float("inf"), 0.0, 0.0)
    bpy.context.view_layer.update()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        far = cache.compute_signature(bpy.context, geometry=True)
        assert cache.compute_signature(bpy.context, geometry=True) == far
    assert any(entry[1] == "Crate" for entry in far)
    box.location = point(info, 0.6, 0.8, -0.5).tolist()
    bpy.context.view_layer.update()
    assert cache.compute_signature(bpy.context, geometry=True) != far


def test_a_closed_room_round_the_character_is_named_and_explained(fresh, addon):
    """A closed box round the whole character (fuzz seed 98): its inside counts as solid,
    so the start is refused, and the message says why and what to do, not that the arm
    touches a wall it is metres from."""
    arm, info = humanoid()
    target = rigs.add_target("Cup", point(info, 0.6, 0.2, 0.0))
    rigs.add_box("Room", info.joints_world["shoulder"], (6.0, 6.0, 4.0))
    result = bake(addon, arm, [target]).results[0]
    assert not result.success and result.reason == addon.core.START_IN_COLLISION
    assert "chest (sternum) is enclosed by the mesh 'Room'" in result.message
    assert "leave 'Room' out of the obstacles" in result.message
    assert "already touches" not in result.message


def test_bone_overrides_rescue_a_rig_detection_fails(fresh, addon):
    """Numbered bones with twin chains on each arm (fuzz seeds 386, 780): nothing tells
    the arms apart, so detection fails naming each override to set; set, they are used."""
    names = synthetic.NUMBERED
    arm = synthetic.humanoid(names, decoy="twin", clavicle=False, name="Rig")
    with pytest.raises(addon.core.ReachError,
                       match="set upper_arm_right, forearm_right, hand_right, upper_arm_left"):
        addon.blender.rig.build(arm, "right")
    overrides = {f"{role}_{side}": names[f"{role}_{tag}"]
                 for side, tag in (("right", "R"), ("left", "L"))
                 for role in ("upper_arm", "forearm", "hand")}
    info = addon.blender.rig.build(arm, "right", overrides)
    assert info.bones.arms["right"].upper_arm == names["upper_arm_R"]
    assert info.bones.chest == names["chest"]
    target = rigs.add_target("Cup", point(info, 0.6, 0.2, 0.0))
    outcome = bake(addon, arm, [target], side="right", overrides=overrides)
    assert outcome.results[0].success, outcome.results[0].message
    check_clear(arm, "right", outcome.results[0], [], overrides)
