"""Exact triangle geometry in numpy: the independent oracle's distances and tests.

Shares no code with Reach's collision checker (:mod:`reach_addon.core.collision`, Blender's
BVH). Every array is float64 in one frame (world space, the scene's units; distances in
those units). *Pairwise* functions take arrays that broadcast against each other (points
``(..., 3)``, triangles as their corners ``a``, ``b``, ``c``) and answer for each pair;
the others say what they take.

Exact: every distance, and :func:`triangles_intersect` for triangles in general position
(touching counts; two coplanar triangles that overlap are not found). :func:`points_inside`
is ray parity, meaningful for a closed mesh (:func:`closed`). Why the oracle is written
apart from the planner: ``docs/design.md``, *Verification*.
"""

from __future__ import annotations

import numpy as np

#: Directions of the three rays of :func:`points_inside` (unit, far from every axis and
#: from each other, so that a box's faces, edges and vertices are met generically).
RAYS = np.array([[0.5403, 0.7071, 0.4568], [-0.6287, 0.2313, 0.7425], [0.3090, -0.8090, 0.5000]])
RAYS = RAYS / np.linalg.norm(RAYS, axis=1, keepdims=True)


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def triangle_areas(tris) -> np.ndarray:
    """Areas (T,) of triangles (T, 3, 3)."""
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    return 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)


def segments_cross_triangles(p, q, a, b, c) -> np.ndarray:
    """Pairwise: does the closed segment p–q meet the closed triangle a, b, c? (K,) bool.
    A segment parallel to the triangle's plane never does here (the coplanar case: see
    the module docstring)."""
    d, e1, e2 = q - p, b - a, c - a
    h = np.cross(d, e2)
    det = _dot(e1, h)
    scale = np.linalg.norm(d, axis=-1) * np.linalg.norm(e1, axis=-1) * np.linalg.norm(e2, axis=-1)
    ok = np.abs(det) > 1e-12 * np.maximum(scale, 1e-300)
    inv = 1.0 / np.where(ok, det, 1.0)
    s = p - a
    u = inv * _dot(s, h)
    k = np.cross(s, e1)
    v = inv * _dot(d, k)
    t = inv * _dot(e2, k)
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


def triangles_intersect(A, B) -> np.ndarray:
    """Pairwise: do triangles A[k] and B[k] (K, 3, 3) share a point? (K,) bool: an edge of
    either passes through the other (touching counts; coplanar overlap does not)."""
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    hit = np.zeros(len(A), dtype=bool)
    for X, Y in ((A, B), (B, A)):
        for i, j in ((0, 1), (1, 2), (2, 0)):
            hit |= segments_cross_triangles(X[:, i], X[:, j], Y[:, 0], Y[:, 1], Y[:, 2])
    return hit


def box_pairs(lo_a, hi_a, lo_b, hi_b, pad: float = 0.0, chunk: int = 2048):
    """Indices (ia, ib) of the pairs whose axis-aligned boxes (lo, hi: (N, 3) and (M, 3))
    overlap once each is grown by ``pad``."""
    ia, ib = [], []
    for s in range(0, len(lo_a), chunk):
        la, ha = lo_a[s:s + chunk, None] - pad, hi_a[s:s + chunk, None] + pad
        near = np.all((la <= hi_b[None]) & (ha >= lo_b[None]), axis=2)
        i, j = np.nonzero(near)
        ia.append(i + s)
        ib.append(j)
    if not ia:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    return np.concatenate(ia), np.concatenate(ib)


def intersecting_pairs(A, B) -> tuple:
    """(ia, ib): every pair of triangles A[ia] (N, 3, 3) and B[ib] (M, 3, 3) that share a
    point (:func:`triangles_intersect`), found among the pairs whose boxes overlap."""
    A = np.asarray(A, dtype=float).reshape(-1, 3, 3)
    B = np.asarray(B, dtype=float).reshape(-1, 3, 3)
    if not len(A) or not len(B):
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    ia, ib = box_pairs(A.min(1), A.max(1), B.min(1), B.max(1))
    keep = np.zeros(len(ia), dtype=bool)
    for s in range(0, len(ia), 65536):
        keep[s:s + 65536] = triangles_intersect(A[ia[s:s + 65536]], B[ib[s:s + 65536]])
    return ia[keep], ib[keep]


