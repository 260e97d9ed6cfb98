"""The baked motion as an animator sees it, on real rigs and a bulky synthetic character:
evaluated by Blender at 4 instants per frame (``frame_set(f, subframe=s)``) and checked with
geometry that shares nothing with the planner.

Each scene is built around the rig in its own body frame and scaled by its own arm: a plate
across the straight path (``rigs.plate_scene``), and a ledge the hand must reach over. At
every instant:

* the arm's capsules (upper arm, forearm, hand) keep clear of the obstacles' triangles by
  their radii (``clearance``: exact distances, numpy), and no bone of the arm or of the
  hand, finger bones included, passes through them;
* the hand's direction relative to the forearm (the forearm bone's own matrix, as Blender
  evaluates it) turns at most the hand turn speed limit per frame, and no bone of the hand
  turns in space faster than the hand turn speed in space;
* at every keyed frame the keyed hand is the planned hand: the wrist where the plan has it,
  the hand's axis (wrist to the mean of its finger joints) along the plan's.
"""

import bpy
import clearance
import numpy as np
import pytest
import rigs
import synthetic
from clearance import hand_bones, segments
from geometry import angle_deg, segment_triangle_distances
from test_bake import triangles

INSTANTS = (0.0, 0.25, 0.5, 0.75)


def bulky():
    """A synthetic character with thick limbs (skin 7.5 cm from every bone, an arm of 0.54 m:
    the forearm's radius is about a seventh of the arm)."""
    rigs.empty_file()
    return synthetic.humanoid(synthetic.MIXAMO, skin_radius=0.075, name="Bulky")


def load(kind):
    if kind == "bulky":
        return bulky()
    arm = rigs.load(kind)
    rigs.rest_still(arm)
    return arm


def ledge_scene(info):
    """A ledge in front of the reaching side at wrist height of a forward reach: a box
    from below the start wrist up to just under the shoulder, and the target behind its far
    edge, so the hand must go up and over it."""
    f, length = info.frame, info.arm.arm_length
    side = f.right if info.side == "right" else -f.right
    shoulder = info.joints_world["shoulder"]
    top = shoulder - 0.25 * length * f.up
    centre = top - 0.3 * length * f.up + 0.45 * length * f.forward + 0.1 * length * side
    rot = np.column_stack([f.right, f.forward, f.up])
    ledge = rigs.add_box("Ledge", centre, (0.6 * length, 0.12 * length, 0.6 * length), rot)
    target = rigs.add_target("Cup", top + 0.15 * length * f.up + 0.62 * length * f.forward
                             + 0.1 * length * side)
    return target, ledge


def bone_distances(armature, names, tris):
    """Exact distances from the bones ``names`` (head to tail, as Blender evaluates them now)
    to the triangles."""
    segs = segments(armature, names)
    return segment_triangle_distances([p for p, _q in segs], [q for _p, q in segs], tris)


def hand_in_forearm(armature, forearm, bones):
    """The hand's direction (wrist → mean of its finger joints) in the forearm bone's frame."""
    mw = np.array(armature.matrix_world)
    rot = mw[:3, :3] @ np.array(armature.pose.bones[forearm].matrix)[:3, :3]
    rot /= np.linalg.norm(rot, axis=0)
    segs = segments(armature, bones)
    wrist = segs[0][0]
    pts = np.array([p for s in segs[1:] for p in s]) if len(segs) > 1 else np.array([segs[0][1]])
    d = pts.mean(0) - wrist
    return rot.T @ (d / np.linalg.norm(d))


