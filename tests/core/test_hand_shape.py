"""The hand as skinned (``core.hand_shape``): capsules fitted to a hand's skin, placed in
the hand's frame at every pose, and tested by the collision checker in place of the axis
capsule."""

import dataclasses

import numpy as np
import pytest
from geometry import standard_arm

from reach_addon.core import Obstacles, Settings
from reach_addon.core.arm import ArmConfig, pose_from_config
from reach_addon.core.collision import CollisionChecker
from reach_addon.core.generator import ConfigurationGenerator
from reach_addon.core.hand_shape import (capsule_volume, fit_capsule, fit_hand_shape, hand_frames,
                                         shape_points, tip_shape_ends, tip_shape_points,
                                         with_shape, world_pose)
from reach_addon.core.keys import between, segment_frames
from reach_addon.samples import box


def _held(points, shape, slack=1e-9):
    """Is every point within one of the shape's capsules?"""
    p = np.asarray(points, dtype=float)
    best = np.full(len(p), np.inf)
    for a, b, r in shape:
        a, b = np.asarray(a), np.asarray(b)
        ab = b - a
        t = np.clip((p - a) @ ab / max(ab @ ab, 1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - (a + t[:, None] * ab), axis=1) - r)
    return bool((best <= slack).all())


def _mitten(rng, n=400):
    """A flat hand: a plate 0.19 long, 0.09 wide and 0.03 thick along d, g, d × g, with a
    thumb standing out to one side."""
    plate = rng.uniform([0.0, -0.045, -0.015], [0.19, 0.045, 0.015], (n, 3))
    thumb = rng.uniform([0.03, 0.045, -0.012], [0.09, 0.1, 0.012], (n // 8, 3))
    return np.vstack([plate, thumb])


def test_a_fitted_capsule_holds_every_point():
    rng = np.random.default_rng(5)
    for _ in range(50):
        p = rng.normal(size=(rng.integers(2, 200), 3)) * rng.uniform(0.01, 1.0, 3)
        a, b, r = fit_capsule(p)
        assert _held(p, [(a, b, r)])


def test_a_flat_hand_gets_several_capsules_that_hold_it_in_less_room_than_one():
    p = _mitten(np.random.default_rng(1))
    shape = fit_hand_shape(p)
    one = fit_capsule(p)
    assert 2 <= len(shape) <= 4
    assert _held(p, shape)
    assert sum(capsule_volume(*c) for c in shape) < 0.7 * capsule_volume(*one)
    assert fit_hand_shape(p) == shape                       # the same skin, the same shape


def test_a_round_hand_keeps_one_capsule():
    rng = np.random.default_rng(2)
    t = rng.uniform(0, 0.18, 500)
    ring = rng.normal(size=(500, 2))
    ring = 0.03 * ring / np.linalg.norm(ring, axis=1, keepdims=True)
    shape = fit_hand_shape(np.column_stack([t, ring]))
    assert len(shape) == 1
    assert fit_hand_shape(np.zeros((0, 3))) == ()


def _shaped_arm(rng):
    arm = standard_arm()
    local = _mitten(rng, 200) * (arm.hand_length / 0.19)
    return dataclasses.replace(arm, hand_shape=fit_hand_shape(local)), local


def test_the_shape_turns_with_the_hand_as_the_bake_turns_it():
    """A point fixed in the hand has constant coordinates in the frame the bake turns the
    hand bone by (``keys.segment_frames``' hand frame: d, the hinge made perpendicular to
    d, its palm roll), at every pose."""
    rng = np.random.default_rng(3)
    arm, _local = _shaped_arm(rng)
    for _ in range(100):
        c = ArmConfig.from_array([rng.uniform(-30, 30), rng.uniform(-60, 120),
                                  rng.uniform(-40, 120), rng.uniform(-60, 60),
                                  rng.uniform(0, 140)])
        pose = dataclasses.replace(pose_from_config(arm, c, hand=tuple(rng.uniform(-40, 40, 2))),
                                   roll=float(rng.uniform(-90, 90)))
        rows = with_shape(arm, pose.joints, pose.bend, pose.roll)
        frame = segment_frames(arm, pose)[3]                # columns (d, g, d × g)
        local = (rows[5:] - pose.wrist) @ frame
        ends = np.array([e for a, b, _r in arm.hand_shape for e in (a, b)])
        np.testing.assert_allclose(local, ends, atol=1e-9)
        np.testing.assert_allclose(rows[:5], pose.joints)


def test_between_keys_the_shape_rides_the_hand_as_blender_blends_it():
    """``keys.between`` gives the shape's ends in the hand's blended frame: on the keys,
    exactly where ``with_shape`` puts them; between, at the same distances from the
    wrist (a rigid hand)."""
    rng = np.random.default_rng(4)
    arm, _local = _shaped_arm(rng)
    for _ in range(60):
        c = np.array([rng.uniform(-30, 30), rng.uniform(-60, 120), rng.uniform(-40, 120),
                      rng.uniform(-60, 60), rng.uniform(5, 140)])
        a = pose_from_config(arm, ArmConfig.from_array(c), hand=tuple(rng.uniform(-40, 40, 2)))
        b = pose_from_config(arm, ArmConfig.from_array(c + rng.normal(size=5) * 6),
                             hand=tuple(rng.uniform(-40, 40, 2)))
        joints, _bends, _body = between(arm, a, b, [0.0, 0.3, 0.7, 1.0])
        assert joints.shape == (4, 5 + 2 * len(arm.hand_shape), 3)
        np.testing.assert_allclose(joints[0], with_shape(arm, a.joints, a.bend), atol=1e-9)
        np.testing.assert_allclose(joints[-1], with_shape(arm, b.joints, b.bend), atol=1e-9)
        reach = np.linalg.norm(joints[:, 5:] - joints[:, 3:4], axis=2)
        np.testing.assert_allclose(reach, reach[:1].repeat(4, 0), atol=1e-9)


def test_the_checker_tests_the_shape_in_place_of_the_axis_capsule():
    """A box beside the hand, clear of its axis capsule but in the way of its plate, is a
    contact for the shaped arm and not for the same arm without a shape; a pose without
    the shape's rows is refused loudly rather than tested without a hand."""
    rng = np.random.default_rng(6)
    shaped, _local = _shaped_arm(rng)
    plain = dataclasses.replace(shaped, hand_shape=())
    pose = pose_from_config(shaped, ArmConfig(0.0, 80.0, 0.0, 0.0, 30.0))
    frame = hand_frames((pose.joints[4] - pose.wrist) / shaped.hand_length,
                        np.cross(pose.joints[2] - pose.joints[1], pose.bend))
    # the plate's edge toward g, half way along the hand
    edge = pose.wrist + frame @ np.array([0.5 * shaped.hand_length, 0.1, 0.0])
    g = frame[:, 1]
    lo = edge + 0.005 * g - 0.02
    hi = edge + 0.005 * g + 0.02
    verts, tris = box(np.minimum(lo, hi), np.maximum(lo, hi))
    obstacles = Obstacles.from_triangles(shaped.to_world_points(verts), tris)
    s = Settings(clearance=0.0)
    axis_gap = np.linalg.norm(np.cross(verts.mean(0) - pose.wrist,
                                       frame[:, 0])) - 0.02 * np.sqrt(2)
    assert axis_gap > plain.hand_radius                  # the axis capsule is clear of it
    assert not CollisionChecker(plain, obstacles, s).collides(plain.to_world_points(pose.joints))
    shaped_checker = CollisionChecker(shaped, obstacles, s)
    assert shaped_checker.first_hit(world_pose(shaped, pose))[0] == "hand"
    with pytest.raises(ValueError, match="hand's shape"):
        shaped_checker.collides(shaped.to_world_points(pose.joints))
    # the generator's hand tests agree with the checker
    gen = ConfigurationGenerator(shaped, obstacles, s)
    assert gen.pose_collides(pose)
    assert not gen.hands_clear(pose.joints, pose.bend, 0.0, [(1.0, 0.0, 0.0)])[0]
    assert ConfigurationGenerator(plain, obstacles, s).hands_clear(
        pose.joints, pose.bend, 0.0, [(1.0, 0.0, 0.0)])[0]


def test_shape_points_place_capsule_ends_in_the_frame():
    shape = (((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 0.1), ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), 0.2))
    frame = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])   # columns
    pts = shape_points(shape, np.array([1.0, 2.0, 3.0]), frame)
    np.testing.assert_allclose(pts, [[1, 2, 3], [1, 2, 4], [2, 2, 3], [1, 3, 3]])


