"""The shoulder strength model of Zhao, Liu & Badler (2005), section "Human strength model".

Angles in degrees, in the convention of :mod:`reach_addon.core.arm` (α abduction, β
flexion, γ humeral twist); strengths in the paper's units (percent of a reference
exertion). Every function takes floats or numpy arrays and broadcasts.

The paper's three-level ranking: (1) ``f_R = f_H + f_V``, how many of the two directions
fall below their preferred level; (2) within ``f_R = 0`` the least exertion ``f_E``, within
``f_R = 1`` the largest strength gain ``f_S``, within ``f_R = 2`` the balanced gain
``f_T``; (3) the elbow's preferred side (Algorithm 1, :mod:`~reach_addon.core.limits`).
:func:`rank_order` implements levels 1 and 2 (level 3 as an optional first key).
``Settings.strength_reading`` chooses the angles the curves are read at
(:func:`strength_angles`).
"""

from __future__ import annotations

import math

from functools import cache

import numpy as np

# Each curve is a list of pieces (lower, upper, upper_inclusive, (c0, c1, c2)) giving
# c0 + c1·x + c2·x² on [lower, upper) or [lower, upper]. The first piece's lower bound and
# the last piece's upper bound are the curve's domain.
_S_H_PIECES = (
    (-60.0, 0.0, False, (65.0, 0.33, 0.0)),
    (0.0, 90.0, True, (65.0, -0.23, 0.0)),
    (90.0, 180.0, True, (54.0, -0.11, 0.0)),
)
_S_V_PIECES = (
    (-60.0, -30.0, False, (56.666, 0.793, 0.0)),
    (-30.0, 0.0, False, (65.752, 1.096, 0.0)),
    (0.0, 180.0, True, (65.752, -0.51383, 1.1058e-3)),
)


def _evaluate(pieces, x):
    """A curve at ``x``: a float, or an array of any shape (the pieces on arrays)."""
    if isinstance(x, (float, int)):
        return _float_curve(pieces)(float(x))
    x = np.minimum(np.maximum(np.asarray(x, dtype=float), pieces[0][0]), pieces[-1][1])
    _lo, _hi, _inc, (c0, c1, c2) = pieces[-1]
    out = c0 + x * (c1 + c2 * x) if c2 else c0 + c1 * x
    for _lo, hi, inclusive, (c0, c1, c2) in reversed(pieces[:-1]):
        value = c0 + x * (c1 + c2 * x) if c2 else c0 + c1 * x
        out = np.where((x <= hi) if inclusive else (x < hi), value, out)
    return out if out.ndim else float(out)


@cache
def _float_curve(pieces):
    """A curve's pieces as a function of one float (no type checks: the scorer of the few
    candidates of one wrist calls it for each)."""
    lo, hi = pieces[0][0], pieces[-1][1]
    rows = tuple((h, inclusive, c0, c1, c2) for _lo, h, inclusive, (c0, c1, c2) in pieces)
    *_, (_h, _i, c0_last, c1_last, c2_last) = rows

    def evaluate(x: float) -> float:
        x = lo if x < lo else hi if x > hi else x
        for h, inclusive, c0, c1, c2 in rows:
            if x < h or (inclusive and x == h):
                return c0 + x * (c1 + c2 * x)
        return c0_last + x * (c1_last + c2_last * x)

    return evaluate


_s_h_float = _float_curve(_S_H_PIECES)
_s_v_float = _float_curve(_S_V_PIECES)


def _minimum(pieces):
    """The least value of a piecewise quadratic over its domain: endpoints and vertices."""
    candidates = []
    for lo, hi, _inclusive, (c0, c1, c2) in pieces:
        xs = [lo, hi]
        if c2 != 0.0 and lo < -c1 / (2.0 * c2) < hi:
            xs.append(-c1 / (2.0 * c2))
        candidates += [c0 + c1 * x + c2 * x * x for x in xs]
    return min(candidates)


def strength_horizontal(alpha_deg):
    """S_H(α), shoulder abduction/adduction strength.

    .. math::
        S_H(α) = \\begin{cases}
            65 + 0.33 α & -60° ≤ α < 0° \\\\
            65 - 0.23 α & 0° ≤ α ≤ 90° \\\\
            54 - 0.11 α & 90° < α ≤ 180°
        \\end{cases}

    Angles outside the paper's domain [-60°, 180°] are read at the nearest end (the joint
    limits keep legal poses inside it).
    """
    return _evaluate(_S_H_PIECES, alpha_deg)


def strength_vertical(beta_deg):
    """S_V(β), shoulder flexion/extension strength.

    .. math::
        S_V(β) = \\begin{cases}
            56.666 + 0.793 β & -60° ≤ β < -30° \\\\
            65.752 + 1.096 β & -30° ≤ β < 0° \\\\
            65.752 - 0.51383 β + 1.1058·10^{-3} β^2 & 0° ≤ β ≤ 180°
        \\end{cases}

    Angles outside [-60°, 180°] are read at the nearest end.
    """
    return _evaluate(_S_V_PIECES, beta_deg)


