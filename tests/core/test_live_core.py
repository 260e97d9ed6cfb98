"""Live sessions and the moving-obstacle chase, on the sample workplace (real triangle meshes
behind a real mathutils BVH), every shown pose checked by the independent geometry of
``tests/geometry.py``."""

import math

import numpy as np
import pytest

from geometry import HANGING, arm_penetration, obstacles, run_steps, standard_arm, triangles_of
from reach_addon.core import (NEEDS_STEP, NO_PATH, START_IN_COLLISION, TARGET_IN_OBSTACLE,
                              Planner, ReachError, Settings, Task)
from reach_addon.core.live import CLOSEST, REACHED, LiveSession
from reach_addon.core.steps import drain
from reach_addon.core.chase import chase_steps
from reach_addon.core.workspace import build_workspace, workspace_steps
from reach_addon.demo import WORKPLACE

WALL = {"Crate": [((-0.60, -0.36, 0.70), (0.00, -0.30, 1.08))]}
BEHIND_WALL = np.array([-0.28, -0.46, 1.14])


@pytest.fixture(scope="module")
def arm():
    return standard_arm()


# --- independent checks ------------------------------------------------------------------------

def angle_deg(a, b):
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    return math.degrees(math.acos(float(np.clip(a @ b, -1.0, 1.0))))


def flexion_deg(j):
    return angle_deg(j[2] - j[1], j[3] - j[2])


def check_jump(arm, settings, a, b):
    """Between two shown poses (world joints (5, 3)), no joint moves more than the
    smoothness bound allows for the wrist's travel: elbow flexion by at most B, the upper
    arm's direction by at most (1 + √2) B (each shoulder angle and the chest by B), with
    B = max_joint_step × max(1, travel / step)."""
    step = settings.step * arm.arm_length
    bound = settings.max_joint_step * max(1.0, float(np.linalg.norm(b[3] - a[3])) / step)
    assert abs(flexion_deg(b) - flexion_deg(a)) <= bound + 1e-6
    assert angle_deg(a[2] - a[1], b[2] - b[1]) <= (1 + math.sqrt(2)) * bound + 1e-6


def shown_world(session, poses):
    return [session.arm.to_world_points(p.joints) for p in poses]


def follow(session, targets, tris=None):
    """Move the target through ``targets``; after each, run the session to rest. Returns
    the world joints of every pose shown, in order, with the index of the target."""
    shown = [(None, session.arm.to_world_points(session.pose.joints))]
    for k, t in enumerate(targets):
        session.set_target(t)
        for j in shown_world(session, session.run()):
            shown.append((k, j))
            if tris is not None:
                assert arm_penetration(session.arm, j, tris) >= 0.0, f"target {k}"
    return shown


# --- live sessions ---------------------------------------------------------------------------

def test_the_arm_follows_a_moving_target_without_collisions_or_jumps(arm):
    s = Settings()
    session = LiveSession(arm, obstacles(WALL), s, HANGING, "cup")
    tris = triangles_of(WALL)
    # behind the crate, then sliding along it and up, as a user drags the target
    path = [BEHIND_WALL + np.array([0.02 * k, 0.0, 0.01 * k]) for k in range(8)]
    shown = follow(session, path, tris)
    assert len(shown) > len(path)
    for (_ka, a), (_kb, b) in zip(shown, shown[1:]):
        check_jump(arm, s, a, b)
    # each target reached when the session came to rest
    for k, t in enumerate(path):
        last = [j for kk, j in shown if kk == k][-1]
        assert np.linalg.norm(last[3] - t) <= s.goal_tolerance * arm.arm_length + 1e-9
    assert session.status.state == REACHED and session.status.reason is None


def test_small_moves_start_from_the_previous_plan(arm):
    session = LiveSession(arm, obstacles(WALL), Settings(), HANGING, "cup")
    session.set_target(BEHIND_WALL)
    session.run()
    first = session.status.nodes_searched
    planner = session.planner
    session.set_target(BEHIND_WALL + np.array([0.01, 0.0, 0.005]))
    session.run()
    assert session.status.state == REACHED
    assert session.planner is planner, "the planner (BVH, generator, grid) is kept"
    assert session.status.nodes_searched <= 3 < first
    # a target that did not move starts nothing
    assert not session.set_target(session.target.copy())
    assert not session.busy


