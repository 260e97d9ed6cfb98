"""The hand as skinned: a few capsules fixed in the hand's frame that hold its skin.

The paper takes the wrist as the end-effector and leaves the hand out. Reach keeps the
hand clear too, and one capsule round the hand's axis (wrist → far end, ``hand_radius``)
does for a hand that is round about its axis. Most hands are not: a mitten is a flat
plate, a thumb or a splayed little finger stands out to one side, and a capsule thick
enough to hold them all round the axis would be fat where the hand is thin. So where the
rig adapter reads a hand's skin, it fits ``ArmModel.hand_shape``: up to
:data:`MOST_CAPSULES` capsules ``(a, b, r)`` in the hand's own frame, which the collision
checker tests in place of the axis capsule.

**The hand's frame** is the one the bake turns the hand bone by
(:func:`~reach_addon.core.arm.hand_orientation`): columns (d, g, d × g) with d the hand's
direction (wrist → far end) and g the elbow's hinge axis h = u × b made perpendicular to d,
turned by the palm's roll ψ about d (:func:`~reach_addon.core.arm.roll_frames`). Its
coordinates are taken in the canonical frame, so a point fixed in the hand is at

.. math:: x = w + a_d\\, d + a_g\\, g + a_c\\, (d × g)

at every pose (:func:`shape_points`). The bake carries every bone of the hand (fingers
included, which it does not key) rigidly by that frame's turn, so the skin stays where
these coordinates say.

**The fit** (:func:`fit_hand_shape`), a choice where the paper is silent: the skin's
vertices (weighted at least half to the hand's bones, or the parts parented to them) are
held by one capsule along their principal axis that covers every vertex
(:func:`fit_capsule`); then, greedily, the capsule whose cut in two (along one of its
points' principal axes, at the median, a quartile or the 10th or 90th percentile)
takes the most volume off is cut,
while a cut takes at least :data:`SPLIT_GAIN` of the shape's volume off and there are
fewer than :data:`MOST_CAPSULES` (deterministic: no random start). More capsules cost more
tests where the hand is near something, and a round hand needs one. Capsules are convex,
so a skin triangle whose vertices one capsule holds lies in it; a triangle spanning two
capsules' vertices may leave their union by a fraction of its edge, which the clearance
covers.
"""

from __future__ import annotations

import math

import numpy as np

from .arm import hand_orientation, roll_frames
from .numeric import cross

#: The most capsules a hand's shape has (each costs a capsule test where the hand is near
#: an obstacle).
MOST_CAPSULES = 4
#: A capsule is split in two only where that takes at least this share off the shape's
#: whole volume.
SPLIT_GAIN = 0.05
#: Fewest skin vertices either part of a split keeps.
FEWEST_POINTS = 4
#: The most points the cuts are chosen on (a dense hand's skin is thinned evenly first).
FIT_POINTS = 400


def capsule_volume(a, b, r) -> float:
    """π r² |b − a| + 4/3 π r³."""
    return math.pi * r * r * float(np.linalg.norm(np.asarray(b) - np.asarray(a))) + \
        4.0 / 3.0 * math.pi * r ** 3


