"""What makes an arm configuration legal and a move smooth: the joint limits of a move,
the elbow's side (the paper's Algorithm 1) and the smoothness bound.

Angles in degrees, over (α, β, γ, θ): the shoulder angles and the elevation θ of
:mod:`~reach_addon.core.arm`. Limits are (lower, upper) arrays (4, 1), for one comparison
per side against the (W, 4, S) angle blocks of :func:`~reach_addon.core.ik.solve`. The
smoothness bound: no joint angle changes by more than ``max_change`` degrees in one move
(the twist measured the short way round, :func:`twist_change`).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .arm import ArmConfig, ArmModel, forward_kinematics
from .numeric import ARRAY, SCALAR

#: An elbow with sin ε below this is straight: its twist cannot be seen and is kept.
STRAIGHT = 1e-6


def side_normal(wrist, shoulder, waist, m=ARRAY):
    r"""Algorithm 1, RightArmSide(w, e, s, a): the normal of the plane P through wrist,
    shoulder and waist, from (x, y, z) component tuples (floats with ``m`` = SCALAR, arrays
    with ARRAY). Returns (n_x, n_y, n_z, degenerate): degenerate where P is undefined.

    .. math::
        \hat n = \mathrm{normalize}[(s - w) × (a - s)],\quad
        \hat p = \mathrm{normalize}(e - e_P),\quad
        \text{RIGHT} \iff \hat p = \hat n

    where ``e_P`` is the projection of the elbow ``e`` on P; callers test ``p̂ = n̂`` as
    ``(e - s) · n̂ > 0`` (:func:`~reach_addon.core.ik.solve` for every swivel sample at once, with ``e - s``
    affine in the swivel angle). Where P is degenerate every elbow counts as RIGHT. For a
    right arm reaching forward n̂ points outward and down, so RIGHT is the natural,
    elbow-out side; in the canonical frame a left arm is mirrored into a right arm and the
    same rule gives its natural (left) side."""
    px, py, pz = shoulder[0] - wrist[0], shoulder[1] - wrist[1], shoulder[2] - wrist[2]
    qx, qy, qz = waist[0] - shoulder[0], waist[1] - shoulder[1], waist[2] - shoulder[2]
    kx, ky, kz = py * qz - pz * qy, pz * qx - px * qz, px * qy - py * qx
    kn = m.sqrt(kx * kx + ky * ky + kz * kz)
    degenerate = kn < 1e-9
    kn = m.maximum(kn, 1e-12)
    return kx / kn, ky / kn, kz / kn, degenerate


_LAST_LIMITS: list = [None, None]


def settings_limits(st):
    """:func:`_limits` of a settings object (the last one asked for is remembered: the
    planner asks with the same object every time)."""
    if _LAST_LIMITS[0] is not st:
        _LAST_LIMITS[1] = _limits(st.alpha_min, st.beta_min, st.gamma_min, st.alpha_max,
                                  st.beta_max, st.gamma_max, st.elevation_max)
        _LAST_LIMITS[0] = st
    return _LAST_LIMITS[1]


@lru_cache(maxsize=16)
def _limits(alpha_min, beta_min, gamma_min, alpha_max, beta_max, gamma_max, elevation_max):
    """Lower and upper limits (4, 1) of (α, β, γ, θ), for one comparison per side."""
    lo = np.array([[alpha_min], [beta_min], [gamma_min], [-np.inf]])
    hi = np.array([[alpha_max], [beta_max], [gamma_max], [elevation_max]])
    return lo, hi


def move_limits(st, previous: ArmConfig | None):
    """The joint limits (lower, upper), each (4, 1) over (α, β, γ, θ), of a move from
    ``previous``: the settings' limits widened to take in ``previous``'s own angles.

    A rig's start pose is taken as it is held, outside the limits or not (a T-posed arm
    whose slight bend reads as a humeral twist of -130°; an arm raised past the elevation
    limit): the limits bound where a move may go, never where it starts. A move from a
    pose outside them may stay as far out or come back in, never go farther out, so the
    arm returns toward the legal range as it moves and the target's own pose (solved with
    no previous pose) is always inside it. :func:`~reach_addon.core.ik.solve` widens the
    elbow's flexion limits the same way."""
    lo, hi = settings_limits(st)
    if previous is None:
        return lo, hi
    alpha, beta = previous.alpha, previous.beta
    gamma = (previous.gamma + 180.0) % 360.0 - 180.0
    theta = math.hypot(alpha, beta)
    if lo[0, 0] <= alpha <= hi[0, 0] and lo[1, 0] <= beta <= hi[1, 0] and \
            lo[2, 0] <= gamma <= hi[2, 0] and theta <= hi[3, 0]:
        return lo, hi
    own = np.array([[alpha], [beta], [gamma], [theta]])
    return np.minimum(lo, own), np.maximum(hi, own)


def on_elbow_side(arm: ArmModel, config: ArmConfig) -> bool:
    """Is the elbow of ``config`` on Algorithm 1's preferred side (:func:`side_normal`),
    or the side undefined there (a straight elbow, a degenerate plane)? Remembered on the
    arm for the last configurations asked about (a search asks once per node, for each of
    the positions it tries from there)."""
    cache = arm.side_cache
    side = cache.get(config)
    if side is None:
        joints, _bend = forward_kinematics(arm, config.as_array())
        s, e, w = joints[1].tolist(), joints[2].tolist(), joints[3].tolist()
        nx, ny, nz, degenerate = side_normal(w, s, arm.waist.tolist(), SCALAR)
        value = (e[0] - s[0]) * nx + (e[1] - s[1]) * ny + (e[2] - s[2]) * nz
        side = bool(degenerate or value > 0.0
                    or math.sin(math.radians(config.elbow)) < STRAIGHT)
        if len(cache) >= 256:
            cache.clear()
        cache[config] = side
    return side


