"""The swivel and the hand chosen along a whole path (core.elbow): a path whose middle lifts
the elbow over a low hand comes back with none, every pose legal, clear and within the
bounds of the one before; a path without a wing, or with the pass turned off, is left as
it is."""

import numpy as np

from reach_addon.core import Settings
from reach_addon.core.arm import frame_turn
from reach_addon.core.collision import Obstacles
from reach_addon.core.elbow import chicken_wing, elbow_lift, relax_elbow, wing_count
from reach_addon.core.generator import ConfigurationGenerator
from reach_addon.samples import standard_arm


def test_the_wing_and_the_lift_are_measured_against_the_shoulder():
    # e_z - s_z > m L and s_z - w_z > m L
    assert chicken_wing(0.0, 0.15, -0.2, 1.0, 0.1)
    assert not chicken_wing(0.0, 0.05, -0.2, 1.0, 0.1)      # elbow low
    assert not chicken_wing(0.0, 0.15, -0.05, 1.0, 0.1)     # hand high
    # max(0, e_z - s_z) / L where the wrist is below the shoulder
    assert np.allclose(elbow_lift(0.0, [0.2, -0.1, 0.2], [-0.1, -0.1, 0.1], 2.0),
                       [0.1, 0.0, 0.0])


def winged_path(gen):
    """Wrist positions at most one step apart from an arm low at the side out to the side
    and on, forward and down; the ends the generator's strongest poses, the middle the
    highest-elbow candidate at each position (canonical frame, the standard figure)."""
    corners = np.array([[0.30, 0.05, -0.25], [0.45, 0.20, -0.10], [0.25, 0.40, -0.20]])
    start = gen.solve(corners[0])
    wrists = [corners[0]]
    for a, b in zip(corners, corners[1:]):
        n = int(np.ceil(np.linalg.norm(b - a) / gen.step_length))
        wrists += [a + (b - a) * t for t in np.linspace(0.0, 1.0, n + 1)[1:]]
    poses = [start]
    for w in wrists[1:-1]:
        _sol, ks, joints = gen.clear_swivels(w, 0.0, start)
        poses.append(gen.solve(w, body_rotation=0.0, swivel=ks[int(np.argmax(joints[:, 2, 2]))]))
    poses.append(gen.solve(wrists[-1], body_rotation=0.0))
    return poses


def test_a_winged_path_comes_back_without_a_wing():
    arm, s = standard_arm(), Settings()
    gen = ConfigurationGenerator(arm, Obstacles(None), s)
    path = winged_path(gen)
    assert all(p is not None for p in path)
    assert wing_count(path, arm.arm_length, s.wing_margin) > 0
    out = relax_elbow(gen, path)
    assert out is not path
    assert wing_count(out, arm.arm_length, s.wing_margin) == 0
    assert out[0] is path[0] and out[-1] is path[-1]            # the ends kept
    assert np.allclose([p.wrist for p in out], [p.wrist for p in path])
    for a, b in zip(out, out[1:]):
        assert gen.smooth_between(a, b)
        assert not gen.pose_collides(b)


def test_a_bound_in_space_keeps_the_relaxed_hand_from_turning_faster():
    """A chase's frames cannot be slowed: with ``space_turn`` the relaxed path's hand turns
    in space (the arm's swing included, :func:`frame_turn`) within it where a path without a
    wing can, here where the unbounded choice turns it almost twice as far."""
    arm, s = standard_arm(), Settings()
    gen = ConfigurationGenerator(arm, Obstacles(None), s)
    path = winged_path(gen)

    def most(poses):
        return max(frame_turn(a, b) for a, b in zip(poses, poses[1:]))

    assert most(relax_elbow(gen, path)) > 15.0
    bounded = relax_elbow(gen, path, space_turn=10.0)
    assert wing_count(bounded, arm.arm_length, s.wing_margin) == 0
    assert most(bounded) <= 10.0 + 1e-6
    for a, b in zip(bounded, bounded[1:]):
        assert gen.smooth_between(a, b) and not gen.pose_collides(b)


def test_a_path_without_a_wing_or_with_the_pass_off_is_left_as_it_is():
    arm = standard_arm()
    gen = ConfigurationGenerator(arm, Obstacles(None), Settings())
    path = winged_path(gen)
    off = ConfigurationGenerator(arm, Obstacles(None), Settings(elbow_comfort=0.0))
    assert relax_elbow(off, path) is path
    relaxed = relax_elbow(gen, path)
    assert relax_elbow(gen, relaxed) is relaxed


def test_the_elbow_kept_low_lets_the_hand_follow_through_a_hole():
    """Tight scene 2 (the robot arm through a rectangular hole): the search's path lifts
    the elbow over the hand and the hand cannot follow it clear (test_tight's sampling
    fallback case); with the swivels and hands chosen along the whole path it can, with no
    sampling planner, checked by the independent segment-triangle test."""
    from verification import tight

    arm_name, family, seed = tight.scene_plan(240, 0)[2]
    scene = tight.generate(arm_name, tight.make_arm(arm_name), family, seed)
    out = tight.plan_scene(scene, 0.0, Settings(sampling_fallback=False), run_ompl=False)
    assert out["reach_planned"] and out["reach_method"] != "sampling", out["reach_message"]
    assert out["reach_success"] and out["reach_collisions"] == 0
