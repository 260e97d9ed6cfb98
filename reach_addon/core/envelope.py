"""The reach envelope: which points around the character the arm can reach, and how.

The points of a grid in the reaching shoulder's (forward, outward, up) frame
(:func:`grid_coordinates`: ``Settings.envelope_resolution`` points a side,
``Settings.envelope_extent`` arm lengths from the centre to each face) are sorted into
:data:`CLASSES`: ``f_R 0`` / ``f_R 1`` / ``f_R 2``, the strength category of the strongest
legal pose clear there, hand included (:func:`exhaustive`); ``chest``, reachable only
because the chest turns; ``blocked``, within reach but with no room for the arm or hand
(:func:`~reach_addon.core.diagnosis.diagnose_target`); ``lean`` (with ``Settings.lean``
on, below); ``out``, no legal arm pose puts the wrist there at any chest rotation of the
range. It classifies the *end* pose: a point in a
closed box with room inside is reachable here and ``no_path`` for Plan. And it classifies
the point itself at the search's swivel step (``Settings.swivel_step``), while a search
asks its last tries before it refuses (:func:`~reach_addon.core.search.last_tries`: the
tolerance ball's rim, a 1° swivel): a plan may reach a point classed ``blocked`` whose
only clear swivel window is narrower than the step (or, with it, find a stronger pose than
the envelope's), and one classed ``blocked`` or ``out`` within the tolerance of a clear
pose (5 of the 125 points of the Blender test's plate grid). Asking those tries at every
point cost the envelope's tests about fifteen times their time.

With ``Settings.lean`` on, a point no arm pose reaches is ``lean`` where a lean of the
trunk brings it within reach (:func:`leanable`, at most ``Settings.lean_max``, the chest
turned as the planner may turn it). Given the body as it stands (a
:class:`~.stance.Stance`, which the Blender layer reads from the rig's legs and
segments), the lean is the one a reach takes: about the lean bone's head, the centre of
mass (the stance's rigid estimate) over the feet, the hips moved back where they must
be; without one, as the ``needs_lean`` refusal reads it, about the arm model's waist,
the balance not weighed. Given the stance, the rest are, in the order a reach recruits
them:

- ``squat`` where a squat or bend does (:func:`squattable`: the posture
  :func:`~.squat.squat_leans` would choose, its joints within their limits and the centre
  of mass, the stance's rigid estimate, kept the balance margin inside the feet);
- ``step`` where ``Settings.stepping`` is on and steps along the ground do
  (:func:`steppable`: :func:`~.step.plan_step` finds at most ``Settings.steps_max`` of
  them, the point then within ``Settings.step_reach`` of the shoulder).

Like ``lean``, they say a posture exists; a Bake weighs the balance on the rig as it
poses it and checks the whole skin, and may still refuse one (an obstacle in the way of
the trunk, a foot's path blocked).
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from dataclasses import dataclass

import numpy as np

from . import ik
from .diagnosis import beyond_reach
from .errors import OUT_OF_REACH
from .generator import CHEST_FIT_STEP
from .lean import chest_turns, choose_lean
from .balance import balance_margin
from .hips import shifted_lean
from .squat import squat_leans
from .step import plan_step
from .whole_body import SHIFT_SHARES, below_the_arm

#: The classes, in the order of their codes (0 … 8).
CLASSES = ("f_R 0", "f_R 1", "f_R 2", "chest", "blocked", "lean", "squat", "step", "out")
CHEST, BLOCKED, LEAN, SQUAT, STEP, OUT = 3, 4, 5, 6, 7, 8
#: Display colours (linear RGBA) per class: green, yellow, red for the three strength
#: categories, blue for chest rotation, grey for blocked, purple for a lean, pink for a
#: squat, cyan for a step; out-of-reach points are not drawn.
COLOURS = ((0.10, 0.75, 0.15, 1.0), (0.95, 0.80, 0.05, 1.0), (0.90, 0.12, 0.08, 1.0),
           (0.15, 0.45, 0.95, 1.0), (0.45, 0.45, 0.45, 1.0), (0.60, 0.25, 0.85, 1.0),
           (0.90, 0.35, 0.60, 1.0), (0.10, 0.75, 0.80, 1.0), (0.0, 0.0, 0.0, 0.0))
LABELS = ("Strong (f_R 0)", "Fair (f_R 1)", "Weak (f_R 2)", "Chest turn only", "Blocked",
          "By a lean", "By a squat", "By a step", "Out of reach")


def grid_coordinates(resolution: int, extent: float) -> np.ndarray:
    """(n³, 3) points in the shoulder's frame, arm lengths: (forward, outward, up), each
    axis ``linspace(-extent, extent, n)``, ordered like :func:`itertools.product` (forward
    slowest, up fastest).

    .. math:: p_{ijk} = -e + \\frac{2e}{n-1}(i, j, k),\\quad 0 \\le i, j, k < n
    """
    n = int(resolution)
    axis = [-extent + 2.0 * extent * (k / (n - 1) if n > 1 else 0.5) for k in range(n)]
    return np.array(list(itertools.product(axis, axis, axis)), dtype=float)


def shoulder_frame_to_canonical(arm, coordinates) -> np.ndarray:
    """Canonical points of shoulder-frame ``coordinates`` (..., 3) (forward, outward, up,
    arm lengths): the canonical frame's axes are (outward, forward, up), so

    .. math:: c = s + L\\,(o, f, u)

    with ``s`` the shoulder at rest and ``L`` the arm's length."""
    c = np.asarray(coordinates, dtype=float)
    return np.asarray(arm.shoulder, float) + arm.arm_length * c[..., [1, 0, 2]]


