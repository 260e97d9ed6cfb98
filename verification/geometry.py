"""Triangle geometry in numpy for the refusal cross-check: exact tests, no BVH.

Written for :mod:`verification.refusal` and sharing no code with Reach's collision checker
(:mod:`reach_addon.core.collision`, Blender's BVH). Every array is float64 in one frame
(world space, the scene's units). Functions called *pairwise* take arrays of one length K
and answer for row k of each; the others say what they broadcast.

What is exact and what is not:

* :func:`triangles_intersect` is exact for triangles in general position: two triangles
  share a point if and only if an edge of one passes through the other, which is what
  it tests (Möller–Trumbore with closed bounds, so touching counts). Two triangles lying
  in one plane and overlapping are not detected; they share no volume (a contact of zero
  depth), and a skin lying flat on a face is found by its other triangles or not at all.
* :func:`points_inside` counts ray crossings (parity) along three fixed directions and
  takes the majority, so a ray grazing an edge or a vertex (counted twice or not at all)
  cannot decide alone. It is meaningful for a closed mesh (:func:`closed`).
* :func:`point_triangle_distance` is exact (Ericson, *Real-Time Collision Detection* 5.1.5).
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


def point_triangle_distance(p, a, b, c) -> np.ndarray:
    """Pairwise exact distance from points p to triangles a, b, c ((K, 3) each): to the
    closest point of the triangle (Voronoi regions of its vertices, edges and face)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    bp = p - b
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    cp = p - c
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    vc = d1 * d4 - d3 * d2
    vb = d5 * d2 - d1 * d6
    va = d3 * d6 - d5 * d4

    def safe(x):
        return np.where(np.abs(x) > 1e-300, x, 1e-300)

    v_ab = d1 / safe(d1 - d3)
    w_ac = d2 / safe(d2 - d6)
    w_bc = (d4 - d3) / safe((d4 - d3) + (d5 - d6))
    denom = 1.0 / safe(va + vb + vc)
    face = a + ab * (vb * denom)[:, None] + ac * (vc * denom)[:, None]
    conds = [(d1 <= 0) & (d2 <= 0), (d3 >= 0) & (d4 <= d3), (vc <= 0) & (d1 >= 0) & (d3 <= 0),
             (d6 >= 0) & (d5 <= d6), (vb <= 0) & (d2 >= 0) & (d6 <= 0),
             (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)]
    choices = [a, b, a + ab * v_ab[:, None], c, a + ac * w_ac[:, None], b + (c - b) * w_bc[:, None]]
    closest = face
    for cond, choice in zip(reversed(conds), reversed(choices)):
        closest = np.where(cond[:, None], choice, closest)
    return np.linalg.norm(p - closest, axis=1)


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
