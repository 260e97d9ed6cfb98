"""Why the arm cannot do what was asked: why a target can never be reached
(:func:`diagnose_target`, a :class:`Diagnosis`) and what holds an arm that cannot move from
its start pose (:func:`what_holds`, a :class:`Hold`).

Both take a :class:`~reach_addon.core.generator.ConfigurationGenerator` (its arm,
obstacles and settings) and test what the generator tests, in its order. Positions are
canonical, distances in the figure's units, angles in degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import ik
from .arm import Pose, hand_coefficients
from .body_capsules import body_hit, self_collision
from .errors import ARM_DOES_NOT_FIT, NEEDS_LEAN, NEEDS_STEP, OUT_OF_REACH, TARGET_IN_OBSTACLE
from .hand_shape import with_shape
from .lean import least_lean
from .search import last_tries

#: How far the body's up axis, read from the bones, may be off the true vertical (degrees;
#: the Quaternius test rig's, hips to chest, leans 6.8° at rest): a target is reported too
#: high or too low only where no tilt this large could make it a step away instead
#: (:func:`_beyond_reach`).
UP_TILT_DEG = 15.0


@dataclass(frozen=True)
class Diagnosis:
    """Why a target cannot be reached (:func:`diagnose_target`):
    ``reason`` (one of :data:`~reach_addon.core.errors.REASONS`), the ``obstacle`` and the
    ``part`` of the arm in the way, the clearance or distance ``missing`` (figure units),
    the target's ``distance`` from the shoulder and the trunk lean that would reach it."""

    reason: str
    obstacle: str | None = None
    part: str | None = None
    missing: float = 0.0
    distance: float = 0.0
    lean_deg: float = 0.0
    above: bool = False


@dataclass(frozen=True)
class Hold:
    """What holds an arm that cannot move from its start pose
    (:func:`what_holds`): ``kind`` is "obstacle", "body", "hand"
    (the arm is clear but its hand cannot turn to a clear direction without touching),
    "limits", "smoothness" or "reach"; ``what`` the obstacle or body capsule, ``part`` the
    arm's part it holds; ``steps`` of the ``tried`` steps from the start it refuses."""

    kind: str
    what: str
    part: str
    steps: int
    tried: int


def what_holds(generator, start: Pose, directions) -> Hold | None:
    """Why the arm cannot move from ``start`` at all, or None if it can: some step of
    the search from it (one ``Settings.step`` along each of ``directions``, unit rows,
    canonical) has a legal, smooth pose clear with some hand.

    Each step is put down to the first thing that refuses it, in the order the
    generator tests them: the arm's reach (the wrist beyond it), the joint limits (no
    legal pose there), the smoothness bound (legal poses, but none within a step's
    change of the start's angles: the elbow or chest would jump), the body (a part
    inside one of its capsules) or an obstacle (which one, at which part). The
    :class:`Hold` names the most frequent one and how many of the steps it refuses."""
    causes = []
    for d in np.asarray(directions, dtype=float):
        wrist = start.wrist + generator.step_length * d
        if generator.solve(wrist, start) is not None:    # with any clear hand
            return None
        causes.append(_refusal(generator, start, wrist))
    counts: dict = {}
    for c in causes:
        counts[c] = counts.get(c, 0) + 1
    kind, what, part = max(counts, key=lambda c: (counts[c], c != ("limits", "", "")))
    return Hold(kind, what, part, counts[(kind, what, part)], len(causes))

def _refusal(generator, start: Pose, wrist) -> tuple:
    """(kind, what, part) of the first test that refuses every pose at ``wrist`` for a
    step from ``start`` (:meth:`what_holds`)."""
    arm, st = generator.arm, generator.settings
    body = generator.chest(wrist) if generator.chest is not None else None
    sol = ik.solve(arm, wrist[None], st, start.config, body,
                   generator.max_change(start, wrist))
    if not sol.reachable[0]:
        return ("reach", "", "")
    if not sol.valid[0].any():
        free = ik.solve(arm, wrist[None], st, body_rotation=body)
        legal = ik.solve(arm, wrist[None], st, start.config, body, 360.0)
        return ("smoothness", "", "") if legal.valid[0].any() or free.legal[0].any() \
            else ("limits", "", "")
    caps = generator.capsules_at(float(sol.body[0]))
    first = None
    for k in sol.ranked(0, st.elbow_side)[: st.max_pose_tries]:
        joints = sol.joints(0, k)[0]
        for hand in (False, True):
            hit = body_hit(arm, joints.tolist(), caps, include_hand=hand) if caps else None
            if hit is not None:
                first = first or ("body", arm.body_capsules[hit[1]].name, hit[0])
                break
            shaped = with_shape(arm, joints, sol.bend_at(0, k)) if hand else joints
            hit = generator.checker.first_hit(arm.to_world_points(shaped), include_hand=hand)
            if hit is not None:
                first = first or ("obstacle", hit[1], hit[0])
                break
        else:
            # the arm and its straight hand are clear: the hand's turn from the start's
            # is what no clear direction allows (it touches on the way)
            first = first or ("hand", "", "hand")
    return first or ("limits", "", "")