def canonical_to_shoulder_frame(arm, points) -> np.ndarray:
    """The inverse of :func:`shoulder_frame_to_canonical`:
    :math:`(f, o, u) = ((c - s)_y, (c - s)_x, (c - s)_z) / L`."""
    d = (np.asarray(points, dtype=float) - np.asarray(arm.shoulder, float)) / arm.arm_length
    return d[..., [1, 0, 2]]


def exhaustive(settings):
    """``settings`` with every ranked pose tried at a position (``max_pose_tries`` at its
    maximum). A point is reachable if *any* legal pose there is clear; the search tries
    only the strongest few per position, for speed (and within the smoothness bound of the
    pose before, a different few), so with the search's budget a point the search reaches
    could be classed blocked."""
    top = next(f.metadata["max"] for f in dataclasses.fields(settings)
               if f.name == "max_pose_tries")
    return settings.replace(max_pose_tries=top)


@dataclass
class Envelope:
    """The classes (n,) of canonical ``points`` (n, 3), the strength category f_R of the
    chosen pose where there is one (-1 elsewhere) and the time the classification took."""

    points: np.ndarray
    classes: np.ndarray
    f_r: np.ndarray
    time_s: float = 0.0

    def counts(self) -> dict:
        """Points per class name (every class listed, zeros included)."""
        return {name: int(np.count_nonzero(self.classes == k)) for k, name in enumerate(CLASSES)}


def classify_point(generator, point, legal: bool | None = None, stance=None) -> tuple:
    """(class, f_R or -1) of one canonical wrist point, with the planner's generator (made
    with :func:`exhaustive` settings; see the module docstring), at the chest rotation a
    reach would arrive there with (``ConfigurationGenerator.target_chest``: Table 1's
    where it fits, else the nearest that does). ``legal``: whether some legal arm pose
    (joint limits, any chest rotation of the range) puts the wrist there, if the caller
    knows; ``stance``: the body as it stands (:class:`~.stance.Stance`), for the squat and
    step classes.

    Without a clear pose the point is ``blocked`` or ``out`` as
    :func:`~reach_addon.core.diagnosis.diagnose_target` sorts it
    (inside an obstacle: target_in_obstacle; no legal pose: beyond reach; else the arm or
    the hand does not fit), without working out how much room is missing."""
    point = np.asarray(point, dtype=float)
    chest = generator.target_chest(point)
    if chest is not None:
        pose = generator.solve(point, body_rotation=chest)
        if generator.settings.chest_rotation and abs(chest) > 1e-9 and \
                generator.solve(point, body_rotation=0.0) is None:
            return CHEST, int(pose.f_r)
        return int(pose.f_r), int(pose.f_r)
    if legal is None:
        legal = bool(legal_anywhere(generator, point[None])[0])
    if legal or generator.obstacles.point_inside(generator.arm.to_world_points(point)):
        return BLOCKED, -1
    return body_class(generator.arm, point, generator.settings, stance), -1


