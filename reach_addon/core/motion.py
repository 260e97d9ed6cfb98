"""From a searched path to motion: shortcut smoothing, then minimum-jerk timing into frames.

The search path zig-zags where it went around obstacles. :func:`shortcut` replaces runs of
it by straight wrist segments wherever every position along the segment (sampled at most
one search step apart) has a legal, smooth, collision-free pose; the output is the *dense*
validated pose sequence along the smoothed path.

:func:`time_path` then places the frames along that sequence with a minimum-jerk
(bell-shaped) speed profile — the "velocity profile" the paper lists as future work:

.. math:: s(τ) = 10τ^3 - 15τ^4 + 6τ^5,\\quad τ = t / T

over the path's arc length, measured by the arm's farthest-moving point (elbow, wrist or
hand end, :func:`path_steps`), so a hand that turns in place takes time. Each frame is the dense
sequence interpolated at its arc length (:class:`PathSampler`): the frames follow the
validated path instead of being solved again, so what the search checked, the hand's turns
included, is what is keyed. The chest's phasing (the arm leads, the chest follows) is part
of the path: :class:`~reach_addon.core.torso.ChestPath`.
"""

from __future__ import annotations

import math

import numpy as np

from .arm import ArmConfig, Pose, hand_frame
from .generator import ConfigurationGenerator
from .torso import minimum_jerk


def wrist_path_length(poses) -> float:
    pts = np.array([p.wrist for p in poses])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()) if len(pts) > 1 else 0.0


def roll_marker(pose: Pose, lever: float) -> np.ndarray:
    """A point ``lever`` off the wrist across the hand (along the second axis of
    :func:`~reach_addon.core.arm.hand_frame`): it moves when the arm rolls about its own
    axis (a twist of a straight arm), which no joint position shows."""
    return pose.joints[3] + lever * hand_frame(pose)[:, 1]


def path_steps(poses) -> np.ndarray:
    """Length of each step of a pose sequence: how far the arm's farthest-moving point
    goes — the elbow, the wrist, the hand's end (its joints in :attr:`Pose.joints`), or
    the side of the hand half its length off its axis (:func:`roll_marker`). A hand that
    turns in place, an elbow that swings round while the wrist hardly moves, or a straight
    arm that rolls, takes the time that move takes; the timing then never drives any part
    of the arm faster than the speed profile."""
    if len(poses) < 2:
        return np.zeros(0)
    lever = 0.5 * float(np.linalg.norm(poses[0].joints[4] - poses[0].joints[3]))
    j = np.array([np.vstack([p.joints[2:5], roll_marker(p, lever)]) for p in poses])
    return np.linalg.norm(np.diff(j, axis=0), axis=2).max(axis=1)


def connect(generator: ConfigurationGenerator, a: Pose, b: Pose):
    """Poses along the straight wrist segment from ``a`` to ``b``, each at most one step
    from the last, ending with ``b`` itself; None if some position has no legal, smooth,
    collision-free pose or ``b`` is not within the smoothness bound of the last one."""
    delta = b.wrist - a.wrist
    n = max(1, int(math.ceil(float(np.linalg.norm(delta)) / generator.step_length - 1e-9)))
    out = []
    prev = a
    for k in range(1, n):
        pose = generator.solve(a.wrist + delta * (k / n), prev, hand_scale=1.0)
        if pose is None:
            return None
        out.append(pose)
        prev = pose
    if not generator.smooth_between(prev, b):
        return None
    out.append(b)
    return out


