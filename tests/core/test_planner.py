"""The four tasks on scenes of real meshes, checked frame by frame by an independent test.

The figure stands at the origin facing -Y, chest at 1.4 m; its right shoulder is at about
(-0.19, 0, 1.4) and the hanging right wrist near (-0.29, -0.14, 0.85).
"""

import numpy as np
import pytest

from geometry import (HANGING, arm_penetration, obstacles, run_steps, shelf, standard_arm,
                      table, triangles_of)
from reach_addon.core import (ARM_DOES_NOT_FIT, NEEDS_LEAN, NEEDS_STEP, NO_PATH, OUT_OF_REACH,
                              START_HELD, START_IN_COLLISION, TARGET_IN_OBSTACLE,
                              ArmConfig, Obstacles, Planner, ReachError, Settings, Task, plan)
from reach_addon.core.diagnosis import what_holds
from reach_addon.core.motion import minimum_jerk

WALL = {"Crate": [((-0.60, -0.36, 0.70), (0.00, -0.30, 1.08))]}
BEHIND_WALL = np.array([-0.28, -0.46, 1.14])


def check_plan(p, named_parts, settings=None):
    """Every frame legal and clear of the obstacles by the independent check."""
    s = settings or p.settings
    arm = p.arm
    tris = triangles_of(named_parts) if named_parts else None
    joints = p.world_joints()
    for f, pose in enumerate(p.poses):
        c = pose.config
        assert s.alpha_min - 1e-6 <= c.alpha <= s.alpha_max + 1e-6, f
        assert s.beta_min - 1e-6 <= c.beta <= s.beta_max + 1e-6, f
        assert s.gamma_min - 1e-6 <= c.gamma <= s.gamma_max + 1e-6, f
        assert s.elbow_min - 1e-6 <= c.elbow <= s.elbow_max + 1e-6, f
        # segment lengths are the arm's
        assert np.linalg.norm(joints[f, 2] - joints[f, 1]) == pytest.approx(arm.upper_arm_length)
        assert np.linalg.norm(joints[f, 3] - joints[f, 2]) == pytest.approx(arm.forearm_length)
        if tris is not None:
            depth = arm_penetration(arm, joints[f], tris)
            assert depth >= 0.0, f"frame {f} passes {-depth:.4f} m into an obstacle"


def straight_line_blocked(a, b, lo, hi, samples=400):
    pts = a + np.linspace(0, 1, samples)[:, None] * (b - a)
    return bool(((pts >= lo) & (pts <= hi)).all(axis=1).any())


@pytest.fixture(scope="module")
def arm():
    return standard_arm()


@pytest.fixture(scope="module")
def start_wrist(arm):
    return Planner(arm, None).generator.config_pose(HANGING).wrist


def test_collision_free_reach_around_a_blocking_crate(arm):
    obs = obstacles(WALL)
    start = arm.to_world_points(Planner(arm, obs).generator.config_pose(HANGING).wrist)
    lo, hi = np.array(WALL["Crate"][0][0]), np.array(WALL["Crate"][0][1])
    assert straight_line_blocked(start, BEHIND_WALL, lo, hi), "the scene must block the straight path"
    p = plan(Task("reach", BEHIND_WALL[None], HANGING), arm, obs)
    assert p.success, p.message
    assert np.linalg.norm(p.wrist_trajectory()[-1] - BEHIND_WALL) <= 0.005 * arm.arm_length
    check_plan(p, WALL)
    st = p.stats
    assert st.nodes_in_solution == len(p.segments[0].search_path) >= 2
    assert st.nodes_searched >= st.nodes_in_solution - 1
    steps = np.linalg.norm(np.diff(p.search_path(), axis=0), axis=1)
    assert steps.max() <= Settings().step * arm.arm_length + 1e-9
    assert st.path_length_arm_lengths == pytest.approx(steps.sum() / arm.arm_length)
    assert st.search_time_s > 0 and st.frames == len(p.poses)
    assert st.min_clearance_arm_lengths >= 0


def test_the_clearance_margin_is_kept(arm):
    s = Settings(clearance=0.05)
    p = plan(Task("reach", BEHIND_WALL[None], HANGING), arm, obstacles(WALL), s)
    assert p.success, p.message
    tris = triangles_of(WALL)
    worst = min(arm_penetration(arm, j, tris) for j in p.world_joints())
    assert worst >= 0.05 * arm.arm_length - 0.002


