"""The places obstacles take over several frames, as one obstacle set (:func:`union`): what
a chase that plans ahead plans among where obstacles move
(:meth:`~reach_addon.core.chase._Chase._plan_ahead`)."""

from __future__ import annotations

import hashlib

import numpy as np

from .collision import Obstacles


def union(sets) -> Obstacles:
    """One BVH of every piece of ``sets`` (:class:`~reach_addon.core.Obstacles` built by
    ``from_triangles``, which keep their triangles): each piece (one obstacle at one
    instant) stays a part of its own, so each encloses its own inside. A piece met again
    (the same owner, the same world triangles: an obstacle that did not move) is taken
    once. Raises ValueError where a set's triangles are not known."""
    names: dict = {}
    seen = set()
    verts, tris, owners, parts = [], [], [], []
    offset = 0
    for obs in sets:
        if obs.tree is None:
            continue
        if obs.triangles is None or obs.vertices is None:
            raise ValueError("a union needs obstacles built from triangles")
        part = obs.triangle_part if obs.triangle_part is not None else \
            np.zeros(len(obs.triangles), dtype=np.int64)
        for k in np.unique(part):
            mine = obs.triangles[part == k]
            name = obs.owner(int(np.flatnonzero(part == k)[0]))
            corners = np.ascontiguousarray(obs.vertices[mine])
            key = (name, corners.shape,
                   hashlib.blake2b(corners.tobytes(), digest_size=16).digest())
            if key in seen:
                continue
            seen.add(key)
            used, local = np.unique(mine, return_inverse=True)
            verts.append(obs.vertices[used])
            tris.append(local.reshape(-1, 3) + offset)
            owners.append(np.full(len(mine), names.setdefault(name, len(names))))
            parts.append(np.full(len(mine), len(parts)))
            offset += len(used)
    if not tris:
        return Obstacles(None)
    return Obstacles.from_triangles(np.concatenate(verts), np.concatenate(tris),
                                    np.concatenate(owners), list(names), np.concatenate(parts))