def body_class(arm, point, settings, stance=None) -> int:
    """The class of a canonical ``point`` no arm pose reaches, by what of the body would,
    as a single reach recruits it (see the module docstring): :data:`LEAN` where a lean
    does (:func:`leanable`); where the point lies surely below the arm
    (:func:`~.diagnosis.beyond_reach` says ``out_of_reach`` and it lies below the shoulder
    past the arm's length, :func:`~.whole_body.below_the_arm`, as for a refused reach, and
    ``Settings.squat`` is on), :data:`SQUAT` where a squat does (:func:`squattable`);
    else :data:`STEP` where steps do (:func:`steppable`); else :data:`OUT`. Without Lean,
    or without a ``stance``, only the first; with a stance whose trunk is not free
    (:attr:`~.stance.Stance.trunk_free`), only a step; a point below the ground the feet stand on
    is :data:`OUT`; and every one is :data:`OUT` without ``Settings.envelope_body`` (off
    by default: the body's classes take minutes on the default grid, the arm's seconds)."""
    if not settings.envelope_body:
        return OUT
    if stance is not None and not stance.trunk_free:
        settings = settings.replace(squat=False)        # steps only (``Stance.trunk_free``)
    elif leanable(arm, point, settings, stance):
        return LEAN
    if stance is None or not settings.lean:
        return OUT
    world = arm.to_world_points(np.asarray(point, dtype=float)[None])[0]
    if float(world @ np.asarray(stance.up, dtype=float)) < stance.ground:
        return OUT
    low = beyond_reach(arm.shoulder, arm.waist, point, arm.arm_length, settings.lean_max)
    if settings.squat and low.reason == OUT_OF_REACH and below_the_arm(arm, point) and \
            squattable(arm, point, settings, stance):
        return SQUAT
    return STEP if steppable(arm, point, settings, stance) else OUT


#: The envelope's squat grid (arm lengths between the hips' drops and shifts tried) at
#: its finest, and how many chest turns it tries: coarser than a reach's choice
#: (``Settings.squat_step``, 0.05, and every :data:`~.lean.CHEST_TURN_STEP` degrees), as
#: a reach's takes 0.3 s a point and up to 25 times that where none is found (the
#: standard figure), too slow for hundreds of points. A coarser grid only has fewer
#: postures, so the class is conservative: a point classed ``squat`` has one; one left
#: ``step`` or ``out`` may still be squatted by a reach.
ENVELOPE_SQUAT_STEP = 0.1
ENVELOPE_TURNS = 3


def envelope_turns(settings, count: int = ENVELOPE_TURNS) -> list:
    """``count`` chest turns from :func:`~.lean.chest_turns` spread over its range (its
    middle, 0°, first; with three, 0° and both ends)."""
    turns = chest_turns(settings)
    picks = np.unique(np.round(np.linspace(0, len(turns) - 1, max(1, int(count)))).astype(int))
    return sorted((turns[i] for i in picks), key=abs)


