"""The trunk's lean: how far the upper body must tip at the hips to bring a target within
the arm's reach, what that lean costs, and the ranges it keeps to.

The first piece of the whole-body reach (issue "Reach past the arm"; the plan is in
``docs/design/core.md``, *balance.py*). The refusal ``needs_lean`` reads its lean from
here (:func:`least_lean`), and so will the planner when it leans.

**Geometry.** The upper body turns rigidly about a horizontal axis ``k`` through the
``pivot`` (the hips; the arm model's waist where the rig gives none). ``k`` is at right
angles to the pivot's horizontal direction ``h`` to the target, ``k = up × h``, so the
trunk tips straight toward the target: flexion for a target ahead, a lateral bend for one
to the side, both for one in between. A point ``v`` of the upper body, relative to the
pivot, goes to (Rodrigues, :func:`rotate_about`)

.. math:: R_k(θ)\\,v = v\\cos θ + (k × v)\\sin θ + k\\,(k·v)(1 - \\cos θ)

**The least lean** (:func:`least_lean`) is the least θ in [0, θ_max] with

.. math:: |t - p - R_k(θ)(s - p)| \\le r

for the shoulder ``s``, the pivot ``p``, the target ``t`` and the reach ``r``: in closed
form, the leans that reach are one window of angles (a lean past the target's height takes
the shoulder away again), and the least is its lower end.

The limit (``Settings.lean_max``, 45°) lies well within the American Academy of
Orthopaedic Surgeons' average ranges (*Joint Motion: Method of Measuring and Recording*,
1965): thoracolumbar flexion 80°, hip flexion 120°. A young adult's lean with the feet
fixed reaches about 37-42 cm past the arm (Duncan et al. 1990, *Functional reach*,
J Gerontol 45: M192).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .numeric import cross
from .torso import rotate_about_spine

#: The canonical frame's up axis (the arm frame: x outward, y forward, z up).
UP = np.array([0.0, 0.0, 1.0])


def lean_axis(pivot, target) -> np.ndarray:
    """The axis the trunk tips about to lean toward ``target`` (canonical, unit):
    ``up × h`` with ``h`` the pivot's horizontal direction to the target (straight ahead,
    +y, where the target is right above or below the pivot)."""
    d = np.asarray(target, dtype=float) - np.asarray(pivot, dtype=float)
    h = np.array([d[0], d[1], 0.0])
    n = float(np.linalg.norm(h))
    h = h / n if n > 1e-9 else np.array([0.0, 1.0, 0.0])
    return cross(UP, h)


def rotate_about(points, pivot, axis, angle_deg) -> np.ndarray:
    """``points`` (..., 3) turned by ``angle_deg`` about the line through ``pivot`` along
    the unit ``axis`` (Rodrigues):
    :math:`p + v\\cos θ + (k × v)\\sin θ + k (k·v)(1 - \\cos θ)`, ``v = x - p``."""
    p = np.asarray(pivot, dtype=float)
    k = np.asarray(axis, dtype=float)
    v = np.asarray(points, dtype=float) - p
    t = math.radians(float(angle_deg))
    c, s = math.cos(t), math.sin(t)
    kv = v @ k
    return p + v * c + cross(k, v) * s + k * (kv[..., None] if np.ndim(kv) else kv) * (1.0 - c)


def lean_rotation(pivot, axis, angle_deg) -> np.ndarray:
    """The 4×4 rigid transform (canonical frame) of a lean: :func:`rotate_about` as a
    matrix, so a leaned arm's ``to_world`` is ``to_world @ lean_rotation(...)``."""
    m = np.eye(4)
    m[:3, :3] = rotate_about(np.eye(3), np.zeros(3), axis, angle_deg).T
    p = np.asarray(pivot, dtype=float)
    m[:3, 3] = p - m[:3, :3] @ p
    return m


