"""A chase's way ahead, timed at the chase's limits (:func:`at_chase_speed`) and, where the
way planned is too slow for the frames left, shortened for them (:func:`shortcut_for`).

A chase's frames are tied to the clock: a way to where the target ends must fit the frames
left at the chase's limits, the wrist at most ``Settings.chase_max_speed``, each arm angle
at most ``Settings.max_joint_step`` for each search step the wrist may go, the hand's
whole turn at most ``Settings.hand_space_turn_speed``. A span between two poses costs the
frames its tightest limit asks (:func:`span_cost`); a way costs the sum. The search
shortens a way in the wrist's length and the sampling planner in its joint metric, neither
in this cost, where the limit that binds changes along the way (the hand turning in place
at one end, the wrist travelling at the other).

A frame of the pursuit that would go faster than a bound takes part of its way
(:func:`part_way`, measured by the hand's turn or :func:`wrist_travel`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .arm import ArmConfig, Pose, frame_turn
from .generator import ConfigurationGenerator
from .sampling import JointSpace, StateValidity, densify_rows, pose_row
from .settings import Settings

#: Tries of :func:`shortcut_for` (pairs of poses joined by a straight line in joint space).
SHORTCUT_TRIES = 100


def chase_rate(settings: Settings, fps: float) -> float:
    """The chase's limits a frame, in search steps: ``chase_max_speed / fps / step``. The
    wrist moves at most that many step lengths a frame (``Settings.chase_max_speed``) and
    each arm angle at most that many times ``Settings.max_joint_step`` (the search's
    bound a step). :func:`~.chase.chase_steps_per_frame` is its whole part, what the
    pursuit's search takes."""
    return settings.chase_max_speed / fps / settings.step


def blend(generator: ConfigurationGenerator, a: Pose, b: Pose, t: float) -> Pose:
    """The pose ``t`` of the way from ``a`` to ``b``: their angles blended (the twist the
    short way), the wrist's two angles and the palm's roll too."""
    qa, qb = a.config.as_array(), b.config.as_array()
    delta = qb - qa
    delta[3] = (delta[3] + 180.0) % 360.0 - 180.0            # the twist the short way
    ha, hb = np.asarray(a.hand, dtype=float), np.asarray(b.hand, dtype=float)
    config = ArmConfig.from_array(qa + t * delta)
    pose = generator.config_pose(config, tuple((ha + t * (hb - ha)).tolist()))
    return replace(pose, roll=a.roll + t * (b.roll - a.roll))


def span_cost(generator: ConfigurationGenerator, settings: Settings, fps: float):
    """The frames a span from pose a to pose b asks at the chase's limits, as a function
    (a, b) → float: max(wrist travel / (rate × step length), largest arm angle change /
    (rate × ``max_joint_step``), hand turn / (``hand_space_turn_speed`` / fps)), rate being
    :func:`chase_rate`."""
    rate = chase_rate(settings, fps)
    reach = rate * generator.step_length
    joints = rate * settings.max_joint_step
    turn = settings.hand_space_turn_speed / fps

    def cost(a: Pose, b: Pose) -> float:
        return max(math.dist(a.wrist.tolist(), b.wrist.tolist()) / reach,
                   float(np.abs(b.config.as_array() - a.config.as_array()).max()) / joints,
                   frame_turn(a, b) / turn)

    return cost


def at_chase_speed(gen: ConfigurationGenerator, poses: list, frames: int, settings: Settings,
                   fps: float):
    """``poses`` (a planned motion) retimed as fast as the chase may go, in at most
    ``frames`` frames: each span between two of them costs the frames its tightest limit
    asks (:func:`span_cost`), and the keys are laid at equal shares of the whole cost,
    blended within a span (:func:`blend`); the fewest frames whose keys all keep those
    limits and are clear as they interpolate. None if no count up to ``frames`` does. A key
    blended within a span that is not clear as a key (:meth:`~.generator.
    ConfigurationGenerator.key_clear`: the whole margin, where the instants between the
    span's own keys keep half of it) is the span's nearer end instead (the crate scene of
    ``test_chase_timing``: a hand relaxed to the margin's edge left blends at 0.7 of one
    span short of it, and no count of keys was clear). The
    limits are the settings' own (:func:`chase_rate`), not the pursuit's whole steps a
    frame: at 24 fps the default speed is 2.78 steps a frame, which the pursuit takes as
    2, and a reach retimed at 2 missed by 0.16 of a frame a way OMPL's path showed fits at
    the limit (fuzz seed 213)."""
    cost = span_cost(gen, settings, fps)

    def within(a: Pose, b: Pose) -> bool:
        return cost(a, b) <= 1.0 + 1e-6 and gen.transition_problem(a, b) is None

    costs = np.array([cost(a, b) for a, b in zip(poses[:-1], poses[1:])])
    at = np.concatenate([[0.0], np.cumsum(costs)])
    total = float(at[-1])
    for n in range(max(1, int(math.ceil(total - 1e-9))), frames + 1):
        keys = [poses[0]]
        for k in range(1, n):
            c = total * k / n
            i = min(int(np.searchsorted(at, c, side="right")) - 1, len(costs) - 1)
            t = min(max(0.0 if costs[i] <= 0.0 else (c - at[i]) / costs[i], 0.0), 1.0)
            key = blend(gen, poses[i], poses[i + 1], t)
            if not gen.key_clear(key):     # the span's nearer end, a clear key itself
                key = poses[i] if t < 0.5 else poses[i + 1]
            keys.append(key)
        keys.append(poses[-1])
        if all(within(a, b) for a, b in zip(keys[:-1], keys[1:])):
            return keys
    return None


