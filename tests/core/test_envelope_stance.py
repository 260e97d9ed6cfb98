"""The reach envelope's whole-body classes (``squat``, ``step``) on the standard figure
given a body of its own (a :class:`~reach_addon.core.stance.Stance` built here by hand: the
legs and feet of ``test_squat``, Winter's segments on them), checked by geometry written
out here: the stance's centre of mass by Rodrigues' rotation, the step by the distance
along the ground, and the squat's quick bound against the full search it saves."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry import standard_arm
from test_squat import FEET, LEGS, UP

from reach_addon.core import OUT_OF_REACH, Settings
from reach_addon.core import envelope
from reach_addon.core.diagnosis import beyond_reach
from reach_addon.core.balance import centre_of_mass, polygon_of
from reach_addon.core.lean import Lean
from reach_addon.core.squat import squat_leans
from reach_addon.core.stance import Stance
from reach_addon.core.steps import drain
from reach_addon.core.whole_body import below_the_arm
from reach_addon.core import Planner

#: The figure's hips' midpoint and its ground (world, metres).
HIPS, GROUND = np.array([0.0, 0.0, 0.90]), 0.0


def stance(arm) -> Stance:
    """The standard figure standing: both arms hanging from its shoulders, the trunk from
    the hips to the shoulders' middle, the head above, the legs of ``test_squat``."""
    right = arm.to_world_points(np.asarray(arm.shoulder, float)[None])[0]
    left = right * np.array([-1.0, 1.0, 1.0])
    down = np.array([0.0, 0.0, -1.0])
    segments = []
    for s in (right, left):
        e, w = s + 0.30 * down, s + 0.56 * down
        segments += [("upper_arm", s, e), ("forearm", e, w), ("hand", w, w + 0.18 * down)]
    for leg in LEGS:
        segments += [("thigh", leg.hip, leg.knee), ("shank", leg.knee, leg.ankle),
                     ("foot", leg.ankle, leg.ankle + np.array([0.0, -0.15, -0.08]))]
    top = 0.5 * (right + left)
    segments += [("trunk", HIPS, top), ("head_neck", top, top + np.array([0.0, 0.0, 0.25]))]
    return Stance(segments=tuple(segments), arm=0, pivot=HIPS + np.array([0.0, 0.0, 0.1]),
                  to_world=np.asarray(arm.to_world, float), polygon=polygon_of(FEET, UP),
                  up=UP, planted_share=0.12, margin=0.02, floor=0.0, leg_joints=tuple(LEGS),
                  ankles=np.array([leg.ankle for leg in LEGS]),
                  leg_length=float(np.linalg.norm(LEGS[0].hip - LEGS[0].ankle)),
                  shoulder=right, ground=GROUND)


@pytest.fixture(scope="module")
def arm():
    return standard_arm()


def rodrigues(axis, degrees) -> np.ndarray:
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    t = math.radians(degrees)
    return np.eye(3) + math.sin(t) * kx + (1 - math.cos(t)) * kx @ kx


def leaned_segments(body, r) -> list:
    """The stance's segments with the trunk turned by the rotation ``r`` (3, 3) about its
    pivot: both points of the arms and the head, the trunk's top; the legs stay."""
    o = body.pivot
    out = []
    for kind, a, b in body.segments:
        if kind in ("upper_arm", "forearm", "hand", "head_neck"):
            a, b = o + r @ (a - o), o + r @ (b - o)
        elif kind == "trunk":
            b = o + r @ (b - o)
        out.append((kind, a, b))
    return out