def least_lean(shoulder, pivot, target, reach, lean_max_deg):
    """The least lean (degrees) toward ``target`` that brings it within ``reach`` of the
    shoulder: 0 where it already is, ``None`` where no lean up to ``lean_max_deg`` does.

    In closed form: with ``v = s - p``, ``d = t - p`` and the lean's axis ``k``,

    .. math::
        |d - R_k(θ) v|^2 \\le r^2 \\iff A\\cos θ + B\\sin θ \\ge D,\\quad
        A = d·v - (k·d)(k·v),\\ B = d·(k × v),\\
        D = \\tfrac12(|d|^2 + |v|^2 - r^2) - (k·d)(k·v)

    and :math:`A\\cos θ + B\\sin θ = M\\cos(θ - φ)` (:math:`M = \\sqrt{A^2 + B^2}`,
    :math:`φ = \\operatorname{atan2}(B, A)`), so the leans that reach are the window
    :math:`|θ - φ| \\le \\arccos(D / M)`: the least is 0 inside it, else its lower end."""
    p = np.asarray(pivot, dtype=float)
    v = np.asarray(shoulder, dtype=float) - p
    d = np.asarray(target, dtype=float) - p
    k = lean_axis(p, target)
    kk = float(k @ d) * float(k @ v)
    a = float(d @ v) - kk
    b = float(d @ cross(k, v))
    need = 0.5 * (float(d @ d) + float(v @ v) - float(reach) ** 2) - kk
    m = math.hypot(a, b)
    if m <= 1e-12 * max(1.0, float(v @ v)):
        return 0.0 if need <= 0.0 else None
    if need > m:
        return None
    phi = math.degrees(math.atan2(b, a))
    half = math.degrees(math.acos(max(-1.0, need / m)))
    if a >= need:                      # θ = 0 reaches: M cos(0 - φ) = A
        return 0.0
    lowest = (phi - half) % 360.0
    return lowest if lowest <= float(lean_max_deg) else None


@dataclass(frozen=True)
class Lean:
    """A lean of the upper body (canonical frame of the upright arm): ``angle`` degrees
    about the line through ``pivot`` along the unit ``axis`` (:func:`lean_axis`), the
    hips moved by ``shift`` (canonical, :mod:`~.hips`; none by default) with everything
    they carry."""

    pivot: np.ndarray
    axis: np.ndarray
    angle: float
    shift: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def shift_share(self, fraction: float = 1.0) -> float:
        """How much of the hips' shift is made at ``fraction`` of the lean: as much as the
        trunk's forward lean is, :math:`g(f) = \\sin(fθ) / \\sin θ` (``f`` where θ is
        under a degree). The trunk's weight comes forward as the sine of its lean, and the
        hips going back by the same share keep the centre of mass where the full posture
        puts it all the way (by a share ``f`` instead, a 74° squat's trunk came forward
        faster than the hips went back, and the body was 0.0045 arm lengths past its toes
        half-way)."""
        f = float(fraction)
        if abs(self.angle) < 1.0:
            return f
        return math.sin(math.radians(self.angle * f)) / math.sin(math.radians(self.angle))

    def shift_at(self, fraction: float = 1.0) -> np.ndarray:
        """The hips' shift (canonical) at ``fraction`` of the lean (:meth:`shift_share`)."""
        return self.shift_share(fraction) * np.asarray(self.shift, dtype=float)

    def matrix(self, fraction: float = 1.0) -> np.ndarray:
        """The 4×4 canonical transform of ``fraction`` of the lean: the hips' shift after
        the turn about the pivot, T(:meth:`shift_at` f) · :func:`lean_rotation`."""
        m = lean_rotation(self.pivot, self.axis, self.angle * float(fraction))
        m[:3, 3] += self.shift_at(fraction)
        return m

    def moved(self, fraction: float = 1.0) -> np.ndarray:
        """The 4×4 canonical transform of what the hips carry below the pivot at
        ``fraction``: the shift alone."""
        m = np.eye(4)
        m[:3, 3] = self.shift_at(fraction)
        return m


def leaned_arm(arm, lean: Lean, fraction: float = 1.0):
    """``arm`` on a trunk leaned by ``fraction`` of ``lean``: the same arm in its own
    (leaned) canonical frame, whose ``to_world`` is ``arm.to_world @ L``. The body
    capsules that turn with the chest (chest, head) lean with it; the others (the pelvis,
    below the pivot) only move with the hips' shift ``S`` (:meth:`Lean.moved`), so in the
    leaned frame they are carried by ``L⁻¹ S``."""
    m = lean.matrix(fraction)
    back = np.linalg.inv(m) @ lean.moved(fraction)

    def stay(c):
        if c.turns_with_chest:
            return c
        a, b = (back[:3, :3] @ np.asarray(p, dtype=float) + back[:3, 3] for p in (c.a, c.b))
        return dataclasses.replace(c, a=a, b=b)

    return dataclasses.replace(arm, to_world=np.asarray(arm.to_world, dtype=float) @ m,
                               body_capsules=tuple(stay(c) for c in arm.body_capsules))


#: The chest turns :func:`choose_lean` tries, degrees apart.
CHEST_TURN_STEP = 5.0


def chest_turns(settings) -> list:
    """Every chest turn (degrees) the planner may give a reach: every
    :data:`CHEST_TURN_STEP` within ``Settings.chest_rotation_max`` either way, where chest
    rotation is on; else none (0)."""
    if not settings.chest_rotation or settings.chest_rotation_max <= 0.0:
        return [0.0]
    n = int(math.ceil(settings.chest_rotation_max / CHEST_TURN_STEP))
    return [float(t) for t in np.linspace(-settings.chest_rotation_max,
                                          settings.chest_rotation_max, 2 * n + 1)]


