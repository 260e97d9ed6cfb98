"""A natural arm on every rig: the wrist near its rest alignment, no chicken wing, and a
report that says so.

Each (rig, everyday scene) of ``test_every_rig`` is baked as a user's Bake is and measured
on Blender's evaluated bones by :mod:`verification.naturalness`, which shares no code with
the planner: the hand bone's axis in the forearm bone's frame against the rest pose (wrist
bend), and the elbow more than 0.1 arm lengths above the shoulder while the wrist is more
than that below it (chicken wing), over every frame of the motion. Each reach must keep the
mean bend within 12° and the largest within 45°, with no chicken wing; and the report's
own figures (``blender.results.measure_naturalness``, another construction: the hand's
axis from its fingers against where the rest pose would hold it) must agree with the
measured ones.

The pairs the planner does not do yet are ``xfail(strict=True)`` in :data:`XFAIL`, with
what was measured: the wrist bent by a shelf board or the wall's top, where the report does
not yet say that an obstacle forced it, and elbows lifted over a low hand, which the
swivel's choice has no comfort term against yet (issue "A natural arm").
"""

from __future__ import annotations

import json

import bpy
import everyday
import pytest
from test_every_rig import cases, rig_file  # noqa: F401  (the fixture)

from verification import naturalness

#: How far the report's mean and largest bend may lie from the measured ones (degrees): the
#: two read the hand's axis differently (its fingers' middle, its bone's y axis), and a
#: wrist bend turns the two by a little more or less.
MEAN_AGREES, MAX_AGREES = 2.0, 6.0

_WING = "elbow lifted over a low hand: no elbow-comfort term in the swivel's choice yet"
_FORCED = "bend forced by the scene, not yet reported as forced"
#: (rig, scene) → what keeps it from the goal, as measured at this commit.
XFAIL = {
    ("gomakehuman", "wall"): f"max bend 67° over the wall's top; 2 wing frames: {_FORCED}",
    ("gomakehuman", "shelf"): f"max bend 66° at the slot, 8 wing frames: {_WING}",
    ("gomakehuman", "chase"): f"6 wing frames: {_WING}",
    ("malebase", "chase"): f"5 wing frames: {_WING}",
    ("goblin", "shelf"): f"mean 26°, max 75° into the slot: {_FORCED}",
    ("knight", "shelf"): f"mean 16°, max 74° into the slot: {_FORCED}",
    ("robot", "wall"): f"max bend 57°: {_FORCED}",
    ("robot", "shelf"): f"mean 24°, max 73° into the slot: {_FORCED}",
}


def bake(addon, rig_file, kind, scene):  # noqa: F811
    path, name = rig_file(kind)
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    arm = bpy.data.objects[name]
    info = addon.blender.rig.build(arm, "right")
    targets = everyday.build(scene, info, arm)
    pipeline = addon.blender.pipeline
    request = pipeline.Request(arm.name, [t.name for t in targets], task=everyday.TASKS[scene],
                               side="right", frame_start=1, draw=False)
    return arm, info, pipeline.run(bpy.context, request, bake=True)


@pytest.mark.parametrize("kind, scene", list(cases(XFAIL)))
def test_the_arm_looks_natural(addon, rig_file, kind, scene):  # noqa: F811
    arm, info, outcome = bake(addon, rig_file, kind, scene)
    tasks = outcome.results
    assert outcome.baked and all(t.success for t in tasks)
    b = info.bones.arms["right"]
    figures = naturalness.measure(arm, b.upper_arm, b.forearm, b.hand,
                                  range(tasks[0].frame_start, tasks[-1].frame_end + 1))
    frames = [t.frame_end - t.frame_start + 1 for t in tasks]
    reported_mean = sum(t.stats["mean_wrist_bend_deg"] * n for t, n in zip(tasks, frames)) / \
        sum(frames)
    reported_max = max(t.stats["max_wrist_bend_deg"] for t in tasks)
    reported_wings = sum(t.stats["chicken_wing_frames"] for t in tasks)
    print(f"NATURAL {json.dumps({'rig': kind, 'scene': scene} | figures.summary())} "
          f"reported mean {reported_mean:.2f} max {reported_max:.2f} wings {reported_wings}")
    # the report says what the bones show
    assert abs(reported_mean - figures.mean_bend) <= MEAN_AGREES
    assert abs(reported_max - figures.max_bend) <= MAX_AGREES
    assert reported_wings == len(figures.wing_frames)
    # and what they show is natural
    assert not figures.wing_frames, f"chicken wing at frames {figures.wing_frames}"
    assert figures.mean_bend <= naturalness.MEAN_BEND_MAX, figures.summary()
    assert figures.max_bend <= naturalness.MAX_BEND_MAX, figures.summary()
