"""The step: where no lean or squat brings a target within reach, the feet move (stage 5 of
the whole-body reach, ``docs/design/core.md``).

**How far** (:func:`step_shift`). The whole stance moves along the ground, straight from
the shoulder toward the target, by the least that leaves the target within
``Settings.step_reach`` arm lengths of the shoulder (its height unchanged): the arm then
reaches it standing, or leans or squats for the rest, as it would for a target that near.
The move is taken in ``count`` equal steps (:func:`step_count`), each at most
``Settings.step_length`` leg lengths (hip to ankle) and at most ``Settings.steps_max`` of
them; more is refused.

**How** (:func:`step_motion`). The paper is silent; the choice is a side-stepping
shuffle, as people take a step or two toward something to the side: for each step,

1. the weight shifts onto the trailing foot (the hips move over its ankle);
2. the leading foot (the one farther along the move, :func:`lead_foot`) lifts, swings and
   is placed one step on;
3. the weight shifts onto the leading foot;
4. the trailing foot follows, one step on, so the stance ends as wide as it began;

and after the last, the weight comes back between the feet. Each phase is a minimum-jerk
move (:func:`~.torso.minimum_jerk`): a weight shift takes ``Settings.step_weight_time``
seconds, or longer where the hips would move faster on average than
``Settings.step_weight_speed`` leg lengths a second; a swing ``Settings.step_time`` (the
swing phase of gait is about 0.4 s, 40 % of a 1 s stride: Perry, *Gait Analysis*, 1992;
a deliberate side step is slower). A swinging
foot rises by ``Settings.step_lift`` leg lengths at mid-swing,
:math:`h(s) = 16\\,l\\,s^2 (1-s)^2` (zero speed at lift-off and touch-down,
:func:`swing_lift`), and moves on along the ground by a minimum-jerk move over the swing
less its first and last :data:`SWING_LIFT_OFF` (:func:`swing_along`): it rises before it
moves, and comes down where it lands. The hips move over
the stance foot's ankle by ``Settings.step_weight`` of the way from where they stand over
the feet's middle: the centre of mass follows them (the Blender layer measures it against
the stance foot alone on every frame of a swing, and refuses a step that would tip).

Pure numpy, in the caller's frame (world, in the Blender layer), lengths in its units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .torso import minimum_jerk


def horizontal(vector, up) -> np.ndarray:
    """``vector`` less its part along the unit ``up``."""
    v = np.asarray(vector, dtype=float)
    u = np.asarray(up, dtype=float)
    return v - float(v @ u) * u


def step_shift(shoulder, target, up, reach: float) -> np.ndarray | None:
    """The least horizontal move ``D`` of the body (and its shoulder) straight toward
    ``target`` that leaves it within ``reach`` of the shoulder:

    .. math:: |h| - \\sqrt{r^2 - v^2}

    along the unit horizontal direction ``h / |h|`` (``h``, ``v``: the target's horizontal
    and vertical offsets from the shoulder, ``r`` the reach). None where no move is needed
    (the target within reach already) or where a move along the ground cannot do it
    (``|v| ≥ r``: too high or too low, whatever the feet do)."""
    u = np.asarray(up, dtype=float) / np.linalg.norm(up)
    d = np.asarray(target, dtype=float) - np.asarray(shoulder, dtype=float)
    v = float(d @ u)
    h = horizontal(d, u)
    dist = float(np.linalg.norm(h))
    if abs(v) >= reach:
        return None
    left = math.sqrt(reach * reach - v * v)
    if dist <= left + 1e-12:
        return None
    return h * ((dist - left) / dist)


def step_count(shift, step_length: float, steps_max: int) -> int | None:
    """How many equal steps take the body by ``shift`` (each at most ``step_length``):
    :math:`\\lceil |D| / l \\rceil`, None where more than ``steps_max`` would."""
    n = max(1, int(math.ceil(float(np.linalg.norm(shift)) / float(step_length) - 1e-9)))
    return n if n <= int(steps_max) else None


def lead_foot(ankles, direction) -> int:
    """The index of the foot that steps first: the one farther along ``direction`` (the
    first where both are as far)."""
    a = np.asarray(ankles, dtype=float)
    along = a @ np.asarray(direction, dtype=float)
    return int(np.argmax(along))


@dataclass(frozen=True)
class Step:
    """A planned step: the body's horizontal ``shift`` (the caller's frame), taken in
    ``count`` equal steps, the foot ``lead`` (an index into the feet) first."""

    shift: np.ndarray
    count: int
    lead: int


@dataclass(frozen=True)
class StepMotion:
    """A step frame by frame: the hips' offset (F, 3) and each foot's (F, 2, 3) from where
    they stand on frame 0, and which feet bear the weight (F, 2) on each frame (a foot in
    the air does not; a foot on the ground does, whatever the hips do); ``swings``: each
    swing's frames (first, last), in turn, the foot that stays bearing the weight."""

    hips: np.ndarray
    feet: np.ndarray
    planted: np.ndarray
    swings: tuple = ()

    @property
    def frames(self) -> int:
        """Frames the step takes after its first (its last is where the reach starts)."""
        return len(self.hips) - 1


