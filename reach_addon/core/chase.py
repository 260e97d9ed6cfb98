"""The chase reach: the target moves (one position per frame) and every frame is re-planned
from the last.

:func:`chase_steps` plans a whole chase (one planner per frame, so obstacles may move);
:func:`chase_step` plans one frame: a best-first search with
``Settings.chase_nodes_per_frame`` nodes, committing at most
:func:`chase_steps_per_frame` steps (``Settings.chase_max_speed``) and a hand turn within
``Settings.hand_space_turn_speed``. A start in contact leads with its escape
(:func:`escape_frames`). Where that pursuit misses the target at the end, or catches it
only by turning the hand too fast or lifting the elbow over a low hand, the chase
plans ahead (``Settings.chase_plan_ahead``): a reach to where the target
ends, retimed to the chase's limits, the wrist waiting there (:meth:`_Chase._plan_ahead`).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from . import obstacle_union
from .arm import Pose, frame_turn
from .chase_timing import (at_chase_speed, chase_rate, part_way, shortcut_for, span_cost,
                           wrist_travel)
from .contact import line_escape
from .diagnosis import diagnose_target
from .elbow import relax_elbow, wing_count
from .errors import NO_PATH, START_IN_COLLISION, require_finite
from .generator import ConfigurationGenerator
from .hand import HandReport, plan_hand
from .hand_shape import world_pose
from .motion_check import escape_contact, motion_stats, pose_clearances
from .results import Plan, Segment, Stats
from .sampling import sampling_steps, straight_poses
from .search import BestFirstSearch, SearchResult
from .settings import Settings
from .steps import drain
from .tasks import Task


#: How many frames a chase whose pursuit lifts the elbow over a low hand tries to plan
#: ahead to and follow from (:meth:`_Chase.run`), besides the target's end.
AHEAD_TRIES = 4

#: Degrees a turn may exceed its bound by round-off alone (the search's own hand-turn
#: bound leaves poses right at it).
TURN_ROUND_OFF = 0.01


def chase_step(generator: ConfigurationGenerator, previous: Pose, target, steps: int,
               fps: float = 24.0, strict: bool = False):
    """One frame of a chase: a best-first search from ``previous`` toward ``target``
    (canonical) with ``Settings.chase_nodes_per_frame`` nodes, stopping ``steps`` steps
    along. Returns (the pose committed, the search result, with the nodes and time of every
    search of the frame counted).

    The hand is kept continuous; a search with the hand free is taken where the kept one
    does not reach the target and the free one does, or where the kept one is stuck (not
    half a step nearer) and the free one gets a step nearer (it runs only where one of
    these can happen). The pose committed is :func:`_commit`'s: at most ``steps`` along
    the path (and where ``Settings.chase_max_speed`` allows less than one step a frame,
    :func:`chase_rate`, only that part of it, :func:`part_way`), clear as the keys
    interpolate, the hand's turn in space within
    ``Settings.hand_space_turn_speed`` / ``fps``; with ``strict`` (where the hand pass
    could not keep the hand within its bound, :func:`chase_steps`) that bound holds on the
    target too and a first step too fast is taken only part of the way (:func:`part_way`).
    Where no pose along the path is clear the arm holds its pose (``result.held``)."""
    s = generator.settings
    view = generator.for_reach(previous, target, fit_chest=False)
    turn = s.hand_space_turn_speed / fps       # the hand's whole turn in a frame, roll too
    results = []              # (distance left to the target, pose committed, search result)
    stuck = False
    for continuity in (True, False):
        searcher = BestFirstSearch(view, previous, target,
                                   node_budget=s.chase_nodes_per_frame,
                                   stall_budget=s.chase_nodes_per_frame, depth_limit=steps,
                                   hand_continuity=continuity, last_try=False)
        searcher.run()
        result = searcher.result()
        pose, k = _commit(view, previous, result, steps, turn, strict)
        results.append((math.dist(pose.wrist.tolist(), result.target.tolist()), pose, result))
        if result.success and k > 0:
            break
        if continuity:
            # the free search cannot reach a target farther than its steps go (each move
            # carries the wrist a step at most): it runs only where its result can be kept
            before = math.dist(previous.wrist.tolist(), result.target.tolist())
            stuck = results[0][0] >= before - 0.5 * generator.step_length
            if not stuck and before > steps * generator.step_length + searcher.tolerance:
                break
    best = results[0]
    if len(results) > 1 and (results[1][2].success or
                             (stuck and results[1][0] < best[0] - generator.step_length)):
        best = results[1]
    pose, result = best[1], best[2]
    result.nodes_searched = sum(r[2].nodes_searched for r in results)
    result.search_time_s = sum(r[2].search_time_s for r in results)
    # a speed limit below one search step a frame: the frame takes part of its step
    limit = chase_rate(s, fps) * generator.step_length
    if limit < generator.step_length and wrist_travel(previous, pose) > limit:
        slower = part_way(view, previous, pose, limit, measure=wrist_travel)
        if slower is None:
            slower, result.held = replace(previous), True
        pose = slower
    return pose, result


def _commit(view: ConfigurationGenerator, previous: Pose, result: SearchResult, steps: int,
            turn: float, strict: bool):
    """(the pose a chase frame commits to, its index k along ``result.path``; 0: the arm
    holds): the farthest pose at most ``steps`` along that the arm and hand reach from
    ``previous`` clear as the keys interpolate
    (:meth:`ConfigurationGenerator.transition_problem`) and, unless it is on the target
    (or ``strict``), whose hand turns (roll included, :func:`~reach_addon.core.arm.frame_turn`)
    at most ``turn`` degrees. Where even the first pose touches between the keys and
    ``previous`` is clear, or (``strict``) no part of the way to a too fast first pose is
    clear, the arm holds and ``result.held`` is set. The pose is never ``previous`` itself
    (the frames' caches are kept by the poses' identities)."""
    def clear_back(k: int) -> int:         # the nearest k or less clear between the keys
        while k > 1 and view.transition_problem(previous, result.path[k]) is not None:
            k -= 1
        return k

    k = clear_back(min(steps, len(result.path) - 1))
    on_target = result.success and k == len(result.path) - 1
    if not on_target or strict:
        # a pose nearer, for the hand's turn, must be clear between the keys too (fuzz
        # seed 4880: one two steps along touched where the third, too fast, did not)
        while k > 1 and frame_turn(previous, result.path[k]) > turn:
            k = clear_back(k - 1)
    if k == 1 and view.transition_problem(previous, result.path[1]) is not None and \
            view.key_clear(previous):
        k = 0                                  # the arm holds for the frame
        result.held = True
    pose = result.path[k]
    if strict and k > 0 and frame_turn(previous, pose) > turn + TURN_ROUND_OFF:
        pose = part_way(view, previous, pose, turn)
        if pose is None:
            k, pose, result.held = 0, previous, True
    if pose is result.path[0]:
        pose = replace(pose)
    return pose, k


def chase_steps_per_frame(settings: Settings, fps: float) -> int:
    """Search steps the wrist may take in one frame: ``chase_max_speed / fps / step``."""
    return max(1, int(settings.chase_max_speed / fps / settings.step + 1e-9))


def chase_steps(planners, task: Task, chunk: int = 1):
    """Plan a chase with one planner per frame (``planners[f]`` holds the obstacles at
    frame ``f``; pass the same planner for frames where nothing moved): each frame is
    re-planned from the previous frame's pose against the obstacles *at that frame*. A
    generator like :meth:`Planner.plan_steps`: yields (fraction, message) every ``chunk``
    frames and returns the :class:`Plan`. With one planner for every frame this is
    :meth:`Planner.plan` of the chase task (which calls it so). A frame whose pose is hit
    by an obstacle that moved into it fails the chase, naming the obstacle and the frame."""
    t0 = time.perf_counter()
    planners = list(planners)
    if task.kind != "chase":
        raise ValueError("chase_steps plans chase tasks")
    if len(planners) != len(task.targets):
        raise ValueError(f"one planner per frame: {len(task.targets)} frames, "
                         f"{len(planners)} planners")
    first = planners[0]
    start = first.generator.config_pose(task.start, task.start_hand)
    require_finite("start pose", start.joints)
    way_out, failed = first.start_escape(task, start)
    if failed is not None:
        failed.stats.planning_time_s = time.perf_counter() - t0
        return failed
    chase = _Chase(planners, task, start, way_out)
    hand = yield from chase.run(chunk)
    if way_out is not None and not chase._caught(hand.poses) and \
            not any(contact for _r, contact in chase.frames):
        # a start in contact whose way out led nowhere: straight lines out toward where
        # the target ends, over the chest's range (contact.line_escape; fuzz seed 2959)
        other = line_escape(first.generator, start, way_out.obstacle,
                            first.arm.to_canonical_points(np.asarray(task.targets[-1], float)))
        if other is not None:
            again = _Chase(planners, task, start, other)
            again_hand = yield from again.run(chunk)
            if again._caught(again_hand.poses):
                if again.frames:             # the first try's nodes count too
                    again.frames[0][0].nodes_searched += sum(r.nodes_searched
                                                             for r, _c in chase.frames)
                chase, hand = again, again_hand
    plan = chase.plan(hand)
    plan.stats.planning_time_s = time.perf_counter() - t0
    return plan


class _Chase:
    """One chase being planned (:func:`chase_steps`): its frames' poses (the start, the
    escape's frames, then one per chased frame) and, per chased frame, (its search result,
    the contact of an obstacle that moved into its pose or None)."""

    def __init__(self, planners: list, task: Task, start: Pose, way_out):
        self.planners, self.task, self.start, self.way_out = planners, task, start, way_out
        self.arm, self.settings = planners[0].arm, planners[0].settings
        s = self.settings
        self.steps = chase_steps_per_frame(s, task.fps)
        self.trajectory = self.arm.to_canonical_points(task.targets)
        self.poses = [start] + self._way_out(way_out, start)
        self.lead = len(self.poses)       # the chased frames start here
        self.frames: list = []
        self.ahead_why = ""       # why a chase that caught the target planned ahead

    def _way_out(self, way_out, start: Pose) -> list:
        """The escape's frames (:func:`escape_frames`), ``self.steps`` of its poses a frame
        at most, fewer where the keys so far apart would touch again after leaving contact
        as Blender interpolates them (:func:`~reach_addon.core.motion_check.escape_contact`,
        against the first frame's obstacles), down to one a frame."""
        turn = self.settings.hand_space_turn_speed / self.task.fps
        frames = len(self.trajectory)
        gen = self.planners[0].generator
        picked = []
        for steps in range(self.steps, 0, -1):
            picked = escape_frames(way_out, steps, frames, turn)
            poses = [start] + picked
            if not picked or escape_contact(
                    gen, poses, pose_clearances(self.arm, poses, [gen.checker] * len(poses))) is None:
                break
        return picked

    def run(self, chunk: int):
        """Pursue the target (:meth:`_pursue`); where that misses it at the end, or catches
        it only by turning the hand faster than its bound (its strict re-chase missed), and
        ``Settings.chase_plan_ahead`` is on, plan ahead to where it ends
        (:meth:`_plan_ahead`) and keep that where it catches it within the bounds (the
        demo's chase from the rest pose: the pursuit turned the hand 15.9° in a frame and
        lifted the elbow over it for 11 frames; the reach ahead keeps to 14.5°, no wing).
        Where the pursuit catches it within the bounds but lifts the elbow over a low hand
        (:func:`~reach_addon.core.elbow.wing_count`), it plans ahead to where the target
        is on the frame the pursuit first caught it, on :data:`AHEAD_TRIES` frames from
        there on and on the last, following it from there; the chase whose elbow rises
        least (:meth:`_lifts`) is kept, the pursuit and then the earlier on a tie (the
        rigid robot's chase over a table: its wrist rose in front of the shoulder, where a
        forearm 2.4 times the upper arm folds the elbow up, for 10 winged frames; the
        reaches to where the target is on frames 24, 30, 36 and 42 lift it too, to frame
        30's within the margin by a hair and 0.23 arm lengths over the shoulder; the reach
        to its end rises inward of the shoulder, no wing, the wrist waiting 24 frames).
        A generator: yields (fraction, message) and returns the hand pass's report."""
        hand = yield from self._pursue(chunk)
        wings = self._wings(hand)
        if not self.settings.chase_plan_ahead or \
                (self._caught(hand.poses) and self._first_too_fast(hand) is None and not wings):
            return hand
        if not self._caught(hand.poses) or self._first_too_fast(hand) is not None:
            ahead = self._plan_ahead()
            return hand if ahead is None else ahead
        # caught within the bounds, with the elbow lifted: ahead to where the target is
        # when the pursuit first caught it, then following it; or later; or to its end
        best = (self._lifts(hand), list(self.poses), list(self.frames), hand)
        on, end = self._first_on_target(hand.poses), len(self.trajectory) - 1
        for to in dict.fromkeys([*range(on, end, max(1, (end - on) // AHEAD_TRIES)), end]):
            self.poses[:], self.frames = list(best[1]), list(best[2])
            ahead = self._plan_ahead(to)
            if ahead is not None and self._lifts(ahead) < best[0]:
                best = (self._lifts(ahead), list(self.poses), list(self.frames), ahead)
                self.ahead_why = f"following it lifted the elbow over a low hand on {wings} " \
                                 "frames"
        self.poses[:], self.frames = best[1], best[2]
        return best[3]

    def _wings(self, hand: HandReport, share: float = 1.0) -> int:
        """The chased frames of ``hand`` with the elbow lifted over a low hand
        (:func:`~reach_addon.core.elbow.wing_count`, ``share`` of the margin)."""
        return wing_count(hand.poses[self.lead - 1:], self.arm.arm_length,
                          share * self.settings.wing_margin)

    def _lifts(self, hand: HandReport) -> tuple:
        """How a chase's elbow rises over a low hand, to compare chases by: (its winged
        frames, those at half the margin: an elbow 0.2 arm lengths over a hand just at
        the margin below the shoulder is as lifted to the eye)."""
        return self._wings(hand), self._wings(hand, 0.5)

    def _caught(self, poses) -> bool:
        return float(np.linalg.norm(poses[-1].wrist - self.trajectory[-1])) <= \
            self.settings.goal_tolerance * self.arm.arm_length

    def _first_on_target(self, poses) -> int:
        """The first chased frame whose wrist is on the target (within the goal
        tolerance)."""
        tol = self.settings.goal_tolerance * self.arm.arm_length
        return next(f for f in range(self.lead, len(poses))
                    if float(np.linalg.norm(poses[f].wrist - self.trajectory[f])) <= tol)

    def _plan_ahead(self, to: int | None = None):
        """Where the pursuit misses: the paper's reach (:meth:`Planner.plan`, guided and
        sampling fallbacks included) from the pose of the frame before the chase to where
        the target ends, its frames taken as fast as the chase's limits let
        (:meth:`_at_chase_speed`), the wrist then waiting there until the last frame. The
        pursuit aims each frame at where the target is then, and a way round an obstacle
        that needs the wrist to leave the target's side first is beyond its few nodes a
        frame: fuzz seeds 171 (249 frames had for a way followed in 21), 55, 225, 5199
        and 5310, found by the cross-check of a chase's ``no_path``.

        The reach is planned among the obstacles where they are on that frame; where
        obstacles move and one comes into that way, again among every place they take
        over the chase's frames (:func:`~reach_addon.core.obstacle_union.union`: a way clear of
        all of them whenever it runs; fuzz seed 384, a box that moved into the first
        way). Either way each frame's keys and the instants into it are checked against
        the obstacles as they are on it. The hand report of the first chase so planned
        that catches the target with every hand turn within its bound and every
        transition clear; else None, and the pursuit stays.

        With ``to`` (a frame): the reach goes to where the target is on that frame, the
        wrist waiting there until it comes, and the pursuit follows it from there."""
        first = self.lead - 1
        for planner in self._ahead_planners(first):
            hand = self._ahead_with(planner, first, len(self.trajectory) - 1 if to is None
                                    else to)
            if hand is not None:
                return hand
        return None

    def _ahead_planners(self, first: int):
        """The planners :meth:`_plan_ahead` tries, in order: the one of frame ``first``,
        then (where obstacles move from it on) one among every place they take."""
        yield self.planners[first]
        distinct = list({id(p): p for p in self.planners[first:]}.values())
        if len(distinct) > 1:
            try:
                union = obstacle_union.union([p.obstacles for p in distinct])
            except ValueError:
                return
            # a planner like the chase's own (its class: chase must not import planner,
            # which imports chase)
            yield type(distinct[0])(self.arm, union, self.settings)

    def _ahead_with(self, planner, first: int, to: int):
        """:meth:`_plan_ahead` with ``planner``'s obstacles, to the target on frame ``to``:
        the hand report, or None."""
        start, n = self.poses[first], to + 1
        t0 = time.perf_counter()
        plan = planner.plan(Task("reach", np.asarray(self.task.targets)[to:to + 1],
                                 start.config, fps=self.task.fps, names=(self.task.name(0),),
                                 start_hand=start.hand))
        way = None if not plan.success else self._at_chase_speed(
            planner.generator, [start] + list(plan.poses[1:]), n - 1 - first)
        target = self.trajectory[to]
        if way is None:
            # the search's way is longer than the frames allow: a straight line in joint
            # space to a goal pose, if one is clear (fuzz seed 2482: OMPL's straight line
            # fitted the frames exactly)
            line = straight_poses(planner.generator, start, target)
            way = None if line is None else self._at_chase_speed(planner.generator, line,
                                                                 n - 1 - first)
        if way is None and plan.success:
            way = self._shortened(planner, [start] + list(plan.poses[1:]), target, n - 1 - first)
        if way is None:
            return None
        way += [replace(way[-1]) for _ in range(n - first - len(way))]   # waiting there
        moving = any(p is not planner for p in self.planners[first:])
        if moving and any(
                self.planners[first + k].generator.transition_problem(a, b) is not None
                or not self.planners[first + k].generator.key_clear(b)
                for k, (a, b) in enumerate(zip(way[:-1], way[1:]), start=1)):
            return None          # an obstacle that moves comes into the way on its frame
        kept = list(self.poses), list(self.frames)
        self.poses[first:] = way
        elapsed = time.perf_counter() - t0
        self.frames = [(SearchResult(True, None, [a, b], plan.stats.nodes_searched if k == 0
                                     else 0, elapsed if k == 0 else 0.0, 0.0,
                                     self.trajectory[first + 1 + k], method="ahead"), None)
                       for k, (a, b) in enumerate(zip(way[:-1], way[1:]))]
        drain(self._chase_frames(len(self.trajectory), 0))     # following it from ``to``
        hand = self._hand()
        # transitions of the escape from a start in contact (before the chase's first
        # frame) touch by design; :meth:`_way_out` checked them (fuzz seed 5239)
        if self._caught(hand.poses) and self._first_too_fast(hand) is None and \
                not any(k >= first for k in hand.unclear_transitions):
            return hand
        self.poses[:], self.frames = kept
        return None

    def _shortened(self, planner, poses: list, target, frames: int):
        """Where neither the search's way nor a straight line fits ``frames``: the search's
        way, then the sampling planner's, shortened in the chase's own cost
        (:func:`~.chase_timing.shortcut_for`), timed at its limits; None if neither fits
        (fuzz seeds 5804 and 3327, whose OMPL ways fit their frames exactly)."""
        gen, s = planner.generator, self.settings
        cost = span_cost(gen, s, self.task.fps)
        way = self._at_chase_speed(gen, shortcut_for(gen, poses, cost, seed=s.sampling_seed),
                                   frames)
        if way is None and s.sampling_fallback:
            sampled = drain(sampling_steps(gen.for_reach(poses[0], target), poses[0], target))
            if sampled.success:
                way = self._at_chase_speed(gen, shortcut_for(gen, sampled.path, cost,
                                                             seed=s.sampling_seed), frames)
        return way

    def _at_chase_speed(self, gen: ConfigurationGenerator, poses: list, frames: int):
        """:func:`~.chase_timing.at_chase_speed` with this chase's settings and frame rate."""
        return at_chase_speed(gen, poses, frames, self.settings, self.task.fps)

    def _pursue(self, chunk: int):
        """Chase every frame, then hand the frames to the hand pass; where it could not keep
        the hand within its bound (the forearm itself turned too fast), chase again from that
        frame on, strictly (:func:`chase_step`). A generator: yields (fraction, message)
        every ``chunk`` frames and returns the hand pass's report; :attr:`frames` are then
        the chase's. Where the strict chase misses the target at the end that the first,
        loose one caught, the loose one is kept (catching the target wins)."""
        n = len(self.trajectory)
        strict_from = n
        loose = None              # (poses, frames, hand) of a first chase that caught it
        while True:
            yield from self._chase_frames(strict_from, chunk)
            hand = self._hand()
            late = self._first_too_fast(hand)
            caught = self._caught(self.poses)
            if strict_from < n and not caught and loose is not None:
                self.poses, self.frames, hand = loose
                return hand
            if late is None or late >= strict_from:
                return hand
            if strict_from == n and caught:
                loose = (list(self.poses), list(self.frames), hand)
            strict_from = late
            del self.poses[late:], self.frames[late - self.lead:]

    def _chase_frames(self, strict_from: int, chunk: int):
        """Plan the frames not planned yet (:func:`chase_step`), strictly from frame
        ``strict_from``; yields progress every ``chunk`` frames."""
        task, arm, planners, poses = self.task, self.arm, self.planners, self.poses
        n = len(self.trajectory)
        for f in range(self.lead + len(self.frames), n):
            if chunk and f % chunk == 0:
                yield f / n, f"chasing '{task.name(0)}': frame {f}"
            gen = planners[f].generator
            nxt, res = chase_step(gen, poses[-1], self.trajectory[f], self.steps, task.fps,
                                  strict=f >= strict_from)
            poses.append(nxt)
            contact = gen.checker.first_hit(world_pose(arm, nxt)) \
                if planners[f] is not planners[f - 1] else None
            self.frames.append((res, contact))

    def _hand(self) -> HandReport:
        """The hand pass over the frames (no frames inserted: they are the target's). Where
        the chased frames lift the elbow over a low hand, their swivels and hands are first
        chosen again along the whole chase (:func:`~reach_addon.core.elbow.relax_elbow`,
        the last frame before the chase and the last frame kept), and kept if the hand pass
        over them touches and lifts its bound no more often and turns too fast no
        earlier."""
        gens = [p.generator for p in self.planners]
        hand = self._hand_pass(self.poses)
        first = self.lead - 1
        chased = self.poses[first:]
        relaxed = relax_elbow(gens[first:], chased,
                              self.settings.hand_space_turn_speed / self.task.fps)
        if relaxed is chased:
            return hand
        poses = self.poses[:first] + relaxed
        other = self._hand_pass(poses)
        never = len(poses)
        if len(other.unclear_transitions) <= len(hand.unclear_transitions) and \
                other.unbounded_turns <= hand.unbounded_turns and \
                (self._first_too_fast(other) or never) >= (self._first_too_fast(hand) or never):
            self.poses[:] = poses
            return other
        return hand

    def _hand_pass(self, poses: list) -> HandReport:
        return plan_hand([p.generator for p in self.planners], poses, self.task.fps,
                         may_insert=False, arcs=range(len(poses)),
                         escape=escape_of(self.way_out, poses))

    def _first_too_fast(self, hand: HandReport):
        """The first chased frame into which the hand turns faster than its bound in space
        (:func:`~reach_addon.core.arm.frame_turn`), or None."""
        bound = self.settings.hand_space_turn_speed / self.task.fps + TURN_ROUND_OFF
        p = hand.poses
        return next((k + 1 for k in range(self.lead - 1, len(p) - 1)
                     if frame_turn(p[k], p[k + 1]) > bound), None)

    def plan(self, hand: HandReport) -> Plan:
        """The chase's :class:`Plan` (one segment) from the hand pass's report."""
        task, arm, s = self.task, self.arm, self.settings
        poses = hand.poses
        stats = self._stats(hand)
        reason, message = self._outcome(poses, stats)
        seg = Segment(0, task.name(0), task.targets[-1], reason is None, reason, message, 0,
                      len(poses) - 1, stats,
                      arm.to_world_points(np.array([p.wrist for p in poses])), np.zeros((0, 3)),
                      "chase")
        total = Stats()
        total.add(stats)
        total.frames = len(poses)
        return Plan(task, arm, s, poses, [seg], total, self.planners[0].built_workspace)

    def _stats(self, hand: HandReport) -> Stats:
        """The chase's statistics: nodes and search time of every frame, the wrist's path
        length, and the motion's (:func:`~reach_addon.core.motion_check.motion_stats`)."""
        poses, frames, length = hand.poses, self.frames, self.arm.arm_length
        stats = Stats()
        stats.nodes_searched = sum(res.nodes_searched for res, _c in frames)
        stats.search_time_s = sum(res.search_time_s for res, _c in frames)
        stats.nodes_in_solution = sum(min(self.steps, len(res.path) - 1)
                                      for res, _c in frames) + 1
        path = np.array([p.wrist for p in poses])
        stats.path_length_arm_lengths = float(
            np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) / length
        motion_stats(stats, self.arm, poses, [p.generator.checker for p in self.planners],
                     stats.path_length_arm_lengths, self.settings.wing_margin, hand=hand)
        return stats

    def _outcome(self, poses, stats: Stats):
        """(reason, message) of the chase: an obstacle that moved into the arm, the target
        caught, or why the wrist did not catch it."""
        s, name, trajectory = self.settings, self.task.name(0), self.trajectory
        length = self.arm.arm_length
        hit = next(((self.lead + i, c) for i, (_r, c) in enumerate(self.frames)
                    if c is not None), None)
        gap = float(np.linalg.norm(poses[-1].wrist - trajectory[-1])) / length
        if hit is not None:
            f, (part, obstacle) = hit
            return START_IN_COLLISION, (
                f"'{obstacle}' moves into the arm (at the {part}) on frame {f} of the chase of "
                f"'{name}' and no clear pose was found; change the obstacle's motion or the "
                "chase speed limit")
        if gap <= s.goal_tolerance:
            on_target = sum(float(np.linalg.norm(p.wrist - trajectory[f])) <=
                            s.goal_tolerance * length
                            for f, p in enumerate(poses) if f >= self.lead)
            ahead = [k for k, (res, _c) in enumerate(self.frames) if res.method == "ahead"]
            how = "" if not ahead else \
                " by planning ahead to where it ends, the wrist waiting there" \
                if ahead[-1] == len(self.frames) - 1 else \
                f" by planning ahead to where it is on frame {self.lead + ahead[-1]}, then " \
                "following it"
            why = f" ({self.ahead_why})" if ahead and self.ahead_why else ""
            return None, (f"caught '{name}'{how}{why}"
                          + f" ({on_target} of {len(poses) - 1} frames on target)")
        last = self.planners[-1]
        diagnosis = diagnose_target(last.generator, trajectory[-1])
        fake = SearchResult(False, NO_PATH, [], stats.nodes_searched, 0.0, gap * length,
                            trajectory[-1])
        reason, message = last.explain_failure(name, fake, diagnosis, self.start)
        if reason == NO_PATH:
            held = sum(res.held for res, _c in self.frames)
            message = (f"the wrist did not catch '{name}' by the last frame ({gap:.2f} arm "
                       "lengths behind)")
            message += (f": on {held} frame(s) the arm held still where its next step would "
                        "have touched an obstacle as the keys interpolate; slow the target "
                        "there or give the arm more room" if held else
                        "; raise the chase speed limit or the nodes per frame")
        return reason, message


def escape_frames(way_out, steps_per_frame: int, frames: int, turn: float = math.inf) -> list:
    """The frames of a chase that leave a start in contact (:mod:`~reach_addon.core.contact`):
    from each frame's pose, the farthest pose of the escape at most ``steps_per_frame``
    steps on to which the hand turns (roll included) no more than ``turn`` degrees, at
    least the next one (its last included), at most ``frames`` - 1 of them; none without
    one."""
    if way_out is None:
        return []
    poses = way_out.poses
    picked, at = [], 0
    while at < len(poses) - 1 and len(picked) < frames - 1:
        nxt = min(at + steps_per_frame, len(poses) - 1)
        while nxt > at + 1 and frame_turn(poses[at], poses[nxt]) > turn:
            nxt -= 1
        picked.append(poses[nxt])
        at = nxt
    return picked


def escape_of(way_out, poses):
    """The hand pass's ``escape`` for a chase, whose frames' "arc lengths" are their
    numbers: frames before the escape's end are checked with its thinner arm."""
    if way_out is None:
        return None
    end = next((k for k, p in enumerate(poses) if p is way_out.poses[-1]), 0)
    return way_out.generator, float(end)


