"""The head's gaze (``core.gaze``), checked by geometry written here: the turn the angles
give puts the target on the line of sight from the turned eyes; the limits clip; the head
turns toward each new target on a minimum-jerk curve of the set time and never faster
than the set speed."""

from __future__ import annotations

import numpy as np
import pytest

from reach_addon.core import Settings
from reach_addon.core.gaze import clip_gaze, gaze_angles, gaze_blend, gaze_rotation

FORWARD, UP = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])


def sight_miss(target, eyes, yaw, pitch):
    """How far ``target`` lies off the line of sight of the eyes turned by (yaw, pitch)."""
    r = gaze_rotation(FORWARD, UP, yaw, pitch)
    e, f = r @ eyes, r @ FORWARD
    v = target - e
    return float(np.linalg.norm(v - (v @ f) * f)), float(v @ f)


@pytest.mark.parametrize("target", [(0.3, 0.5, -0.4), (-0.6, 0.2, 0.1), (0.05, 0.9, -0.6),
                                    (0.4, -0.1, 0.3)])
@pytest.mark.parametrize("eyes", [(0.0, 0.0, 0.0), (0.0, 0.08, 0.2), (0.0, 0.02, 0.12)])
def test_the_turned_eyes_look_through_the_target(target, eyes):
    target, eyes = np.array(target), np.array(eyes)
    yaw, pitch = gaze_angles(target, FORWARD, UP, eyes)
    miss, ahead = sight_miss(target, eyes, yaw, pitch)
    assert miss < 1e-9 and ahead > 0.0, (yaw, pitch, miss)


def test_the_turn_takes_forward_toward_the_left_and_up_for_positive_angles():
    r = gaze_rotation(FORWARD, UP, 30.0, 20.0)
    f = r @ FORWARD
    assert f @ np.cross(UP, FORWARD) > 0.0 and f @ UP > 0.0
    assert np.allclose(r @ r.T, np.eye(3)) and np.linalg.det(r) == pytest.approx(1.0)


def test_the_limits_clip_each_angle():
    s = Settings()
    assert clip_gaze(80.0, -70.0, s) == (s.gaze_turn_max, -s.gaze_down_max)
    assert clip_gaze(-80.0, 70.0, s) == (-s.gaze_turn_max, s.gaze_up_max)
    assert clip_gaze(10.0, -5.0, s) == (10.0, -5.0)


def test_the_head_turns_in_the_set_time_then_keeps_to_the_target_and_no_faster():
    s = Settings()
    fps = 24.0
    n = 40
    aims = np.tile([[40.0, -20.0]], (n, 1))
    aims[20:] = [-30.0, 10.0]
    starts = np.where(np.arange(n) < 20, 0, 20)
    out = gaze_blend(aims, starts, fps, s)
    assert np.allclose(out[0], 0.0)
    turn = int(np.ceil(s.gaze_time * fps))
    assert np.allclose(out[turn:20], aims[turn:20])
    assert np.allclose(out[20 + turn + 4:], aims[20 + turn + 4:])
    steps = np.abs(np.diff(out, axis=0))
    assert steps.max() <= s.gaze_speed / fps + 1e-9
    fast = gaze_blend(aims, starts, fps, s.replace(gaze_speed=60.0))
    assert np.abs(np.diff(fast, axis=0)).max() <= 60.0 / fps + 1e-9
    assert not np.allclose(fast[turn], aims[turn])       # too slow to be there yet
