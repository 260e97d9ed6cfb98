"""Match orientation in the core (core.orient): the best roll and its window against brute
force, the roll's ramp within the hand's turn bound, the hand pass's pull toward the wanted
direction, and nothing changed when it is off."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geometry import HANGING, standard_arm
from reach_addon.core import Planner, Settings, Task
from reach_addon.core.arm import frame_turn, hand_frame, roll_frames
from reach_addon.core.arm import frame_angle
from reach_addon.core.orient import (best_roll, clamp_roll, minimum_jerk_steps,
                                     palm_frame, roll_increments, wanted_axes)

FPS = 24.0


def unit(v):
    return np.asarray(v, float) / np.linalg.norm(v)


def random_frame(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2 ** 31 - 1))
def test_best_roll_is_the_best_of_every_roll(seed):
    rng = np.random.default_rng(seed)
    hand, want = random_frame(rng), random_frame(rng)
    d, n = hand[:, 0], hand[:, 1]
    psi = float(best_roll(d, n, want[:, 0], want[:, 1]))
    grid = np.linspace(-180.0, 180.0, 3601)
    # the palm rolled about d, by Rodrigues' formula (not the module's roll_frames)
    rolled = [np.cos(np.radians(a)) * n + np.sin(np.radians(a)) * np.cross(d, n) for a in grid]
    errors = [float(frame_angle(palm_frame(d, r), want)) for r in rolled]
    rolled_best = np.cos(np.radians(psi)) * n + np.sin(np.radians(psi)) * np.cross(d, n)
    assert float(frame_angle(palm_frame(d, rolled_best), want)) <= min(errors) + 1e-6


def test_roll_frames_turns_about_the_first_column():
    rng = np.random.default_rng(3)
    f = random_frame(rng)
    r = roll_frames(f, 30.0)
    assert np.allclose(r[:, 0], f[:, 0])
    assert math.degrees(math.acos(r[:, 1] @ f[:, 1])) == pytest.approx(30.0)
    assert np.allclose(r.T @ r, np.eye(3))
    assert np.allclose(np.cross(f[:, 0], f[:, 1]) @ r[:, 1], math.sin(math.radians(30.0)))


def test_a_roll_beyond_the_window_stops_at_the_nearer_limit():
    assert clamp_roll(50.0, -80.0, 60.0) == 50.0
    assert clamp_roll(70.0, -80.0, 60.0) == 60.0
    assert clamp_roll(-170.0, -80.0, 60.0) == -80.0       # 90° from -80, 130° from 60
    assert clamp_roll(150.0, -80.0, 60.0) == 60.0         # 90° from 60, 130° from -80
    assert clamp_roll(175.0, -80.0, 60.0) == -80.0        # 105° from -80 through 180°


def test_the_convention_reads_the_targets_axes():
    r = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])   # 90° about z
    finger, palm = wanted_axes(r, "+y", "-z")
    assert np.allclose(finger, [-1.0, 0.0, 0.0]) and np.allclose(palm, [0.0, 0.0, -1.0])
    finger, palm = wanted_axes(2.0 * r, "+z", "-y")                        # scale ignored
    assert np.allclose(finger, [0.0, 0.0, 1.0]) and np.allclose(palm, [1.0, 0.0, 0.0])


@pytest.mark.parametrize("delta", [120.0, -75.0])
def test_the_roll_ramp_adds_up_within_its_slack(delta):
    n = 30
    ample = np.full(n, 100.0)
    steps = roll_increments(delta, ample)
    assert steps.sum() == pytest.approx(delta)
    assert np.allclose(steps, delta * minimum_jerk_steps(n + 1))        # the min-jerk profile
    slack = np.full(n, 100.0)
    slack[10:20] = 2.0                                                   # a busy stretch
    steps = roll_increments(delta, slack)
    assert steps.sum() == pytest.approx(delta)
    assert (np.abs(steps) <= slack + 1e-9).all()
    tight = np.full(n, 1.0)                                              # not enough room
    steps = roll_increments(delta, tight)
    assert np.abs(steps).sum() == pytest.approx(n) and (np.sign(steps) == np.sign(delta)).all()


def _rotation(finger, palm):
    """A target's rotation whose +y is ``finger`` and -z ``palm`` (the default convention)."""
    y, z = unit(finger), -unit(palm)
    return np.column_stack([np.cross(y, z), y, z])


