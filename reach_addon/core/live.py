"""Live reach: re-planning while the target (or the scene) moves, in time-budgeted slices.

A :class:`LiveSession` keeps one :class:`~reach_addon.core.planner.Planner` and the pose on
screen. When the target moves it re-plans from that pose with the reach task's search and
fallbacks (:meth:`~reach_addon.core.planner.Planner.route_steps`);
:meth:`LiveSession.advance` runs for at most a time budget (default
:data:`DEFAULT_BUDGET_S`) and the next call continues where it stopped, with the same poses
however it is sliced. Each update shows at most one new pose of the searched path, within
the smoothness bound of the pose shown before. A target that cannot be reached leaves the
arm at the closest approach, with the reason and message a plan would give. A chase
against moving obstacles is :func:`~reach_addon.core.chase.chase_steps`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .arm import ArmConfig, Pose
from .collision import Obstacles
from .errors import NEEDS_STEP, START_IN_COLLISION, require_finite
from .search import BestFirstSearch, SearchResult
from .settings import Settings
from .planner import Planner
from .whole_body import body_helps

#: Time one :meth:`LiveSession.advance` may take by default: one frame at 30 fps.
DEFAULT_BUDGET_S = 1.0 / 30.0

#: Search nodes tested between two looks at the clock (one node costs about 0.5–3 ms).
NODES_PER_SLICE = 2

#: A target that moved less than this (arm lengths) has not moved.
TARGET_EPSILON = 1e-6

#: States of a live session, as :attr:`LiveStatus.state`.
IDLE, SEARCHING, MOVING, REACHED, CLOSEST, BLOCKED = (
    "idle", "searching", "moving", "reached", "closest", "blocked")


@dataclass
class LiveStatus:
    """What the session is doing and, after a re-plan, how it went. ``reason`` is one of
    :data:`~reach_addon.core.errors.REASONS` when the target is not reached; ``message``
    says it in words the panel shows; ``distance`` is wrist-to-target in arm lengths."""

    state: str = IDLE
    reason: str | None = None
    message: str = "waiting for a target"
    distance: float = math.inf
    nodes_searched: int = 0
    search_time_s: float = 0.0


class LiveSession:
    """One arm following one target interactively (see the module docstring).

    ``start``: the arm's configuration (or pose) on screen when the session begins.
    ``name``: what the user calls the target (for messages); ``start_hand``: the wrist's
    two angles on screen."""

    def __init__(self, arm, obstacles: Obstacles | None, settings: Settings | None = None,
                 start: ArmConfig | Pose | None = None, name: str = "target",
                 start_hand=(0.0, 0.0)):
        self.settings = settings if settings is not None else Settings()
        self.planner = Planner(arm, obstacles, self.settings)
        if start is None:
            raise ValueError("a live session needs the arm's start configuration")
        self.pose = start if isinstance(start, Pose) else \
            self.planner.generator.config_pose(start, start_hand)
        require_finite("start pose", self.pose.joints)
        self.name = name
        self.target: np.ndarray | None = None      # world space
        self.status = LiveStatus()
        self.updates = 0                            # poses shown since the session began
        self._job = None
        self._searcher: BestFirstSearch | None = None
        self._pending: Pose | None = None
        self._path: list = []
        self._cursor = 0
        self._pose_clear = False

    # --- inputs ----------------------------------------------------------------------
    @property
    def arm(self):
        return self.planner.arm

    @property
    def obstacles(self) -> Obstacles:
        return self.planner.obstacles

    @property
    def busy(self) -> bool:
        return (self._job is not None or self._pending is not None
                or self._cursor < len(self._path) - 1)

    def set_obstacles(self, obstacles: Obstacles | None) -> bool:
        """Plan against new obstacles from now on (a new planner: the workspace grid is
        rebuilt if it is needed again). A re-plan toward the current target starts from the
        pose on screen. Returns True if anything changed."""
        obstacles = obstacles if obstacles is not None else Obstacles(None)
        if obstacles is self.planner.obstacles:
            return False
        self.planner = Planner(self.arm, obstacles, self.settings)
        self._pose_clear = False
        # progress made against the old obstacles is not kept: it may touch the new ones
        self._searcher, self._pending = None, None
        if self.target is not None:
            self._restart()
        return True

    def set_target(self, target_world, name: str | None = None, force: bool = False) -> bool:
        """Follow ``target_world`` (a world position). Starts a re-plan from the pose on
        screen if the target moved (or ``force``); returns True if it did."""
        target = require_finite(f"target '{name or self.name}'", target_world).reshape(3)
        if name is not None:
            self.name = name
        moved = self.target is None or \
            float(np.linalg.norm(target - self.target)) > TARGET_EPSILON * self.arm.arm_length
        if not (moved or force):
            return False
        self.target = target.copy()
        self._restart()
        return True

    def _restart(self):
        if self._job is not None and self._searcher is not None and self._pending is None:
            # The target moved during a search: keep the progress made (the path to the
            # closest position so far, as far as the smoothness bound allows); the next
            # update shows it and the new search starts there.
            partial = self._searcher.result().path
            k = self._farthest_smooth(partial, 0)
            if k > 0:
                self._pending = partial[k]
        if self._job is not None:
            self._job.close()
        self._searcher = None
        self._path, self._cursor = [], 0
        self._job = self._replan(self.arm.to_canonical_points(self.target))
        self.status = LiveStatus(SEARCHING, None, f"searching toward '{self.name}'",
                                 self._distance(self.pose))

    # --- running ---------------------------------------------------------------------
    def advance(self, budget_s: float | None = DEFAULT_BUDGET_S) -> bool:
        """Work on the current re-plan for at most ``budget_s`` seconds (None: to the end),
        then show at most one new pose. Returns True if :attr:`pose` changed."""
        if self._pending is not None:
            self.pose, self._pending = self._pending, None
            self._pose_clear = True
            self.updates += 1
            self.status.distance = self._distance(self.pose)
            return True
        deadline = None if budget_s is None else time.perf_counter() + budget_s
        while self._job is not None:
            try:
                next(self._job)
            except StopIteration:
                self._job = None
                break
            if deadline is not None and time.perf_counter() >= deadline:
                return False
        return self._show_next()

    def run(self) -> list:
        """Advance until idle; the poses shown, in order (for scripts and tests)."""
        shown = []
        while self.busy:
            if self.advance(None):
                shown.append(self.pose)
        return shown

    def _show_next(self) -> bool:
        """Move the shown pose along the searched path: to its end if that is within the
        smoothness bound of the pose shown now, else as far as the bound allows."""
        last = len(self._path) - 1
        if self._cursor >= last:
            return False
        # Consecutive poses of a searched path are within the bound of each other, so the
        # arm always gets at least one step further.
        k = max(self._cursor + 1, self._farthest_smooth(self._path, self._cursor))
        self._cursor = k
        self.pose = self._path[k]
        self.updates += 1
        if k >= last:
            self.status.state = REACHED if self.status.reason is None else CLOSEST
        self.status.distance = self._distance(self.pose)
        return True

    def _farthest_smooth(self, path: list, cursor: int) -> int:
        """Index of the farthest pose of ``path`` after ``cursor`` that is within the
        smoothness bound of the pose shown: the end if it is, else walking forward while
        each next pose still is; ``cursor`` if none is."""
        gen = self.planner.generator
        last = len(path) - 1
        if last <= cursor:
            return cursor
        if gen.smooth_between(self.pose, path[last]):
            return last
        k = cursor
        while k < last and gen.smooth_between(self.pose, path[k + 1]):
            k += 1
        return k

    def _keep(self, searcher: BestFirstSearch) -> None:
        """Keep the running search, so that a re-plan interrupted by a new target can keep
        the progress made (:meth:`_restart`)."""
        self._searcher = searcher

    def _distance(self, pose: Pose) -> float:
        if self.target is None:
            return math.inf
        wrist = self.arm.to_world_points(pose.wrist)
        return float(np.linalg.norm(wrist - self.target)) / self.arm.arm_length

    def _replan(self, target_c):
        """The re-plan as a generator (yields every :data:`NODES_PER_SLICE` nodes)."""
        planner = self.planner
        gen = planner.generator
        start = self.pose
        # A pose the search produced against these obstacles is clear; test only a pose
        # from elsewhere (the rig, an undo) or one the obstacles may have moved into.
        problem = None if self._pose_clear else gen.start_problem(start)
        self._pose_clear = problem is None
        if problem is not None and problem[0] == "sternum":
            self.status = LiveStatus(
                BLOCKED, START_IN_COLLISION,
                f"the body is inside '{problem[1]}'; move the character or the obstacle",
                self._distance(start))
            return
        prefix = []
        if problem is not None:
            # Something moved into the arm: first try another pose with the wrist where it
            # is (within the smoothness bound), then search on from there.
            escape = gen.for_reach(start, target_c, fit_chest=False).solve(start.wrist, start)
            if escape is not None:
                prefix, start, problem = [start], escape, None
        # The reach task's search, fallbacks included; the diagnosis (is the target
        # reachable at all?) is worked out only if the first slice does not settle it.
        route = yield from planner.route_steps(start, target_c, chunk=NODES_PER_SLICE,
                                               keep=self._keep)
        result, diagnosis = route.result, route.diagnosis
        if prefix:
            result.path = prefix + list(result.path)
        self._searcher = None
        self._finish(result, diagnosis, start, problem)

    def _body_note(self, reason) -> str:
        """Where a Plan or Bake would have the body help (``Settings.lean`` on, a target
        beyond the arm or a step away, or below it with ``Settings.squat``:
        :func:`~.whole_body.body_helps`), the clause that says Live does not: it poses the arm alone, each
        slice a search of the arm (a lean is planned, posed and weighed on the rig)."""
        s = self.planner.settings
        if not s.lean or not (reason == NEEDS_STEP or
                              body_helps(s, self.planner.arm, reason, self.target)):
            return ""
        return "; Live poses the arm alone: Plan or Bake the reach to have the body lean, " \
            "squat or step"

    def _finish(self, result: SearchResult, diagnosis, start: Pose, problem):
        status = LiveStatus(MOVING, None, f"on '{self.name}'", self._distance(start),
                            result.nodes_searched, result.search_time_s)
        if not result.success:
            status.reason, status.message = self.planner.explain_failure(
                self.name, result, diagnosis, start)
            status.message += self._body_note(status.reason)
        end = result.path[-1] if result.path else start
        if problem is not None and self.planner.generator.pose_collides(end):
            status.reason = START_IN_COLLISION
            status.message = (f"'{problem[1]}' touches the arm (at the {problem[0]}) and no "
                              "clear pose was found nearby; move it away from the arm")
        self._path, self._cursor = list(result.path), 0
        if len(self._path) > 1:
            self._pose_clear = True     # every pose after the first was solved clear
        if len(self._path) < 2:
            status.state = REACHED if status.reason is None else CLOSEST
        self.status = status


__all__ = ["DEFAULT_BUDGET_S", "LiveSession", "LiveStatus", "IDLE", "SEARCHING", "MOVING",
           "REACHED", "CLOSEST", "BLOCKED"]
