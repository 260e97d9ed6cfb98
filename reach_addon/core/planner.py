"""The planner: every task's one entry point (:meth:`Planner.plan`, :func:`plan`), and the
one search with its fallbacks that every reach runs (:meth:`Planner.route_steps`).

A :class:`Planner` holds one arm, one set of obstacles and one :class:`Settings`, and
keeps what can be reused between plans (the configuration generator, the workspace grid).
A reach: the start leaves any contact (:mod:`~reach_addon.core.contact`), the search finds
a path of wrist positions (:mod:`~reach_addon.core.search`, then
:mod:`~reach_addon.core.sampling`), and the motion is smoothed, timed
(:mod:`~reach_addon.core.motion`) and given its hand (:mod:`~reach_addon.core.hand`). A
chase goes to :func:`~reach_addon.core.chase.chase_steps`. The same task, arm, obstacles
and settings always give the same poses. A target that cannot be reached fails with one of
:data:`~reach_addon.core.errors.REASONS` (:mod:`~reach_addon.core.failure`) and carries the
closest-approach motion, clear of everything.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from .arm import ArmModel, Pose
from .chase import chase_steps
from .collision import Obstacles
from .contact import bone_touches, depth_message, escape, line_escape, start_clearance
from .diagnosis import diagnose_target
from .elbow import relax_elbow
from .errors import NO_PATH, START_HELD, START_IN_COLLISION, require_finite
from .failure import explain_failure
from .generator import ConfigurationGenerator
from .hand_shape import world_pose
from .hand import HandReport, plan_hand
from .motion import auto_duration, limb_turn, shortcut, time_path, wrist_path_length
from .motion_check import first_contact, motion_stats, pose_clearances
from .orient import apply_roll, goal_for, pose_error
from .results import Plan, Route, Segment, Stats
from .sampling import sampling_steps
from .search import BestFirstSearch, SearchResult
from .settings import Settings
from .steps import drain, relay
from .tasks import Task
from .workspace import Workspace, build_workspace, workspace_steps

#: :meth:`Planner.route_steps`' ``diagnosis`` when the caller has not diagnosed the target.
UNDIAGNOSED = object()


class Planner:
    """Plans tasks for one arm among one set of obstacles, keeping what can be reused
    between plans (the configuration generator and the workspace grid)."""

    def __init__(self, arm: ArmModel, obstacles: Obstacles | None, settings: Settings | None = None):
        self.obstacles = obstacles if obstacles is not None else Obstacles(None)
        self.settings = settings if settings is not None else Settings()
        if arm.hand_shape and not self.settings.hand_as_skinned:
            arm = dataclasses.replace(arm, hand_shape=())     # the axis capsule instead
        self.arm = arm
        self.generator = ConfigurationGenerator(arm, self.obstacles, self.settings)
        self._workspace: Workspace | None = None

    @property
    def workspace(self) -> Workspace:
        """The workspace grid, built on first use."""
        if self._workspace is None:
            self._workspace = build_workspace(self.generator)
        return self._workspace

    @property
    def has_workspace(self) -> bool:
        return self._workspace is not None

    @property
    def built_workspace(self) -> Workspace | None:
        """The workspace grid if it has been built, else None (never builds it)."""
        return self._workspace

    def line_clear(self, a, b) -> bool:
        """Is the straight line between wrist positions ``a`` and ``b`` (canonical) clear
        of the obstacles by a forearm's thickness (and the clearance)?"""
        p, q = self.arm.to_world_points(np.array([a, b], dtype=float))
        return self.generator.checker.capsule_clear(p, q, self.arm.forearm_radius)

    # --- searching ---------------------------------------------------------------------
    def searcher(self, start: Pose, target_c, guided: bool = False, **limits) -> BestFirstSearch:
        """A resumable best-first search from ``start`` toward ``target_c`` (canonical),
        through the workspace's guiding nodes if ``guided`` (the grid must be built for
        that: :attr:`workspace` or :meth:`workspace_steps`)."""
        guides, radius = None, 0.0
        if guided:
            ws = self.workspace
            guides = ws.guiding_nodes(start.wrist, target_c)
            radius = self.settings.guide_radius * float(np.min(ws.cell))
        generator = self.generator.for_reach(start, target_c)
        return BestFirstSearch(generator, start, target_c, guides, radius, **limits)

    def search_steps(self, start: Pose, target_c, guided: bool = False, chunk: int = 0,
                     keep=None, **limits):
        """One best-first search (canonical target), through guiding nodes if ``guided``, as a
        generator: yields the nodes searched so far every ``chunk`` nodes (never, if 0) and
        returns the :class:`SearchResult`. ``keep`` (if given) is
        called with the :class:`BestFirstSearch` before it runs (live mode keeps it, to
        resume from its progress when the target moves)."""
        searcher = self.searcher(start, target_c, guided, **limits)
        if keep is not None:
            keep(searcher)
        while not searcher.run(chunk or None):
            yield searcher.nodes_searched
        return searcher.result()

    def workspace_steps(self, chunk: int | None = 8):
        """:attr:`workspace` as a generator (yields 0 between slices of the grid's work;
        nothing if it is built already), returning the :class:`Workspace`."""
        if self._workspace is None:
            self._workspace = yield from relay(workspace_steps(self.generator, chunk or None),
                                               lambda _: 0)
        return self._workspace

    def route_steps(self, start: Pose, target_c, guided: bool = False, chunk: int = 0,
                    diagnosis=UNDIAGNOSED, keep=None):
        """Find a path from ``start`` to ``target_c`` (canonical) the way every reach does
        (the reach task and live mode alike): a best-first search, straight or through the
        guiding nodes (``guided``, or ``Settings.guide_when_blocked`` with the straight line
        blocked); then, if that fails, the other route (``Settings.guided_fallback``), the
        hand left free with what is left of the node budget, and the sampling planner
        (``Settings.sampling_fallback``). A target diagnosed unreachable
        (:func:`~reach_addon.core.diagnosis.diagnose_target`) gets only the searches, each on a
        shorter leash (``stall_budget / 4``). A generator: yields the nodes searched every
        ``chunk`` nodes (and between slices of the grid) and returns a :class:`Route`. The
        count yielded is the route's so far, every search of it together: it never falls.

        ``diagnosis``: the target's, if the caller has it; else (:data:`UNDIAGNOSED`) it is
        worked out only when needed: after the first slice of the search, which restarts
        on the shorter leash if the target is unreachable."""
        s, gen = self.settings, self.generator
        run = _Searches(self, start, target_c, chunk, keep)
        blocked = not guided and s.guide_when_blocked and not self.line_clear(start.wrist, target_c)
        if blocked and diagnosis is UNDIAGNOSED:
            diagnosis = diagnose_target(gen, target_c)
        if blocked and diagnosis is None:
            guided = True           # the paper's guiding nodes lead round what is in the way
        if guided:
            yield from run.workspace()
        result, diagnosis, limits = yield from self._first_search(run, guided, diagnosis)
        run.spent = result.nodes_searched
        if not result.success and diagnosis is None and s.guided_fallback:
            # the other route, the hand still continuous
            if not guided:
                yield from run.workspace()
            retry = yield from run.search(not guided)
            result = _better(result, retry)
            run.spent = result.nodes_searched
        left = s.node_budget - result.nodes_searched
        if not result.success and left > 0:
            # the hand free, with what is left of the node budget
            free = yield from run.search(guided, hand_continuity=False,
                                         **{**limits, "node_budget": left})
            result = _better(result, free, gen.step_length)
            run.spent = result.nodes_searched
        sampled = bool(not result.success and diagnosis is None and s.sampling_fallback)
        if sampled:
            result = yield from run.counted(self._sampling(start, target_c, chunk, result))
        return Route(result, None if diagnosis is UNDIAGNOSED else diagnosis, sampled)

    def _first_search(self, run: _Searches, guided: bool, diagnosis):
        """The first search of :meth:`route_steps` (a generator like it), on the shorter
        leash for a target diagnosed unreachable. An :data:`UNDIAGNOSED` target is diagnosed
        after the first slice (the search restarts on the leash if it is unreachable) and
        again if the search fails. Returns (the search's result, the diagnosis, the limits
        the search ran with)."""
        gen = self.generator
        leash = {"stall_budget": max(20, self.settings.stall_budget // 4)}
        limits = {} if diagnosis in (None, UNDIAGNOSED) else leash
        steps = run.search(guided, **limits)
        if diagnosis is not UNDIAGNOSED:
            result = yield from steps
            return result, diagnosis, limits
        try:
            nodes = next(steps)
        except StopIteration as done:
            result = done.value
        else:
            diagnosis = diagnose_target(gen, run.target_c)
            if diagnosis is not None:
                steps.close()
                limits = leash
                steps = run.search(guided, **limits)
            yield nodes
            result = yield from steps
        if not result.success:
            diagnosis = diagnose_target(gen, run.target_c)
        return result, diagnosis, limits

    # --- tasks -------------------------------------------------------------------------
    def plan(self, task: Task) -> Plan:
        """Plan ``task`` from its start configuration (see the module docstring)."""
        return drain(self.plan_steps(task))

    def plan_steps(self, task: Task, chunk: int = 50):
        """:meth:`plan` as a generator, for callers that must stay responsive (a modal
        operator, live mode): it yields ``(fraction done, what it is doing)`` every
        ``chunk`` searched nodes and between stages, and returns the :class:`Plan`. The
        plan is the same however it is consumed."""
        if task.kind == "chase":        # every frame against the same obstacles
            return (yield from chase_steps([self] * len(task.targets), task, 1 if chunk else 0))
        t0 = time.perf_counter()
        start = self.generator.config_pose(task.start, task.start_hand)
        require_finite("start pose", start.joints)
        plan = yield from self._reaches(task, start, task.kind == "guided", chunk)
        plan.stats.planning_time_s = time.perf_counter() - t0
        return plan

    def _start_failure(self, task: Task, start: Pose, problem, msg: str | None = None,
                       reason: str = START_IN_COLLISION) -> Plan:
        part, obstacle = problem
        if msg is None and part == "sternum":
            # the body's root is enclosed: a room or box round the character, or a solid
            # through its chest; parity counts all of a closed mesh's inside as solid
            msg = (f"the character's chest (sternum) is enclosed by the mesh '{obstacle}', "
                   "and Reach counts everything a mesh encloses as solid; if it is a "
                   f"room or box round the character, leave '{obstacle}' out of the obstacles "
                   "(plan against an obstacle collection without it) or delete a face the "
                   "arm cannot touch (an open mesh encloses nothing); if it "
                   "passes through the chest, move the character out of it")
        msg = msg or (f"the start pose already touches '{obstacle}' (at the {part}); move the "
                      "arm or the obstacle apart, or lower the clearance, before planning")
        segs = [Segment(i, task.name(i), task.targets[i], False, reason, msg, 0, 0,
                        Stats(), np.zeros((0, 3)), np.zeros((0, 3)))
                for i in range(1 if task.kind == "chase" else len(task.targets))]
        return Plan(task, self.arm, self.settings, [start], segs, Stats(frames=1))

    def start_escape(self, task: Task, start: Pose):
        """(None, None) if the start is clear; (Escape, None) for a start in contact that
        moves out of it (:mod:`~reach_addon.core.contact`); (None, failed Plan) if the
        start is too deep or finds no way out."""
        gen = self.generator
        problem = gen.start_problem(start)
        if problem is None:
            return None, None
        part, obstacle = problem
        if part == "sternum":
            return None, self._start_failure(task, start, problem)
        length = self.arm.arm_length
        depth = -start_clearance(gen, start) / length
        limit = self.settings.start_contact_depth
        world = world_pose(self.arm, start)
        axis = [world[a] + t * (world[b] - world[a]) for a, b in ((1, 2), (2, 3), (3, 4))
                for t in (0.0, 0.5, 1.0)]
        how = None
        if any(self.obstacles.point_inside(p) for p in axis):
            depth = math.inf                     # a joint inside a closed obstacle
        elif depth > 0.0 and bone_touches(gen.checker, world):
            # a bone itself through an obstacle's surface: no depth of its capsule's measure
            # tells which way is out (through a thin plane every way is as deep)
            depth, how = math.inf, "bone-deep in"
        if depth > limit:
            return None, self._start_failure(task, start, problem,
                                             depth_message(obstacle, part, depth, limit, how))
        way_out = escape(gen, start, obstacle,
                         target=self.arm.to_canonical_points(np.asarray(task.targets[0], float)))
        if way_out is None:
            if depth <= 0.0:
                # nearer than the clearance, not touching: what holds the arm, not a contact
                cm = 100.0 * -depth * length * self.arm.metres_per_unit
                return None, self._start_failure(task, start, problem, (
                    f"the arm cannot move from its start pose: its {part} is {cm:.1f} cm "
                    f"({-depth:.3f} arm lengths) from '{obstacle}', nearer than the clearance "
                    f"({gen.checker.margin / length:g} arm lengths), and no step takes it farther "
                    f"from '{obstacle}'; move the arm or '{obstacle}' apart, or lower the "
                    "clearance"), START_HELD)
            return None, self._start_failure(task, start, problem)
        return way_out, None

    def _reaches(self, task: Task, start: Pose, guided: bool, chunk: int):
        way_out, failed = self.start_escape(task, start)
        if failed is not None:
            return failed
        poses = [start]
        segments = []
        total = Stats()
        n = len(task.targets)
        goals = [None] * n
        if self.settings.match_orientation and task.orientations is not None:
            goals = [goal_for(self.arm, self.settings, start, r, task.start_palm,
                              task.start_fingers)
                     for r in task.orientations]
        for i, target in enumerate(task.targets):
            steps = self._reach_segment(task, i, poses[-1], target, guided,
                                        frame_start=len(poses) - 1, chunk=chunk,
                                        way_out=way_out if i == 0 else None, goal=goals[i])
            seg, seg_poses = yield from _progress(steps, i, n, task.name(i))
            if i == 0 and way_out is not None and seg.reason == NO_PATH:
                # a start in contact whose way out led nowhere: straight lines out
                # toward the target, over the chest's range (contact.line_escape)
                other = line_escape(self.generator, start, way_out.obstacle,
                                    self.arm.to_canonical_points(np.asarray(target, float)))
                if other is not None:
                    steps = self._reach_segment(task, i, start, target, guided, frame_start=0,
                                                chunk=chunk, way_out=other, goal=goals[i])
                    again, again_poses = yield from _progress(steps, i, n, task.name(i))
                    if again.success:
                        _count_search(again.stats, seg.stats)   # the first try's too
                        seg, seg_poses = again, again_poses
            poses += seg_poses[1:]
            segments.append(seg)
            total.add(seg.stats)
        total.frames = len(poses)
        return Plan(task, self.arm, self.settings, poses, segments, total,
                    self._workspace)

    def _reach_segment(self, task: Task, i: int, start: Pose, target_w, guided: bool,
                       frame_start: int, chunk: int = 0, way_out=None, goal=None):
        """One target's reach from ``start``; with ``way_out`` (an
        :class:`~reach_addon.core.contact.Escape` from ``start``) the search starts where
        the escape ends and the motion leads with it; with ``goal`` (an
        :class:`~reach_addon.core.orient.OrientGoal`) the hand arrives oriented."""
        s, arm, gen = self.settings, self.arm, self.generator
        first = start
        if way_out is not None:
            start = way_out.poses[-1]
        length = arm.arm_length
        name = task.name(i)
        target = arm.to_canonical_points(target_w)
        stats = Stats()
        had_workspace = self.has_workspace
        diagnosis = diagnose_target(gen, target)

        route = yield from self.route_steps(start, target, guided, chunk, diagnosis)
        result, sampled = route.result, route.sampled
        if self.has_workspace and not had_workspace:
            stats.preprocess_time_s = self._workspace.build_time_s

        seg_poses, hand, wrist_length, smoothed = self._motion(task, result, first, start,
                                                               target, way_out, goal)
        clearances = pose_clearances(arm, seg_poses, [gen.checker] * len(seg_poses))
        contact = first_contact(gen, seg_poses, hand, clearances, way_out is not None) \
            if result.success else None
        if contact is not None and smoothed is not None:
            # the elbow kept low cannot follow clear at every instant: the search's swivels
            seg_poses, hand, wrist_length, _s = self._motion(task, result, first, start,
                                                             target, way_out, goal, smoothed)
            clearances = pose_clearances(arm, seg_poses, [gen.checker] * len(seg_poses))
            contact = first_contact(gen, seg_poses, hand, clearances, way_out is not None)
        if contact is not None and s.sampling_fallback and not sampled:
            # The search's path is clear, but the hand cannot follow it clear at every
            # instant (a hand the search left free flips between samples in a tight
            # place): the sampling planner keeps the hand continuous and checked.
            retry = yield from self._sampling(start, target, chunk, result)
            if retry.method == "sampling":
                result = retry
                seg_poses, hand, wrist_length, _s = self._motion(task, result, first, start,
                                                                 target, way_out, goal)
                clearances = pose_clearances(arm, seg_poses, [gen.checker] * len(seg_poses))
                contact = first_contact(gen, seg_poses, hand, clearances, way_out is not None)

        stats.search_time_s = result.search_time_s
        stats.nodes_searched = result.nodes_searched
        stats.sampling_states = result.states_tested
        stats.nodes_in_solution = result.nodes_in_solution
        stats.path_length_arm_lengths = result.path_length() / length

        success, reason, message = result.success, None, f"reached '{name}'"
        if result.method == "sampling":
            message += " (sampling planner: the best-first search found no way in)"
        if not result.success:
            reason, message = self.explain_failure(name, result, diagnosis, start)
        elif contact is not None:
            # never call a motion that touches something a success: keep the frames
            # before the first contact as the closest approach, and say so
            frame, depth = contact
            success, reason = False, NO_PATH
            message = (f"found a path to '{name}' but the {depth[0]} cannot follow it clear "
                       f"of '{depth[1]}' (from frame {frame} of the reach); try a smaller "
                       "clearance, a larger sampling budget, or move the obstacle")
            seg_poses = seg_poses[:max(1, frame)]
            hand.poses = seg_poses
            hand.unclear_transitions = [k for k in hand.unclear_transitions
                                        if k < len(seg_poses) - 1]
        self._motion_stats(stats, seg_poses, wrist_length, hand, clearances[:len(seg_poses)])
        if goal is not None:
            stats.orientation_error_deg = pose_error(seg_poses[-1], goal)
            stats.orientation_met = stats.orientation_error_deg <= goal.tolerance
        seg = Segment(i, name, np.asarray(target_w, float), success, reason, message,
                      frame_start, frame_start + len(seg_poses) - 1, stats,
                      arm.to_world_points(np.array([p.wrist for p in result.path])),
                      arm.to_world_points(result.guides) if len(result.guides) else np.zeros((0, 3)),
                      result.method)
        return seg, seg_poses

    def _sampling(self, start: Pose, target, chunk: int, result: SearchResult):
        """The sampling planner (:mod:`~reach_addon.core.sampling`) from ``start``: its
        result if it finds a path, else ``result``; the counts of both are kept."""
        view = self.generator.for_reach(start, target)
        # a search path that reached the target (the hand could not follow it clear) is
        # repaired; a closest approach is not followed (its end is a dead end the trees
        # would crowd into)
        seed = result.path if result.success and len(result.path) > 1 else ()
        # states are cheaper than searched positions: ten count as one
        sampled = yield from relay(sampling_steps(view, start, target, chunk, seed, bool(seed)),
                                   lambda states: states // 10)
        if sampled.success:
            sampled.states_tested = sampled.nodes_searched
            sampled.nodes_searched = result.nodes_searched
            sampled.search_time_s += result.search_time_s
            return sampled
        result.states_tested += sampled.nodes_searched
        result.search_time_s += sampled.search_time_s
        return result

    def _motion(self, task: Task, result: SearchResult, first: Pose, start: Pose, target,
                way_out, goal=None, smoothed=None):
        """The frames of one reach along a search's path: shortcut smoothing, the elbow
        kept low along it (:func:`~reach_addon.core.elbow.relax_elbow`), minimum-jerk
        timing and the hand pass (with ``goal``, the hand sought toward that orientation
        and the palm rolled to it, :mod:`~reach_addon.core.orient`; a roll the reach starts
        with is carried). ``smoothed``: the smoothed path to time as it is (the elbow not
        relaxed). Returns (poses, the hand pass's report, the wrist's path length in arm
        lengths, the smoothed path the elbow pass changed, else None)."""
        s, length = self.settings, self.arm.arm_length
        gen = self.generator.for_reach(start, target)
        changed = None
        if smoothed is not None:
            dense = smoothed
        elif result.method == "sampling":
            # a sampled path is already shortcut in joint space (its poses are not the IK's,
            # so the wrist-space shortcuts could only join them one by one)
            dense = list(result.path)
        else:
            smooth = shortcut(gen, result.path) if s.smoothing else list(result.path)
            dense = relax_elbow(gen, smooth)
            changed = smooth if dense is not smooth else None
        lead = [] if way_out is None else way_out.poses[:-1]
        dense = lead + dense
        wrist_length = wrist_path_length(dense) / length
        if len(dense) < 2:
            seg_poses, arcs, sampler = [first], [0.0], None
        else:
            duration = task.duration_s or auto_duration(wrist_length, s)
            frames = max(2, int(round(duration * task.fps)) + 1)
            seg_poses, arcs, sampler = time_path(gen, dense, frames)
            # an automatic duration is stretched where a limb would turn faster than
            # limb_turn_speed at the peak (an elbow swinging round a short wrist path), up
            # to twice; again while it still does, as the turn need not scale with the
            # frames (a path's poses far apart in joint space move unevenly between them)
            bound = s.limb_turn_speed / task.fps
            most = 2 * frames
            turn = limb_turn(seg_poses)
            while task.duration_s is None and turn > bound and frames < most:
                frames = min(most, int(math.ceil(frames * turn / bound)))
                seg_poses, arcs, sampler = time_path(gen, dense, frames)
                turn = limb_turn(seg_poses)
        loose = None if way_out is None or sampler is None else \
            (way_out.generator, float(sampler.cum[len(lead)]))
        hand = plan_hand(gen, seg_poses, task.fps, arcs=arcs, sampler=sampler, escape=loose,
                         goal=goal)
        if goal is not None or first.roll:
            apply_roll(hand, first.roll, goal, s.hand_space_turn_speed / task.fps)
        return hand.poses, hand, wrist_length, changed

    def explain_failure(self, name: str, result: SearchResult, diagnosis, start: Pose):
        """(reason, message) of a failed reach: :func:`~reach_addon.core.failure.explain_failure`
        with this planner's generator."""
        return explain_failure(self.generator, name, result, diagnosis, start)

    def _motion_stats(self, stats: Stats, poses, motion_length: float,
                      hand: HandReport | None = None, clearances=None):
        motion_stats(stats, self.arm, poses, [self.generator.checker] * len(poses),
                     motion_length, self.settings.wing_margin, hand, clearances)


class _Searches:
    """The searches of one route (:meth:`Planner.route_steps`) from ``start`` toward
    ``target_c``, their progress counted together: each yields the nodes of the searches
    before it (:attr:`spent`, which the route sets) plus its own."""

    def __init__(self, planner: Planner, start: Pose, target_c, chunk: int, keep):
        self.planner, self.start, self.target_c = planner, start, target_c
        self.chunk, self.keep = chunk, keep
        self.spent = 0

    def counted(self, steps):
        """``steps`` (a generator yielding its own node count) counted with the route's."""
        return relay(steps, lambda nodes: self.spent + nodes)

    def search(self, guided: bool, **limits):
        """One best-first search (:meth:`Planner.search_steps`), counted."""
        return self.counted(self.planner.search_steps(self.start, self.target_c, guided,
                                                      self.chunk, self.keep, **limits))

    def workspace(self):
        """The workspace grid's slices (:meth:`Planner.workspace_steps`), counted."""
        return self.counted(self.planner.workspace_steps(self.chunk))


def _better(result: SearchResult, retry: SearchResult, margin: float = 0.0) -> SearchResult:
    """The result a route keeps after ``retry`` (a fallback search run after ``result``):
    the retry if it reaches the target or ends more than ``margin`` (figure units) nearer
    it, else ``result``; either way with the nodes and search time of both."""
    retry.nodes_searched += result.nodes_searched
    retry.search_time_s += result.search_time_s
    if retry.success or retry.closest_distance < result.closest_distance - margin:
        return retry
    result.nodes_searched, result.search_time_s = retry.nodes_searched, retry.search_time_s
    return result


def _count_search(stats: Stats, tried: Stats) -> None:
    """Add to ``stats`` the search effort of an attempt ``tried`` that was not kept."""
    for name in ("nodes_searched", "search_time_s", "sampling_states", "preprocess_time_s"):
        setattr(stats, name, getattr(stats, name) + getattr(tried, name))


def _progress(steps, index: int, count: int, name: str):
    """Re-yield a segment's search progress as (fraction of the whole task, message)."""
    return relay(steps, lambda nodes: ((index + min(0.95, nodes / 2000.0)) / count,
                                       f"reaching '{name}': {nodes} positions"))


def plan(task: Task, arm: ArmModel, obstacles: Obstacles | None, settings: Settings | None = None,
         planner: Planner | None = None) -> Plan:
    """Plan one task: the pipeline's single entry into the core. Pass ``planner`` to reuse
    its workspace and generator across plans (same arm, obstacles and settings)."""
    if planner is None:
        planner = Planner(arm, obstacles, settings)
    return planner.plan(task)

