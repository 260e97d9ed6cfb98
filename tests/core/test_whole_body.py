"""A lean, then the reach (``core.whole_body``, ``core.lean``): a target beyond the arm is
reached by leaning the trunk at the hips where ``Settings.lean`` is on; every instant of the
lean and every pose after it is measured clear by the independent oracle
(``verification.clearance``), arm and trunk; a lean that would put the head into a shelf is
refused, naming it."""

from __future__ import annotations

import numpy as np
import pytest
from geometry import HANGING, arm_penetration, obstacles, segment_clearance, standard_arm

from reach_addon.core import NEEDS_LEAN, Planner, Settings, Task
from reach_addon.core.lean import lean_axis, leaned_arm, least_lean
from reach_addon.core.whole_body import body_held_back, body_target, lean_then_reach
from reach_addon.samples import triangle_soup

#: A low table in front of the figure, its top 0.45 below the shoulder (metres, world).
TABLE = {"Table": [((-0.70, -1.20, 0.40), (0.40, -0.30, 0.75))]}


def tris_of(scene):
    verts, tris, _owners, _names = triangle_soup(scene)
    return verts[tris]


def ahead(arm, arm_lengths, down=0.0):
    """The world point ``arm_lengths`` ahead of the shoulder (the figure faces -Y), ``down``
    metres lower."""
    shoulder = arm.to_world_points(arm.shoulder)
    return shoulder + np.array([0.0, -arm_lengths * arm.arm_length, -down])


def plan_with_lean(arm, scene, target, settings):
    obst = obstacles(scene)
    planner = Planner(arm, obst, settings)
    task = Task("reach", target[None], HANGING, names=("Cup",))
    failed = planner.plan(task)
    phase, reach = lean_then_reach(planner, task, failed, arm.waist,
                                   lambda a, s=None: Planner(a, obst, s or settings))
    return failed, phase, reach


def test_a_target_beyond_the_arm_is_reached_by_a_lean_clear_at_every_instant():
    arm = standard_arm()
    settings = Settings().replace(lean=True)
    target = ahead(arm, 1.35, down=0.10)
    failed, phase, reach = plan_with_lean(arm, TABLE, target, settings)
    assert failed.reason == NEEDS_LEAN, failed.message
    assert phase is not None, reach
    assert reach.success, reach.message
    # the lean: at most the least that brings the target within lean_reach of the
    # shoulder without a chest turn (a turn may take some of it)
    plain = least_lean(arm.shoulder, arm.waist, arm.to_canonical_points(target),
                       settings.lean_reach * arm.arm_length, settings.lean_max)
    assert 2.0 < phase.lean.angle <= plain + 1e-6
    assert phase.fractions[0] == 0.0 and phase.fractions[-1] == pytest.approx(1.0)
    assert np.all(np.diff(phase.fractions) >= 0.0)
    # the wrist ends on the target
    wrist = reach.world_joints()[-1, 3]
    assert np.linalg.norm(wrist - target) <= settings.goal_tolerance * arm.arm_length + 1e-9
    # every instant of the lean (the arm held on the trunk) and every pose of the reach:
    # clear of the table by the oracle, the arm's capsules and the chest's and head's
    tris = tris_of(TABLE)
    start = Planner(arm, None).generator.config_pose(HANGING).joints
    margin = settings.clearance * arm.arm_length
    for f in np.linspace(0.0, 1.0, 41):
        lean_m = arm.to_world @ phase.lean.matrix(f)
        world = start @ lean_m[:3, :3].T + lean_m[:3, 3]
        assert arm_penetration(arm, world, tris) >= margin - 2e-3, f
        for c in arm.body_capsules:
            if c.turns_with_chest:
                a, b = (lean_m[:3, :3] @ np.asarray(p) + lean_m[:3, 3] for p in (c.a, c.b))
                assert segment_clearance(a, b, tris) >= c.radius - 2e-3, (f, c.name)
    for joints in reach.world_joints():
        assert arm_penetration(arm, joints, tris) >= margin - 2e-3


