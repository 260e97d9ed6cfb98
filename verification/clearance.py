"""The independent clearance oracle: an arm's capsules against obstacle triangles.

An arm pose is its five joints in world space, ``(5, 3)``: sternum, shoulder, elbow, wrist
and the hand's far end; its four segments (clavicle, upper arm, forearm, hand) are
capsules of the arm model's radii (:class:`reach_addon.core.arm.ArmModel`: the clavicle
takes the upper arm's). *Clearance* is a segment's distance to a triangle minus its radius,
in the units of the joints: negative where a capsule passes into an obstacle. Distances
come from :mod:`verification.geometry` (numpy, no code shared with the planner).

:func:`independent_check` is exact and is what the fuzz campaign, the OMPL race and the
tight scenes hold both planners to; :func:`segment_clearance` and :func:`arm_penetration`
measure by dense points instead, a second method the tests compare it with.
"""

from __future__ import annotations

import math

import numpy as np

from .geometry import point_triangle_distance, segment_triangle_distance


def _segments(arm, include_hand: bool, rows: int = 5) -> list:
    """(first joint, second joint, radius) of each capsule checked: the clavicle, upper arm
    and forearm, and with ``include_hand`` the hand (a sphere at the wrist where it has no
    length): the capsules of the arm's hand shape where it has one and the poses carry
    their ends (``rows``, the rows of a pose: 5 + 2K, in the order
    ``reach_addon.core.hand_shape.with_shape`` gives them), else its axis capsule."""
    segs = [(0, 1, arm.upper_arm_radius), (1, 2, arm.upper_arm_radius),
            (2, 3, arm.forearm_radius)]
    shape = getattr(arm, "hand_shape", ())
    if include_hand and shape and rows >= 5 + 2 * len(shape):
        segs += [(5 + 2 * i, 6 + 2 * i, r) for i, (_a, _b, r) in enumerate(shape)]
    elif include_hand:
        segs.append((3, 4, arm.hand_radius))
    return segs


def independent_check(arm, world_joints, tris, include_hand=True, horizon=math.inf,
                      chunk=256) -> tuple:
    """Contacts of poses ``world_joints`` (N, 5, 3) with triangles ``tris`` (T, 3, 3).

    Returns (the number of poses in which a capsule comes closer to a triangle than its
    radius, the same counting the arm only (clavicle, upper arm, forearm), the least
    clearance over all poses, capped at ``horizon``). Segment–triangle pairs whose bounds
    (a sphere round the capsule, the triangle's box) are farther apart than ``horizon`` are
    not measured: they can neither touch nor set the least clearance. The hand is checked
    with ``include_hand`` where the arm has one."""
    joints = np.asarray(world_joints, dtype=float)
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    segs = _segments(arm, include_hand and arm.hand_length > 0, joints.shape[1] if joints.ndim == 3 else 5)
    if len(joints) == 0 or len(tris) == 0:
        return 0, 0, horizon
    box_lo, box_hi = tris.min(axis=1), tris.max(axis=1)
    radii = np.array([r for _a, _b, r in segs])
    n_seg = len(segs)
    colliding, colliding_arm, least = 0, 0, horizon
    for lo in range(0, len(joints), chunk):
        j = joints[lo:lo + chunk]
        n = len(j)
        p = np.stack([j[:, a] for a, _b, _r in segs], 1).reshape(-1, 3)      # (n·S, 3)
        q = np.stack([j[:, b] for _a, b, _r in segs], 1).reshape(-1, 3)
        r = np.tile(radii, n)
        mid, half = 0.5 * (p + q), 0.5 * np.linalg.norm(q - p, axis=1)
        outside = np.maximum(np.maximum(box_lo[None] - mid[:, None], mid[:, None] - box_hi[None]),
                             0.0)                                            # (n·S, T, 3)
        near = np.linalg.norm(outside, axis=2) <= (half + r + horizon)[:, None]
        si, ti = np.nonzero(near)
        if si.size == 0:
            continue
        tri = tris[ti]
        clearance = segment_triangle_distance(p[si], q[si], tri[:, 0], tri[:, 1], tri[:, 2]) - r[si]
        per_segment = np.full(n * n_seg, np.inf)
        np.minimum.at(per_segment, si, clearance)
        per_segment = per_segment.reshape(n, n_seg)
        colliding += int((per_segment.min(axis=1) < 0).sum())
        colliding_arm += int((per_segment[:, :3].min(axis=1) < 0).sum())
        least = min(least, float(per_segment.min()))
    return colliding, colliding_arm, least


def segment_clearance(p, q, tris, spacing=0.002) -> float:
    """Least distance from the segment p–q to the triangles (T, 3, 3), measured at points
    at most ``spacing`` apart along it: at most ``spacing`` / 2 above the exact one."""
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    n = max(2, int(np.ceil(np.linalg.norm(q - p) / spacing)) + 1)
    pts = p + np.linspace(0, 1, n)[:, None] * (q - p)
    return float(point_triangle_distance(pts[:, None], tris[None, :, 0], tris[None, :, 1],
                                         tris[None, :, 2]).min())


def arm_penetration(arm, world_joints, tris, include_hand=True) -> float:
    """For one pose (5, 3), the worst clearance over the arm's capsules, sampled by
    :func:`segment_clearance` (2 mm): negative where a capsule passes into an obstacle."""
    return min(segment_clearance(world_joints[a], world_joints[b], tris) - r
               for a, b, r in _segments(arm, include_hand, len(world_joints)))
