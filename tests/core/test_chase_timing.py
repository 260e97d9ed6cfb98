"""A chase's way ahead shortened in the chase's own cost (``core.chase_timing``), on the
crate scene of the planner's tests, checked by the sampling planner's state test."""

import numpy as np
import pytest

from geometry import HANGING, obstacles, standard_arm
from reach_addon.core import Planner, Settings, Task
from reach_addon.core.chase_timing import at_chase_speed, shortcut_for, span_cost
from reach_addon.core.sampling import JointSpace, StateValidity, pose_row

WALL = {"Crate": [((-0.60, -0.36, 0.70), (0.00, -0.30, 1.08))]}


@pytest.fixture(scope="module")
def way():
    arm = standard_arm()
    planner = Planner(arm, obstacles(WALL), Settings())
    plan = planner.plan(Task("reach", np.array([[-0.28, -0.47, 1.14]]), HANGING))
    assert plan.success
    return planner.generator, list(plan.poses)


def test_the_way_costs_less_and_stays_valid(way):
    gen, poses = way
    cost = span_cost(gen, gen.settings, 24.0)
    short = shortcut_for(gen, poses, cost)
    before = sum(cost(a, b) for a, b in zip(poses[:-1], poses[1:]))
    after = sum(cost(a, b) for a, b in zip(short[:-1], short[1:]))
    assert after < before
    assert short[0] is poses[0] and short[-1] is poses[-1]
    validity = StateValidity(gen.arm, gen.settings, gen.checker,
                             JointSpace(gen.arm, gen.settings, pose_row(poses[0])))
    assert all(validity.valid(pose_row(p)) for p in short[1:-1])
    # and it can be timed at the chase's limits (the keys clear as they interpolate)
    assert at_chase_speed(gen, short, 500, gen.settings, 24.0) is not None


def test_the_same_seed_gives_the_same_way(way):
    gen, poses = way
    cost = span_cost(gen, gen.settings, 24.0)
    a, b = shortcut_for(gen, poses, cost, seed=3), shortcut_for(gen, poses, cost, seed=3)
    assert [pose_row(p).tolist() for p in a] == [pose_row(p).tolist() for p in b]
