"""Chase bakes of animated targets on a shared rig (Quaternius, CC0), checked frame by frame
by evaluating the baked armature in Blender, independently of the planner: the wrist's
distance to the target and its speed, the joints' change per frame, and exact distances
from the arm's bones to the obstacles as they are on that frame."""

import json
import math

import bpy
import clearance
import numpy as np
import pytest
import rigs
from geometry import angle_deg, segment_clearance
from test_bake import SKIN_CHAIN, triangles, world_heads

CHAIN = SKIN_CHAIN["quaternius"]
KEY_FRAMES = (1, 10, 19, 28, 37)


def heads(armature):
    bpy.context.view_layer.update()
    return world_heads(armature, CHAIN)


def loop_points(info):
    """A loop in front of the right shoulder, across the body's right/up plane."""
    f, length = info.frame, info.arm.arm_length
    centre = (info.joints_world["shoulder"] + 0.6 * length * f.forward + 0.1 * length * f.right
              - 0.05 * length * f.up)
    angles = 2 * np.pi * np.arange(len(KEY_FRAMES)) / (len(KEY_FRAMES) - 1)
    return centre, [centre + 0.15 * length * (np.cos(a) * f.right + np.sin(a) * f.up)
                    for a in angles]


def linear(block):
    """Linear interpolation on every key of an ID's action (whatever the action API)."""
    action = block.animation_data.action
    curves = rigs.fcurves(action)
    for fc in curves:
        for k in fc.keyframe_points:
            k.interpolation = "LINEAR"
    return curves


def animated_target(kind, info):
    """The target moving round the loop by keys, a Follow Path constraint, or a parent."""
    _centre, points = loop_points(info)
    target = rigs.add_target("Ball", (0.0, 0.0, 0.0))
    if kind == "keys":
        for frame, p in zip(KEY_FRAMES, points):
            target.location = p
            target.keyframe_insert("location", frame=frame)
    elif kind == "parent":
        carrier = rigs.add_target("Carrier", (0.0, 0.0, 0.0))
        for frame, p in zip(KEY_FRAMES, points):
            carrier.location = p
            carrier.keyframe_insert("location", frame=frame)
        target.parent = carrier
    elif kind == "follow_path":
        curve = bpy.data.curves.new("Loop", "CURVE")
        curve.dimensions = "3D"
        spline = curve.splines.new("POLY")
        spline.points.add(len(points) - 1)
        for point, p in zip(spline.points, points):
            point.co = (*p, 1.0)
        curve.use_path = True
        curve.path_duration = KEY_FRAMES[-1] - KEY_FRAMES[0]
        path = bpy.data.objects.new("Loop", curve)
        bpy.context.scene.collection.objects.link(path)
        for frame, t in ((KEY_FRAMES[0], 0.0), (KEY_FRAMES[-1], curve.path_duration)):
            curve.eval_time = t
            curve.keyframe_insert("eval_time", frame=frame)
        linear(curve)
        con = target.constraints.new("FOLLOW_PATH")
        con.target = path
    bpy.context.scene.frame_end = 80            # longer than the motion: the range must end with it
    bpy.context.scene.frame_set(1)
    return target


def set_up(addon):
    arm = rigs.load("quaternius")
    rigs.rest_still(arm)
    info = addon.blender.rig.build(arm, "right")
    return arm, info


def bake_chase(arm, target):
    props = bpy.context.scene.reach
    props.armature, props.target, props.arm, props.task = arm, target, "RIGHT", "CHASE"
    assert bpy.ops.reach.bake() == {"FINISHED"}
    return json.loads(props.last_result)["tasks"][0]


