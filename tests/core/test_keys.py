"""The instants between two keys as Blender interpolates them (``core.keys``): the arm
chained from its segments' relative rotations, each blended by nlerp. (That Blender puts
the bones there is ``tests/blender/test_between_keys.py``.)"""

import numpy as np
import pytest
from geometry import standard_arm

from reach_addon.core.arm import ArmConfig, pose_from_config
from reach_addon.core.keys import between, nlerp, quaternion, segment_frames


@pytest.fixture(scope="module")
def arm():
    return standard_arm()


def _pair(arm, rng, spread=1.0):
    c = np.array([rng.uniform(-30, 30), rng.uniform(-60, 120), rng.uniform(-40, 120),
                  rng.uniform(-60, 60), rng.uniform(5, 140)])
    h = rng.uniform(-40, 40, 2)
    d = spread * rng.normal(size=7) * np.array([3, 6, 6, 6, 6, 8, 8])
    a = pose_from_config(arm, ArmConfig.from_array(c), hand=tuple(h))
    b = pose_from_config(arm, ArmConfig.from_array(c + d[:5]), hand=tuple(h + d[5:]))
    return a, b


def test_quaternions_of_every_rotation_turn_as_it_does():
    rng = np.random.default_rng(3)
    q = rng.normal(size=(2000, 4))
    q[:4] = np.eye(4)                                 # the half-turns and the identity
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for w, x, y, z in q:
        m = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                      [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                      [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
        got = np.array(quaternion(tuple(map(tuple, m.T))))
        assert min(np.abs(got - (w, x, y, z)).max(), np.abs(got + (w, x, y, z)).max()) < 1e-12


def test_nlerp_takes_the_short_way_and_ends_on_the_keys():
    qa = (1.0, 0.0, 0.0, 0.0)
    qb = (-np.cos(0.3), 0.0, 0.0, -np.sin(0.3))         # the same turn, other sign
    np.testing.assert_allclose(nlerp(qa, qb, 0.0), qa)
    np.testing.assert_allclose(nlerp(qa, qb, 1.0), np.negative(qb))
    half = nlerp(qa, qb, 0.5)
    assert np.degrees(2 * np.arctan2(half[3], half[0])) == pytest.approx(np.degrees(0.3))


def test_the_keys_themselves_are_the_poses(arm):
    rng = np.random.default_rng(0)
    for _ in range(200):
        a, b = _pair(arm, rng)
        joints, bends, body = between(arm, a, b, [0.0, 1.0])
        np.testing.assert_allclose(joints[0], a.joints, atol=1e-12)
        np.testing.assert_allclose(joints[1], b.joints, atol=1e-12)
        np.testing.assert_allclose(bends, [a.bend, b.bend], atol=1e-12)
        np.testing.assert_allclose(body, [a.config.body_rotation, b.config.body_rotation],
                                   atol=1e-9)


def test_between_keys_the_segments_keep_their_lengths_and_the_elbow_its_hinge(arm):
    rng = np.random.default_rng(1)
    t = np.linspace(0.05, 0.95, 7)
    for _ in range(100):
        a, b = _pair(arm, rng, spread=3.0)
        j, bend, _body = between(arm, a, b, t)
        lengths = np.linalg.norm(np.diff(j[:, 1:], axis=1), axis=2)
        np.testing.assert_allclose(lengths, np.broadcast_to(
            [arm.upper_arm_length, arm.forearm_length, arm.hand_length], lengths.shape),
            rtol=1e-12)
        # the forearm turns about the elbow's hinge only: it stays in the plane of the
        # upper arm and the bend direction
        hinge = np.cross(j[:, 2] - j[:, 1], bend)
        assert np.abs(np.einsum("ij,ij->i", hinge, j[:, 3] - j[:, 2])).max() < 1e-9


def test_a_palm_roll_turns_the_frames_but_moves_no_joint(arm):
    rng = np.random.default_rng(2)
    a, b = _pair(arm, rng)
    rolled = type(b)(b.config, b.joints, b.bend, b.f_r, b.hand, 40.0)
    assert not np.allclose(segment_frames(arm, rolled)[3], segment_frames(arm, b)[3])
    j0, _b0, _c0 = between(arm, a, b, [1.0])
    j1, _b1, _c1 = between(arm, a, rolled, [1.0])
    np.testing.assert_allclose(j0, j1, atol=1e-12)


def test_small_moves_stay_near_the_straight_line_of_the_angles_large_ones_do_not(arm):
    """The blend and the straight line between the angles agree to second order in the
    step: near for a small move, apart for a large one (the reason the planner checks
    the blend)."""
    from reach_addon.core.sampling import joints_of, pose_row

    rng = np.random.default_rng(4)
    t = np.array([0.25, 0.5, 0.75])
    gaps = {}
    for spread in (0.1, 3.0):
        worst = 0.0
        for _ in range(100):
            a, b = _pair(arm, rng, spread)
            j, _bend, _body = between(arm, a, b, t)
            rows = (1 - t)[:, None] * pose_row(a) + t[:, None] * pose_row(b)
            worst = max(worst, float(np.linalg.norm(j - joints_of(arm, rows), axis=2).max()))
        gaps[spread] = worst / arm.arm_length
    assert gaps[0.1] < 1e-4 < 1e-2 < gaps[3.0], gaps
