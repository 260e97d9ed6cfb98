"""The strength model: the paper's curves by hand, the derived minima, the three levels."""

import numpy as np
import pytest

from reach_addon.core import Settings, strength
from reach_addon.core.strength import (S_H_MIN, S_V_MIN, f_e, f_h, f_r, f_s, f_t, f_v,
                                       rank_order, scores, strength_horizontal,
                                       strength_vertical)


@pytest.mark.parametrize("alpha, expected", [
    (-60.0, 65 + 0.33 * -60),   # first branch, its lower end
    (-30.0, 55.1),              # 65 + 0.33·(-30)
    (0.0, 65.0),                # second branch starts at 0
    (45.0, 54.65),              # 65 - 0.23·45
    (90.0, 44.3),               # 90 belongs to the second branch
    (120.0, 40.8),              # 54 - 0.11·120
    (180.0, 34.2),
])
def test_s_h_by_hand(alpha, expected):
    assert strength_horizontal(alpha) == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize("beta, expected", [
    (-60.0, 9.086),             # 56.666 + 0.793·(-60)
    (-45.0, 20.981),            # 56.666 + 0.793·(-45)
    (-30.0, 32.872),            # -30 belongs to the middle branch: 65.752 - 32.88
    (-15.0, 49.312),            # 65.752 + 1.096·(-15)
    (0.0, 65.752),
    (60.0, 38.90308),           # 65.752 - 30.8298 + 3.98088
    (120.0, 20.015920),         # 65.752 - 61.6596 + 15.92352
    (180.0, 9.09052),           # 65.752 - 92.4894 + 35.82792
])
def test_s_v_by_hand(beta, expected):
    assert strength_vertical(beta) == pytest.approx(expected, abs=1e-6)


def test_curves_take_and_return_arrays():
    a = np.array([-30.0, 45.0, 120.0])
    out = strength_horizontal(a)
    assert isinstance(out, np.ndarray) and out.shape == (3,)
    np.testing.assert_allclose(out, [55.1, 54.65, 40.8])
    np.testing.assert_allclose(strength_vertical(np.array([[-15.0, 60.0]])), [[49.312, 38.90308]])
    assert isinstance(strength_horizontal(45.0), float)


def test_minima_are_derived_from_the_curves():
    # S_H is least at 180° (34.2); S_V at -60° (9.086), a hair below its value at 180°.
    assert S_H_MIN == pytest.approx(34.2)
    assert S_V_MIN == pytest.approx(9.086)
    grid = np.linspace(-60, 180, 24001)
    assert S_H_MIN == pytest.approx(strength_horizontal(grid).min())
    assert S_V_MIN == pytest.approx(strength_vertical(grid).min())


def test_preferred_levels_default_to_strength_at_60_degrees():
    s = Settings()
    assert s.preferred_level_h == pytest.approx(51.2)
    assert s.preferred_level_v == pytest.approx(38.90308)


def test_first_level_counts_weak_directions():
    lh, lv = 51.2, 38.9
    assert f_h(30.0, lh) == 0 and f_h(90.0, lh) == 1
    assert f_v(30.0, lv) == 0 and f_v(100.0, lv) == 1
    np.testing.assert_array_equal(f_r(np.array([10.0, 90.0, 90.0]), np.array([10.0, 10.0, 100.0]),
                                      lh, lv), [0, 1, 2])


def test_exertion_weights_each_degree_of_freedom():
    assert f_e(10, 20, 30, 0, 0, 0, 1.0, 2.0, 3.0) == pytest.approx(10 + 40 + 90)
    assert f_e(-10, 0, 0, 10, 0, 0, 1.0, 1.0, 1.0) == pytest.approx(20)


def test_f_s_and_f_t():
    lh, lv = 51.2, 38.9
    # α = 120: S_H = 40.8, f_S = (51.2 - 40.8)/(51.2 - 34.2)
    assert f_s(120.0, 0.0, lh, lv) == pytest.approx(10.4 / 17.0)
    # β = 120 only: S_V = 20.01592, f_S = (38.9 - 20.01592)/(38.9 - 9.086)
    assert f_s(0.0, 120.0, lh, lv) == pytest.approx((38.9 - 20.01592) / (38.9 - 9.086))
    fa, fb = 10.4 / 17.0, (38.9 - 20.01592) / (38.9 - 9.086)
    assert f_t(120.0, 120.0, lh, lv) == pytest.approx(fa + fb - fa * fb)


def test_ranking_orders_by_f_r_then_second_level():
    s = Settings()
    alpha = np.array([100.0, 10.0, 120.0, 20.0, 150.0])
    beta = np.array([10.0, 10.0, 120.0, 5.0, 10.0])
    gamma = np.zeros(5)
    level, second = scores(alpha, beta, gamma, (0.0, 0.0, 0.0), s)
    np.testing.assert_array_equal(level, [1, 0, 2, 0, 1])
    order = rank_order(level, second)
    # f_R = 0 first, least exertion first (20+5 = 25 > 10+10 = 20); then f_R = 1 by f_S
    # (α = 100 is stronger than α = 150); then f_R = 2.
    assert order.tolist() == [1, 3, 0, 4, 2]