def closed(triangles) -> bool:
    """Is a mesh of triangles (T, 3) of vertex indices closed, so that it has an inside:
    every undirected edge used by an even number of triangles (two, or pairs of faces
    doubled), and at least one triangle?"""
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if not len(t):
        return False
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _keys, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(np.all(counts % 2 == 0))


def _ray_crossings(points, direction, a, b, c):
    """(P,) crossings of rays from ``points`` along ``direction`` with triangles a, b, c (T, 3)."""
    e1, e2 = b - a, c - a                                    # (T, 3)
    h = np.cross(direction, e2)                              # (T, 3)
    det = _dot(e1, h)
    ok = np.abs(det) > 1e-14 * np.maximum(np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1),
                                          1e-300)
    inv = 1.0 / np.where(ok, det, 1.0)
    s = points[:, None] - a[None]                            # (P, T, 3)
    u = inv * _dot(s, h[None])
    k = np.cross(s, e1[None])
    v = inv * _dot(direction[None, None], k)
    t = inv * _dot(e2[None], k)
    return np.sum(ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0), axis=1)


def points_inside(points, tris, chunk: int = 256) -> np.ndarray:
    """(P,) bool: is each point (P, 3) inside the closed mesh of triangles ``tris``
    (T, 3, 3)? Ray parity along :data:`RAYS`, the majority of the three."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    out = np.zeros(len(points), dtype=bool)
    if not len(points) or not len(tris):
        return out
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    lo, hi = tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0)
    boxed = np.flatnonzero(np.all((points >= lo) & (points <= hi), axis=1))
    for s in range(0, len(boxed), chunk):
        idx = boxed[s:s + chunk]
        odd = sum((_ray_crossings(points[idx], r, a, b, c) % 2 == 1).astype(int) for r in RAYS)
        out[idx] = odd >= 2
    return out


def unit(v) -> np.ndarray:
    """The vector ``v`` scaled to length 1 (float64)."""
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def point_segment_distance(p, a, b) -> np.ndarray:
    """Pairwise distance from points ``p`` to the closed segments a–b."""
    p, a, b = (np.asarray(x, dtype=float) for x in (p, a, b))
    ab = b - a
    t = np.clip(_dot(p - a, ab) / np.maximum(_dot(ab, ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - a - t[..., None] * ab, axis=-1)


def point_triangle_distance(p, a, b, c) -> np.ndarray:
    """Pairwise exact distance from points ``p`` to the closed triangles a, b, c: to the
    plane where the foot of the perpendicular lies inside the triangle, else to its nearest
    edge. A triangle without area (its corners in a line, or two of them one) is measured
    by its edges."""
    p, a, b, c = (np.asarray(x, dtype=float) for x in (p, a, b, c))
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    n_len = np.linalg.norm(n, axis=-1)
    flat = n_len <= 1e-12 * np.linalg.norm(ab, axis=-1) * np.linalg.norm(ac, axis=-1)
    n = n / np.where(flat, 1.0, n_len)[..., None]
    height = _dot(p - a, n)
    foot = p - height[..., None] * n
    inside = ((_dot(np.cross(ab, foot - a), n) >= 0) & (_dot(np.cross(c - b, foot - b), n) >= 0)
              & (_dot(np.cross(a - c, foot - c), n) >= 0) & ~flat)
    edges = np.minimum(np.minimum(point_segment_distance(p, a, b), point_segment_distance(p, b, c)),
                       point_segment_distance(p, c, a))
    return np.where(inside, np.abs(height), edges)


def segment_segment_distance(p1, q1, p2, q2) -> np.ndarray:
    """Pairwise exact distance between the closed segments p1–q1 and p2–q2: the stationary
    point of the squared distance where it lies inside both, else the least distance of an
    end of one to the other (the square [0, 1]² of the two parameters has its minimum there)."""
    p1, q1, p2, q2 = (np.asarray(x, dtype=float) for x in (p1, q1, p2, q2))
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, b, e = _dot(d1, d1), _dot(d1, d2), _dot(d2, d2)
    c, f = _dot(d1, r), _dot(d2, r)
    det = a * e - b * b
    ok = det > 1e-12 * np.maximum(a * e, 1e-300)
    safe = np.where(ok, det, 1.0)
    s = (b * f - c * e) / safe
    t = (a * f - b * c) / safe
    inside = ok & (s >= 0) & (s <= 1) & (t >= 0) & (t <= 1)
    gap = r + s[..., None] * d1 - t[..., None] * d2
    best = np.where(inside, np.linalg.norm(gap, axis=-1), np.inf)
    for dist in (point_segment_distance(p1, p2, q2), point_segment_distance(q1, p2, q2),
                 point_segment_distance(p2, p1, q1), point_segment_distance(q2, p1, q1)):
        best = np.minimum(best, dist)
    return best


def segment_triangle_distance(p, q, a, b, c) -> np.ndarray:
    """Pairwise exact distance between the closed segments p–q and triangles a, b, c: 0
    where the segment crosses the triangle, else the least of its ends to the triangle and
    of the segment to the triangle's three edges."""
    p, q, a, b, c = (np.asarray(x, dtype=float) for x in (p, q, a, b, c))
    best = np.minimum(point_triangle_distance(p, a, b, c), point_triangle_distance(q, a, b, c))
    for x, y in ((a, b), (b, c), (c, a)):
        best = np.minimum(best, segment_segment_distance(p, q, x, y))
    return np.where(segments_cross_triangles(p, q, a, b, c), 0.0, best)


