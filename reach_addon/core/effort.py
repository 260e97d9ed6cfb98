"""Trunk effort: which of the body's stages a reach takes, so that the comfortable posture
wins (issue 41, *Recruitment as people do it*).

The paper plans the arm and the chest, the chest turned as its Table 1 has it; the planner
turns the chest farther where Table 1's turn puts no clear arm on the target
(:meth:`~.generator.ConfigurationGenerator.target_chest`). That extra turn gets the arm
past an obstacle, and it also brings a target beyond the arm within reach: a chest turned
60° swings the shoulder forward by most of the shoulders' half-width. People do not reach
a thing ahead of them that way; they lean. So where a reach was planned with the chest
turned past Table 1's because Table 1's shoulder is farther than the straight arm from the
target (:func:`twist_for_reach`), the lean is planned as well, and the one with the smaller
trunk effort is taken.

**The effort** (:func:`trunk_effort`) is the normalized joint displacement of the trunk's
joints away from their neutral, the discomfort measure of Yang, Marler et al. (2004,
*Multi-objective optimization for upper body posture prediction*, AIAA 2004-4506; the
Santos model):

.. math:: E = w_t \\left(\\frac{q_t}{R_t}\\right)^2 + \\left(\\frac{q_l}{R_l}\\right)^2

with ``q_t`` the chest's turn past Table 1's (Table 1's own turn is the paper's neutral for
that direction: a reach within the arm keeps it and costs nothing), ``R_t`` the standing
body's axial range (:data:`AXIAL_RANGE_DEG`), ``q_l`` the lean at the hips and ``R_l`` the
trunk's flexion range (:data:`FLEXION_RANGE_DEG`), and ``w_t`` the weight
``Settings.twist_weight`` (1: the two displacements count alike, as Yang's; 0: a twist
costs nothing: an upright reach that twists is kept, and a refused one tries Table 1's
lean and then the least, as before the costing). The squat's knees and the hips moved
back are not in it: a squat is tried only where no standing lean reaches and never in
place of an upright reach (:func:`~.whole_body.lean_then_reach`), and ranks its own
postures by the same measure over its joints' limits (:func:`~.squat.effort`).
"""

from __future__ import annotations

import math

import numpy as np

from .lean import choose_lean
from .torso import body_rotation_deg, rotate_about_spine

#: The standing body's axial turn (degrees) against the feet: trunk 32.6° on the pelvis
#: and pelvis 63.8° on the feet (Montgomery et al. 2011, *Trunk and pelvis rotation in
#: standing reach*), the ``R_t`` of :func:`trunk_effort`.
AXIAL_RANGE_DEG = 96.4
#: The trunk's flexion range (degrees) a lean at the hips shares: thoracolumbar flexion
#: 80° and hip flexion 120° (AAOS, *Joint Motion*, 1965), the ``R_l`` of
#: :func:`trunk_effort`.
FLEXION_RANGE_DEG = 200.0
#: The widest angle (degrees) off straight ahead, seen from the waist, of a target for which
#: :func:`twist_for_reach` weighs a lean against a twist: the lean toward it is then mostly
#: flexion, whose range :data:`FLEXION_RANGE_DEG` is. A target farther round to the side or
#: behind, which people turn toward, keeps the twist that reaches it.
AHEAD_DEG = 45.0


def joint_displacement(angle_deg: float, range_deg: float) -> float:
    """One joint's term of the discomfort (Yang, Marler et al. 2004): its displacement from
    neutral over its range, squared, :math:`(q / R)^2`."""
    return (float(angle_deg) / float(range_deg)) ** 2


def trunk_effort(twist_deg: float, lean_deg: float, settings) -> float:
    """:math:`E = w_t (q_t / R_t)^2 + (q_l / R_l)^2` (module docstring): ``twist_deg`` the
    chest's turn past Table 1's, ``lean_deg`` the lean at the hips, ``w_t``
    ``Settings.twist_weight``."""
    return (float(settings.twist_weight) * joint_displacement(twist_deg, AXIAL_RANGE_DEG)
            + joint_displacement(lean_deg, FLEXION_RANGE_DEG))


def twist_past_table1(plan, index: int = -1) -> float:
    """How far (degrees) the chest of ``plan`` (a :class:`~.results.Plan`) is turned past
    Table 1's turn for its target ``index`` (:func:`~.torso.body_rotation_deg`, canonical
    frame of ``plan.arm``) as it arrives there (its segment's last pose): the last
    target by default."""
    arm = plan.arm
    target = arm.to_canonical_points(np.asarray(plan.task.targets[index], dtype=float))
    table = body_rotation_deg(target, arm.arm_length, arm.hand_length, plan.settings)
    pose = plan.poses[plan.segments[index].frame_end]
    return abs(float(pose.config.body_rotation) - float(table))


def reach_effort(plan, lean_deg: float, first: int = 0) -> float:
    """The trunk's effort over the targets of ``plan`` from ``first`` on: the sum, over
    each arrival, of :func:`trunk_effort` for its chest's turn past Table 1's
    (:func:`twist_past_table1`) and the lean ``lean_deg`` the trunk holds. A sequence's
    lean is held through the targets after it (:func:`~.whole_body.body_target`), so a
    lean for one far target costs at each later one too."""
    s, n = plan.settings, len(plan.task.targets)
    return sum(trunk_effort(twist_past_table1(plan, i), lean_deg, s) for i in range(first, n))


def twist_for_reach(plan) -> tuple | None:
    """Whether ``plan`` (a single reach, or a sequence or guided reach, that reached every
    target upright, the arm and chest alone) turned the chest past Table 1's to bring one
    of its targets within reach, and a lean would cost less there: (the index of the
    first such target, its twist past Table 1's, the least lean that brings it within
    ``Settings.lean_reach`` of the shoulder with Table 1's turn, about the arm's waist:
    :func:`~.lean.choose_lean`), degrees; else None. A target does not count where Table
    1's shoulder is within the straight arm of it (the turn got the arm past something,
    which a lean does not), where no lean within ``Settings.lean_max`` would do, where it
    is more than :data:`AHEAD_DEG` off straight ahead, or where the lean's
    :func:`trunk_effort` is not below the twist's."""
    s = plan.settings
    if not plan.success or not s.lean or s.twist_weight <= 0:
        return None
    for i in range(len(plan.task.targets)):
        costed = _twist_at(plan, i)
        if costed is not None:
            return (i,) + costed
    return None


def _twist_at(plan, i: int) -> tuple | None:
    """:func:`twist_for_reach` for the target ``i`` of ``plan``: (twist, lean) or None."""
    s, arm = plan.settings, plan.arm
    target = arm.to_canonical_points(np.asarray(plan.task.targets[i], dtype=float))
    off = target - np.asarray(arm.waist, dtype=float)
    if math.degrees(math.atan2(abs(float(off[0])), float(off[1]))) > AHEAD_DEG:
        return None
    table = float(body_rotation_deg(target, arm.arm_length, arm.hand_length, s))
    shoulder = rotate_about_spine(np.asarray(arm.shoulder, dtype=float), table)
    if float(np.linalg.norm(target - shoulder)) <= arm.arm_length:
        return None
    twist = twist_past_table1(plan, i)
    lean = choose_lean(arm, target, arm.waist, s, (table,))
    if lean is None or trunk_effort(0.0, lean.angle, s) >= trunk_effort(twist, 0.0, s):
        return None
    return twist, float(lean.angle)
