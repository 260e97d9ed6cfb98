"""The collision checker's distance formula against a brute-force minimum."""

import numpy as np
import pytest

from reach_addon.core.distances import (fan_segment_distances, point_segment_distance,
                                        segment_distance_float)


def brute_distance(p1, q1, p2, q2, n=401):
    """Least distance over an n × n grid of points on the two segments: never below the
    true minimum, and above it by at most half a grid step of each segment's length."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    a = p1 + s * (q1 - p1)
    b = p2 + s * (q2 - p2)
    return float(np.min(np.linalg.norm(a[:, None, :] - b[None, :, :], axis=-1)))


def test_segment_distance_is_the_least_distance_between_the_segments():
    rng = np.random.default_rng(7)
    cases = [tuple(rng.uniform(-1, 1, (4, 3))) for _ in range(150)]
    p = rng.uniform(-1, 1, 3)
    d = rng.uniform(-1, 1, 3)
    cases += [
        (p, p + d, p + [0.0, 0.3, 0.0], p + [0.0, 0.3, 0.0] + 2 * d),    # parallel
        (p, p + d, p + 0.5 * d, p + 3 * d),                              # collinear, overlapping
        (p, p, p + d, p + 2 * d),                                        # a point and a segment
        (p, p, p + d, p + d),                                            # two points
        (p, p + d, p + d, p + 2 * d + [0.1, 0.0, 0.0]),                  # touching ends
    ]
    for p1, q1, p2, q2 in cases:
        p1, q1, p2, q2 = (np.asarray(v, float) for v in (p1, q1, p2, q2))
        exact = segment_distance_float(p1.tolist(), q1.tolist(), p2.tolist(), q2.tolist())
        brute = brute_distance(p1, q1, p2, q2)
        slack = 0.5 / 400 * (np.linalg.norm(q1 - p1) + np.linalg.norm(q2 - p2)) + 1e-12
        assert brute - slack <= exact <= brute + 1e-12, (p1, q1, p2, q2, exact, brute)
        if np.linalg.norm(q2 - p2) == 0.0:
            assert abs(exact - point_segment_distance(p2.tolist(), p1.tolist(), q1.tolist())) < 1e-12


def test_fan_distances_are_the_float_distances_to_the_last_bit():
    """The hand pass tests a fan of hand directions against the body in one array
    expression: it must give exactly the scalar formula's numbers (the planner's results
    may not depend on which of the two ran), degenerate segments included."""
    rng = np.random.default_rng(11)
    for trial in range(200):
        p = rng.normal(size=3)
        tips = rng.normal(size=(12, 3))
        a, b = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
        if trial % 4 == 0:
            b[0] = a[0]                                  # a capsule that is a sphere
        if trial % 5 == 0:
            tips[0] = p                                  # a hand of no length
        if trial % 6 == 0:
            b[1] = a[1] + 0.3 * (tips[2] - p)            # parallel to a hand
        fan = fan_segment_distances(p.tolist(), tips, a, b)
        one = [[segment_distance_float(p.tolist(), t.tolist(), a[k].tolist(), b[k].tolist())
                for k in range(5)] for t in tips]
        assert fan.tolist() == one


def test_axis_distance_is_the_segments_least_distance_to_the_mesh_within_its_tolerance():
    """:meth:`CollisionChecker.axis_distance` (branch and bound on BVH distances) against
    the exact segment–triangle distance of the tests' own geometry, on a table and a
    shelf: never more than the tolerance above it, never below it; and a pose's
    clearance is its segments' least distance minus their radii."""
    from geometry import (obstacles, segment_triangle_distances, shelf, standard_arm, table,
                          triangles_of)

    from reach_addon.core.collision import CollisionChecker
    from reach_addon.core.settings import Settings

    parts = {"table": table((0.0, -0.5), (1.0, 0.6), 0.75),
             "shelf": shelf((0.5, -0.6), 0.6, 0.3, (0.9, 1.2, 1.5))}
    tris = triangles_of(parts)
    arm = standard_arm()
    checker = CollisionChecker(arm, obstacles(parts), Settings())
    lo, hi = tris.reshape(-1, 3).min(0) - 0.2, tris.reshape(-1, 3).max(0) + 0.2
    rng = np.random.default_rng(3)
    tolerance, horizon = 1e-4, 0.5
    checked = 0
    for _ in range(300):
        p = rng.uniform(lo, hi)
        q = p + rng.normal(size=3) * rng.uniform(0.05, 0.5)
        exact = min(horizon, segment_triangle_distances(p, q, tris)[0])
        measured = checker.axis_distance(p, q, horizon, tolerance)
        # (the BVH holds single-precision floats)
        assert exact - 1e-6 <= measured <= exact + tolerance + 1e-6, (p, q, exact, measured)
        checked += exact < horizon
    assert checked > 100
    joints = np.array([arm.sternum, arm.shoulder, [0.0, 0.2, -0.3], [0.1, 0.45, -0.3],
                       [0.1, 0.6, -0.3]])
    world = arm.to_world_points(joints)
    expected = min(segment_triangle_distances(world[a], world[b], tris)[0] - seg.radius
                   + checker.margin for seg in checker.segments for a, b in [(seg.a, seg.b)])
    assert abs(checker.pose_clearance(world, 1.0, tolerance) - min(1.0, expected)) <= tolerance


