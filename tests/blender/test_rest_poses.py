"""A rig's start pose is taken as the rig holds it: a T-posed arm with a straight elbow
bent backward and a rolled hand, an elbow bent up, a hand rolled against the forearm.

The limits on the arm's joints (the humeral twist within [-90°, 90°], Algorithm 1's elbow
side) bound where a move may go, never where it starts (``core.limits.move_limits``,
``core.limits.on_elbow_side``). A T-posed arm whose elbow is bent 1° backward reads as a twist of
-180°, outside the limits and off the elbow's side: before, every pose a step away was
refused (the twist may change 15° a step and had to land inside [-90°, 90°]), the search
never left the start, and every reach ended ``no_path`` with the closest approach the
start's own distance. That is what VRM avatars and Godot-style mannequins showed (every
reach failed after 9aa6506, which bounded a straight arm's twist like the other joints).

Checked on Blender's evaluated bones: the reach past a wall is baked, on the target at its
last frame and clear of the wall at every frame and three sub-frames, hand included
(``clearance``).
"""

from __future__ import annotations

import bpy
import clearance
import everyday
import numpy as np
import pytest
import synthetic as syn
from test_bake import triangles

#: (name map, rest pose, elbow bend (degrees), the way it bends, hand roll (degrees), hand)
RIGS = {
    "vrm T, straight elbow bent back, hand rolled 55°": ("vrm", "T", 1.0, (0, 1, 0), 55.0, "fingers"),
    "unity T, straight elbow bent up, hand rolled -90°": ("unity", "T", 0.5, (0, 0, 1), -90.0, "bone"),
    "mixamo T, elbow bent 9° up, mitten": ("mixamo", "T", 9.0, (0, 0.3, 1), 0.0, "mitten"),
}


def t_rig(key):
    names, pose, bend, way, roll, hand = RIGS[key]
    return syn.humanoid(syn.MAPS[names], proportions=syn.shape(pose=pose, elbow_bend_deg=bend,
                                                               elbow_bend_dir=way),
                        hand_roll_deg=roll, hand=hand, name="TRig")


@pytest.mark.parametrize("key", RIGS)
def test_a_t_posed_arm_reaches_past_a_wall(fresh, addon, key):
    arm = t_rig(key)
    rig = addon.blender.rig
    info = rig.build(arm, "right")
    start = info.start
    if "back" in key:                       # the case that failed: off the limits and the side
        assert abs(start.gamma) > 170.0 and not addon.core.limits.on_elbow_side(info.arm, start)
    (target,) = everyday.build("wall", info, arm)
    pipeline = addon.blender.pipeline
    request = pipeline.Request(arm.name, [target.name], side="right", frame_start=1, draw=False)
    outcome = pipeline.run(bpy.context, request, bake=True)
    task = outcome.results[0]
    assert task.success, task.message
    first, last = task.frame_start, task.frame_end
    bpy.context.scene.frame_set(last)
    check = clearance.Arm(arm, info)
    wrist = check.wrist()
    assert np.linalg.norm(wrist - np.array(target.matrix_world.translation)) \
        <= 0.01 * info.arm.arm_length
    check.check_instants(triangles(bpy.data.objects["Wall"]), range(first, last + 1))