@pytest.fixture(scope="module")
def reach():
    arm = standard_arm()
    length = arm.arm_length
    forward, up, out = (arm.to_world_vectors(v) for v in ([0, 1, 0], [0, 0, 1], [1, 0, 0]))
    target = arm.to_world_points(arm.shoulder) + length * (0.6 * forward + 0.1 * out - 0.1 * up)
    return arm, target, forward, up, out


def test_off_the_plan_is_the_one_without_orientations(reach):
    arm, target, forward, up, _out = reach
    rot = _rotation(forward, -up)[None]
    plain = Planner(arm, None, Settings()).plan(Task("reach", target[None], HANGING, FPS))
    given_ = Planner(arm, None, Settings()).plan(Task("reach", target[None], HANGING, FPS,
                                                      orientations=rot))
    assert len(plain.poses) == len(given_.poses)
    for a, b in zip(plain.poses, given_.poses):
        assert np.array_equal(a.joints, b.joints) and a.hand == b.hand and b.roll == 0.0
    assert given_.segments[0].stats.orientation_error_deg is None


@pytest.mark.parametrize("case", ["forward palm down", "forward palm in", "up and forward"])
def test_the_hand_arrives_oriented_within_its_bounds(reach, case):
    arm, target, forward, up, out = reach
    finger, palm = {"forward palm down": (forward, -up), "forward palm in": (forward, -out),
                    "up and forward": (forward + up, forward - up)}[case]
    s = Settings(match_orientation=True)
    plan = Planner(arm, None, s).plan(Task("reach", target[None], HANGING, FPS,
                                           orientations=_rotation(finger, palm)[None]))
    assert plan.success
    stats = plan.segments[0].stats
    # the palm frame at the last frame, from the joints and the roll (canonical → world)
    last = plan.poses[-1]
    frame = roll_frames(hand_frame(last), last.roll)
    d = arm.to_world_vectors(frame[:, 0])
    n = arm.to_world_vectors(frame @ [0.0, -1.0, 0.0])   # the core's palm without a rig: −g
    want = palm_frame(unit(finger), unit(palm - (palm @ unit(finger)) * unit(finger)))
    measured = float(frame_angle(palm_frame(d, n), want))
    assert stats.orientation_error_deg == pytest.approx(measured, abs=1e-6)
    assert stats.orientation_met and measured <= s.orientation_tolerance
    # the roll ramps in from 0 and every frame's turn in space stays within the bound
    rolls = [p.roll for p in plan.poses]
    assert rolls[0] == 0.0 and abs(rolls[-1]) > 1.0
    bound = s.hand_space_turn_speed / FPS
    turns = [frame_turn(a, b) for a, b in zip(plan.poses[:-1], plan.poses[1:])]
    assert max(turns) <= bound + 1e-6
    assert stats.max_hand_turn_deg_per_frame == pytest.approx(max(turns))


def test_beyond_the_forearms_range_the_closest_is_kept_and_reported(reach):
    arm, target, forward, up, _out = reach
    s = Settings(match_orientation=True)
    # palm up: 180° of supination from the palm-down start, beyond the forearm's 80°
    plan = Planner(arm, None, s).plan(Task("reach", target[None], HANGING, FPS,
                                           orientations=_rotation(forward, up)[None]))
    stats = plan.segments[0].stats
    assert plan.success and not stats.orientation_met
    assert stats.orientation_error_deg > s.orientation_tolerance
    assert abs(plan.poses[-1].roll) <= max(s.pronation_max, s.supination_max) + 1e-6
