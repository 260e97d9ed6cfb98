"""The whole body in a guided reach (issue "Reach past the arm", item 5: guided uses it):
the scenes of ``test_body_lean`` (a cup 1.3 arm lengths ahead, over a table) and
``test_body_step`` (a cup 2.3 arm lengths to the side, beside a counter), baked as a
*guided* reach with *Lean* on, as a user's Bake is. Measured on what Blender evaluates:
the wrist (the hand bone's head) ends on the target; the report says the trunk leaned,
or the body stepped, first. Without *Lean* the same guided reach is refused as before.
A sequence still refuses (one posture per target is not planned yet).
"""

from __future__ import annotations

import bpy
import everyday
import numpy as np
import pytest
import test_body_lean
import test_body_step
from test_body_lean import attach_loose_parts, open_rig
from test_every_rig import ON_TARGET, rig_file  # noqa: F401  (the fixture)

RIGS = ("metarig", "quaternius")


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


def test_a_guided_reach_through_two_targets_or_among_moving_boxes_does_not_lean_or_step(
        addon, rig_file):  # noqa: F811
    """Only a reach or guided reach to one target, among obstacles that hold still, has
    the body help; the refusals say so."""
    armature = open_rig(rig_file, "metarig")
    info = addon.blender.rig.build(armature, "right")
    far, _table = test_body_lean.scene(armature, info, 1.3)
    near = bpy.data.objects.new("Near Cup", None)
    near.location = tuple(float(x) for x in everyday.at(info, 0.5, 0.1, -0.3))
    bpy.context.scene.collection.objects.link(near)
    pipeline = addon.blender.pipeline
    settings = addon.core.Settings().replace(lean=True)
    request = pipeline.Request(armature.name, [far.name, near.name], task="guided",
                               side="right", frame_start=1, draw=False, settings=settings)
    result = pipeline.run(bpy.context, request, bake=False).results[0]
    assert result.reason == "needs_lean" and "to one target" in result.message, result.message
    assert "lean_deg" not in result.stats

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
