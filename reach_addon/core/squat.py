"""The squat or bend: where no standing lean brings a low target within reach, the hips
come down, the knees bend and the trunk leans farther, the feet planted (stage 4 of the
whole-body reach, ``docs/design/core.md``).

**The posture** is a :class:`~.lean.Lean` whose hips' shift has a downward part: the
trunk leans by θ about its pivot, and the hips bone moves back by δ along the lean's
horizontal direction ``h`` and down by η, ``shift = −δh − ηu`` (``u`` up), the knees and
ankles taking the difference with the feet where they are (two-bone IK per leg,
:func:`~.hips.two_bone_knee`). η = 0 is a bend (a deep lean, the legs near straight); more
is a squat. Nothing else is new: the lean's arm, phase, checks and bake are those of the
standing lean.

**Its joints** (:func:`leg_angles`, on the legs as they stand, :class:`Leg`): the knee's
flexion κ (0 straight: the angle between the thigh and the shank), the ankle's
dorsiflexion α (how far the shank tips over the planted foot from where it stands: the
figure's rest stance is taken as neutral) and the thigh's flexion φ (its angle from the
pelvis's down; the hips bone only moves, it does not tilt). Each stays within its limit:
``Settings.knee_max`` 135° and ``Settings.hip_max`` 120° (the averages of the American
Academy of Orthopaedic Surgeons, *Joint Motion: Method of Measuring and Recording*, 1965),
``Settings.ankle_max`` 38° (the weight-bearing lunge test's normal range, 30-38°: a squat
loads the ankle, which AAOS's 20° is not measured with). The trunk's lean θ is at most
``Settings.bend_max`` (90°) from upright; a person shares it between the pelvis's tilt
at the hips (whose flexion is then φ plus that tilt) and the spine's flexion (AAOS
thoracolumbar 80°, ``Settings.spine_max``), so a tilt exists that keeps both within
their ranges exactly where

.. math:: θ + φ \\le φ_{max} + σ_{max}.

**Which posture** (:func:`squat_leans`). The paper is silent, so the choice is ours: a
grid over the hips' drop η and shift δ (``Settings.squat_step`` arm lengths apart, both
up to the leg's length: the joints' limits and the balance bound them), and at each node the least lean
θ that brings the target within ``Settings.lean_reach`` of the shoulder (closed form,
:func:`~.lean.least_lean`). A node is kept where every joint is within its limit and the
centre of mass stands the balance margin inside the feet (the trunk's centre of mass at θ
read from a table of :data:`COM_STEP`-degree leans, the hips' shift moving what they carry,
:func:`~.hips.shifted_centre`). The kept nodes are ranked by effort (:func:`effort`):
each joint's share of its range, squared, summed,

.. math:: E = (θ/θ_{max})^2 + (κ/κ_{max})^2 + (α/α_{max})^2 + (φ/φ_{max})^2

for the lean θ, the knee κ, the ankle α and the hip φ: a continuous reading of REBA's
trunk and leg scores (Hignett & McAtamney 2000), which rise with the trunk's flexion and
the knee's bend, and squared, as a static joint torque grows with the joint's angle, so
the effort spreads over the joints (a person neither stoops with locked knees nor squats
bolt upright to pick a cup off the floor). The Blender layer's checks (balance measured
on the rig, the body's skin against the obstacles) then take the first that passes.

Pure numpy; the legs and the balance come from the caller, in the world frame
(:func:`~.hips.shifted_lean`'s ``body``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .balance import balance_margin
from .effort import joint_displacement
from .hips import STRAIGHT_SHARE, body_frame, horizontal_toward, shifted_centre, two_bone_knee
from .lean import Lean, lean_axis, least_lean
from .torso import rotate_about_spine

#: Degrees between the leans at which the trunk's centre of mass is read; between them
#: it is interpolated (it moves on a circle about the pivot: 2.5° apart, the chord
#: departs from the arc by under 0.03 % of the radius).
COM_STEP = 2.5


@dataclass(frozen=True)
class Leg:
    """One leg as it stands (world): its hip joint, knee and ankle, and the direction its
    knee bends (:func:`knee_pole`)."""

    hip: np.ndarray
    knee: np.ndarray
    ankle: np.ndarray
    pole: np.ndarray

    @property
    def thigh(self) -> float:
        return float(np.linalg.norm(np.asarray(self.knee) - np.asarray(self.hip)))

    @property
    def shank(self) -> float:
        return float(np.linalg.norm(np.asarray(self.ankle) - np.asarray(self.knee)))


def knee_pole(hip, knee, ankle, forward) -> np.ndarray:
    """The direction a knee bends: the way it is bent now where that is forward of the leg
    (``forward``: the body's), else straight forward. A leg held straight has no bend of
    its own to follow, and a knee bends only forward."""
    h, k, a = (np.asarray(p, dtype=float) for p in (hip, knee, ankle))
    line = a - h
    pole = (k - h) - ((k - h) @ line) / float(line @ line) * line
    ahead = np.asarray(forward, dtype=float)
    if float(np.linalg.norm(pole)) < 0.05 * float(np.linalg.norm(k - h)) \
            or float(pole @ ahead) <= 0.0:
        return ahead
    return pole


def _angle(a, b) -> float:
    """The angle (degrees) between directions ``a`` and ``b``."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    c = float(a @ b) / max(float(np.linalg.norm(a) * np.linalg.norm(b)), 1e-300)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def leg_angles(leg: Leg, shift, up) -> tuple:
    """(knee flexion, ankle dorsiflexion, hip flexion), degrees, of ``leg`` with its hip
    joint moved by ``shift`` (world) and its ankle where it is: the knee where
    :func:`~.hips.two_bone_knee` puts it; the knee's flexion the angle between thigh and
    shank, κ = ∠(k − h, a − k); the ankle's the angle the shank has tipped through,
    α = ∠(k' − a, k − a); the hip's the thigh's angle from down, φ = ∠(k' − h', −u)."""
    hip = np.asarray(leg.hip, dtype=float) + np.asarray(shift, dtype=float)
    knee = two_bone_knee(hip, leg.ankle, leg.thigh, leg.shank, leg.pole)
    ankle = np.asarray(leg.ankle, dtype=float)
    return (_angle(knee - hip, ankle - knee), _angle(knee - ankle, np.asarray(leg.knee) - ankle),
            _angle(knee - hip, -np.asarray(up, dtype=float)))


def reach_of(leg: Leg, shift) -> bool:
    """Whether the hip joint moved by ``shift`` is within :data:`~.hips.STRAIGHT_SHARE` of
    the leg's length from its ankle (a leg that can still reach its foot)."""
    hip = np.asarray(leg.hip, dtype=float) + np.asarray(shift, dtype=float)
    return float(np.linalg.norm(hip - np.asarray(leg.ankle))) <= \
        STRAIGHT_SHARE * (leg.thigh + leg.shank) + 1e-9


def effort(theta, knee, ankle, hip, settings) -> float:
    """The posture's effort: each joint's share of its range, squared, summed (see the
    module docstring; :func:`~.effort.joint_displacement`)."""
    return joint_displacement(theta, settings.bend_max) + \
        joint_displacement(knee, settings.knee_max) + \
        joint_displacement(ankle, settings.ankle_max) + joint_displacement(hip, settings.hip_max)


@dataclass(frozen=True)
class Squat:
    """A posture found by :func:`squat_leans`: the ``lean`` (its shift carries the hips
    back and down), its ``effort``, the worst ``knee``, ``ankle`` and ``hip`` angles over
    both legs (degrees) and the centre of mass's estimated ``margin`` (world units)."""


    lean: Lean
    effort: float
    knee: float
    ankle: float
    hip: float
    margin: float
    #: the chest's turn it was found for (degrees) and its estimated centre of mass
    #: (canonical)
    turn: float = 0.0
    centre: np.ndarray = field(default_factory=lambda: np.zeros(3))


def com_table(com, pivot_c, axis, most: float):
    """``com(θ)`` read every :data:`COM_STEP` degrees from 0 to ``most`` and interpolated
    between: a function of θ (degrees) → the centre of mass (as ``com`` gives it)."""
    thetas = np.arange(0.0, float(most) + COM_STEP, COM_STEP)
    table = np.array([np.asarray(com(Lean(np.asarray(pivot_c, float), axis, float(t))), float)
                      for t in thetas])

    def at(theta):
        return np.array([np.interp(float(theta), thetas, table[:, i]) for i in range(3)])
    return at


def squat_leans(arm, target_c, pivot_c, settings, turns, body) -> list:
    """Every posture of the grid (see the module docstring) that reaches ``target_c``
    (canonical) within the joints' limits and the balance margin, with the chest turned by
    one of ``turns`` (degrees), best first (:class:`Squat`, least effort; ties by the lesser
    drop): [] where none does. ``body``: as :func:`~.hips.shifted_lean`'s, with
    ``leg_joints`` (:class:`Leg`, world) besides, and optionally ``com_posed(lean)``: the
    centre of mass (world) of the whole posture as the rig takes it (the knees come
    forward as the hips drop, which the estimate leaves out). Where it is given, the best
    posture is measured so, the estimate corrected by the difference and the grid ranked
    again, :data:`CALIBRATIONS` times at most (on the Goblin the estimate put the centre
    of mass 0.06 arm lengths too far back)."""
    grid = _Grid(arm, target_c, pivot_c, settings, body)
    correction = np.zeros(3)
    found = []
    for turn in turns:
        found = grid.rank(float(turn), correction)
        if found:
            break
    if not found or not hasattr(body, "com_posed"):
        return found
    for _ in range(CALIBRATIONS):
        best = found[0]
        error = grid.canonical(body.com_posed(best.lean)) - best.centre
        error = error - float(error @ grid.ground) * grid.ground     # its ground part
        if float(np.linalg.norm(error)) <= CALIBRATED * arm.arm_length:
            break
        correction = correction + error
        found = grid.rank(best.turn, correction)
        if not found:
            break
    return found


#: How many times :func:`squat_leans` measures its best posture and ranks again, and the
#: error (arm lengths) under which it stops.
CALIBRATIONS = 2
CALIBRATED = 0.005


class _Grid:
    """The grid :func:`squat_leans` ranks, for one arm, target and body (see the module
    docstring): ``rank(turn, correction)`` with the chest turned by ``turn`` and the
    estimated centre of mass moved by ``correction`` (canonical)."""

    def __init__(self, arm, target_c, pivot_c, settings, body):
        self.rot, self.scale, self.canonical, self.polygon, self.ground = body_frame(arm, body)
        self.up_w = np.asarray(body.up, dtype=float)
        self.arm, self.settings, self.body = arm, settings, body
        self.target = np.asarray(target_c, dtype=float)
        self.pivot = np.asarray(pivot_c, dtype=float)
        self.axis = lean_axis(self.pivot, self.target)
        self.h = horizontal_toward(self.pivot, self.target, self.ground)
        self.legs = list(body.leg_joints)
        step = settings.squat_step * arm.arm_length
        deepest = max(leg.thigh + leg.shank for leg in self.legs) / self.scale
        self.steps = np.arange(0.0, deepest + 0.5 * step, step)
        self.com_at = com_table(lambda lean: self.canonical(body.com(lean)), self.pivot,
                                self.axis, settings.bend_max)
        # the nodes the legs reach, (η, δ, shift, its world vector), and each one's leg
        # angles once asked: neither depends on the chest's turn, which rank is asked
        # again for
        self.nodes = []
        for eta in self.steps:
            for delta in self.steps:
                shift = -delta * self.h - eta * self.ground
                world = self.rot @ shift
                if all(reach_of(leg, world) for leg in self.legs):
                    self.nodes.append((eta, delta, shift, world))
        self.angles = {}

    def leg_angles_at(self, k: int) -> tuple:
        """The worst (knee, ankle, hip) angles over the legs at node ``k``."""
        if k not in self.angles:
            world = self.nodes[k][3]
            self.angles[k] = tuple(np.max([leg_angles(leg, world, self.up_w)
                                           for leg in self.legs], axis=0))
        return self.angles[k]

    def rank(self, turn: float, correction) -> list:
        s, h = self.settings, self.h
        shoulder = rotate_about_spine(self.arm.shoulder, turn)
        margin = self.body.margin / self.scale
        reach = s.lean_reach * self.arm.arm_length
        found = []
        for k, (_eta, delta, shift, _world) in enumerate(self.nodes):
            theta = least_lean(shoulder + shift, self.pivot + shift, self.target, reach,
                               s.bend_max)
            if theta is None:
                continue
            centre = shifted_centre(self.com_at(theta), h, delta,
                                    self.body.planted_share) + correction
            kept = balance_margin(centre, self.polygon, self.ground)
            if kept < margin:
                continue
            knee, ankle, hip = self.leg_angles_at(k)
            if knee > s.knee_max or ankle > s.ankle_max or hip > s.hip_max or \
                    theta + hip > s.hip_max + s.spine_max:
                continue
            found.append(Squat(Lean(self.pivot, self.axis, float(theta), shift),
                               effort(theta, knee, ankle, hip, s), float(knee),
                               float(ankle), float(hip), kept * self.scale, turn, centre))
        found.sort(key=lambda q: (round(q.effort, 9), -float(q.lean.shift @ self.ground),
                                  q.lean.angle))
        return found
