"""A motion planned among obstacles that move while it lasts (``core.sweep``), with the
moving obstacles handed in by a callback as the Blender layer hands them: a box that
slides onto the straight path of a reach, and boxes put on a planned motion's path."""

import numpy as np
import pytest

from reach_addon.core import NO_PATH, START_IN_COLLISION, Planner, Settings, Task
from reach_addon.core.collision import CollisionChecker
from reach_addon.core.steps import drain
from reach_addon.core.sweep import (check_moving, coming_into, obstacles_from_pieces,
                                    plan_among_moving)
from reach_addon.demo import WORKPLACE
from reach_addon.samples import HANGING, box, standard_arm, triangle_soup

FIRST = 10                      # the frame of the motion's first pose


def pieces(named_parts) -> list:
    """[(label, vertices, triangles)] of boxes {name: [(lo, hi), ...]}."""
    out = []
    for name, parts in named_parts.items():
        for lo, hi in parts:
            v, t = box(lo, hi)
            out.append((name, v, t))
    return out


def cube(name, centre, half):
    c = np.asarray(centre, float)
    return pieces({name: [(c - half, c + half)]})


@pytest.fixture(scope="module")
def reach():
    arm = standard_arm()
    task = Task("reach", np.array([[-0.28, -0.47, 1.14]]), HANGING, 24.0,
                names=("over the crate",))
    still = pieces(WORKPLACE)
    return arm, task, still


def test_pieces_make_the_same_obstacles_as_a_triangle_soup():
    verts, tris, owners, names = triangle_soup(WORKPLACE)
    ours = obstacles_from_pieces(pieces(WORKPLACE))
    assert sorted(ours.owner_names) == sorted(names)
    assert ours.triangle_count == len(tris)
    assert obstacles_from_pieces([]).tree is None


def test_a_union_of_frames_holds_each_place_once_and_each_inside():
    """The places obstacles take over a chase's frames as one set (what a chase that plans
    ahead plans among where obstacles move): a box that stays is taken once, one that
    moves at each place, and each place encloses its own inside."""
    from reach_addon.core import Obstacles
    from reach_addon.core.obstacle_union import union as union_of
    still = cube("Crate", (0.0, 0.0, 0.0), 0.1)
    frames = [obstacles_from_pieces(still + cube("Ball", (x, 0.0, 0.0), 0.05))
              for x in (0.5, 0.5, 0.8)]
    union = union_of(frames)
    assert sorted(union.owner_names) == ["Ball", "Crate"]
    assert union.triangle_count == 3 * 12
    for x in (0.0, 0.5, 0.8):
        assert union.point_inside((x, 0.0, 0.0)), x
    assert not union.point_inside((0.65, 0.0, 0.0))
    assert union.enclosing_owner((0.8, 0.0, 0.0)) == "Ball"
    assert union_of([Obstacles(None)]).tree is None


def test_without_moving_obstacles_the_first_plan_is_the_answer(reach):
    arm, task, still = reach
    planner = Planner(arm, obstacles_from_pieces(still), Settings())

    def sweep(f0, f1):
        raise AssertionError("nothing moves: nothing is swept")

    plan, used = drain(plan_among_moving(planner, task, FIRST, still, set(), sweep))
    assert used is planner and plan.success
    again = Planner(arm, obstacles_from_pieces(still), Settings()).plan(task)
    assert np.allclose(plan.world_joints(), again.world_joints())


