"""Trunk effort (``core.effort``): a target beyond the arm that the planner reaches upright
only by turning the chest past Table 1's is reached by a lean where the lean costs the
trunk less; Table 1 still holds for a target within the arm; a twist weight of 0 gives
the upright reach as before."""

from __future__ import annotations

import numpy as np
import pytest
from geometry import HANGING, obstacles, standard_arm

from reach_addon.core import Planner, Settings, Task
from reach_addon.core.effort import (AXIAL_RANGE_DEG, FLEXION_RANGE_DEG, reach_effort,
                                     trunk_effort, twist_for_reach, twist_past_table1)
from reach_addon.core.lean import least_lean
from reach_addon.core.whole_body import _leans_to_try, lean_then_reach


def ahead(arm, arm_lengths, down):
    """The world point ``arm_lengths`` ahead of the shoulder (the figure faces -Y) and
    ``down`` arm lengths below it."""
    shoulder = arm.to_world_points(arm.shoulder)
    return shoulder + arm.arm_length * np.array([0.0, -arm_lengths, -down])


def upright(arm, target, settings):
    planner = Planner(arm, obstacles({}), settings)
    task = Task("reach", target[None], HANGING, names=("Cup",))
    return planner, task, planner.plan(task)


def test_the_effort_is_each_joints_displacement_over_its_range_squared():
    s = Settings()
    assert trunk_effort(0.0, 0.0, s) == 0.0
    assert trunk_effort(AXIAL_RANGE_DEG / 2, 0.0, s) == pytest.approx(0.25)
    assert trunk_effort(0.0, FLEXION_RANGE_DEG / 2, s) == pytest.approx(0.25)
    assert trunk_effort(AXIAL_RANGE_DEG, FLEXION_RANGE_DEG, s.replace(twist_weight=2.0)) == \
        pytest.approx(3.0)


def test_a_target_reached_by_twisting_past_table1_is_reached_leaning_instead():
    """1.15 arm lengths ahead, 0.3 below: the arm and chest reach it upright with the chest
    40° past Table 1's; a 16° lean costs the trunk a sixth as much, and the lean's reach
    keeps within 5° of Table 1's turn on the leaned trunk."""
    arm = standard_arm()
    s = Settings().replace(lean=True)
    target = ahead(arm, 1.15, 0.3)
    planner, task, plan = upright(arm, target, s)
    assert plan.success, plan.message
    twist = twist_past_table1(plan)
    assert twist >= 30.0
    costed = twist_for_reach(plan)
    assert costed is not None
    plain = least_lean(arm.shoulder, arm.waist, arm.to_canonical_points(target),
                       s.lean_reach * arm.arm_length, s.lean_max)
    assert costed[0] == 0 and costed[1] == pytest.approx(twist)
    assert costed[2] == pytest.approx(plain, abs=1e-6)        # Table 1's turn is 0 ahead
    obst = obstacles({})
    phase, reach = lean_then_reach(planner, task, plan, arm.waist,
                                   lambda a, st=None: Planner(a, obst, st or s), aim=0)
    assert phase is not None and reach.success, reach
    assert twist_past_table1(reach) <= 5.0
    assert trunk_effort(twist_past_table1(reach), phase.lean.angle, s) < \
        trunk_effort(twist, 0.0, s) / 4
    wrist = reach.world_joints()[-1, 3]
    assert np.linalg.norm(wrist - target) <= s.goal_tolerance * arm.arm_length + 1e-9


def test_a_sequence_leans_for_its_far_target_after_the_near_one():
    """A sequence to a near target (0.8 ahead) and the far one (1.15): reached upright, the
    chest turned past Table 1's at the far one only; there a lean costs less, and the
    lean, planned after the near target (reached upright as before), costs the trunk less
    over the far target than the twist did."""
    arm = standard_arm()
    s = Settings().replace(lean=True)
    targets = np.array([ahead(arm, 0.8, 0.3), ahead(arm, 1.15, 0.3)])
    planner = Planner(arm, obstacles({}), s)
    task = Task("sequence", targets, HANGING, names=("Near", "Far"))
    plan = planner.plan(task)
    assert plan.success, plan.message
    assert twist_past_table1(plan, 0) == pytest.approx(0.0, abs=1e-9)
    assert twist_past_table1(plan, 1) == pytest.approx(twist_past_table1(plan))
    assert twist_past_table1(plan) >= 30.0
    aim, twist, _lean = twist_for_reach(plan)
    assert aim == 1 and twist == pytest.approx(twist_past_table1(plan, 1))
    assert reach_effort(plan, 0.0) == pytest.approx(reach_effort(plan, 0.0, 1))
    obst = obstacles({})
    phase, reach = lean_then_reach(planner, task, plan, arm.waist,
                                   lambda a, st=None: Planner(a, obst, st or s), aim=aim,
                                   ceiling=reach_effort(plan, 0.0, aim))
    assert phase is not None and reach.success, reach
    assert phase.ready_reaches == 1 and list(reach.task.names) == ["Far"]
    assert reach_effort(reach, phase.lean.angle) < reach_effort(plan, 0.0, 1) / 4