#: S_H^min: the least abduction/adduction strength over the curve's domain (34.2 at α = 180°).
S_H_MIN = _minimum(_S_H_PIECES)
#: S_V^min: the least flexion/extension strength over the curve's domain (9.086 at β = -60°).
S_V_MIN = _minimum(_S_V_PIECES)

#: Default preferred level SL_H. The paper gives no number. We take the strength left at 60°
#: of abduction, S_H(60°) = 51.2: ISO 11226 (static working postures) finds upper-arm
#: elevation beyond 60° not acceptable, so strength below that level is what a person
#: avoids. A setting (``Settings.preferred_level_h``).
PREFERRED_LEVEL_H = float(strength_horizontal(60.0))
#: Default preferred level SL_V: S_V(60°) = 38.903, by the same ISO 11226 argument for
#: flexion. A setting (``Settings.preferred_level_v``).
PREFERRED_LEVEL_V = float(strength_vertical(60.0))


#: The readings of α and β that ``Settings.strength_reading`` chooses between.
READINGS = ("split", "horizontal")


def strength_angles(alpha_deg, beta_deg, reading="split"):
    """(α_S, β_S): the angles S_H and S_V are read at, from the shoulder angles (α, β).

    .. math::
        split:\\ (α_S, β_S) = (α, β) \\qquad
        horizontal:\\ (α_S, β_S) = (\\operatorname{atan2}(α, β),\\ \\sqrt{α^2 + β^2})

    ``reading`` (``Settings.strength_reading``): ``"split"`` reads the curves at the joint
    angles themselves, the elevation θ split by the direction φ it is raised toward (α = θ
    cos φ, β = θ sin φ); ``"horizontal"`` at the upper arm's direction in the horizontal
    plane from straight ahead toward the arm's side (0 forward, 90 to the side, 180
    behind, negative across the body), atan2(α, β), and its elevation √(α² + β²) = θ.
    Floats or arrays.

    f_R (SL_H = S_H(60°), SL_V = S_V(60°), the defaults) for the arm raised 60° and 90°:

    =======================  =========  ==============
    arm raised               ``split``  ``horizontal``
    =======================  =========  ==============
    60° sideways             0          1
    90° sideways             1          2
    60° forward              0          0
    90° forward              1          1
    =======================  =========  ==============
    """
    if reading == "split":
        return alpha_deg, beta_deg
    if reading != "horizontal":
        raise ValueError(f"unknown strength reading {reading!r}; one of {READINGS}")
    if isinstance(alpha_deg, float) and isinstance(beta_deg, float):
        return math.degrees(math.atan2(alpha_deg, beta_deg)), math.hypot(alpha_deg, beta_deg)
    a, b = np.asarray(alpha_deg, dtype=float), np.asarray(beta_deg, dtype=float)
    return np.degrees(np.arctan2(a, b)), np.hypot(a, b)


def below_level(strength_value, level):
    """The first-level indicator: 1 where a strength is below its preferred level, else 0
    (f_H and f_V are this applied to S_H(α) and S_V(β))."""
    if isinstance(strength_value, (float, int)):
        return int(strength_value < level)
    return (np.asarray(strength_value) < level).astype(np.int8)


def deficit(strength_value, level, minimum):
    """(SL - S) / (SL - S^min): how far a strength has fallen below its preferred level,
    0 at the level and 1 at the weakest point of its curve (the f_S formula)."""
    return (level - strength_value) / (level - minimum)


def balanced(f_s_alpha, f_s_beta):
    """f_S(α) + f_S(β) - f_S(α)·f_S(β) (the f_T formula)."""
    return f_s_alpha + f_s_beta - f_s_alpha * f_s_beta


def f_h(alpha_deg, level_h):
    """f_H(α) = 0 if S_H(α) ≥ SL_H, else 1."""
    return below_level(strength_horizontal(alpha_deg), level_h)


def f_v(beta_deg, level_v):
    """f_V(β) = 0 if S_V(β) ≥ SL_V, else 1."""
    return below_level(strength_vertical(beta_deg), level_v)


def f_r(alpha_deg, beta_deg, level_h, level_v):
    """f_R(α, β, γ) = f_H(α) + f_V(β), the first-level criterion (0, 1 or 2; smaller is
    stronger)."""
    return f_h(alpha_deg, level_h) + f_v(beta_deg, level_v)


def f_e(alpha, beta, gamma, alpha0, beta0, gamma0, w_alpha, w_beta, w_gamma):
    """f_E, the exertion of a move from (α', β', γ') to (α, β, γ), used when f_R = 0.

    .. math:: f_E = ω_α |α - α'| + ω_β |β - β'| + ω_γ |γ - γ'|

    The weights reflect the strength of the muscles that drive each degree of freedom: a
    weaker group pays more for the same displacement (see ``Settings.weight_*``).
    """
    return w_alpha * abs(alpha - alpha0) + w_beta * abs(beta - beta0) + w_gamma * abs(gamma - gamma0)