def test_time_slices_give_the_same_poses_as_one_run(arm):
    targets = [BEHIND_WALL, BEHIND_WALL + np.array([0.05, 0.02, 0.04])]
    whole = LiveSession(arm, obstacles(WALL), Settings(), HANGING)
    sliced = LiveSession(arm, obstacles(WALL), Settings(), HANGING)
    a = [j for _k, j in follow(whole, targets)]
    b = [sliced.arm.to_world_points(sliced.pose.joints)]
    calls = 0
    for t in targets:
        sliced.set_target(t)
        while sliced.busy:
            calls += 1
            if sliced.advance(1e-5):
                b.append(sliced.arm.to_world_points(sliced.pose.joints))
    assert calls > len(b), "a tiny budget spreads the search over many updates"
    assert len(a) == len(b)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_a_new_target_abandons_the_search_under_way(arm):
    session = LiveSession(arm, obstacles(WALL), Settings(), HANGING)
    session.set_target(BEHIND_WALL)
    session.advance(1e-5)
    assert session.busy
    other = np.array([-0.30, -0.22, 1.15])     # between the body and the crate
    session.set_target(other)
    session.run()
    wrist = arm.to_world_points(session.pose.wrist)
    assert session.status.reason is None, session.status.message
    assert np.linalg.norm(wrist - other) <= Settings().goal_tolerance * arm.arm_length + 1e-9


def test_a_fast_drag_keeps_the_progress_made(arm):
    s = Settings()
    session = LiveSession(arm, obstacles(WALL), s, HANGING)
    assert session.planner.workspace is not None  # built by an earlier re-plan: the slices search
    start = arm.to_world_points(session.pose.joints)
    session.set_target(BEHIND_WALL)
    for _ in range(10):
        assert not session.advance(1e-5)
    assert session.busy, "round the crate takes more than 20 nodes"
    # the target moves on before the search is done: the arm takes what was found so far
    session.set_target(BEHIND_WALL + np.array([0.01, 0.0, 0.0]))
    assert session.advance(1e-5)
    now = arm.to_world_points(session.pose.joints)
    check_jump(arm, s, start, now)
    assert np.linalg.norm(now[3] - BEHIND_WALL) < np.linalg.norm(start[3] - BEHIND_WALL)
    assert arm_penetration(arm, now, triangles_of(WALL)) >= 0
    shown = follow(session, [BEHIND_WALL + np.array([0.01, 0.0, 0.0])], triangles_of(WALL))
    assert session.status.state == REACHED
    for (_a, a), (_b, b) in zip(shown, shown[1:]):
        check_jump(arm, s, a, b)


def test_out_of_reach_gets_the_closest_approach_and_says_why(arm):
    s = Settings()
    session = LiveSession(arm, obstacles(WALL), s, HANGING, "far cup")
    shoulder = arm.to_world_points(arm.shoulder)
    far = shoulder + np.array([0.0, -2.0 * arm.arm_length, 0.0])
    start = arm.to_world_points(session.pose.wrist)
    shown = follow(session, [far], triangles_of(WALL))
    st = session.status
    assert st.state == CLOSEST and st.reason == NEEDS_STEP
    assert "far cup" in st.message and "out of reach" in st.message and "step" in st.message
    wrist = shown[-1][1][3]
    # as close as it legally can: the arm nearly straight toward the target
    assert np.linalg.norm(wrist - far) < np.linalg.norm(start - far) - 0.5 * arm.arm_length
    assert flexion_deg(shown[-1][1]) <= 45.0
    assert st.distance == pytest.approx(np.linalg.norm(wrist - far) / arm.arm_length)
    # Lean is on by default: a Bake would step; Live says it poses the arm alone
    assert "Live poses the arm alone" in st.message
    off = LiveSession(arm, obstacles(WALL), s.replace(lean=False), HANGING, "far cup")
    follow(off, [far], triangles_of(WALL))
    assert off.status.reason == NEEDS_STEP and "Live poses" not in off.status.message