def _segment_distances(points, a, b) -> np.ndarray:
    ab = b - a
    t = np.clip((points - a) @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


def fit_capsule(points) -> tuple:
    """(a, b, r): a capsule that holds every point (N, 3): its axis the points' principal
    direction through their mean, its ends at the extreme projections moved in by the
    share of the radius (of 0, ¼, ½, ¾, 1) that gives the least volume, its radius the
    farthest point from that axis segment."""
    p = np.asarray(points, dtype=float)
    c = p.mean(0)
    if len(p) < 2:
        return c.copy(), c.copy(), 0.0
    _w, v = np.linalg.eigh(np.cov((p - c).T) + 1e-30 * np.eye(3))
    axis = v[:, -1]
    axis = axis if axis[np.argmax(np.abs(axis))] > 0 else -axis       # one sign, always
    t = (p - c) @ axis
    lo, hi = float(t.min()), float(t.max())
    best = None
    r0 = float(_segment_distances(p, c + lo * axis, c + hi * axis).max())
    for share in (0.0, 0.25, 0.5, 0.75, 1.0):
        inset = min(share * r0, 0.5 * (hi - lo))
        a, b = c + (lo + inset) * axis, c + (hi - inset) * axis
        r = float(_segment_distances(p, a, b).max())
        vol = capsule_volume(a, b, r)
        if best is None or vol < best[0] - 1e-15:
            best = (vol, a, b, r)
    return best[1], best[2], best[3]


def _cuts(p) -> list:
    """Ways to cut points ``p`` in two: along each of their principal axes at the median,
    the quartiles and the 10th and 90th percentiles of the projections (boolean masks of
    one side)."""
    c = p.mean(0)
    _w, v = np.linalg.eigh(np.cov((p - c).T) + 1e-30 * np.eye(3))
    out = []
    for axis in v.T[::-1]:
        t = (p - c) @ axis
        for q in (0.5, 0.25, 0.75, 0.1, 0.9):
            out.append(t <= np.quantile(t, q))
    # two-means from the two points farthest apart along the first axis
    t = (p - c) @ v[:, -1]
    centres = p[[int(np.argmin(t)), int(np.argmax(t))]]
    for _ in range(8):
        side = np.linalg.norm(p - centres[0], axis=1) <= np.linalg.norm(p - centres[1], axis=1)
        if side.all() or not side.any():
            break
        centres = np.array([p[side].mean(0), p[~side].mean(0)])
    out.append(side)
    return out


def fit_hand_shape(points, most: int = MOST_CAPSULES) -> tuple:
    """Capsules ``((a, b, r), …)`` (tuples of floats, the points' frame) that hold the
    hand's skin vertices ``points`` (N, 3), given in the hand's frame with the wrist at the
    origin (the module docstring's fit). Empty for no points."""
    every = np.asarray(points, dtype=float).reshape(-1, 3)
    if not len(every):
        return ()
    # the cuts are chosen on at most FIT_POINTS of the points (every k-th), the capsules
    # then widened to hold every point
    p = every[::max(1, -(-len(every) // FIT_POINTS))]
    groups = [np.arange(len(p))]
    caps = [fit_capsule(p)]
    while len(groups) < max(1, most):
        total = sum(capsule_volume(*c) for c in caps)
        best = None
        for i, g in enumerate(groups):
            if len(g) < 2 * FEWEST_POINTS:
                continue
            own = capsule_volume(*caps[i])
            for side in _cuts(p[g]):
                if min(side.sum(), (~side).sum()) < FEWEST_POINTS:
                    continue
                two = [fit_capsule(p[g[side]]), fit_capsule(p[g[~side]])]
                gain = own - sum(capsule_volume(*c) for c in two)
                if best is None or gain > best[0] + 1e-15:
                    best = (gain, i, (g[side], g[~side]), two)
        if best is None or best[0] < SPLIT_GAIN * total:
            break
        _gain, i, parts, two = best
        groups[i:i + 1] = list(parts)
        caps[i:i + 1] = two
    return tuple((tuple(float(x) for x in a), tuple(float(x) for x in b), float(r))
                 for a, b, r in _holding(caps, every))


def _holding(caps, points) -> list:
    """``caps`` with each point that none holds given to the one it lies nearest the
    surface of, that capsule's radius widened to hold it."""
    gaps = np.array([_segment_distances(points, a, b) - r for a, b, r in caps])   # (K, N)
    out = []
    nearest = np.argmin(gaps, axis=0)
    for k, (a, b, r) in enumerate(caps):
        mine = gaps[k][nearest == k]
        out.append((a, b, r + max(0.0, float(mine.max())) if len(mine) else r))
    return out


def hand_frames(d, hinge, roll=0.0) -> np.ndarray:
    """The hand's frames (..., 3, 3), columns (d, g, d × g), of unit hand directions ``d``
    (..., 3) and elbow hinge axes ``hinge`` (..., 3) (:func:`~.arm.hand_orientation`),
    turned by ``roll`` (degrees, (...) or a number) about d (:func:`~.arm.roll_frames`):
    the frame the bake turns the hand by."""
    frames = hand_orientation(np.asarray(d, dtype=float), np.asarray(hinge, dtype=float))
    return roll_frames(frames, roll) if np.any(roll) else frames


def shape_points(shape, wrist, frames) -> np.ndarray:
    """The ends of the shape's capsules at poses whose wrists are ``wrist`` (..., 3) and
    hand frames ``frames`` (..., 3, 3): (..., 2K, 3) in the order a₁, b₁, a₂, b₂, …"""
    local = np.array([e for a, b, _r in shape for e in (a, b)], dtype=float)    # (2K, 3)
    f = np.asarray(frames, dtype=float)[..., None, :, :]                        # (..., 1, 3, 3)
    # w + e₀ d + e₁ g + e₂ c, summed in that order (as :func:`tip_shape_ends` sums it)
    return np.asarray(wrist, dtype=float)[..., None, :] + (
        f[..., 0] * local[:, 0:1] + f[..., 1] * local[:, 1:2] + f[..., 2] * local[:, 2:3])


def with_shape(arm, joints, bend, roll=0.0) -> np.ndarray:
    """Joints (..., 5, 3) followed by the ends of ``arm.hand_shape``'s capsules
    (:func:`shape_points`) at those poses: (..., 5 + 2K, 3), canonical, for the collision
    checker. ``bend``: the bend directions (..., 3) (the hinge is u × b, defined with a
    straight elbow too); ``roll``: the palm's roll (degrees). The joints unchanged where
    the arm has no shape."""
    joints = np.asarray(joints, dtype=float)
    if not arm.hand_shape:
        return joints
    base = joints[..., :5, :]
    w = base[..., 3, :]
    d = base[..., 4, :] - w
    d = d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-12)
    hinge = cross(base[..., 2, :] - base[..., 1, :], np.asarray(bend, dtype=float))
    ends = shape_points(arm.hand_shape, w, hand_frames(d, hinge, roll))
    return np.concatenate([base, ends], axis=-2)


def tip_shape_points(arm, wrist, tips, hinge) -> np.ndarray:
    """The ends (N, 2K, 3) of the shape's capsules for a hand from ``wrist`` (3,) to each
    of ``tips`` (N, 3) at an arm pose whose elbow hinge is ``hinge`` (3,) (no roll: the
    search keeps the palm unrolled; :mod:`.orient` rolls it after)."""
    w = np.asarray(wrist, dtype=float)
    d = np.asarray(tips, dtype=float) - w
    d = d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-12)
    h = np.broadcast_to(np.asarray(hinge, dtype=float), d.shape)
    return shape_points(arm.hand_shape, np.broadcast_to(w, d.shape), hand_frames(d, h))


def tip_shape_ends(arm, wrist, tip, hinge) -> list:
    """:func:`tip_shape_points` for one tip, in floats: the 2K ends (lists of 3 floats,
    canonical) of the shape's capsules for a hand from ``wrist`` to ``tip`` at an arm pose
    whose elbow hinge is ``hinge`` (unit). The same products and sums, in the same order:
    d = (t − w) / |t − w|, g = (h − (h·d) d) / |h − (h·d) d|, c = d × g, each end
    w + e₀ d + e₁ g + e₂ c. The search tries hands one at a time, and the arrays'
    broadcasting cost about 190 µs a hand (a fifth of the demo's planning)."""
    wx, wy, wz = (float(v) for v in wrist)
    dx, dy, dz = float(tip[0]) - wx, float(tip[1]) - wy, float(tip[2]) - wz
    n = max(math.sqrt(dx * dx + dy * dy + dz * dz), 1e-12)
    dx, dy, dz = dx / n, dy / n, dz / n
    hx, hy, hz = (float(v) for v in hinge)
    s = hx * dx + hy * dy + hz * dz
    gx, gy, gz = hx - s * dx, hy - s * dy, hz - s * dz
    m = max(math.sqrt(gx * gx + gy * gy + gz * gz), 1e-12)
    gx, gy, gz = gx / m, gy / m, gz / m
    cx, cy, cz = dy * gz - dz * gy, dz * gx - dx * gz, dx * gy - dy * gx
    return [[wx + (dx * ex + gx * ey + cx * ez), wy + (dy * ex + gy * ey + cy * ez),
             wz + (dz * ex + gz * ey + cz * ez)]
            for a, b, _r in arm.hand_shape for ex, ey, ez in (a, b)]


def world_pose(arm, pose) -> np.ndarray:
    """What the collision checker takes for a :class:`~reach_addon.core.arm.Pose`: its
    joints followed by the hand shape's rows (:func:`with_shape`, its palm roll included),
    in world space."""
    return arm.to_world_points(with_shape(arm, pose.joints, pose.bend, pose.roll))