def test_one_tip_in_floats_gives_the_arrays_numbers():
    """The search's float path for one hand (:func:`tip_shape_ends`) places the shape's
    capsule ends where the arrays' (:func:`tip_shape_points`) do, bit for bit: a plan must
    not depend on which path tested its hand."""
    rng = np.random.default_rng(5)
    arm, _local = _shaped_arm(rng)
    for _ in range(200):
        wrist, tip = rng.normal(size=3), rng.normal(size=3)
        hinge = rng.normal(size=3)
        hinge /= np.linalg.norm(hinge)
        arrays = tip_shape_points(arm, wrist, [tip], hinge)[0]
        assert np.array_equal(np.array(tip_shape_ends(arm, wrist, tip, hinge)), arrays)


def test_hand_as_skinned_off_keeps_the_axis_capsule():
    """``Settings.hand_as_skinned`` off: the planner's arm has no shape, its checker tests
    the axis capsule, and a plan's poses carry the five joints only."""
    from reach_addon.core import Planner

    rng = np.random.default_rng(6)
    shaped, _local = _shaped_arm(rng)
    on = Planner(shaped, None, Settings())
    off = Planner(shaped, None, Settings(hand_as_skinned=False))
    assert on.generator.checker.hand_shape == shaped.hand_shape
    assert off.arm.hand_shape == () and off.generator.checker.hand_shape == ()
    assert [s.name for s in off.generator.checker.segments][-1] == "hand"
    assert off.generator.checker.rows == 5
