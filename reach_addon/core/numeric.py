"""One formula, two speeds: math namespaces for Python floats and for numpy arrays.

The planner's inner loop solves one wrist position at a time. A numpy call costs about a
microsecond however small its array, so the per-wrist arithmetic (a few dozen operations)
is much faster on plain floats; the workspace grid solves a thousand wrists at once, where
numpy wins. Code that must serve both is written once against a namespace from
:func:`ops` (``m.sqrt``, ``m.where``, ``m.clip``, ...) and runs on whichever it is given.
"""

from __future__ import annotations

import math

import numpy as np


class _Scalar:
    sqrt = staticmethod(math.sqrt)
    cos = staticmethod(math.cos)
    sin = staticmethod(math.sin)
    acos = staticmethod(math.acos)
    atan2 = staticmethod(math.atan2)
    hypot = staticmethod(math.hypot)
    radians = staticmethod(math.radians)
    degrees = staticmethod(math.degrees)

    @staticmethod
    def clip(x, lo, hi):
        return lo if x < lo else hi if x > hi else x

    @staticmethod
    def maximum(a, b):
        return a if a > b else b

    @staticmethod
    def minimum(a, b):
        return a if a < b else b

    @staticmethod
    def where(condition, a, b):
        return a if condition else b


class _Array:
    sqrt = staticmethod(np.sqrt)
    cos = staticmethod(np.cos)
    sin = staticmethod(np.sin)
    acos = staticmethod(np.arccos)
    atan2 = staticmethod(np.arctan2)
    hypot = staticmethod(np.hypot)
    radians = staticmethod(np.radians)
    degrees = staticmethod(np.degrees)
    maximum = staticmethod(np.maximum)
    minimum = staticmethod(np.minimum)
    where = staticmethod(np.where)

    @staticmethod
    def clip(x, lo, hi):
        return np.minimum(np.maximum(x, lo), hi)


SCALAR = _Scalar()
ARRAY = _Array()


def ops(*values):
    """The namespace for these values: scalar math if all are plain numbers, else numpy."""
    return SCALAR if all(isinstance(v, (float, int)) for v in values) else ARRAY


def cross(a, b) -> np.ndarray:
    """The cross product of 3-vectors along the last axis (broadcast like ``np.cross``).
    The same products and differences as ``np.cross``, so the same numbers, without its
    axis handling, which costs tens of microseconds a call: the hand pass calls it for
    every pose it places."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.ndim == 1 and b.ndim == 1:
        ax, ay, az = a.tolist()
        bx, by, bz = b.tolist()
        return np.array([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx])
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    np.subtract(a1 * b2, a2 * b1, out=out[..., 0])
    np.subtract(a2 * b0, a0 * b2, out=out[..., 1])
    np.subtract(a0 * b1, a1 * b0, out=out[..., 2])
    return out
