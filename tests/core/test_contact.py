"""Starting in contact (core.contact): a hand resting on a table or fingertips a centimetre
from a wall is planned out of contact, every early frame farther from it; a start deeper
than the tolerance is refused, naming the obstacle. Checked by the independent exact
distances of tests/geometry.py."""

import numpy as np
import pytest

from geometry import HANGING, arm_penetration, obstacles, standard_arm, triangles_of
from reach_addon.core import START_IN_COLLISION, Planner, Settings, Task

TARGET = np.array([-0.30, -0.42, 1.12])      # in front, at chest height


@pytest.fixture(scope="module")
def arm():
    return standard_arm()


def start_joints(arm):
    return arm.to_world_points(Planner(arm, None).generator.config_pose(HANGING).joints)


def slab_under(point, below, half=0.15, thick=0.04):
    """A table top whose upper face is ``below`` under ``point``."""
    top = point[2] - below
    return {"Table": [((point[0] - half, point[1] - half, top - thick),
                       (point[0] + half, point[1] + half, top))]}


def wall_before(point, gap, direction, half=0.2, thick=0.04):
    """A wall across ``direction`` (a unit axis, ±x or ±y) ``gap`` beyond ``point``."""
    lo, hi = point - half, point + half
    axis = int(np.flatnonzero(direction)[0])
    sign = float(direction[axis])
    face = point[axis] + sign * gap
    lo[axis], hi[axis] = (face, face + thick) if sign > 0 else (face - thick, face)
    return {"Wall": [(tuple(lo), tuple(hi))]}


def check_way_out(arm, plan, scene, settings):
    tris = triangles_of(scene)
    depth = [arm_penetration(arm, j, tris) for j in plan.world_joints()]
    margin = settings.clearance * arm.arm_length
    out = next(i for i, d in enumerate(depth) if d >= margin - 1e-3)
    assert out > 0, "the start was in contact"
    # the first frames only ever get farther from what the arm touched ...
    assert all(b >= a - 1e-4 for a, b in zip(depth[:out], depth[1:out + 1])), depth[:out + 1]
    # ... and once clear it stays clear
    assert min(depth[out:]) >= 0.0


def test_a_hand_resting_on_a_table_moves_off_it_first(arm):
    tip = start_joints(arm)[4]
    scene = slab_under(tip, 0.5 * arm.hand_radius)        # the hand's capsule sinks in
    s = Settings()
    plan = Planner(arm, obstacles(scene), s).plan(Task("reach", TARGET[None], HANGING))
    assert plan.success, plan.message
    assert np.linalg.norm(plan.wrist_trajectory()[-1] - TARGET) <= s.goal_tolerance * arm.arm_length
    check_way_out(arm, plan, scene, s)


def test_fingertips_a_centimetre_from_a_wall(arm):
    joints = start_joints(arm)
    tip = joints[4]
    # the wall beside the hanging hand, on its outer side, a centimetre from the fingertips
    scene = wall_before(tip, 0.01, np.array([-1.0, 0.0, 0.0]))
    s = Settings()
    planner = Planner(arm, obstacles(scene), s)
    assert planner.generator.start_problem(planner.generator.config_pose(HANGING)) is not None
    plan = planner.plan(Task("reach", TARGET[None], HANGING))
    assert plan.success, plan.message
    check_way_out(arm, plan, scene, s)


def test_a_start_deeper_than_the_tolerance_is_refused(arm):
    tip = start_joints(arm)[4]
    deep = 0.9 * arm.hand_radius                 # the capsule 0.05 arm lengths in, the tip not
    scene = slab_under(tip, arm.hand_radius - deep)
    strict = Settings(start_contact_depth=0.02)
    assert deep > strict.start_contact_depth * arm.arm_length
    plan = Planner(arm, obstacles(scene), strict).plan(Task("reach", TARGET[None], HANGING))
    assert not plan.success and plan.reason == START_IN_COLLISION
    assert "Table" in plan.message and "Start contact tolerance" in plan.message
    assert len(plan.poses) == 1
    # within the (default) tolerance the same start is planned out of contact
    s = Settings()
    plan = Planner(arm, obstacles(scene), s).plan(Task("reach", TARGET[None], HANGING))
    assert plan.success, plan.message
    check_way_out(arm, plan, scene, s)
    # the fingers inside the table: refused whatever the tolerance
    inside = slab_under(tip, -0.5 * arm.hand_radius)
    plan = Planner(arm, obstacles(inside), Settings(start_contact_depth=0.5)).plan(
        Task("reach", TARGET[None], HANGING))
    assert plan.reason == START_IN_COLLISION and "inside 'Table'" in plan.message


