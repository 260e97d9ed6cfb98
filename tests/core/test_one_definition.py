"""Where a formula has a fast path beside its definition (floats for the pose the planner
tries, arrays for many), the fast path gives the definition's numbers."""

import math

import numpy as np

from reach_addon.core import Settings
from reach_addon.core.body_capsules import body_capsules_at
from reach_addon.core.arm import (forward_kinematics, hand_angles, hand_basis, hand_coefficients,
                                  hand_direction, hand_direction_floats)
from reach_addon.core.collision import Obstacles
from reach_addon.core.generator import ConfigurationGenerator
from reach_addon.core.limits import twist_change
from reach_addon.core.torso import rotate_about_spine
from reach_addon.samples import standard_arm


def random_poses(arm, rng, n=60):
    s = Settings()
    configs = np.column_stack([rng.uniform(-40, 40, n), rng.uniform(s.alpha_min, s.alpha_max, n),
                               rng.uniform(s.beta_min, s.beta_max, n),
                               rng.uniform(s.gamma_min, s.gamma_max, n),
                               rng.uniform(5, s.elbow_max, n)])
    joints, bends = forward_kinematics(arm, configs)
    return joints, bends


def test_the_hand_direction_is_one_formula_everywhere():
    """d = f cos β_w cos σ_w + p sin β_w cos σ_w + h sin σ_w, h = u × b / |u × b|,
    p = h × f — written here from the definition, against every path that computes it."""
    arm = standard_arm()
    rng = np.random.default_rng(11)
    joints, bends = random_poses(arm, rng)
    gen = ConfigurationGenerator(arm, Obstacles(None), Settings())
    for j, b in zip(joints, bends):
        u = (j[2] - j[1]) / np.linalg.norm(j[2] - j[1])
        f = (j[3] - j[2]) / np.linalg.norm(j[3] - j[2])
        h = np.cross(u, b)
        h /= np.linalg.norm(h)
        p = np.cross(h, f)
        wb, ws = rng.uniform(-70, 70), rng.uniform(-30, 30)
        rb, rs = math.radians(wb), math.radians(ws)
        expected = f * math.cos(rb) * math.cos(rs) + p * math.sin(rb) * math.cos(rs) + h * math.sin(rs)
        np.testing.assert_allclose(hand_direction(u, b, f, wb, ws), expected, atol=1e-12)
        np.testing.assert_allclose(hand_direction_floats(u.tolist(), b.tolist(), f.tolist(), wb, ws),
                                   expected, atol=1e-12)
        np.testing.assert_allclose(np.array(hand_coefficients(wb, ws)) @ gen.hand_axes(j, b),
                                   expected, atol=1e-12)
        np.testing.assert_allclose(np.array(hand_basis(u.tolist(), b.tolist(), f.tolist())),
                                   np.array([f, p, h]), atol=1e-12)
        np.testing.assert_allclose(hand_angles(u, b, f, expected), (wb, ws), atol=1e-9)


def test_the_chest_turns_the_body_capsules_by_one_rotation():
    arm = standard_arm()
    assert any(c.turns_with_chest for c in arm.body_capsules)
    assert any(not c.turns_with_chest for c in arm.body_capsules)
    for body in (0.0, 17.5, -42.0, 90.0):
        floats = body_capsules_at(arm, body)
        for c, (a, b, mid, half, r) in zip(arm.body_capsules, floats):
            ea = rotate_about_spine(c.a, body) if c.turns_with_chest else c.a
            eb = rotate_about_spine(c.b, body) if c.turns_with_chest else c.b
            np.testing.assert_allclose(a, ea, atol=1e-12)
            np.testing.assert_allclose(b, eb, atol=1e-12)
            np.testing.assert_allclose(mid, 0.5 * (ea + eb), atol=1e-12)
            assert abs(half - 0.5 * np.linalg.norm(ea - eb)) < 1e-12 and r == c.radius


def test_the_twist_change_is_the_short_way_round():
    rng = np.random.default_rng(5)
    gamma = rng.uniform(-720, 720, 500)
    previous = rng.uniform(-180, 180, 500)
    change = twist_change(gamma, previous)
    # the least |γ - γ_prev + 360 k| over whole turns k
    expected = np.min(np.abs(gamma[:, None] - previous[:, None] + 360.0 * np.arange(-4, 5)), axis=1)
    np.testing.assert_allclose(change, expected, atol=1e-9)
    assert twist_change(179.0, -179.0) == 2.0
