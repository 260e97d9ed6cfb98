"""The step's plan and motion (``core/step.py``), on its own geometry."""

from __future__ import annotations

import numpy as np
import pytest

from reach_addon.core import Settings
from reach_addon.core.step import (Step, lead_foot, plan_step, step_count, step_motion,
                                   step_shift, swing_along, swing_lift)

UP = np.array([0.0, 0.0, 1.0])
SHOULDER = np.array([0.2, 0.0, 1.4])
ANKLES = np.array([[0.1, 0.0, 0.08], [-0.1, 0.0, 0.08]])


@pytest.mark.parametrize("target", [(1.8, 0.3, 1.2), (0.2, -2.0, 0.9), (-1.5, 1.5, 1.6)])
def test_the_shift_leaves_the_target_exactly_at_the_reach(target):
    target = np.array(target)
    shift = step_shift(SHOULDER, target, UP, 0.6)
    assert abs(float(shift @ UP)) < 1e-12
    assert np.linalg.norm(target - (SHOULDER + shift)) == pytest.approx(0.6, abs=1e-9)
    # straight toward it, along the ground
    h = (target - SHOULDER) * [1, 1, 0]
    assert np.cross(shift, h) == pytest.approx(np.zeros(3), abs=1e-12)
    assert float(shift @ h) > 0


def test_no_shift_within_reach_nor_for_a_target_too_high():
    assert step_shift(SHOULDER, SHOULDER + [0.3, 0.3, 0.0], UP, 0.6) is None
    assert step_shift(SHOULDER, SHOULDER + [3.0, 0.0, 0.7], UP, 0.6) is None


def test_the_count_is_the_fewest_steps_within_the_length():
    assert step_count(np.array([0.0, 1.0, 0.0]), 0.4, 5) == 3
    assert step_count(np.array([0.0, 0.8, 0.0]), 0.4, 5) == 2
    assert step_count(np.array([0.0, 2.1, 0.0]), 0.4, 5) is None
    assert lead_foot(ANKLES, [1.0, 0.0, 0.0]) == 0 and lead_foot(ANKLES, [-1.0, 0, 0]) == 1


@pytest.mark.parametrize("count", [1, 2])
def test_the_motion_ends_planted_a_whole_move_on(count):
    s = Settings()
    step = Step(np.array([0.9, 0.2, 0.0]), count, 0)
    m = step_motion(ANKLES, step, UP, s, 24.0, 0.85)
    assert m.hips[0] == pytest.approx(np.zeros(3)) and (m.feet[0] == 0).all()
    assert m.feet[-1][0] == pytest.approx(step.shift) and m.feet[-1][1] == pytest.approx(step.shift)
    assert m.hips[-1] == pytest.approx(step.shift)
    assert m.planted[0].all() and m.planted[-1].all()
    # never both feet in the air; a foot in the air is above the ground, one on it is on it
    assert m.planted.any(axis=1).all()
    heights = m.feet[..., 2]
    assert (heights[m.planted] == pytest.approx(0.0, abs=1e-12))
    assert heights.max() == pytest.approx(s.step_lift * 0.85, rel=1e-6)
    # a planted foot does not slide
    for f in range(1, len(m.feet)):
        for foot in range(2):
            if m.planted[f - 1, foot] and m.planted[f, foot]:
                assert m.feet[f, foot] == pytest.approx(m.feet[f - 1, foot], abs=1e-12)
    # every foot moves forward only, in `count` swings each
    swings = (np.diff(m.planted.astype(int), axis=0) == -1).sum(axis=0)
    assert list(swings) == [count, count]
    # smooth: no frame moves a foot more than the peak of a minimum-jerk move (1.875 times
    # its average) over the 70 % of the swing in which it moves along
    fps, per = 24.0, np.linalg.norm(step.shift) / count
    worst = np.linalg.norm(np.diff(m.feet, axis=0), axis=2).max()
    assert worst < 1.875 / 0.7 * per / (s.step_time * fps)


def test_swing_lift_is_smooth_at_its_ends():
    assert swing_lift(0.5) == pytest.approx(1.0)
    assert swing_lift(0.0) == 0.0 and swing_lift(1.0) == 0.0
    e = 1e-4
    assert swing_lift(e) / e < 1e-2 and swing_lift(1 - e) / e < 1e-2
    # it rises before it moves along
    assert swing_along(0.15) == 0.0 and swing_along(0.85) == 1.0 and swing_lift(0.15) > 0.25


def test_plan_step_refuses_a_walk_with_its_reason():
    s = Settings()
    step, why = plan_step(SHOULDER, SHOULDER + [6.0, 0, -0.2], ANKLES, UP, 0.6, 0.85, s)
    assert step is None and "Steps limit" in why
    step, why = plan_step(SHOULDER, SHOULDER + [1.4, 0, -0.2], ANKLES, UP, 0.6, 0.85, s)
    assert why is None and step.lead == 0 and step.count == 3     # 0.93 in steps of 0.38