#: A desk whose top (4 cm thick, 0.91 m up) reaches back over the hanging hand: its near
#: edge 0.15 m ahead of the shoulder, the hanging forearm within the clearance under it.
DESK = {"Desk": [((-0.70, -1.20, 0.87), (0.40, -0.15, 0.91))]}


def test_a_hand_under_a_desk_rises_before_the_trunk_leans():
    """Arm first, then the lean (``Settings.lean_ready``): held as it hangs, the forearm
    would be carried into the desk from the lean's first degree, so that lean is refused;
    with a ready reach the arm first rises on the upright trunk toward where the target
    will be, the trunk leans with the arm there, then the reach ends on the target. Every
    instant is measured by the oracle: the ready reach leaves the desk (the hanging forearm
    starts 2 cm into it) going no deeper, the lean and the reach keep the clearance; the
    chest holds through the ready reach and the reach starts where it ended."""
    arm = standard_arm()
    target = ahead(arm, 1.25) + np.array([0.0, 0.0, 0.91 + 0.15 * arm.arm_length
                                          - ahead(arm, 1.25)[2]])
    held = Settings().replace(lean=True, lean_ready=0.0)
    failed, phase, why = plan_with_lean(arm, DESK, target, held)
    assert failed.reason == NEEDS_LEAN and phase is None
    assert "forearm against 'Desk'" in why, why
    settings = Settings().replace(lean=True)
    failed, phase, reach = plan_with_lean(arm, DESK, target, settings)
    assert phase is not None and phase.ready is not None, reach
    assert reach.success and phase.ready.success, reach.message
    ready, tris = phase.ready, tris_of(DESK)
    margin = settings.clearance * arm.arm_length
    assert all(p.config.body_rotation == 0.0 for p in ready.poses)
    assert np.allclose(ready.poses[-1].config.as_array(), reach.poses[0].config.as_array())
    depths = [arm_penetration(arm, joints, tris) for joints in ready.world_joints()]
    assert depths[0] < 0.0                  # the hanging forearm starts touching the desk
    assert min(depths) >= depths[0] - 2e-3 and depths[-1] >= margin - 2e-3
    end = ready.poses[-1].joints
    for f in np.linspace(0.0, 1.0, 41):
        lean_m = arm.to_world @ phase.lean.matrix(f)
        assert arm_penetration(arm, end @ lean_m[:3, :3].T + lean_m[:3, 3], tris) >= margin - 2e-3
    for joints in reach.world_joints():
        assert arm_penetration(arm, joints, tris) >= margin - 2e-3
    wrist = reach.world_joints()[-1, 3]
    assert np.linalg.norm(wrist - target) <= settings.goal_tolerance * arm.arm_length + 1e-9


def test_the_lean_is_on_by_default_and_off_when_turned_off():
    arm = standard_arm()
    assert Settings().lean and Settings().squat and Settings().stepping
    failed, phase, why = plan_with_lean(arm, {}, ahead(arm, 1.35), Settings(lean=False))
    assert failed.reason == NEEDS_LEAN and phase is None and why is None
    _failed, phase, _why = plan_with_lean(arm, {}, ahead(arm, 1.35), Settings())
    assert phase is not None and phase.lean.angle > 0.0


def sequence_near_and_far(arm, near_box=False):
    """A sequence: a cup within reach, then one 1.35 arm lengths ahead (needs a lean)."""
    near = arm.to_world_points(arm.shoulder) + np.array([0.0, -0.6, -0.2]) * arm.arm_length
    return Task("sequence", np.array([near, ahead(arm, 1.35)]), HANGING, names=("A", "B"))


