"""Distances between points and segments on plain floats (and a fan of them on arrays):
the collision checker's, the body capsules' and the hand's geometry."""

from __future__ import annotations

import math

import numpy as np


def point_segment_distance(p, a, b) -> float:
    """Distance from point ``p`` to the segment a-b (float 3-sequences)."""
    abx, aby, abz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    apx, apy, apz = p[0] - a[0], p[1] - a[1], p[2] - a[2]
    den = abx * abx + aby * aby + abz * abz
    t = (apx * abx + apy * aby + apz * abz) / den if den > 1e-18 else 0.0
    t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
    dx, dy, dz = apx - t * abx, apy - t * aby, apz - t * abz
    return math.sqrt(dx * dx + dy * dy + dz * dz)


def segment_distance_float(p1, q1, p2, q2) -> float:
    """Shortest distance between segments p1-q1 and p2-q2 (float 3-sequences), degenerate
    segments included: the closest points minimise |p1 + s d1 - p2 - t d2| over
    s, t ∈ [0, 1] (Ericson, *Real-Time Collision Detection*, §5.1.9). Written on plain
    floats: the planner's body test calls it for every pose it tries."""
    d1x, d1y, d1z = q1[0] - p1[0], q1[1] - p1[1], q1[2] - p1[2]
    d2x, d2y, d2z = q2[0] - p2[0], q2[1] - p2[1], q2[2] - p2[2]
    rx, ry, rz = p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    b = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * rx + d1y * ry + d1z * rz
    f = d2x * rx + d2y * ry + d2z * rz
    eps = 1e-18
    a_s = a if a > eps else eps
    e_s = e if e > eps else eps
    denom = a * e - b * b
    if denom > 1e-12 * a * e:
        s = (b * f - c * e) / (denom if denom > eps else eps)
        s = 0.0 if s < 0.0 else 1.0 if s > 1.0 else s
    else:
        s = 0.0
    t = (b * s + f) / e_s
    if t < 0.0:
        s = -c / a_s
        s = 0.0 if s < 0.0 else 1.0 if s > 1.0 else s
    elif t > 1.0:
        s = (b - c) / a_s
        s = 0.0 if s < 0.0 else 1.0 if s > 1.0 else s
    t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
    if a <= eps:
        s = 0.0
    elif e <= eps:
        s = -c / a_s
        s = 0.0 if s < 0.0 else 1.0 if s > 1.0 else s
    if e <= eps:
        t = 0.0
    elif a <= eps:
        t = f / e_s
        t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
    dx = rx + d1x * s - d2x * t
    dy = ry + d1y * s - d2y * t
    dz = rz + d1z * s - d2z * t
    return math.sqrt(dx * dx + dy * dy + dz * dz)


def fan_segment_distances(p, tips, a, b) -> np.ndarray:
    """:func:`segment_distance_float` between each segment p-tips[i] (a fan from one point
    ``p``, ``tips`` (N, 3)) and each segment a[k]-b[k] (``a``, ``b`` (K, 3)), as an (N, K)
    array: the same operations in the same order on arrays, so every distance is the
    float one to the last bit (each numpy operation rounds as a float operation does).
    For the many hand directions of one pose tested against the body at once."""
    p = [float(v) for v in p]
    tips = np.asarray(tips, dtype=float)
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    d1x, d1y, d1z = (tips[:, i:i + 1] - p[i] for i in range(3))          # (N, 1)
    d2x, d2y, d2z = (b[None, :, i] - a[None, :, i] for i in range(3))      # (1, K)
    rx, ry, rz = (p[i] - a[None, :, i] for i in range(3))                  # (1, K)
    aa = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    bb = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * rx + d1y * ry + d1z * rz
    f = d2x * rx + d2y * ry + d2z * rz
    eps = 1e-18
    a_s, e_s = np.maximum(aa, eps), np.maximum(e, eps)
    denom = aa * e - bb * bb
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > 1e-12 * aa * e,
                     np.clip((bb * f - c * e) / np.where(denom > eps, denom, eps), 0.0, 1.0),
                     0.0)
        t = (bb * s + f) / e_s
        s = np.where(t < 0.0, np.clip(-c / a_s, 0.0, 1.0),
                     np.where(t > 1.0, np.clip((bb - c) / a_s, 0.0, 1.0), s))
        t = np.clip(t, 0.0, 1.0)
        s = np.where(aa <= eps, 0.0, np.where(e <= eps, np.clip(-c / a_s, 0.0, 1.0), s))
        t = np.where(e <= eps, 0.0, np.where(aa <= eps, np.clip(f / e_s, 0.0, 1.0), t))
    dx = rx + d1x * s - d2x * t
    dy = ry + d1y * s - d2y * t
    dz = rz + d1z * s - d2z * t
    return np.sqrt(dx * dx + dy * dy + dz * dz)
