"""Straight lines in joint space: the shortest way there is, tried before anything that
samples or searches where a way must be found (:func:`straight_to_goal`). The sampling
planner tries it first (:func:`~.sampling.sampling_steps`), and so does a chase's plan
ahead where the search's way is too long for its frames (:func:`~.sampling.straight_poses`).
The goal poses span the chest's whole range, which the sampling planner's own goal region
does not.
"""

from __future__ import annotations

import math

import numpy as np

from . import ik


#: The chest rotations (degrees apart) whose goal poses :func:`straight_to_goal` tries.
STRAIGHT_CHEST_STEP = 10.0


def straight_to_goal(generator, target, start_row, validity, space):
    """A straight line in joint space from ``start_row`` to a goal pose at ``target``, every
    state a step of the metric apart valid, or None: tried before the sampling planner,
    toward the goal poses at the chest rotations every :data:`STRAIGHT_CHEST_STEP` degrees
    over its range, the nearest in the metric first. The sampling planner's goal region
    holds only this reach's chest and the start's, and its chest range only what lies
    between them: fuzz seeds 1286 and 7624 failed after 200,000 states where the
    cross-check's OMPL, over the whole chest range, went straight to a goal with the chest
    at -30°. ``validity``, ``space``: the sampling planner's state test and joint space
    (:class:`~.sampling.StateValidity`, :class:`~.sampling.JointSpace`), for ``start_row``."""
    s = generator.settings
    limit = float(s.chest_rotation_max) if s.chest_rotation else 0.0
    n = int(math.floor(limit / STRAIGHT_CHEST_STEP))
    rows = [q for k in range(-n, n + 1)
            for q in goal_rows(generator, target, k * STRAIGHT_CHEST_STEP, validity)]
    rows.sort(key=lambda q: space.distance(start_row, q))
    for goal in rows:
        steps = max(1, int(math.ceil(space.distance(start_row, goal) / s.step)))
        if all(validity.valid(start_row + (goal - start_row) * (k / steps))
               for k in range(1, steps + 1)):
            return [start_row, goal]
    return None


def goal_rows(generator, target, body: float, validity, spread: bool = False) -> list:
    """The IK's legal swivel solutions with the wrist on ``target`` (canonical) and the chest
    at ``body`` degrees, each with the most relaxed hand sample ``validity`` accepts
    (configuration rows (7,)), strongest first; ``spread``: every other ranked solution
    first, so that the first few are not one narrow cluster."""
    s = generator.settings
    hands = sorted(generator.hand_samples, key=lambda h: generator._relax[h])
    sol = ik.solve(generator.arm, np.asarray(target, dtype=float)[None], s, None, body)
    ranked = sol.ranked(0, s.elbow_side)
    if spread:
        ranked = ranked[::2] + ranked[1::2]
    rows = []
    for k in ranked:
        config = sol.config(0, k).as_array()
        for hand in hands:
            q = np.concatenate([config, hand])
            if validity.valid(q):
                rows.append(q)
                break
    return rows
