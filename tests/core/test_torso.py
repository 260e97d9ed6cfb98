"""Table 1: chest rotation from reach direction, and the shoulder carried by it."""

import numpy as np
import pytest

from reach_addon.core import Settings
from reach_addon.core.torso import (body_rotation_deg, chest_rotation_deg, rotate_about_spine,
                                    starting_angle_deg, table1_coefficients, table1_distance)


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


def test_outside_the_rows_the_regression_is_extrapolated():
    # the same straight lines in distance: nearer targets start turning at a larger
    # direction (the paper: "the starting rotation degree varies according to the target
    # distance"), farther ones sooner; no fade to zero
    assert starting_angle_deg(0.65) == pytest.approx(34.5 / 0.55)
    assert starting_angle_deg(0.45) == pytest.approx(50.1 / 0.65)
    assert starting_angle_deg(0.95) == pytest.approx(11.1 / 0.40)
    assert chest_rotation_deg(90.0, 0.65) == pytest.approx(0.55 * 90 - 34.5)
    assert chest_rotation_deg(150.0, 0.30) == pytest.approx(0.725 * 150 - 61.8)
    assert chest_rotation_deg(90.0, 0.95) == pytest.approx(0.40 * 90 - 11.1)
    # monotone in direction at every distance, continuous across the rows
    for d in (0.2, 0.5, 0.75, 0.8, 0.85, 1.0):
        values = chest_rotation_deg(np.linspace(-180, 180, 361), np.full(361, d))
        assert np.all(np.diff(values) >= 0)
    near = [chest_rotation_deg(120.0, d) for d in (0.7499999, 0.75, 0.8500001, 0.85)]
    assert near[0] == pytest.approx(near[1]) and near[2] == pytest.approx(near[3])
    # far beyond the table the starting angle stays at 0: straight ahead never turns
    assert chest_rotation_deg(0.0, 1.6) == 0.0 and starting_angle_deg(1.6) == 0.0
    # the cap
    assert chest_rotation_deg(170.0, 0.85, max_deg=45.0) == 45.0


def test_arrays_in_arrays_out():
    out = chest_rotation_deg(np.array([0.0, 90.0, 120.0]), np.array([0.8, 0.8, 0.75]))
    np.testing.assert_allclose(out, [0.0, 0.475 * 90 - 22.8, 33.3])


def test_reach_distance_is_measured_to_the_hand_and_scaled_by_arm_length():
    s = Settings()
    # The standard adult (arm 0.58 m, hand 0.19 m) with its wrist 0.56 m straight out to
    # the side: its fingertips are 0.75 m out, and it reads Table 1's 75 cm row.
    adult = body_rotation_deg(np.array([0.56, 0.0, 0.0]), 0.58, 0.19, s)
    assert adult == pytest.approx(0.50 * 90 - 26.7)
    # the 85 cm row: wrist 0.66 m out
    assert body_rotation_deg(np.array([0.0, -0.66, 0.0]) @ np.array(
        [[0, -1, 0], [1, 0, 0], [0, 0, 1]]).T, 0.58, 0.19, s) == pytest.approx(0.45 * 90 - 18.9)
    # a figure twice as big reads the same rows at twice the distance
    big = body_rotation_deg(np.array([1.12, 0.0, 0.0]), 1.16, 0.38, s)
    assert big == pytest.approx(adult)
    # the hand point is a setting: at the wrist (0) the same wrist is 0.56 m out
    at_wrist = body_rotation_deg(np.array([0.56, 0.0, 0.0]), 0.58, 0.19,
                                 s.replace(table1_hand_point=0.0))
    assert at_wrist == pytest.approx(chest_rotation_deg(90.0, 0.56))
    assert table1_distance(0.56, 0.58, 0.19, s.replace(table1_hand_point=0.4)) == pytest.approx(
        0.56 + 0.4 * 0.19)
    arrays = body_rotation_deg(np.array([[0.56, 0.0, 0.0], [0.0, 0.56, 0.0]]), 0.58, 0.19, s)
    np.testing.assert_allclose(arrays, [adult, 0.0])
    assert body_rotation_deg(np.array([0.56, 0.0, 0.0]), 0.58, 0.19,
                             s.replace(chest_rotation=False)) == 0


def test_table1_applies_to_reachable_wrists_of_the_standard_figure_as_its_rows_do():
    """With the wrist scaled to a 0.58 m arm and a fade below 75 cm, 14% of the reachable
    wrist positions got any chest rotation where Table 1's rows give it to over half. Over
    random reachable wrists of the standard figure, the share that turns the chest now
    agrees with the rows' (direction past their starting angles), and a wrist 0.60 m out
    reads close to the 75 cm row."""
    from reach_addon.core.torso import reach_direction_deg
    from reach_addon.samples import standard_arm

    arm, s = standard_arm(), Settings()
    rng = np.random.default_rng(3)
    u = rng.normal(size=(20000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    radius = arm.arm_length * rng.uniform(0.0, 1.0, 20000) ** (1 / 3)
    wrists = arm.shoulder + u * radius[:, None]
    turned = np.mean(body_rotation_deg(wrists, arm.arm_length, arm.hand_length, s) > 0)
    direction = reach_direction_deg(wrists)
    rows = np.mean(direction > starting_angle_deg(0.75)), np.mean(direction > starting_angle_deg(0.85))
    assert rows[0] - 0.1 < turned < rows[1] + 0.02
    for direction_deg, row75 in ((90.0, 18.3), (120.0, 33.3)):
        t = np.radians(direction_deg)
        wrist = np.array([0.60 * np.sin(t), 0.60 * np.cos(t), 0.0])
        assert body_rotation_deg(wrist, arm.arm_length, arm.hand_length, s) == pytest.approx(
            row75, abs=2.0)


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
    path = ChestPath(0.58, 0.19, s, start, 0.0, target)
    assert body_rotation_deg(start, 0.58, 0.19, s) > 5.0
    assert path(start) == pytest.approx(0.0)                     # consistent with the rig
    assert path(target) == pytest.approx(body_rotation_deg(target, 0.58, 0.19, s))
    line = start + np.linspace(0, 1, 201)[:, None] * (target - start)
    values = np.array([path(p) for p in line])
    assert np.abs(np.diff(values)).max() < 1.0                   # no jump along the way
    # phased: the chest keeps its start rotation until the wrist is chest_phase_delay of
    # the way to the target, then follows the minimum-jerk profile of the rest
    theta0 = body_rotation_deg(start, 0.58, 0.19, s)
    agreeing = ChestPath(0.58, 0.19, s, start, theta0, target)
    progress = 1.0 - np.linalg.norm(line - target, axis=1) / np.linalg.norm(start - target)
    early = int(np.flatnonzero(progress < 0.9 * s.chest_phase_delay)[-1])
    assert agreeing(line[early]) == pytest.approx(theta0)
    mid = line[150]
    p = (progress[150] - s.chest_phase_delay) / (1.0 - s.chest_phase_delay)
    recruited = 10 * p**3 - 15 * p**4 + 6 * p**5
    assert agreeing(mid) == pytest.approx(theta0 + (body_rotation_deg(mid, 0.58, 0.19, s) - theta0)
                                          * recruited)
    assert agreeing(target) == pytest.approx(body_rotation_deg(target, 0.58, 0.19, s))
