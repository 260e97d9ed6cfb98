"""The trunk's lean (``core.lean``): its rotation, the least lean that reaches, the skin's
clearance as it moves; and the ``needs_lean`` refusal reading its lean from it. Figures worked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from reach_addon.core import lean


def test_a_lean_toward_a_target_ahead_tips_the_trunk_forward():
    axis = lean.lean_axis([0.0, 0.0, 0.0], [0.0, 2.0, 1.0])
    assert np.allclose(axis, [-1.0, 0.0, 0.0])
    # the top of a trunk 1 tall, leaned 30°: sin 30° forward, cos 30° up
    top = lean.rotate_about([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], axis, 30.0)
    assert np.allclose(top, [0.0, 0.5, math.sqrt(3) / 2])


def test_a_lean_to_the_side_bends_the_trunk_sideways_about_the_pivot():
    pivot = np.array([0.1, 0.2, -1.0])
    target = pivot + [3.0, 0.0, 0.5]
    top = lean.rotate_about(pivot + [0.0, 0.0, 1.0], pivot, lean.lean_axis(pivot, target), 90.0)
    assert np.allclose(top, pivot + [1.0, 0.0, 0.0])


def test_the_lean_matrix_moves_points_as_the_rotation_does():
    rng = np.random.default_rng(3)
    pivot, pts = rng.normal(size=3), rng.normal(size=(5, 3))
    axis = lean.lean_axis(pivot, rng.normal(size=3))
    m = lean.lean_rotation(pivot, axis, 37.0)
    moved = pts @ m[:3, :3].T + m[:3, 3]
    assert np.allclose(moved, lean.rotate_about(pts, pivot, axis, 37.0))
    assert np.allclose(m[:3, :3] @ m[:3, :3].T, np.eye(3)) and np.linalg.det(m[:3, :3]) > 0
    assert np.allclose(np.linalg.norm(moved - pivot, axis=1), np.linalg.norm(pts - pivot, axis=1))


def test_the_least_lean_is_the_one_that_just_reaches():
    """Shoulder 1 above the pivot, target 1 ahead and 1 up, reach 0.5. Leaned θ, the
    shoulder is at (0, sin θ, cos θ), and |t - s|² = 3 - 2 (sin θ + cos θ) ≤ 0.25 first at
    θ = asin(1.375 / √2) - 45° = 31.476°."""
    expected = math.degrees(math.asin(1.375 / math.sqrt(2.0))) - 45.0
    got = lean.least_lean([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 1.0, 1.0], 0.5, 45.0)
    assert got == pytest.approx(expected, abs=0.01) and got >= expected - 1e-9
    assert lean.least_lean([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 1.0, 1.0], 0.5, 30.0) is None
    assert lean.least_lean([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.3, 1.0], 0.5, 30.0) == 0.0


def test_a_narrow_window_of_leans_is_found_and_its_least_is_given():
    """Target on the unit circle the shoulder sweeps, at 60°, reach 0.02: only leans within
    2 asin(0.01) = 1.146° of 60° reach it; the least is 58.854°. A brute-force scan of
    leans every 0.001° agrees."""
    target = [0.0, math.sin(math.radians(60.0)), math.cos(math.radians(60.0))]
    got = lean.least_lean([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], target, 0.02, 90.0)
    assert got == pytest.approx(60.0 - math.degrees(2 * math.asin(0.01)), abs=1e-6)
    rng = np.random.default_rng(11)
    for _ in range(20):
        shoulder, pivot, tgt = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3) * 2
        reach = float(rng.uniform(0.2, 1.5))
        angles = np.arange(0.0, 90.0, 0.001)
        k = lean.lean_axis(pivot, tgt)
        tops = np.array([lean.rotate_about(shoulder, pivot, k, a) for a in angles[::50]])
        hits = angles[::50][np.linalg.norm(tops - tgt, axis=1) <= reach]
        got = lean.least_lean(shoulder, pivot, tgt, reach, 90.0)
        if len(hits):
            assert got is not None and got <= hits[0] + 1e-9 and got > hits[0] - 0.05 - 1e-9
        if got is not None:
            top = lean.rotate_about(shoulder, pivot, k, got)
            assert np.linalg.norm(top - tgt) <= reach + 1e-9


def test_the_skin_check_finds_a_thin_board_a_coarse_step_would_jump():
    """A point moved 1 m in two instants past a board 2 mm thick: the instants between are
    added (it moves at most 1.5 clearances between two), so the board is found; a point
    that starts within the clearance is not held to it."""
    from reach_addon.core import Settings
    from reach_addon.core.collision import CollisionChecker
    from reach_addon.samples import obstacles, standard_arm

    arm = standard_arm()
    board = obstacles({"Board": [((0.499, -1.0, -1.0), (0.501, 1.0, 1.0))]})
    checker = CollisionChecker(arm, board, Settings())
    path = np.array([[[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]]])
    assert lean.skin_hit(path, checker) == (1, "Board")
    assert lean.skin_hit(path[:, :, :] * [0.45, 1, 1], checker) is None
    touching = np.array([[[0.505, 0.0, 0.0]], [[0.52, 0.0, 0.0]]])      # starts 4 mm away
    assert checker.margin > 0.004 and lean.skin_hit(touching, checker) is None
    assert lean.skin_hit(np.concatenate([path, touching], axis=1), checker) == (1, "Board")


def test_skin_that_starts_on_a_floor_box_may_not_sink_into_it():
    """A point on the top of a floor box (1 mm over it, within the clearance, so not held
    to the clearance) that sinks three clearances into the box is found there, by the rays'
    parity; one that sinks half a clearance, or slides along the top, is not. On an open
    plane, which has no inside, the same sinking point is not held (the documented gap)."""
    from reach_addon.core import Settings
    from reach_addon.core.collision import CollisionChecker, Obstacles
    from reach_addon.samples import obstacles, standard_arm

    arm = standard_arm()
    floor = obstacles({"Floor": [((-1.0, -1.0, -0.2), (1.0, 1.0, 0.0))]})
    checker = CollisionChecker(arm, floor, Settings())
    m = checker.margin
    start = [0.1, 0.0, 0.001]

    def sink(depth, slide=0.0):
        return np.array([[start], [[0.1 + slide, 0.0, 0.001 - 0.5 * depth]],
                         [[0.1 + slide, 0.0, 0.001 - depth]]])

    assert lean.skin_hit(sink(3.0 * m), checker) == (1, "Floor")     # 1.5 deep there
    assert lean.skin_hit(sink(0.5 * m), checker) is None
    assert lean.skin_hit(sink(0.0, slide=0.3), checker) is None
    plane = Obstacles.from_triangles(
        np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]]),
        np.array([[0, 1, 2], [0, 2, 3]]), owner_names=("Plane",))
    assert lean.skin_hit(sink(3.0 * m), CollisionChecker(arm, plane, Settings())) is None
