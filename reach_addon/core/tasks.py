"""The four reach tasks of the paper, and the one entry point every caller uses: :func:`plan`.

* ``reach`` — collision-free reach: best-first search straight toward one target, or,
  where an obstacle lies across the straight line from the wrist to the target and
  ``Settings.guide_when_blocked`` is on, through the workspace's guiding nodes (the
  paper's guided search: a straight best-first search would fill the space in front of
  the obstacle before it found the way round; on a plate across the line it tested 1242
  positions and stalled, where the guided one needed 76). If that finds no path (and the
  target is not out of reach or inside an obstacle) and ``Settings.guided_fallback`` is
  on, the search is repeated the other way (straight after guided, guided after
  straight).
* ``sequence`` — rotation reach: several targets in order, each reach starting where the
  last ended; body rotation engages (Table 1) as the targets move round to the side.
* ``guided`` — guided reach: the search follows the guiding nodes of the workspace grid.
* ``chase`` — chase reach: the target moves along a given trajectory (one position per
  frame); each frame re-plans from the current pose with a node budget
  (``Settings.chase_nodes_per_frame``) and commits at most as many steps as the wrist
  speed limit allows (``Settings.chase_max_speed``).

Input targets are in **world space**; the returned poses are in the canonical arm frame
(``Plan.world_joints()`` gives world space). Everything is deterministic: the same task,
arm, obstacles and settings give the same poses.

Targets that cannot be reached are answered, not forced: the plan fails with one of
:data:`~reach_addon.core.errors.REASONS` — ``needs_lean``, ``needs_step`` or
``out_of_reach`` beyond the arm, ``target_in_obstacle``, ``arm_does_not_fit`` (free space
the arm or hand has no room in, by how much), ``no_path`` (after the best-first search and
the sampling fallback), ``start_in_collision`` — and carries the closest-approach motion,
clear of everything.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import ik
from .arm import ArmConfig, ArmModel, Pose, frame_turn
from .collision import Obstacles
from .contact import depth_message, escape, start_clearance
from .errors import (ARM_DOES_NOT_FIT, NEEDS_LEAN, NEEDS_STEP, NO_PATH, OUT_OF_REACH, START_HELD,
                     START_IN_COLLISION, TARGET_IN_OBSTACLE, ReachError, require_finite)
from .generator import ConfigurationGenerator
from .hand import HandReport, plan_hand
from .keys import between
from .motion import auto_duration, limb_turn, shortcut, time_path, wrist_path_length
from .orient import apply_roll, goal_for, pose_error
from .sampling import sampling_steps
from .search import (TURN_ROUND_OFF, BestFirstSearch, SearchResult, chase_step,
                     sphere_directions)
from .settings import Settings
from .steps import drain, relay
from .workspace import Workspace, build_workspace, workspace_steps

TASK_KINDS = ("reach", "sequence", "guided", "chase")

#: :meth:`Planner.route_steps`' ``diagnosis`` when the caller has not diagnosed the target.
UNDIAGNOSED = object()


class Route(NamedTuple):
    """What :meth:`Planner.route_steps` found: the search's (or the sampler's) result, the
    target's diagnosis (None: reachable, or not needed because the path was found) and
    whether the sampling planner ran."""

    result: SearchResult
    diagnosis: object
    sampled: bool


@dataclass(frozen=True)
class Task:
    """What to plan. ``targets``: world positions (k, 3) — one for ``reach``, one or more in
    order for ``sequence`` and ``guided``, one per frame for ``chase`` (frame 0 first).
    ``start``: the arm's configuration at the first frame. ``duration_s``: seconds per
    reach (None = from the path length, :func:`~reach_addon.core.motion.auto_duration`).
    ``names``: what the user calls each target (for messages). ``start_hand``: the wrist's
    two angles at the first frame (:func:`~reach_addon.core.arm.hand_angles`; the rig's
    own hand), which the motion starts from. ``orientations``: the targets' world rotations
    (k, 3, 3), for ``Settings.match_orientation`` (:mod:`~reach_addon.core.orient`; None:
    positions only). ``start_palm``: the palm's normal at the first frame (canonical; the
    rig's, :func:`~reach_addon.blender.rig.palm_normal`), None for the palm at forearm
    neutral; ``start_fingers``: the fingers' direction then (canonical; the wrist to the
    middle finger's knuckle, :func:`~reach_addon.blender.rig.finger_axis`), None for the
    hand's own direction."""

    kind: str
    targets: np.ndarray
    start: ArmConfig
    fps: float = 24.0
    duration_s: float | None = None
    names: tuple = ()
    start_hand: tuple = (0.0, 0.0)
    orientations: np.ndarray | None = None
    start_palm: np.ndarray | None = None
    start_fingers: np.ndarray | None = None

    def __post_init__(self):
        if self.kind not in TASK_KINDS:
            raise ReachError(f"unknown task '{self.kind}'; choose one of {', '.join(TASK_KINDS)}")
        targets = require_finite("target position", self.targets).reshape(-1, 3)
        if len(targets) == 0:
            raise ReachError(f"the {self.kind} task has no target; give at least one")
        if self.kind == "reach" and len(targets) != 1:
            raise ReachError("a reach task takes exactly one target; use 'sequence' for several")
        if self.kind == "chase" and len(targets) < 2:
            raise ReachError("a chase needs the target's position on at least two frames")
        object.__setattr__(self, "targets", targets)
        require_finite("start configuration", self.start.as_array())
        if not (self.fps > 0 and math.isfinite(self.fps)):
            raise ReachError(f"frame rate must be positive, got {self.fps}")
        if self.duration_s is not None and not (self.duration_s > 0):
            raise ReachError(f"duration must be positive seconds, got {self.duration_s}")
        if self.orientations is not None:
            rot = require_finite("target rotation", self.orientations).reshape(-1, 3, 3)
            if len(rot) != len(targets):
                raise ReachError(f"{len(rot)} target rotations for {len(targets)} targets; "
                                 "give one per target")
            object.__setattr__(self, "orientations", rot)
        if self.start_palm is not None:
            object.__setattr__(self, "start_palm", require_finite("palm normal", self.start_palm))
        if self.start_fingers is not None:
            object.__setattr__(self, "start_fingers",
                               require_finite("finger direction", self.start_fingers))

    def name(self, i: int) -> str:
        return self.names[i] if i < len(self.names) else f"target {i + 1}"