def test_the_least_clearance_sees_an_edge_the_row_of_points_misses():
    """A bead beside the forearm, midway between two of the checker's sample points
    and nearer its axis than the radius by less than the row's over-read: the row of
    points (:meth:`CollisionChecker.clearance`) calls the forearm clear, the lower bound
    (:meth:`CollisionChecker.least_clearance`) calls it touching, within its tolerance of
    the exact distance (fuzz seed 1846: a way out of a start in contact that touched a
    tube's edge again after leaving it)."""
    from geometry import HANGING, arm_penetration, obstacles, standard_arm, triangles_of

    from reach_addon.core import Planner
    from reach_addon.core.collision import CLEARANCE_TOLERANCE, CollisionChecker
    from reach_addon.core.settings import Settings

    arm = standard_arm()
    s = Settings()
    world = arm.to_world_points(Planner(arm, None).generator.config_pose(HANGING).joints)
    forearm = CollisionChecker(arm, obstacles({}), s).by_name["forearm"]
    elbow, wrist = world[2], world[3]
    axis = (wrist - elbow) / np.linalg.norm(wrist - elbow)
    fractions = forearm.fractions[:, 0]
    spacing = forearm.length * float(fractions[1] - fractions[0])
    r = arm.forearm_radius
    depth = spacing ** 2 / (16.0 * r)                # less than the row's over-read
    middle = elbow + axis * 0.5 * float(fractions[1] + fractions[2]) * forearm.length
    side = np.cross(axis, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    half = 1e-4 * arm.arm_length                     # a bead: a corner of a tiny box
    centre = middle + side * (r - depth + 2.0 * half)
    bead = {"Bead": [(tuple(centre - half), tuple(centre + half))]}
    checker = CollisionChecker(arm, obstacles(bead), s)
    # the oracle samples each axis 2 mm apart: at most 1 mm over the exact distance
    exact = arm_penetration(arm, world, triangles_of(bead))
    assert -depth <= exact < -0.5 * depth
    assert checker.clearance(world, arm.arm_length) > 0.0       # the row misses it
    least = checker.least_clearance(world, arm.arm_length)
    assert exact - CLEARANCE_TOLERANCE * arm.arm_length - 1e-3 <= least <= exact + 1e-6
    assert checker.least_clearance(world + [0.0, 0.0, 10.0], arm.arm_length) == float("inf")


def test_no_clearance_still_keeps_the_least_margin():
    """With the clearance set to 0 (or below twice the least margin), the keys and the
    instants between them keep :data:`~reach_addon.core.collision.MIN_CLEARANCE` (arm
    lengths): Blender's evaluated bones between two keys stood 1e-4 arm lengths off the
    model's (fuzz seed 4880, a chase with the clearance 0 that touched a box by that much
    at frame 17.5). The default clearance is kept as it is, half of it between keys."""
    from geometry import obstacles, standard_arm

    from reach_addon.core import Planner
    from reach_addon.core.collision import MIN_CLEARANCE, CollisionChecker
    from reach_addon.core.settings import Settings

    arm = standard_arm()
    length = arm.arm_length
    for clearance, keys, between in ((0.0, MIN_CLEARANCE, MIN_CLEARANCE),
                                     (0.0015, 0.0015, MIN_CLEARANCE),
                                     (0.02, 0.02, 0.01)):
        s = Settings().replace(clearance=clearance)
        assert CollisionChecker(arm, obstacles({}), s).margin == pytest.approx(keys * length)
        gen = Planner(arm, obstacles({}), s).generator
        assert gen.checker.margin == pytest.approx(keys * length)
        assert gen.between_keys().checker.margin == pytest.approx(between * length)
