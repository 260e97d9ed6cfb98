"""The whole body in a guided reach (issue "Reach past the arm", item 5: guided uses it):
the scenes of ``test_body_lean`` (a cup 1.3 arm lengths ahead, over a table) and
``test_body_step`` (a cup 2.3 arm lengths to the side, beside a counter), baked as a
*guided* reach with *Lean* on, as a user's Bake is. Measured on what Blender evaluates:
the wrist (the hand bone's head) ends on the target; the report says the trunk leaned,
or the body stepped, first. Without *Lean* the same guided reach is refused as before.

A sequence or guided reach through two targets, a near one and the far one over the
table, reaches the near one upright, then leans and reaches the far one: each target
reached on its arrival frame, the trunk upright until the first, the feet held and the
skin clear of the table at every frame and instant between (``test_body_lean.walk``).
"""

from __future__ import annotations

from types import SimpleNamespace

import bpy
import everyday
import numpy as np
import pytest
import test_body_lean
import test_body_step
from test_body_lean import attach_loose_parts, bone_heads, open_rig, walk
from test_every_rig import ON_TARGET, rig_file  # noqa: F401  (the fixture)

RIGS = ("metarig", "quaternius")
#: Rigs that reach the far cup upright, turning the chest past Table 1's, where the others
#: are refused upright (``test_body_lean``'s far test).
TWIST_RIGS = ("alien", "malebase")


def bake(addon, armature, target, task, lean=True):
    pipeline = addon.blender.pipeline
    settings = addon.core.Settings().replace(lean=lean)
    request = pipeline.Request(armature.name, [target.name], task=task, side="right",
                               frame_start=1, draw=False, settings=settings)
    return pipeline.run(bpy.context, request, bake=True)


def wrist(armature, info, frame):
    bpy.context.scene.frame_set(frame)
    pb = armature.pose.bones[info.bones.arms["right"].hand]
    return np.array(armature.matrix_world @ pb.head)


@pytest.mark.parametrize("kind", RIGS)
def test_a_guided_reach_leans_past_the_arm_and_steps_farther(addon, rig_file, kind):  # noqa: F811
    for case in ("lean", "step"):
        armature = open_rig(rig_file, kind)
        attach_loose_parts(armature)
        info = addon.blender.rig.build(armature, "right")
        bpy.context.scene.frame_set(1)
        if case == "lean":
            target, _table = test_body_lean.scene(armature, info, 1.3)
        else:
            target, _counter = test_body_step.scene(armature, info)
        outcome = bake(addon, armature, target, "guided")
        result = outcome.results[0]
        print(f"GUIDED {kind} {case}: {result.message} "
              f"{ {k: v for k, v in result.stats.items() if k.startswith(('lean', 'step'))} }")
        assert result.success, result.message
        goal = np.array(target.matrix_world.translation)
        assert np.linalg.norm(wrist(armature, info, result.frame_end) - goal) <= \
            ON_TARGET * info.arm.arm_length
        lines = addon.ui.operators.body_lines(result.stats)    # the Result panel's
        if case == "lean":
            assert result.stats["lean_deg"] > 0.0, result.stats
            assert lines[-1].startswith(f"  trunk leaned {result.stats['lean_deg']:.0f}°")
        else:
            n = result.stats["step_count"]
            assert n >= 1, result.stats
            assert lines[0].startswith(f"  body: {n} step"), lines


def test_without_lean_a_guided_reach_past_the_arm_is_refused_as_before(addon, rig_file):  # noqa: F811
    armature = open_rig(rig_file, "metarig")
    info = addon.blender.rig.build(armature, "right")
    target, _table = test_body_lean.scene(armature, info, 1.3)
    result = bake(addon, armature, target, "guided", lean=False).results[0]
    assert not result.success and result.reason == "needs_lean", result.message
    assert "turn on Lean" in result.message
    assert addon.ui.operators.body_lines(result.stats) == []


