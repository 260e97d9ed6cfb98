"""Test geometry: the sample furniture and figure, and the independent clearance oracle.

The furniture (``reach_addon.samples``) is ordinary closed triangle meshes in world space,
metres; the planner sees them through a real ``mathutils`` BVHTree. The oracle the tests
measure plans with (:mod:`verification.clearance`, :mod:`verification.geometry`) shares no
code with the planner; it is imported here so that the tests keep one place to import from.
"""

from __future__ import annotations

import math

import numpy as np

from reach_addon.samples import (CHEST_Z, HANGING, box, figure_transform, obstacles, shelf,
                                 standard_arm, table, triangle_soup)
from verification.clearance import arm_penetration, segment_clearance
from verification.geometry import segment_crosses, segment_triangle_distances

__all__ = ["CHEST_Z", "HANGING", "box", "figure_transform", "obstacles", "shelf", "standard_arm",
           "table", "triangles_of", "arm_penetration", "segment_clearance", "segment_crosses",
           "segment_triangle_distances", "angle_deg", "run_steps"]


def triangles_of(named_parts):
    """All triangles (T, 3, 3) of a scene of {name: [boxes]}, for the independent check."""
    verts, tris, _owners, _names = triangle_soup(named_parts)
    return verts[tris]


def angle_deg(a, b):
    """Angle between two vectors, in degrees."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    return math.degrees(math.acos(float(np.clip(a @ b, -1.0, 1.0))))


def run_steps(steps):
    """(everything a step generator yielded, the value it returned)."""
    yielded = []
    while True:
        try:
            yielded.append(next(steps))
        except StopIteration as done:
            return yielded, done.value