def swing_lift(s) -> np.ndarray:
    """The swinging foot's rise, as a share of the lift, at swing fraction ``s``:
    :math:`16 s^2 (1 - s)^2` (1 at mid-swing; zero speed at lift-off and touch-down)."""
    s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    return 16.0 * s ** 2 * (1.0 - s) ** 2


#: The share of a swing at each end in which the foot only rises (or comes down): it moves
#: along the ground in between, so it does not scuff along it on lift-off or touch-down.
SWING_LIFT_OFF = 0.15


def swing_along(s) -> np.ndarray:
    """The swinging foot's progress along its step at swing fraction ``s``: a minimum-jerk
    move over the swing less :data:`SWING_LIFT_OFF` at each end."""
    a = SWING_LIFT_OFF
    return minimum_jerk((np.asarray(s, dtype=float) - a) / (1.0 - 2.0 * a))


def phase_frames(seconds: float, fps: float) -> int:
    """Frames a phase of ``seconds`` takes at ``fps`` (at least 2)."""
    return max(2, int(math.ceil(float(seconds) * float(fps) - 1e-9)))


def step_motion(ankles, step: Step, up, settings, fps: float, leg_length: float,
                extra=None) -> StepMotion:
    """The step frame by frame (see the module docstring): ``ankles`` (2, 3) where the feet
    stand, ``step`` (:class:`Step`), ``up`` (unit), ``settings`` (``step_time``,
    ``step_weight_time``, ``step_lift``, ``step_weight``), ``fps``, and the leg's length
    (hip to ankle) the lift is a share of. ``extra`` (2 × count, 3), or one more row:
    added to where the hips go on each shift of the weight onto one foot, in turn, and
    back between the feet at the end (the Blender layer's correction where the centre
    of mass, measured, falls short of the foot's middle, or of the balance margin)."""
    u = np.asarray(up, dtype=float) / np.linalg.norm(up)
    ankles = np.asarray(ankles, dtype=float)
    move = horizontal(step.shift, u) / step.count
    lead, trail = step.lead, 1 - step.lead
    middle0 = horizontal(ankles.mean(axis=0), u)
    share = float(settings.step_weight)
    lift = float(settings.step_lift) * float(leg_length)
    hips = [np.zeros(3)]
    feet = [np.zeros((2, 3))]
    planted = [np.array([True, True])]
    s_n = phase_frames(settings.step_time, fps)

    def weight_to(goal):
        start = hips[-1]
        far = float(np.linalg.norm(goal - start)) / float(leg_length)
        n = phase_frames(max(float(settings.step_weight_time),
                             far / float(settings.step_weight_speed)), fps)
        for s in minimum_jerk(np.arange(1, n + 1) / n):
            hips.append(start + s * (goal - start))
            feet.append(feet[-1].copy())
            planted.append(np.array([True, True]))

    def over(foot):
        at = horizontal(ankles[foot], u) + feet[-1][foot]
        return share * (horizontal(at, u) - middle0) + (1.0 - share) * (
            horizontal(ankles.mean(axis=0), u) + feet[-1].mean(axis=0) - middle0)

    swings = []

    def swing(foot):
        swings.append((len(feet), len(feet) + s_n - 1))
        start = feet[-1].copy()
        t = np.arange(1, s_n + 1) / s_n
        for tau, s in zip(t, swing_along(t)):
            now = start.copy()
            now[foot] = start[foot] + s * move + lift * float(swing_lift(tau)) * u
            feet.append(now)
            hips.append(hips[-1].copy())
            on = np.array([True, True])
            on[foot] = tau >= 1.0
            planted.append(on)

    extra = np.zeros((2 * step.count, 3)) if extra is None else np.asarray(extra, dtype=float)
    for k in range(step.count):
        weight_to(over(trail) + horizontal(extra[2 * k], u))
        swing(lead)
        weight_to(over(lead) + horizontal(extra[2 * k + 1], u))
        swing(trail)
    weight_to(feet[-1].mean(axis=0) + (horizontal(extra[2 * step.count], u)
                                       if len(extra) > 2 * step.count else 0.0))
    return StepMotion(np.array(hips), np.array(feet), np.array(planted), tuple(swings))


def plan_step(shoulder, target, ankles, up, arm_length: float, leg_length: float,
              settings, reach: float | None = None) -> tuple:
    """(:class:`Step`, None), or (None, why not: a sentence): the step that brings
    ``target`` within ``reach`` (default ``Settings.step_reach``) arm lengths of the
    ``shoulder`` (:func:`step_shift`),
    in equal steps of at most ``Settings.step_length`` leg lengths (:func:`step_count`), led
    by the foot on the target's side (:func:`lead_foot`)."""
    reach = float(settings.step_reach if reach is None else reach) * float(arm_length)
    shift = step_shift(shoulder, target, up, reach)
    if shift is None:
        return None, ("no step along the ground brings it within reach: it lies too far "
                      "above or below the shoulder")
    count = step_count(shift, float(settings.step_length) * float(leg_length),
                       int(settings.steps_max))
    if count is None:
        far = float(np.linalg.norm(shift)) / float(arm_length)
        return None, (f"it would take the body {far:.2f} arm lengths toward it, more than "
                      f"{int(settings.steps_max)} steps of {settings.step_length:g} leg "
                      "lengths (Steps limit, Step length)")
    return Step(np.asarray(shift, dtype=float), count, lead_foot(ankles, shift)), None
