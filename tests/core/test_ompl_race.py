"""The OMPL race harness (verification/race.py) measures what it claims to, on real data.

Its kinematics must be the core's, its validity test the core's acceptance, and its
independent collision check (exact segment–triangle distances, verification/clearance.py)
must agree with the sampled point-to-triangle check (points along each segment, a second
method) and find real contacts. The race itself
runs on the demo workplace when OMPL is installed (``requirements-bench.txt``). No timing
is asserted.
"""

import math

import numpy as np
import pytest

from geometry import HANGING

from reach_addon.core import Planner, Settings, body_capsules, ik
from reach_addon.core.arm import ArmConfig, pose_from_config
from reach_addon.core.sampling import joints_of, joints_of_one, pose_row
from reach_addon.demo import WORKPLACE, demo_tasks
from reach_addon.samples import obstacles, standard_arm
from verification import race as race_mod
from verification.clearance import arm_penetration, independent_check, segment_clearance
from verification.geometry import point_triangle_distance, segment_triangle_distance
from verification.race import JointSpace, Validity, densify, race_targets, workplace_triangles


@pytest.fixture(scope="module")
def planner():
    return Planner(standard_arm(), obstacles(WORKPLACE), Settings())


@pytest.fixture(scope="module")
def space(planner):
    return JointSpace(planner.arm, planner.settings)


def random_configs(space, n, seed=1):
    rng = np.random.default_rng(seed)
    return space.lo + rng.random((n, 7)) * (space.hi - space.lo)


def test_kinematics_are_the_cores(planner, space):
    """Both forward kinematics of the harness reproduce the core's poses, hand included."""
    arm = planner.arm
    q = random_configs(space, 300)
    fast = joints_of(arm, q)
    for row, joints in zip(q, fast):
        core = pose_from_config(arm, ArmConfig.from_array(row[:5]), hand=(row[5], row[6]))
        np.testing.assert_allclose(joints, core.joints, atol=1e-12)
        np.testing.assert_allclose(np.array(joints_of_one(arm, row)), core.joints, atol=1e-12)


def test_lever_metric_bounds_wrist_travel(planner, space):
    """OMPL's distance is built to approximate wrist travel: for small moves from random
    configurations the wrist never moves more than the lever-weighted joint change (sum of
    |lever · Δangle|), which the metric's per-joint scale encodes."""
    arm = planner.arm
    rng = np.random.default_rng(2)
    q = random_configs(space, 200)
    dq = rng.normal(size=q.shape) * 0.5
    w0, w1 = joints_of(arm, q)[:, 3], joints_of(arm, q + dq)[:, 3]
    travel = np.linalg.norm(w1 - w0, axis=1) / arm.arm_length
    bound = np.abs(dq * space.scale).sum(axis=1)
    assert (travel <= bound * 1.01 + 1e-9).all()


def test_validity_is_the_cores_acceptance(planner, space):
    """A configuration is valid exactly when it is inside the limits, on the required elbow
    side, clear of the body as the generator tests it and clear of the obstacles by the
    core's checker."""
    arm, st = planner.arm, planner.settings
    validity = Validity(planner, space)
    checker = planner.generator.checker
    q = random_configs(space, 400, seed=3)
    seen = {True: 0, False: 0}
    for row in q:
        joints = joints_of(arm, row)[0]
        legal = math.hypot(row[1], row[2]) <= st.elevation_max
        # Algorithm 1: the elbow on the side of n = (s - w) × (a - s), or P degenerate
        n = np.cross(joints[1] - joints[3], arm.waist - joints[1])
        legal &= bool((joints[2] - joints[1]) @ n > 0 or np.linalg.norm(n) < 1e-9)
        body_clear = not body_capsules.self_collision(arm, float(row[0]), joints[None], include_hand=True)[0]
        clear = not checker.collides(arm.to_world_points(joints), include_hand=True)
        expected = bool(legal and body_clear and clear)
        assert validity.valid(list(row)) == expected, row
        seen[expected] += 1
    assert seen[True] > 20 and seen[False] > 20, seen


