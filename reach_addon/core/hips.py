"""The hips move back as the trunk leans, the feet planted: how far, and where the knees
go (stage 3 of the whole-body reach, ``docs/design/core.md``).

**The shift** (:func:`hips_shift`). Leaning the trunk forward carries the centre of mass
toward the toes. The hips bone, which carries the trunk, both arms and the thighs,
translates back by δ along the lean's horizontal direction ``h`` (away from the target).
Every segment it carries moves with it; the shanks and feet do not (their share of the
mass, ``planted_share``, stays). So the centre of mass moves back linearly:

.. math:: c(δ) = c_0 - δ\\,(1 - m_p)\\,h

(:func:`shifted_centre`, ``m_p``: the planted share). The least δ ≥ 0 that brings its
margin over the support polygon (:func:`~.balance.balance_margin`) to ``margin`` is found
by bisection (the margin is continuous in δ and, along a line through a convex polygon,
rises to a single peak, so the least δ is the first crossing before it).

**Lean and shift together** (:func:`lean_and_shift`). A shift takes the shoulder back by
δ too, so the lean that reaches grows, and with it the shift its centre of mass needs: the
pair is where the two agree, found by bisection on δ (iterating the two in turn converges
only geometrically, about 0.6 a round on a hand-built body, and never lands on both).

**The knees** (:func:`two_bone_knee`). With a hip joint moved and its ankle held, the knee
lies where the thigh (from the hip) and the shank (from the ankle) meet, on the side of
the ``pole`` (the knee's forward direction at rest): the law of cosines in the plane of
hip, ankle and pole. Where the hip has moved beyond the leg's length from the ankle, the
hips drop (:func:`hips_drop`) to a hip-to-ankle distance of :data:`STRAIGHT_SHARE` of the
leg's length: a straight knee is singular for IK, and looks locked.

Pure numpy; every position in one frame (canonical or world, the caller's), lengths in its
units.
"""

from __future__ import annotations

import math

import numpy as np

from .balance import balance_margin, ground_basis, polygon_of
from .lean import Lean, lean_axis, least_lean
from .torso import rotate_about_spine

#: The greatest hip-to-ankle distance the knees are solved for, as a share of thigh +
#: shank: a leg kept just short of straight.
STRAIGHT_SHARE = 0.995


def shifted_centre(com, h, delta: float, planted_share: float) -> np.ndarray:
    """The centre of mass with the hips moved back by ``delta`` along ``-h``:
    c(δ) = c₀ − δ (1 − m_p) h."""
    return np.asarray(com, dtype=float) - float(delta) * (1.0 - float(planted_share)) * \
        np.asarray(h, dtype=float)


def hips_shift(com, polygon, up, h, planted_share: float, margin: float, most: float,
               halvings: int = 40) -> float | None:
    """The least shift δ in [0, ``most``] of the hips back along ``-h`` whose centre of mass
    (:func:`shifted_centre`) stands ``margin`` inside ``polygon``: 0 where it already does,
    None where no shift up to ``most`` does."""
    def margin_at(delta):
        return balance_margin(shifted_centre(com, h, delta, planted_share), polygon, up)

    if margin_at(0.0) >= margin:
        return 0.0
    # the first δ that reaches the margin, sampled then bisected (the margin rises to one
    # peak along the line, so the first sample over it bounds the least δ)
    samples = np.linspace(0.0, float(most), 33)
    over = next((d for d in samples[1:] if margin_at(float(d)) >= margin), None)
    if over is None:
        return None
    lo, hi = float(over) - float(samples[1]), float(over)
    for _ in range(halvings):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if margin_at(mid) < margin else (lo, mid)
    return hi


def horizontal_toward(pivot, target, up) -> np.ndarray:
    """The unit horizontal direction from ``pivot`` toward ``target`` (``up``: unit)."""
    up = np.asarray(up, dtype=float)
    d = np.asarray(target, dtype=float) - np.asarray(pivot, dtype=float)
    d = d - (d @ up) * up
    n = float(np.linalg.norm(d))
    if n <= 1e-12:
        raise ValueError("the target is straight above or below the hips")
    return d / n