def test_a_target_inside_an_obstacle_is_named(arm):
    session = LiveSession(arm, obstacles(WALL), Settings(), HANGING, "buried")
    inside = np.array([-0.30, -0.33, 0.95])
    follow(session, [inside], triangles_of(WALL))
    assert session.status.reason == TARGET_IN_OBSTACLE
    assert "Crate" in session.status.message and "buried" in session.status.message


def test_an_obstacle_moved_onto_the_arm_is_reported_and_the_arm_never_jumps(arm):
    s = Settings()
    session = LiveSession(arm, None, s, HANGING, "cup")
    target = np.array([-0.30, -0.45, 1.10])
    follow(session, [target])
    planner = session.planner
    assert not session.set_obstacles(session.obstacles), "same obstacles: nothing to do"
    assert session.planner is planner
    # a board pushed through the forearm: no clear pose within the smoothness bound
    j = arm.to_world_points(session.pose.joints)
    mid = 0.5 * (j[2] + j[3])
    half = np.array([0.1, 0.1, 0.012])
    board = {"Board": [(tuple(mid - half), tuple(mid + half))]}
    assert arm_penetration(arm, j, triangles_of(board)) < 0, "the board cuts the forearm"
    assert session.set_obstacles(obstacles(board))
    assert session.planner is not planner and session.busy
    assert session.run() == [], "the arm stays where it is rather than jump"
    assert session.status.reason == START_IN_COLLISION
    assert "'Board'" in session.status.message
    # the board lifted away and the target moved: the arm goes on, clear of it
    lifted = {"Board": [(tuple(mid - half + [0, 0, 0.3]), tuple(mid + half + [0, 0, 0.3]))]}
    session.set_obstacles(obstacles(lifted))
    shown = follow(session, [target + np.array([0.03, 0.0, 0.05])], triangles_of(lifted))
    assert len(shown) > 1 and session.status.state == REACHED


def test_an_obstacle_grazing_the_arm_is_cleared_by_turning_the_elbow(arm):
    s = Settings()
    session = LiveSession(arm, None, s, HANGING, "cup")
    target = np.array([-0.30, -0.45, 1.10])
    follow(session, [target])
    before = arm.to_world_points(session.pose.joints)
    # a small block inside the clearance margin beside the forearm, near the elbow
    side = np.array([-0.95, -0.312, 0.01]) / np.linalg.norm([-0.95, -0.312, 0.01])
    c = before[2] + 0.2 * (before[3] - before[2]) + 0.055 * side
    block = {"Block": [(tuple(c - 0.01), tuple(c + 0.01))]}
    session.set_obstacles(obstacles(block))
    assert session.planner.generator.start_problem(session.pose) is not None
    shown = shown_world(session, session.run())
    assert len(shown) == 1
    check_jump(arm, s, before, shown[0])
    assert arm_penetration(arm, shown[0], triangles_of(block)) >= 0
    assert np.linalg.norm(shown[0][3] - target) <= s.goal_tolerance * arm.arm_length + 1e-9
    assert session.status.state == REACHED and session.status.reason is None


def test_bad_input_names_the_target(arm):
    session = LiveSession(arm, None, Settings(), HANGING, "cup")
    with pytest.raises(ReachError, match="cup"):
        session.set_target([0.0, float("nan"), 1.0])


# --- the workspace grid in slices ----------------------------------------------------------

@pytest.mark.parametrize("scene", [WORKPLACE, WALL, {}])
def test_the_sliced_workspace_is_the_workspace(arm, scene):
    planner = Planner(arm, obstacles(scene) if scene else None, Settings())
    whole = build_workspace(planner.generator)
    yielded, sliced = run_steps(workspace_steps(planner.generator))
    assert len(yielded) > 20
    np.testing.assert_array_equal(sliced.occupied, whole.occupied)
    np.testing.assert_array_equal(sliced.valid, whole.valid)
    np.testing.assert_array_equal(sliced.lower, whole.lower)
    assert sliced.valid.any() and (not scene or sliced.occupied.any())


