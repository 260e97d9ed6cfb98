"""The reach envelope (core.envelope) against the planner's own answers, point by point.

The figure stands at the origin facing -Y (see test_planner.py). Every point's class is
checked against what the planner says of that wrist position, asked directly: the
strongest clear pose (ConfigurationGenerator.solve) at the chest rotation a reach arrives
there with (target_chest), the same with the chest held still, and the diagnosis of a
position with no clear pose (diagnose_target).
"""

import numpy as np
import pytest

from geometry import obstacles, run_steps, shelf, standard_arm, table
from reach_addon.batch import _grid_points
from reach_addon.core import (ARM_DOES_NOT_FIT, NEEDS_LEAN, NEEDS_STEP, OUT_OF_REACH, Planner,
                              Settings, TARGET_IN_OBSTACLE)
from reach_addon.core import envelope
from reach_addon.core.diagnosis import diagnose_target
from reach_addon.core.steps import drain

SCENES = {
    "open": None,
    "table": {"Table": table((-0.3, -0.6), (1.0, 0.5), 0.95)},
    "shelf": {"Shelf": shelf((-0.25, -0.55), 0.9, 0.3, (0.95, 1.25, 1.55))},
    # a crate round a point in front of the shoulder, within reach
    "crate": {"Crate": [((-0.45, -0.55, 1.20), (-0.05, -0.30, 1.50))]},
}


@pytest.fixture(scope="module")
def arm():
    return standard_arm()


def envelope_of(arm, scene, settings=None, resolution=11):
    """The envelope of ``arm`` in ``scene``; ``settings`` default to the arm's alone (Lean
    off: the body's classes have tests of their own)."""
    planner = Planner(arm, None if scene is None else obstacles(scene),
                      envelope.exhaustive(settings or Settings(lean=False)))
    pts = envelope.shoulder_frame_to_canonical(arm, envelope.grid_coordinates(resolution, 1.15))
    return planner, drain(envelope.envelope_steps(planner.generator, pts))


def test_grid_is_the_batch_studys_shoulder_grid():
    for n, e in ((5, 1.15), (13, 1.15), (4, 0.7)):
        grid = {"min": [-e] * 3, "max": [e] * 3, "count": [n] * 3}
        np.testing.assert_allclose(envelope.grid_coordinates(n, e), np.array(_grid_points(grid, "t")),
                                   atol=1e-12)


def test_shoulder_frame_is_outward_forward_up(arm):
    # the canonical frame is (outward, forward, up); one arm length along each
    c = envelope.shoulder_frame_to_canonical(arm, np.eye(3))
    np.testing.assert_allclose(c - arm.shoulder, arm.arm_length * np.array(
        [[0, 1, 0], [1, 0, 0], [0, 0, 1]]), atol=1e-12)


@pytest.mark.parametrize("name", list(SCENES))
def test_every_point_is_classed_as_the_planner_answers_there(arm, name):
    planner, env = envelope_of(arm, SCENES[name])
    gen = planner.generator
    seen = set()
    for p, cls, f_r in zip(env.points, env.classes, env.f_r):
        chest = gen.target_chest(p)               # Table 1's, else the nearest that fits
        pose = None if chest is None else gen.solve(p, body_rotation=chest)
        if pose is not None:
            still = gen.solve(p, body_rotation=0.0)
            expected = envelope.CHEST if still is None and abs(chest) > 1e-9 else pose.f_r
            assert (cls, f_r) == (expected, pose.f_r), p
        else:
            why = diagnose_target(gen, p, ball=False)     # the point itself
            if why is not None and why.reason in (OUT_OF_REACH, NEEDS_LEAN, NEEDS_STEP):
                assert (cls, f_r) == (envelope.OUT, -1), p
            else:
                assert why is None or why.reason in (TARGET_IN_OBSTACLE, ARM_DOES_NOT_FIT)
                assert (cls, f_r) == (envelope.BLOCKED, -1), p
        seen.add(int(cls))
    # the grid holds every kind of point: strong, chest-only, blocked (the body, the
    # scene) and out of reach
    assert {0, envelope.CHEST, envelope.BLOCKED, envelope.OUT} <= seen