def f_s_horizontal(alpha_deg, level_h):
    """f_S(α) = (SL_H - S_H(α)) / (SL_H - S_H^min)."""
    return deficit(strength_horizontal(alpha_deg), level_h, S_H_MIN)


def f_s_vertical(beta_deg, level_v):
    """f_S(β) = (SL_V - S_V(β)) / (SL_V - S_V^min)."""
    return deficit(strength_vertical(beta_deg), level_v, S_V_MIN)


def f_s(alpha_deg, beta_deg, level_h, level_v):
    """f_S(α, β, γ), the second-level criterion when f_R = 1.

    .. math::
        f_S = \\begin{cases}
            (SL_H - S_H(α)) / (SL_H - S_H^{min}) & f_H(α) = 1 \\\\
            (SL_V - S_V(β)) / (SL_V - S_V^{min}) & f_V(β) = 1
        \\end{cases}

    Smaller is preferred (the move with the most strength left). Where neither direction
    is below its level the value is 0.
    """
    sh, sv = strength_horizontal(alpha_deg), strength_vertical(beta_deg)
    out = _f_s(sh, sv, level_h, level_v)
    return out if out.ndim else float(out)


def _f_s(sh, sv, level_h, level_v):
    return np.where(sh < level_h, deficit(sh, level_h, S_H_MIN),
                    np.where(sv < level_v, deficit(sv, level_v, S_V_MIN), 0.0))


def f_t(alpha_deg, beta_deg, level_h, level_v):
    """f_T(α, β, γ), the second-level criterion when f_R = 2.

    .. math:: f_T = f_S(α) + f_S(β) - f_S(α) · f_S(β)

    The product term favours moves that spread the strength change over both directions.
    Smaller is preferred.
    """
    return balanced(f_s_horizontal(alpha_deg, level_h), f_s_vertical(beta_deg, level_v))


def scores(alpha, beta, gamma, previous, settings):
    """(f_R, second-level score) of candidates — floats or arrays — evaluating each strength
    curve once: f_E where f_R = 0, f_S where f_R = 1, f_T where f_R = 2. ``previous`` is
    (α', β', γ'), the posture the move starts from."""
    lh, lv = settings.preferred_level_h, settings.preferred_level_v
    sa, sb = strength_angles(alpha, beta, settings.strength_reading)
    if isinstance(alpha, float) and isinstance(beta, float):
        a0, b0, g0 = previous
        return score_float(alpha, beta, gamma, a0, b0, g0, lh, lv, settings.weight_alpha,
                           settings.weight_beta, settings.weight_gamma, sa, sb)
    sh, sv = strength_horizontal(sa), strength_vertical(sb)
    level = below_level(sh, lh) + below_level(sv, lv)
    a0, b0, g0 = previous
    exertion = f_e(alpha, beta, gamma, a0, b0, g0,
                   settings.weight_alpha, settings.weight_beta, settings.weight_gamma)
    dh, dv = deficit(sh, lh, S_H_MIN), deficit(sv, lv, S_V_MIN)
    second = np.where(level == 0, exertion,
                      np.where(level == 1, np.where(sh < lh, dh, dv), balanced(dh, dv)))
    return level, second


def score_float(alpha, beta, gamma, a0, b0, g0, lh, lv, w_alpha, w_beta, w_gamma,
                strength_alpha=None, strength_beta=None):
    """:func:`scores` of one candidate given as floats, with the settings' levels and
    weights passed in: the same formulas written out branch by branch (f_E, the deficits,
    the balanced gain), one Python call instead of eight, for the planner's inner loop.
    The strength curves are read at (``strength_alpha``, ``strength_beta``) when given
    (:func:`strength_angles`), else at (α, β); f_E always measures the joint angles."""
    if strength_alpha is None:
        sh, sv = _s_h_float(alpha), _s_v_float(beta)
    else:
        sh, sv = _s_h_float(strength_alpha), _s_v_float(strength_beta)
    if sh >= lh:
        if sv >= lv:
            return 0, w_alpha * abs(alpha - a0) + w_beta * abs(beta - b0) + w_gamma * abs(gamma - g0)
        return 1, (lv - sv) / (lv - S_V_MIN)
    dh = (lh - sh) / (lh - S_H_MIN)
    if sv >= lv:
        return 1, dh
    dv = (lv - sv) / (lv - S_V_MIN)
    return 2, dh + dv - dh * dv


def strength_category(alpha_deg, beta_deg, settings):
    """f_R of shoulder angles under ``settings`` (its preferred levels and its reading of
    α and β, :func:`strength_angles`)."""
    sa, sb = strength_angles(alpha_deg, beta_deg, settings.strength_reading)
    return f_r(sa, sb, settings.preferred_level_h, settings.preferred_level_v)


def rank_order(f_r_values, second, first_key=None):
    """Indices that sort candidates best first: by ``first_key`` (if given, e.g. 1 for the
    elbow on the wrong side), then f_R, then the second-level score, then the original
    index (so equal scores keep a fixed, deterministic order)."""
    keys = [np.arange(len(f_r_values)), second, f_r_values]
    if first_key is not None:
        keys.append(first_key)
    return np.lexsort(keys)