def test_a_sequence_reaches_the_near_target_upright_then_leans_for_the_far_one():
    """With Lean on, a sequence whose second target needs a lean reaches the first upright,
    as planned without the body, then leans toward the second as a single reach to it
    would, and reaches it on the leaned trunk; with ``split`` off it leans before the first
    and reaches both on the leaned trunk; without Lean the refusal says to turn it on."""
    arm = standard_arm()
    task = sequence_near_and_far(arm)
    settings = Settings().replace(lean=True)
    obst = obstacles({})
    planner = Planner(arm, obst, settings)
    failed = planner.plan(task)
    assert failed.reason == NEEDS_LEAN, failed.message
    assert [s.success for s in failed.segments] == [True, False]
    assert "a single reach, a sequence or a guided reach leans" in failed.message
    assert body_target(settings, task, failed, arm) == 1

    def make(a, s=None):
        return Planner(a, obst, s or settings)

    tolerance = settings.goal_tolerance * arm.arm_length + 1e-9
    phase, reach = lean_then_reach(planner, task, failed, arm.waist, make)
    assert phase is not None, reach
    assert phase.ready_reaches == 1 and len(phase.ready.segments) == 1
    near_end = failed.segments[0].frame_end
    assert len(phase.ready.poses) == near_end + 1
    assert np.allclose(phase.ready.world_joints(), failed.world_joints()[:near_end + 1])
    assert np.linalg.norm(phase.ready.world_joints()[-1, 3] - task.targets[0]) <= tolerance
    assert reach.success and len(reach.segments) == 1, reach.message
    assert reach.poses[0].config.body_rotation == pytest.approx(
        failed.poses[near_end].config.body_rotation)
    assert np.linalg.norm(reach.world_joints()[reach.segments[0].frame_end, 3] -
                          task.targets[1]) <= tolerance
    # the lean is toward the far target: the same a single reach to it takes
    single = Task("reach", task.targets[1:], HANGING, names=("B",))
    alone, _reach = lean_then_reach(planner, single, planner.plan(single), arm.waist, make)
    assert alone is not None
    assert phase.lean.angle == pytest.approx(alone.lean.angle)
    assert np.allclose(phase.lean.axis, alone.lean.axis)
    # leaning before the first: both reached on the leaned trunk
    before, both = lean_then_reach(planner, task, failed, arm.waist, make, split=False)
    assert before is not None and before.ready is None and before.ready_reaches == 0
    assert both.success and len(both.segments) == 2, both.message
    joints = both.world_joints()
    for seg, goal in zip(both.segments, task.targets):
        assert np.linalg.norm(joints[seg.frame_end, 3] - goal) <= tolerance
    plan = Planner(arm, obst, Settings(lean=False)).plan(task)
    assert plan.reason == NEEDS_LEAN and "turn on Lean" in plan.message, plan.message
    assert body_target(Settings(lean=False), task, plan, arm) is None


def test_a_sequence_with_a_target_a_lean_cannot_mend_does_not_lean_and_says_why():
    """A sequence whose first target is inside a box and whose second needs a lean: no
    lean (it would not mend the first), and the clause names the first and its reason."""
    arm = standard_arm()
    task = sequence_near_and_far(arm)
    near = task.targets[0]
    box = {"Box": [(tuple(near - 0.05), tuple(near + 0.05))]}
    settings = Settings().replace(lean=True)
    failed = Planner(arm, obstacles(box), settings).plan(task)
    reasons = [s.reason for s in failed.segments]
    assert reasons == ["target_in_obstacle", NEEDS_LEAN], failed.message
    assert body_target(settings, task, failed, arm) is None
    why, helped = body_held_back(settings, task, failed, arm)
    assert why is not None and "'A' is refused as target_in_obstacle" in why, why
    assert [seg.name for seg in helped] == ["B"]       # said of the one a lean would reach
    single = Task("reach", task.targets[1:], HANGING, names=("B",))
    alone = Planner(arm, obstacles(box), settings).plan(single)
    assert body_target(settings, single, alone, arm) == 0
    assert body_held_back(settings, single, alone, arm) == (None, [])