def test_a_bone_through_a_thin_plate_is_refused_whatever_its_capsule_s_depth(arm):
    """A thin plate across the forearm (between the points the start's closed-obstacle test
    samples, so it is no joint inside a closed mesh): its capsule reads only its radius
    deep (about 0.07 arm lengths, within the default start contact tolerance), however the
    bone runs through, so no depth says which way is out; Reach refuses the start as
    bone-deep (fuzz seeds 5103, 5117). The same plate a radius and a half off the bone
    holds nothing back."""
    joints = start_joints(arm)
    mid = joints[2] + 0.3 * (joints[3] - joints[2])

    def plate(dx):
        c = mid + np.array([dx, 0.0, 0.0])
        return {"Plate": [((c[0] - 0.04, c[1] - 0.04, c[2] - 0.002),
                           (c[0] + 0.04, c[1] + 0.04, c[2] + 0.002))]}

    s = Settings()
    assert arm.forearm_radius < s.start_contact_depth * arm.arm_length
    plan = Planner(arm, obstacles(plate(0.0)), s).plan(Task("reach", TARGET[None], HANGING))
    assert plan.reason == START_IN_COLLISION, plan.message
    assert "bone-deep in 'Plate' (at the forearm)" in plan.message, plan.message
    scene = plate(-1.5 * arm.forearm_radius)
    plan = Planner(arm, obstacles(scene), s).plan(Task("reach", TARGET[None], HANGING))
    assert plan.success, plan.message


def test_a_chase_from_a_hand_resting_on_a_table(arm):
    tip = start_joints(arm)[4]
    scene = slab_under(tip, 0.5 * arm.hand_radius)
    s = Settings()
    t = np.linspace(0.0, 1.0, 48)[:, None]
    moving = TARGET + t * np.array([0.0, 0.0, 0.08])       # a target rising slowly
    planner = Planner(arm, obstacles(scene), s)
    plan = planner.plan(Task("chase", moving, HANGING))
    assert plan.reason != START_IN_COLLISION, plan.message
    assert plan.success, plan.message
    check_way_out(arm, plan, scene, s)
    # a chase's way out takes several of the escape's poses a frame: as the keys
    # interpolate it still never touches again once clear (chase._Chase._way_out)
    from reach_addon.core.motion_check import escape_contact, pose_clearances

    gen = planner.generator
    poses = plan.poses
    assert escape_contact(gen, poses, pose_clearances(arm, poses, [gen.checker] * len(poses))) \
        is None


def test_a_clavicle_against_a_box_leaves_by_turning_the_chest(arm):
    """A box behind the clavicle, its capsule 0.3 of its radius in: no step of the wrist
    moves the clavicle, so the greedy way out is stuck; the escape's search turns the
    chest (fuzz seed 5235, a clavicle in a mesh), every early frame no nearer the box."""
    from reach_addon.core import contact

    joints = start_joints(arm)
    mid, r = 0.5 * (joints[0] + joints[1]), arm.upper_arm_radius
    face = mid[1] + 0.7 * r
    scene = {"Box": [((mid[0] - 0.03, face, mid[2] - 0.05), (mid[0] + 0.03, face + 0.04,
                                                              mid[2] + 0.05))]}
    s = Settings()
    planner = Planner(arm, obstacles(scene), s)
    gen = planner.generator
    start = gen.config_pose(HANGING)
    assert gen.start_problem(start) == ("clavicle", "Box")
    c0 = contact.start_clearance(gen, start)
    loose = contact.thinner(gen, gen.checker.margin - c0 + 1e-3 * arm.arm_length)
    assert contact._greedy(loose, gen, start, c0, 40) is None
    way = contact.escape(gen, start, "Box")
    assert way is not None and abs(way.poses[-1].config.body_rotation) >= 5.0
    plan = planner.plan(Task("reach", TARGET[None], HANGING))
    assert plan.success, plan.message
    check_way_out(arm, plan, scene, s)


def test_a_way_out_that_touches_again_after_clearing_is_caught(arm):
    """The rule an independent check of a baked way out applies: a start in contact may
    stay in contact only while leaving it. Keys of a hand on a table (the elbow bent 20°,
    in; 26°, clear but within the margin; 22°, in again; 30°, clear by the margin):
    :func:`~reach_addon.core.motion_check.escape_contact` names the key that touches
    again; the same keys in order (20°, 24°, 26°, 30°) leave cleanly."""
    import dataclasses

    from reach_addon.core.motion_check import escape_contact, pose_clearances

    tip = start_joints(arm)[4]
    gen = Planner(arm, obstacles(slab_under(tip, 0.5 * arm.hand_radius)), Settings()).generator

    def keys(*elbows):
        return [gen.config_pose(dataclasses.replace(HANGING, elbow=e)) for e in elbows]

    back = keys(20.0, 26.0, 22.0, 30.0)
    clearances = pose_clearances(arm, back, [gen.checker] * 4)
    assert [c < 0 for c in clearances] == [True, False, True, False]
    assert gen.checker.collides(arm.to_world_points(back[1].joints))
    assert not gen.checker.collides(arm.to_world_points(back[3].joints))
    at, (part, obstacle) = escape_contact(gen, back, clearances)
    assert at == 2 and obstacle == "Table", (at, part, obstacle)
    out = keys(20.0, 24.0, 26.0, 30.0)
    assert escape_contact(gen, out, pose_clearances(arm, out, [gen.checker] * 4)) is None


