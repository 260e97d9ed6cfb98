"""The shoulder angle convention, forward kinematics and the analytic IK."""

import numpy as np
import pytest
from hypothesis import assume, given, settings as hyp_settings, strategies as st

from geometry import HANGING, standard_arm
from reach_addon.core import ArmConfig, ArmModel, ReachError, Settings, forward_kinematics
from reach_addon.core.arm import (REACH_SLACK, bend_direction, config_from_joints, shoulder_angles,
                                  reach_sphere, twist_angle, upper_arm_direction)
from reach_addon.core.ik import solve
from reach_addon.core.limits import move_limits, on_elbow_side


@pytest.mark.parametrize("direction, alpha, beta", [
    ((0, 0, -1), 0, 0),        # hanging
    ((1, 0, 0), 90, 0),        # straight out to the side
    ((0, 1, 0), 0, 90),        # straight forward
    ((0, -1, 0), 0, -90),      # straight back
    ((-1, 0, 0), -90, 0),      # across the body
])
def test_canonical_directions(direction, alpha, beta):
    a, b = shoulder_angles(np.array(direction, float))
    assert (float(a), float(b)) == (pytest.approx(alpha, abs=1e-9), pytest.approx(beta, abs=1e-9))


def test_overhead_is_180_by_either_route():
    eps = 1e-6
    a, b = shoulder_angles(np.array([eps, 0, 1.0]) / np.linalg.norm([eps, 0, 1.0]))
    assert float(a) == pytest.approx(180, abs=1e-3) and float(b) == pytest.approx(0, abs=1e-3)
    a, b = shoulder_angles(np.array([0, eps, 1.0]) / np.linalg.norm([0, eps, 1.0]))
    assert float(a) == pytest.approx(0, abs=1e-3) and float(b) == pytest.approx(180, abs=1e-3)


def test_angles_round_trip_to_directions():
    rng = np.random.default_rng(0)
    u = rng.normal(size=(2000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    u = u[np.degrees(np.arccos(-u[:, 2])) < 179]
    a, b = shoulder_angles(u)
    np.testing.assert_allclose(upper_arm_direction(a, b), u, atol=1e-9)


@hyp_settings(max_examples=400, deadline=None)
@given(st.floats(-60, 180), st.floats(-60, 180), st.floats(-1, 1), st.floats(-1, 1),
       st.floats(-1, 1))
def test_no_jump_inside_the_reachable_range(alpha, beta, vx, vy, vz):
    """Nudging the arm's direction by a small angle changes (α, β) by at most the map's
    stretch θ / sin θ times that angle — at most 170° / sin 170° ≈ 17 at the elevation
    limit — so the decomposition has no jump wherever the arm may be."""
    # outside the elevation limit the test says nothing: such examples are discarded
    assume(np.hypot(alpha, beta) <= 170 and np.linalg.norm([vx, vy, vz]) >= 1e-3)
    u1 = upper_arm_direction(alpha, beta)
    u2 = u1 + 0.01 * np.array([vx, vy, vz]) / np.linalg.norm([vx, vy, vz])
    u2 /= np.linalg.norm(u2)
    assume(np.degrees(np.arccos(-u2[2])) <= 170)
    a1, b1 = shoulder_angles(u1)
    a2, b2 = shoulder_angles(u2)
    # the angle between them by atan2 (arccos loses it below ~1e-6° near 1)
    moved = np.degrees(np.arctan2(np.linalg.norm(np.cross(u1, u2)), u1 @ u2))
    assert np.hypot(a2 - a1, b2 - b1) <= 17.5 * moved + 1e-6


def test_twist_convention():
    down = np.array([0.0, 0.0, -1.0])
    assert float(twist_angle(down, np.array([0.0, 1.0, 0.0]))) == pytest.approx(0)
    # internal rotation swings a hanging arm's forearm across the belly (toward -x)
    assert float(twist_angle(down, np.array([-1.0, 0.0, 0.0]))) == pytest.approx(90)
    side = np.array([1.0, 0.0, 0.0])
    assert float(twist_angle(side, np.array([0.0, 1.0, 0.0]))) == pytest.approx(0)
    assert float(twist_angle(side, np.array([0.0, 0.0, -1.0]))) == pytest.approx(90)   # forearm down
    assert float(twist_angle(side, np.array([0.0, 0.0, 1.0]))) == pytest.approx(-90)   # goal post
    u = upper_arm_direction(40.0, 70.0)
    for g in (-80.0, -10.0, 0.0, 35.0, 85.0):
        assert float(twist_angle(u, bend_direction(u, g))) == pytest.approx(g)


def test_forward_kinematics_of_named_poses():
    arm = standard_arm()
    joints, _ = forward_kinematics(arm, np.array([0.0, 90.0, 0.0, 0.0, 0.0]))
    np.testing.assert_allclose(joints[3], arm.shoulder + [arm.arm_length, 0, 0], atol=1e-12)
    joints, _ = forward_kinematics(arm, np.array([0.0, 0.0, 90.0, 0.0, 90.0]))
    # arm forward, elbow bent 90° with no twist: forearm points up
    np.testing.assert_allclose(joints[2], arm.shoulder + [0, arm.upper_arm_length, 0], atol=1e-12)
    np.testing.assert_allclose(joints[3], joints[2] + [0, 0, arm.forearm_length], atol=1e-12)


reachable_points = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1),
                             st.floats(0.45, 0.99))