def test_the_guided_fallback_builds_the_grid_in_slices(arm):
    # ten nodes cannot take the wrist round the crate (more than 40 steps): the straight
    # search fails, so the guided one runs, on a grid built over many updates
    s = Settings(node_budget=10, stall_budget=10, sampling_fallback=False)
    session = LiveSession(arm, obstacles(WALL), s, HANGING, "cup")
    session.set_target(BEHIND_WALL)
    ticks = 0
    while session.busy:
        session.advance(0.005)
        ticks += 1
    assert session.planner.has_workspace
    assert ticks > 10
    np.testing.assert_array_equal(session.planner.workspace.valid,
                                  build_workspace(session.planner.generator).valid)
    ref = Planner(arm, obstacles(WALL), s).plan(Task("reach", BEHIND_WALL[None], HANGING))
    assert not ref.success and session.status.reason == ref.reason == NO_PATH
    assert "cup" in session.status.message
    assert session.status.state == CLOSEST


def test_live_mode_falls_back_on_the_sampling_planner_as_the_reach_task_does(arm):
    s = Settings(node_budget=10, stall_budget=10)
    session = LiveSession(arm, obstacles(WALL), s, HANGING, "cup")
    shown = follow(session, [BEHIND_WALL], triangles_of(WALL))
    ref = Planner(arm, obstacles(WALL), s).plan(Task("reach", BEHIND_WALL[None], HANGING))
    assert ref.success and ref.segments[0].method == "sampling"
    assert session.status.state == REACHED, session.status.message
    assert np.linalg.norm(shown[-1][1][3] - BEHIND_WALL) <= s.goal_tolerance * arm.arm_length


# --- chase with obstacles per frame ----------------------------------------------------------

def sweep_task():
    t = np.linspace(0.0, 1.0, 60)
    targets = np.stack([-0.45 + 0.35 * t, -0.40 + 0.0 * t, 1.15 + 0.1 * np.sin(np.pi * t)], 1)
    return Task("chase", targets, HANGING, 24.0, names=("ball",))


def box_scenes(centre, half, arrives):
    """{name: boxes} per frame: a box far above until frame ``arrives``, then at ``centre``."""
    out = []
    for f in range(60):
        c = centre + (np.array([0.0, 0.0, 1.0]) if f < arrives else 0.0)
        out.append({"Slab": [(tuple(c - half), tuple(c + half))]})
    return out


def planners_for(arm, scenes):
    out = []
    for f, scene in enumerate(scenes):
        out.append(out[-1] if f and scene == scenes[f - 1] else Planner(arm, obstacles(scene)))
    return out


def test_chase_avoids_an_obstacle_that_moves_in(arm):
    task = sweep_task()
    free = Planner(arm, None).plan(task)
    joints = free.world_joints()
    # a box that arrives at frame 30 just under where the free chase has its elbow at 45
    scenes = box_scenes(joints[45, 2] + [0.0, 0.0, -0.05], np.full(3, 0.04), 30)
    assert min(arm_penetration(arm, joints[f], triangles_of(scenes[f])) for f in range(60)) < 0, \
        "without re-sampling, the chase runs into the box"
    p = drain(chase_steps(planners_for(arm, scenes), task))
    assert p.success, p.message
    moving = p.world_joints()
    for f in range(60):
        assert arm_penetration(arm, moving[f], triangles_of(scenes[f])) >= 0, f"frame {f}"
    assert np.linalg.norm(moving[-1, 3] - task.targets[-1]) <= Settings().goal_tolerance * arm.arm_length


def test_an_obstacle_that_lands_on_the_arm_fails_the_chase_by_name(arm):
    task = sweep_task()
    joints = Planner(arm, None).plan(task).world_joints()
    scenes = box_scenes(joints[30, 1] + 0.6 * (joints[30, 2] - joints[30, 1]), np.full(3, 0.04), 30)
    p = drain(chase_steps(planners_for(arm, scenes), task))
    assert not p.success and p.reason == START_IN_COLLISION
    assert "'Slab'" in p.message and "frame 30" in p.message