def test_a_lean_that_would_put_the_head_into_a_shelf_is_refused_naming_it():
    arm = standard_arm()
    target = ahead(arm, 1.35)
    head = arm.to_world_points(np.array([0.0, 0.02, 0.30]))
    # a shelf board just in front of the head, above the arm's way
    shelf = {"Shelf": [((head[0] - 0.3, head[1] - 0.30, head[2] - 0.02),
                        (head[0] + 0.3, head[1] - 0.16, head[2] + 0.02))]}
    failed, phase, why = plan_with_lean(arm, shelf, target, Settings().replace(lean=True))
    assert failed.reason == NEEDS_LEAN and phase is None
    assert "'Shelf'" in why and "head" in why, why


def test_a_leaned_arm_carries_the_chest_and_head_and_leaves_the_pelvis():
    arm = standard_arm()
    target = arm.to_canonical_points(ahead(arm, 1.2))
    from reach_addon.core.lean import Lean
    lean = Lean(arm.waist, lean_axis(arm.waist, target), 20.0)
    leaned = leaned_arm(arm, lean)
    for before, after in zip(arm.body_capsules, leaned.body_capsules):
        w0 = arm.to_world_points(np.array([before.a, before.b]))
        w1 = leaned.to_world_points(np.array([after.a, after.b]))
        if before.turns_with_chest:
            assert not np.allclose(w0, w1), before.name
            # leaned toward the target (forward, -Y) about the waist
            assert w1[1, 1] < w0[1, 1]
        else:
            assert np.allclose(w0, w1), before.name


def test_a_shifted_lean_that_tips_the_body_is_not_tried_with_a_smaller_shift():
    """Where the Blender layer refuses a lean with the hips back for its balance
    (``Why(..., BALANCE)``), a quarter of the margin (a smaller shift, so a body farther
    past its feet) is not tried; where it refuses it for a touch, it is."""
    from test_squat import body

    from reach_addon.core.whole_body import BALANCE, LEAN_TRIES, TOUCH, Why

    arm = standard_arm()
    settings = Settings().replace(lean=True, squat=False)
    target = ahead(arm, 1.35, down=0.10)
    planner = Planner(arm, obstacles({}), settings)
    task = Task("reach", target[None], HANGING, names=("Cup",))
    failed = planner.plan(task)
    # short feet: the toes 0.03 ahead of the ankles, so the lean tips the body forward
    figure = body(arm, feet=[(-0.15, 0.10, 0.0), (0.15, 0.10, 0.0), (0.15, -0.03, 0.0),
                             (-0.15, -0.03, 0.0)])
    figure.drop = lambda shift: 0.0
    counts = {}
    for cause in (BALANCE, TOUCH):
        shifted, plain = [], []

        def acceptable(lean, arm_world=None, turned=None, shifted=shifted, plain=plain,
                       cause=cause):
            (shifted if np.any(lean.shift) else plain).append(lean)
            return Why("refused", cause)

        phase, why = lean_then_reach(planner, task, failed, arm.waist,
                                     lambda a: Planner(a, obstacles({}), settings),
                                     acceptable, None, figure)
        assert phase is None and "refused" in why
        counts[cause] = (len(shifted), [lean.angle for lean in plain])
    # each lean tried with the whole margin; a touch tries a quarter of it as well
    assert counts[BALANCE][0] >= 1 and counts[TOUCH][0] == 2 * counts[BALANCE][0], counts
    # after a lean refused for its balance only smaller ones are tried; after a touch,
    # the next by effort, deeper or not, up to LEAN_TRIES and the last; none twice
    tipped, touched = counts[BALANCE][1], counts[TOUCH][1]
    assert all(b < a for a, b in zip(tipped, tipped[1:])), tipped
    assert any(b > a for a, b in zip(touched, touched[1:])), touched
    assert len(touched) == len(set(touched)) == LEAN_TRIES + 1, touched
    # a lean refused for the balance is followed by smaller ones only, a touch by any
    assert counts[BALANCE][1] <= counts[TOUCH][1], counts