def test_rotation_reach_engages_the_chest_past_the_starting_angle(arm):
    # in front, then to the side, then behind-side at the edge of reach
    targets = np.array([[-0.30, -0.45, 1.30], [-0.70, -0.15, 1.35], [-0.62, 0.35, 1.35]])
    p = plan(Task("sequence", targets, HANGING, names=("front", "side", "behind")), arm, None)
    assert p.success, p.message
    wrists = p.wrist_trajectory()
    body = np.array([q.config.body_rotation for q in p.poses])
    for seg, target in zip(p.segments, targets):
        assert seg.success
        assert np.linalg.norm(wrists[seg.frame_end] - target) <= 0.005 * arm.arm_length
    assert [s.name for s in p.segments] == ["front", "side", "behind"]
    assert p.segments[1].frame_start == p.segments[0].frame_end
    assert abs(body[p.segments[0].frame_end]) < 1e-9          # in front: no chest rotation
    assert body[p.segments[2].frame_end] > 15.0               # behind the side: the chest turns
    assert np.all(np.diff(body[p.segments[2].frame_start:p.segments[2].frame_end + 1]) > -1e-6)
    check_plan(p, None)


def test_guided_reach_follows_guiding_nodes_through_free_cells(arm):
    scene = {"Shelf": shelf((-0.25, -0.55), 0.9, 0.3, (0.95, 1.25, 1.55))}
    target = np.array([-0.25, -0.46, 1.10])          # between the two lower boards
    planner = Planner(arm, obstacles(scene))
    p = planner.plan(Task("guided", target[None], HANGING))
    assert p.success, p.message
    check_plan(p, scene)
    ws = planner.workspace
    assert ws.valid.shape == (11, 11, 11) and ws.valid.sum() > 50
    guides = p.guiding_nodes()
    assert len(guides) >= 1
    for g in arm.to_canonical_points(guides):
        idx = tuple(np.floor((g - ws.lower) / ws.cell).astype(int))
        assert ws.valid[idx] and not ws.occupied[idx]
    assert p.stats.preprocess_time_s > 0


def test_chase_reach_follows_a_moving_target(arm):
    frames = 48
    t = np.linspace(0, 1, frames)
    path = np.stack([-0.30 + 0.2 * np.cos(2 * np.pi * t), -0.45 + 0.05 * np.sin(2 * np.pi * t),
                     1.30 + 0.1 * np.sin(2 * np.pi * t)], 1)
    scene = {"Table": table((-0.3, -0.6), (1.0, 0.5), 0.95)}
    s = Settings()
    p = plan(Task("chase", path, HANGING, fps=24.0), arm, obstacles(scene), s)
    assert len(p.poses) == frames
    assert p.success, p.message
    wrists = p.wrist_trajectory()
    assert np.linalg.norm(wrists[-1] - path[-1]) <= s.goal_tolerance * arm.arm_length
    per_frame = np.linalg.norm(np.diff(wrists, axis=0), axis=1)
    limit = s.chase_max_speed / 24.0 * arm.arm_length
    assert per_frame.max() <= limit + 1e-9
    check_plan(p, scene)


def test_a_chase_slower_than_a_step_a_frame_keeps_its_speed_limit(arm):
    """A speed limit of 0.24 arm lengths a second is half a search step a frame at 24 fps:
    each frame takes part of its step (it took a whole one, twice the limit)."""
    frames = 48
    t = np.linspace(0, 1, frames)[:, None]
    path = np.array([-0.30, -0.45, 1.20]) + t * np.array([0.0, 0.0, 0.3])
    s = Settings(chase_max_speed=0.24, chase_plan_ahead=False)
    assert s.chase_max_speed / 24.0 < s.step
    p = plan(Task("chase", path, HANGING, fps=24.0), arm, None, s)
    per_frame = np.linalg.norm(np.diff(p.wrist_trajectory(), axis=0), axis=1)
    limit = s.chase_max_speed / 24.0 * arm.arm_length
    assert per_frame.max() <= limit * (1 + 1e-6), per_frame.max() / limit
    assert per_frame.max() >= 0.9 * limit               # and it goes at the limit


def test_target_out_of_reach_gets_the_closest_approach(arm):
    far = np.array([-0.3, -1.6, 1.4])
    p = plan(Task("reach", far[None], HANGING, names=("Lamp",)), arm, None)
    assert not p.success and p.reason == NEEDS_STEP
    assert "Lamp" in p.message and "out of reach" in p.message
    wrists = p.wrist_trajectory()
    assert len(p.poses) > 2
    assert np.linalg.norm(wrists[-1] - far) < np.linalg.norm(wrists[0] - far) - 0.3
    check_plan(p, None)


def test_target_inside_an_obstacle(arm):
    scene = {"Cabinet": [((-0.5, -0.7, 0.9), (0.0, -0.4, 1.3))]}
    inside = np.array([-0.25, -0.5, 1.1])
    p = plan(Task("reach", inside[None], HANGING, names=("Mug",)), arm, obstacles(scene))
    assert not p.success and p.reason == TARGET_IN_OBSTACLE
    assert "Cabinet" in p.message and "Mug" in p.message
    check_plan(p, scene)