def choose_lean(arm, target_c, pivot_c, settings, turns=(0.0,)) -> Lean | None:
    """The least lean, about ``pivot_c``, that brings ``target_c`` (canonical) within
    ``Settings.lean_reach`` arm lengths of the shoulder (:func:`least_lean`), at most
    ``Settings.lean_max``, with the chest turned by one of ``turns`` (degrees; the planner
    then fits its own turn on the leaned trunk); ``None`` where none does. 0° where the
    target is within that reach already."""
    reach = settings.lean_reach * arm.arm_length
    leans = [least_lean(rotate_about_spine(arm.shoulder, float(t)), pivot_c, target_c, reach,
                        settings.lean_max) for t in turns]
    leans = [x for x in leans if x is not None]
    if not leans:
        return None
    return Lean(np.asarray(pivot_c, dtype=float), lean_axis(pivot_c, target_c), float(min(leans)))


def lean_frames(arm, joints_c, lean: Lean, settings, fps: float) -> np.ndarray:
    """The lean's fraction on each frame of its own phase, before the arm moves: a
    minimum-jerk curve (:func:`~reach_addon.core.torso.minimum_jerk`) over as many frames
    as the wrist's path takes at the automatic duration's speed
    (:func:`~reach_addon.core.motion.auto_duration` reasoning: ``Settings.mean_speed`` arm
    lengths a second, at least ``Settings.min_duration``). The path is the wrist's arc
    (``lean.angle`` in radians times its distance from the pivot) and, where the hips move
    (back, or down in a squat), their travel, the two combined as legs of a right angle
    (``hypot``): the wrist's turn about the pivot and the hips' drop run nearly across each
    other. Frame 0 is the upright start (fraction 0); the last is 1."""
    wrist = np.asarray(joints_c, dtype=float)[3]
    arc = math.hypot(math.radians(lean.angle) * float(np.linalg.norm(wrist - lean.pivot)),
                     float(np.linalg.norm(lean.shift))) / arm.arm_length
    seconds = max(settings.min_duration, arc / settings.mean_speed)
    n = max(2, int(math.ceil(seconds * fps)) + 1)
    t = np.linspace(0.0, 1.0, n)
    return t * t * t * (10.0 + t * (-15.0 + 6.0 * t))


#: Instants checked between two frames of the lean (besides the frames themselves).
LEAN_SUBSTEPS = 4


@dataclass(frozen=True)
class TrunkSkin:
    """The trunk as skinned, for the lean's obstacle test (canonical frame of the upright
    arm): ``points`` (n, 3), the skin the lean carries less the reaching arm's, and
    ``turns`` (n,), which of them the chest's turn carries too."""

    points: np.ndarray
    turns: np.ndarray


def carried(points_c, transforms) -> np.ndarray:
    """``points_c`` (canonical (n, 3)) carried by the 4×4 ``transforms`` (canonical →
    world, one an instant): world (T, n, 3)."""
    pts = np.asarray(points_c, dtype=float)
    return np.array([pts @ m[:3, :3].T + m[:3, 3] for m in transforms])


def skin_hit(world, checker):
    """The first instant at which a point of the skin, at ``world`` (T, n, 3) on the
    instants in turn, comes within the clearance (``checker.margin``) of an obstacle:
    (instant index, obstacle name), or None.

    Exact about crossing: the distance to a surface is 1-lipschitz, so a point at least
    the margin from every surface at two instants, having moved less than twice the margin
    between them, was clear in between; instants are added where a point moves more. Only
    the points that come within their own travel of an obstacle are measured after the
    first instant. A point already within the margin at the first instant is not held to
    the margin (a figure may stand against a table, its soles on the floor; the points
    round it are), only kept out of the obstacle it touches: it may not be inside a
    closed obstacle by more than the margin at any of the instants given (between them it
    is not read; :func:`sunk_hit`)."""
    world = np.asarray(world, dtype=float)
    if not world.shape[1] or checker.obstacles.tree is None:
        return None
    travel = np.linalg.norm(world - world[0], axis=2).max(axis=0)
    margin = checker.margin
    first = np.array([checker.obstacles.distance(p, t + margin) for p, t in zip(world[0], travel)])
    near = (first < travel + margin) & (first >= margin)
    touching = (first < margin) & (travel > margin)
    for k in range(1, len(world)):
        if near.any():
            prev, now = world[k - 1][near], world[k][near]
            step = float(np.linalg.norm(now - prev, axis=1).max())
            splits = max(1, int(math.ceil(step / (1.5 * max(margin, 1e-12)))))
            for j in range(1, splits + 1):
                at = prev + (now - prev) * (j / splits)
                for p in at:
                    if checker.obstacles.distance(p, margin) < margin:
                        return k, owner_near(checker, p)
        hit = sunk_hit(world[k][touching], checker) if touching.any() else None
        if hit is not None:
            return k, hit
    return None