@dataclass
class Stats:
    """Table 2's statistics (first five fields) and more, for a segment or a whole plan.
    Lengths are in arm lengths."""

    search_time_s: float = 0.0
    preprocess_time_s: float = 0.0
    nodes_searched: int = 0
    nodes_in_solution: int = 0
    path_length_arm_lengths: float = 0.0
    motion_path_length_arm_lengths: float = 0.0
    frames: int = 0
    strength_categories: list = field(default_factory=lambda: [0, 0, 0])
    min_clearance_arm_lengths: float = math.inf
    planning_time_s: float = 0.0
    # the hand (core.hand): turns per frame relative to the forearm and in space, the
    # wrist's bend from neutral, frames added to slow through tight spots, and what the
    # pass could not bring within its bounds
    max_wrist_turn_deg_per_frame: float = 0.0
    max_hand_turn_deg_per_frame: float = 0.0
    mean_wrist_bend_deg: float = 0.0
    max_wrist_bend_deg: float = 0.0
    inserted_frames: int = 0
    unbounded_hand_turns: int = 0
    touching_transitions: int = 0
    # states the sampling fallback (core.sampling) tested, beyond the nodes searched
    sampling_states: int = 0
    # match orientation (core.orient): the angle left between the palm's frame and the
    # wanted one at the last frame, and whether it is within the tolerance (None: not asked)
    orientation_error_deg: float | None = None
    orientation_met: bool | None = None

    @property
    def mean_f_r(self) -> float:
        n = sum(self.strength_categories)
        return (self.strength_categories[1] + 2 * self.strength_categories[2]) / n if n else 0.0

    def add(self, other: Stats) -> None:
        n = self.frames + other.frames
        if n:
            self.mean_wrist_bend_deg = (self.mean_wrist_bend_deg * self.frames
                                        + other.mean_wrist_bend_deg * other.frames) / n
        for name in ("max_wrist_turn_deg_per_frame", "max_hand_turn_deg_per_frame",
                     "max_wrist_bend_deg"):
            setattr(self, name, max(getattr(self, name), getattr(other, name)))
        for name in ("inserted_frames", "unbounded_hand_turns", "touching_transitions",
                     "sampling_states",
                     "search_time_s", "preprocess_time_s", "nodes_searched",
                     "nodes_in_solution", "path_length_arm_lengths",
                     "motion_path_length_arm_lengths", "frames",
                     "planning_time_s"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.strength_categories = [a + b for a, b in
                                    zip(self.strength_categories, other.strength_categories)]
        self.min_clearance_arm_lengths = min(self.min_clearance_arm_lengths,
                                             other.min_clearance_arm_lengths)
        if other.orientation_error_deg is not None:       # the worst target's
            self.orientation_error_deg = max(self.orientation_error_deg or 0.0,
                                             other.orientation_error_deg)
            self.orientation_met = self.orientation_met is not False and bool(other.orientation_met)

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in self.__dataclass_fields__}
        d["mean_f_r"] = self.mean_f_r
        if math.isinf(d["min_clearance_arm_lengths"]):
            d["min_clearance_arm_lengths"] = None
        return d