def test_table1_holds_within_the_arm_and_a_free_twist_keeps_the_upright_reach():
    arm = standard_arm()
    s = Settings().replace(lean=True)
    near = upright(arm, ahead(arm, 0.8, 0.3), s)[2]
    assert near.success and twist_past_table1(near) == pytest.approx(0.0, abs=1e-9)
    assert twist_for_reach(near) is None
    far = upright(arm, ahead(arm, 1.15, 0.3), s.replace(twist_weight=0.0))[2]
    assert far.success and twist_past_table1(far) >= 30.0
    assert twist_for_reach(far) is None
    assert twist_for_reach(upright(arm, ahead(arm, 1.15, 0.3), s.replace(lean=False))[2]) \
        is None


def test_leans_are_tried_least_effort_first():
    """Table 1's lean leads where a twist costs more than the lean it saves (16° for 1.15
    arm lengths ahead); for a deeper one (1.3 ahead) a little twist takes some of it."""
    arm = standard_arm()
    s = Settings()
    target_c = arm.to_canonical_points(ahead(arm, 1.15, 0.3))
    leans, turns = _leans_to_try(arm, target_c, arm.waist, s, 0.0)
    efforts = [trunk_effort(abs(t[0]), lean.angle, s) for lean, t in zip(leans[:-1], turns)]
    assert efforts == sorted(efforts)
    assert turns[0] == (0.0,)
    assert len(leans) - 1 == len(set(turns[:-1])) > 10
    # last, the least lean, its hips' shift sought with every turn
    assert leans[-1].angle == min(lean.angle for lean in leans) and len(turns[-1]) > 10
    target_c = arm.to_canonical_points(ahead(arm, 1.3, 0.3))
    leans, turns = _leans_to_try(arm, target_c, arm.waist, s, 0.0)
    table1 = next(lean for lean, t in zip(leans, turns) if t == (0.0,))
    assert 0.0 < abs(turns[0][0]) <= 10.0 and leans[0].angle < table1.angle
    # a twist as free as the lean: the two leans tried before the costing, Table 1's and
    # the least over every turn
    free = s.replace(twist_weight=0.0)
    leans, turns = _leans_to_try(arm, target_c, arm.waist, free, 0.0)
    assert turns[0] == (0.0,) and leans[0].angle == pytest.approx(table1.angle)
    assert len(leans) == 2 and leans[1].angle < table1.angle - 5.0 and len(turns[1]) > 10
    # a lean to replace an upright reach's twist: only those costing less than it
    ceiling = trunk_effort(20.0, 0.0, s)
    leans, turns = _leans_to_try(arm, target_c, arm.waist, s, 0.0, ceiling)
    assert leans and all(trunk_effort(abs(t[0]), lean.angle, s) < ceiling
                         for lean, t in zip(leans[:-1], turns))


def test_a_target_round_to_the_side_keeps_its_twist():
    """Seen from the waist more than ``AHEAD_DEG`` off straight ahead (here 60°), a target
    the chest turned past Table 1's for is not leaned for: people turn toward it."""
    arm = standard_arm()
    s = Settings().replace(lean=True)
    waist = arm.to_world_points(arm.waist)
    shoulder = arm.to_world_points(arm.shoulder)
    # the figure faces -Y, its reaching side is +X (canonical x outward)
    side = np.array([np.sin(np.radians(60.0)), -np.cos(np.radians(60.0)), 0.0])
    for distance in np.arange(0.9, 1.6, 0.05) * arm.arm_length:
        target = waist + distance * side
        target[2] = shoulder[2] - 0.3 * arm.arm_length
        plan = upright(arm, target, s)[2]
        if plan.success and twist_past_table1(plan) >= 15.0:
            break
    else:
        pytest.fail("no target 60° round reached by a twist")
    off = arm.to_canonical_points(target) - arm.waist
    assert np.degrees(np.arctan2(abs(off[0]), off[1])) == pytest.approx(60.0, abs=1e-6)
    assert twist_for_reach(plan) is None