def sunk_hit(points, checker):
    """The name of a closed obstacle one of ``points`` (world) lies inside, deeper than the
    clearance (``checker.margin``), else None: the test of :func:`skin_hit` for the skin
    that touches an obstacle where it starts (the soles on a floor box; the Goblin's ankle,
    its skin blended between the shank and the foot, went 7 cm into the floor as a squat
    tipped the shank over it, and the margin alone never held it). Inside is read by the
    rays' parity (:meth:`~.collision.Obstacles.point_inside`), so an open mesh (a plane)
    has no inside and holds nothing here; a point within the margin of a surface is not
    asked."""
    margin = checker.margin
    for p in points:
        if checker.obstacles.distance(p, margin) >= margin and \
                checker.obstacles.point_inside(p):
            return checker.obstacles.enclosing_owner(p)
    return None


def owner_near(checker, point) -> str:
    """The name of the obstacle nearest ``point`` (world)."""
    hit = checker.obstacles.nearest(point, math.inf)
    return checker.obstacles.owner(hit[2] if hit else None)


def capsules_hit(ends, capsules, checker):
    """The first instant at which one of ``capsules`` (their radii and names), at ``ends``
    (T, C, 2, 3): each capsule's two ends, world, on the instants in turn) touches an
    obstacle with the clearance: (instant index, capsule name, obstacle name), or None. A
    capsule already touching at the first instant is not held to it: the body's capsules
    are proportional guesses, and a figure may stand close to a table."""
    ends = np.asarray(ends, dtype=float)
    held = [i for i, c in enumerate(capsules) if checker.capsule_clear(*ends[0, i], c.radius)]
    for k in range(len(ends)):
        for i in held:
            a, b = ends[k, i]
            if not checker.capsule_clear(a, b, capsules[i].radius):
                return k, capsules[i].name, owner_near(checker, 0.5 * (a + b))
    return None


def lean_hit(arm, joints_c, lean: Lean, fractions, checker, trunk: TrunkSkin | None = None,
             turn: float = 0.0):
    """The first part that touches an obstacle as the trunk leans: (fraction, part name,
    obstacle name), or ``None`` where the lean is clear. The arm holds its start pose
    (``joints_c``, canonical (5, 3), followed by the hand shape's rows where the arm has one:
    :func:`~.hand_shape.with_shape`) on the leaning trunk; the arm's capsules (hand
    included, as ``checker`` tests them) are tested on every frame of ``fractions`` and
    :data:`LEAN_SUBSTEPS` instants between two, and then the trunk on them: its skin where
    the rig gives it (``trunk``, :func:`skin_hit`: part "trunk"), else the chest's and
    head's capsules (:func:`capsules_hit`), the part the chest carries turned by ``turn``
    (degrees: the chest's turn the arm holds, :func:`~.torso.rotate_about_spine`)."""
    joints_c = np.asarray(joints_c, dtype=float)
    f = np.asarray(fractions, dtype=float)
    steps = np.linspace(0.0, 1.0, LEAN_SUBSTEPS + 2)[1:]
    instants = np.concatenate([[f[0]]] + [a + (b - a) * steps for a, b in zip(f[:-1], f[1:])])
    transforms = [arm.to_world @ lean.matrix(float(x)) for x in instants]
    for fraction, m in zip(instants, transforms):
        hit = checker.first_hit(joints_c @ m[:3, :3].T + m[:3, 3])
        if hit is not None:
            return float(fraction), hit[0], hit[1]
    if trunk is not None:
        points = np.array(trunk.points, dtype=float)
        points[trunk.turns] = rotate_about_spine(points[trunk.turns], turn)
        hit = skin_hit(carried(points, transforms), checker)
        part = None if hit is None else "trunk"
    else:
        body = [c for c in arm.body_capsules if c.turns_with_chest]
        ends = [rotate_about_spine(np.array([c.a, c.b], dtype=float), turn) for c in body]
        hit = capsules_hit(np.stack([carried(e, transforms) for e in ends], axis=1)
                           if body else np.zeros((len(transforms), 0, 2, 3)), body, checker)
        part = None if hit is None else hit[1]
    return None if hit is None else (float(instants[hit[0]]), part, hit[-1])
