"""Body (chest) rotation read from the reach direction: the paper's Table 1.

The paper (after Delleman 2003) gives the chest's rotation about the vertical axis as
``max(0, direction × slope + intercept)``, with slope 0.50 and intercept -26.7 at a reach
distance of 75 cm, 0.45 and -18.9 at 85 cm. The direction is the wrist's horizontal angle
from straight ahead in the canonical arm frame (:mod:`reach_addon.core.arm`), positive
toward the reaching side; angles in degrees. The distance is measured to the point the
hand reaches and scaled to the study's population by arm length
(:func:`table1_distance`); between and beyond the rows, slope and intercept are
interpolated and extrapolated linearly in distance; the rotation is capped at
``Settings.chest_rotation_max``. Along one reach the chest hands over from its start
rotation to Table 1, phased behind the arm (:class:`ChestPath`).
"""

from __future__ import annotations

import math

import numpy as np

from .numeric import ARRAY, SCALAR, ops

#: Table 1: (reach distance in metres, slope, intercept in degrees).
TABLE1 = ((0.75, 0.50, -26.7), (0.85, 0.45, -18.9))
#: Shoulder-to-wrist length of the subject behind Table 1 (see the module docstring).
TABLE1_REFERENCE_ARM_LENGTH_M = 0.58
#: Where the hand's reach is measured, as a fraction of the hand's length beyond the wrist.
TABLE1_HAND_POINT = 1.0
#: Default cap on the chest's rotation (degrees; see the module docstring).
CHEST_ROTATION_MAX_DEG = 60.0


def _operand(x):
    """(namespace, value): plain numbers stay numbers, anything else becomes an array."""
    m = ops(x)
    return (m, x) if m is SCALAR else (m, np.asarray(x, dtype=float))


def table1_coefficients(distance_m):
    """(slope, intercept) of Table 1 at a reach distance (the table's metres).

    .. math::
        t = \\frac{d - 0.75}{0.85 - 0.75},\\quad slope = 0.50 - 0.05\\,t,\\quad
        intercept = \\min(0,\\ -26.7 + 7.8\\,t)

    linear between the 75 cm and 85 cm rows and extrapolated beyond them (the intercept
    never positive, so the starting angle stays at or above 0°)."""
    m, distance = _operand(distance_m)
    (d0, s0, i0), (d1, s1, i1) = TABLE1
    t = (distance - d0) / (d1 - d0)
    return s0 + (s1 - s0) * t, m.minimum(i0 + (i1 - i0) * t, 0.0)


def starting_angle_deg(distance_m):
    """The reach direction at which the chest starts to turn: -intercept / slope
    (53.4° at 75 cm, 42.0° at 85 cm, larger for nearer targets)."""
    slope, intercept = table1_coefficients(distance_m)
    return -intercept / slope


def chest_rotation_deg(direction_deg, distance_m, max_deg=None):
    """Chest rotation from reach direction and distance (Table 1).

    .. math:: θ_{chest} = \\min(θ_{max},\\ \\max(0,\\ direction × slope(d) + intercept(d)))

    with slope and intercept from :func:`table1_coefficients`. ``distance_m`` is already
    measured to the hand and scaled to the paper's subject (see :func:`table1_distance`).
    Floats in, float out; arrays in, array out.
    """
    if isinstance(direction_deg, float) and isinstance(distance_m, float):
        return _chest_rotation_float(direction_deg, distance_m, max_deg)
    m, direction = _operand(direction_deg)
    m2, distance = _operand(distance_m)
    if m is not m2:
        m, direction, distance = ARRAY, np.asarray(direction, float), np.asarray(distance, float)
    slope, intercept = table1_coefficients(distance)
    rotation = m.maximum(0.0, direction * slope + intercept)
    if max_deg is not None:
        rotation = m.minimum(rotation, max_deg)
    return rotation