@dataclass
class Segment:
    """One target's part of a plan: frames ``frame_start``..``frame_end`` (indices into
    ``Plan.poses``; the wrist arrives at the target on ``frame_end`` when successful)."""

    index: int
    name: str
    target: np.ndarray
    success: bool
    reason: str | None
    message: str
    frame_start: int
    frame_end: int
    stats: Stats
    search_path: np.ndarray       # world wrist positions of the searched solution path
    guiding_nodes: np.ndarray     # world positions
    #: what found the path: "best-first" (the paper's search) or "sampling" (the
    #: fallback of core.sampling); for a chase, "chase"
    method: str = "best-first"


@dataclass
class Plan:
    """Poses per frame (frame 0 = the start pose) + statistics + success / reason."""

    task: Task
    arm: ArmModel
    settings: Settings
    poses: list
    segments: list
    stats: Stats
    workspace: Workspace | None = None

    @property
    def success(self) -> bool:
        return all(s.success for s in self.segments)

    @property
    def reason(self) -> str | None:
        return next((s.reason for s in self.segments if not s.success), None)

    @property
    def message(self) -> str:
        failed = [s.message for s in self.segments if not s.success]
        if failed:
            return "; ".join(failed)
        return f"reached {len(self.segments)} target(s) in {len(self.poses)} frames"

    def world_joints(self) -> np.ndarray:
        """Joint positions per frame in world space, (frames, 5, 3) in JOINTS order."""
        return self.arm.to_world_points(np.array([p.joints for p in self.poses]))

    def world_bends(self) -> np.ndarray:
        """Forearm bend direction per frame in world space, (frames, 3)."""
        return self.arm.to_world_vectors(np.array([p.bend for p in self.poses]))

    def wrist_trajectory(self) -> np.ndarray:
        return self.world_joints()[:, 3]

    def search_path(self) -> np.ndarray:
        parts = [s.search_path for s in self.segments if len(s.search_path)]
        return np.concatenate(parts) if parts else np.zeros((0, 3))

    def guiding_nodes(self) -> np.ndarray:
        parts = [s.guiding_nodes for s in self.segments if len(s.guiding_nodes)]
        return np.concatenate(parts) if parts else np.zeros((0, 3))