@pytest.mark.parametrize("kind", RIGS + ("gomakehuman",) + TWIST_RIGS)
@pytest.mark.parametrize("task", ("sequence", "guided"))
def test_two_targets_in_turn_reach_the_near_upright_then_lean_for_the_far(
        addon, rig_file, kind, task):  # noqa: F811
    armature = open_rig(rig_file, kind)
    attach_loose_parts(armature)
    info = addon.blender.rig.build(armature, "right")
    bpy.context.scene.frame_set(1)
    far, table = test_body_lean.scene(armature, info, 1.3)
    near = bpy.data.objects.new("Near Cup", None)
    near.location = tuple(float(x) for x in everyday.at(info, 0.5, 0.1, -0.3))
    bpy.context.scene.collection.objects.link(near)
    pipeline = addon.blender.pipeline
    settings = addon.core.Settings().replace(lean=True)
    request = pipeline.Request(armature.name, [near.name, far.name], task=task, side="right",
                               frame_start=1, draw=False, settings=settings)
    first, second = pipeline.run(bpy.context, request, bake=True).results
    print(f"TWO {kind} {task}: {first.message} [{first.frame_start}-{first.frame_end}] | "
          f"{second.message} [{second.frame_start}-{second.frame_end}]")
    assert first.success and second.success, (first.message, second.message)
    assert "lean_deg" not in first.stats and "leaning" not in first.message, first.message
    assert second.stats["lean_deg"] > 0.0 and second.stats["lean_frames"] > 0, second.stats
    assert "leaning the trunk" in second.message, second.message
    # the Alien and the Male Base Mesh reach the far cup upright by a twist past Table
    # 1's; the lean replaces it (``core.effort``), on the far cup's report
    spared = second.stats.get("lean_spared_twist_deg")
    assert (spared is not None) == (kind in TWIST_RIGS), (kind, second.stats)
    if spared is not None:
        assert f"instead of turning the chest {spared:.0f}°" in second.message
        assert "lean_spared_twist_deg" not in first.stats
    assert first.frame_start == 1 and second.frame_start == first.frame_end
    # the lean starts once the near cup is reached, or once the arm has risen toward the
    # far one from there (GoMakeHuman's: the arm held at the near cup would touch)
    lean_first = second.frame_start + second.stats["lean_ready_frames"]
    assert ("the arm raised toward it" in second.message) == (lean_first > first.frame_end)
    length = info.arm.arm_length
    for r, ob in ((first, near), (second, far)):
        goal = np.array(ob.matrix_world.translation)
        assert np.linalg.norm(wrist(armature, info, r.frame_end) - goal) <= ON_TARGET * length
    scene_ = bpy.context.scene
    scene_.frame_set(first.frame_start)
    start = bone_heads(armature)
    span = SimpleNamespace(frame_start=first.frame_start, frame_end=second.frame_end)
    worst_feet, worst_skin, _now, _feet = walk(addon, armature, info, span, table, start, kind)
    assert worst_feet <= 5e-4 * length, (kind, worst_feet / length)
    assert worst_skin > 0.0, (kind, worst_skin / length)
    # the trunk upright until the lean starts, then leaned, and held so
    bone = armature.pose.bones[second.stats["lean_bone"]]
    turns = []
    for f in (1, lean_first, lean_first + second.stats["lean_frames"], second.frame_end):
        scene_.frame_set(f)
        turns.append(np.array(armature.matrix_world @ bone.matrix)[:3, :3])

    def angle(a, b):
        return float(np.degrees(np.arccos(np.clip((np.trace(a @ b.T) - 1.0) / 2.0, -1, 1))))

    assert angle(turns[1], turns[0]) < 0.5, (kind, angle(turns[1], turns[0]))
    assert angle(turns[2], turns[0]) > 0.5 * second.stats["lean_deg"]
    assert angle(turns[3], turns[2]) < 0.5, (kind, angle(turns[3], turns[2]))


def test_a_reach_among_moving_boxes_does_not_step(addon, rig_file):  # noqa: F811
    """The body moves only among obstacles that hold still; the refusal says so."""
    armature = open_rig(rig_file, "metarig")
    info = addon.blender.rig.build(armature, "right")
    side, _counter = test_body_step.scene(armature, info)
    box = everyday.box(info, "Moving Box", (2.0, -2.5, -0.5), (2.2, -2.3, -0.3))
    box.keyframe_insert("location", frame=1)
    box.location.z += 0.1
    box.keyframe_insert("location", frame=400)
    outcome = bake(addon, armature, side, "reach")
    result = outcome.results[0]
    assert result.reason == "needs_step", result.message
    assert "steps only among obstacles that hold still" in result.message, result.message
    assert "'Moving Box'" in result.message


def test_a_reach_to_two_targets_does_not_lean_and_points_to_the_sequence(addon, rig_file):  # noqa: F811
    """A reach to several targets plans them as separate reaches, which the body does not
    help; the far one's refusal says so and names the sequence task, which leans."""
    armature = open_rig(rig_file, "metarig")
    info = addon.blender.rig.build(armature, "right")
    far, _table = test_body_lean.scene(armature, info, 1.3)
    near = bpy.data.objects.new("Near Cup", None)
    near.location = tuple(float(x) for x in everyday.at(info, 0.5, 0.1, -0.3))
    bpy.context.scene.collection.objects.link(near)
    pipeline = addon.blender.pipeline
    request = pipeline.Request(armature.name, [near.name, far.name], task="reach",
                               side="right", frame_start=1, draw=False,
                               settings=addon.core.Settings().replace(lean=True))
    first, second = pipeline.run(bpy.context, request, bake=False).results
    assert first.success, first.message
    assert second.reason == "needs_lean", second.message
    assert "the body leans only in a reach to one target, and this run reaches 2 targets" \
        in second.message and "the sequence task" in second.message, second.message
    assert "lean_deg" not in second.stats