def test_obstacles_block_points_the_open_scene_reaches(arm):
    _, open_env = envelope_of(arm, None)
    _, crate = envelope_of(arm, SCENES["crate"])
    lo, hi = np.array(SCENES["crate"]["Crate"][0])
    world = arm.to_world_points(crate.points)
    inside = np.all((world > lo) & (world < hi), axis=1)
    assert inside.sum() >= 4
    assert (open_env.classes[inside] <= envelope.CHEST).all()       # reachable without the crate
    assert (crate.classes[inside] == envelope.BLOCKED).all()
    # and the crate only takes reach away
    assert (crate.classes[open_env.classes == envelope.OUT] == envelope.OUT).all()


def test_chest_points_are_lost_without_chest_rotation(arm):
    _, env = envelope_of(arm, None)
    _, fixed = envelope_of(arm, None, Settings(chest_rotation=False, lean=False))
    chest = env.classes == envelope.CHEST
    assert chest.sum() >= 10
    assert (fixed.classes[chest] >= envelope.BLOCKED).all()
    assert (fixed.classes != envelope.CHEST).all()


def test_the_same_however_it_is_consumed_and_run_again(arm):
    planner, env = envelope_of(arm, SCENES["table"], resolution=7)
    fractions, again = run_steps(envelope.envelope_steps(planner.generator, env.points, chunk=5))
    assert len(fractions) >= 3 and fractions == sorted(fractions) and 0 < fractions[-1] < 1
    np.testing.assert_array_equal(again.classes, env.classes)
    np.testing.assert_array_equal(again.f_r, env.f_r)
    single = [envelope.classify_point(planner.generator, p) for p in env.points]
    np.testing.assert_array_equal(np.array(single)[:, 0], env.classes)
    assert sum(env.counts().values()) == len(env.points) == 7 ** 3


def lean_reaches(arm, settings, point, slack):
    """Brute force, sharing no code with the planner: "upright" where a chest turn (every
    1° of the range) alone brings the shoulder within Lean to (+ ``slack``) arm lengths of
    ``point``, "leaning" where a lean toward it about the waist (every 0.25° up to Lean
    limit) is needed too, else "no"."""
    limit = settings.chest_rotation_max
    turns = np.radians(np.arange(-limit, limit + 0.5, 1.0))
    thetas = np.radians(np.arange(0.0, settings.lean_max + 1e-9, 0.25))
    s = np.asarray(arm.shoulder, float)
    shoulders = np.stack([s[0] * np.cos(turns) - s[1] * np.sin(turns),
                          s[0] * np.sin(turns) + s[1] * np.cos(turns),
                          np.full_like(turns, s[2])], axis=1)
    w = np.asarray(arm.waist, float)
    h = (np.asarray(point, float) - w) * np.array([1.0, 1.0, 0.0])
    h /= np.linalg.norm(h)
    k = np.cross([0.0, 0.0, 1.0], h)
    v = shoulders - w                                           # (T, 3)
    c, sn = np.cos(thetas)[:, None, None], np.sin(thetas)[:, None, None]
    leaned = w + v * c + np.cross(k, v) * sn + k * (v @ k)[None, :, None] * (1 - c)
    reach = (settings.lean_reach + slack) * arm.arm_length
    within = (np.linalg.norm(leaned - np.asarray(point, float), axis=2) <= reach).any(axis=1)
    return "upright" if within[0] else "leaning" if within.any() else "no"


def test_with_lean_on_the_points_a_lean_reaches_are_their_own_class(arm):
    """With Lean on, a point beyond every arm pose is ``lean`` exactly where a lean is
    needed to bring it within Lean to of the shoulder, the chest turned as it may be (by
    brute force, :func:`lean_reaches`), and the rest of the grid is classed as with Lean
    off."""
    settings = Settings().replace(lean=True, envelope_body=True)
    _planner, plain = envelope_of(arm, None, resolution=7)
    planner, leaned = envelope_of(arm, None, settings, resolution=7)
    changed = np.flatnonzero(plain.classes != leaned.classes)
    assert len(changed) and np.all(plain.classes[changed] == envelope.OUT)
    assert np.all(leaned.classes[changed] == envelope.LEAN)
    for i in np.flatnonzero(plain.classes == envelope.OUT):
        p = plain.points[i]
        wide, narrow = (lean_reaches(arm, settings, p, d) for d in (0.002, -0.002))
        if wide != narrow:
            continue                    # within a rounding of a boundary: either will do
        # a point the shoulder is near enough upright (joint limits keep the arm off it)
        # is no nearer for a lean: "out"
        assert (leaned.classes[i] == envelope.LEAN) == (wide == "leaning"), (p, wide)
    assert envelope.classify_point(planner.generator, leaned.points[changed[0]]) == \
        (envelope.LEAN, -1)