def test_a_lean_turns_the_trunk_head_and_arms_about_the_pivot_and_leaves_the_legs(arm):
    body = stance(arm)
    lean = Lean(arm.to_canonical_points(body.pivot[None])[0], np.array([1.0, 0.0, 0.0]), 0.0)
    np.testing.assert_allclose(body.com(lean), centre_of_mass(body.segments), atol=1e-12)
    # toward a target ahead (canonical +y) the trunk tips about up × ahead = -x
    tipped = Lean(lean.pivot, np.array([-1.0, 0.0, 0.0]), 40.0)
    world_axis = arm.to_world_vectors(np.array([-1.0, 0.0, 0.0]))
    r = rodrigues(world_axis, 40.0)
    expected = leaned_segments(body, r)
    moved = body.com(tipped)
    np.testing.assert_allclose(moved, centre_of_mass(expected), atol=1e-9)
    assert moved[1] < centre_of_mass(body.segments)[1] - 0.05      # forward is -y


def envelope_of(arm, settings, with_stance=True, resolution=9, extent=2.4):
    planner = Planner(arm, None, envelope.exhaustive(settings))
    points = envelope.shoulder_frame_to_canonical(
        arm, envelope.grid_coordinates(resolution, extent))
    return drain(envelope.envelope_steps(planner.generator, points,
                                         stance=stance(arm) if with_stance else None))


def steps_needed(arm, settings, body, world) -> float:
    """How many steps of Step length the shoulder must move along the ground to bring
    ``world`` within Step to of it: inf where its height alone keeps it out, 0 where it is
    that near already (a point behind the back: a step toward it does not help)."""
    reach = settings.step_reach * arm.arm_length
    d = world - body.shoulder
    v, h = float(d[2]), float(np.hypot(d[0], d[1]))
    if abs(v) >= reach:
        return math.inf
    move = h - math.sqrt(reach * reach - v * v)
    if move <= 0.0:
        return 0
    return max(1, math.ceil(move / (settings.step_length * body.leg_length) - 1e-9))


def test_points_past_a_lean_are_squat_or_step_as_the_body_reaches_them(arm):
    settings = Settings().replace(lean=True, envelope_body=True)
    body = stance(arm)
    plain = envelope_of(arm, settings, with_stance=False)
    env = envelope_of(arm, settings)
    changed = np.flatnonzero(plain.classes != env.classes)
    # the stance moves the lean to its pivot and weighs its balance: lean and out points
    # change, and squat and step come
    assert np.all(np.isin(plain.classes[changed], (envelope.OUT, envelope.LEAN)))
    assert {envelope.SQUAT, envelope.STEP} <= set(env.classes[changed])
    world = arm.to_world_points(env.points)
    coarse = settings.replace(squat_step=envelope.ENVELOPE_SQUAT_STEP)
    pivot = arm.to_canonical_points(body.pivot[None])[0]
    for i in np.flatnonzero(np.isin(plain.classes, (envelope.OUT, envelope.LEAN))):
        c, w = env.classes[i], world[i]
        if w[2] < GROUND:
            assert c == envelope.OUT, w
            continue
        if c == envelope.LEAN:
            continue
        if c == envelope.STEP:
            assert 1 <= steps_needed(arm, settings, body, w) <= settings.steps_max, w
        if c == envelope.OUT:
            assert steps_needed(arm, settings, body, w) in (0, math.inf) or \
                steps_needed(arm, settings, body, w) > settings.steps_max, w
        if c in (envelope.STEP, envelope.OUT):
            # where a reach would squat (refused as surely below the arm), the quick
            # bound left out nothing the full search finds
            low = beyond_reach(arm.shoulder, arm.waist, env.points[i], arm.arm_length,
                               settings.lean_max)
            if low.reason == OUT_OF_REACH and below_the_arm(arm, env.points[i]):
                assert not squat_leans(arm, env.points[i], pivot, coarse,
                                       envelope.envelope_turns(settings), body.toward(w)), w
    squats = np.flatnonzero(env.classes == envelope.SQUAT)
    assert len(squats) and np.all(world[squats, 2] < body.shoulder[2])
    assert np.all(np.linalg.norm(world[squats] - body.shoulder, axis=1) > arm.arm_length)
    assert np.count_nonzero(env.classes == envelope.STEP) > len(squats)