def open_bin(centre, half, depth, missing=("top",)):
    """(vertices, triangles) of a box around ``centre`` (half widths ``half`` in x and y,
    ``depth`` tall, its top face at ``centre``'s height plus half the depth), one mesh
    with the ``missing`` faces ("top", "bottom") left out: open, so it encloses nothing."""
    from reach_addon.samples import box
    lo = np.asarray(centre, float) - (half, half, depth / 2)
    hi = np.asarray(centre, float) + (half, half, depth / 2)
    verts, tris = box(lo, hi)
    keep = []
    for t in tris:
        z = verts[t, 2]
        if ("top" in missing and np.all(z == hi[2])) or ("bottom" in missing and np.all(z == lo[2])):
            continue
        keep.append(t)
    return verts, np.array(keep)


def test_open_meshes_enclose_nothing_and_overlapping_solids_each_enclose_their_inside():
    """An open-topped bin or an open-ended tube reads as air inside (ray parity is odd
    along four or five axes there, yet nothing is solid); two overlapping closed boxes
    each enclose their common part (crossed twice there by one ray, once per box)."""
    from reach_addon.core import Obstacles
    from reach_addon.samples import triangle_soup
    for missing in (("top",), ("top", "bottom")):
        v, t = open_bin((0, 0, 0), 0.2, 0.4, missing)
        bin_ = Obstacles.from_triangles(v, t, np.zeros(len(t), int), ["Bin"])
        assert not bin_.point_inside((0.0, 0.0, 0.0)), missing
        assert not bin_.part_closed(0)
    v, t = open_bin((0, 0, 0), 0.2, 0.4, ())
    assert Obstacles.from_triangles(v, t).point_inside((0.0, 0.0, 0.0))
    verts, tris, owners, names = triangle_soup({"A": [((0, 0, 0), (1, 1, 1))],
                                                "B": [((0.5, 0.2, 0.2), (1.5, 0.8, 0.8))]})
    both = Obstacles.from_triangles(verts, tris, owners, names)
    assert both.point_inside((0.75, 0.5, 0.5)) and both.enclosing_owner((0.75, 0.5, 0.5)) == "A"
    assert both.enclosing_owner((1.25, 0.5, 0.5)) == "B"


def test_a_hand_touching_the_wall_inside_an_open_bin_is_planned_out(arm):
    """The hand hangs in an open-topped bin, touching its wall: it is in contact, not
    inside anything, so Reach leaves the contact and reaches (fuzz seed 5413: refused as
    inside an open mesh, by a parity that read the bin's inside as solid)."""
    from reach_addon.core import Obstacles
    joints = start_joints(arm)
    hand = 0.5 * (joints[3] + joints[4])
    half = 0.12
    # the bin's -x wall half a hand radius into the hand's capsule
    centre = hand.copy()
    centre[0] = joints[4][0] - 0.5 * arm.hand_radius + half
    v, t = open_bin(centre, half, 0.3)
    obs = Obstacles.from_triangles(v, t, np.zeros(len(t), int), ["Bin"])
    assert not any(obs.point_inside(p) for p in joints[1:])
    plan = Planner(arm, obs, Settings()).plan(Task("reach", TARGET[None], HANGING))
    assert "inside" not in plan.message, plan.message
    assert plan.success, plan.message


def test_the_check_counts_a_way_out_and_back_in_as_no_way_reach_takes(arm):
    """The refusal check searches from a start in contact with a state test that holds the
    arm no deeper than the start; a path it finds counts only if it also leaves contact as
    Reach's escape does, never deeper than the least depth reached (fuzz seed 7074: a way
    0.0085 arm lengths deep at best that went back to 0.0090)."""
    from reach_addon.core.sampling import JointSpace, pose_row
    from verification.refusal import HeldValidity, _leaves_as_reach_does
    tip = start_joints(arm)[4]
    planner = Planner(arm, obstacles(slab_under(tip, -0.3 * arm.hand_radius)), Settings())
    start = pose_row(planner.generator.config_pose(HANGING))
    lifted = start.copy()
    lifted[4] += 30.0                          # the elbow bent: the hand rises off the table
    space = JointSpace(arm, planner.settings, start)
    checker = planner.generator.checker
    c0 = checker.least_clearance(arm.to_world_points(planner.generator.config_pose(
        HANGING).joints), arm.arm_length)
    assert c0 < 0.0
    held = HeldValidity(arm, planner.settings, checker, space, c0)
    assert _leaves_as_reach_does(held, [start, lifted]) is None
    at, c, best = _leaves_as_reach_does(held, [start, lifted, start])
    assert 0.5 < at <= 1.0 and c < min(best, 0.0)
