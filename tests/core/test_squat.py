"""The squat or bend (``core.squat``) on a hand-built figure: the standard arm on a body
with two legs, checked by its own geometry (the law of cosines, the shoulder's distance,
the margin read again), not by the module's formulas."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from geometry import HANGING, standard_arm

from reach_addon.core import OUT_OF_REACH, Settings, Task
from reach_addon.core.balance import balance_margin, polygon_of
from reach_addon.core.lean import Lean, rotate_about
from reach_addon.core.squat import Leg, knee_pole, leg_angles, squat_leans
from reach_addon.core.whole_body import wants_body

UP = np.array([0.0, 0.0, 1.0])
FORWARD = np.array([0.0, -1.0, 0.0])        # the standard figure faces -Y
#: The legs as they stand (world): hips 0.90 up, knees a little forward, ankles 0.08 up.
LEGS = [Leg(np.array([x, 0.0, 0.90]), np.array([x, -0.01, 0.49]), np.array([x, 0.0, 0.08]),
            knee_pole((x, 0.0, 0.90), (x, -0.01, 0.49), (x, 0.0, 0.08), FORWARD))
        for x in (-0.09, 0.09)]
#: Both feet, heels 0.06 behind the ankles, toes 0.18 ahead.
FEET = [(-0.15, 0.06, 0.0), (0.15, 0.06, 0.0), (0.15, -0.18, 0.0), (-0.15, -0.18, 0.0)]
#: What the lean carries (trunk, head, arms) and its share of the mass; the rest stands.
TRUNK_C, TRUNK_SHARE = np.array([0.0, 0.0, -0.15]), 0.68
LEGS_AT = np.array([0.0, 0.0, 0.45])
PLANTED = 0.12


def body(arm, margin=0.02, feet=FEET):
    def com(lean):
        m = np.asarray(arm.to_world, float) @ lean.matrix(1.0)
        return TRUNK_SHARE * (m[:3, :3] @ TRUNK_C + m[:3, 3]) + (1 - TRUNK_SHARE) * LEGS_AT

    return SimpleNamespace(up=UP, polygon=polygon_of(feet, UP), com=com,
                           planted_share=PLANTED, margin=margin, floor=0.0, leg_joints=LEGS)


def floor_target(arm, above=0.12, ahead=0.5):
    """The world target ``above`` arm lengths over the floor (z = 0) and ``ahead`` arm
    lengths in front of the shoulder."""
    s = arm.to_world_points(arm.shoulder)
    return np.array([s[0], s[1] - ahead * arm.arm_length, above * arm.arm_length])


def knee_by_cosines(hip, ankle, thigh, shank) -> float:
    d = float(np.linalg.norm(np.asarray(hip) - np.asarray(ankle)))
    inner = math.degrees(math.acos((thigh ** 2 + shank ** 2 - d ** 2) / (2 * thigh * shank)))
    return 180.0 - inner


def test_a_hip_brought_down_bends_the_knee_as_the_law_of_cosines_says():
    leg = LEGS[0]
    for down in (0.05, 0.2, 0.4):
        shift = np.array([0.0, 0.1, -down])
        knee, ankle, hip = leg_angles(leg, shift, UP)
        assert knee == pytest.approx(knee_by_cosines(leg.hip + shift, leg.ankle, leg.thigh,
                                                     leg.shank), abs=1e-6)
        assert 0.0 < ankle < 90.0 and 0.0 < hip < 180.0
    # deeper is more bent everywhere
    angles = [leg_angles(leg, np.array([0.0, 0.1, -d]), UP) for d in (0.1, 0.3, 0.5)]
    assert all(a[0] < b[0] and a[1] < b[1] and a[2] < b[2] for a, b in zip(angles, angles[1:]))


def test_a_target_near_the_floor_is_reached_by_a_squat_within_every_limit_and_balance():
    arm, settings = standard_arm(), Settings().replace(lean=True)
    target_w = floor_target(arm)
    target = arm.to_canonical_points(target_w)
    b = body(arm)
    found = squat_leans(arm, target, arm.waist, settings, (0.0,), b)
    assert found
    efforts = [q.effort for q in found]
    assert efforts == sorted(efforts)
    reach = settings.lean_reach * arm.arm_length
    w = np.asarray(arm.to_world, float)
    polygon = polygon_of(FEET, UP)
    for q in found[:10]:
        lean = q.lean
        shift = np.asarray(lean.shift)
        assert shift[2] < 0.0                         # the hips came down
        # the shoulder, turned about the pivot and moved with the hips, reaches
        shoulder = rotate_about(arm.shoulder[None], lean.pivot, lean.axis, lean.angle)[0] + shift
        assert np.linalg.norm(shoulder - target) <= reach + 1e-9
        assert lean.angle <= settings.bend_max
        # the knees, by the law of cosines, within their limit
        for leg in LEGS:
            hip = leg.hip + w[:3, :3] @ shift
            assert np.linalg.norm(hip - leg.ankle) < leg.thigh + leg.shank
            assert knee_by_cosines(hip, leg.ankle, leg.thigh, leg.shank) <= settings.knee_max
        assert q.ankle <= settings.ankle_max and q.hip <= settings.hip_max
        assert lean.angle + q.hip <= settings.hip_max + settings.spine_max + 1e-9
        # over the feet: the trunk carried by the lean and moved with the hips, the thighs
        # moved with them, the shanks and feet standing
        back = -(w[:3, :3] @ shift) * np.array([1.0, 1.0, 0.0])
        com = b.com(Lean(lean.pivot, lean.axis, lean.angle)) - (1 - PLANTED) * back
        assert balance_margin(com, polygon, UP) >= b.margin - 1e-9
    # the same every time
    again = squat_leans(arm, target, arm.waist, settings, (0.0,), body(arm))
    assert [(q.lean.angle, tuple(q.lean.shift)) for q in again] == \
        [(q.lean.angle, tuple(q.lean.shift)) for q in found]


def test_stiff_knees_bend_the_trunk_instead_and_none_is_found_past_every_limit():
    arm = standard_arm()
    target = arm.to_canonical_points(floor_target(arm, above=0.5))
    free = squat_leans(arm, target, arm.waist, Settings(), (0.0,), body(arm))
    stiff = squat_leans(arm, target, arm.waist, Settings().replace(knee_max=60.0), (0.0,),
                        body(arm))
    assert free and stiff
    assert max(q.knee for q in stiff) <= 60.0
    assert stiff[0].lean.angle >= free[0].lean.angle - 1e-9
    assert squat_leans(arm, target, arm.waist, Settings().replace(knee_max=5.0, bend_max=40.0),
                       (0.0,), body(arm)) == []


def test_the_hips_keep_pace_with_the_trunk_on_the_way():
    lean = Lean(np.zeros(3), np.array([1.0, 0.0, 0.0]), 60.0, np.array([0.0, -0.2, -0.3]))
    assert lean.shift_share(0.0) == 0.0 and lean.shift_share(1.0) == pytest.approx(1.0)
    # as the trunk's forward reach, the sine of its lean
    assert lean.shift_share(0.5) == pytest.approx(math.sin(math.radians(30)) /
                                                  math.sin(math.radians(60)))
    assert np.allclose(lean.matrix(0.5)[:3, 3] - Lean(lean.pivot, lean.axis, 60.0).matrix(0.5)[:3, 3],
                       lean.shift_share(0.5) * lean.shift)


def test_only_a_low_target_past_the_arm_asks_for_the_body():
    arm = standard_arm()
    settings = Settings().replace(lean=True)
    # a refused plan as the planner gives it: one segment, refused as out of reach
    failed = SimpleNamespace(reason=OUT_OF_REACH, segments=[SimpleNamespace(
        index=0, name="Cup", success=False, reason=OUT_OF_REACH)])

    def task(point):
        return Task("reach", np.asarray(point, float)[None], HANGING)

    low = floor_target(arm)
    high = arm.to_world_points(arm.shoulder) + np.array([0.0, 0.0, 1.2 * arm.arm_length])
    near = arm.to_world_points(arm.shoulder) + np.array([0.0, 0.0, -0.5 * arm.arm_length])
    assert wants_body(settings, task(low), failed, arm)
    assert not wants_body(settings, task(high), failed, arm)
    assert not wants_body(settings, task(near), failed, arm)
    assert not wants_body(settings.replace(squat=False), task(low), failed, arm)
    assert not wants_body(Settings(lean=False), task(low), failed, arm)