@hyp_settings(max_examples=150, deadline=None)
@given(reachable_points)
def test_every_candidate_puts_the_wrist_on_the_target(sample):
    """FK of every legal IK candidate reproduces the wrist to 1e-6 arm lengths. A wrist
    with no legal candidate (about 3 in 10 of the samples: behind the body, or where the
    joint limits leave no pose) checks nothing, so it is discarded."""
    arm = standard_arm()
    s = Settings()
    x, y, z, r = sample
    direction = np.array([x, y, z])
    assume(np.linalg.norm(direction) >= 1e-3)
    wrist = arm.shoulder + direction / np.linalg.norm(direction) * r * arm.arm_length
    sol = solve(arm, wrist[None], s)
    legal = np.flatnonzero(sol.legal[0])
    assume(len(legal) > 0)
    for k in legal:
        c = sol.config(0, k)
        joints, _ = forward_kinematics(arm, c.as_array())
        assert np.linalg.norm(joints[3] - wrist) <= 1e-6 * arm.arm_length
        assert np.linalg.norm(joints[2] - sol.joints(0, k)[0, 2]) <= 1e-6 * arm.arm_length
        assert s.alpha_min <= c.alpha <= s.alpha_max and s.beta_min <= c.beta <= s.beta_max
        assert s.gamma_min <= c.gamma <= s.gamma_max and s.elbow_min <= c.elbow <= s.elbow_max


def test_swivel_samples_cover_the_circle():
    arm = standard_arm()
    wrist = arm.shoulder + np.array([0.2, 0.3, -0.1])
    sol = solve(arm, wrist[None], Settings(swivel_step=10.0))
    assert sol.alpha.shape == (1, 36)
    elbows = sol.joints(0, np.arange(36))[:, 2]
    # all on one circle around the shoulder-wrist axis, at the upper arm's length
    np.testing.assert_allclose(np.linalg.norm(elbows - arm.shoulder, axis=1), arm.upper_arm_length)
    np.testing.assert_allclose(np.linalg.norm(wrist - elbows, axis=1), arm.forearm_length)


def test_unreachable_wrist_has_no_candidates():
    arm = standard_arm()
    far = arm.shoulder + np.array([0.0, 1.2 * arm.arm_length, 0.0])
    sol = solve(arm, far[None], Settings())
    assert not sol.reachable[0] and not sol.legal.any()
    near = arm.shoulder + np.array([0.0, 0.05, 0.0])   # needs more than 150° of elbow flexion
    assert not solve(arm, near[None], Settings()).legal.any()