def test_start_and_goal_poses_are_valid(planner, space):
    """The race's start pose and the generator's goal pose for every demo target are valid
    states for OMPL."""
    validity = Validity(planner, space)
    gen = planner.generator
    assert validity.valid(list(pose_row(gen.config_pose(HANGING))))
    for _name, task in demo_tasks():
        for target in race_targets(task)[0]:
            goal = gen.solve(planner.arm.to_canonical_points(target))
            assert goal is not None
            assert validity.valid(list(pose_row(goal)))
    # Every legal pose with the wrist inside the crate: not valid.
    arm = planner.arm
    inside = arm.to_canonical_points(np.array([-0.25, -0.34, 1.0]))
    sol = ik.solve(arm, inside[None], planner.settings)
    legal = np.flatnonzero(sol.legal[0])
    assert legal.size > 0
    for k in legal.tolist():
        row = list(sol.config(0, k).as_array()) + [0.0, 0.0]
        assert not validity.valid(row)


def _pairs(p, q, tris):
    return segment_triangle_distance(p, q, tris[:, 0], tris[:, 1], tris[:, 2])


def test_segment_triangle_distance_matches_sampled_check():
    """Exact segment–triangle distances agree with dense point sampling
    (``clearance.segment_clearance``) to within half the sample spacing, and a segment
    through a triangle is at distance 0."""
    rng = np.random.default_rng(4)
    tris = rng.normal(size=(60, 3, 3))
    p = rng.normal(size=(60, 3)) * 1.5
    q = p + rng.normal(size=(60, 3))
    exact = _pairs(p, q, tris)
    for k in range(60):
        sampled = segment_clearance(p[k], q[k], tris[k:k + 1], spacing=0.001)
        assert exact[k] <= sampled + 1e-9
        assert sampled - exact[k] <= 0.0005 + 1e-9
    tri = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])
    through = _pairs(np.array([[0.2, 0.2, -1.0]]), np.array([[0.2, 0.2, 1.0]]), tri)
    assert through[0] == 0.0
    beside = _pairs(np.array([[2.0, 0.0, -1.0]]), np.array([[2.0, 0.0, 1.0]]), tri)
    assert beside[0] == pytest.approx(1.0)
    corner = point_triangle_distance(np.array([[2.0, 0.0, 0.0]]), *tri[0])[0]
    assert corner == pytest.approx(1.0)


def test_independent_check_finds_a_hand_swept_through_an_obstacle(planner, space):
    """The wrist in front of the shelf, the hand bent fully one way and then the other
    (turned sideways 25°): both ends are clear by the core's checker, the neutral hand in
    between is not. The check finds the sweep's contacts, for the hand alone, in agreement
    with the sampled check (``clearance.arm_penetration``)."""
    arm, gen = planner.arm, planner.generator
    tris = workplace_triangles()
    base = pose_row(gen.solve(arm.to_canonical_points(np.array([-0.30, -0.45, 1.30]))))
    ends = []
    for bend in (-70.0, 0.0, 70.0):
        row = base.copy()
        row[5], row[6] = bend, 25.0
        ends.append(row)
    touches = [checker_hits(planner, joints_of(arm, row)[0]) for row in ends]
    assert touches == [False, True, False], "the scene must set the test up"
    dense = densify(space, np.array([ends[0], ends[2]]), 0.002 * arm.arm_length)
    world = arm.to_world_points(joints_of(arm, dense))
    hits, arm_hits, least = independent_check(arm, world, tris, True, 0.05)
    assert hits > 0 and arm_hits == 0 and least < 0
    for w in world[::10]:
        depth = arm_penetration(arm, w, tris)   # sampled every 2 mm along each segment
        if abs(depth) > 0.001:
            assert (independent_check(arm, w[None], tris, True, 0.05)[0] == 1) == (depth < 0)
    assert independent_check(arm, world[:1], tris, True, 0.05)[0] == 0
    assert independent_check(arm, world, tris, False, 0.05)[0] == 0


def checker_hits(planner, joints):
    return planner.generator.checker.collides(planner.arm.to_world_points(joints))


