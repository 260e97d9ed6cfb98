"""The independent naturalness measure (verification.naturalness) on known rotations."""

import math

import numpy as np
import pytest

from verification.naturalness import chicken_wing, wrist_bend_deg


def rot(axis, deg):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    t = math.radians(deg)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * k @ k


def test_a_bend_is_the_hand_axis_turn_in_the_forearm_frame_from_rest():
    forearm_rest = rot((0, 0, 1), 30.0)
    hand_rest = forearm_rest @ rot((1, 0, 0), 10.0)         # the rig's own 10° at rest
    assert wrist_bend_deg(forearm_rest, hand_rest, forearm_rest, hand_rest) == pytest.approx(0.0, abs=1e-6)
    # the whole arm turned: no bend
    turn = rot((0.3, 1.0, 0.2), 70.0)
    assert wrist_bend_deg(turn @ forearm_rest, turn @ hand_rest, forearm_rest,
                          hand_rest) == pytest.approx(0.0, abs=1e-6)
    # the hand bent 25° more about the forearm's x axis
    bent = forearm_rest @ rot((1, 0, 0), 35.0)
    assert wrist_bend_deg(forearm_rest, bent, forearm_rest, hand_rest) == pytest.approx(25.0)
    # a twist about the hand's own axis is not a bend
    twisted = hand_rest @ rot((0, 1, 0), 40.0)
    assert wrist_bend_deg(forearm_rest, twisted, forearm_rest, hand_rest) == pytest.approx(0.0, abs=1e-6)
    # scale in the matrices is divided out
    assert wrist_bend_deg(2.0 * forearm_rest, 3.0 * bent, forearm_rest,
                          hand_rest) == pytest.approx(25.0)


def test_a_chicken_wing_is_an_elbow_up_over_a_low_hand():
    up, length = (0, 0, 1), 1.0
    shoulder = np.zeros(3)
    assert chicken_wing(shoulder, (0.3, 0, 0.15), (0.5, 0, -0.2), up, length)
    assert not chicken_wing(shoulder, (0.3, 0, 0.05), (0.5, 0, -0.2), up, length)   # elbow low
    assert not chicken_wing(shoulder, (0.3, 0, 0.15), (0.5, 0, -0.05), up, length)  # hand high
    assert not chicken_wing(shoulder, (0, 0, -0.4), (0.3, 0, -0.6), up, length)     # hanging
