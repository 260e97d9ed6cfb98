"""The chase reach: the target moves (one position per frame) and every frame is re-planned
from the last.

:func:`chase_steps` plans a whole chase (one planner per frame, so obstacles may move);
:func:`chase_step` plans one frame: a best-first search with
``Settings.chase_nodes_per_frame`` nodes, committing at most
:func:`chase_steps_per_frame` steps (``Settings.chase_max_speed``) and a hand turn within
``Settings.hand_space_turn_speed``. A start in contact leads with its escape
(:func:`escape_frames`).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from .arm import ArmConfig, Pose, frame_turn
from .errors import NO_PATH, START_IN_COLLISION, require_finite
from .generator import ConfigurationGenerator
from .hand import plan_hand
from .motion_check import motion_stats
from .results import Plan, Segment, Stats
from .search import BestFirstSearch, SearchResult
from .settings import Settings
from .tasks import Task


#: Degrees a turn may exceed its bound by round-off alone (the search's own hand-turn
#: bound leaves poses right at it).
TURN_ROUND_OFF = 0.01


def part_way(generator: ConfigurationGenerator, a: Pose, b: Pose, bound: float,
             halvings: int = 10) -> Pose | None:
    """A pose part of the way from ``a`` to ``b`` whose hand turns at most ``bound`` degrees
    from ``a``'s (roll included, :func:`~reach_addon.core.arm.frame_turn`),
    and that is clear as a key and as the keys from ``a`` interpolate
    (:meth:`ConfigurationGenerator.key_clear`, ``transition_problem``): the angles of the
    two poses, the wrist's two and the roll included, blended at the largest share found by
    ``halvings`` bisections; None if no share is clear. A chase cannot slow down its frames:
    where one step of its search turns the hand faster than the bound (a twist of the upper
    arm near its bound turns the forearm 15° and more), the frame takes only part of it."""
    qa, qb = a.config.as_array(), b.config.as_array()
    delta = qb - qa
    delta[3] = (delta[3] + 180.0) % 360.0 - 180.0            # the twist the short way
    ha, hb = np.asarray(a.hand, dtype=float), np.asarray(b.hand, dtype=float)

    def at(t):
        config = ArmConfig.from_array(qa + t * delta)
        pose = generator.config_pose(config, tuple((ha + t * (hb - ha)).tolist()))
        return replace(pose, roll=a.roll + t * (b.roll - a.roll))

    lo, hi = 0.0, 1.0
    for _ in range(halvings):
        mid = 0.5 * (lo + hi)
        if frame_turn(a, at(mid)) <= bound:
            lo = mid
        else:
            hi = mid
    while lo > 1e-3:
        pose = at(lo)
        if generator.key_clear(pose) and generator.transition_problem(a, pose) is None:
            return pose
        lo *= 0.5
    return None


def chase_step(generator: ConfigurationGenerator, previous: Pose, target, steps: int,
               fps: float = 24.0, strict: bool = False):
    """One frame of a chase: a best-first search from ``previous`` toward ``target``
    (canonical) with ``Settings.chase_nodes_per_frame`` nodes, stopping ``steps`` steps
    along. The hand is kept continuous; where that does not reach the target and a search
    with the hand free does, or where it is stuck (not half a step nearer) and the free one
    gets a step nearer, the free one is taken (it is not run where neither can happen: the
    kept hand got half a step nearer and the target is farther than the frame's steps
    reach). The pose committed is the farthest along
    the path (at most ``steps``) that the arm and hand reach clear as the keys interpolate
    (:meth:`ConfigurationGenerator.transition_problem`) and, unless that pose is on the
    target, whose hand has turned (its roll included,
    :func:`~reach_addon.core.arm.frame_turn`) no more than the hand turn speed in space
    allows in a frame at ``fps``. (The hand pass
    then smooths the hand and reports what it could not). Returns (the pose committed,
    the search result, with the nodes of both searches counted). Where even the first pose
    along the path touches something as the keys interpolate, the arm holds its pose for
    the frame if that pose is clear (a chase may fall behind; it does not pass through
    anything to keep up), and the search with the hand free is tried as where the kept one
    is stuck; an obstacle that moved into the pose itself is left by the first step.

    ``strict`` (where the hand pass found it could not keep the hand within its bound,
    :func:`chase_steps`): the turn is bounded on the target too,
    and where even the first pose along the path turns the hand (with the search's own
    wrist angles) faster than the bound, the frame takes part of the way to it
    (:func:`part_way`); the chase then falls behind rather than turn the hand faster than
    the bound (the wrist's angles alone could not make up for an arm turning too fast over
    several frames in a row)."""
    s = generator.settings
    view = generator.for_reach(previous, target, fit_chest=False)
    turn = s.hand_space_turn_speed / fps       # the hand's whole turn in a frame, roll too
    results = []
    stuck = False
    for continuity in (True, False):
        searcher = BestFirstSearch(view, previous, target,
                                   node_budget=s.chase_nodes_per_frame,
                                   stall_budget=s.chase_nodes_per_frame, depth_limit=steps,
                                   hand_continuity=continuity)
        searcher.run()
        result = searcher.result()
        # the frame's pose: as far along as the wrist may go, but no farther than the
        # arm and hand can get to straight, as the keys interpolate (else the chase slows)
        k = min(steps, len(result.path) - 1)
        while k > 1 and view.transition_problem(previous, result.path[k]) is not None:
            k -= 1
        if k == 1 and view.transition_problem(previous, result.path[1]) is not None and \
                view.key_clear(previous):
            k = 0                                  # the arm holds for the frame
            result.held = True
        on_target = result.success and k == len(result.path) - 1
        if not on_target or strict:
            # while catching up, the hand turns (roll included) no faster than the limit:
            # the farthest pose along the path that keeps to it; on the target, keeping to
            # it wins (unless strict)
            while k > 1 and frame_turn(previous, result.path[k]) > turn:
                k -= 1
        pose = result.path[k]
        if strict and k > 0 and frame_turn(previous, pose) > turn + TURN_ROUND_OFF:
            pose = part_way(view, previous, pose, turn)
            if pose is None:
                k, pose, result.held = 0, previous, True
        if pose is result.path[0]:
            # a pose of its own (the frames' caches are kept by the poses' identities)
            pose = replace(pose)
        results.append((math.dist(pose.wrist.tolist(), result.target.tolist()), pose, result))
        if result.success and k > 0:
            break
        if continuity:
            # The free search is taken only where it reaches the target or where the kept
            # hand is stuck; it cannot reach a target farther than its steps go (each
            # move carries the wrist a step at most), so it runs only where one can be.
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
    return pose, result


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
    arm, s = first.arm, first.settings
    start = first.generator.config_pose(task.start, task.start_hand)
    require_finite("start pose", start.joints)
    way_out, failed = first.start_escape(task, start)
    if failed is not None:
        failed.stats.planning_time_s = time.perf_counter() - t0
        return failed
    length = arm.arm_length
    steps = chase_steps_per_frame(s, task.fps)
    trajectory = arm.to_canonical_points(task.targets)
    poses = [start] + escape_frames(way_out, steps, len(trajectory),
                                    s.hand_space_turn_speed / task.fps)
    lead = len(poses)
    frames: list = []       # per chased frame: (its search result, its pose's contact)
    strict_from = len(trajectory)
    loose = (None, None, None, False)   # the first, loose chase: poses, frames, hand, caught
    while True:
        for f in range(lead + len(frames), len(trajectory)):
            if chunk and f % chunk == 0:
                yield f / len(trajectory), f"chasing '{task.name(0)}': frame {f}"
            gen = planners[f].generator
            nxt, res = chase_step(gen, poses[-1], trajectory[f], steps, task.fps,
                                  strict=f >= strict_from)
            poses.append(nxt)
            contact = gen.checker.first_hit(arm.to_world_points(nxt.joints)) \
                if planners[f] is not planners[f - 1] else None
            frames.append((res, contact))
        hand = plan_hand([p.generator for p in planners], poses, task.fps, may_insert=False,
                         arcs=range(len(poses)), escape=escape_of(way_out, poses))
        # where the hand pass could not keep the hand within its bound (the forearm itself
        # turned too fast), the chase is planned again from that frame on, strictly
        bound = s.hand_space_turn_speed / task.fps + TURN_ROUND_OFF
        late = next((k + 1 for k in range(lead - 1, len(poses) - 1)
                     if frame_turn(hand.poses[k], hand.poses[k + 1]) > bound), None)
        caught = float(np.linalg.norm(poses[-1].wrist - trajectory[-1])) <= \
            s.goal_tolerance * length
        if strict_from < len(trajectory) and not caught and loose[3]:
            # the strict chase falls behind and misses the target at the end where the
            # loose one caught it: catching the target wins (its over-bound turns reported)
            poses, frames, hand = loose[:3]
            break
        if late is None or late >= strict_from:
            break
        if strict_from == len(trajectory):
            loose = (list(poses), list(frames), hand, caught)
        strict_from = late
        del poses[late:], frames[late - lead:]
    poses = hand.poses
    path = [p.wrist for p in poses]
    stats = Stats()
    held = sum(res.held for res, _c in frames)
    stats.nodes_searched = sum(res.nodes_searched for res, _c in frames)
    stats.search_time_s = sum(res.search_time_s for res, _c in frames)
    stats.nodes_in_solution = sum(min(steps, len(res.path) - 1) for res, _c in frames) + 1
    on_target = sum(float(np.linalg.norm(p.wrist - trajectory[f])) <= s.goal_tolerance * length
                    for f, p in enumerate(poses) if f >= lead)
    hit = next(((lead + i, c) for i, (_r, c) in enumerate(frames) if c is not None), None)
    stats.path_length_arm_lengths = float(
        np.linalg.norm(np.diff(np.array(path), axis=0), axis=1).sum()) / length
    motion_stats(stats, arm, poses, [p.generator.checker for p in planners],
                 stats.path_length_arm_lengths, hand=hand)
    gap = float(np.linalg.norm(poses[-1].wrist - trajectory[-1])) / length
    name = task.name(0)
    last = planners[-1]
    if hit is not None:
        f, (part, obstacle) = hit
        reason, message = START_IN_COLLISION, (
            f"'{obstacle}' moves into the arm (at the {part}) on frame {f} of the chase of "
            f"'{name}' and no clear pose was found; change the obstacle's motion or the "
            "chase speed limit")
    elif gap <= s.goal_tolerance:
        reason, message = None, f"caught '{name}' ({on_target} of {len(poses) - 1} frames on target)"
    else:
        diagnosis = last.generator.diagnose_target(trajectory[-1])
        fake = SearchResult(False, NO_PATH, [], stats.nodes_searched, 0.0, gap * length,
                            trajectory[-1])
        reason, message = last.explain_failure(name, fake, diagnosis, start)
        if reason == NO_PATH:
            message = (f"the wrist did not catch '{name}' by the last frame ({gap:.2f} arm "
                       "lengths behind)")
            message += (f": on {held} frame(s) the arm held still where its next step would "
                        "have touched an obstacle as the keys interpolate; slow the target "
                        "there or give the arm more room" if held else
                        "; raise the chase speed limit or the nodes per frame")
    seg = Segment(0, name, task.targets[-1], reason is None, reason, message, 0,
                  len(poses) - 1, stats, arm.to_world_points(np.array(path)), np.zeros((0, 3)),
                  "chase")
    total = Stats()
    total.add(stats)
    total.frames = len(poses)
    total.planning_time_s = time.perf_counter() - t0
    return Plan(task, arm, s, poses, [seg], total, first.built_workspace)


def escape_frames(way_out, steps_per_frame: int, frames: int, turn: float = math.inf) -> list:
    """The frames of a chase that leave a start in contact (:mod:`~reach_addon.core.contact`):
    from each frame's pose, the farthest pose of the escape at most ``steps_per_frame``
    steps on to which the hand turns (roll included) no more than ``turn`` degrees, at
    least the next one (its last included), at most ``frames`` - 1 of them; none without
    one. (Taking every ``steps_per_frame``-th pose turned the hand 24° in a frame.)"""
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