def test_densify_keeps_ends_and_spacing(planner, space):
    q = random_configs(space, 5, seed=5)
    spacing = 0.002 * planner.arm.arm_length
    dense = densify(space, q, spacing)
    np.testing.assert_array_equal(dense[0], q[0])
    np.testing.assert_array_equal(dense[-1], q[-1])
    # no joint (elbow, wrist, the hand's far end) moves farther than the spacing
    joints = joints_of(planner.arm, dense)[:, 2:5]
    assert np.linalg.norm(np.diff(joints, axis=0), axis=2).max() <= spacing * (1 + 1e-9)
    # a hand turning about a still wrist is sampled as densely as a moving wrist
    turn = np.array([q[0], q[0] + np.r_[0, 0, 0, 0, 0, 60.0, 0]])
    hand = joints_of(planner.arm, densify(space, turn, spacing))[:, 4]
    assert len(hand) > 10
    assert np.linalg.norm(np.diff(hand, axis=0), axis=1).max() <= spacing * (1 + 1e-9)


def test_chase_is_raced_through_evenly_spaced_frames():
    chase = dict(demo_tasks())["chase"]
    targets, note = race_targets(chase, 4)
    np.testing.assert_array_equal(targets, chase.targets[[0, 24, 48, 71]])
    assert "4 legs" in note
    reach = dict(demo_tasks())["collision_free"]
    assert race_targets(reach)[0] is reach.targets and race_targets(reach)[1] == ""


def test_race_on_the_demo_reach():
    """One race, held to one rule for both: each path succeeds and passes the independent
    check with arm and hand (no densely interpolated pose touching), numbers are plain, the
    ratios are given because both passed, Reach's time holds its grid where it built one,
    OMPL's goal is a region of the same IK's poses, and the same seed gives the same race.
    OMPL is part of the test environment (requirements-dev.txt): a missing OMPL fails."""
    import ompl  # noqa: F401

    task = dict(demo_tasks())["collision_free"]

    def fresh():
        return Planner(standard_arm(), obstacles(WORKPLACE), Settings())

    first = race_mod.race("collision_free", fresh(), task, seed=3, time_limit_s=30.0,
                          count_queries=True)
    assert set(race_mod.KEYS) <= set(first)
    for key in race_mod.KEYS:
        assert type(first[key]) in (str, float, int, bool), key
    for side in ("reach", "ompl"):
        assert first[f"{side}_success"] and first[f"{side}_passed"], side
        assert first[f"{side}_collisions"] == 0 and first[f"{side}_min_clearance"] > 0, side
        assert first[f"{side}_obstacle_queries"] > 0, side
    # Both wrists travel at least the straight distance from start to target.
    planner = fresh()
    arm = planner.arm
    start = arm.to_world_points(planner.generator.config_pose(task.start).wrist)
    straight = np.linalg.norm(task.targets[0] - start) / arm.arm_length
    assert first["reach_path_length"] >= straight - 0.01
    assert first["ompl_path_length"] >= straight - 0.01
    assert 0.0 <= first["reach_mean_f_r"] <= 2.0 and 0.0 <= first["ompl_mean_f_r"] <= 2.0
    assert first["time_ratio"] == pytest.approx(first["ompl_time_s"] / first["reach_time_s"])
    # the goal region: more than the one pose, all with the wrist on the target
    space = JointSpace(planner.arm, planner.settings)
    target_c = arm.to_canonical_points(task.targets[0])
    goals = race_mod.goal_rows(planner, Validity(planner, space), target_c)
    assert 1 < len(goals) <= race_mod.GOAL_STATES
    for row in goals:
        assert np.linalg.norm(joints_of_one(arm, list(row))[3] - target_c) < 1e-6 * arm.arm_length
    again = race_mod.race("collision_free", fresh(), task, seed=3, time_limit_s=30.0,
                          count_queries=True)
    for key in ("ompl_path_length", "ompl_mean_f_r", "ompl_validity_checks",
                "reach_path_length", "reach_collisions", "ompl_min_clearance",
                "reach_obstacle_queries", "ompl_obstacle_queries"):
        assert again[key] == first[key], key
    # the guided reach builds the grid inside Reach's plan: its time holds it
    guided = race_mod.race("guided", fresh(), dict(demo_tasks())["guided"], seed=3,
                           time_limit_s=30.0)
    assert 0 < guided["reach_preprocess_time_s"] < guided["reach_time_s"]


def test_race_refuses_foreign_obstacles_without_their_triangles():
    arm = standard_arm()
    other = Planner(arm, obstacles({"Crate": WORKPLACE["Crate"]}), Settings())
    with pytest.raises(ValueError, match="triangles"):
        race_mod.race("collision_free", other, dict(demo_tasks())["collision_free"])
