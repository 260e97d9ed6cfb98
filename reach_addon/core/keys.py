"""The instants between two keyed poses, as Blender interpolates the keys.

The bake (``reach_addon.blender.bake``) turns each keyed bone so that its frame follows
its segment's (:func:`segment_frames`); a bone's channels then hold its rotation relative
to its parent, ``A · R_p⁻¹ R_c · B``, with ``A`` and ``B`` constant rotations. On a linear
span Blender blends each quaternion channel by nlerp, which commutes with those constant
rotations, so the arm between two keys is the chain of the nlerped relative rotations of
its segments (:func:`between`), whatever the rig's rolls and rest pose. Spans keyed with
Bézier curves and bones in an Euler mode are checked by the bake itself.
"""

from __future__ import annotations

import math

import numpy as np

from .arm import ArmModel, Pose, hand_direction_floats
from .hand_shape import shape_points
from .numeric import cross
from .orient import FOREARM_SHARE
from .torso import rotate_about_spine, spine_rotation_matrix

# Plain floats throughout: the hand pass asks for a few instants of hundreds of
# transitions, where numpy's cost per call on 3-vectors would be most of the time.


def _unit(v):
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / n, v[1] / n, v[2] / n)


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _frame(a, b, roll: float = 0.0):
    """Columns (a, b', a × b') with a unit and b made perpendicular to it and unit, turned
    by ``roll`` degrees about a (:func:`~reach_addon.core.arm.roll_frames`)."""
    a = _unit(a)
    k = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    b = _unit((b[0] - k * a[0], b[1] - k * a[1], b[2] - k * a[2]))
    c = _cross(a, b)
    if roll:
        r = math.radians(roll)
        cos, sin = math.cos(r), math.sin(r)
        b, c = (tuple([cos * y + sin * z for y, z in zip(b, c)]),
                tuple([cos * z - sin * y for y, z in zip(b, c)]))
    return a, b, c


def _frames(pose: Pose, hand=None):
    """:func:`segment_frames` as column triples, the chest as the body rotation."""
    s, e, w, tip = (pose.joints[i].tolist() for i in (1, 2, 3, 4))
    bend = pose.bend.tolist()
    u = _unit([e[i] - s[i] for i in range(3)])
    f = _unit([w[i] - e[i] for i in range(3)])
    d = [tip[i] - w[i] for i in range(3)] if hand is None else \
        hand_direction_floats(u, bend, f, *hand)
    hinge = _cross(u, bend)
    roll = float(pose.roll)
    return (float(pose.config.body_rotation), _frame(u, bend), _frame(f, hinge, FOREARM_SHARE * roll),
            _frame(d, hinge, roll))


def segment_frames(arm: ArmModel, pose: Pose, hand=None) -> np.ndarray:
    """The frames (4, 3, 3), canonical, columns first, that the bake turns the chest, upper
    arm, forearm and hand bones by at ``pose``: the body rotation about the spine; (u, b,
    u × b) with u the upper arm's direction and b the bend direction; (f, h, f × h) with
    h = u × b the elbow's hinge; (d, g, d × g) with d the hand's direction and g the hinge
    made perpendicular to it. The hand's frame is turned by the palm's roll ψ about d and
    the forearm's by ``FOREARM_SHARE`` · ψ about f (``blender.bone_matrices.target_matrices``). ``hand``:
    the wrist's two angles (degrees) instead of the pose's own."""
    body, *limbs = _frames(pose, hand)
    return np.array([spine_rotation_matrix(body)] + [np.array(cols).T for cols in limbs])


def quaternion(cols) -> tuple:
    """The unit quaternion (w, x, y, z) of a rotation given by its columns, from the
    largest of 1 + trace and 1 ± the diagonal (so never from a small one):

    .. math:: 4w^2 = 1 + m_{00} + m_{11} + m_{22},\\quad 4x^2 = 1 + m_{00} - m_{11} - m_{22},
              \\ldots,\\quad 4wx = m_{21} - m_{12},\\ 4xy = m_{01} + m_{10},\\ \\ldots
    """
    (m00, m10, m20), (m01, m11, m21), (m02, m12, m22) = cols
    cand = (1 + m00 + m11 + m22, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22)
    i = max(range(4), key=cand.__getitem__)
    r = 0.5 * math.sqrt(cand[i])
    k = 0.25 / r
    if i == 0:
        q = (r, (m21 - m12) * k, (m02 - m20) * k, (m10 - m01) * k)
    elif i == 1:
        q = ((m21 - m12) * k, r, (m01 + m10) * k, (m02 + m20) * k)
    elif i == 2:
        q = ((m02 - m20) * k, (m01 + m10) * k, r, (m12 + m21) * k)
    else:
        q = ((m10 - m01) * k, (m02 + m20) * k, (m12 + m21) * k, r)
    return _normalized(q)