def test_required_side_keeps_only_preferred_elbows():
    arm = standard_arm()
    wrist = arm.shoulder + np.array([0.0, 0.45, 0.0])
    required = solve(arm, wrist[None], Settings())
    free = solve(arm, wrist[None], Settings(elbow_side="off"))
    assert required.legal.sum() < free.legal.sum()
    assert not required.wrong_side[required.legal].any()
    # every kept elbow is on the n̂ side of the plane through wrist, shoulder and waist,
    # n̂ = (s - w) × (a - s): outward and down for this forward reach
    n = np.cross(arm.shoulder - wrist, arm.waist - arm.shoulder)
    assert n[0] > 0 and n[2] < 0
    elbows = required.joints(0, np.flatnonzero(required.legal[0]))[:, 2]
    assert ((elbows - arm.shoulder) @ n > 0).all()
    dropped = free.joints(0, np.flatnonzero(free.legal[0] & ~required.legal[0]))[:, 2]
    assert len(dropped) and ((dropped - arm.shoulder) @ n <= 0).all()


def test_smoothness_bound_limits_the_change():
    arm = standard_arm()
    s = Settings()
    start = HANGING
    joints, _ = forward_kinematics(arm, start.as_array())
    wrist = joints[3] + np.array([0.0, 0.01, 0.0])
    sol = solve(arm, wrist[None], s, start, max_change=5.0)
    for k in np.flatnonzero(sol.valid[0]):
        c = sol.config(0, k)
        assert abs(c.alpha - start.alpha) <= 5 and abs(c.beta - start.beta) <= 5
        assert abs(c.elbow - start.elbow) <= 5
    assert sol.valid.sum() < sol.legal.sum()


# --- a start outside the limits: the rig's own pose --------------------------------------

def _t_pose(gamma, elbow):
    """A T-posed arm (straight out to the side) with this twist and elbow flexion."""
    return ArmConfig(0.0, 90.0, 0.0, gamma, elbow)


def test_the_limits_of_a_move_take_in_where_it_starts():
    s = Settings()
    lo, hi = move_limits(s, None)
    assert (lo[2, 0], hi[2, 0]) == (s.gamma_min, s.gamma_max)
    assert move_limits(s, _t_pose(10.0, 9.0))[0] is lo           # inside: the same limits
    lo2, hi2 = move_limits(s, _t_pose(-132.0, 9.0))
    assert lo2[2, 0] == pytest.approx(-132.0) and hi2[2, 0] == s.gamma_max
    assert (lo2[:2] == lo[:2]).all() and (hi2[[0, 1, 3]] == hi[[0, 1, 3]]).all()
    raised = ArmConfig(0.0, 175.0, 0.0, 0.0, 10.0)                # past the elevation limit
    assert move_limits(s, raised)[1][3, 0] == pytest.approx(175.0)


@pytest.mark.parametrize("gamma, elbow", [(-132.0, 9.0), (-179.0, 1.0), (150.0, 1.0)])
def test_a_start_twisted_outside_the_limits_moves_and_comes_back(gamma, elbow):
    """A T-posed arm whose slight bend reads as a twist outside [-90°, 90°] (a straight
    elbow bent backward, a Goblin's 9° bent up): every step away from it has valid poses
    (none did when the limits applied to the start itself), none twisted farther out than
    the start, and the twist comes back toward the legal range as the arm moves."""
    arm, s = standard_arm(), Settings()
    start = _t_pose(gamma, elbow)
    joints, _ = forward_kinematics(arm, start.as_array())
    # forward, a little inward: a straight arm can only bend so far (15°) in one step
    inward = joints[3] + s.step * arm.arm_length * np.array([-0.2, 0.98, 0.0])
    sol = solve(arm, inward[None], s, start, body_rotation=0.0, max_change=s.max_joint_step)
    assert sol.valid[0].any()
    lo, hi = s.gamma_min, s.gamma_max
    out_of_range = np.maximum(lo - sol.gamma[0], sol.gamma[0] - hi)
    start_out = max(lo - gamma, gamma - hi)
    assert (out_of_range[sol.valid[0]] <= start_out + 1e-9).all()
    # a plain solve (no previous pose: the target's own) keeps to the limits
    plain = solve(arm, inward[None], s)
    assert (plain.gamma[0][plain.legal[0]] >= lo - 1e-9).all()
    assert (plain.gamma[0][plain.legal[0]] <= hi + 1e-9).all()


