"""The hand pass's states: a grid of wrist angles (bend in the elbow's plane, side bend
across it, degrees) over the wrist's range, joined to the start hand, and the turn between
any two of them.

A state's hand direction is given by its coefficients along the hand's frame (f, p, h) of
:func:`~reach_addon.core.arm.hand_coefficients`; turns are the angles between directions
(degrees, relative to the forearm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .arm import hand_coefficients


@dataclass(frozen=True)
class HandGrid:
    """The wrist-angle states: ``angles`` (S, 2) degrees, ``coefficients`` (S, 3) (see
    :func:`~reach_addon.core.arm.hand_coefficients`), ``turn`` (S, S) degrees between
    their directions, ``bend`` (S,) degrees from the neutral wrist (the ``rest`` of
    :func:`hand_grid`); ``start`` the start state."""

    angles: np.ndarray
    coefficients: np.ndarray
    turn: np.ndarray
    bend: np.ndarray
    start: int


def wrist_turn(coefficients_a, coefficients_b):
    """Angle (degrees) between hand directions given by their coefficients (…, 3)."""
    dot = np.einsum("...i,...i->...", coefficients_a, coefficients_b)
    return np.degrees(np.arccos(np.clip(dot, -1.0, 1.0)))


def bend_step(step: float, bound: float) -> float:
    """The grid's bend step: ``step`` (``Settings.hand_grid_step``) shortened so that a
    whole number of steps makes the turn bound a frame, ``bound`` / ⌈``bound`` / ``step``⌉
    (5° at 24 fps, 4.8° at 25, 4° at 30): a hand relaxing as fast as the bound allows
    moves by the bound each frame, not by the largest multiple of ``step`` below it
    (10° a frame at 25 fps with 5° steps and a 14.4° bound)."""
    if bound <= 0.0 or not math.isfinite(bound):
        return step
    return bound / math.ceil(bound / step - 1e-9)


def hand_grid(settings, start_hand, bound: float, extra=(), rest=(1.0, 0.0, 0.0)) -> HandGrid:
    """The grid of wrist angles (bends every :func:`bend_step` from 0 out to the wrist's
    limit, which is a state too), plus the start hand and a chain of states (at most half
    the bound apart) from it to the nearest grid state, then the ``extra`` states (the
    wanted hand of :mod:`.orient`, when the hand is matched to a target's orientation).
    ``rest``: the neutral wrist's coefficients (``ArmModel.rest_coefficients``) the states'
    ``bend`` is measured from (:func:`wrist_turn`)."""
    step = bend_step(settings.hand_grid_step, bound)
    b_max, s_max = settings.wrist_bend_max, settings.wrist_side_max
    if b_max > 0:
        half = list(np.arange(1, math.floor(b_max / step + 1e-9) + 1) * step)
        if b_max - (half[-1] if half else 0.0) > 1e-9:
            half.append(b_max)                   # the wrist's limit is a state too
        bends = np.concatenate([-np.array(half[::-1]), [0.0], half])
    else:
        bends = [0.0]
    n_side = 2 * math.ceil(s_max / (2.5 * settings.hand_grid_step)) + 1 if s_max > 0 else 1
    sides = np.linspace(-s_max, s_max, n_side) if s_max > 0 else [0.0]
    grid = [(float(b), float(s)) for b in bends for s in sides]
    coef = np.array([hand_coefficients(b, s) for b, s in grid])
    start = (float(start_hand[0]), float(start_hand[1]))
    c0 = np.array(hand_coefficients(*start))
    near = int(np.argmin(wrist_turn(coef, c0)))
    gap = float(wrist_turn(coef[near], c0))
    chain = []
    n = math.ceil(gap / (0.5 * bound)) if gap > 1e-6 else 0
    for k in range(n):
        t = k / n
        chain.append((start[0] + t * (grid[near][0] - start[0]),
                      start[1] + t * (grid[near][1] - start[1])))
    if not chain:
        chain = [start]
    chain += [(float(b), float(s)) for b, s in extra]
    angles = np.array(grid + chain)
    coefficients = np.vstack([coef, [hand_coefficients(b, s) for b, s in chain]])
    turn = wrist_turn(coefficients[:, None], coefficients[None])
    bend = wrist_turn(coefficients, rest)
    return HandGrid(angles, coefficients, turn, bend, len(grid))
