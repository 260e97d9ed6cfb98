"""The hips moving back as the trunk leans (``core.hips``), on hand-built bodies: each figure
is checked by its own geometry (distances, the margin read again), not by the formulas."""

import numpy as np
import pytest

from reach_addon.core.balance import balance_margin, polygon_of
from reach_addon.core.hips import (STRAIGHT_SHARE, hips_drop, hips_shift, lean_and_shift,
                                   shifted_centre, two_bone_knee)
from reach_addon.core.lean import rotate_about, lean_axis

UP = np.array([0.0, 0.0, 1.0])
#: Two feet side by side: the support polygon from 0.08 behind the ankles to 0.18 ahead.
FEET = polygon_of([(-0.08, -0.15, 0.0), (0.18, -0.15, 0.0), (0.18, 0.15, 0.0),
                   (-0.08, 0.15, 0.0)], UP)


def test_the_knee_meets_both_bones_on_the_poles_side():
    hip, ankle = np.array([0.0, 0.1, 0.9]), np.array([0.05, 0.1, 0.08])
    knee = two_bone_knee(hip, ankle, 0.45, 0.42, pole=(1.0, 0.0, 0.0))
    assert np.linalg.norm(knee - hip) == pytest.approx(0.45)
    assert np.linalg.norm(knee - ankle) == pytest.approx(0.42)
    line = (ankle - hip) / np.linalg.norm(ankle - hip)
    off = (knee - hip) - ((knee - hip) @ line) * line
    assert off[0] > 0.0                                    # bent forward, toward the pole


def test_a_hip_too_far_from_its_ankle_drops_to_a_leg_just_short_of_straight():
    hip, ankle = np.array([-0.3, 0.0, 0.92]), np.array([0.0, 0.0, 0.08])
    eta = hips_drop(hip, ankle, 0.45, 0.42, UP)
    assert eta > 0.0
    assert np.linalg.norm(hip - eta * UP - ankle) == pytest.approx(STRAIGHT_SHARE * 0.87)
    assert hips_drop(hip - eta * UP, ankle, 0.45, 0.42, UP) == pytest.approx(0.0, abs=1e-9)


def test_the_least_shift_brings_the_margin_and_no_less_does():
    com = np.array([0.25, 0.0, 1.0])                        # 0.07 past the toes
    h = np.array([1.0, 0.0, 0.0])
    delta = hips_shift(com, FEET, UP, h, planted_share=0.1, margin=0.03, most=0.5)
    assert delta is not None and delta > 0.0
    at = balance_margin(shifted_centre(com, h, delta, 0.1), FEET, UP)
    assert at == pytest.approx(0.03, abs=1e-6)
    assert balance_margin(shifted_centre(com, h, 0.98 * delta, 0.1), FEET, UP) < 0.03
    # moved back by the carried share only: (0.25 - 0.15) / 0.9
    assert delta == pytest.approx(0.10 / 0.9, abs=1e-6)
    assert hips_shift(com, FEET, UP, h, 0.1, 0.03, most=0.05) is None
    assert hips_shift(np.array([0.0, 0.0, 1.0]), FEET, UP, h, 0.1, 0.03, 0.5) == 0.0


def test_lean_and_shift_reach_the_target_with_the_body_over_its_feet():
    pivot, shoulder = np.array([0.0, 0.0, 1.0]), np.array([0.0, -0.2, 1.45])
    trunk = np.array([0.0, 0.0, 1.4])                      # the leaning part's own centre
    target, reach = np.array([0.75, -0.2, 1.1]), 0.62
    feet = polygon_of([(-0.08, -0.15, 0.0), (0.12, -0.15, 0.0), (0.12, 0.15, 0.0),
                       (-0.08, 0.15, 0.0)], UP)

    def com_of(theta):
        leaned = rotate_about(trunk[None], pivot, lean_axis(pivot, target), theta)[0]
        return 0.7 * leaned + 0.3 * np.array([0.02, 0.0, 0.55])   # trunk; legs and feet

    found = lean_and_shift(shoulder, pivot, target, reach, 45.0, com_of, feet, UP,
                           planted_share=0.15, margin=0.02, most=0.4)
    assert found is not None
    theta, delta = found
    h = (target - pivot) * np.array([1.0, 1.0, 0.0])
    h /= np.linalg.norm(h)
    back = delta * h
    leaned = rotate_about((shoulder - back)[None], pivot - back,
                          lean_axis(pivot - back, target), theta)[0]
    assert np.linalg.norm(target - leaned) <= reach + 1e-6         # it reaches
    com = shifted_centre(com_of(theta), h, delta, 0.15)
    assert balance_margin(com, feet, UP) >= 0.02 - 1e-9            # over the feet
    # the shift is needed: the lean alone leaves the centre of mass short of the margin,
    # and a shift a hundredth less does not keep it
    assert delta > 0.0
    assert balance_margin(com_of(theta), feet, UP) < 0.02
    assert lean_and_shift(shoulder, pivot, target, reach, 45.0, com_of, feet, UP, 0.15,
                          margin=0.02, most=0.99 * delta) is None


def test_a_shifted_lean_carries_the_arm_and_moves_the_pelvis_by_the_shift_alone():
    from geometry import standard_arm
    from reach_addon.core.lean import Lean, leaned_arm

    arm = standard_arm()
    pivot = np.array([0.0, 0.0, float(arm.shoulder[2]) - 0.5 * arm.arm_length])
    shift = np.array([-0.1, 0.02, -0.01]) * arm.arm_length
    lean = Lean(pivot, np.array([0.0, 1.0, 0.0]), 20.0, shift)
    upright = Lean(pivot, np.array([0.0, 1.0, 0.0]), 20.0)
    moved, still = leaned_arm(arm, lean), leaned_arm(arm, upright)
    w = np.asarray(arm.to_world, dtype=float)[:3, :3]
    # the shoulder in the world: leaned as without the shift, then moved by it
    assert np.allclose(moved.to_world_points(moved.shoulder),
                       still.to_world_points(still.shoulder) + w @ shift)
    for a, rest in zip(moved.body_capsules, arm.body_capsules):
        if not a.turns_with_chest:       # the pelvis: where it was, moved by the shift only
            assert np.allclose(moved.to_world_points(np.asarray(a.a)),
                               arm.to_world_points(np.asarray(rest.a)) + w @ shift)
    assert any(not c.turns_with_chest for c in arm.body_capsules)
