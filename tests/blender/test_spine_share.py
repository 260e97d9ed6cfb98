"""The chest's turn shared down the spine (``Settings.spine_share``; issue "Reach past the
arm", item 1: *Table 1's rotation is shared over pelvis, spine and chest*), on every rig of
``test_every_rig``, measured on what Blender evaluates, against the same reach baked with
the chest turning alone:

- at every frame the chest and the hand are where the chest-alone bake has them: the arm
  the planner checked is the arm keyed;
- between keys (three instants a frame) the wrist stays within :data:`BETWEEN` arm lengths
  of the chest-alone bake's;
- each shared bone has turned, at the end, by its share of the chest's turn about an axis
  near the body's up, and the chest against its parent by what is left;
- a rig without a spine bone between the chest and the hips (the robot), and Rigify's
  torso controls, say why nothing is shared;
- a bake again over the same frames replaces Reach's own spine keys, and one with the share
  off leaves the spine as it stood; a key a user set on a spine bone is kept and that bone
  is left out.
"""

from __future__ import annotations

import math

import bpy
import everyday
import numpy as np
import pytest
import rigs
from test_body_lean import open_rig
from test_every_rig import KINDS, rig_file  # noqa: F401  (the fixture)

#: How far the wrist may be between keys from where the chest-alone bake has it (arm
#: lengths): each bone's keys are interpolated on their own, so a composed turn between two
#: keys differs from a single one by a second-order amount.
BETWEEN = 1e-4
#: Slack on the turns' shares (degrees).
SHARE_SLACK = 1.0


def reach(addon, armature, info, share, frame_start=1):
    target = bpy.data.objects.get("Behind") or bpy.data.objects.new("Behind", None)
    if target.name not in bpy.context.scene.objects:
        bpy.context.scene.collection.objects.link(target)
    target.location = tuple(everyday.at(info, -0.25, 0.7, -0.2))
    settings = addon.core.Settings().replace(spine_share=share)
    pipeline = addon.blender.pipeline
    request = pipeline.Request(armature.name, [target.name], task="reach", side="right",
                               frame_start=frame_start, draw=False, settings=settings)
    outcome = pipeline.run(bpy.context, request, bake=True)
    result = outcome.results[0]
    assert result.success, result.message
    return result


def world(armature, bone):
    return np.array(armature.matrix_world) @ np.array(armature.pose.bones[bone].matrix)


def rotation(m):
    r = m[:3, :3]
    return r / np.linalg.norm(r, axis=0)


def angle_axis(r):
    """(degrees, unit axis) of rotation ``r``."""
    c = max(-1.0, min(1.0, (np.trace(r) - 1.0) / 2.0))
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    n = np.linalg.norm(v)
    return math.degrees(math.acos(c)), (v / n if n > 1e-12 else np.array([0.0, 0.0, 1.0]))


def track(armature, bones, frames):
    scene = bpy.context.scene
    out = []
    for f in frames:
        scene.frame_set(int(f), subframe=float(f - int(f)))
        out.append({b: world(armature, b) for b in bones})
    return out


