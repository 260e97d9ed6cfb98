"""The whole-body reach: what the body does where the arm alone cannot reach the target.

Stage 1 of the plan in ``docs/design/core.md`` (*balance.py*): **a lean, then the reach.**
Where a reach fails as ``needs_lean`` and ``Settings.lean`` is on (or reaches its one
target, or one of its sequence's, only by turning the chest past Table 1's, where a
lean costs the trunk less: :func:`~.effort.twist_for_reach`), the trunk leans at the
hips toward the target, feet planted: the chest turns as the paper's Table 1 has it,
and the lean brings the target within ``Settings.lean_reach`` arm lengths of the
shoulder (:func:`~.lean.choose_lean`),
or, where a little twist saves more lean than it costs, the chest turns a little farther
(:func:`_leans_to_try`, least trunk effort first); failing those, smaller leans with the
chest turned farther, and last the least lean with the chest turned as far as the planner
may (a smaller lean, a larger twist). The arm
holds its start pose on the leaning trunk (a minimum-jerk phase of its own,
:func:`~.lean.lean_frames`); then the paper's planner plans the reach unchanged, for the
same arm in the leaned trunk's frame (:func:`~.lean.leaned_arm`). Every instant of the
lean is checked, the arm (hand included) and the trunk (:func:`~.lean.lean_hit`), and the
trunk again on every pose of the reach, as the chest turns (:func:`body_hit`): the trunk
as skinned where the rig gives it (:class:`~.lean.TrunkSkin`), else the chest's and head's
capsules.

Where the Blender layer's balance refuses a lean (the centre of mass past the feet, with
the arm at its start or on any pose of the reach) the hips move back
(:func:`~.hips.shifted_lean`, stage 3), the lean growing as the shoulder comes back with
them.

Where no standing lean reaches (a target low in front, refused as ``out_of_reach``, or
every lean refused) and ``Settings.squat`` is on, the hips come down as well
(:func:`squat_then_reach`, stage 4, :mod:`.squat`): the same phase, checks and bake.

Where the arm, held at its start, would touch as the trunk leans or find no way after it,
the arm goes first (``Settings.lean_ready``, :func:`_ready_lean_reach`): a reach on the
upright trunk toward where the target will be, the lean with the arm there, then the reach.

Where none of these reaches, the Blender layer steps toward the target first
(``Settings.stepping``, ``blender/step.py``, :mod:`.step`) and plans the reach, and any
lean, again from where the step ends.

What these stages leave to later ones, and refuse meanwhile: the ready reach, the lean and
the reach run one after the other (not blended); the other arm rides on the trunk in the
plan and its checks (the Blender layer turns it to keep its direction afterwards, and
checks it again: ``blender/other_arm.py``); a sequence reaches its first targets upright
and then leans once, as far as its farthest refused target asks, and holds the lean
through the rest (:func:`body_target`, :func:`upright_part`); only
a single reach or a guided reach to one target steps (:data:`STEP_TASKS`); a chase still
refuses as ``needs_lean``; and the body moves only among obstacles that hold still.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .arm import ArmModel, hand_frame
from .errors import NEEDS_LEAN, NEEDS_STEP, OUT_OF_REACH
from .hand_shape import with_shape
from .hips import shifted_lean
from .lean import (Lean, TrunkSkin, capsules_hit, chest_turns, choose_lean, lean_frames, lean_hit,
                   leaned_arm, skin_hit)
from .orient import hand_locals
from .results import Plan
from .squat import squat_leans
from .effort import trunk_effort
from .torso import body_rotation_deg, rotate_about_spine


#: The cause of a refusal (:class:`Why`) where the centre of mass falls past the feet.
BALANCE = "balance"
#: The cause of a refusal where a part of the body touches an obstacle.
TOUCH = "touch"
#: The cause of a refusal where the rig's legs would not keep the feet planted.
SLIDE = "slide"


class Why(str):
    """A refusal's sentence with its ``cause`` (:data:`BALANCE`, :data:`TOUCH`, or "" where
    not said), as the Blender layer's ``acceptable`` gives it: a string everywhere one is
    read, and the recruitment tells the causes apart (a lean with the hips back that tips
    the body is not tried again with a smaller shift, which tips it farther)."""

    cause: str

    def __new__(cls, text: str, cause: str = ""):
        out = super().__new__(cls, text)
        out.cause = cause
        return out


#: The shares of ``Settings.balance_margin`` a lean with the hips back keeps, tried in
#: turn (:func:`~.hips.shifted_lean`): the whole margin first; where that lean is refused
#: (its trunk touching, its arm finding no way), a quarter of it: a smaller shift, so a
#: smaller lean, still over the feet. On the Quaternius alien over the stage-1 table the
#: whole margin asked a 3.8° lean whose belly, turning with the chest, touched the table;
#: a quarter asks 2.6°, which clears it. A lean refused for its balance is not tried
#: with a quarter (:class:`Why`).
SHIFT_SHARES = (1.0, 0.25)


@dataclass(frozen=True)
class LeanPhase:
    """A planned lean: the ``lean``, its ``fractions`` (one a frame, 0 on the first, 1 on
    the last: :func:`~.lean.lean_frames`) and the ``arm`` on the leaned trunk that the
    reach after it was planned for; ``ready``, where the arm first reached toward the
    target on the upright trunk (:func:`_ready_lean_reach`), that reach's plan (for the
    upright arm; its last pose is the lean's and the reach's first)."""

    lean: Lean
    fractions: np.ndarray
    arm: ArmModel
    ready: Plan | None = None
    #: how many of the task's targets ``ready`` reaches (a sequence's first targets, reached
    #: upright before the lean: :func:`upright_part`); 0 where it goes to a ready point
    ready_reaches: int = 0

    @property
    def frames(self) -> int:
        """Frames the lean takes before the reach's first (its last is the reach's start)."""
        return len(self.fractions) - 1

    @property
    def ready_frames(self) -> int:
        """Frames the ready reach takes before the lean's first (its last is the lean's)."""
        return 0 if self.ready is None else len(self.ready.poses) - 1


def lean_then_reach(planner, task, failed, pivot_c, make_planner, acceptable=None,
                    trunk: TrunkSkin | None = None, body=None, split: bool = True,
                    aim: int | None = None, ceiling: float | None = None):
    """Plan ``task`` (a reach, a sequence or a guided reach) with a lean toward the target
    :func:`body_target` picks, where ``failed`` (``planner``'s plan of it) was refused as
    ``needs_lean`` there: returns (:class:`LeanPhase`, the reach's plan on the
    leaned trunk), or (None, why not: a sentence) where no lean is planned; (None, None)
    where none was asked for. ``pivot_c``: the hips' pivot (canonical frame of
    ``planner.arm``); ``make_planner(arm, settings=None)``: a :class:`~.planner.Planner`
    for an arm among the same obstacles and settings (or ``settings``);
    ``acceptable(lean, arm_world=None, turned=None)``:
    why a lean may not be taken (the Blender layer's balance, the arm at its start, or
    with its joints on each pose of the reach at ``arm_world`` and the chest turned by
    ``turned``: weighed again as the arm reaches, :func:`_balanced_reach`), or None;
    ``trunk``: the trunk as skinned (:class:`~.lean.TrunkSkin`, canonical frame of
    ``planner.arm``), which the lean's obstacle tests use instead of the chest's and head's
    capsules where given; ``body``:
    the rig's balance (:func:`~.hips.shifted_lean`), with which a lean that
    ``acceptable`` refuses, before or after its reach, is tried again with the hips moved
    back (``Settings.lean_hips_back``); ``split``: where the first refused target of a
    sequence (or guided reach) comes after others, reach those upright first and lean
    after them (:func:`upright_part`; the phase's ``ready`` is their plan, followed by the
    arm's ready reach where it rose first, ``ready_reaches`` their count), else (or where
    that finds no lean) lean before the first. The Blender layer turns it off where the
    lean bone is the chest it keys: the upright reaches turn the chest, which the lean's
    keys would overwrite. ``aim``: the index of the target to lean toward instead of
    :func:`body_target`'s, where ``failed`` reached every target (turning the chest past
    Table 1's, which costs more than a lean: :func:`~.effort.twist_for_reach`), and
    ``ceiling`` the upright reach's trunk effort per arrival from there on
    (:func:`~.effort.reach_effort` over the targets the lean is held through), which a
    lean's (:func:`~.effort.trunk_effort`, one arrival) must stay below
    (no squat is tried there: the upright reach reached).

    Recruitment, as the issue orders it, costed (:mod:`.effort`): the leans are tried
    least trunk effort first (:func:`_leans_to_try`): where a twist would cost more than the
    lean it saves, the chest turns as the paper's Table 1 has it at the target and the lean
    takes the rest (:func:`~.lean.choose_lean`); where that lean is not acceptable or finds
    no way, smaller leans with the chest turned farther, and last the least lean with the
    chest turned as far as the planner may turn it (:func:`~.lean.chest_turns`)."""
    s, arm = planner.settings, planner.arm
    aim = body_target(s, task, failed, arm) if aim is None else aim
    if aim is None:
        return None, None
    target_c = arm.to_canonical_points(np.asarray(task.targets[aim], dtype=float))
    first = next((i for i, seg in enumerate(failed.segments) if not seg.success), aim)
    base = float(task.start.body_rotation)
    later = ""
    if split and first > 0:
        upright, rest = upright_part(planner, task, failed, first)
        phase, why = _lean_toward(planner, rest, target_c, pivot_c, make_planner, acceptable,
                                  trunk, body, base, ceiling)
        if phase is not None:
            # where the arm rose toward the far target before the lean (a ready reach from
            # where the upright part ends, the chest held), both are upright reaches in turn
            ready = upright if phase.ready is None else dataclasses.replace(
                upright, poses=upright.poses + list(phase.ready.poses[1:]))
            return dataclasses.replace(phase, ready=ready, ready_reaches=first), why
        names = ", ".join(f"'{n}'" for n in task.names[:first]) or f"{first} target(s)"
        later = f"with {names} reached upright first: {why or 'no lean'}; leaning before them: "
    phase, why = _lean_toward(planner, task, target_c, pivot_c, make_planner, acceptable,
                              trunk, body, base, ceiling)
    return (phase, why) if phase is not None else (None, later + why)


def upright_part(planner, task, failed, first: int):
    """A sequence's (or guided reach's) first ``first`` targets, which ``failed`` (its plan
    on the upright trunk) reached: (their plan, cut from ``failed``; the task of the rest,
    starting where that plan ends, its hand's palm and fingers carried on from the task's
    start, :func:`~.orient.hand_locals`). The body leans after them, for the rest
    (:func:`lean_then_reach`): a person reaches what is near before leaning for what is
    far, and a target near the body may be out of reach from the leaned trunk."""
    end = failed.segments[first - 1].frame_end
    cut = {"targets": task.targets[:first], "names": tuple(task.names[:first]),
           "orientations": None if task.orientations is None else task.orientations[:first]}
    upright = dataclasses.replace(failed, task=dataclasses.replace(task, **cut),
                                  poses=list(failed.poses[:end + 1]),
                                  segments=list(failed.segments[:first]))
    pose = failed.poses[end]
    start = planner.generator.config_pose(task.start, task.start_hand)
    finger, palm = hand_locals(start, task.start_palm, task.start_fingers)
    frame = hand_frame(pose)
    rest = dataclasses.replace(
        task, targets=task.targets[first:], names=tuple(task.names[first:]),
        orientations=None if task.orientations is None else task.orientations[first:],
        start=pose.config, start_hand=tuple(pose.hand),
        start_palm=None if task.start_palm is None else frame @ palm,
        start_fingers=None if task.start_fingers is None else frame @ finger)
    return upright, rest


def _lean_toward(planner, task, target_c, pivot_c, make_planner, acceptable, trunk, body,
                 base: float, ceiling: float | None = None):
    """:func:`lean_then_reach` toward the canonical ``target_c``, for ``task`` from its
    start (``base``: the chest's turn the rig stands with, from which the body's checks
    turn the trunk): (:class:`LeanPhase`, the reach's plan) or (None, why not).
    ``ceiling``: the :func:`~.effort.trunk_effort` a lean must stay below (an upright
    reach's twist it would replace, per arrival the lean is held through): no lean at or
    above it is tried, nor a squat."""
    s, arm = planner.settings, planner.arm
    table1 = body_rotation_deg(target_c, arm.arm_length, arm.hand_length, s)
    turns = [(table1,), chest_turns(s)]
    leans, turns_tried = _leans_to_try(arm, target_c, pivot_c, s, table1, ceiling)
    whys = []
    if not leans:
        whys.append(f"no lean up to {s.lean_max:.0f}° at the hips brings it within reach"
                    if ceiling is None else "no lean costs the trunk less than the twist")
    shifting = body is not None and s.lean_hips_back
    tipped, tries = math.inf, 0     # the least lean refused for its balance; leans tried
    planned: dict = {}              # why each lean tried as it stands was refused
    for k, (lean, turn) in enumerate(zip(leans, turns_tried)):
        if k < len(leans) - 1 and (lean.angle >= tipped - 1e-9 or tries == LEAN_TRIES):
            continue       # a lean as deep tips the body as far; the last is always tried
        tries += 1
        key = round(lean.angle, 9)
        if key in planned:            # the last: tried already; only its shift is new
            why = planned[key]
        else:
            why = acceptable(lean) if acceptable is not None else None
            if getattr(why, "cause", "") == BALANCE:
                tipped = min(tipped, lean.angle)
            if why is None:
                phase, why = _balanced_reach(planner, task, lean, make_planner, trunk,
                                             acceptable, base)
                if phase is not None:
                    return phase, why
            planned[key] = why
        for share in (SHIFT_SHARES if shifting and why is not None else ()):
            shifted = shifted_lean(arm, target_c, pivot_c, s, turn, body, share)
            if shifted is None or (ceiling is not None and trunk_effort(
                    0.0, shifted.angle, s) >= ceiling):
                break
            why = acceptable(shifted)
            if why is None:
                phase, why = _balanced_reach(planner, task, shifted, make_planner, trunk,
                                             acceptable, base)
                if phase is not None:
                    return phase, why
            if getattr(why, "cause", "") == BALANCE:
                break              # a smaller shift leaves the body farther past its feet
        if why not in whys:
            whys.append(why)
    if shifting and s.squat and ceiling is None:
        phase, why = squat_then_reach(planner, task, target_c, pivot_c, turns, body,
                                      make_planner, trunk, acceptable, base)
        if phase is not None:
            return phase, why
        whys.append(why)
    return None, "; ".join(whys)


#: How many of :func:`_leans_to_try`'s leans :func:`_lean_toward` tries at most before
#: its last (a lean as deep as one refused for the balance is not tried, nor counted).
LEAN_TRIES = 6


def _leans_to_try(arm, target_c, pivot_c, s, table1: float, ceiling: float | None = None
                  ) -> tuple:
    """The leans :func:`_lean_toward` tries in turn, and the chest turns (a tuple, degrees)
    each was chosen with, among which :func:`~.hips.shifted_lean` seeks its hips' shift
    where the lean would tip the body: for Table 1's turn and each of
    :func:`~.lean.chest_turns`, the least lean that brings ``target_c`` within reach
    (:func:`~.lean.choose_lean`), least :func:`~.effort.trunk_effort` first (the turn past
    Table 1's, and the lean): Table 1's lean leads where a twist would cost more than the
    lean it saves, as people lean before they twist; a deeper lean then gives way to a
    smaller one with the chest turned farther (Quaternius' alien, whose 16° lean for the
    far target tips it past its feet whatever its hips do, reaches it with less lean and
    more twist). Last, the least lean of all, its hips' shift sought with every turn (the
    smallest lean, the largest twist). With ``Settings.twist_weight`` 0, the two the
    recruitment tried before the costing: Table 1's lean (where more than 0.5° deeper
    than the least) and the least. Leans whose effort is ``ceiling`` or more are left
    out. Empty where no lean reaches."""
    every = [table1] + [t for t in chest_turns(s) if abs(t - table1) > 1e-9]
    found = [(abs(t - table1), lean, (t,)) for t in every
             if (lean := choose_lean(arm, target_c, pivot_c, s, (t,))) is not None]
    if ceiling is not None:
        found = [f for f in found if trunk_effort(f[0], f[1].angle, s) < ceiling]
    if not found:
        return [], []
    least = min(found, key=lambda f: f[1].angle)
    if s.twist_weight <= 0.0:
        first = found[0] if found[0][2] == (table1,) and \
            found[0][1].angle > least[1].angle + 0.5 else None
        found = [] if first is None else [first]
    else:
        found.sort(key=lambda f: (trunk_effort(f[0], f[1].angle, s), f[0]))
    return [f[1] for f in found] + [least[1]], [f[2] for f in found] + [tuple(every)]


#: The tasks the body leans (and squats) for: a single reach, a sequence and a guided
#: reach, with any number of targets (:func:`body_target`). A step (:data:`STEP_TASKS`)
#: and a chase, whose target moves, still refuse.
BODY_TASKS = ("reach", "sequence", "guided")
#: The tasks the body steps for, with one target: a single reach and a guided reach.
STEP_TASKS = ("reach", "guided")


def body_target(settings, task, failed, arm) -> int | None:
    """The index of the target the body leans (or squats) toward where ``failed`` (a plan
    of ``task``, :data:`BODY_TASKS`, with ``Settings.lean`` on) refused one or more of its
    targets: of those refused as ``needs_lean`` (or, with ``Settings.squat``, as
    ``out_of_reach`` below the shoulder and beyond the arm, :func:`below_the_arm`: a squat
    may bring it within reach; one within the arm's length but past its joint limits, or
    above it, stays refused), the farthest from the shoulder, which asks the deepest lean;
    None where any target is refused for another reason (a lean does not clear an
    obstacle) or none is refused.

    The choice is ours (the paper plans the arm alone): a sequence leans once, after the
    targets it reaches upright (:func:`upright_part`), as far as the target that asks most,
    and holds that lean through the rest (the lean's checks and the balance are weighed on
    all of them). A person may lean in and out between targets; one lean keeps the lean's
    planning and bake those of a single reach."""
    if not settings.lean or task.kind not in BODY_TASKS:
        return None
    refused = [s for s in failed.segments if not s.success]
    if not refused or any(not _helps(settings, task, arm, s) for s in refused):
        return None
    shoulder = np.asarray(arm.shoulder, dtype=float)
    return max(refused, key=lambda seg: float(np.linalg.norm(
        arm.to_canonical_points(np.asarray(task.targets[seg.index], dtype=float)) -
        shoulder))).index


def body_helps(settings, arm, reason, target_world) -> bool:
    """Whether a target at ``target_world`` refused for ``reason`` is one a lean or squat
    may reach: ``needs_lean``, or (with ``Settings.squat``) ``out_of_reach`` below the
    shoulder and beyond the arm (:func:`below_the_arm`)."""
    if reason == NEEDS_LEAN:
        return True
    return reason == OUT_OF_REACH and settings.squat and below_the_arm(
        arm, arm.to_canonical_points(np.asarray(target_world, dtype=float)))


def _helps(settings, task, arm, seg) -> bool:
    """:func:`body_helps` for the refused segment ``seg`` of a plan of ``task``."""
    return body_helps(settings, arm, seg.reason, task.targets[seg.index])


def body_held_back(settings, task, failed, arm) -> tuple:
    """Where a plan of ``task`` (:data:`BODY_TASKS`, ``Settings.lean`` on) refused targets
    the body might reach and another it may not (:func:`body_target` is None): (the clause
    that says why the body did not lean, naming the other target and its reason; the
    segments it is said of, those the body might have reached); else (None, [])."""
    if not settings.lean or task.kind not in BODY_TASKS:
        return None, []
    refused = [s for s in failed.segments if not s.success]
    other = next((s for s in refused if not _helps(settings, task, arm, s)), None)
    helped = [s for s in refused if _helps(settings, task, arm, s)]
    if other is None or not helped:
        return None, []
    return (f"the body leans only where every refused target is one a lean may reach, and "
            f"target '{other.name}' is refused as {other.reason}"), helped


def wants_body(settings, task, failed, arm) -> bool:
    """Whether ``failed`` (a plan of ``task``) is one the body may reach where the arm
    cannot: one with a target to lean toward (:func:`body_target`)."""
    return body_target(settings, task, failed, arm) is not None


def wants_step(settings, task, failed, arm) -> bool:
    """Whether ``failed`` is one the body may step toward: with ``Settings.lean`` and
    ``Settings.stepping`` on, a reach or guided reach to one target (:data:`STEP_TASKS`)
    refused as ``needs_step``, or one the lean and squat are tried for
    (:func:`wants_body`)."""
    if not (settings.lean and settings.stepping) or task.kind not in STEP_TASKS or \
            len(task.targets) != 1:
        return False
    return failed.reason == NEEDS_STEP or wants_body(settings, task, failed, arm)


def below_the_arm(arm, target_c) -> bool:
    """Whether the canonical ``target_c`` lies below the shoulder and beyond the arm's
    length from it (where a squat may help: :func:`wants_body`)."""
    d = np.asarray(target_c, dtype=float) - arm.shoulder
    return float(np.linalg.norm(d)) > arm.arm_length and float(d[2]) < 0.0


#: How many squats :func:`squat_then_reach` tries, best first, each at least
#: :data:`SQUAT_APART` grid steps from those tried in the hips' drop or shift.
SQUAT_TRIES = 4
SQUAT_APART = 2


def squat_then_reach(planner, task, target_c, pivot_c, turns, body, make_planner, trunk,
                     acceptable, base: float):
    """Stage 4: the squat or bend (:func:`~.squat.squat_leans`) with the chest turned as
    Table 1 has it, else as far as the planner may turn it (``turns``, as
    :func:`lean_then_reach` tries them), then the reach on it, each posture held to
    ``acceptable`` as a lean is (:func:`_balanced_reach`): (:class:`LeanPhase`, the reach's
    plan) or (None, why not). Of the postures found, up to :data:`SQUAT_TRIES` are tried
    in their order, skipping those near one tried (the checks that refuse one, a body
    touching or tipping, refuse its neighbours too)."""
    s = planner.settings
    squats = []
    for group in turns:
        squats = squat_leans(planner.arm, target_c, pivot_c, s, group, body)
        if squats:
            break
    if not squats:
        return None, (f"no squat or bend (trunk up to {s.bend_max:.0f}°, knees "
                      f"{s.knee_max:.0f}°, ankles {s.ankle_max:.0f}°, hips {s.hip_max:.0f}°) "
                      "brings it within reach with the body over its feet")
    step = s.squat_step * planner.arm.arm_length
    tried, why = [], None
    for q in squats:
        if len(tried) >= SQUAT_TRIES:
            break
        if any(np.abs(q.lean.shift - t).max() < SQUAT_APART * step - 1e-9 for t in tried):
            continue
        tried.append(np.asarray(q.lean.shift, dtype=float))
        why = acceptable(q.lean) if acceptable is not None else None
        if why is None:
            phase, why = _balanced_reach(planner, task, q.lean, make_planner, trunk,
                                         acceptable, base)
            if phase is not None:
                return phase, why
    return None, f"squatting: {why}"


def _balanced_reach(planner, task, lean, make_planner, trunk, acceptable, base: float):
    """:func:`_lean_and_reach`, and the body weighed again on every pose of the reach
    (``acceptable(lean, arm_world, turned)``: the arm's joints in the world, (P, 5, 3),
    and ``turned(points, k)``, world points the chest carries where its turn on pose k
    takes them, so the other arm and the head turn back as the reaching shoulder comes
    forward; counted from ``base``, the turn the rig stands with, as a reach after a
    sequence's first targets starts turned): (phase, the reach's plan), or (None, why not)."""
    phase, reach = _lean_and_reach(planner, task, lean, make_planner, trunk, acceptable)
    if phase is None or acceptable is None:
        return phase, reach
    arm = phase.arm
    turns = [p.config.body_rotation - base for p in reach.poses]

    def turned(points, k):
        return arm.to_world_points(rotate_about_spine(arm.to_canonical_points(points),
                                                      turns[k]))

    joints = arm.to_world_points(np.array([p.joints for p in reach.poses], dtype=float))
    why = acceptable(lean, joints, turned)
    return (phase, reach) if why is None else (None, why)


def _lean_and_reach(planner, task, lean, make_planner, trunk=None, acceptable=None):
    """(:class:`LeanPhase`, the reach's plan) for one ``lean``, or (None, why not): the arm
    held at its start as the trunk leans, then the reach; where that is refused, the arm
    first reaching toward the target on the upright trunk (:func:`_ready_lean_reach`, its
    poses weighed by ``acceptable`` as :func:`lean_then_reach` takes it)."""
    start = planner.generator.config_pose(task.start, task.start_hand)
    phase, reach = _leaned_reach(planner, task, lean, make_planner, trunk, start)
    if phase is not None or planner.settings.lean_ready <= 0.0:
        return phase, reach
    ready_phase, ready_reach = _ready_lean_reach(planner, task, lean, make_planner, trunk,
                                                 acceptable)
    if ready_phase is not None:
        return ready_phase, ready_reach
    return None, f"{reach} (and with the arm raised first: {ready_reach})"


def _leaned_reach(planner, task, lean, make_planner, trunk, held, ready=None):
    """The lean with the arm held at the pose ``held`` (the task's start, or the ready
    reach's end), then the reach ``task`` on the leaned trunk: (:class:`LeanPhase`, the
    reach's plan), or (None, why not)."""
    s, arm = planner.settings, planner.arm
    fractions = lean_frames(arm, held.joints, lean, s, task.fps)
    hit = lean_hit(arm, with_shape(arm, held.joints, held.bend, held.roll), lean, fractions,
                   planner.generator.checker, trunk, held.config.body_rotation)
    if hit is not None:
        fraction, part, obstacle = hit
        return None, (f"leaning {lean.angle * fraction:.0f}° of the {lean.angle:.0f}° it "
                      f"needs would bring the {part} against '{obstacle}'")
    leaned = leaned_arm(arm, lean)
    reach = make_planner(leaned).plan(task)
    if not reach.success:
        return None, f"leaning {lean.angle:.0f}°, the arm still finds no way: {reach.message}"
    hit = body_hit(leaned, reach.poses, planner.generator.checker, trunk)
    if hit is not None:
        frame, part, obstacle = hit
        return None, (f"leaning {lean.angle:.0f}°, the {part} would touch '{obstacle}' on "
                      f"the reach's frame {frame}")
    return LeanPhase(lean, fractions, leaned, ready), reach


def ready_point(arm, lean, target_world, share) -> np.ndarray:
    """The ready reach's goal (world): ``share`` of the way from the shoulder to where the
    target will be relative to the trunk once it has leaned by ``lean``,
    :math:`s + f (L^{-1} t - s)` in the upright arm's canonical frame (``L`` the lean's
    transform, :func:`~.lean.leaned_arm`), so the lean carries the hand toward the target
    and the reach after it covers the rest."""
    t = leaned_arm(arm, lean).to_canonical_points(np.asarray(target_world, dtype=float))
    s = np.asarray(arm.shoulder, dtype=float)
    return arm.to_world_points(s + float(share) * (t - s))


def _ready_lean_reach(planner, task, lean, make_planner, trunk, acceptable=None):
    """Arm first, then the lean (``Settings.lean_ready``): a reach on the upright trunk to
    :func:`ready_point` (the paper's planner unchanged; the chest held, as it is held
    through a lean: the reach after it turns it as Table 1 has it), the lean with the arm
    there, then the reach from that pose, its hand's palm and fingers carried on from the
    task's start (:func:`~.orient.hand_locals`). The ready reach's poses are weighed on the
    upright body (``acceptable`` with no lean): a raised arm carries the centre of mass
    forward. A start whose chest is turned is not tried."""
    s, arm = planner.settings, planner.arm
    if abs(float(task.start.body_rotation)) > 1e-9:
        return None, "its chest starts turned"
    goal = ready_point(arm, lean, task.targets[0], s.lean_ready)
    ready_task = dataclasses.replace(task, targets=goal[None], names=("the ready point",),
                                     duration_s=None, orientations=None)
    ready = make_planner(arm, dataclasses.replace(s, chest_rotation=False)).plan(ready_task)
    if not ready.success:
        return None, f"raising the arm toward it finds no way: {ready.message}"
    if acceptable is not None:
        upright = dataclasses.replace(lean, angle=0.0, shift=np.zeros(3))
        why = acceptable(upright, arm.to_world_points(np.array([p.joints for p in ready.poses])))
        if why is not None:
            return None, f"raising the arm toward it first: {why}"
    end = ready.poses[-1]
    start = planner.generator.config_pose(task.start, task.start_hand)
    finger, palm = hand_locals(start, task.start_palm, task.start_fingers)
    frame = hand_frame(end)
    reach_task = dataclasses.replace(
        task, start=end.config, start_hand=tuple(end.hand),
        start_palm=None if task.start_palm is None else frame @ palm,
        start_fingers=None if task.start_fingers is None else frame @ finger)
    return _leaned_reach(planner, reach_task, lean, make_planner, trunk, end, ready)


def body_hit(arm, poses, checker, trunk: TrunkSkin | None = None):
    """The first pose whose trunk touches an obstacle, on the trunk of ``arm`` (leaned),
    turned with the chest: (pose index, part name, obstacle name), else None. The trunk is
    its skin where given (``trunk``: its ``turns`` points turned with the chest,
    :func:`~.lean.skin_hit`, part "trunk"), else the chest's and head's capsules
    (:func:`~.lean.capsules_hit`)."""
    m = arm.to_world
    if trunk is not None:
        def at(pose):
            pts = np.array(trunk.points, dtype=float)
            pts[trunk.turns] = rotate_about_spine(pts[trunk.turns], pose.config.body_rotation)
            return pts

        world = np.array([at(p) @ m[:3, :3].T + m[:3, 3] for p in poses])
        hit = skin_hit(world, checker)
        return None if hit is None else (hit[0], "trunk", hit[1])
    body = [c for c in arm.body_capsules if c.turns_with_chest]
    ends = np.array([[rotate_about_spine(np.array([c.a, c.b], dtype=float),
                                         p.config.body_rotation) @ m[:3, :3].T + m[:3, 3]
                      for c in body] for p in poses]).reshape(len(poses), len(body), 2, 3)
    return capsules_hit(ends, body, checker)