def test_no_path_within_the_node_budget(arm):
    p = plan(Task("reach", BEHIND_WALL[None], HANGING), arm, obstacles(WALL),
             Settings(node_budget=10, guided_fallback=False, sampling_fallback=False))
    assert not p.success and p.reason == NO_PATH
    assert p.stats.nodes_searched == 10
    check_plan(p, WALL)


def test_start_pose_in_collision_is_reported(arm, start_wrist):
    w = arm.to_world_points(start_wrist)
    scene = {"Box": [(tuple(w - 0.05), tuple(w + 0.05))]}
    p = plan(Task("reach", BEHIND_WALL[None], HANGING), arm, obstacles(scene))
    assert not p.success and p.reason == START_IN_COLLISION and "Box" in p.message
    assert len(p.poses) == 1


def test_a_start_inside_the_body_is_a_start_in_collision(arm):
    """The forearm across the chest on the start frame: the search cannot leave the body's
    capsule, and the reason says so (it said no_path); a start in the body the search does
    leave is planned as usual."""
    stuck = ArmConfig(0.0, -30.0, -60.0, 0.0, 120.0)
    p = plan(Task("reach", np.array([[-0.35, -0.35, 1.2]]), stuck), arm, None,
             Settings(node_budget=600))
    assert not p.success and p.reason == START_IN_COLLISION
    assert "forearm inside the character's own body (its 'chest' capsule" in p.message
    left = ArmConfig(0.0, -15.0, -60.0, 0.0, 90.0)         # the forearm in the pelvis's
    assert plan(Task("reach", np.array([[-0.35, -0.35, 1.2]]), left), arm, None,
                Settings(node_budget=600)).success


def test_what_holds_an_arm_that_cannot_move(arm):
    """A small block half a step beyond the forearm's reach beside the wrist, out to the
    arm's side: the step toward it is refused by the block (at the forearm), and with only
    that step to take the arm is held by it; with the step away from it as well, the arm
    can move. A search that gives up after leaving the start is ``no_path``, not held."""
    start = Planner(arm, None).generator.config_pose(HANGING)
    s = Settings()
    side = np.array([1.0, 0.0, 0.0])                          # the arm's side, canonical
    gap = arm.forearm_radius + (s.clearance + 0.5 * s.step) * arm.arm_length
    centre = arm.to_world_points(start.wrist + (gap + 0.01) * side)
    block = {"Block": [(tuple(centre - 0.01), tuple(centre + 0.01))]}
    gen = Planner(arm, obstacles(block)).generator
    assert gen.solve(start.wrist, hand_scale=None) is not None   # the start itself is clear
    held = what_holds(gen, start, [side])
    assert held is not None and (held.kind, held.what, held.steps, held.tried) == \
        ("obstacle", "Block", 1, 1), held
    assert what_holds(gen, start, [side, -side]) is None
    p = plan(Task("reach", BEHIND_WALL[None], HANGING), arm, obstacles(WALL),
             Settings(node_budget=40, guided_fallback=False, sampling_fallback=False))
    assert not p.success and p.reason == NO_PATH


def test_an_arm_held_by_its_smoothness_bound_is_start_held(arm):
    """Smoothness 1° a step of 0.05 arm lengths: no step from the hanging arm is within it,
    so the search never leaves the start. Refused as ``start_held``, naming the setting
    (it said no_path, as a crowded scene does)."""
    p = plan(Task("reach", np.array([[-0.3, -0.35, 1.1]]), HANGING), arm, None,
             Settings(max_joint_step=1.0, step=0.05, sampling_fallback=False))
    assert not p.success and p.reason == START_HELD, p.message
    assert "cannot move from its start pose" in p.message
    assert "more than 1° at once, the Smoothness setting" in p.message


def test_plans_are_deterministic(arm):
    scene = {**WALL, "Table": table((-0.3, -0.7), (1.0, 0.4), 0.9)}
    a = plan(Task("reach", BEHIND_WALL[None], HANGING), arm, obstacles(scene))
    b = plan(Task("reach", BEHIND_WALL[None], HANGING), arm, obstacles(scene))
    assert len(a.poses) == len(b.poses)
    assert np.array_equal(a.world_joints(), b.world_joints())
    assert [q.config for q in a.poses] == [q.config for q in b.poses]
    assert a.stats.nodes_searched == b.stats.nodes_searched


def test_left_arm_mirrors_the_right(arm):
    left = standard_arm("left")
    target_right = np.array([-0.30, -0.45, 1.25])
    target_left = target_right * [-1, 1, 1]
    pr = plan(Task("reach", target_right[None], HANGING), arm, None)
    pl = plan(Task("reach", target_left[None], HANGING), left, None)
    assert pr.success and pl.success
    np.testing.assert_allclose(pl.world_joints(), pr.world_joints() * [-1, 1, 1], atol=1e-9)
    # the left elbow stays on the left of the body plane
    assert pl.world_joints()[-1, 2, 0] > 0