def test_without_squat_or_step_their_classes_are_empty(arm):
    on = Settings().replace(lean=True, envelope_body=True)
    for off, gone in ((on.replace(squat=False), envelope.SQUAT),
                      (on.replace(stepping=False), envelope.STEP)):
        env = envelope_of(arm, off, resolution=7)
        assert not np.any(env.classes == gone)
    assert not np.isin(envelope_of(arm, Settings(lean=False), resolution=7).classes,
                       (envelope.LEAN, envelope.SQUAT, envelope.STEP)).any()


def inside(point, corners) -> float:
    """Signed distance of ``point``'s ground projection (z up) from the convex polygon of
    ``corners`` (counter-clockwise or not): positive inside."""
    q = np.asarray(point, float)[:2]
    c = np.asarray(corners, float)[:, :2]
    centre = c.mean(axis=0)
    order = np.argsort(np.arctan2(c[:, 1] - centre[1], c[:, 0] - centre[0]))
    c = c[order]
    worst = math.inf
    for a, b in zip(c, np.roll(c, -1, axis=0)):
        e = b - a
        n = np.array([e[1], -e[0]]) / np.linalg.norm(e)       # outward for CCW
        worst = min(worst, float((a - q) @ n))
    return worst


def balanced_lean(arm, settings, body, world, step=1.0) -> bool:
    """Whether some lean of the trunk about the stance's pivot, toward ``world`` (about
    the horizontal axis at right angles to the way to it), of at most Lean limit, with
    the chest turned by some angle within its limit, brings the shoulder within Lean reach
    of it with the centre of mass of the turned segments (the arm straight toward it)
    over the feet: a search over a grid of ``step`` degrees, by Rodrigues' rotation."""
    o = body.pivot
    h = world - o
    h[2] = 0.0
    h /= np.linalg.norm(h)
    axis = np.cross(UP, h)
    reach = settings.lean_reach * arm.arm_length
    origin = arm.to_world_points(np.zeros((1, 3)))[0]
    s0 = body.shoulder
    turns = np.arange(-settings.chest_rotation_max, settings.chest_rotation_max + 1e-9, 5.0)
    for theta in np.arange(0.0, settings.lean_max + 1e-9, step):
        r = rodrigues(axis, theta)
        segs = leaned_segments(body, r)
        for t in turns:
            turned = origin + rodrigues(UP, -t) @ (s0 - origin)
            shoulder = o + r @ (turned - o)
            if np.linalg.norm(world - shoulder) > reach:
                continue
            arm_segs = list(segs)
            s = o + r @ (s0 - o)
            d = (world - s) / np.linalg.norm(world - s)
            lengths = [np.linalg.norm(b - a) for _k, a, b in body.segments[:3]]
            e = s + lengths[0] * d
            w = e + lengths[1] * d
            arm_segs[:3] = [("upper_arm", s, e), ("forearm", e, w), ("hand", w, w + lengths[2] * d)]
            if inside(centre_of_mass(arm_segs), FEET) >= body.floor - 1e-6:
                return True
    return False


def test_a_lean_point_given_the_stance_has_a_lean_the_body_balances(arm):
    """Given the stance, and the hips not moving back, a point is ``lean`` only where a
    lean about the stance's pivot reaches it with the centre of mass over the feet
    (:func:`balanced_lean`, searched here on a grid); the stance's pivot and balance
    change the class from the plain envelope's, which leans about the arm model's waist
    without weighing it."""
    settings = Settings().replace(lean=True, envelope_body=True, lean_hips_back=False, squat=False,
                                  stepping=False)
    body = stance(arm)
    plain = envelope_of(arm, settings, with_stance=False)
    env = envelope_of(arm, settings)
    world = arm.to_world_points(env.points)
    leans = np.flatnonzero(env.classes == envelope.LEAN)
    assert len(leans)
    assert np.any(plain.classes != env.classes)
    for i in leans:
        assert balanced_lean(arm, settings, body, world[i]), world[i]
