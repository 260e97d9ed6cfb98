"""Table 1: chest rotation from reach direction, and the shoulder carried by it."""

import numpy as np
import pytest

from reach_addon.core import Settings
from reach_addon.core.torso import (body_rotation_deg, chest_rotation_deg, rotate_about_spine,
                                    starting_angle_deg, table1_coefficients)


def test_table1_rows():
    assert chest_rotation_deg(90.0, 0.75) == pytest.approx(0.50 * 90 - 26.7)
    assert chest_rotation_deg(90.0, 0.85) == pytest.approx(0.45 * 90 - 18.9)
    assert chest_rotation_deg(120.0, 0.75) == pytest.approx(33.3)


def test_between_rows_is_interpolated():
    slope, intercept = table1_coefficients(0.80)
    assert (slope, intercept) == (pytest.approx(0.475), pytest.approx(-22.8))
    assert chest_rotation_deg(90.0, 0.80) == pytest.approx(0.475 * 90 - 22.8)


def test_starting_angles_match_the_table():
    assert starting_angle_deg(0.75) == pytest.approx(53.4, abs=0.05)
    assert starting_angle_deg(0.85) == pytest.approx(42.0, abs=0.05)
    assert chest_rotation_deg(53.0, 0.75) == 0.0       # just before the start: no rotation
    assert chest_rotation_deg(54.0, 0.75) > 0.0


def test_across_the_body_gives_no_rotation():
    assert chest_rotation_deg(-90.0, 0.80) == 0.0
    assert chest_rotation_deg(0.0, 0.80) == 0.0


def test_outside_the_table():
    # beyond 85 cm the 85 cm row holds
    assert chest_rotation_deg(90.0, 1.2) == pytest.approx(chest_rotation_deg(90.0, 0.85))
    # below 75 cm the 75 cm value fades linearly to zero at the fade start (0.5 m)
    full = chest_rotation_deg(90.0, 0.75)
    assert chest_rotation_deg(90.0, 0.625) == pytest.approx(full / 2)
    assert chest_rotation_deg(90.0, 0.50) == 0.0
    assert chest_rotation_deg(90.0, 0.30) == 0.0
    # a step instead of a fade when the fade start is at the table's edge
    assert chest_rotation_deg(90.0, 0.74, fade_start_m=0.75) == 0.0
    # the cap
    assert chest_rotation_deg(170.0, 0.85, max_deg=45.0) == 45.0


def test_arrays_in_arrays_out():
    out = chest_rotation_deg(np.array([0.0, 90.0, 120.0]), np.array([0.8, 0.8, 0.75]))
    np.testing.assert_allclose(out, [0.0, 0.475 * 90 - 22.8, 33.3])


def test_reach_distance_is_scaled_by_arm_length():
    s = Settings()
    # A target straight out to the side, 0.78 m from the spine axis, for the Table 1
    # subject (arm 0.58 m), and the same target scaled for a figure twice as big.
    small = body_rotation_deg(np.array([0.78, 0.0, 0.0]), 0.58, s)
    big = body_rotation_deg(np.array([1.56, 0.0, 0.0]), 1.16, s)
    assert small == pytest.approx(big) and small > 0
    assert small == pytest.approx(chest_rotation_deg(90.0, 0.78))
    arrays = body_rotation_deg(np.array([[0.78, 0.0, 0.0], [0.0, 0.78, 0.0]]), 0.58, s)
    np.testing.assert_allclose(arrays, [small, 0.0])
    assert body_rotation_deg(np.array([0.78, 0.0, 0.0]), 0.58, s.replace(chest_rotation=False)) == 0


def test_chest_turns_toward_the_reaching_side_about_the_spine():
    shoulder = np.array([0.19, 0.0, 0.05])
    turned = rotate_about_spine(shoulder, 30.0)
    # facing turns toward +x, so the reaching-side shoulder swings back, height unchanged
    assert turned[1] < 0 and turned[2] == pytest.approx(0.05)
    assert np.linalg.norm(turned[:2]) == pytest.approx(0.19)
    forward = rotate_about_spine(np.array([0.0, 1.0, 0.0]), 30.0)
    np.testing.assert_allclose(forward, [np.sin(np.radians(30)), np.cos(np.radians(30)), 0], atol=1e-12)


def test_chest_path_hands_over_from_the_start_rotation_to_table_1():
    from reach_addon.core.torso import ChestPath

    s = Settings()
    start = np.array([0.66, 0.0, -0.3])          # an A-posed arm: Table 1 already wants a turn
    target = np.array([0.70, 0.45, 0.1])
    path = ChestPath(0.58, s, start, 0.0, target)
    assert body_rotation_deg(start, 0.58, s) > 5.0
    assert path(start) == pytest.approx(0.0)                     # consistent with the rig
    assert path(target) == pytest.approx(body_rotation_deg(target, 0.58, s))
    line = start + np.linspace(0, 1, 201)[:, None] * (target - start)
    values = np.array([path(p) for p in line])
    assert np.abs(np.diff(values)).max() < 1.0                   # no jump along the way
    # phased: the chest keeps its start rotation until the wrist is chest_phase_delay of
    # the way to the target, then follows the minimum-jerk profile of the rest
    theta0 = body_rotation_deg(start, 0.58, s)
    agreeing = ChestPath(0.58, s, start, theta0, target)
    progress = 1.0 - np.linalg.norm(line - target, axis=1) / np.linalg.norm(start - target)
    early = int(np.flatnonzero(progress < 0.9 * s.chest_phase_delay)[-1])
    assert agreeing(line[early]) == pytest.approx(theta0)
    mid = line[150]
    p = (progress[150] - s.chest_phase_delay) / (1.0 - s.chest_phase_delay)
    recruited = 10 * p**3 - 15 * p**4 + 6 * p**5
    assert agreeing(mid) == pytest.approx(theta0 + (body_rotation_deg(mid, 0.58, s) - theta0)
                                          * recruited)
    assert agreeing(target) == pytest.approx(body_rotation_deg(target, 0.58, s))