def test_scalar_and_array_scores_agree():
    s = Settings()
    rng = np.random.default_rng(3)
    a, b, g = rng.uniform(-60, 180, 50), rng.uniform(-60, 180, 50), rng.uniform(-90, 90, 50)
    level, second = scores(a, b, g, (5.0, 10.0, -3.0), s)
    for i in range(50):
        lv, sv = scores(float(a[i]), float(b[i]), float(g[i]), (5.0, 10.0, -3.0), s)
        assert lv == level[i] and sv == pytest.approx(second[i])


def test_prefer_side_is_a_first_key():
    level = np.array([0, 0])
    second = np.array([5.0, 1.0])
    assert rank_order(level, second).tolist() == [1, 0]
    assert rank_order(level, second, np.array([True, False])).tolist() == [1, 0]
    assert rank_order(level, second, np.array([False, True])).tolist() == [0, 1]


# --- the two readings of α and β --------------------------------------------------------------

def _raised(elevation_deg, toward):
    """Upper-arm direction (chest frame, x to the arm's side, y forward, z up) raised by
    ``elevation_deg`` from hanging toward the side or the front."""
    e = np.radians(elevation_deg)
    horizontal = np.array([1.0, 0.0]) if toward == "sideways" else np.array([0.0, 1.0])
    return np.array([*(np.sin(e) * horizontal), -np.cos(e)])


def _documented_table():
    """The f_R table in strength_angles' docstring: {(elevation, toward): (split, horizontal)}."""
    rows = {}
    for line in strength.strength_angles.__doc__.splitlines():
        words = line.split()
        if len(words) == 4 and words[1] in ("sideways", "forward") and words[0].endswith("°"):
            rows[(float(words[0][:-1]), words[1])] = (int(words[2]), int(words[3]))
    return rows


def test_both_readings_as_documented():
    """The docstring's table of f_R under each reading is what the code computes, from the
    upper arm's direction through the arm module's own angle convention."""
    from reach_addon.core.arm import shoulder_angles

    table = _documented_table()
    assert set(table) == {(e, t) for e in (60.0, 90.0) for t in ("sideways", "forward")}
    for (elevation, toward), expected in table.items():
        alpha, beta = (float(x) for x in shoulder_angles(_raised(elevation, toward)))
        got = tuple(int(strength.strength_category(alpha, beta,
                                                   Settings(strength_reading=reading)))
                    for reading in ("split", "horizontal"))
        assert got == expected, (elevation, toward)
    assert table[(90.0, "sideways")] == (1, 2)          # the readings do differ


def test_the_split_reading_is_continuous_where_the_arm_hangs():
    """Why split is the default: swinging a nearly hanging arm by a degree changes nothing
    under split, but moves S_H across its whole range under the horizontal reading."""
    from reach_addon.core.arm import shoulder_angles

    swings = [np.array([np.sin(np.radians(1.0)) * np.cos(p), np.sin(np.radians(1.0)) * np.sin(p),
                        -np.cos(np.radians(1.0))]) for p in np.radians(np.arange(0, 360, 30))]
    split, horizontal = [], []
    for u in swings:
        alpha, beta = (float(x) for x in shoulder_angles(u))
        split.append(strength_horizontal(strength.strength_angles(alpha, beta, "split")[0]))
        horizontal.append(strength_horizontal(
            strength.strength_angles(alpha, beta, "horizontal")[0]))
    assert max(split) - min(split) < 0.5
    assert max(horizontal) - min(horizontal) > 20.0


def test_the_reading_reaches_the_planner_float_and_array_paths_alike():
    """ik.solve scores one wrist with floats and many with arrays; under the horizontal
    reading both give the f_R of strength_category at the angles they return."""
    from reach_addon.core.ik import solve
    from reach_addon.samples import standard_arm

    arm = standard_arm()
    s = Settings(strength_reading="horizontal")
    rng = np.random.default_rng(5)
    wrists = arm.shoulder + rng.uniform(-0.5, 0.5, (12, 3)) * arm.arm_length
    many = solve(arm, wrists, s)
    checked = 0
    for i, w in enumerate(wrists):
        one = solve(arm, w[None], s)
        valid = np.flatnonzero(one.valid[0])
        if not len(valid):
            continue
        expected = strength.strength_category(one.alpha[0, valid], one.beta[0, valid], s)
        np.testing.assert_array_equal(np.asarray(one.f_r)[0, valid], expected)
        np.testing.assert_array_equal(np.asarray(many.f_r)[i, valid], expected)
        checked += 1
    assert checked >= 6
    split = solve(arm, wrists, Settings())
    assert not np.array_equal(np.asarray(split.f_r)[split.valid], np.asarray(many.f_r)[many.valid])