class Planner:
    """Plans tasks for one arm among one set of obstacles, keeping what can be reused
    between plans (the configuration generator and the workspace grid)."""

    def __init__(self, arm: ArmModel, obstacles: Obstacles | None, settings: Settings | None = None):
        self.arm = arm
        self.obstacles = obstacles if obstacles is not None else Obstacles(None)
        self.settings = settings if settings is not None else Settings()
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
        (:meth:`ConfigurationGenerator.diagnose_target`) gets only the searches, each on a
        shorter leash (``stall_budget / 4``). A generator: yields the nodes searched every
        ``chunk`` nodes (and between slices of the grid) and returns a :class:`Route`. The
        count yielded is the route's so far, every search of it together: it never falls.

        ``diagnosis``: the target's, if the caller has it; else (:data:`UNDIAGNOSED`) it is
        worked out only when needed (live mode: most moves of the target are caught within
        the first slice, and the diagnosis costs a few ms) — after the first slice of the
        search, which restarts on the shorter leash if the target is unreachable."""
        s, gen = self.settings, self.generator
        leash = {"stall_budget": max(20, s.stall_budget // 4)}
        spent = [0]                     # nodes of the searches before the one running

        def counted(steps):
            return relay(steps, lambda nodes: spent[0] + nodes)

        def search(guided_, **limits_):
            return counted(self.search_steps(start, target_c, guided_, chunk, keep, **limits_))

        blocked = not guided and s.guide_when_blocked and not self.line_clear(start.wrist, target_c)
        if blocked and diagnosis is UNDIAGNOSED:
            diagnosis = gen.diagnose_target(target_c)
        if blocked and diagnosis is None:
            # something lies across the straight line: the paper's guiding nodes lead round
            # it (a straight best-first search would fill the space in front of it first)
            guided = True
        if guided:
            yield from counted(self.workspace_steps(chunk))
        limits = {} if diagnosis in (None, UNDIAGNOSED) else leash
        steps = search(guided, **limits)
        if diagnosis is UNDIAGNOSED:
            try:
                nodes = next(steps)
            except StopIteration as done:
                result = done.value
            else:
                diagnosis = gen.diagnose_target(target_c)
                if diagnosis is not None:
                    steps.close()
                    limits = leash
                    steps = search(guided, **limits)
                yield nodes
                result = yield from steps
            if not result.success:
                diagnosis = gen.diagnose_target(target_c)
        else:
            result = yield from steps
        spent[0] = result.nodes_searched
        if not result.success and diagnosis is None and s.guided_fallback:
            # The other route, the hand still continuous: through the guiding nodes after a
            # straight search, straight after a guided one (a guided search can pass every
            # guiding node and still stall in the last approach, which the straight one
            # makes from another side).
            if not guided:
                yield from counted(self.workspace_steps(chunk))
            retry = yield from search(not guided)
            retry.nodes_searched += result.nodes_searched
            retry.search_time_s += result.search_time_s
            if retry.success or retry.closest_distance < result.closest_distance:
                result = retry
            else:
                result.nodes_searched = retry.nodes_searched
                result.search_time_s = retry.search_time_s
            spent[0] = result.nodes_searched
        left = s.node_budget - result.nodes_searched
        if not result.success and left > 0:
            # The hand kept continuous can shut the search out of a way the arm has (a hand
            # caught in a pocket of clear directions): search once more with the hand free,
            # with what is left of the node budget, and keep that if it does better; the
            # hand pass then reports what it could not make smooth and clear.
            free = yield from search(guided, hand_continuity=False,
                                     **{**limits, "node_budget": left})
            free.nodes_searched += result.nodes_searched
            free.search_time_s += result.search_time_s
            if free.success or free.closest_distance < result.closest_distance - gen.step_length:
                result = free
            else:
                result.nodes_searched, result.search_time_s = free.nodes_searched, free.search_time_s
            spent[0] = result.nodes_searched
        sampled = False
        if not result.success and diagnosis is None and s.sampling_fallback:
            result = yield from counted(self._sampling(start, target_c, chunk, result))
            sampled = True
        return Route(result, None if diagnosis is UNDIAGNOSED else diagnosis, sampled)

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
                   "(plan against an obstacle collection without it) or delete the faces the "
                   "arm cannot touch (a mesh open on three sides encloses nothing); if it "
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
        world = self.arm.to_world_points(start.joints)
        axis = [world[a] + t * (world[b] - world[a]) for a, b in ((1, 2), (2, 3), (3, 4))
                for t in (0.0, 0.5, 1.0)]
        if any(self.obstacles.point_inside(p) for p in axis):
            depth = math.inf                     # a joint inside a closed obstacle
        if depth > limit:
            return None, self._start_failure(task, start, problem,
                                             depth_message(obstacle, part, depth, limit))
        way_out = escape(gen, start, obstacle)
        if way_out is None:
            if depth <= 0.0:
                # nearer than the clearance, not touching: what holds the arm, not a contact
                cm = 100.0 * -depth * length * self.arm.metres_per_unit
                return None, self._start_failure(task, start, problem, (
                    f"the arm cannot move from its start pose: its {part} is {cm:.1f} cm "
                    f"({-depth:.3f} arm lengths) from '{obstacle}', nearer than the clearance "
                    f"({self.settings.clearance:g} arm lengths), and no step takes it farther "
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
        diagnosis = gen.diagnose_target(target)

        route = yield from self.route_steps(start, target, guided, chunk, diagnosis)
        result, sampled = route.result, route.sampled
        if self.has_workspace and not had_workspace:
            stats.preprocess_time_s = self._workspace.build_time_s

        seg_poses, hand, wrist_length = self._motion(task, result, first, start, target, way_out,
                                                     goal)
        clearances = pose_clearances(arm, seg_poses, [gen.checker] * len(seg_poses))
        contact = first_contact(gen, seg_poses, hand, clearances, way_out is not None) \
            if result.success else None
        if contact is not None and s.sampling_fallback and not sampled:
            # The search's path is clear, but the hand cannot follow it clear at every
            # instant (a hand the search left free flips between samples in a tight
            # place): the sampling planner keeps the hand continuous and checked.
            retry = yield from self._sampling(start, target, chunk, result)
            if retry.method == "sampling":
                result = retry
                seg_poses, hand, wrist_length = self._motion(task, result, first, start,
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
                way_out, goal=None):
        """The frames of one reach along a search's path: shortcut smoothing, minimum-jerk
        timing and the hand pass (with ``goal``, the hand sought toward that orientation and
        the palm rolled to it, :mod:`~reach_addon.core.orient`; a roll the reach starts
        with is carried). Returns (poses, the hand pass's report, the wrist's path length
        in arm lengths)."""
        s, length = self.settings, self.arm.arm_length
        gen = self.generator.for_reach(start, target)
        # a sampled path is already shortcut in joint space (its poses are not the IK's, so
        # the wrist-space shortcuts could only join them one by one)
        dense = shortcut(gen, result.path) if s.smoothing and result.method != "sampling" \
            else list(result.path)
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
            # limb_turn_speed at the peak (an elbow swinging round a short wrist path)
            bound = s.limb_turn_speed / task.fps
            turn = limb_turn(seg_poses)
            if task.duration_s is None and turn > bound:
                frames = int(math.ceil(frames * min(turn / bound, 2.0)))
                seg_poses, arcs, sampler = time_path(gen, dense, frames)
        loose = None if way_out is None or sampler is None else \
            (way_out.generator, float(sampler.cum[len(lead)]))
        hand = plan_hand(gen, seg_poses, task.fps, arcs=arcs, sampler=sampler, escape=loose,
                         goal=goal)
        if goal is not None or first.roll:
            apply_roll(hand, first.roll, goal, s.hand_space_turn_speed / task.fps)
        return hand.poses, hand, wrist_length

    def explain_failure(self, name: str, result: SearchResult, diagnosis, start: Pose):
        """(reason, message) of a failed reach: the diagnosis's
        (:meth:`ConfigurationGenerator.diagnose_target`), else ``no_path``."""
        arm = self.arm
        length = arm.arm_length
        gap = result.closest_distance / length
        closest = f"closest approach {gap:.2f} arm lengths"

        def size(x):     # figure units, as centimetres and arm lengths
            return f"{100.0 * x * arm.metres_per_unit:.1f} cm, {x / length:.3f} arm lengths"

        d = diagnosis
        inside = body_contact(arm, start) if d is None else None
        if inside is not None:
            # a start inside the character's own body capsules: the search cannot leave it
            # (every step it tries is inside too), which is the start's fault, not the path's
            part, capsule = inside
            return START_IN_COLLISION, (
                f"the start pose has the {part} inside the character's own body (its "
                f"'{capsule}' capsule, sized from the shoulder width), so no clear path to "
                f"target '{name}' leaves it ({result.nodes_searched} tested positions, "
                f"{closest}); pose the arm clear of the body on the start frame, or start "
                "from a frame where it is")
        held = self.generator.for_reach(start, result.target).what_holds(
            start, sphere_directions(int(self.settings.directions))) \
            if d is None and len(result.path) == 1 else None
        if held is not None:
            return START_HELD, self._held_message(name, held, closest)
        if d is None:
            return NO_PATH, (
                f"no collision-free path to target '{name}' within {result.nodes_searched} "
                f"tested positions and {result.states_tested} sampled states ({closest}); "
                "try the guided task, a larger sampling budget or a smaller clearance")
        if d.reason == NEEDS_LEAN:
            return NEEDS_LEAN, (
                f"target '{name}' is out of reach by {size(d.missing)} without leaning "
                f"({d.distance / length:.2f} arm lengths from the shoulder): leaning the trunk "
                f"about {d.lean_deg:.0f}° would reach it, which Reach does not plan "
                f"({closest}); move the target or the character closer")
        if d.reason == NEEDS_STEP:
            return NEEDS_STEP, (
                f"target '{name}' is out of reach even leaning {self.settings.lean_max:.0f}° "
                f"({d.distance / length:.2f} arm lengths from the shoulder): it needs a step "
                f"of at least {size(d.missing)} toward it ({closest}); move the character or "
                "the target")
        if d.reason == OUT_OF_REACH:
            if d.missing <= 0:
                where = "no legal arm pose puts the wrist there (joint limits)"
            elif d.above:
                where = f"{size(d.missing)} above what the arm reaches from the shoulder"
            else:
                where = (f"{size(d.missing)} below what the arm reaches from the shoulder, and "
                         f"leaning {self.settings.lean_max:.0f}° does not bring it within reach: "
                         "only crouching or kneeling would")
            return OUT_OF_REACH, (
                f"target '{name}' is out of reach: {where} ({closest}); move the target")
        if d.reason == ARM_DOES_NOT_FIT:
            radius = {"hand": arm.hand_radius, "upper arm": arm.upper_arm_radius}.get(
                d.part, arm.forearm_radius)
            return ARM_DOES_NOT_FIT, (
                f"the {d.part} does not fit at target '{name}' (the target is in free space): "
                f"its best pose there lacks {size(d.missing)} of room against '{d.obstacle}' "
                f"(the {d.part}'s radius is {size(radius)}, the clearance "
                f"{size(self.settings.clearance * length)}); widen the gap, move the target or "
                "lower the clearance")
        return TARGET_IN_OBSTACLE, (
            f"target '{name}' is inside obstacle '{d.obstacle}': no pose puts the wrist there "
            f"({closest}); move the target out of it")

    def _held_message(self, name: str, held, closest: str) -> str:
        """The message of a reach whose arm cannot move from its start pose (``held``, a
        :class:`~reach_addon.core.generator.Hold`): what holds it and what to do."""
        share = f"{held.steps} of the {held.tried} steps the search tries from it"
        st = self.settings
        if held.kind == "obstacle":
            cause = (f"'{held.what}' is in the way of the {held.part} ({share}); move "
                     f"'{held.what}' back or pose the arm clear of it on the start frame")
        elif held.kind == "body":
            cause = (f"the {held.part} would pass through the character's own body (its "
                     f"'{held.what}' capsule; {share}); pose the arm away from the body on "
                     "the start frame")
        elif held.kind == "hand":
            cause = (f"the hand has no clear way to turn ({share}); pose the hand clear of "
                     "what is near it on the start frame")
        elif held.kind == "smoothness":
            cause = (f"every step would turn a joint more than {st.max_joint_step:g}° at once, "
                     f"the Smoothness setting ({share}): raise it, or, if the arm starts "
                     "straight at the edge of its reach, bend the elbow a little on the start "
                     "frame")
        elif held.kind == "reach":
            cause = f"the wrist is at the edge of the arm's reach ({share})"
        else:
            cause = (f"no pose a step from it is within the joint limits ({share}); pose the "
                     "arm inside its limits on the start frame or widen them (body presets)")
        return (f"the arm cannot move from its start pose toward target '{name}': {cause} "
                f"({closest})")

    def _motion_stats(self, stats: Stats, poses, motion_length: float,
                      hand: HandReport | None = None, clearances=None):
        motion_stats(stats, self.arm, poses, [self.generator.checker] * len(poses),
                     motion_length, hand, clearances)


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


def body_contact(arm: ArmModel, pose: Pose):
    """(part, capsule name) of the first part of ``pose`` (the elbow half of the upper arm,
    the forearm, the hand) inside one of the character's own body capsules
    (:func:`~reach_addon.core.ik.body_hit`), or None."""
    if not arm.body_capsules:
        return None
    hit = ik.body_hit(arm, np.asarray(pose.joints, dtype=float).tolist(),
                      ik.body_capsules_at(arm, pose.config.body_rotation))
    return None if hit is None else (hit[0], arm.body_capsules[hit[1]].name)


def first_contact(generator, poses, hand: HandReport, clearances, escaping: bool = False):
    """Where a motion first touches an obstacle: (frame, (part, obstacle)) of the first key
    whose arm or hand comes into contact (no margin) or the first pair of keys that touch
    as they interpolate (at half the clearance, :meth:`ConfigurationGenerator.transition_problem`,
    as the hand pass reports them); None if it never does. ``clearances``: each key's, from
    :func:`pose_clearances`. ``escaping``: the motion starts
    in contact and moves out of it (:mod:`~reach_addon.core.contact`); its first keys in
    contact, up to the first clear one, are that escape and do not count."""
    arm = generator.arm
    checker = generator.checker
    touching = [c < 0.0 for c in clearances]
    first = 0
    if escaping:
        while first < len(poses) and touching[first]:
            first += 1
    unclear = sorted(k for k in hand.unclear_transitions if k >= first)
    bad = unclear[0] + 1 if unclear else len(poses)
    for k in range(first, bad):
        if touching[k]:
            world = arm.to_world_points(poses[k].joints)
            return k, checker.first_hit(world) or ("arm", "an obstacle")
    if unclear:
        k = unclear[0]
        return k + 1, _between_hit(generator, poses[k], poses[k + 1])
    return None


def _between_hit(generator, a: Pose, b: Pose):
    """(part, obstacle) of the first contact between two keys as they interpolate (the
    instants of :meth:`ConfigurationGenerator.transition_problem`, at half the clearance)."""
    n = max(2, generator.settings.instants_per_frame)
    instants, _bends, _body = between(generator.arm, a, b, np.arange(1, n) / n)
    checker = generator.between_keys().checker
    for joints in generator.arm.to_world_points(instants):
        hit = checker.first_hit(joints)
        if hit is not None:
            return hit
    return (generator.transition_problem(a, b) or "hand", "the character's own body")


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


def pose_clearances(arm: ArmModel, poses, checkers) -> list:
    """Each pose's least clearance (figure units, no margin; ``inf`` beyond half an arm
    length), measured by its own checker (one per pose: a chase against moving obstacles
    has one obstacle set per frame)."""
    horizon = 0.5 * arm.arm_length
    return [checker.clearance(arm.to_world_points(p.joints), horizon)
            for p, checker in zip(poses, checkers)]


def motion_stats(stats: Stats, arm: ArmModel, poses, checkers, motion_length: float,
                 hand: HandReport | None = None, clearances=None) -> None:
    """Fill the motion part of ``stats``: frames, strength categories and the least
    clearance (``clearances`` if already measured, else :func:`pose_clearances` with
    ``checkers``), and what the hand pass reported."""
    length = arm.arm_length
    if hand is not None:
        stats.max_wrist_turn_deg_per_frame = hand.max_wrist_turn_deg
        stats.max_hand_turn_deg_per_frame = hand.max_hand_turn_deg
        stats.mean_wrist_bend_deg = hand.mean_wrist_bend_deg
        stats.max_wrist_bend_deg = hand.max_wrist_bend_deg
        stats.inserted_frames = hand.inserted_frames
        stats.unbounded_hand_turns = hand.unbounded_turns
        stats.touching_transitions = len(hand.unclear_transitions)
    stats.motion_path_length_arm_lengths = motion_length
    stats.frames = len(poses)
    for p in poses:
        stats.strength_categories[max(0, min(2, int(p.f_r)))] += 1
    if clearances is None:
        clearances = pose_clearances(arm, poses, checkers)
    for c in clearances:
        stats.min_clearance_arm_lengths = min(stats.min_clearance_arm_lengths, c / length)