def test_a_box_that_slides_onto_the_path_is_planned_around(reach):
    """On the first frames the box is far to the side; from frame FIRST + 4 on it sits on
    the straight path's middle. The motion is planned again among every place it takes
    and keeps clear of it on every frame."""
    arm, task, still = reach
    planner = Planner(arm, obstacles_from_pieces(still), Settings())
    straight = planner.plan(task)
    middle = straight.world_joints()[len(straight.poses) // 2, 3]
    swept_frames = []

    def place(f):
        return middle if f >= FIRST + 4 else middle + np.array([2.0, 0.0, 0.0])

    def sweep(f0, f1):
        swept_frames.append((f0, f1))
        return {f: [cube("Box", place(f), 0.04), cube("Box", place(f + 0.5), 0.04)]
                for f in range(f0, f1 + 1)}

    plan, used = drain(plan_among_moving(planner, task, FIRST, still, {"Box"}, sweep))
    assert plan.success, plan.message
    assert used is not planner
    assert swept_frames[0] == (FIRST, FIRST + 2 * (len(straight.poses) - 1))
    assert FIRST + len(plan.poses) - 1 <= swept_frames[-1][1]     # no frame unswept
    touching = Settings().replace(clearance=0.0)
    for i, joints in enumerate(plan.world_joints()):
        box_now = obstacles_from_pieces(cube("Box", place(FIRST + i), 0.04))
        assert CollisionChecker(arm, box_now, touching).first_hit(joints) is None, i


def test_a_motion_that_meets_a_moving_obstacle_fails_naming_it(reach):
    arm, task, still = reach
    plan = Planner(arm, obstacles_from_pieces(still), Settings()).plan(task)
    assert plan.success
    k = len(plan.poses) // 2
    wrist = plan.world_joints()[k, 3]
    swept = {FIRST + i: [cube("Lid", wrist, 0.03) if i == k else []]
             for i in range(len(plan.poses))}
    check_moving(plan, FIRST, swept, FIRST + len(plan.poses), {"Lid"}, Settings())
    seg = plan.segments[0]
    assert not seg.success and seg.reason == NO_PATH
    assert seg.message.startswith("'Lid' moves while the arm reaches for 'over the crate'")
    assert f"meets 'Lid' at frame {FIRST + k}" in seg.message


def test_a_motion_that_outlasts_the_swept_frames_fails(reach):
    arm, task, still = reach
    plan = Planner(arm, obstacles_from_pieces(still), Settings()).plan(task)
    swept = {FIRST + i: [[]] for i in range(5)}
    check_moving(plan, FIRST, swept, FIRST + 4, {"Lid", "Box"}, Settings())
    seg = plan.segments[0]
    assert not seg.success
    assert seg.message.startswith("'Box', 'Lid' move while the arm reaches")
    assert "outlasts every frame swept" in seg.message


def test_a_box_that_comes_to_the_start_pose_is_named_with_its_frame(reach):
    """The start is clear on its own frame; from frame FIRST + 6 on a box sits on the
    shoulder, which only the body could move away from. The refusal is the start's, and it
    says the box comes there, on which frame (fuzz seed 6356: the message said the start
    pose touched the box, which the start frame belied)."""
    arm, task, still = reach
    planner = Planner(arm, obstacles_from_pieces(still), Settings())
    shoulder = arm.to_world_points(arm.shoulder)

    def place(f):
        return shoulder if f >= FIRST + 6 else shoulder + np.array([0.0, -3.0, 0.0])

    def sweep(f0, f1):
        return {f: [cube("Swing", place(f), 0.05), cube("Swing", place(f + 0.5), 0.05)]
                for f in range(f0, f1 + 1)}

    plan, _used = drain(plan_among_moving(planner, task, FIRST, still, {"Swing"}, sweep))
    seg = plan.segments[0]
    assert not seg.success and seg.reason == START_IN_COLLISION
    assert seg.message.startswith(f"'Swing' moves into the arm's start pose (at the "
                                  f"clavicle) on frame {FIRST + 6}, "), seg.message
    # the Blender layer reads the obstacle and the frame back to check the skin there
    assert coming_into(seg.message) == ("Swing", FIRST + 6)
    assert coming_into("the start pose already touches 'Swing' (at the hand)") is None
    # a scene's frames may be negative (fuzz seed 25: frame -8 read as no claim at all)
    assert coming_into("'Box' moves into the arm's start pose (at the forearm) on frame -8, "
                       "while the reach for 'Cup' lasts") == ("Box", -8)
