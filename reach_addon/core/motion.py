"""From a searched path to motion: shortcut smoothing, then minimum-jerk timing into frames.

The search path zig-zags where it went around obstacles. :func:`shortcut` replaces runs of
it by straight wrist segments wherever every position along the segment (sampled at most
one search step apart) has a legal, smooth, collision-free pose; the output is the *dense*
validated pose sequence along the smoothed path.

:func:`time_path` then places the frames along that sequence with a minimum-jerk
(bell-shaped) speed profile — the "velocity profile" the paper lists as future work:

.. math:: s(τ) = 10τ^3 - 15τ^4 + 6τ^5,\\quad τ = t / T

Every frame is solved again from the previous frame (smoothness bound scaled to the frame's
move) and collision-checked; if that fails, the frame takes the nearest validated pose of
the dense sequence. So every output pose is legal and collision-free.

Phasing (paper: "the joint recruitments are phased; they do not all change
simultaneously"): the arm leads and the chest follows. The chest rotation of frame τ is
interpolated from its start to its end value with the minimum-jerk profile delayed by
``Settings.chest_phase_delay`` of the duration, s((τ - δ)/(1 - δ)); the arm's IK is solved
around that chest. Where that pose fails, the frame falls back to Table 1's chest.
"""

from __future__ import annotations

import math

import numpy as np

from .arm import Pose
from .generator import ConfigurationGenerator


def minimum_jerk(tau):
    """s(τ) = 10τ³ - 15τ⁴ + 6τ⁵ on [0, 1] (clipped outside): position fraction of a
    minimum-jerk move at time fraction τ."""
    t = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    out = t * t * t * (10.0 + t * (-15.0 + 6.0 * t))
    return out if out.ndim else float(out)


def phased(tau, delay):
    """Minimum-jerk progress of a joint recruited after ``delay`` of the move:
    s((τ - δ) / (1 - δ))."""
    if delay >= 1.0:
        return minimum_jerk(np.asarray(tau) >= 1.0)
    return minimum_jerk((np.asarray(tau, dtype=float) - delay) / (1.0 - delay))


def wrist_path_length(poses) -> float:
    pts = np.array([p.wrist for p in poses])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()) if len(pts) > 1 else 0.0


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

    Greedy: from the current node, try to jump straight to the path's end; failing that,
    to nodes 2, 4, 8, ... ahead until a jump fails, then bisect between the last good and
    the first bad jump. The junctions are the search's own poses, so a one-node jump
    (an edge of the search path) always stands.
    """
    if len(path) <= 2:
        return list(path)
    out = [path[0]]
    i, last = 0, len(path) - 1
    while i < last:
        seg = connect(generator, out[-1], path[last]) if last - i > 1 else None
        if seg is not None:
            out += seg
            break
        good, good_seg = i + 1, [path[i + 1]]
        jump, bad = 2, last
        while i + jump < last:
            seg = connect(generator, out[-1], path[i + jump])
            if seg is None:
                bad = i + jump
                break
            good, good_seg = i + jump, seg
            jump *= 2
        while bad - good > 1:
            mid = (good + bad) // 2
            seg = connect(generator, out[-1], path[mid])
            if seg is None:
                bad = mid
            else:
                good, good_seg = mid, seg
        out += good_seg
        i = good
    return out


def auto_duration(path_length_arm_lengths: float, settings) -> float:
    """Automatic duration of a reach: path length / ``Settings.mean_speed``, at least
    ``Settings.min_duration`` seconds."""
    return max(settings.min_duration, path_length_arm_lengths / settings.mean_speed)


def time_path(generator: ConfigurationGenerator, dense: list, frames: int):
    """``frames`` poses (the first is ``dense[0]``, the last sits at ``dense[-1]``'s wrist)
    spaced in time by the minimum-jerk profile, with phased chest rotation. Returns
    (poses, number of frames that fell back to a validated pose)."""
    if frames < 2 or len(dense) < 2:
        return [dense[0]] * max(frames, 1), 0
    s = generator.settings
    pts = np.array([p.wrist for p in dense])
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    total = cum[-1]
    chest0, chest1 = dense[0].config.body_rotation, dense[-1].config.body_rotation
    out = [dense[0]]
    snapped = 0
    for f in range(1, frames):
        tau = f / (frames - 1)
        arc = minimum_jerk(tau) * total
        k = int(np.clip(np.searchsorted(cum, arc, side="right") - 1, 0, len(dense) - 2))
        frac = 0.0 if seg[k] <= 0 else (arc - cum[k]) / seg[k]
        wrist = pts[k] + (pts[k + 1] - pts[k]) * frac
        prev = out[-1]
        pose = None
        if s.chest_rotation:
            chest = chest0 + (chest1 - chest0) * phased(tau, s.chest_phase_delay)
            pose = generator.solve(wrist, prev, body_rotation=chest, hand_scale=1.0)
        if pose is None:
            pose = generator.solve(wrist, prev, hand_scale=1.0)
        if pose is None:
            pose = generator.solve(wrist, prev, hand_scale=generator.move_scale(prev, wrist))
        if pose is None:
            pose = dense[k + 1] if frac >= 0.5 else dense[k]
            snapped += 1
        out.append(pose)
    return out, snapped