@pytest.mark.parametrize("scene", ["plate", "ledge"])
@pytest.mark.parametrize("kind", rigs.RIGS + ("bulky",))
def test_baked_reach_is_clear_and_smooth_at_every_instant(fresh, addon, kind, scene):
    armature = load(kind)
    info = addon.blender.rig.build(armature, "right")
    if scene == "plate":
        target, obstacle = rigs.plate_scene(info, armature)
    else:
        target, obstacle = ledge_scene(info)
    tris = triangles(obstacle)
    outcome, res, plan, first = rigs.bake_reach(addon, armature, target)
    length = info.arm.arm_length
    s = outcome.request.settings
    fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    bones = info.bones.arms["right"]
    chain = [bones.upper_arm, bones.forearm]
    hand = hand_bones(armature, bones.hand)
    planned = plan.world_joints()
    capsules = clearance.Arm(armature, info)
    # a rig driven through constraints (Rigify) is settled against its evaluated pose: the
    # keyed wrist is on the plan's everywhere, chest turned or not, up to the residual the
    # bake reports (the spine's own stretch), which stays within a percent of the arm
    residual = res.stats.get("rig_residual_arm_lengths", 0.0)
    assert 0.0 <= residual <= 0.01
    wrist_tolerance = max(0.005, residual + 0.001) * length

    scene_ = bpy.context.scene
    worst, worst_at, prev_dir, turns, space, prev_bones = np.inf, None, None, [], [], None
    for f in range(res.frame_start, res.frame_end + 1):
        for sub in INSTANTS if f < res.frame_end else (0.0,):
            scene_.frame_set(f, subframe=sub)
            capsules.check(tris, f"{kind} {scene}: frame {f + sub:g}")
            d = bone_distances(armature, chain + hand, tris)
            if d.min() < worst:
                worst, worst_at = float(d.min()), (f, sub, (chain + hand)[int(d.argmin())])
            if sub == 0.0:
                # the keyed hand is the planned hand: the wrist where the plan has it, and
                # the hand's axis (wrist → mean of its finger joints, or of its skin
                # where it has no fingers) along the plan's hand
                j = planned[f - first]
                segs = segments(armature, hand)
                wrist = segs[0][0]
                pts = np.array([x for seg in segs[1:] for x in seg]) if len(segs) > 1 \
                    else np.array([clearance.hand_axis_point(armature, (bones.hand,),
                                                             capsules.anchor)])
                assert np.linalg.norm(wrist - j[3]) <= wrist_tolerance, \
                    f"frame {f}: the keyed wrist is off the plan's"
                off = angle_deg(pts.mean(0) - wrist, j[4] - j[3])
                assert off <= 2.0, f"frame {f}: the keyed hand is {off:.1f}° off the plan's"
            if sub == 0.0:
                now = hand_in_forearm(armature, bones.forearm, hand)
                bones_now = [q - p for p, q in segments(armature, hand)]
                if prev_dir is not None:
                    turns.append(angle_deg(prev_dir, now))
                    space.append(max(angle_deg(a, b) for a, b in zip(prev_bones, bones_now)))
                prev_dir, prev_bones = now, bones_now
    print(f"{kind} {scene}: worst margins (arm lengths): {capsules.report()}")
    assert worst > 0.0, f"{worst_at}: a bone passes through the {obstacle.name}"
    assert max(turns) <= s.hand_turn_speed / fps + 2.0, \
        f"the hand turns {max(turns):.1f}° relative to the forearm in one frame"
    assert max(space) <= s.hand_space_turn_speed / fps + 2.0, \
        f"a bone of the hand turns {max(space):.1f}° in space in one frame"
    st = res.stats
    assert st["touching_transitions"] == 0 and st["unbounded_hand_turns"] == 0
    assert 0.0 <= st["mean_wrist_bend_deg"] <= st["max_wrist_bend_deg"]


@pytest.mark.parametrize("kind", ["quaternius", "gomakehuman"])
def test_fingertips_a_centimetre_from_a_wall_start_out_of_contact(fresh, addon, kind):
    """A start within the clearance of a wall is planned out of contact (it used to be
    refused): the hand's bones get no nearer the wall on the way out, and nothing passes
    through it at any instant. The hand's capsule starts inside the wall (a hand resting on
    a surface sinks its round capsule into it) and comes out at every instant, no capsule
    nearer the wall than at the instant before, until it is clear by the whole margin;
    from then on the capsules keep the room they keep everywhere (``clearance``)."""
    armature = load(kind)
    info = addon.blender.rig.build(armature, "right")
    f, length = info.frame, info.arm.arm_length
    bones = info.bones.arms["right"]
    hand = hand_bones(armature, bones.hand)
    side = f.right if info.side == "right" else -f.right
    # the wall's face half a centimetre (on an adult) beyond the arm's outermost surface
    # at the side: the fingers, and the forearm's and hand's thickness
    a = info.arm
    tips = np.array([x for seg in segments(armature, hand) for x in seg])
    w, e = info.joints_world["wrist"], info.joints_world["elbow"]
    outer = max(float((tips @ side).max()), float(w @ side) + max(a.forearm_radius, a.hand_radius),
                float(e @ side) + max(a.forearm_radius, a.upper_arm_radius))
    face = outer + 0.005 * length / 0.58
    centre = w + side * (face - float(w @ side) + 0.02 * length)
    wall = rigs.add_box("Wall", centre, (0.04 * length, 0.8 * length, 0.8 * length),
                        np.column_stack([f.right, f.forward, f.up]))
    tris = triangles(wall)
    start = bone_distances(armature, hand, tris).min()
    assert start < request_margin(addon) * length, "the fingertips must start within the clearance"
    target = rigs.add_target("Cup", info.joints_world["shoulder"] + 0.65 * length * f.forward
                             - 0.1 * length * f.up)
    request = addon.blender.pipeline.Request(armature=armature.name, targets=[target.name],
                                             side="right", frame_start=1)
    outcome = addon.blender.pipeline.run(bpy.context, request, bake=True)
    res = outcome.results[0]
    assert res.success, res.message
    capsules = clearance.Arm(armature, info)
    near, room, instants = [], [], []
    for fr in range(res.frame_start, res.frame_end + 1):
        for sub in INSTANTS if fr < res.frame_end else (0.0,):
            bpy.context.scene.frame_set(fr, subframe=sub)
            near.append(bone_distances(armature, [bones.upper_arm, bones.forearm] + hand,
                                       tris).min())
            room.append(min(capsules.margins(tris).values()))
            instants.append(fr + sub)
    assert min(near) > 0.0, "a bone passes through the wall"
    clear_at = next(i for i, d in enumerate(near) if d >= request_margin(addon) * length)
    assert all(b >= a - 0.001 * length for a, b in zip(near[:clear_at], near[1:clear_at + 1]))
    assert room[0] < 0.0, "the hand's capsule must start inside the wall"
    out = next(i for i, m in enumerate(room)
               if m >= request_margin(addon) - clearance.TOLERANCE)
    assert all(b >= a - 0.001 for a, b in zip(room[:out], room[1:out + 1])), \
        f"a capsule gets nearer the wall on the way out: {room[:out + 1]}"
    worst = int(np.argmin(room[out:])) + out
    print(f"{kind}: out of contact at frame {instants[out]:g}; then least room "
          f"{room[worst]:+.4f} arm lengths at frame {instants[worst]:g}")
    assert room[worst] >= capsules.required, \
        f"frame {instants[worst]:g}: a capsule {room[worst]:+.4f} arm lengths from the wall"


