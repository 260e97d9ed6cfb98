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