def squattable(arm, point, settings, stance, step: float = ENVELOPE_SQUAT_STEP,
               turns: int = ENVELOPE_TURNS) -> bool:
    """Whether a squat or bend brings the canonical ``point`` within ``Settings.lean_reach``
    of the shoulder: :func:`~.squat.squat_leans` finds a posture for it on the ``stance``
    (its joints within their limits, the centre of mass the margin inside the feet) on a
    grid ``step`` arm lengths apart at its finest, the chest turned by one of ``turns``
    turns of its range (:data:`ENVELOPE_SQUAT_STEP`, :func:`envelope_turns`). Points no
    hips' drop could bring near are passed over first: the pivot moves at most the legs'
    length back and down, so a point farther from every such pivot than the shoulder's
    distance from it and the reach is out (:func:`squat_bound`)."""
    point = np.asarray(point, dtype=float)
    pivot = arm.to_canonical_points(np.asarray(stance.pivot, dtype=float)[None])[0]
    if not squat_bound(arm, point, pivot, settings, stance):
        return False
    target = stance.toward(arm.to_world_points(point[None])[0])
    coarse = settings.replace(squat_step=max(float(settings.squat_step), float(step)))
    return bool(squat_leans(arm, point, pivot, coarse, envelope_turns(settings, turns), target))


def squat_bound(arm, point, pivot, settings, stance) -> bool:
    """The necessary condition :func:`squattable` checks first: with ``x`` the point's
    horizontal distance from the pivot and ``z`` its height over it (canonical, z up),
    ``d`` the deepest drop the squat's grid tries (the longer leg's thigh and shank, as
    :func:`~.squat.squat_leans` has it) and ``r`` the farthest any chest turn takes the
    shoulder from the pivot plus ``Settings.lean_reach`` arm lengths, the distance from
    the point to the rectangle of pivots the hips' drop η and shift δ reach (both in
    [0, d], back and down),

    .. math:: \\sqrt{\\max(0, x)^2 + \\max(0, -d - z,\\, z)^2} \\le r."""
    scale = abs(float(np.linalg.det(np.asarray(arm.to_world, float)[:3, :3]))) ** (1.0 / 3.0)
    d = max(leg.thigh + leg.shank for leg in stance.leg_joints) / scale
    v = np.asarray(point, dtype=float) - np.asarray(pivot, dtype=float)
    x, z = float(np.hypot(v[0], v[1])), float(v[2])
    dz = max(0.0, -d - z, z)
    s_, p_ = np.asarray(arm.shoulder, dtype=float), np.asarray(pivot, dtype=float)
    # the shoulder as far from the pivot as any chest turn (about the canonical z axis)
    # takes it: its horizontal distance from the axis and the pivot's, added
    apart = float(np.hypot(np.hypot(s_[0], s_[1]) + np.hypot(p_[0], p_[1]), s_[2] - p_[2]))
    r = apart + settings.lean_reach * arm.arm_length
    return bool(np.hypot(x, dz) <= r)


def steppable(arm, point, settings, stance) -> bool:
    """Whether ``Settings.stepping`` is on and steps along the ground bring the canonical
    ``point`` within ``Settings.step_reach`` arm lengths of the shoulder
    (:func:`~.step.plan_step`: at most ``Settings.steps_max`` steps of
    ``Settings.step_length`` leg lengths; the point neither too high nor too low for
    that)."""
    if not settings.stepping:
        return False
    world = arm.to_world_points(np.asarray(point, dtype=float)[None])[0]
    scale = abs(float(np.linalg.det(np.asarray(arm.to_world, float)[:3, :3]))) ** (1.0 / 3.0)
    step, _why = plan_step(stance.shoulder, world, stance.ankles, stance.up,
                           arm.arm_length * scale, stance.leg_length, settings)
    return step is not None


