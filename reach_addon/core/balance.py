"""The body's balance: its centre of mass from the rig's segments, and how far inside the
feet's support polygon it stands.

The first piece of the whole-body reach (lean, squat, step): those motions must keep the
centre of mass over the planted feet, and the report gives its margin. Here it is measured
on the rig as it stands and as the arm moves.

**Centre of mass** (:func:`centre_of_mass`). Each segment's mass is a share of the body's
mass, placed at a fixed fraction of the segment's length from its proximal end. Both come
from Winter's table (:data:`WINTER`). A segment the rig lacks is left out, and the shares
of the rest are renormalised.

.. math:: c = \\frac{\\sum_i m_i \\,(p_i + r_i (d_i - p_i))}{\\sum_i m_i}

**Support polygon**: the convex hull of the soles' points where they are known
(:func:`polygon_of`); else (:func:`support_polygon`) each foot is a rectangle on the ground plane.
It runs from the heel, behind the ankle's projection (:data:`HEEL_BACK`), to the toe's. Its
width is a share of the ankle-to-toe length (:data:`FOOT_WIDTH`). The polygon is the
convex hull of both feet's corners.

**Margin** (:func:`balance_margin`). The signed distance from the centre of mass's ground
projection to the polygon's edge: positive inside, negative outside.
"""

from __future__ import annotations

import math

import numpy as np

from .numeric import cross

#: Segment mass as a fraction of body mass, and the segment's centre of mass as a fraction
#: of its length from the proximal end. Winter, D. A. (2009), *Biomechanics and Motor
#: Control of Human Movement*, 4th ed., Table 4.1 (after Dempster). The trunk runs from
#: the greater trochanter to the glenohumeral joint; head and neck from C7–T1 to the ear
#: canal, with its centre of mass at the distal end. The shares of a whole body sum to 1.
WINTER = {
    "hand": (0.006, 0.506),
    "forearm": (0.016, 0.430),
    "upper_arm": (0.028, 0.436),
    "foot": (0.0145, 0.50),
    "shank": (0.0465, 0.433),
    "thigh": (0.100, 0.433),
    "head_neck": (0.081, 1.000),
    "trunk": (0.497, 0.50),
}

#: A foot's breadth over its length: an adult foot is about 10 cm wide and 26 cm long.
FOOT_WIDTH = 0.38
#: How far the heel reaches behind the ankle, as a share of the ankle-to-toe length: the
#: back of the heel lies about 5 cm behind the ankle joint of a foot whose toes lie about
#: 20 cm ahead of it.
HEEL_BACK = 0.25


def segment_centre(proximal, distal, fraction: float) -> np.ndarray:
    """A segment's centre of mass: ``proximal + fraction (distal − proximal)``."""
    p = np.asarray(proximal, dtype=float)
    return p + float(fraction) * (np.asarray(distal, dtype=float) - p)


def centre_of_mass(segments) -> np.ndarray:
    """The body's centre of mass (3,) from ``segments``: [(kind, proximal, distal)], kind
    a key of :data:`WINTER` (both arms and both legs give one entry each). The masses of
    the segments given are renormalised to sum to one. Raises ValueError for none."""
    total, acc = 0.0, np.zeros(3)
    for kind, proximal, distal in segments:
        mass, fraction = WINTER[kind]
        acc += mass * segment_centre(proximal, distal, fraction)
        total += mass
    if total <= 0.0:
        raise ValueError("no segments to weigh")
    return acc / total


def arm_toward(shoulder, lengths, target) -> list:
    """An arm held straight from ``shoulder`` toward ``target`` (world), the wrist at most on
    it: [("upper_arm", s, e), ("forearm", e, w), ("hand", w, t)] for ``lengths`` (upper arm,
    forearm, hand). With ``u`` the unit direction to the target and ``d`` its distance,
    :math:`w = s + \\min(d, l_1 + l_2)\\,u`, the elbow on the way at :math:`l_1/(l_1+l_2)`
    of it and the hand's end :math:`l_3` on: an estimate of where a reaching arm ends."""
    s = np.asarray(shoulder, dtype=float)
    upper, fore, hand = (float(x) for x in lengths)
    d = np.asarray(target, dtype=float) - s
    u = d / max(float(np.linalg.norm(d)), 1e-12)
    w = s + min(float(np.linalg.norm(d)), upper + fore) * u
    e = s + upper / max(upper + fore, 1e-12) * (w - s)
    return [("upper_arm", s, e), ("forearm", e, w), ("hand", w, w + hand * u)]


def ground_basis(up) -> np.ndarray:
    """Two unit vectors (2, 3) spanning the ground plane perpendicular to ``up``."""
    u = np.asarray(up, dtype=float)
    u = u / np.linalg.norm(u)
    seed = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    a = cross(u, seed)
    a /= np.linalg.norm(a)
    return np.stack([a, cross(u, a)])


def _hull(points: np.ndarray) -> np.ndarray:
    """Convex hull (K, 2), counter-clockwise, of 2-D ``points`` (Andrew's monotone chain)."""
    pts = sorted(set(map(tuple, np.round(points, 12).tolist())))
    if len(pts) <= 2:
        return np.array(pts, dtype=float)

    def turn(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and turn(lower[-2], lower[-1], p) <= 0.0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and turn(upper[-2], upper[-1], p) <= 0.0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1], dtype=float)


def polygon_of(points, up) -> np.ndarray:
    """The convex hull (K, 2), in :func:`ground_basis` coordinates of ``up``, of world
    ``points`` (n, 3) projected on the ground plane (a foot's sole)."""
    return _hull(np.asarray(points, dtype=float) @ ground_basis(up).T)


def support_polygon(feet, up, width: float = FOOT_WIDTH, heel: float = HEEL_BACK) -> np.ndarray:
    """The support polygon (K, 2) in :func:`ground_basis` coordinates of ``up``: the convex
    hull of each foot's rectangle. ``feet``: [(ankle, toe)] world points; a foot runs from
    ``heel`` times its ankle-to-toe length behind the ankle's ground projection to the
    toe's, ``width`` times the ankle-to-toe length wide."""
    basis = ground_basis(up)
    corners = []
    for ankle, toe in feet:
        a, t = basis @ np.asarray(ankle, dtype=float), basis @ np.asarray(toe, dtype=float)
        along = t - a
        length = float(np.linalg.norm(along))
        if length <= 0.0:
            corners.append(a)
            continue
        side = np.array([-along[1], along[0]]) / length * (0.5 * width * length)
        back = a - heel * along
        corners += [back + side, back - side, t + side, t - side]
    return _hull(np.array(corners))


def balance_margin(point, polygon: np.ndarray, up) -> float:
    """Signed distance (world units) from ``point``'s ground projection (along ``up``) to
    the edge of ``polygon`` (:func:`support_polygon`, the same ``up``): positive inside,
    negative outside."""
    q = ground_basis(up) @ np.asarray(point, dtype=float)
    poly = np.asarray(polygon, dtype=float)
    if len(poly) < 3:
        return -min((float(np.linalg.norm(q - p)) for p in poly), default=math.inf)
    nearest, inside = math.inf, True
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        edge = b - a
        t = float(np.clip((q - a) @ edge / max(float(edge @ edge), 1e-300), 0.0, 1.0))
        nearest = min(nearest, float(np.linalg.norm(q - (a + t * edge))))
        if edge[0] * (q[1] - a[1]) - edge[1] * (q[0] - a[0]) < 0.0:
            inside = False
    return nearest if inside else -nearest