def test_figure_size_does_not_change_the_plan():
    """A figure 100 times bigger (centimetres) among obstacles 100 times bigger plans the
    same motion: every length setting is in arm lengths."""
    small, big = standard_arm(), standard_arm(scale=100.0, position=(0, 0, 140.0))
    scene_big = {"Crate": [(tuple(np.array(lo) * 100), tuple(np.array(hi) * 100))
                           for lo, hi in WALL["Crate"]]}
    a = plan(Task("reach", BEHIND_WALL[None], HANGING), small, obstacles(WALL))
    b = plan(Task("reach", BEHIND_WALL[None] * 100, HANGING), big, obstacles(scene_big))
    assert a.success and b.success
    assert a.stats.nodes_searched == b.stats.nodes_searched
    assert a.stats.path_length_arm_lengths == pytest.approx(b.stats.path_length_arm_lengths)
    np.testing.assert_allclose(b.world_joints(), a.world_joints() * 100, atol=1e-6)


def test_minimum_jerk_timing_and_phased_chest(arm):
    target = np.array([-0.72, 0.05, 1.35])           # out to the side: the chest turns
    p = plan(Task("reach", target[None], HANGING, duration_s=1.5, fps=30.0), arm, None)
    assert p.success and len(p.poses) == 46
    wrists = p.wrist_trajectory()
    speed = np.linalg.norm(np.diff(wrists, axis=0), axis=1)
    assert speed[0] < 0.2 * speed.max() and speed[-1] < 0.2 * speed.max()
    assert 0.3 * len(speed) < int(np.argmax(speed)) < 0.7 * len(speed)
    body = np.array([q.config.body_rotation for q in p.poses])
    assert body[-1] > 5.0
    # arm first, chest after: a quarter of the way in, the wrist has covered much more of
    # its path than the chest of its turn
    travelled = np.concatenate([[0], np.cumsum(speed)]) / speed.sum()
    q = len(p.poses) // 4
    assert body[q] / body[-1] < 0.5 * travelled[q]
    assert minimum_jerk(0.5) == pytest.approx(0.5) and minimum_jerk(1.0) == 1.0


def test_bad_input_raises_the_core_error(arm):
    with pytest.raises(ReachError, match="not finite"):
        Task("reach", np.array([[np.nan, 0, 1]]), HANGING)
    with pytest.raises(ReachError, match="unknown task"):
        Task("wave", BEHIND_WALL[None], HANGING)
    with pytest.raises(ReachError, match="exactly one target"):
        Task("reach", np.zeros((2, 3)), HANGING)
    with pytest.raises(ReachError, match="not finite"):
        Task("reach", BEHIND_WALL[None], ArmConfig(0, np.inf, 0, 0, 0))
    with pytest.raises(ReachError):
        Settings(step=float("nan"))
    with pytest.raises(ReachError, match="unknown setting"):
        Settings().replace(stepp=0.1)
    with pytest.raises(ReachError, match="below its minimum"):
        Settings(grid_cells=1)


def test_open_and_closed_meshes_inside_test():
    closed = obstacles({"Box": [((0, 0, 0), (1, 1, 1))]})
    assert closed.point_inside((0.5, 0.5, 0.5))
    assert not closed.point_inside((1.5, 0.5, 0.5))
    verts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    plane = Obstacles.from_triangles(verts, [[0, 1, 2], [0, 2, 3]])
    assert not plane.point_inside((0.5, 0.5, 0.5)) and not plane.point_inside((0.5, 0.5, -0.5))
    assert Obstacles(None).point_inside((0, 0, 0)) is False


def test_the_mesh_named_as_enclosing_a_point_is_the_one_that_does():
    """A room round the character and a small box beside its chest: the box is the nearer
    surface, the room the one that encloses the chest (fuzz seed 92 named the box)."""
    obs = obstacles({"Room": [((-3, -3, -1), (3, 3, 3))],
                     "Box": [((0.05, -0.1, 1.3), (0.25, 0.1, 1.5))]})
    chest = (0.0, 0.0, 1.4)
    assert obs.point_inside(chest)
    assert obs.enclosing_owner(chest) == "Room"
    assert obs.enclosing_owner((0.15, 0.0, 1.4)) == "Room"    # inside both: each one's parity
    outside = obstacles({"Box": [((0.05, -0.1, 1.3), (0.25, 0.1, 1.5))]})
    assert outside.enclosing_owner(chest) == "Box"           # none encloses it: the nearest


