"""The bench's everyday reaches (``reach_addon.samples.everyday_scenes``): each is reached,
clear at every frame by the tests' own geometry (not the planner's), and searched
efficiently — at most 3× as many positions as the path holds, the goal of the search's
steering by the guiding nodes. The drawer's reach needs the hand tilted to fit inside;
the search leads the hand toward the target's hand as it nears (``Settings.hand_lead``),
and without that it spent its budget at the drawer's opening (2,983 positions, then the
sampling planner)."""

import numpy as np
import pytest

from geometry import arm_penetration
from reach_addon.core import Obstacles, Planner, Settings, Task
from reach_addon.samples import HANGING, everyday_scenes, standard_arm

ARM = standard_arm()
SCENES = everyday_scenes(ARM)


@pytest.fixture(scope="module")
def plans():
    out = {}
    for name, (verts, tris, owners, names, target) in SCENES.items():
        planner = Planner(ARM, Obstacles.from_triangles(verts, tris, owners, names), Settings())
        out[name] = (planner.plan(Task("reach", np.asarray(target)[None], HANGING)), verts[tris])
    return out


@pytest.mark.parametrize("name", list(SCENES))
def test_an_everyday_reach_is_reached_clear_at_every_frame(plans, name):
    plan, tris = plans[name]
    assert plan.success, plan.message
    target = SCENES[name][4]
    assert np.linalg.norm(plan.wrist_trajectory()[-1] - target) <= 0.005 * ARM.arm_length
    worst = min(arm_penetration(ARM, joints, tris) for joints in plan.world_joints())
    assert worst >= 0.0, f"{name}: a frame passes {-worst:.4f} m into an obstacle"


@pytest.mark.parametrize("name", list(SCENES))
def test_an_everyday_reach_searches_at_most_three_times_its_path(plans, name):
    plan, _tris = plans[name]
    st = plan.stats
    assert plan.segments[0].method == "best-first"
    assert st.nodes_searched <= 3 * st.nodes_in_solution, (st.nodes_searched,
                                                           st.nodes_in_solution)


def test_the_scenes_are_built_round_the_arm_they_are_for():
    """Scaled by the arm and placed in its body frame: a left arm twice the size, standing
    elsewhere, gets the same scenes, mirrored to its side, scaled and carried with it (so
    the bench means the same for any rig)."""
    big = standard_arm(side="left", scale=2.0, position=(3.0, -1.0, 2.8))
    for name, (verts, _t, _o, _n, target) in everyday_scenes(big).items():
        small_verts, small_target = SCENES[name][0], SCENES[name][4]
        to_c = ARM.to_canonical_points
        np.testing.assert_allclose(big.to_canonical_points(verts), 2.0 * to_c(small_verts),
                                   atol=1e-9)
        np.testing.assert_allclose(big.to_canonical_points(np.asarray(target)[None]),
                                   2.0 * to_c(np.asarray(small_target)[None]), atol=1e-9)


def test_the_hand_leads_into_the_drawer():
    """With the hand's lead off (``Settings.hand_lead`` = 0) the search reaches the
    drawer's opening with the hand straight and spends its budget there; with it, the hand
    tilts on the way in and the search finds the way at once."""
    verts, tris, owners, names, target = SCENES["into a drawer"]
    obstacles = Obstacles.from_triangles(verts, tris, owners, names)
    task = Task("reach", np.asarray(target)[None], HANGING)
    led = Planner(ARM, obstacles, Settings()).plan(task)
    unled = Planner(ARM, obstacles, Settings(hand_lead=0.0)).plan(task)
    assert led.success and led.segments[0].method == "best-first"
    assert unled.stats.nodes_searched > 10 * led.stats.nodes_searched, (
        unled.stats.nodes_searched, led.stats.nodes_searched)