def segment_triangle_distances(p, q, tris, horizon=np.inf) -> np.ndarray:
    """Least distances (S,) from the segments p[i]–q[i] ((S, 3) each) to any of the
    triangles (T, 3, 3), each at most ``horizon`` (segment–triangle pairs whose bounds,
    a sphere round the segment and the triangle's box, are farther apart are not
    measured)."""
    p = np.asarray(p, dtype=float).reshape(-1, 3)
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    out = np.full(len(p), float(horizon))
    if len(tris) == 0 or len(p) == 0:
        return out
    mid, half = 0.5 * (p + q), 0.5 * np.linalg.norm(q - p, axis=1)
    gap = np.maximum(np.maximum(tris.min(axis=1)[None] - mid[:, None],
                                mid[:, None] - tris.max(axis=1)[None]), 0.0)     # (S, T, 3)
    si, ti = np.nonzero(np.linalg.norm(gap, axis=2) <= (half + horizon)[:, None])
    if len(si):
        tri = tris[ti]
        np.minimum.at(out, si, segment_triangle_distance(p[si], q[si], tri[:, 0], tri[:, 1],
                                                         tri[:, 2]))
    return out


def segment_crosses(p, q, tris) -> bool:
    """Does the closed segment p–q (two points) meet any of the triangles (T, 3, 3)?"""
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    return bool(segments_cross_triangles(p, q, tris[:, 0], tris[:, 1], tris[:, 2]).any())


def least_distance(points, tris, horizon: float, chunk: int = 1024) -> float:
    """The least distance from any point (P, 3) to any triangle (T, 3, 3), where it is
    within ``horizon`` (pairs whose boxes are farther apart are not measured); ``horizon``
    if none is nearer."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    if not len(points) or not len(tris):
        return float(horizon)
    ip, it = box_pairs(points, points, tris.min(1), tris.max(1), pad=horizon)
    best = float(horizon)
    for s in range(0, len(ip), chunk * 64):
        i, t = ip[s:s + chunk * 64], it[s:s + chunk * 64]
        d = point_triangle_distance(points[i], tris[t, 0], tris[t, 1], tris[t, 2])
        if len(d):
            best = min(best, float(d.min()))
    return best