@pytest.mark.parametrize("size, far", [(0.16, 1.2), (0.02, 30.0), (5.0, 4000.0)])
def test_inside_a_small_box_far_from_the_origin(size, far):
    """A box small against its distance from the origin (a 16 cm crate round a hand a
    metre up): the ray's nudge past each face it crosses must outstep the BVH's 32-bit
    floats there, else the face is counted again and a point inside reads outside (it did,
    for every point of a hand in a crate)."""
    c = np.array([-0.6, -0.15, 1.0]) * far
    box = obstacles({"Crate": [(tuple(c - size / 2), tuple(c + size / 2))]})
    assert box.point_inside(c) and box.point_inside(c + 0.4 * size)
    assert not box.point_inside(c + 0.6 * size)


def test_the_independent_check_sees_a_penetration(arm):
    """The check used above is not vacuous: a pose through a box reads negative."""
    pose = Planner(arm, None).generator.config_pose(ArmConfig(0.0, 0.0, 90.0, 0.0, 0.0))
    joints = arm.to_world_points(pose.joints)
    mid = 0.5 * (joints[2] + joints[3])                   # middle of the forearm
    scene = {"Post": [(tuple(mid - [0.02, 0.02, 0.3]), tuple(mid + [0.02, 0.02, 0.3]))]}
    assert arm_penetration(arm, joints, triangles_of(scene)) < -0.03
    assert Planner(arm, obstacles(scene)).generator.pose_collides(pose)


def test_a_plan_consumed_in_slices_is_the_same_plan(arm):
    """The generator form (modal operator, live mode) yields progress and returns exactly
    the plan of one uninterrupted run."""
    planner = Planner(arm, obstacles(WALL))
    progress, sliced = run_steps(planner.plan_steps(Task("reach", BEHIND_WALL[None], HANGING),
                                                    chunk=5))
    assert len(progress) >= 3
    assert all(0 <= f <= 1 for f, _msg in progress)
    whole = Planner(arm, obstacles(WALL)).plan(Task("reach", BEHIND_WALL[None], HANGING))
    assert np.array_equal(sliced.world_joints(), whole.world_joints())


# --- reasons a user can act on ---------------------------------------------------------------

def shoulder_of(arm):
    return arm.to_world_points(arm.shoulder)


@pytest.mark.parametrize("beyond, reason, words", [
    (0.40, NEEDS_LEAN, "leaning the trunk about"),     # 0.4 arm lengths past the hand
    (1.50, NEEDS_STEP, "a step of"),
])
def test_beyond_the_arm_says_whether_leaning_or_a_step_would_reach(arm, beyond, reason, words):
    forward = np.array([0.0, -1.0, 0.0])                 # the figure faces -Y
    target = shoulder_of(arm) + forward * (1.0 + beyond) * arm.arm_length
    p = plan(Task("reach", target[None], HANGING, names=("Box",)), arm, None)
    assert not p.success and p.reason == reason, p.message
    assert "'Box' is out of reach" in p.message and words in p.message
    if reason == NEEDS_LEAN:
        # the distance missing, in centimetres, from the geometry (the figure is in metres)
        missing_cm = 100 * (nearest_shoulder(arm, target) - arm.arm_length)
        said = float(p.message.split("out of reach by ")[1].split(" cm")[0])
        assert said == pytest.approx(missing_cm, abs=0.5)


def nearest_shoulder(arm, target) -> float:
    """How near the target (world) the shoulder gets as the chest turns it (±60° about the
    spine, the body's up axis through the canonical origin): the distance left."""
    s = np.asarray(arm.shoulder, dtype=float)
    turns = np.radians(np.linspace(-60.0, 60.0, 1201))
    turned = np.stack([s[0] * np.cos(turns) - s[1] * np.sin(turns),
                       s[0] * np.sin(turns) + s[1] * np.cos(turns),
                       np.full_like(turns, s[2])], -1)
    return float(np.linalg.norm(arm.to_world_points(turned) - target, axis=1).min())


def test_a_target_the_turned_trunk_brings_within_reach_is_reached(arm):
    """A quarter arm length past the straight arm's reach, straight ahead: Table 1 leaves
    the chest still there, but turning it brings the shoulder forward enough, so the reach
    arrives with the chest turned (ConfigurationGenerator.target_chest) instead of being
    refused as needs_lean (the cross-check's OMPL found that pose: a false refusal)."""
    target = shoulder_of(arm) + np.array([0.0, -1.0, 0.0]) * 1.25 * arm.arm_length
    p = plan(Task("reach", target[None], HANGING), arm, None)
    assert p.success, p.message
    assert abs(p.poses[-1].config.body_rotation) > 20.0
    assert np.linalg.norm(p.wrist_trajectory()[-1] - target) <= 0.005 * arm.arm_length


def test_a_target_too_high_is_out_of_reach_by_its_height(arm):
    target = shoulder_of(arm) + np.array([0.0, 0.0, 1.5 * arm.arm_length])
    p = plan(Task("reach", target[None], HANGING, names=("Lamp",)), arm, None)
    assert not p.success and p.reason == OUT_OF_REACH
    assert f"{100 * 0.5 * arm.arm_length:.1f} cm" in p.message and "above" in p.message