def fit_within_tolerance(generator, wrist):
    """Where the point ``wrist`` itself has no clear pose at any chest rotation
    (:meth:`~reach_addon.core.generator.ConfigurationGenerator.target_chest`): the first
    of the search's last tries (:func:`~reach_addon.core.search.last_tries`, all within
    the goal tolerance) that has one, as ``(generator, point, chest)``, or None. The
    search's success is within the tolerance, so a target refused must have none."""
    for g, point in last_tries(generator, wrist):
        chest = g.target_chest(point)
        if chest is not None:
            return g, point, chest
    return None


def diagnose_target(generator, wrist, ball: bool = True) -> Diagnosis | None:
    """Why a wrist position can never be reached, or None if some legal pose there is
    clear, hand included, or (with ``ball``) one within the goal tolerance
    (:func:`fit_within_tolerance`). A :class:`Diagnosis`:

    * ``TARGET_IN_OBSTACLE``: the target is inside a closed obstacle (or every legal
      pose there passes through the character's own body);
    * ``ARM_DOES_NOT_FIT``: the target is in free space but no legal pose there keeps
      the arm (or, with the arm clear, the hand at any wrist angle) clear; ``missing``
      is the clearance the best pose lacks (figure units, margin included), ``part`` the
      segment and ``obstacle`` what it touches;
    * ``NEEDS_LEAN`` / ``NEEDS_STEP`` / ``OUT_OF_REACH``: no legal arm pose puts the
      wrist there (:meth:`_beyond_reach`).

    Every chest rotation of the range counts (:meth:`chest_candidates`), not Table 1's
    alone: a target a turned trunk reaches is reachable (:meth:`target_chest`); the
    reason given is read at the rotation nearest Table 1's that has legal poses, and
    beyond reach from the turn that brings the shoulder nearest the target."""
    wrist = np.asarray(wrist, dtype=float)
    arm, checker = generator.arm, generator.checker
    world = arm.to_world_points(wrist)
    if generator.obstacles.point_inside(world):
        return Diagnosis(TARGET_IN_OBSTACLE, obstacle=generator.obstacles.enclosing_owner(world))
    if generator.target_chest(wrist) is not None:
        return None
    if ball and fit_within_tolerance(generator, wrist) is not None:
        return None
    nearest = None           # the chest rotation whose shoulder is nearest the target
    for chest in generator.chest_candidates(wrist):
        sol = ik.solve(arm, wrist[None], generator.settings, body_rotation=chest)
        if sol.legal[0].any():
            break
        if nearest is None or np.linalg.norm(wrist - sol.shoulder[0]) < \
                np.linalg.norm(wrist - nearest.shoulder[0]):
            nearest = sol
    else:
        return _beyond_reach(generator, wrist, nearest)
    legal = np.flatnonzero(sol.legal[0])
    body = float(sol.body[0])
    joints = sol.joints(0, legal)
    clear_of_body = ~self_collision(arm, body, joints, include_hand=False)
    if not clear_of_body.any():
        return Diagnosis(TARGET_IN_OBSTACLE, obstacle="the character's own body")
    horizon = 0.5 * arm.arm_length
    best = (-math.inf, "arm", "an obstacle")
    hands = fine_hand_coefficients(generator)
    for n in np.flatnonzero(clear_of_body):
        j = joints[n]
        hit = checker.first_hit(arm.to_world_points(j), include_hand=False)
        if hit is not None:
            if checker.hand_shape:
                c = checker.clearance(arm.to_world_points(j), horizon, include_hand=False)
            else:
                arm_only = np.vstack([j[:4], j[3:4]])
                c = checker.clearance(arm.to_world_points(arm_only), horizon)
            if c > best[0]:
                best = (c, hit[0], hit[1])
            continue
        if not generator.checker.check_hand:
            return None
        bend = sol.bend_at(0, int(legal[n]))
        if generator.hands_clear(j, bend, body, hands).any():
            return None
        axes = generator.hand_axes(j, bend)
        for coefficients in hands:
            full = j.copy()
            full[4] = j[3] + arm.hand_length * (np.asarray(coefficients) @ axes)
            w = arm.to_world_points(with_shape(arm, full, bend))
            c = checker.clearance(w, horizon)
            if c > best[0]:
                hit = checker.first_hit(w)
                best = (c, "hand", hit[1] if hit else "the character's own body")
    clearance, part, obstacle = best
    missing = checker.margin - clearance if math.isfinite(clearance) else math.nan
    return Diagnosis(ARM_DOES_NOT_FIT, obstacle=obstacle, part=part, missing=missing)