@pytest.mark.parametrize("kind", KINDS + ("rigify",))
def test_the_spine_takes_its_share_of_the_chests_turn(addon, rig_file, kind):  # noqa: F811
    armature = open_rig(rig_file, kind)
    info = addon.blender.rig.build(armature, "right")
    chest, hand = info.bones.keyed_chest, info.bones.arms["right"].hand
    length = info.arm.arm_length
    alone = reach(addon, armature, info, 0.0)
    assert not any(k.startswith("spine_") for k in alone.stats), alone.stats
    frames = np.arange(alone.frame_start, alone.frame_end + 1, dtype=float)
    between = np.concatenate([frames[:-1] + s for s in (0.25, 0.5, 0.75)])
    before = track(armature, (chest, hand), np.concatenate([frames, between]))

    armature = open_rig(rig_file, kind)
    shared = reach(addon, armature, info, 0.4)
    bones = [b for b in shared.stats.get("spine_bones", "").split(", ") if b]
    print(f"SPINE {kind}: {bones or shared.stats.get('spine_note')}, "
          f"{shared.stats.get('spine_turn_deg')}°")
    if info.bones.key_chest:
        assert "torso controls" in shared.stats["spine_note"]
        return
    if not bones:
        assert "no spine bone" in shared.stats["spine_note"], shared.stats
        return
    after = track(armature, (chest, hand, *bones), np.concatenate([frames, between]))
    worst = 0.0
    for i, (a, b) in enumerate(zip(before, after)):
        for bone in (chest, hand):
            d = np.linalg.norm(a[bone][:3, 3] - b[bone][:3, 3]) / length
            turn = angle_axis(rotation(a[bone]).T @ rotation(b[bone]))[0]
            if i < len(frames):
                assert d < 1e-5 and turn < 0.01, (kind, bone, frames[i], d, turn)
            else:
                worst = max(worst, d)
    assert worst < BETWEEN, (kind, worst)

    up = np.asarray(info.frame.up, dtype=float)
    first, last = after[0], after[len(frames) - 1]
    total, axis = angle_axis(rotation(last[chest]) @ rotation(first[chest]).T)
    assert total > 10.0, (kind, total)          # the scene turns the chest
    assert abs(axis @ up) > 0.9, (kind, axis)
    b_data = armature.data.bones
    lengths = np.array([b_data[b].length for b in bones])
    shares = 0.4 * np.cumsum(lengths) / lengths.sum()
    for bone, share in zip(bones, shares):
        turn, bone_axis = angle_axis(rotation(last[bone]) @ rotation(first[bone]).T)
        assert abs(turn - share * total) < SHARE_SLACK, (kind, bone, turn, share * total)
        assert abs(bone_axis @ up) > 0.9, (kind, bone, bone_axis)
    own = angle_axis(rotation(last[bones[-1]]).T @ rotation(last[chest])
                     @ (rotation(first[bones[-1]]).T @ rotation(first[chest])).T)[0]
    assert abs(own - 0.6 * total) < SHARE_SLACK, (kind, own, total)
    assert shared.stats["spine_turn_deg"] == pytest.approx(0.4 * total, abs=SHARE_SLACK)
    print(f"  chest {total:.1f}°, its own {own:.1f}°, wrist between keys {worst:.1e} arm")

    # again over the same frames: Reach's own spine keys are replaced, not refused
    again = reach(addon, armature, info, 0.4)
    assert again.stats.get("spine_bones") == shared.stats["spine_bones"]
    # and with the share off, left where the earlier bake ended: the spine is back as it
    # stood (a channel whose keys are cleared is set to its value at the bake's start)
    bpy.context.scene.frame_set(again.frame_end)
    off = reach(addon, armature, info, 0.0)
    assert "spine_bones" not in off.stats
    back = track(armature, bones, frames[:1])[0]
    for bone in bones:
        assert angle_axis(rotation(back[bone]).T @ rotation(first[bone]))[0] < 0.01, bone

    # a user's key on the lowest shared bone: kept, and that bone is left out
    armature = open_rig(rig_file, kind)
    pb = armature.pose.bones[bones[0]]
    path = {"QUATERNION": "rotation_quaternion",
            "AXIS_ANGLE": "rotation_axis_angle"}.get(pb.rotation_mode, "rotation_euler")
    pb.keyframe_insert(path, frame=200)
    kept = reach(addon, armature, info, 0.4)
    assert bones[0] not in kept.stats.get("spine_bones", "").split(", "), kept.stats
    keys = [kp.co[0] for fc in rigs.fcurves(armature.animation_data.action)
            if fc.data_path == f'pose.bones["{bones[0]}"].{path}' for kp in fc.keyframe_points]
    assert keys and all(k == 200.0 for k in keys), keys


def test_a_lean_keeps_the_spine_below_the_chest_as_one_piece(addon, rig_file):  # noqa: F811
    """The lean's checks of the trunk's skin and balance hold the trunk below the chest as
    one piece: where the body leans, nothing is shared and the report says why."""
    from test_body_lean import run

    armature = open_rig(rig_file, "metarig")
    info = addon.blender.rig.build(armature, "right")
    _target, _table, outcome = run(addon, armature, info, 1.3, True, True)
    result = outcome.results[0]
    assert result.success and "lean" in result.message, result.message
    assert result.stats["spine_note"].startswith("the body leans"), result.stats
    assert "spine_bones" not in result.stats
    keyed = {fc.data_path.split('"')[1] for fc in rigs.fcurves(armature.animation_data.action)}
    assert "spine.002" not in keyed, sorted(keyed)


#: How far the chest and the hand may be at a key from where the chest alone put them, with
#: the pelvis turning (arm lengths): a leg standing straight needs the hips to come down by
#: the square of the hip joint's move over twice the leg, which the turn is held within
#: (pelvis_turn.DROP, 5e-4).
PELVIS_DROP = 6e-4


def behind(addon, armature, info, **settings):
    target = bpy.data.objects.get("Behind") or bpy.data.objects.new("Behind", None)
    if target.name not in bpy.context.scene.objects:
        bpy.context.scene.collection.objects.link(target)
    target.location = tuple(everyday.at(info, -0.55, 0.45, -0.2))
    pipeline = addon.blender.pipeline
    request = pipeline.Request(armature.name, [target.name], task="reach", side="right",
                               frame_start=1, draw=False,
                               settings=addon.core.Settings().replace(**settings))
    result = pipeline.run(bpy.context, request, bake=True).results[0]
    assert result.success, result.message
    return result


def heads(armature):
    mw = armature.matrix_world
    return {pb.name: np.array(mw @ pb.head) for pb in armature.pose.bones}