def test_a_target_too_low_near_the_feet_is_out_of_reach_by_its_height(arm):
    """On the floor half an arm length in front: no step brings it within reach."""
    target = shoulder_of(arm) + arm.arm_length * np.array([0.0, -0.5, -2.4])
    p = plan(Task("reach", target[None], HANGING, names=("Shoe",)), arm, None)
    assert not p.success and p.reason == OUT_OF_REACH, p.message
    assert f"{100 * 1.4 * arm.arm_length:.1f} cm" in p.message and "below" in p.message


def tilted(arm, degrees):
    """``arm`` with its body's up axis leaning forward by ``degrees`` (as a spine bent in
    the rest pose reads), the shoulder where it was."""
    from dataclasses import replace

    t = np.radians(degrees)
    turn = np.eye(4)
    turn[:3, :3] = [[1, 0, 0], [0, np.cos(t), -np.sin(t)], [0, np.sin(t), np.cos(t)]]
    s = shoulder_of(arm)
    about = np.eye(4)
    about[:3, 3] = s
    back = np.eye(4)
    back[:3, 3] = -s
    return replace(arm, to_world=about @ turn @ back @ arm.to_world)


def test_a_far_target_is_a_step_away_whatever_the_body_axis_tilt(arm):
    """88 arm lengths ahead (5 m on a 0.2 m figure), a little below the shoulder: a step
    is what is missing, by the target's distance. The body's up axis leaning 3° forward
    puts the target 4.6 arm lengths "above" along it, which is not a reason."""
    for lean in (0.0, 3.0, -3.0):
        bent = tilted(arm, lean)
        up = bent.to_world[:3, 2]
        assert np.degrees(np.arccos(up @ [0, 0, 1])) == pytest.approx(abs(lean))
        shoulder = shoulder_of(bent)
        target = shoulder + arm.arm_length * np.array([0.0, -88.0, -0.3])
        p = plan(Task("reach", target[None], HANGING, names=("Far",)), bent, None)
        assert not p.success and p.reason == NEEDS_STEP, (lean, p.message)
        assert "above" not in p.message and "below" not in p.message
        beyond = nearest_shoulder(bent, target) - arm.arm_length    # the chest turned
        said = float(p.message.split("a step of at least ")[1].split(" cm")[0])
        assert said == pytest.approx(100 * beyond, abs=0.5), p.message


def cubby(centre, opening, depth, wall=0.02):
    """An open-fronted box (toward +Y, the figure) with a square opening of side
    ``opening``, the front face at ``centre``."""
    x, y, z = centre
    h = opening / 2
    return [((x - h - wall, y - depth - wall, z - h - wall), (x + h + wall, y - depth, z + h + wall)),
            ((x - h - wall, y - depth, z - h - wall), (x - h, y, z + h + wall)),
            ((x + h, y - depth, z - h - wall), (x + h + wall, y, z + h + wall)),
            ((x - h, y - depth, z - h - wall), (x + h, y, z - h)),
            ((x - h, y - depth, z + h), (x + h, y, z + h + wall))]


def test_an_arm_that_does_not_fit_says_by_how_much(arm):
    s = Settings()
    room = arm.forearm_radius + s.clearance * arm.arm_length      # what the forearm needs
    opening = 2 * room - 0.01                                     # 5 mm short each side
    scene = {"Cubby": cubby((-0.25, -0.25, 1.15), opening, 0.40)}
    target = np.array([-0.25, -0.33, 1.15])                       # in free space, 8 cm in
    p = plan(Task("reach", target[None], HANGING, names=("Jar",)), arm, obstacles(scene), s)
    assert not p.success and p.reason == ARM_DOES_NOT_FIT, p.message
    assert "in free space" in p.message and "'Cubby'" in p.message and "'Jar'" in p.message
    lacks = float(p.message.split("lacks ")[1].split(" cm")[0])
    assert lacks >= 0.5 - 0.05            # at least the 5 mm each side a centred arm lacks
    check_plan(p, scene)