def lean_and_shift(shoulder, pivot, target, reach: float, lean_max_deg: float, com_of,
                   polygon, up, planted_share: float, margin: float, most: float,
                   halvings: int = 40):
    """(θ, δ): the lean (degrees) and the hips' shift back that together bring ``target``
    within ``reach`` of the shoulder with the centre of mass ``margin`` inside ``polygon``;
    None where no lean up to ``lean_max_deg`` with a shift up to ``most`` does.
    ``com_of(θ)``: the centre of mass with the trunk leaned by θ, the hips not moved (the
    caller's segments). Shoulder, pivot and target in one frame; ``up`` its up.

    With θ(δ) the least lean that reaches with the body shifted by δ and n(θ) the shift
    θ's centre of mass needs (:func:`hips_shift`), the pair is the least δ with
    g(δ) = n(θ(δ)) − δ ≤ 0, bracketed on a sampling of [0, ``most``] and bisected; the δ
    returned is the bracket's upper end, so both hold exactly: θ(δ) reaches, and
    n(θ(δ)) ≤ δ keeps the margin."""
    h = horizontal_toward(pivot, target, up)
    s, p = np.asarray(shoulder, dtype=float), np.asarray(pivot, dtype=float)

    def lean_at(delta):
        return least_lean(s - delta * h, p - delta * h, target, reach, lean_max_deg)

    def settled(delta):          # True / False, or None where no lean or shift will do
        theta = lean_at(delta)
        if theta is None:
            return None
        need = hips_shift(com_of(theta), polygon, up, h, planted_share, margin, most)
        return None if need is None else need <= delta

    first = settled(0.0)
    if first is None:
        return None
    if first:
        return lean_at(0.0), 0.0
    samples = np.linspace(0.0, float(most), 33)
    lo = hi = None
    for a, b in zip(samples[:-1], samples[1:]):
        ok = settled(float(b))
        if ok is None:
            return None
        if ok:
            lo, hi = float(a), float(b)
            break
    if hi is None:
        return None
    for _ in range(halvings):
        mid = 0.5 * (lo + hi)
        ok = settled(mid)
        lo, hi = (lo, mid) if ok else (mid, hi)
    return lean_at(hi), hi


class LegOverstretchedError(ValueError):
    """A hip moved so far from its ankle across the ground that no drop of the hips brings
    the foot within the leg's reach (:func:`hips_drop`): a posture the legs cannot take,
    which a caller trying postures refuses and goes on."""


def hips_drop(hip, ankle, thigh: float, shank: float, up, share: float = STRAIGHT_SHARE
              ) -> float:
    """How far (≥ 0) the hip must come down along ``up`` for its ankle to lie within
    ``share`` (:data:`STRAIGHT_SHARE`) of the leg's length: the least η with
    |hip − η·up − ankle| ≤ s (thigh + shank)."""
    up = np.asarray(up, dtype=float)
    d = np.asarray(hip, dtype=float) - np.asarray(ankle, dtype=float)
    most = share * (float(thigh) + float(shank))
    if float(np.linalg.norm(d)) <= most:
        return 0.0
    vertical = float(d @ up)
    flat = float(np.linalg.norm(d - vertical * up))
    if flat >= most:
        raise LegOverstretchedError("the hip has moved farther from its ankle than the leg is long")
    return vertical - math.sqrt(most * most - flat * flat)


def legs_drop(leg_joints, shift, up) -> float:
    """How far (≥ 0) the hips come down along ``up`` when they move by ``shift``, both feet
    planted: the most :func:`hips_drop` any of ``leg_joints`` (:class:`~.squat.Leg`, as
    they stand) asks, :math:`\\max(0, \\max_i \\eta_i)`."""
    shift = np.asarray(shift, dtype=float)
    return max([0.0] + [hips_drop(j.hip + shift, j.ankle, j.thigh, j.shank, up)
                        for j in leg_joints])


def two_bone_knee(hip, ankle, thigh: float, shank: float, pole,
                  share: float = STRAIGHT_SHARE) -> np.ndarray:
    """The knee (3,) of a leg whose hip joint and ankle are given, its thigh and shank of
    the given lengths, bent toward ``pole`` (a direction; its part across the hip-ankle
    line is used):

    .. math:: a = \\frac{l_1^2 - l_2^2 + d^2}{2d},\\quad k = h + a\\,u + \\sqrt{l_1^2 - a^2}\\,v

    with ``d`` the hip-to-ankle distance (at most ``share``, :data:`STRAIGHT_SHARE`, of the
    leg's length), ``u`` the unit direction from hip to ankle and ``v`` the pole made
    perpendicular to it."""
    hip, ankle = np.asarray(hip, dtype=float), np.asarray(ankle, dtype=float)
    l1, l2 = float(thigh), float(shank)
    line = ankle - hip
    d = float(np.linalg.norm(line))
    if d <= 1e-12:
        raise ValueError("the hip joint is on its ankle")
    u = line / d
    d = min(d, share * (l1 + l2))
    v = np.asarray(pole, dtype=float) - (np.asarray(pole, dtype=float) @ u) * u
    n = float(np.linalg.norm(v))
    if n <= 1e-12:
        raise ValueError("the knee's pole lies along the leg")
    v = v / n
    a = (l1 * l1 - l2 * l2 + d * d) / (2.0 * d)
    return hip + a * u + math.sqrt(max(0.0, l1 * l1 - a * a)) * v


