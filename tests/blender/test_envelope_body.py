"""The reach envelope's whole-body classes on real rigs (issue "Reach past the arm", item 5:
the envelope gains classes reachable by a lean, by a squat, by a step), borne out by Bakes.

Each rig stands on a floor (``test_body_squat.scene``: a box whose top is the lowest point
of its skin). Its envelope, with *Lean* on, over a cube :data:`EXTENT` arm lengths from the
shoulder, is asked; then a point of each whole-body class is baked as a user's Bake is:

- the ``squat`` point nearest :data:`SQUAT_AT` (low and ahead) is reached, and the report
  says the hips came down or the trunk bent past the lean's limit;
- the ``step`` point nearest :data:`STEP_AT` (far to the reaching side) is reached, and the
  report counts the steps.

Nothing below the floor is classed reachable, and without *Lean* neither class appears.
Measured on what Blender evaluates: the wrist (the hand bone's head) on the target.
"""

from __future__ import annotations

import bpy
import numpy as np
import pytest
from test_body_lean import attach_loose_parts, open_rig
from test_body_squat import scene as floor_scene
from test_every_rig import ON_TARGET, rig_file  # noqa: F401  (the fixture)

#: The envelope's cube: half its side (arm lengths) and points a side.
EXTENT, RESOLUTION = 2.4, 9
#: Where the points baked are chosen near (forward, outward, up; arm lengths from the
#: shoulder): a cup low ahead, something far to the reaching side a little below.
SQUAT_AT = (0.6, 0.0, -1.2)
STEP_AT = (0.0, 2.2, -0.3)
RIGS = ("metarig", "quaternius")


def envelope(addon, armature, settings):
    pipeline = addon.blender.pipeline
    settings = settings.replace(envelope_extent=EXTENT, envelope_resolution=RESOLUTION)
    request = pipeline.Request(armature.name, [], side="right", settings=settings)
    return pipeline.envelope(bpy.context, request)


def bake_at(addon, armature, world, settings):
    ob = bpy.data.objects.new("Envelope Point", None)
    ob.location = tuple(float(x) for x in world)
    bpy.context.scene.collection.objects.link(ob)
    pipeline = addon.blender.pipeline
    request = pipeline.Request(armature.name, [ob.name], task="reach", side="right",
                               frame_start=1, draw=False, settings=settings)
    return ob, pipeline.run(bpy.context, request, bake=True)


def wrist_at_end(armature, info, result):
    bpy.context.scene.frame_set(result.frame_end)
    a = info.bones.arms["right"]
    pb = armature.pose.bones[a.hand]
    return np.array(armature.matrix_world @ pb.head)


def fresh(rig_file, kind, info):  # noqa: F811
    """The rig opened again as it stands, on its floor (``test_body_squat.scene``'s)."""
    armature = open_rig(rig_file, kind)
    attach_loose_parts(armature)
    bpy.context.scene.frame_set(1)
    cup, _floor = floor_scene(armature, info)
    bpy.data.objects.remove(cup)
    return armature


@pytest.mark.parametrize("kind", RIGS)
def test_a_squat_point_and_a_step_point_of_the_envelope_are_reached_so(addon, rig_file,  # noqa: F811
                                                                        kind):
    armature = open_rig(rig_file, kind)
    info = addon.blender.rig.build(armature, "right")
    armature, floor = fresh(rig_file, kind, info), bpy.data.objects["Floor"]
    core = addon.core
    settings = core.Settings().replace(lean=True, envelope_body=True)
    env = envelope(addon, armature, settings)
    classes, coords = env.envelope.classes, env.shoulder
    counts = env.envelope.counts()
    print(f"ENVELOPE {kind}: {counts}")
    squat, step = core.envelope.SQUAT, core.envelope.STEP
    up = np.asarray(info.frame.up, float)
    top = float(np.max([np.array(floor.matrix_world @ v.co) @ up for v in floor.data.vertices]))
    reachable = np.isin(classes, (core.envelope.LEAN, squat, step))
    assert not np.any(env.world[reachable] @ up < top - 1e-6)
    assert counts["squat"] and counts["step"], counts
    length = info.arm.arm_length
    for cls, near in ((squat, SQUAT_AT), (step, STEP_AT)):
        pick = np.flatnonzero(classes == cls)
        i = pick[np.argmin(np.linalg.norm(coords[pick] - np.asarray(near), axis=1))]
        armature = fresh(rig_file, kind, info)
        target, outcome = bake_at(addon, armature, env.world[i], settings)
        result = outcome.results[0]
        print(f"ENVELOPE {kind} {core.envelope.CLASSES[cls]} at {coords[i]}: {result.message} "
              f"{ {k: v for k, v in result.stats.items() if k.startswith(('lean', 'step'))} }")
        assert result.success, (coords[i], result.message)
        assert np.linalg.norm(wrist_at_end(armature, info, result) - env.world[i]) <= \
            ON_TARGET * length
        if cls == squat:
            assert result.stats["lean_hips_down"] > 0.0 or \
                result.stats["lean_deg"] > settings.lean_max, result.stats
        else:
            assert result.stats["step_count"] >= 1, result.stats