def shortcut(generator: ConfigurationGenerator, path: list) -> list:
    """Dense validated poses along a shortcut version of ``path`` (start first).

    Greedy, top-down: from the current node, try to jump straight to the path's end;
    failing that, to the node halfway between the next one and the last that failed,
    halving until a jump stands, and go on from the node it reached. The junctions are
    the search's own poses, so a one-node jump (an edge of the search path) always stands.
    A position counts when the generator gives it a legal, smooth, collision-free pose
    with the hand kept continuous; positions are sampled at most one search step apart."""
    if len(path) <= 2:
        return list(path)
    out = [path[0]]
    i, last = 0, len(path) - 1
    while i < last:
        good, good_seg = i + 1, [path[i + 1]]
        target = last
        while target > good:
            seg = connect(generator, out[-1], path[target])
            if seg is not None:
                good, good_seg = target, seg
                break
            target = (good + target) // 2
        out += good_seg
        i = good
    return out


def auto_duration(path_length_arm_lengths: float, settings) -> float:
    """Automatic duration of a reach: path length / ``Settings.mean_speed``, at least
    ``Settings.min_duration`` seconds."""
    return max(settings.min_duration, path_length_arm_lengths / settings.mean_speed)


class PathSampler:
    """Poses anywhere along a dense validated pose sequence, by arc length
    (:func:`path_steps`): between two neighbouring poses
    the arm's five angles and the wrist's two are interpolated linearly. Neighbours are at
    most one search step apart (or one hand turn in place), each clear, and the hand's turn
    between them checked (:meth:`ConfigurationGenerator._place_hand`), so the pose between
    is the one the search vouched for, to within the clearance."""

    def __init__(self, generator: ConfigurationGenerator, dense: list):
        self.generator = generator
        self.dense = dense
        self.steps = path_steps(dense)
        self.cum = np.concatenate([[0.0], np.cumsum(self.steps)])
        self.total = float(self.cum[-1])
        self.configs = np.array([p.config.as_array() for p in dense])
        self.hands = np.array([p.hand for p in dense], dtype=float)

    def __call__(self, arc: float):
        if len(self.dense) < 2 or arc <= 0.0:
            return self.dense[0]
        if arc >= self.total:
            return self.dense[-1]
        k = int(np.clip(np.searchsorted(self.cum, arc, side="right") - 1, 0, len(self.dense) - 2))
        step = self.steps[k]
        t = 0.0 if step <= 0 else (arc - self.cum[k]) / step
        if t <= 1e-9:
            return self.dense[k]
        if t >= 1.0 - 1e-9:
            return self.dense[k + 1]
        config = (1.0 - t) * self.configs[k] + t * self.configs[k + 1]
        hand = (1.0 - t) * self.hands[k] + t * self.hands[k + 1]
        return self.generator.config_pose(ArmConfig.from_array(config),
                                          (float(hand[0]), float(hand[1])))


def limb_turn(poses) -> float:
    """The largest turn (degrees) of the upper arm's or the forearm's direction from one
    pose to the next."""
    if len(poses) < 2:
        return 0.0
    j = np.array([p.joints for p in poses])
    worst = 0.0
    for a, b in ((1, 2), (2, 3)):
        v = j[:, b] - j[:, a]
        v = v / np.linalg.norm(v, axis=1, keepdims=True)
        cos = np.clip(np.einsum("ij,ij->i", v[1:], v[:-1]), -1.0, 1.0)
        worst = max(worst, float(np.degrees(np.arccos(cos)).max()))
    return worst


def time_path(generator: ConfigurationGenerator, dense: list, frames: int):
    """``frames`` poses along ``dense`` (the first is ``dense[0]``, the last ``dense[-1]``)
    spaced in time by the minimum-jerk profile over the path's arc length
    (:class:`PathSampler`; the chest's phasing is in the path itself,
    :class:`~reach_addon.core.torso.ChestPath`). Returns (poses, their arc lengths, the
    sampler), so that a later pass can put more frames where it must slow down."""
    sampler = PathSampler(generator, dense)
    if frames < 2 or len(dense) < 2:
        return [dense[0]] * max(frames, 1), [0.0] * max(frames, 1), sampler
    arcs = [float(minimum_jerk(f / (frames - 1))) * sampler.total for f in range(frames)]
    return [sampler(a) for a in arcs], arcs, sampler