def _chest_rotation_float(direction: float, distance: float, max_deg) -> float:
    """:func:`chest_rotation_deg` for one float reach, step by step (the planner asks for
    every wrist position it tries)."""
    (d0, s0, i0), (d1, s1, i1) = TABLE1
    t = (distance - d0) / (d1 - d0)
    intercept = i0 + (i1 - i0) * t
    rotation = direction * (s0 + (s1 - s0) * t) + (intercept if intercept < 0.0 else 0.0)
    rotation = rotation if rotation > 0.0 else 0.0
    if max_deg is not None and rotation > max_deg:
        rotation = max_deg
    return rotation


def reach_direction_deg(points):
    """Horizontal direction of canonical-frame points from straight ahead, positive toward
    the reaching side: atan2(x, y) in degrees, in (-180°, 180°]."""
    p = np.asarray(points, dtype=float)
    return np.degrees(np.arctan2(p[..., 0], p[..., 1]))


def reach_distance(points):
    """Horizontal distance of canonical-frame points from the spine axis: √(x² + y²)."""
    p = np.asarray(points, dtype=float)
    return np.hypot(p[..., 0], p[..., 1])


def table1_distance(horizontal, arm_length, hand_length, settings):
    """The reach distance Table 1 is read at, in the table's metres, from the wrist's
    horizontal distance to the spine axis (the figure's units).

    .. math:: d_{table} = (\\sqrt{x_w^2 + y_w^2} + k_{hand} L_{hand}) × L_{ref} / L_{figure}

    ``k_hand`` = ``settings.table1_hand_point``, ``L_ref`` = ``settings.table1_arm_length_m``,
    ``L_figure`` = ``arm_length`` (shoulder to wrist). Floats or arrays."""
    return ((horizontal + settings.table1_hand_point * hand_length)
            * (settings.table1_arm_length_m / arm_length))


def body_rotation_deg(wrists, arm_length, hand_length, settings):
    """Chest rotation for wrist positions (canonical frame, the figure's units): a float
    for one point (3,), an array for (..., 3).

    The multi-joint function of the paper: Table 1 read at the wrist's direction and at
    :func:`table1_distance`. Zero when ``settings.chest_rotation`` is off.
    """
    wrists = np.asarray(wrists, dtype=float)
    if wrists.shape == (3,):
        if not settings.chest_rotation:
            return 0.0
        x, y = float(wrists[0]), float(wrists[1])
        return chest_rotation_deg(
            math.degrees(math.atan2(x, y)),
            float(table1_distance(math.hypot(x, y), arm_length, hand_length, settings)),
            settings.chest_rotation_max)
    if not settings.chest_rotation:
        return np.zeros(wrists.shape[:-1])
    return np.asarray(chest_rotation_deg(
        reach_direction_deg(wrists),
        table1_distance(reach_distance(wrists), arm_length, hand_length, settings),
        settings.chest_rotation_max))


def spine_rotation_matrix(angle_deg):
    """Rotation about the vertical spine axis turning the chest by ``angle_deg`` toward the
    reaching side (+x): forward (0, 1, 0) goes to (sin θ, cos θ, 0). Shape (..., 3, 3)."""
    t = np.radians(np.asarray(angle_deg, dtype=float))
    c, s = np.cos(t), np.sin(t)
    zero, one = np.zeros_like(t), np.ones_like(t)
    return np.stack([
        np.stack([c, s, zero], -1),
        np.stack([-s, c, zero], -1),
        np.stack([zero, zero, one], -1),
    ], -2)


def turn_about_spine(p, cos_t: float, sin_t: float) -> list:
    """:func:`rotate_about_spine` of one point (a float 3-sequence) by the angle whose
    cosine and sine are given, on plain floats (the body test turns the chest's capsules
    for every chest rotation it meets)."""
    return [p[0] * cos_t + p[1] * sin_t, p[1] * cos_t - p[0] * sin_t, p[2]]