def test_an_elbow_bent_past_its_limit_may_unbend():
    """A start with the elbow flexed 156°, past the 150° limit: a step that opens it a
    little is valid (none was: every wrist that near the shoulder was out of reach), one
    that bends it further is not."""
    arm, s = standard_arm(), Settings()
    start = ArmConfig(0.0, 20.0, 30.0, 0.0, 156.0)
    joints, _ = forward_kinematics(arm, start.as_array())
    out = (joints[3] - joints[1]) / np.linalg.norm(joints[3] - joints[1])
    step = 0.5 * s.step * arm.arm_length
    opened = solve(arm, (joints[3] + step * out)[None], s, start, body_rotation=0.0,
                   max_change=s.max_joint_step)
    assert opened.valid[0].any() and 150.0 < float(opened.flex[0]) < 156.0
    closed = solve(arm, (joints[3] - step * out)[None], s, start, body_rotation=0.0,
                   max_change=s.max_joint_step)
    assert not closed.valid[0].any()
    assert not solve(arm, (joints[3] + step * out)[None], s).legal[0].any()


def test_an_elbow_off_its_side_may_come_back_and_the_side_leads():
    """With ``elbow_side = "require"``, a move from a pose whose elbow is off Algorithm 1's
    side has valid poses on either side, the preferred side ranked first; a move from a
    pose on the side keeps to it."""
    arm, s = standard_arm(), Settings()
    wrist = arm.shoulder + np.array([0.0, 0.45, -0.1])
    free = solve(arm, wrist[None], Settings(elbow_side="off"))
    off = [k for k in np.flatnonzero(free.legal[0]) if free.wrong_side[0, k]]
    on = [k for k in np.flatnonzero(free.legal[0]) if not free.wrong_side[0, k]]
    assert off and on
    start_off, start_on = free.config(0, off[len(off) // 2]), free.config(0, on[len(on) // 2])
    assert not on_elbow_side(arm, start_off) and on_elbow_side(arm, start_on)
    sol = solve(arm, wrist[None], s, start_off, max_change=180.0)
    order = sol.order(0, s.elbow_side)
    assert sol.wrong_side[0, order].any() and not sol.wrong_side[0, order].all()
    sides = sol.wrong_side[0, order]
    assert not sides[:np.count_nonzero(~sides)].any()           # the preferred side first
    kept = solve(arm, wrist[None], s, start_on, max_change=180.0)
    assert not kept.wrong_side[0, kept.valid[0]].any()


def test_reading_a_pose_back_from_joints():
    arm = standard_arm()
    c = ArmConfig(12.0, 35.0, 50.0, 20.0, 60.0)
    joints, _ = forward_kinematics(arm, c.as_array())
    back = config_from_joints(arm, joints[2], joints[3], body_rotation=12.0)
    np.testing.assert_allclose(back.as_array(), c.as_array(), atol=1e-9)


def test_bad_arm_geometry_is_refused():
    with pytest.raises(ReachError, match="zero-length"):
        standard_arm().__class__(**{**_fields(standard_arm()), "forearm_length": 0.0})
    with pytest.raises(ReachError, match="not finite"):
        standard_arm().__class__(**{**_fields(standard_arm()), "shoulder": [np.nan, 0, 0]})


def _fields(arm):
    return {f: getattr(arm, f) for f in arm.__dataclass_fields__}


def test_one_wrist_and_many_wrists_give_the_same_solutions():
    """The IK runs on floats for one wrist and on arrays for many: same numbers."""
    arm = standard_arm()
    s = Settings()
    rng = np.random.default_rng(7)
    wrists = arm.shoulder + rng.uniform(-0.5, 0.5, (40, 3))
    wrists[0] = arm.shoulder + [0.0, 0.0, 0.4]        # straight above the shoulder
    prev = ArmConfig(5.0, 30.0, 40.0, 10.0, 60.0)
    many = solve(arm, wrists, s, prev, max_change=30.0)
    for i, w in enumerate(wrists):
        one = solve(arm, w[None], s, prev, max_change=30.0)
        for name in ("alpha", "beta", "gamma", "legal", "valid", "wrong_side"):
            np.testing.assert_allclose(getattr(one, name)[0], getattr(many, name)[i], atol=1e-9)
        np.testing.assert_allclose(one.body[0], many.body[i])
        np.testing.assert_allclose(one.joints(0, np.arange(5)), many.joints(i, np.arange(5)),
                                   atol=1e-12)
        valid = np.flatnonzero(one.valid[0])
        np.testing.assert_array_equal(one.f_r[0, valid], many.f_r[i, valid])
        np.testing.assert_allclose(one.second[0, valid], many.second[i, valid])
        assert one.order(0, "require").tolist() == many.order(i, "require").tolist()


def test_cross_is_numpys_cross_to_the_last_bit():
    """numeric.cross replaces np.cross in the planner for speed: the same numbers for
    single vectors, stacks and broadcasts, so nothing the planner does changes."""
    from reach_addon.core.numeric import cross

    rng = np.random.default_rng(7)
    shapes = [((3,), (3,)), ((5, 3), (3,)), ((3,), (4, 3)), ((2, 7, 3), (2, 7, 3)),
              ((1, 3), (6, 3))]
    for sa, sb in shapes:
        for scale in (1e-9, 1.0, 1e9):
            a, b = scale * rng.normal(size=sa), rng.normal(size=sb)
            ours, theirs = cross(a, b), np.cross(a, b)
            assert ours.shape == theirs.shape and np.array_equal(ours, theirs), (sa, sb)
    assert np.array_equal(cross([0.0, 0.0, 1.0], [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0])


@pytest.mark.parametrize("make", [
    lambda: standard_arm(),
    # a robot's proportions (forearm 2.4× the upper arm, thick), turned and moved in world
    lambda: ArmModel(np.array([0.02, 0.05, 0.1]), np.array([0.3, -0.04, 0.0]),
                     np.array([0.0, 0.0, -0.6]), 0.58, 1.38, 0.68, 0.09, 0.35, 0.24,
                     to_world=_turned(0.7, (3.0, -2.0, 1.0))),
])
def test_every_pose_lies_inside_the_reach_sphere(make):
    """The sphere the Blender layer leaves far objects out by holds every joint of every
    pose with its skin, for any body rotation and any angles (limits or not), and is not
    loose: a straight arm turned outward comes within the slack of its rim."""
    arm = make()
    centre, radius = reach_sphere(arm, slack=0.0)
    rng = np.random.default_rng(3)
    configs = np.column_stack([rng.uniform(-180, 180, 20000), rng.uniform(-180, 180, 20000),
                               rng.uniform(-180, 180, 20000), rng.uniform(-180, 180, 20000),
                               rng.uniform(0, 180, 20000)])
    joints, _bend = forward_kinematics(arm, configs)
    far = np.linalg.norm(arm.to_world_points(joints) - centre, axis=-1).max()
    skin = max(arm.upper_arm_radius, arm.forearm_radius, arm.hand_radius)
    assert far + skin <= radius + 1e-9
    assert far + skin >= radius - 0.2 * arm.arm_length
    _c, with_slack = reach_sphere(arm)
    assert with_slack == pytest.approx(radius + REACH_SLACK * arm.arm_length)


def _turned(angle, offset):
    m = np.eye(4)
    c, s = np.cos(angle), np.sin(angle)
    m[:2, :2] = [[c, -s], [s, c]]
    m[:3, 3] = offset
    return m