def test_without_lean_no_point_is_classed_by_the_body(addon, rig_file):  # noqa: F811
    armature = open_rig(rig_file, "metarig")
    for settings in (addon.core.Settings(lean=False), addon.core.Settings()):
        # Lean off, or on (the default) without Body classes (off by default: slow)
        env = envelope(addon, armature, settings)
        counts = env.envelope.counts()
        assert counts["lean"] == counts["squat"] == counts["step"] == 0, counts
        assert counts["out"] > 0, counts


def test_a_figure_not_standing_under_gravity_has_no_body_class(addon, rig_file):  # noqa: F811
    """Quaternius on its floor with the scene's gravity turned 50°: a reach neither leans,
    squats nor steps for it (``test_body_step``; a lean is refused as "only standing"), so
    its envelope has no point of those classes, where standing it has them all (the test
    above, same rig and settings). A point the standing envelope classes ``lean`` is
    refused so when baked."""
    armature = open_rig(rig_file, "quaternius")
    info = addon.blender.rig.build(armature, "right")
    armature = fresh(rig_file, "quaternius", info)
    tilt = np.radians(50.0)
    bpy.context.scene.gravity = (0.0, 9.81 * np.sin(tilt), -9.81 * np.cos(tilt))
    legs = addon.blender.balance.find_legs(armature, info.bones, info.frame)
    up = -np.asarray(bpy.context.scene.gravity, float) / 9.81
    assert addon.blender.balance.legs_tilt(armature, legs, up) > 40.0
    settings = addon.core.Settings().replace(lean=True, envelope_body=True)
    env = envelope(addon, armature, settings)
    counts = env.envelope.counts()
    print(f"ENVELOPE tilted: {counts}")
    assert counts["lean"] == counts["squat"] == counts["step"] == 0, counts
    # the lean a standing figure's envelope offers is refused on the tilted one
    bpy.context.scene.gravity = (0.0, 0.0, -9.81)
    standing = envelope(addon, armature, settings)
    lean = np.flatnonzero(standing.envelope.classes == addon.core.envelope.LEAN)
    assert len(lean), standing.envelope.counts()
    bpy.context.scene.gravity = (0.0, 9.81 * np.sin(tilt), -9.81 * np.cos(tilt))
    _ob, outcome = bake_at(addon, armature, standing.world[lean[0]], settings)
    result = outcome.results[0]
    assert not result.success and "only a body standing" in result.message, result.message


def test_a_trunk_the_user_keyed_has_no_lean_or_squat_class(addon, rig_file):  # noqa: F811
    """Quaternius on its floor, the bone that leans its trunk keyed by the user: a reach
    keeps those keys and refuses to lean or squat (``lean.plan``), so the envelope has no
    point of those classes, where unkeyed it has both (the step class stays: a step needs
    no lean). A point the unkeyed envelope classes ``lean`` is baked as the keyed one
    says: by a step, or refused for the keys."""
    armature = open_rig(rig_file, "quaternius")
    info = addon.blender.rig.build(armature, "right")
    armature = fresh(rig_file, "quaternius", info)
    settings = addon.core.Settings().replace(lean=True, envelope_body=True)
    free = envelope(addon, armature, settings)
    counts = free.envelope.counts()
    assert counts["lean"] and counts["squat"] and counts["step"], counts
    legs = addon.blender.balance.find_legs(armature, info.bones, info.frame)
    bone = addon.blender.lean.lean_bone(armature, info.bones, legs)
    pb = armature.pose.bones[bone]
    request = addon.blender.pipeline.Request(armature.name, [], side="right", settings=settings)
    before = addon.blender.envelope.state_key(bpy.context, request)
    pb.keyframe_insert("rotation_quaternion" if pb.rotation_mode == "QUATERNION"
                       else "rotation_euler", frame=1)
    # the pose is as it was, but the panel's cached envelope no longer holds
    assert addon.blender.envelope.state_key(bpy.context, request) != before
    keyed = envelope(addon, armature, settings)
    counts = keyed.envelope.counts()
    print(f"ENVELOPE keyed trunk: {counts}")
    assert counts["lean"] == counts["squat"] == 0 and counts["step"], counts
    # a point the unkeyed envelope classes lean: baked, a step reaches it (the keyed
    # envelope says step) or it is refused for the keys (the keyed envelope says out)
    lean = np.flatnonzero(free.envelope.classes == addon.core.envelope.LEAN)
    i = lean[0]
    _ob, outcome = bake_at(addon, armature, free.world[i], settings)
    result = outcome.results[0]
    said = addon.core.envelope.CLASSES[keyed.envelope.classes[i]]
    print(f"ENVELOPE keyed trunk at {free.shoulder[i]}: {said}; {result.message}")
    assert "lean_deg" not in result.stats, result.stats
    if said == "step":
        assert result.success and result.stats["step_count"] >= 1, result.message
    else:
        assert said == "out" and not result.success, (said, result.message)
        assert f"bone '{bone}', which leans the trunk, has keys of its own" in result.message