@pytest.mark.parametrize("kind", KINDS + ("rigify",))
def test_past_the_trunks_range_the_pelvis_turns_over_planted_feet(addon, rig_file, kind):  # noqa: F811
    """A target behind the shoulder turns the chest past 33° against the feet: the pelvis
    takes the rest, about the vertical, the feet planted, the chest and the hand where the
    chest alone put them."""
    armature = open_rig(rig_file, kind)
    info = addon.blender.rig.build(armature, "right")
    chest, hand = info.bones.keyed_chest, info.bones.arms["right"].hand
    length, up = info.arm.arm_length, np.asarray(info.frame.ground, dtype=float)
    alone = behind(addon, armature, info, spine_share=0.0)
    frames = np.arange(alone.frame_start, alone.frame_end + 1, dtype=float)
    before = track(armature, (chest, hand), frames)
    total = angle_axis(rotation(before[-1][chest]) @ rotation(before[0][chest]).T)[0]

    armature = open_rig(rig_file, kind)
    bpy.context.scene.frame_set(1)
    start = heads(armature)
    result = behind(addon, armature, info)
    stats = result.stats
    pelvis = stats.get("spine_pelvis_bone")
    print(f"PELVIS {kind}: chest {total:.1f}°, {pelvis} {stats.get('spine_pelvis_deg')}°, "
          f"spine {stats.get('spine_turn_deg')}°; {stats.get('spine_note')}")
    if info.bones.key_chest:
        assert "torso controls" in stats["spine_note"]
        return
    if total < 33.0 + 0.5:
        assert pelvis is None, stats
        return
    assert pelvis is not None, stats
    after = track(armature, (chest, hand, pelvis), frames)
    diffs = [[float(np.linalg.norm(a[b][:3, 3] - c[b][:3, 3]) / length) for b in (chest, hand)]
             for a, c in zip(before, after)]
    worst = max(max(d) for d in diffs)
    assert worst < PELVIS_DROP, (kind, worst)
    turn, axis = angle_axis(rotation(after[-1][pelvis]) @ rotation(after[0][pelvis]).T)
    # all past 33°, or less where a straight leg would bring the hips down farther than
    # pelvis_turn.DROP (the Male Base Mesh)
    assert 0.5 * (total - 33.0) < turn < total - 33.0 + 0.5, (kind, turn, total)
    assert abs(axis @ up) > 0.99, (kind, axis)
    assert stats["spine_pelvis_deg"] == pytest.approx(turn, abs=0.5)
    assert stats["spine_turn_deg"] == pytest.approx(0.4 * (total - turn), abs=0.5)
    # the feet planted: every bone whose head stood below the knees (a tenth of an arm
    # below the lower knee: the knees themselves move as the hips turn over them), at
    # every frame
    legs = addon.blender.balance.find_legs(armature, info.bones, info.frame)
    knee = min(float(addon.blender.balance.point_of(armature, leg.knee) @ up) for leg in legs)
    low = [n for n, p in start.items() if p @ up < knee - 0.1 * length]
    assert low
    slid = 0.0
    for f in frames:
        bpy.context.scene.frame_set(int(f))
        now = heads(armature)
        slid = max(slid, max(np.linalg.norm(now[n] - start[n]) for n in low) / length)
    assert slid < 0.002, (kind, slid)
    print(f"  chest and hand within {worst:.1e} arm lengths, feet {slid:.1e}, pelvis {turn:.1f}°")


def test_a_bar_before_the_thighs_keeps_the_pelvis_still(addon, rig_file):  # noqa: F811
    """The pelvis's turn carries the hips and thighs round: where their skin would come
    within the clearance of an obstacle (a bar 0.03 arm lengths in front of the thighs,
    the pelvis let turn past 10° of trunk), the pelvis stays, the spine and chest take the
    whole turn, and the report says why; without the bar it turns."""
    from test_body_lean import skin_vertices

    armature = open_rig(rig_file, "quaternius")
    info = addon.blender.rig.build(armature, "right")
    legs = addon.blender.balance.find_legs(armature, info.bones, info.frame)
    hip = np.mean([addon.blender.balance.point_of(armature, leg.hip) for leg in legs], axis=0)
    length = info.arm.arm_length
    forward, up = np.asarray(info.frame.forward, float), np.asarray(info.frame.ground, float)
    band = hip - 0.1 * length * up
    skin = skin_vertices(armature, set())
    thighs = skin[np.abs((skin - band) @ up) < 0.15 * length]
    nearest = thighs[int(np.argmax((thighs - band) @ forward))]    # the bar at its height
    band = band + float((nearest - band) @ up) * up
    front = float((nearest - band) @ forward)
    depth = 0.05 * length
    turned = behind(addon, armature, info, trunk_turn_max=10.0)
    assert turned.stats.get("spine_pelvis_deg", 0.0) > 20.0, turned.stats

    armature = open_rig(rig_file, "quaternius")
    rigs.add_box("Bar", band + (front + 0.03 * length + depth / 2) * forward,
                 np.array([depth, 0.8 * length, 0.1 * length]),
                 np.column_stack([forward, np.cross(up, forward), up]))
    result = behind(addon, armature, info, trunk_turn_max=10.0)
    stats = result.stats
    assert "spine_pelvis_bone" not in stats, stats
    assert "the pelvis stays: turning the pelvis would bring the lower body against 'Bar'" \
        in stats["spine_note"], stats
    assert stats["spine_turn_deg"] > 0.4 * 30.0, stats
