"""The character's own body as capsules (chest, head, …; :attr:`ArmModel.body_capsules`),
and the arm's tests against them: which part of a pose passes through the body.

Points are canonical (:mod:`~reach_addon.core.arm`), in the figure's units; the capsules
that turn with the chest are turned by the pose's chest rotation (degrees). The upper
arm's half nearest the shoulder is never tested: it is attached to the torso there.
"""

from __future__ import annotations

import math

import numpy as np

from .arm import ArmModel
from .distances import segment_distance_float
from .torso import turn_about_spine


def body_capsules_at(arm: ArmModel, body: float) -> list:
    """The body's capsules with the chest turned by ``body`` degrees (those that turn with
    the chest, :func:`~reach_addon.core.torso.rotate_about_spine`), for the scalar body test
    of every pose tried: one plain tuple per capsule, ``(a, b, centre, half, radius)`` —
    its ends and centre (float lists), half its length and its radius. Callers unpack them
    by those names; they stay plain tuples because a tuple subclass (a NamedTuple) unpacks
    through an iterator, which the innermost loop of the search (:func:`segment_hits_body`)
    would pay thousands of times a plan."""
    body = float(body)
    c, s = math.cos(math.radians(body)), math.sin(math.radians(body))
    out = []
    for p, q, mid, half, r, turn in arm.capsule_floats:
        if turn and body != 0.0:
            p, q = turn_about_spine(p, c, s), turn_about_spine(q, c, s)
            mid, half = [0.5 * (p[i] + q[i]) for i in range(3)], 0.5 * math.dist(p, q)
        out.append((p, q, mid, half, r))
    return out


def segment_hits_body(p, q, radius, capsules) -> bool:
    """Does the capsule p-q (float 3-sequences) of ``radius`` pass through one of
    ``capsules`` (from :func:`body_capsules_at`)? Bounding spheres first."""
    mid = [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])]
    reach = 0.5 * math.dist(p, q) + radius          # the segment's bounding sphere
    for a, b, centre, half_c, radius_c in capsules:
        if math.dist(mid, centre) < reach + half_c + radius_c and \
                segment_distance_float(p, q, a, b) < radius + radius_c:
            return True
    return False


def self_collision(arm: ArmModel, body: float, joints, include_hand: bool = True,
                   capsules=None) -> np.ndarray:
    """True for each candidate (joints (n, 5, 3), canonical, one chest rotation ``body``)
    whose forearm, hand (if ``include_hand``) or elbow half of the upper arm passes through
    one of the body's own capsules (chest and head turn with the chest rotation): see
    :func:`body_hit`. ``capsules``: :func:`body_capsules_at` for ``body``, if the caller
    already has them."""
    joints = np.asarray(joints, dtype=float)
    out = np.zeros(len(joints), dtype=bool)
    if not arm.body_capsules:
        return out
    caps = body_capsules_at(arm, body) if capsules is None else capsules
    for n, pose in enumerate(joints.tolist()):
        out[n] = body_hit(arm, pose, caps, include_hand) is not None
    return out


def body_hit(arm: ArmModel, joints, capsules, include_hand: bool = True):
    """(part, index into ``capsules``) of the first part of one pose — the elbow half of
    the upper arm, the forearm, the hand (if ``include_hand``), in that order — that passes
    through one of the body's ``capsules`` (:func:`body_capsules_at`), or None. ``joints``:
    the pose's sternum, shoulder, elbow, wrist and hand end as float lists. The upper arm's
    half nearest the shoulder is not tested: it is attached to the torso there."""
    _st, sh, el, wr, ha = joints[:5]
    parts = [("upper arm", [0.5 * (sh[i] + el[i]) for i in range(3)], el, arm.upper_arm_radius),
             ("forearm", el, wr, arm.forearm_radius)]
    if include_hand:
        parts.append(("hand", wr, ha, arm.hand_radius))
    for part, p, q, r in parts:
        if segment_hits_body(p, q, r, capsules):
            return part, next(k for k, c in enumerate(capsules) if segment_hits_body(p, q, r, [c]))
    return None