def leanable(arm, point, settings, stance=None) -> bool:
    """Whether ``Settings.lean`` is on and a lean of the trunk, at most
    ``Settings.lean_max``, brings the canonical ``point`` within ``Settings.lean_reach`` of
    the shoulder, the chest turned as the planner may turn it (:func:`~.lean.choose_lean`).
    Without a ``stance``, about the arm model's waist, as the ``needs_lean`` refusal reads
    it. With one (:class:`~.stance.Stance`), about its pivot (the lean bone's head), as a
    reach leans: the lean's centre of mass (:meth:`~.stance.Stance.com`, the arm straight
    toward the point) at least the stance's ``floor`` inside the feet, or, with
    ``Settings.lean_hips_back``, a lean with the hips moved back that keeps the margin
    (:func:`~.hips.shifted_lean`, the whole margin, then a share of it:
    :data:`~.whole_body.SHIFT_SHARES`, as a reach tries them)."""
    if not settings.lean:
        return False
    point = np.asarray(point, dtype=float)
    turns = chest_turns(settings)
    if stance is None:
        lean = choose_lean(arm, point, arm.waist, settings, turns)
        return lean is not None and lean.angle > 0.0
    pivot = arm.to_canonical_points(np.asarray(stance.pivot, dtype=float)[None])[0]
    body = stance.toward(arm.to_world_points(point[None])[0])
    lean = choose_lean(arm, point, pivot, settings, turns)
    if lean is None or lean.angle <= 0.0:
        return False
    if balance_margin(body.com(lean), body.polygon, body.up) >= body.floor:
        return True
    return settings.lean_hips_back and any(
        shifted_lean(arm, point, pivot, settings, turns, body, share) is not None
        for share in SHIFT_SHARES)


def legal_anywhere(generator, points) -> np.ndarray:
    """(n,) bool: does a legal arm pose put the wrist at each canonical point (n, 3) at
    some chest rotation the planner may arrive with (Table 1's, then the range every
    ``CHEST_FIT_STEP`` degrees and its ends; Table 1's alone with body rotation off)? One
    vectorised IK call per chest rotation, for the points still without one."""
    st, arm = generator.settings, generator.arm
    points = np.asarray(points, dtype=float)
    legal = ik.solve(arm, points, st).legal.any(axis=1) if len(points) else np.zeros(0, bool)
    if st.chest_rotation and len(points):
        limit = float(st.chest_rotation_max)
        for b in sorted({round(float(b), 9) for b in
                         np.arange(-limit, limit + 1e-9, CHEST_FIT_STEP)} | {-limit, limit}):
            todo = np.flatnonzero(~legal)
            if not todo.size:
                break
            legal[todo] = ik.solve(arm, points[todo], st, body_rotation=b).legal.any(axis=1)
    return legal


def envelope_steps(generator, points, chunk: int = 64, stance=None):
    """Classify canonical ``points`` (n, 3) as a generator: yields the fraction done every
    ``chunk`` points and returns the :class:`Envelope` (the same however it is consumed).
    ``stance``: the body as it stands, for the squat and step classes
    (:func:`body_class`)."""
    points = np.asarray(points, dtype=float)
    n = len(points)
    classes = np.full(n, OUT, dtype=np.int8)
    f_r = np.full(n, -1, dtype=np.int8)
    t0 = time.perf_counter()
    arm = generator.arm
    # Most of a cube round the shoulder is beyond the arm: a few IK calls for every point
    # find those with no legal pose at any chest rotation, which are "out" (or "blocked"
    # when inside an obstacle), as classify_point would find one by one.
    legal = legal_anywhere(generator, points)
    inside = [generator.obstacles.point_inside(w) for w in arm.to_world_points(points[~legal])]
    classes[np.flatnonzero(~legal)[np.array(inside, bool)]] = BLOCKED
    for i in np.flatnonzero(classes == OUT):
        classes[i] = body_class(arm, points[i], generator.settings, stance)
    todo = np.flatnonzero(legal)
    spent = time.perf_counter() - t0
    for k, i in enumerate(todo):
        t0 = time.perf_counter()
        classes[i], f_r[i] = classify_point(generator, points[i], True, stance)
        spent += time.perf_counter() - t0
        if chunk and (k + 1) % chunk == 0 and k + 1 < len(todo):
            yield (k + 1) / len(todo)
    return Envelope(points, classes, f_r, spent)