def rotate_about_spine(points, angle_deg):
    """Points carried by a chest rotation of ``angle_deg`` (broadcasts over angles):
    the initial shoulder position rotated about the vertical axis through the spine,
    (x, y, z) → (x cos θ + y sin θ, -x sin θ + y cos θ, z)."""
    p = np.asarray(points, dtype=float)
    t = np.radians(np.asarray(angle_deg, dtype=float))
    c, s = np.cos(t), np.sin(t)
    x, y = p[..., 0], p[..., 1]
    shape = np.broadcast_shapes(p.shape[:-1], np.shape(t))
    out = np.empty(shape + (3,))
    out[..., 0] = x * c + y * s
    out[..., 1] = y * c - x * s
    out[..., 2] = p[..., 2]
    return out


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


class ChestPath:
    """The chest rotation along one reach, as a function of the wrist position.

    Table 1 comes from static reaching postures (Delleman 2003): it says how far the chest
    is turned *when the hand is at the target*. A reach, though, starts from whatever pose
    the figure is in — an A-posed arm hangs far enough out that Table 1 would already want
    the chest turned. So along a reach the chest hands over from its actual start rotation
    to Table 1:

    .. math::
        θ(w) = T_1(w) + (θ_0 - T_1(w_0))\\,\\min\\left(1, \\frac{|w - t|}{|w_0 - t|}\\right)

    with ``w_0`` and ``θ_0`` the start wrist and chest rotation and ``t`` the target: equal
    to the start rotation at the start, to Table 1 at the target, continuous in between,
    and still a function of the wrist position alone (the paper's dimensionality
    reduction). Capped at ``Settings.chest_rotation_max`` either way. ``target_rotation``:
    the rotation the reach should arrive with where Table 1's puts no clear arm on the
    target (:meth:`~reach_addon.core.generator.ConfigurationGenerator.target_chest`); it
    takes over from Table 1 as the wrist nears the target, as the start's hands over,
    + (θ_t − T_1(t)) (1 − min(1, |w − t| / |w_0 − t|)).

    Phasing (paper: "the joint recruitments are phased; they do not all change
    simultaneously"): the arm leads and the chest follows. The turn from θ_0 toward θ(w)
    is recruited by the reach's progress p = 1 - |w - t| / |w_0 - t| through the
    minimum-jerk profile delayed by δ = ``Settings.chest_phase_delay``,

    .. math:: θ_p(w) = θ_0 + (θ(w) - θ_0)\\, s\\left(\\frac{p - δ}{1 - δ}\\right)

    so the chest starts turning once the wrist is δ of the way, and the whole motion,
    searched and timed, carries it (the timing then needs no second IK solve).
    """

    def __init__(self, arm_length, hand_length, settings, start_wrist, start_rotation, target,
                 target_rotation=None):
        self.arm_length = arm_length
        self.hand_length = hand_length
        self.settings = settings
        self.target = np.asarray(target, dtype=float)
        start_wrist = np.asarray(start_wrist, dtype=float)
        self.offset = float(start_rotation) - float(body_rotation_deg(start_wrist, arm_length,
                                                                        hand_length, settings))
        self.arrival = 0.0 if target_rotation is None else float(target_rotation) - float(
            body_rotation_deg(self.target, arm_length, hand_length, settings))
        self.span = float(np.linalg.norm(start_wrist - self.target))
        self.start_rotation = float(start_rotation)

    def __call__(self, wrist) -> float:
        wrist = np.asarray(wrist, dtype=float)
        table = float(body_rotation_deg(wrist, self.arm_length, self.hand_length,
                                        self.settings))
        if self.span <= 1e-12:
            return table
        remaining = min(1.0, math.dist(wrist.tolist(), self.target.tolist()) / self.span)
        limit = self.settings.chest_rotation_max
        handed = min(max(table + self.offset * remaining + self.arrival * (1.0 - remaining),
                         -limit), limit)
        recruited = phased(1.0 - remaining, self.settings.chest_phase_delay)
        return self.start_rotation + (handed - self.start_rotation) * float(recruited)