def _mul(a, b):
    """The quaternion product a b (the rotation b, then a)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def _conj(q):
    return (q[0], -q[1], -q[2], -q[3])


def _axes(q):
    """The first two columns (x̂ and ŷ carried) of the rotation of a unit quaternion."""
    w, x, y, z = q
    return ((1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)),
            (2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)))


def nlerp(qa, qb, t: float) -> tuple:
    """Blender's blend of two quaternion keys on a linear span: ``qb`` taken in the
    hemisphere of ``qa`` (the bake writes them so), then (1 − t) q_a + t q_b per channel,
    normalised."""
    if qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3] < 0.0:
        qb = (-qb[0], -qb[1], -qb[2], -qb[3])
    return _normalized([(1.0 - t) * x + t * y for x, y in zip(qa, qb)])


def _normalized(q) -> tuple:
    """The quaternion ``q`` (4 floats) over its length (plain arithmetic: the bake and the
    between-keys checks ask for it at every key and instant)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def between(arm: ArmModel, a: Pose, b: Pose, t, hand_a=None, hand_b=None) -> tuple:
    """The arm at instants ``t`` (m,) of the span from key ``a`` (t = 0) to key ``b``
    (t = 1), as Blender interpolates a linear span (the module's docstring): each
    segment's rotation relative to its parent, chest to hand (:func:`segment_frames`),
    blended by :func:`nlerp`, then chained from the chest out.

    .. math:: R_0(t) = \\mathrm{nlerp}(R_{0a}, R_{0b}, t),\\quad
              R_i(t) = R_{i-1}(t)\\, \\mathrm{nlerp}(R_{i-1,a}^\\top R_{ia},\\,
              R_{i-1,b}^\\top R_{ib},\\, t)

    sternum and shoulder carried by the chest's turn, elbow = shoulder + L₁ R₁(t) x̂,
    wrist = elbow + L₂ R₂(t) x̂, the hand's end = wrist + L_h R₃(t) x̂. ``hand_a``,
    ``hand_b``: the wrist's angles at the keys instead of the poses' own.

    Returns (joints (m, 5, 3), bend directions (m, 3), body rotations (m,), degrees), all
    canonical. Where the arm has a hand shape (:mod:`.hand_shape`) the joints are followed
    by its capsules' ends in the hand's frame as it blends, R₃(t): (m, 5 + 2K, 3)."""
    keys = []
    for pose, hand in ((a, hand_a), (b, hand_b)):
        body, *limbs = _frames(pose, hand)
        # the spine's rotation by θ is a turn of −θ about z
        half = -0.5 * math.radians(body)
        chain = [(math.cos(half), 0.0, 0.0, math.sin(half))] + [quaternion(c) for c in limbs]
        keys.append([chain[0]] + [_mul(_conj(p), c) for p, c in zip(chain, chain[1:])])
    lengths = (arm.upper_arm_length, arm.forearm_length, arm.hand_length)
    ends, bends, bodies, hands = [], [], [], []
    for x in np.atleast_1d(np.asarray(t, dtype=float)).tolist():
        q = nlerp(keys[0][0], keys[1][0], x)
        bodies.append(-math.degrees(2.0 * math.atan2(q[3], q[0])))
        points, bend = [], None
        for i in range(3):
            q = _mul(q, nlerp(keys[0][i + 1], keys[1][i + 1], x))
            axis, second = _axes(q)
            points.append([lengths[i] * v for v in axis])
            if i == 0:
                bend = second
        ends.append(points)
        bends.append(bend)
        hands.append((axis, second))
    body = np.array(bodies)
    sternum = rotate_about_spine(arm.sternum, body)
    shoulder = rotate_about_spine(arm.shoulder, body)
    steps = np.cumsum(np.array(ends), axis=1)                 # (m, 3, 3): elbow, wrist, end
    joints = np.concatenate([sternum[:, None], shoulder[:, None], shoulder[:, None] + steps], 1)
    if arm.hand_shape:
        d, g = (np.array(v) for v in zip(*hands))
        frames = np.stack([d, g, cross(d, g)], -1)
        joints = np.concatenate([joints, shape_points(arm.hand_shape, joints[:, 3], frames)], 1)
    return joints, np.array(bends), body
