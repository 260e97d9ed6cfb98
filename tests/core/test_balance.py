"""The balance's arithmetic (core.balance): Winter's shares weigh a whole body, the centre of
mass of a figure is where its segments put it, and the margin is the signed distance to
the support polygon's edge, worked out here by hand for squares and rectangles."""

import numpy as np
import pytest

from reach_addon.core import balance

UP = np.array([0.0, 0.0, 1.0])


def test_winter_s_shares_weigh_a_whole_body():
    limbs = ("hand", "forearm", "upper_arm", "foot", "shank", "thigh")
    whole = 2 * sum(balance.WINTER[k][0] for k in limbs) + balance.WINTER["trunk"][0] + \
        balance.WINTER["head_neck"][0]
    assert whole == pytest.approx(1.0, abs=1e-9)


def test_a_segment_s_mass_sits_at_its_fraction_and_missing_ones_are_renormalised():
    # a trunk alone: its centre, halfway
    c = balance.centre_of_mass([("trunk", (0, 0, 1), (0, 0, 2))])
    assert np.allclose(c, (0, 0, 1.5))
    # a thigh and a shank: the mean of their centres weighted 0.100 : 0.0465
    c = balance.centre_of_mass([("thigh", (0, 0, 1), (0, 0, 0)), ("shank", (1, 0, 1), (1, 0, 0))])
    want = (0.100 * np.array([0, 0, 1 - 0.433]) + 0.0465 * np.array([1, 0, 1 - 0.433])) / 0.1465
    assert np.allclose(c, want)
    with pytest.raises(ValueError):
        balance.centre_of_mass([])


def test_the_margin_is_the_signed_distance_to_the_feet_s_edge():
    # two feet 0.2 apart (centres at x = ±0.1), ankles at y = 0, toes at y = 0.2: each a
    # rectangle 0.076 wide, from the heel at y = -0.05 to y = 0.2
    feet = [((0.1, 0.0, 0.0), (0.1, 0.2, 0.0)), ((-0.1, 0.0, 0.0), (-0.1, 0.2, 0.0))]
    poly = balance.support_polygon(feet, UP)
    basis = balance.ground_basis(UP)
    hull_x = sorted({round(float(v), 6) for v in (np.linalg.pinv(basis) @ poly.T).T[:, 0]})
    assert hull_x[0] == pytest.approx(-0.138) and hull_x[-1] == pytest.approx(0.138)
    # between the feet, 0.05 ahead of the ankles: nearest edge the heel line, 0.1 behind
    assert balance.balance_margin((0.0, 0.05, 1.0), poly, UP) == pytest.approx(0.1)
    # ahead of the toes by 0.1: outside, -0.1
    assert balance.balance_margin((0.0, 0.3, 1.0), poly, UP) == pytest.approx(-0.1)
    # a sole's points: the hull of their projection
    square = balance.polygon_of([(0, 0, 0), (1, 0, 0.01), (1, 1, 0), (0, 1, 0.02), (0.5, 0.5, 0)],
                                UP)
    assert len(square) == 4
    assert balance.balance_margin((0.5, 0.25, 3.0), square, UP) == pytest.approx(0.25)
    assert balance.balance_margin((1.5, 0.5, 0.0), square, UP) == pytest.approx(-0.5)