def body_frame(arm, body) -> tuple:
    """The body (:func:`shifted_lean`'s ``body``, world) in the arm's canonical frame, where
    :func:`~.lean.least_lean` works (z the body's up): (the canonical-to-world rotation, its
    scale, ``canonical(p)`` mapping a world point, the support polygon in canonical
    :func:`~.balance.polygon_of` coordinates of ``ground``, and ``ground``: the body's
    ``up``, the ground's, in the canonical frame). The ground's up is gravity's, not the
    spine's: a body whose spine leans forward as it stands (3.9° on the metarig, 6.9° on
    Quaternius' figure) has its centre of mass over its feet along gravity, and its hips
    move back along the ground."""
    m = np.asarray(arm.to_world, dtype=float)
    rot, inv, origin = m[:3, :3], np.linalg.inv(m[:3, :3]), m[:3, 3]
    scale = abs(float(np.linalg.det(rot))) ** (1.0 / 3.0)

    def canonical(p):
        return inv @ (np.asarray(p, dtype=float) - origin)

    up_w = np.asarray(body.up, dtype=float)
    ground = inv @ up_w
    ground = ground / float(np.linalg.norm(ground))
    polygon = polygon_of([canonical(ground_basis(up_w).T @ np.asarray(c, dtype=float))
                          for c in body.polygon], ground)
    return rot, scale, canonical, polygon, ground


def shifted_lean(arm, target_c, pivot_c, settings, turns, body, share: float = 1.0
                 ) -> Lean | None:
    """The least lean with the hips moved back (:func:`lean_and_shift`) that brings
    ``target_c`` within ``Settings.lean_reach`` of the shoulder with the centre of mass
    ``body.margin`` inside the feet, the chest turned by one of ``turns`` (degrees); the
    hips' shift (canonical) includes how far they come down (``body.drop``); None where
    none up to ``Settings.lean_max`` and ``Settings.lean_hips_max`` does. Solved in the
    arm's canonical frame (z up, where :func:`~.lean.least_lean` works).

    ``body`` is the rig's (the Blender layer's, world frame): ``com(lean)`` the centre of
    mass with the trunk leaned by a :class:`~.lean.Lean` (no shift), ``polygon`` the support
    polygon (:func:`~.balance.ground_basis` coordinates of ``up``), ``up`` the body's up,
    ``planted_share`` the share of the body's mass the shift leaves in place (shanks and
    feet), ``margin`` (world units), ``floor`` (the least margin the lean may keep, world
    units, ≤ ``margin``) and ``drop(shift_world)``. ``share``: how much of the way from
    ``floor`` to ``margin`` the centre of mass is kept (1: the whole margin; less, a
    smaller shift and a smaller lean)."""
    rot, scale, canonical, polygon, ground = body_frame(arm, body)
    axis = lean_axis(pivot_c, target_c)
    length = arm.arm_length
    found = []
    for turn in turns:
        pair = lean_and_shift(
            rotate_about_spine(arm.shoulder, float(turn)), pivot_c, target_c,
            settings.lean_reach * length, settings.lean_max,
            lambda theta: canonical(body.com(Lean(np.asarray(pivot_c, float), axis,
                                                  float(theta)))),
            polygon, ground, body.planted_share,
            (body.floor + float(share) * (body.margin - body.floor)) / scale,
            settings.lean_hips_max * length)
        if pair is not None:
            found.append(pair)
    if not found:
        return None
    theta, delta = min(found)
    shift = -delta * horizontal_toward(pivot_c, target_c, ground)
    drop = body.drop(rot @ shift) / scale
    return Lean(np.asarray(pivot_c, dtype=float), axis, float(theta), shift - drop * ground)