@pytest.mark.parametrize("kind", ["keys", "follow_path", "parent"])
def test_chase_bake_follows_an_animated_target(fresh, addon, kind):
    arm, info = set_up(addon)
    settings = addon.core.Settings()
    length, f = info.arm.arm_length, info.frame
    centre, _points = loop_points(info)
    target = animated_target(kind, info)
    table = rigs.add_box("Table", centre - 0.3 * length * f.up, (0.9 * length, 0.9 * length,
                                                                  0.04 * length),
                         np.column_stack([f.right, f.forward, f.up]))
    tris = triangles(table)
    task = bake_chase(arm, target)
    assert task["success"], task["message"]
    assert (task["frame_start"], task["frame_end"]) == (1, KEY_FRAMES[-1]), \
        "the chase ends when the target's motion ends"

    fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    steps = int(settings.chase_max_speed / fps / settings.step + 1e-9)
    bound = steps * settings.max_joint_step
    prev, gaps, first_on = None, [], None
    for frame in range(task["frame_start"], task["frame_end"] + 1):
        bpy.context.scene.frame_set(frame)
        now = heads(arm)
        goal = np.array(target.matrix_world.translation)
        gap = float(np.linalg.norm(now[2] - goal)) / length
        gaps.append(gap)
        if first_on is None and gap <= settings.goal_tolerance + 1e-6:
            first_on = frame
        if prev is not None:
            speed = np.linalg.norm(now[2] - prev[2]) / length * fps
            assert speed <= settings.chase_max_speed * 1.02, f"frame {frame}: {speed:.2f} arm lengths/s"
            flex = [angle_deg(p[1] - p[0], p[2] - p[1]) for p in (prev, now)]
            assert abs(flex[1] - flex[0]) <= bound + 0.5, f"frame {frame}"
            assert angle_deg(prev[1] - prev[0], now[1] - now[0]) <= (1 + math.sqrt(2)) * bound + 0.5
        prev = now
    # it catches up at the speed limit, then stays on the target
    assert first_on is not None and first_on < 25
    after = np.array(gaps[first_on - 1:])
    assert (after <= settings.goal_tolerance + 1e-6).all()
    assert gaps[-1] <= settings.goal_tolerance + 1e-6
    # the gap shrinks while catching up: the wrist heads straight for the target
    assert all(b < a for a, b in zip(gaps[:first_on - 1], gaps[1:first_on]))
    # upper arm, forearm and hand clear of the table by their radii at every instant
    capsules = clearance.Arm(arm, info, CHAIN)
    capsules.check_instants(tris, range(task["frame_start"], task["frame_end"] + 1))
    print(f"{kind}: worst margins (arm lengths): {capsules.report()}")


def test_chase_bake_avoids_an_obstacle_that_moves_in(fresh, addon):
    arm, info = set_up(addon)
    length, f = info.arm.arm_length, info.frame
    target = animated_target("keys", info)
    # where the arm goes with nothing in the way
    request = addon.blender.pipeline.Request(armature=arm.name, targets=[target.name],
                                             task="chase", side="right", frame_start=1)
    free = addon.blender.pipeline.run(bpy.context, request, bake=False).plans[0][0]
    joints = free.world_joints()
    # a box that jumps in on frame 8 beside where the free chase has its forearm on frame 24
    spot = joints[23, 2] + 0.5 * (joints[23, 3] - joints[23, 2]) + 0.1 * length * f.forward
    box = rigs.add_box("Box", spot, (0.08 * length,) * 3, np.column_stack([f.right, f.forward, f.up]))
    for frame, p in ((1, spot + 3.0 * length * f.up), (8, spot)):
        box.location = p
        box.keyframe_insert("location", frame=frame)
    for fc in linear(box):
        for k in fc.keyframe_points:
            k.interpolation = "CONSTANT"
    hits = []
    for frame in range(1, KEY_FRAMES[-1] + 1):
        bpy.context.scene.frame_set(frame)
        tris = triangles(box)
        j = joints[frame - 1]
        hits.append(min(segment_clearance(j[1], j[2], tris), segment_clearance(j[2], j[3], tris)))
    assert min(hits) < 0.01 * length, "the free chase runs into the box once it is there"
    assert min(hits[:10]) > 0.1 * length, "the box does not land on the arm"

    bpy.context.scene.frame_set(1)
    task = bake_chase(arm, target)
    assert task["success"], task["message"]
    # upper arm, forearm and hand clear of the box by their radii at every instant, the
    # box where it is then
    capsules = clearance.Arm(arm, info, CHAIN)
    capsules.check_instants(lambda: triangles(box), range(task["frame_start"], task["frame_end"] + 1))
    print(f"moving box: worst margins (arm lengths): {capsules.report()}")
    bpy.context.scene.frame_set(task["frame_end"])
    assert np.linalg.norm(heads(arm)[2] - np.array(target.matrix_world.translation)) \
        <= 0.005 * length