def valid_bounds(limits, previous: ArmConfig, body: float, flex: float, max_change: float):
    """(lower, upper) bounds (4, 1) on (α, β, γ, θ) of one wrist's candidates that are both
    legal and within the smoothness bound of ``previous`` (:func:`smooth`): the joint
    ``limits`` (:func:`move_limits`) intersected with ``previous ± max_change`` for α and β
    and with the twist window ``|γ - γ'| ≤ limit`` (mod 360°) for γ. None when nothing can
    be valid (the body or the elbow moves too far, or the windows miss the limits); a third
    element when the twist window meets the limits in two pieces (the caller then tests γ
    in full)."""
    if not (abs(flex - previous.elbow) <= max_change
            and abs(body - previous.body_rotation) <= max_change):
        return None
    (alpha_min, beta_min, gamma_min, _t), (alpha_max, beta_max, gamma_max, elevation_max) = \
        limits[0][:, 0].tolist(), limits[1][:, 0].tolist()
    a_lo, a_hi = max(alpha_min, previous.alpha - max_change), \
        min(alpha_max, previous.alpha + max_change)
    b_lo, b_hi = max(beta_min, previous.beta - max_change), \
        min(beta_max, previous.beta + max_change)
    if a_lo > a_hi or b_lo > b_hi:
        return None
    twist = max_change
    g_lo, g_hi, split = gamma_min, gamma_max, False
    if twist < 180.0:
        centre = (previous.gamma + 180.0) % 360.0 - 180.0     # wrap_degrees, on a float
        pieces = [(max(g_lo, centre + k - twist), min(g_hi, centre + k + twist))
                  for k in (-360.0, 0.0, 360.0)]
        pieces = [q for q in pieces if q[0] <= q[1]]
        if not pieces:
            return None
        if len(pieces) == 1:
            g_lo, g_hi = pieces[0]
        else:
            split = True
    bounds = np.array([a_lo, b_lo, g_lo, -np.inf, a_hi, b_hi, g_hi,
                       elevation_max]).reshape(2, 4, 1)
    return (bounds[0], bounds[1], True) if split else (bounds[0], bounds[1])


def smooth_angles(previous: ArmConfig, body, angles, flex, max_change, m):
    """:func:`smooth` on the (W, 4, S) angle block of :func:`~reach_addon.core.ik.solve` (α, β, γ, θ), the
    twist's change by :func:`twist_change`."""
    if m is SCALAR:
        if not (abs(flex - previous.elbow) <= max_change
                and abs(body - previous.body_rotation) <= max_change):
            return np.zeros((1, angles.shape[2]), dtype=bool)
        wrist_ok = True
    else:
        wrist_ok = ((np.abs(flex - previous.elbow) <= max_change)
                    & (np.abs(body - previous.body_rotation) <= max_change))[:, None]
    within = np.abs(angles[:, :2] - np.array([[previous.alpha], [previous.beta]])) <= max_change
    twist_ok = twist_change(angles[:, 2], previous.gamma) <= max_change
    return within[:, 0] & within[:, 1] & twist_ok & wrist_ok


def wrap_degrees(angle):
    """Angle difference folded into [-180°, 180°)."""
    return (np.asarray(angle) + 180.0) % 360.0 - 180.0


def twist_change(gamma, previous_gamma):
    """How far the humeral twist turns from ``previous_gamma`` to ``gamma`` (degrees), the
    short way round the circle: |wrap(γ - γ_prev)| ∈ [0°, 180°] (:func:`wrap_degrees`).
    The smoothness bound (:func:`smooth`) and its window (:func:`valid_bounds`) use it."""
    # wrap(γ - γ_prev) = (γ - (γ_prev - 180°)) mod 360° - 180°: one array operation fewer
    return np.abs((gamma - (previous_gamma - 180.0)) % 360.0 - 180.0)


def smooth(previous: ArmConfig, body, alpha, beta, gamma, flex, max_change):
    """The smoothness bound: no joint angle changes by more than ``max_change`` degrees from
    ``previous``. Shapes: ``body``/``flex`` (W,) (or floats for one wrist), the shoulder
    angles (W, S). The twist counts like the others even with a straight elbow, where the
    arm's bones hide it: the hand's roll shows it."""
    if isinstance(flex, float) and isinstance(body, float):
        if not (abs(flex - previous.elbow) <= max_change
                and abs(body - previous.body_rotation) <= max_change):
            return np.zeros(np.shape(alpha), dtype=bool)
        return ((np.abs(alpha - previous.alpha) <= max_change)
                & (np.abs(beta - previous.beta) <= max_change)
                & (twist_change(gamma, previous.gamma) <= max_change))
    else:
        flex = np.asarray(flex)
        wrist_ok = ((np.abs(flex - previous.elbow) <= max_change)
                    & (np.abs(np.asarray(body) - previous.body_rotation) <= max_change))[:, None]
    return (wrist_ok & (np.abs(alpha - previous.alpha) <= max_change)
            & (np.abs(beta - previous.beta) <= max_change)
            & (twist_change(gamma, previous.gamma) <= max_change))