def test_the_sampling_fallback_finds_the_way_into_a_cubby(arm):
    # 1.6 times the room the hand and forearm need: the best-first search gives up in the
    # opening; the sampling planner finds the way, clear at every frame and between frames
    s = Settings()
    room = max(arm.forearm_radius, arm.hand_radius) + s.clearance * arm.arm_length
    opening = 2 * room * 1.6
    scene = {"Cubby": cubby((-0.25, -0.25, 1.05 + opening / 2), opening, 0.40)}
    target = np.array([-0.25, -0.33, 1.05 + opening / 2])
    task = Task("reach", target[None], HANGING, names=("Jar",))
    greedy = plan(task, arm, obstacles(scene), s.replace(sampling_fallback=False))
    assert not greedy.success and greedy.reason == NO_PATH
    p = plan(task, arm, obstacles(scene), s)
    assert p.success, p.message
    assert p.segments[0].method == "sampling" and "sampling planner" in p.segments[0].message
    assert p.stats.sampling_states > 0
    assert np.linalg.norm(p.wrist_trajectory()[-1] - target) <= s.goal_tolerance * arm.arm_length
    check_plan(p, scene)
    tris = triangles_of(scene)
    dense = between_frames(p, 4)
    for joints in dense:
        assert arm_penetration(arm, joints, tris) >= 0.0
    again = plan(task, arm, obstacles(scene), s)
    np.testing.assert_array_equal(again.world_joints(), p.world_joints())   # deterministic


def between_frames(p, n):
    """World joints at ``n`` - 1 instants between each pair of frames, the five angles and
    the wrist's two interpolated linearly (as the keys are)."""
    from reach_addon.core.sampling import joints_of
    rows = np.array([np.concatenate([q.config.as_array(), q.hand]) for q in p.poses])
    t = np.arange(1, n) / n
    mids = (rows[:-1, None] * (1 - t)[None, :, None] + rows[1:, None] * t[None, :, None])
    return p.arm.to_world_points(joints_of(p.arm, mids.reshape(-1, 7)))


def _plate_across_the_line(arm, start_config):
    """The bench's plate across the straight line (:func:`reach_addon.samples.plate_across_the_line`):
    (obstacles, triangles, world target)."""
    from reach_addon.samples import plate_across_the_line

    verts, tris, target = plate_across_the_line(arm, start_config)
    return Obstacles.from_triangles(verts, tris), verts[tris], target


def test_a_blocked_straight_line_is_searched_through_the_guiding_nodes(arm):
    """With an obstacle across the straight line, the search goes by the guiding nodes
    (Settings.guide_when_blocked) and tests few positions beyond its path; searched straight
    it fills the space in front of the plate first. A clear line is searched straight."""
    obs, tris, target = _plate_across_the_line(arm, HANGING)
    task = Task("reach", target[None], HANGING)
    guided = plan(task, arm, obs)
    assert guided.success, guided.message
    seg = guided.segments[0]
    assert len(seg.guiding_nodes) > 0 and seg.method == "best-first"
    assert guided.stats.nodes_searched <= 3 * guided.stats.nodes_in_solution
    for joints in guided.world_joints():
        assert arm_penetration(arm, joints, tris) >= 0.0
    straight = plan(task, arm, obs, Settings(guide_when_blocked=False))
    assert straight.stats.nodes_searched > 3 * guided.stats.nodes_searched
    # nothing across the line: no guiding nodes, the paper's straight best-first search
    free_c = arm.shoulder + arm.arm_length * np.array([0.5, 0.1, -0.6])
    planner = Planner(arm, obs)
    assert planner.line_clear(planner.generator.config_pose(HANGING).wrist, free_c)
    clear = planner.plan(Task("reach", arm.to_world_points(free_c)[None], HANGING))
    assert clear.success and len(clear.segments[0].guiding_nodes) == 0


def test_progress_never_falls_back_when_the_search_falls_back(arm):
    """A straight search that stalls at the plate, then the guided one after it (and the
    grid built in between): the positions counted go on from where the first search
    stopped, so a progress bar never runs backwards."""
    obs, _tris, target = _plate_across_the_line(arm, HANGING)
    planner = Planner(arm, obs, Settings(guide_when_blocked=False))
    yielded, result = run_steps(planner.plan_steps(Task("reach", target[None], HANGING), chunk=25))
    progress = [fraction for fraction, _what in yielded]
    assert result.success, result.message
    assert len(result.segments[0].guiding_nodes) > 0, "the guided fallback did not run"
    assert progress == sorted(progress), progress
    assert len(set(progress)) >= 10


