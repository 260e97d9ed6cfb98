"""The hand over the finished motion (core.hand): the wrist angles read back, the start
hand kept, turns within the bound unless the plan says otherwise, and what the plan says
about the instants between keys checked by geometry that shares nothing with the planner."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geometry import HANGING, arm_penetration, obstacles, standard_arm, triangles_of
from reach_addon.core import Planner, Settings, Task
from reach_addon.core.arm import ArmConfig, forward_kinematics, hand_angles, hand_direction
from reach_addon.core.collision import Obstacles
from reach_addon.core.arm import hand_coefficients
from reach_addon.core.generator import ConfigurationGenerator
from reach_addon.core.hand import plan_hand
from reach_addon.core.motion import time_path
from reach_addon.demo import WORKPLACE, demo_tasks

FPS = 24.0


@settings(max_examples=200, deadline=None)
@given(st.floats(-89, 89), st.floats(-80, 80), st.floats(0, 140), st.floats(-60, 60),
       st.floats(-85, 85), st.floats(-85, 85))
def test_hand_angles_invert_hand_direction(alpha, beta, elbow, gamma, bend, side):
    arm = standard_arm()
    joints, b = forward_kinematics(arm, np.array([0.0, alpha, beta, gamma, elbow]))
    u, f = joints[2] - joints[1], joints[3] - joints[2]
    u, f = u / np.linalg.norm(u), f / np.linalg.norm(f)
    d = hand_direction(u, b, f, bend, side)
    got = hand_angles(u, b, f, d)
    assert np.allclose(hand_direction(u, b, f, *got), d, atol=1e-9)


def _instant_poses(plan, n=4):
    """World joints at n instants per frame: the keys, and the arm's angles and the wrist's
    two angles interpolated between them (computed here, from the plan's angles)."""
    arm = plan.arm
    out = []
    for a, b in zip(plan.poses[:-1], plan.poses[1:]):
        for t in np.arange(n) / n:
            c = (1 - t) * a.config.as_array() + t * b.config.as_array()
            joints, bend = forward_kinematics(arm, c)
            hand = (1 - t) * np.array(a.hand) + t * np.array(b.hand)
            s, e, w = joints[1], joints[2], joints[3]
            d = hand_direction((e - s) / np.linalg.norm(e - s), bend,
                               (w - e) / np.linalg.norm(w - e), *hand)
            joints[4] = w + arm.hand_length * d
            out.append(arm.to_world_points(joints))
    out.append(plan.world_joints()[-1])
    return out


@pytest.fixture(scope="module")
def demo_plans():
    arm = standard_arm()
    planner = Planner(arm, obstacles(WORKPLACE), Settings())
    return {name: planner.plan(task) for name, task in demo_tasks(FPS)}


@pytest.mark.parametrize("name", ["collision_free", "rotation", "guided", "chase"])
def test_the_hand_is_bounded_and_clear_between_keys(demo_plans, name):
    """On the four demo tasks the hand keeps its bounds (relative to the forearm and in
    space) and nothing touches between keys: the plan says so, and an independent exact
    distance check at 4 instants a frame agrees."""
    plan = demo_plans[name]
    s = plan.stats
    assert plan.success, plan.message
    assert s.unbounded_hand_turns == 0 and s.touching_transitions == 0
    assert 0.0 <= s.mean_wrist_bend_deg <= s.max_wrist_bend_deg
    assert s.max_wrist_turn_deg_per_frame <= plan.settings.hand_turn_speed / FPS + 1e-6
    assert s.max_hand_turn_deg_per_frame <= plan.settings.hand_space_turn_speed / FPS + 1e-6
    tris = triangles_of(WORKPLACE)
    depth = min(arm_penetration(plan.arm, j, tris) for j in _instant_poses(plan))
    assert depth >= -1e-3, f"{name}: {-depth:.4f} m into an obstacle between keys"


def test_the_motion_starts_from_the_rigs_own_hand():
    arm = standard_arm()
    start_hand = (55.0, -20.0)
    task = Task("reach", np.array([[-0.30, -0.30, 1.10]]), HANGING, FPS, start_hand=start_hand)
    plan = Planner(arm, None, Settings()).plan(task)
    assert plan.success, plan.message
    assert plan.poses[0].hand == pytest.approx(start_hand)
    s = plan.stats
    assert s.unbounded_hand_turns == 0 and s.touching_transitions == 0
    assert s.max_wrist_turn_deg_per_frame <= 360.0 / FPS + 1e-6
    # free space: the hand relaxes back to neutral by the end of the reach
    assert abs(plan.poses[-1].hand[0]) <= 5.0 + 1e-6 and abs(plan.poses[-1].hand[1]) <= 12.5


@pytest.mark.parametrize("rest", [(20.0, 0.0), (-15.0, 10.0)])
def test_the_hand_relaxes_to_the_rigs_own_neutral_wrist(rest):
    """A rig whose rest pose holds the hand bent on the forearm: in free space the hand
    starts at that rest and ends there (within a grid step), not on the forearm's line,
    and the plan's bend figures are measured from it (0 at the start)."""
    import dataclasses

    from reach_addon.core.hand_grid import wrist_turn

    arm = dataclasses.replace(standard_arm(), hand_rest=rest)
    assert wrist_turn(hand_coefficients(*rest), arm.rest_coefficients) == \
        pytest.approx(0.0, abs=1e-6)
    task = Task("reach", np.array([[-0.30, -0.30, 1.10]]), HANGING, FPS, start_hand=rest)
    plan = Planner(arm, None, Settings()).plan(task)
    assert plan.success, plan.message
    end = plan.poses[-1].hand
    off = wrist_turn(hand_coefficients(*end), arm.rest_coefficients)
    assert off <= Settings().hand_grid_step, (end, rest)
    # the forearm's line is as far from the rest as the rest is from it
    assert wrist_turn(hand_coefficients(0.0, 0.0), arm.rest_coefficients) > 10.0
    assert plan.stats.max_wrist_bend_deg <= wrist_turn(
        hand_coefficients(0.0, 0.0), arm.rest_coefficients)


def test_the_forearms_line_is_the_neutral_of_a_rig_without_a_rest_bend():
    """``hand_rest`` (0, 0) keeps the bend from the forearm's line, bit for bit."""
    from reach_addon.core.hand_grid import wrist_turn

    c = np.array([hand_coefficients(b, s) for b in (-70.0, 0.0, 33.0) for s in (-25.0, 0.0, 9.0)])
    np.testing.assert_array_equal(wrist_turn(c, standard_arm().rest_coefficients),
                                  np.degrees(np.arccos(np.clip(c[:, 0], -1.0, 1.0))))


class _Pocket(ConfigurationGenerator):
    """No obstacles, but hand directions cleared by a rule on the wrist's progress ``u``
    along a straight reach and the hand's bend ``b`` in the elbow's plane: everything at
    first; then, with the whole margin, only the hand bent up (b ≥ 30°) while, with half
    of it, bent down by 30-40° too (where the path's own hand, bent down 35°, passes);
    then either way; at the end only bent down."""

    def __init__(self, arm, settings, a, b, loose=False):
        super().__init__(arm, Obstacles(None), settings)
        self.a, self.b, self.loose = a, b, loose

    def between_keys(self):
        return _Pocket(self.arm, self.settings, self.a, self.b, loose=True)

    def hands_clear(self, joints, bend, body_rotation, coefficients):
        c = np.atleast_2d(np.asarray(coefficients, dtype=float))
        ab = self.b - self.a
        u = float(np.dot(np.asarray(joints[3]) - self.a, ab) / np.dot(ab, ab))
        b = np.degrees(np.arctan2(c[:, 1], c[:, 0]))
        if u < 0.3:
            return np.ones(len(c), dtype=bool)
        if u < 0.45:
            return (b >= 30.0) | ((b <= -30.0) & (b >= -40.0) if self.loose else False)
        if u < 0.7:
            return np.abs(b) >= 30.0
        return b <= -30.0


def test_slowing_down_follows_the_paths_own_hand():
    """The DP loses the path's own hand where it turns faster than the bound (here in
    place, early) and later, where the only branch it kept closes, finds no bounded, clear
    choice that slowing down there could give: it slows down where the own hand was lost
    instead, and the hand stays bounded and clear (it used to lift the bound)."""
    arm = standard_arm()
    s = Settings()
    c0 = np.array([0.0, 20.0, 30.0, -20.0, 60.0])
    c1 = np.array([0.0, 40.0, 60.0, 0.0, 70.0])
    plain = ConfigurationGenerator(arm, Obstacles(None), s)
    ends = [plain.config_pose(ArmConfig.from_array(c)) for c in (c0, c1)]
    gen = _Pocket(arm, s, ends[0].wrist, ends[1].wrist)
    dense = []
    for t in np.linspace(0.0, 1.0, 41):
        config = ArmConfig.from_array((1 - t) * c0 + t * c1)
        if t == 0.2:          # the hand turns in place, down 35°, before the pocket
            dense.append(gen.config_pose(config))
        dense.append(gen.config_pose(config, (0.0, 0.0) if t < 0.2 else (-35.0, 0.0)))
    poses, arcs, sampler = time_path(gen, dense, 24)
    report = plan_hand(gen, poses, FPS, arcs=arcs, sampler=sampler)
    assert report.unbounded_turns == 0 and not report.unclear_transitions
    assert report.max_wrist_turn_deg <= s.hand_turn_speed / FPS + 1e-6
    assert report.max_hand_turn_deg <= s.hand_space_turn_speed / FPS + 1e-6
    for p in report.poses:
        assert gen.between_keys().hands_clear(
            p.joints, p.bend, 0.0, [hand_coefficients(*p.hand)])[0]


def test_a_turn_at_the_bound_is_a_whole_number_of_grid_steps():
    """At 25 fps the bound is 14.4° a frame: with bends every 5° the hand could relax only
    10° a frame (Goblin's shelf held its bend two frames longer); the grid's bend step
    divides the bound (hand_grid.bend_step), so a state lies exactly one bound away, and
    at 24 fps the grid is as it was (every 5°)."""
    from reach_addon.core.hand_grid import bend_step, hand_grid
    from reach_addon.core.settings import Settings

    s = Settings()
    assert bend_step(5.0, 15.0) == 5.0 and bend_step(5.0, 14.4) == pytest.approx(4.8)
    assert bend_step(5.0, 12.0) == pytest.approx(4.0) and bend_step(5.0, 0.0) == 5.0
    for bound in (15.0, 14.4, 12.0, 6.0):
        grid = hand_grid(s, (0.0, 0.0), bound)
        at_rest = int(np.flatnonzero((np.abs(grid.angles) < 1e-9).all(axis=1))[0])
        reach = grid.turn[at_rest][grid.turn[at_rest] <= bound + 1e-9]
        assert reach.max() == pytest.approx(bound), bound
        assert grid.angles[:, 0].min() == -s.wrist_bend_max
        assert grid.angles[:, 0].max() == s.wrist_bend_max
    assert sorted(set(hand_grid(s, (0.0, 0.0), 15.0).angles[:, 0].round(9))) == \
        [float(b) for b in np.arange(-70.0, 70.1, 5.0)]
