"""The body as it stands, for the reach envelope's whole-body classes (``squat``, ``step``):
an estimate made once from the rig, with no rig posed after (pure numpy; the Blender
layer reads it, :func:`reach_addon.blender.envelope.read_stance`).

A single reach's lean, squat and step weigh the balance on the rig itself, posing it for
every lean they try (``reach_addon.blender.lean_balance.BalanceBody``). An envelope asks
that of hundreds of points, so here the body's segments are read once, standing, and a
lean carries them rigidly: the points above the lean bone (the trunk's top, the head and
neck, both arms) turn about its head, the rest (the legs, the trunk's base between the
hips) stay, and the reaching arm is held straight from its leaned shoulder toward the
point (:func:`~.balance.arm_toward`, as the rig's estimate holds it). The centre of mass
of that is :meth:`Stance.com`: Winter's segments (:func:`~.balance.centre_of_mass`).

:class:`Stance` is the ``body`` :func:`~.squat.squat_leans` and :func:`~.hips.shifted_lean`
take (its fields by those names, :meth:`Stance.com` and :meth:`Stance.drop`), with what
:func:`~.step.plan_step` needs besides (the ankles, the leg's length).
World frame, the rig's units.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .balance import arm_toward, centre_of_mass
from .hips import legs_drop

#: The kinds of segment whose distal point a lean carries, and those both of whose points
#: it carries; the legs' and the trunk's base (the hips) stay where they stand.
CARRIED_DISTAL = ("trunk",)
CARRIED_WHOLE = ("upper_arm", "forearm", "hand", "head_neck")


@dataclass(frozen=True)
class Stance:
    """The standing body (world frame; see the module docstring).

    ``segments``: [(kind, proximal, distal)] as :func:`~.balance.centre_of_mass` takes them,
    the reaching arm's three (upper arm, forearm, hand) at ``arm`` (their first index);
    ``pivot``: the lean bone's head; ``to_world``: the arm model's canonical-to-world
    matrix (4, 4; a lean is canonical); ``polygon``: the support polygon
    (:func:`~.balance.ground_basis` coordinates of ``up``); ``planted_share``, ``margin``,
    ``floor``: as :func:`~.hips.shifted_lean`'s ``body`` has them; ``leg_joints``:
    :class:`~.squat.Leg` per leg; ``ankles`` (2, 3) and ``leg_length`` (hip to ankle) for
    the step; ``shoulder``: the reaching shoulder; ``ground``: the height (along ``up``)
    the soles stand on; ``target``: the point the reaching arm
    is held toward (:meth:`toward`); ``trunk_free``: whether a reach may lean or squat
    (False where the bone that leans the trunk has a user's keys, which a reach keeps and
    refuses to lean: steps only, the arm alone after them)."""

    segments: tuple
    arm: int
    pivot: np.ndarray
    to_world: np.ndarray
    polygon: np.ndarray
    up: np.ndarray
    planted_share: float
    margin: float
    floor: float
    leg_joints: tuple
    ankles: np.ndarray
    leg_length: float
    shoulder: np.ndarray
    ground: float
    target: np.ndarray | None = None
    trunk_free: bool = True

    def drop(self, shift_world) -> float:
        """How far the hips come down for ``shift_world`` (:func:`~.hips.legs_drop`, on
        the legs as they stand): what :func:`~.hips.shifted_lean` asks of its ``body``."""
        return legs_drop(self.leg_joints, shift_world, self.up)

    def toward(self, target) -> Stance:
        """This stance with the reaching arm held toward ``target`` (world)."""
        return dataclasses.replace(self, target=np.asarray(target, dtype=float))

    def rotation(self, lean) -> np.ndarray:
        """The world rotation (3, 3) of the canonical :class:`~.lean.Lean` ``lean``:
        :math:`Q R Q^{-1}`, ``Q`` the arm's canonical-to-world rotation with its scale
        divided out (a mirror for a left arm)."""
        m = np.asarray(self.to_world, dtype=float)[:3, :3]
        scale = abs(float(np.linalg.det(m))) ** (1.0 / 3.0)
        q = m / scale
        return q @ lean.matrix(1.0)[:3, :3] @ np.linalg.inv(q)

    def com(self, lean) -> np.ndarray:
        """The centre of mass (world) with the trunk leaned by ``lean`` (its turn; the
        shift is the caller's, :func:`~.hips.shifted_centre`): the carried points turned
        by :math:`p' = o + R (p - o)` about the pivot ``o``, the reaching arm straight from
        its leaned shoulder toward ``target`` (as it stands without one)."""
        r = self.rotation(lean)
        o = np.asarray(self.pivot, dtype=float)

        def turn(p):
            return o + r @ (np.asarray(p, dtype=float) - o)

        out = []
        for kind, a, b in self.segments:
            if kind in CARRIED_WHOLE:
                a, b = turn(a), turn(b)
            elif kind in CARRIED_DISTAL:
                b = turn(b)
            out.append((kind, a, b))
        if self.target is not None:
            k = self.arm
            lengths = [float(np.linalg.norm(np.asarray(b) - np.asarray(a)))
                       for _kind, a, b in self.segments[k:k + 3]]
            out[k:k + 3] = arm_toward(out[k][1], lengths, self.target)
        return centre_of_mass(out)