def test_a_chase_frame_skips_the_free_search_only_where_it_could_not_be_taken(arm):
    """chase_step runs the search with the hand free only where its result could be kept:
    where it may reach the target (within the frame's steps) or where the kept hand is
    stuck. The premise: a free search of ``steps`` steps never carries the wrist farther
    than a step per move, so a target beyond that is never reached."""
    from reach_addon.core.chase import chase_step, chase_steps_per_frame
    from reach_addon.core.search import BestFirstSearch

    s = Settings()
    planner = Planner(arm, obstacles({"Table": table((-0.3, -0.6), (1.0, 0.5), 0.95)}), s)
    gen = planner.generator
    start = gen.config_pose(HANGING)
    steps = chase_steps_per_frame(s, 24.0)
    far = arm.to_canonical_points(np.array([-0.30, -0.50, 1.30]))
    assert np.linalg.norm(far - start.wrist) > 3 * steps * gen.step_length
    view = gen.for_reach(start, far)
    free = BestFirstSearch(view, start, far, node_budget=s.chase_nodes_per_frame,
                           stall_budget=s.chase_nodes_per_frame, depth_limit=steps,
                           hand_continuity=False)
    free.run()
    result = free.result()
    assert not result.success and len(result.path) == steps + 1
    travel = np.linalg.norm([p.wrist - start.wrist for p in result.path], axis=1)
    assert (travel <= gen.step_length * np.arange(steps + 1) + 1e-12).all()
    # the frame: the kept hand gets nearer (not stuck), so only its search ran
    kept = BestFirstSearch(view, start, far, node_budget=s.chase_nodes_per_frame,
                           stall_budget=s.chase_nodes_per_frame, depth_limit=steps)
    kept.run()
    pose, frame = chase_step(gen, start, far, steps)
    assert frame.nodes_searched == kept.result().nodes_searched
    assert np.linalg.norm(pose.wrist - far) < np.linalg.norm(start.wrist - far) - gen.step_length
    # a target within the frame's steps: the chase catches it
    near = start.wrist + 0.5 * steps * gen.step_length * (far - start.wrist) / \
        np.linalg.norm(far - start.wrist)
    pose, frame = chase_step(gen, start, near, steps)
    assert frame.success and np.linalg.norm(pose.wrist - near) <= s.goal_tolerance * arm.arm_length


def test_a_target_beyond_reach_by_less_than_the_tolerance_is_reached(arm):
    """The search succeeds within ``goal_tolerance`` of the target, so a target a hair
    beyond the turned shoulder's reach, nearer than the tolerance, is reached on the rim
    of its tolerance ball (search.goal_ball), not refused as needs_lean (fuzz seed 5310:
    0.001 arm lengths short, a false refusal the cross-check's OMPL found)."""
    s = Settings(chest_rotation=False)
    forward = np.array([0.0, -1.0, 0.0])
    out = 0.4 * s.goal_tolerance * arm.arm_length
    target = shoulder_of(arm) + forward * (arm.arm_length + out)
    p = plan(Task("reach", target[None], HANGING), arm, None, s)
    assert p.success, p.message
    assert np.linalg.norm(p.wrist_trajectory()[-1] - target) <= s.goal_tolerance * arm.arm_length
    beyond = shoulder_of(arm) + forward * (arm.arm_length + 3.0 * s.goal_tolerance * arm.arm_length)
    p = plan(Task("reach", beyond[None], HANGING, names=("Cup",)), arm, None, s)
    assert not p.success and p.reason == NEEDS_LEAN, p.message


def test_the_ball_leads_toward_the_shoulder():
    from reach_addon.core.search import GOAL_BALL, goal_ball

    s = Settings()
    target, shoulder = np.array([1.0, 0.0, 0.0]), np.zeros(3)
    ball = goal_ball(target, s, 2.0, (shoulder,))
    r = GOAL_BALL * s.goal_tolerance * 2.0
    assert len(ball) == 1 + s.directions
    assert np.allclose(ball[0], [1.0 - r, 0.0, 0.0])
    assert np.allclose(np.linalg.norm(ball - target, axis=1), r)


@pytest.mark.parametrize("turn", [-60.0, 60.0])
def test_a_target_a_hair_beyond_the_turned_shoulder_is_reached(arm, turn):
    """Fuzz seed 7408: a target beyond the arm from the resting shoulder by over 0.1 arm
    lengths, and from the shoulder as the trunk's turn to the end of its range carries it
    by 0.88 of the goal tolerance: the tolerance ball's rim (at 0.9 of it) is tried toward
    that turned shoulder (search.nearest_shoulder), so the target is reached with the
    trunk turned, not refused as needs_lean (the cross-check's OMPL found the pose: a
    false refusal). Toward the resting shoulder, 19° off, the rim falls short (the 60°
    case fails without the turned shoulder's direction)."""
    from reach_addon.core.diagnosis import diagnose_target
    from reach_addon.core.torso import rotate_about_spine

    s = Settings()
    turned = rotate_about_spine(np.asarray(arm.shoulder, dtype=float), turn)
    out = np.array([turned[0], turned[1], 0.0])
    out /= np.linalg.norm(out)
    target_c = turned + out * (arm.arm_length + 0.88 * s.goal_tolerance * arm.arm_length)
    assert np.linalg.norm(target_c - arm.shoulder) > 1.1 * arm.arm_length
    planner = Planner(arm, None, s)
    assert diagnose_target(planner.generator, target_c) is None
    target = arm.to_world_points(target_c)
    p = planner.plan(Task("reach", target[None], HANGING))
    assert p.success, p.message
    assert np.linalg.norm(p.wrist_trajectory()[-1] - target) <= s.goal_tolerance * arm.arm_length