def fine_hand_coefficients(generator) -> list:
    """Hand directions (their coefficients) for asking whether any wrist angle fits: the
    search's samples, then bends about every two ``hand_grid_step`` and sides every
    third of the side range, both ends included."""
    s = generator.settings
    nb = max(1, int(math.ceil(2 * s.wrist_bend_max / (2 * s.hand_grid_step))))
    bends = np.linspace(-s.wrist_bend_max, s.wrist_bend_max, nb + 1)
    sides = np.linspace(-s.wrist_side_max, s.wrist_side_max, 7)
    fine = [hand_coefficients(float(b), float(d)) for b in bends for d in sides]
    return [hand_coefficients(*h) for h in generator.hand_samples] + fine

def _beyond_reach(generator, wrist, sol) -> Diagnosis:
    """No legal arm pose puts the wrist at ``wrist``. Beyond the straight arm's reach
    from the shoulder: ``NEEDS_LEAN`` if leaning the trunk toward it (about the waist,
    at most ``Settings.lean_max``) brings it within reach; else ``OUT_OF_REACH`` (too
    high or too low: ``above`` says which, ``missing`` by how much) only where that is
    certain, else ``NEEDS_STEP`` with ``missing`` the target's distance beyond the
    arm's reach: the least the shoulder must move toward it. Within the straight arm's
    reach (too close, or behind the back): ``OUT_OF_REACH`` by the joint limits.

    Certain: the body's up axis is read from the bones and may lean off the true
    vertical by up to :data:`UP_TILT_DEG` (a spine bent in the rest pose), and a tilt
    ε moves a target at distance d up or down by up to d·sin ε, more than an arm
    length for a target a few metres away. So a target is too high or too low only
    if it stays more than the arm's reach above (below) the shoulder whichever up
    axis within that tilt is the true one; a far target is a step away, by its
    distance."""
    arm = generator.arm
    return beyond_reach(sol.shoulder[0], arm.waist, wrist, arm.arm_length,
                        generator.settings.lean_max)


def beyond_reach(shoulder, waist, wrist, reach: float, lean_max: float) -> Diagnosis:
    """:func:`_beyond_reach`'s sorting of a canonical ``wrist`` no legal arm pose reaches,
    from the ``shoulder``, the lean's pivot ``waist`` and the straight arm's ``reach``
    (``lean_max`` degrees of lean at most)."""
    shoulder, wrist = np.asarray(shoulder, dtype=float), np.asarray(wrist, dtype=float)
    distance = float(np.linalg.norm(wrist - shoulder))
    if distance <= reach:
        return Diagnosis(OUT_OF_REACH, distance=distance, missing=0.0)
    lean = least_lean(shoulder, waist, wrist, reach, lean_max)
    if lean is not None:
        return Diagnosis(NEEDS_LEAN, distance=distance, missing=distance - reach, lean_deg=lean)
    height = float(wrist[2] - shoulder[2])
    horizontal = float(np.hypot(wrist[0] - shoulder[0], wrist[1] - shoulder[1]))
    elevation = math.atan2(abs(height), horizontal)
    surely = distance * math.sin(max(0.0, elevation - math.radians(UP_TILT_DEG)))
    if surely >= reach:
        return Diagnosis(OUT_OF_REACH, distance=distance, missing=abs(height) - reach,
                         above=height > 0)
    return Diagnosis(NEEDS_STEP, distance=distance, missing=distance - reach)