def request_margin(addon):
    return addon.core.Settings().clearance


def test_a_bake_after_existing_animation_joins_it_without_a_jump(fresh, addon):
    """The user's animation moves the arm from its rest pose to another and holds there at
    frame 12; a reach baked from frame 12 starts from that pose, hand included, and moves
    off it as the animation arrived (at rest): no jump in position or in speed at the join,
    and the user's keys before it are kept."""
    armature = load("gomakehuman")
    info0 = addon.blender.rig.build(armature, "right")
    bones = info0.bones.arms["right"]
    keyed = [bones.keyed(r) for r in ("upper_arm", "forearm", "hand")]
    for name in keyed:
        pb = armature.pose.bones[name]
        pb.rotation_mode = "QUATERNION"
        pb.keyframe_insert("rotation_quaternion", frame=1)
    from mathutils import Quaternion
    armature.pose.bones[keyed[1]].rotation_quaternion = Quaternion((1, 0, 0), 0.5)
    armature.pose.bones[keyed[2]].rotation_quaternion = Quaternion((0, 0, 1), 0.4)
    for name in keyed:
        armature.pose.bones[name].keyframe_insert("rotation_quaternion", frame=12)
    bpy.context.scene.frame_set(12)
    info = addon.blender.rig.build(armature, "right")
    target, _plate = rigs.plate_scene(info, armature)
    before = {}
    for f in (10, 11, 12):
        bpy.context.scene.frame_set(f)
        before[f] = segments(armature, [bones.forearm, bones.hand])
    request = addon.blender.pipeline.Request(armature=armature.name, targets=[target.name],
                                             side="right", frame_start=12)
    outcome = addon.blender.pipeline.run(bpy.context, request, bake=True)
    res = outcome.results[0]
    assert res.success, res.message
    assert res.frame_start == 12
    length = info.arm.arm_length
    hand = hand_bones(armature, bones.hand)

    def points(f):
        bpy.context.scene.frame_set(f)
        return np.array([x for seg in segments(armature, [bones.forearm] + hand) for x in seg])

    # the user's frames before the join are as they were, and the join is where they end
    for f in (10, 11, 12):
        bpy.context.scene.frame_set(f)
        now = segments(armature, [bones.forearm, bones.hand])
        assert np.allclose(np.array(now), np.array(before[f]), atol=0.002 * length), f
    # speed (fastest point of forearm and hand, arm lengths per frame) around the join
    p = {f: points(f) for f in range(9, 16)}
    speed = {f: float(np.linalg.norm(p[f] - p[f - 1], axis=1).max()) / length for f in range(10, 16)}
    peak = max(float(np.linalg.norm(points(f) - points(f - 1), axis=1).max()) / length
               for f in range(13, res.frame_end + 1))
    assert speed[12] <= 0.1 * peak and speed[13] <= 0.1 * peak, (speed, peak)