def shortcut_for(gen: ConfigurationGenerator, poses: list, cost, tries: int = SHORTCUT_TRIES,
                 seed: int = 0) -> list:
    """``poses`` (dense, each clear) shortened in ``cost`` (a span's, (a, b) → float): pairs
    of poses drawn at random (seeded by ``seed``) are joined by a straight line in joint
    space (:func:`blend`; dense as the sampling planner's, :func:`~.sampling.densify_rows`)
    where every
    pose on it is valid (:class:`~.sampling.StateValidity`: legal, clear of the body and,
    with the margin, of the obstacles), the instants between its poses are clear as
    Blender interpolates them (:meth:`~.generator.ConfigurationGenerator.transition_problem`:
    valid poses a step apart may still sweep the hand through an obstacle's corner, and
    :func:`at_chase_speed` could then time no key of that span; the crate scene of
    ``test_chase_timing`` once its hand relaxed off the line toward rest) and it costs
    less than the way between them. The
    chase's way ahead, fuzz seeds 5804 and 3327: the search's way cost 30.4 frames (25
    had) and the sampling planner's 26.1 (23 had); joined so, 19.5 and 21.4, where the
    cross-check's OMPL way fits in 25 and 24."""
    s, arm = gen.settings, gen.arm
    poses = list(poses)
    if len(poses) < 3:
        return poses
    validity = StateValidity(arm, s, gen.checker, JointSpace(arm, s, pose_row(poses[0])))
    rng = np.random.default_rng(seed)
    costs = [cost(a, b) for a, b in zip(poses[:-1], poses[1:])]
    for _ in range(tries):
        i, j = sorted(int(k) for k in rng.choice(len(poses), 2, replace=False))
        if j - i < 2:
            continue
        n = len(densify_rows(arm, [pose_row(poses[i]), pose_row(poses[j])], gen.step_length,
                             s.max_joint_step, s.hand_step_turn)) - 1
        line = [poses[i]] + [blend(gen, poses[i], poses[j], k / n) for k in range(1, n)] + \
            [poses[j]]
        line_costs = [cost(a, b) for a, b in zip(line[:-1], line[1:])]
        if sum(line_costs) >= sum(costs[i:j]) - 1e-6 or \
                not all(validity.valid(pose_row(p)) for p in line[1:-1]) or \
                any(gen.transition_problem(a, b) is not None
                    for a, b in zip(line[:-1], line[1:])):
            continue
        poses[i:j + 1] = line
        costs[i:j] = line_costs
    return poses


def part_way(generator: ConfigurationGenerator, a: Pose, b: Pose, bound: float,
             halvings: int = 10, measure=frame_turn) -> Pose | None:
    """A pose part of the way from ``a`` to ``b`` whose hand turns at most ``bound`` degrees
    from ``a``'s (roll included, :func:`~reach_addon.core.arm.frame_turn`; ``measure``:
    another figure of the move from ``a``, such as :func:`wrist_travel`),
    and that is clear as a key and as the keys from ``a`` interpolate
    (:meth:`ConfigurationGenerator.key_clear`, ``transition_problem``): the angles of the
    two poses, the wrist's two and the roll included, blended at the largest share found by
    ``halvings`` bisections; None if no share is clear. A chase cannot slow down its frames:
    where one step of its search turns the hand faster than the bound (a twist of the upper
    arm near its bound turns the forearm 15° and more), the frame takes only part of it."""
    def at(t):
        return blend(generator, a, b, t)

    lo, hi = 0.0, 1.0
    for _ in range(halvings):
        mid = 0.5 * (lo + hi)
        if measure(a, at(mid)) <= bound:
            lo = mid
        else:
            hi = mid
    while lo > 1e-3:
        pose = at(lo)
        if generator.key_clear(pose) and generator.transition_problem(a, pose) is None:
            return pose
        lo *= 0.5
    return None


def wrist_travel(a: Pose, b: Pose) -> float:
    """How far the wrist moves from ``a`` to ``b`` (figure units)."""
    return math.dist(a.wrist.tolist(), b.wrist.tolist())
