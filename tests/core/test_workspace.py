"""The workspace grid: occupancy, inside regions, valid guiding nodes, shortest paths."""

import numpy as np

from geometry import obstacles, standard_arm
from reach_addon.core import Planner, Settings
from reach_addon.core.workspace import workspace_box


def cell_of(ws, p):
    return tuple(np.floor((p - ws.lower) / ws.cell).astype(int))


def test_grid_has_eleven_cells_a_side_and_covers_every_reach():
    arm = standard_arm()
    ws = Planner(arm, None).workspace
    assert ws.valid.shape == (11, 11, 11) and not ws.occupied.any()
    lower, cell = workspace_box(arm, Settings())
    upper = lower + 11 * cell
    reach = np.hypot(*arm.shoulder[:2]) + arm.arm_length
    assert np.allclose(-lower[:2], reach) and np.allclose(upper[:2], reach)
    # cells far outside the reach are not guiding nodes, cells in front of the shoulder are
    assert not ws.valid[0, 0, 0]
    front = arm.shoulder + [0.0, 0.6 * arm.arm_length, 0.0]
    assert ws.valid[cell_of(ws, front)]
    assert Planner(arm, None, Settings(grid_cells=7)).workspace.valid.shape == (7, 7, 7)


def test_occupancy_marks_surfaces_and_the_inside_of_closed_obstacles():
    arm = standard_arm()
    # a big closed block in front of the figure, in world space
    block = {"Block": [((-0.6, -0.9, 0.9), (0.2, -0.35, 1.6))]}
    ws = Planner(arm, obstacles(block)).workspace
    centre_world = np.array([-0.2, -0.625, 1.25])
    centre = arm.to_canonical_points(centre_world)
    idx = cell_of(ws, centre)
    assert ws.occupied[idx] and not ws.valid[idx]
    # the block's middle is more than a half-diagonal from every face: marked by the
    # inside test, not by surface proximity
    half_diagonal = 0.5 * np.linalg.norm(ws.cell)
    assert Planner(arm, obstacles(block)).obstacles.distance(centre_world, 1.0) > half_diagonal
    # a free cell beside the body stays free
    side = arm.shoulder + [0.5 * arm.arm_length, -0.2 * arm.arm_length, 0.0]
    assert not ws.occupied[cell_of(ws, side)]


def test_shortest_path_goes_round_an_obstacle_through_valid_cells():
    arm = standard_arm()
    wall = {"Wall": [((-0.9, -0.30, 1.0), (0.3, -0.26, 1.45))]}
    planner = Planner(arm, obstacles(wall))
    ws = planner.workspace
    start = arm.to_canonical_points(np.array([-0.35, -0.06, 1.2]))
    goal = arm.to_canonical_points(np.array([-0.35, -0.48, 1.25]))
    a, b = ws.nearest_valid(start), ws.nearest_valid(goal)
    path = ws.shortest_path(a, b)
    assert path[0] == a and path[-1] == b and len(path) > 2
    for p, q in zip(path, path[1:]):
        assert max(abs(np.subtract(p, q))) == 1            # 26-connected steps
        assert ws.valid[q]
    guides = ws.guiding_nodes(start, goal)
    assert len(guides) == len(path) - 2
    # the guides climb over the wall (higher than both ends) or go round its side
    world = arm.to_world_points(guides)
    assert world[:, 2].max() > 1.45 or world[:, 0].min() < -0.9 or world[:, 0].max() > 0.3


def _grid_by_definition(planner, ws):
    """The grid of the module doc on ``ws``'s cells, cell by cell with nothing skipped: a
    cell is occupied when a surface comes within its circumscribed sphere or its centre is
    inside an obstacle; a free cell is valid when one of its best ``max_pose_tries`` legal
    candidates clears the body and the obstacles."""
    from reach_addon.core import ik
    from reach_addon.core.body_capsules import self_collision

    gen, arm, settings = planner.generator, planner.arm, planner.settings
    n = ws.n
    centers = ws.centers().reshape(-1, 3)
    world = arm.to_world_points(centers)
    bound = 0.5 * float(np.linalg.norm(ws.cell)) + gen.checker.margin
    obstacles = planner.obstacles
    occupied = np.array([
        obstacles is not None and not obstacles.empty
        and (obstacles.tree.find_nearest(p.tolist(), bound)[0] is not None
             or obstacles.point_inside(p)) for p in world])
    valid = np.zeros(n ** 3, dtype=bool)
    free = np.flatnonzero(~occupied)
    sol = ik.solve(arm, centers[free], settings)
    for row, flat in enumerate(free):
        order = sol.order(row, settings.elbow_side)[: settings.max_pose_tries]
        if order.size == 0:
            continue
        joints = sol.joints(row, order)
        body = self_collision(arm, float(sol.body[row]), joints, include_hand=False)
        valid[flat] = any(not gen.checker.collides(arm.to_world_points(j), include_hand=False)
                          for j in joints[~body])
    return occupied.reshape(n, n, n), valid.reshape(n, n, n)


def test_grid_is_its_definition_however_it_is_sped_up():
    """The build skips work (cells out of reach, wrists inside the body, candidates after
    the first clear one, regions labelled in bulk): none of it may change a cell."""
    from reach_addon.core.steps import drain
    from reach_addon.core.workspace import workspace_steps
    from reach_addon.demo import WORKPLACE

    arm = standard_arm()
    scenes = {
        "workplace": obstacles(WORKPLACE),
        "block": obstacles({"Block": [((-0.6, -0.9, 0.9), (0.2, -0.35, 1.6))]}),
        "walls": obstacles({"Wall": [((-0.9, -0.30, 1.0), (0.3, -0.26, 1.45))],
                            "Low": [((-0.8, -0.7, 0.7), (0.6, -0.1, 0.74))]}),
    }
    for name, obs in scenes.items():
        planner = Planner(arm, obs)
        occupied, valid = _grid_by_definition(planner, planner.workspace)
        assert occupied.any() and valid.any(), name
        for chunk in (None, 8):
            ws = drain(workspace_steps(planner.generator, chunk))
            assert np.array_equal(ws.occupied, occupied), (name, chunk)
            assert np.array_equal(ws.valid, valid), (name, chunk)
