"""The hand pass's fallback steps (core.hand.HandPass), one at a time, on a real motion: the
demo's collision-free reach over the crate in the demo workplace (real meshes, a real BVH),
searched, smoothed and timed as the planner does it. Each test starts a pass on the motion
(HandPass.begin), takes one step and checks what the step did to the pass's state and to
the DP's answer."""

import numpy as np
import pytest

from geometry import obstacles, standard_arm
from reach_addon.core import Planner, Settings
from reach_addon.core.hand import HandPass
from reach_addon.core.motion import shortcut, time_path
from reach_addon.core.steps import drain
from reach_addon.demo import WORKPLACE, demo_tasks

FPS = 24.0
FRAMES = 40


@pytest.fixture(scope="module")
def motion():
    """(generator, the dense validated path, its frames, their arc lengths, the sampler)."""
    arm = standard_arm()
    planner = Planner(arm, obstacles(WORKPLACE), Settings())
    task = dict(demo_tasks(FPS))["collision_free"]
    start = planner.generator.config_pose(task.start, task.start_hand)
    target = arm.to_canonical_points(task.targets[0])
    route = drain(planner.route_steps(start, target))
    assert route.result.success
    gen = planner.generator.for_reach(start, target)
    dense = shortcut(gen, route.result.path)
    poses, arcs, sampler = time_path(gen, dense, FRAMES)
    return gen, dense, poses, arcs, sampler


def begun(motion, fps=FPS) -> HandPass:
    gen, _dense, poses, arcs, sampler = motion
    hand_pass = HandPass(gen, fps, arcs=arcs, sampler=sampler)
    hand_pass.begin(poses)
    return hand_pass


def dp(p: HandPass):
    return p._dp(p.poses, p.grid, p.feasible, p.banned, p.lifted, p.own_only)


def own(p: HandPass) -> int:
    """The state index of the motion's own hand."""
    return len(p.grid.angles)


def mark_frames(p: HandPass):
    """Some state on frames before and after frame 10, to watch it being renumbered."""
    p.lift(4)
    p.lift(12)
    p.accept(15)
    p.ban(20, (0, 0))


def test_ban_forbids_a_pair_of_hands_on_one_transition(motion):
    p = begun(motion)
    path, fail = dp(p)
    assert fail is None
    pair = (path[5], path[6])
    p.ban(5, pair)
    assert p.banned == {6: {pair}}
    banned_path, fail = dp(p)
    assert fail is None, "a clear, bounded way round the banned pair remains"
    assert (banned_path[5], banned_path[6]) != pair


def test_slow_down_inserts_poses_on_the_validated_path(motion):
    p = begun(motion)
    mark_frames(p)
    n, a10, a11 = len(p.poses), p.arcs[10], p.arcs[11]
    before, after = p.poses[10], p.poses[11]
    assert p.budget >= 3
    assert p.slow_down(10, 3)
    assert len(p.poses) == len(p.feasible) == len(p.arcs) == n + 3 and p.inserted == 3
    assert p.poses[10] is before and p.poses[14] is after
    for i, t in enumerate((0.25, 0.5, 0.75)):
        arc = p.arcs[11 + i]
        assert arc == pytest.approx((1 - t) * a10 + t * a11)
        np.testing.assert_allclose(p.poses[11 + i].wrist, p.sampler(arc).wrist, atol=1e-12)
        assert id(p.poses[11 + i]) in p.refined
        assert p.feasible[11 + i].shape == (own(p) + 1,)
    # frames after the insertion are renumbered, those before are not
    assert p.lifted == {4, 15} and p.accepted == {18} and set(p.banned) == {24}
    # and the budget bounds it
    p.budget = p.inserted
    assert not p.slow_down(20, 2) and len(p.poses) == n + 3


def test_hold_repeats_both_keys_so_the_arm_waits(motion):
    p = begun(motion)
    mark_frames(p)
    n, a10, a11 = len(p.poses), p.arcs[10], p.arcs[11]
    pose10, pose11, clear10, clear11 = p.poses[10], p.poses[11], p.feasible[10], p.feasible[11]
    assert p.hold(10, 3)
    assert len(p.poses) == len(p.feasible) == len(p.arcs) == n + 3 and p.inserted == 3
    # two copies of frame 10 (the hand turns before the move), one of frame 11 (after)
    assert [p.poses[k] for k in range(10, 15)] == [pose10, pose10, pose10, pose11, pose11]
    assert all(p.poses[k] is pose10 for k in (11, 12)) and p.poses[13] is pose11
    assert p.arcs[10:15] == [a10, a10, a10, a11, a11]
    assert p.feasible[11] is clear10 and p.feasible[13] is clear11
    assert not p.refined                          # held frames are no poses between
    assert p.lifted == {4, 15} and p.accepted == {18} and set(p.banned) == {24}


def test_lift_lets_the_hand_turn_faster_than_the_bound_into_a_frame(motion):
    """At 100 times the frame rate no hand can keep to its bound in space (the forearm
    itself turns faster): the DP finds no way into the first frame where the arm moves.
    Lifting the bound there lets it on, and with every frame lifted it finds a path."""
    p = begun(motion, fps=100 * FPS)
    path, fail = dp(p)
    assert path is None
    first = fail[0]
    p.lift(first)
    assert p.lifted == {first}
    path, fail = dp(p)
    assert path is None and fail[0] > first
    for k in range(1, len(p.poses)):
        p.lift(k)
    path, fail = dp(p)
    assert fail is None and len(path) == len(p.poses)


def test_keep_own_holds_a_transition_to_the_motions_own_hands(motion):
    p = begun(motion)
    p.keep_own(20)
    assert p.own_only == {21} and p.forced == (21, 21, [])
    assert p._own_turn(p.poses, 21) <= 1.0            # within the bound: nothing lifted
    assert not p.lifted
    path, fail = dp(p)
    assert fail is None and path[20] == path[21] == own(p)


def test_keep_own_lifts_the_bound_where_the_own_hands_turn_faster(motion):
    p = begun(motion, fps=100 * FPS)
    assert p._own_turn(p.poses, 21) > 1.0
    p.keep_own(20)
    assert p.own_only == {21} and p.lifted == {21} and p.forced == (21, 21, [21])


def test_release_own_undoes_keep_own_and_accepts_the_transition(motion):
    p = begun(motion, fps=100 * FPS)
    p.lift(3)
    p.keep_own(20)
    p._retreat_from_own(22)                 # the DP found no way at 22: lifted there too
    assert p.lifted == {3, 21, 22} and p.forced == (21, 21, [21, 22])
    p.release_own()
    assert p.own_only == set() and p.lifted == {3} and p.accepted == {20}
    assert p.forced is None


def test_accept_leaves_a_touching_transition_out_of_the_checks(motion):
    """Every sixth pose of the dense path as keys, each with its own hand: between two of
    them the arm or hand touches something as the keys interpolate. Accepted, that
    transition is no longer checked."""
    gen, dense, _poses, _arcs, _sampler = motion
    p = HandPass(gen, FPS)
    p.begin(dense[::6] + [dense[-1]])
    hands = [own(p)] * len(p.poses)
    k, _what = p._between(p.poses, p.grid, hands, p.accepted)
    p.accept(k)
    assert p.accepted == {k}
    after = p._between(p.poses, p.grid, hands, p.accepted)
    assert after is None or after[0] > k
