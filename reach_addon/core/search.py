"""Best-first search of wrist positions with backtracking (paper, "Guided path planning").

Around the current node the candidates are the straight step toward the current guiding
node (or the target), ``Settings.directions`` steps of ``Settings.step`` arm lengths spread
evenly on the sphere, the target itself when within a step, and the hand turned in place;
before it refuses, the rim of the tolerance ball round the target (:func:`last_tries`).
They are tried nearest the goal first; the first that the configuration generator gives a
valid pose becomes the next node, and a node whose candidates are used up is left
(backtracking). The search succeeds within ``Settings.goal_tolerance`` of the target and
fails when backtracking leaves the start, after ``Settings.node_budget`` tested positions,
or after ``Settings.stall_budget`` without getting closer (the path to the closest position
is kept). "Nodes searched" counts the positions handed to the generator, "nodes in
solution" the positions of the path, start included (Table 2). :class:`BestFirstSearch` is
resumable: :meth:`~BestFirstSearch.run` takes a node allowance and gives the same result
however it is sliced.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from .arm import Pose
from .errors import NO_PATH
from .generator import ConfigurationGenerator
from .torso import rotate_about_spine


#: Before a search refuses, positions this share of ``goal_tolerance`` from the target are
#: tried from the closest position (:func:`last_tries`).
GOAL_BALL = 0.9
#: ... and this share, toward the shoulder and then all round: a target beyond the arm
#: by more than :data:`GOAL_BALL` of the tolerance is still within it. Short of 1 by the
#: slack a baked rig's own residual needs to stay within the tolerance.
GOAL_BALL_FAR = 0.97
#: The swivel step (degrees) of the last try before a refusal.
FINE_SWIVEL_STEP = 1.0


def goal_ball(target, settings, arm_length: float, toward=()) -> np.ndarray:
    """The rim of the target's tolerance ball, (n, 3): ``target`` + :data:`GOAL_BALL` ×
    ``goal_tolerance`` × ``arm_length`` toward each point of ``toward`` first, then along
    each of ``Settings.directions`` directions (:func:`sphere_directions`)."""
    target = np.asarray(target, dtype=float)
    r = GOAL_BALL * settings.goal_tolerance * arm_length
    ways = [np.asarray(p, dtype=float) - target for p in toward]
    ways = [w / np.linalg.norm(w) for w in ways if np.linalg.norm(w) > 1e-12]
    return target + r * np.vstack(ways + [sphere_directions(int(settings.directions))])


def last_tries(generator, target) -> list:
    """The positions tried before a target is refused, in order, as (generator, canonical
    point) pairs: the rim of its tolerance ball (:func:`goal_ball`) with ``generator``,
    toward the shoulder first, where the one point of the ball within reach of a target just
    beyond it lies: the shoulder as the chest turn of the range that brings it nearest the
    target carries it (:func:`nearest_shoulder`; a target across the body is reached with
    the trunk turned toward it), then the resting shoulder, then straight away from it;
    toward the nearest shoulder also at :data:`GOAL_BALL_FAR` of the tolerance, for a target
    beyond reach by nearly all of it. Then the target, the rim's first three and that
    point with the swivel circle sampled every :data:`FINE_SWIVEL_STEP` degrees
    (:meth:`~reach_addon.core.generator.ConfigurationGenerator.finer`: a clear swivel
    window narrower than the search's step, as an elbow folded to its limit has). Last,
    the rim's even directions at :data:`GOAL_BALL_FAR` with the fine swivel: a pose may fit
    only in the thin shell between the two, on the side away from the body, in a narrow
    swivel window (fuzz seeds 4940, an elbow folded near its limit, clear only 0.95 of the
    tolerance forward; 7738, a hand across the body with the chest at its limit, clear
    only above the target at a swivel between the 5° samples). The
    search's last try (:meth:`BestFirstSearch._last_try`) and the diagnosis of a refusal
    (:func:`~reach_addon.core.diagnosis.fit_within_tolerance`) use these same positions,
    so a target is refused only where neither finds a pose."""
    target = np.asarray(target, dtype=float)
    shoulder = np.asarray(generator.arm.shoulder, dtype=float)
    turned = nearest_shoulder(generator, target)
    rim = goal_ball(target, generator.settings, generator.arm.arm_length,
                    (turned, shoulder, 2.0 * target - shoulder))
    # the rim's first point, toward the turned shoulder, pushed out to GOAL_BALL_FAR
    far = target + (rim[0] - target) * (GOAL_BALL_FAR / GOAL_BALL)
    # the whole rim again at GOAL_BALL_FAR: a clear pose may exist only in the thin shell
    # between GOAL_BALL and the tolerance, on whichever side the body or a limit leaves
    shell = target + (rim[len(rim) - int(generator.settings.directions):] - target) * \
        (GOAL_BALL_FAR / GOAL_BALL)
    fine = generator.finer(FINE_SWIVEL_STEP)
    return [(generator, p) for p in rim] + [(generator, far)] + \
        [(fine, p) for p in (target, rim[0], rim[1], rim[2], far)] + \
        [(fine, p) for p in shell]


def nearest_shoulder(generator, target) -> np.ndarray:
    """The shoulder (canonical) as the chest rotation of
    :meth:`~reach_addon.core.generator.ConfigurationGenerator.chest_candidates` that brings
    it nearest ``target`` carries it (:func:`~.torso.rotate_about_spine`)."""
    turns = np.asarray(generator.chest_candidates(target), dtype=float)
    shoulders = rotate_about_spine(np.asarray(generator.arm.shoulder, dtype=float), turns)
    return shoulders[int(np.argmin(np.linalg.norm(shoulders - target, axis=-1)))]


@lru_cache(maxsize=8)
def sphere_directions(count: int) -> np.ndarray:
    """``count`` unit vectors spread evenly on the sphere (Fibonacci lattice)."""
    k = np.arange(count) + 0.5
    z = 1.0 - 2.0 * k / count
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)


@dataclass
class _Node:
    pose: Pose
    parent: int
    guide: int
    depth: int
    candidates: list | None = None      # positions (lists of 3 floats), the next one last
    exact: int = 0                      # how many of the last candidates are exact targets
    failed: list = field(default_factory=list)   # positions tried from here and blocked


@dataclass
class SearchResult:
    """Outcome of one search: the path (start first) to the target, or on failure to the
    closest position reached."""

    success: bool
    reason: str | None
    path: list
    nodes_searched: int
    search_time_s: float
    closest_distance: float
    target: np.ndarray
    guides: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    #: what found the path: "best-first" (the paper's search, straight or guided) or
    #: "sampling" (:mod:`~reach_addon.core.sampling`, where the search gave up)
    method: str = "best-first"
    #: states the sampling planner tested (its own count, beside nodes_searched)
    states_tested: int = 0
    #: a chase's frame held its pose: its first step would have touched as the keys
    #: interpolate (:func:`~reach_addon.core.chase.chase_step`)
    held: bool = False

    @property
    def nodes_in_solution(self) -> int:
        return len(self.path)

    def path_length(self) -> float:
        """Length of the wrist path in the figure's units."""
        if len(self.path) < 2:
            return 0.0
        pts = np.array([p.wrist for p in self.path])
        return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


class BestFirstSearch:
    """One search from ``start`` to ``target`` (canonical frame) through ``guides``."""

    def __init__(self, generator: ConfigurationGenerator, start: Pose, target, guides=None,
                 guide_radius: float = 0.0, node_budget: int | None = None,
                 stall_budget: int | None = None, depth_limit: int | None = None,
                 hand_continuity: bool = True, last_try: bool = True):
        s = generator.settings
        self.generator = generator
        self.last_try = last_try
        self.target = np.asarray(target, dtype=float)
        self.guides = np.zeros((0, 3)) if guides is None else np.asarray(guides, dtype=float)
        self.guide_radius = guide_radius
        self.step = generator.step_length
        self.tolerance = s.goal_tolerance * generator.arm.arm_length
        self.resolution = s.visited_resolution * self.step
        self.directions = sphere_directions(int(s.directions))
        self.node_budget = s.node_budget if node_budget is None else node_budget
        self.stall_budget = s.stall_budget if stall_budget is None else stall_budget
        self.depth_limit = depth_limit
        self.hand_continuity = hand_continuity
        # the hand the target needs: worked out (one IK call) when the wrist first comes
        # within the lead's radius, so a search that stops short of it (a chase's step)
        # never pays for it; False until then
        self.lead_radius = s.hand_lead * generator.arm.hand_length if hand_continuity else 0.0
        self.goal_hand = False if self.lead_radius > 0.0 else None
        self.offsets = self.step * self.directions
        self.target_list = self.target.tolist()
        self.blocked_radius = float(s.blocked_radius)
        # candidates exactly one step from a blocked position count (floating-point slack)
        self.blocked_sq = (self.blocked_radius * self.step) ** 2 * (1.0 + 1e-9)
        self.nodes: list[_Node] = [_Node(start, -1, self._advance_guide(0, start.wrist), 0)]
        self.stack = [0]
        # Visited positions are keyed with the hand they were tried from (another hand
        # may get where this one could not); positions where no arm pose is clear are
        # blocked for every hand.
        self.visited = {self._key(start.wrist) + (start.hand if hand_continuity else ())}
        self.blocked: set = set()
        self.nodes_searched = 0
        self.closest = 0
        self.closest_distance = float(np.linalg.norm(start.wrist - self.target))
        self.last_improvement = 0
        self.elapsed = 0.0
        self.done = False
        self.success = False
        self.reason: str | None = None
        if self.closest_distance <= self.tolerance:
            self.done = self.success = True

    # --- helpers ---------------------------------------------------------------------
    def _lead(self, wrist):
        """The hand the target needs, where the wrist is near enough to lead the hand
        toward it and that is not the relaxed hand (else None)."""
        if self.goal_hand is None or math.dist(self.target_list, list(wrist)) > self.lead_radius:
            return None
        if self.goal_hand is False:
            at_target = self.generator.solve(self.target)
            self.goal_hand = None if at_target is None or at_target.hand == (0.0, 0.0) \
                else at_target.hand
        return self.goal_hand

    def _key(self, p):
        r = self.resolution
        return (math.floor(p[0] / r), math.floor(p[1] / r), math.floor(p[2] / r))

    def _advance_guide(self, index: int, wrist) -> int:
        w = np.asarray(wrist, dtype=float).tolist()
        while index < len(self.guides) and \
                math.dist(self.guides[index].tolist(), w) <= self.guide_radius:
            index += 1
        return index

    def _goal(self, node: _Node) -> np.ndarray:
        return self.guides[node.guide] if node.guide < len(self.guides) else self.target

    def _candidates(self, node: _Node) -> list:
        """The positions to try from ``node``, best last (they are popped): the target if
        within a step, then the step toward the goal and the sphere of steps, nearest the
        goal first, those near a position blocked from the parent last.

        |w + s d - g|² = |w - g|² + s² - 2 s d·(g - w), so the sphere of steps is ordered
        by -d·(g - w) (one matrix product); the straight step toward the goal is the
        nearest of all and comes first."""
        w = node.pose.wrist
        goal = self._goal(node)
        to_goal = goal - w
        dist = math.sqrt(float(to_goal @ to_goal))
        key = self.directions @ -to_goal
        straight = (w + to_goal * min(1.0, self.step / dist)).tolist() if dist > 1e-12 else None
        parent_failed = self.nodes[node.parent].failed if node.parent >= 0 else None
        if parent_failed and self.blocked_radius > 0.0:
            blocked = np.array(parent_failed)
            pts = w + self.offsets
            f = pts[:, None, :] - blocked[None]
            near = (np.einsum("ijk,ijk->ij", f, f) <= self.blocked_sq).any(1)
            best = pts[np.lexsort((key, near))].tolist()          # clear ones first
            if straight is not None:
                d = blocked - straight
                if (np.einsum("ij,ij->i", d, d) <= self.blocked_sq).any():
                    best.insert(len(best) - int(np.count_nonzero(near)), straight)
                else:
                    best.insert(0, straight)
            best.reverse()
            out = best
        else:
            out = (w + self.offsets[np.argsort(key, kind="stable")[::-1]]).tolist()
            if straight is not None:
                out.append(straight)
        if math.dist(self.target_list, w.tolist()) <= self.step:
            out.append(list(self.target_list))
            node.exact = 1
        # the hand turned in place (to the samples within a step's bound, the most relaxed
        # popped first): after every step that gets nearer the goal, before those that do
        # not, so that a hand in the way turns rather than the search wander sideways
        turns = [h for h in self.generator.hand_order(node.pose.hand, 1.0, self._lead(w))
                 if h != node.pose.hand] if self.hand_continuity else []
        if turns:
            g = goal.tolist()
            near = dist - 1e-12
            k = len(out)
            while k > 0 and math.dist(out[k - 1], g) < near:
                k -= 1
            k = min(k, len(out) - node.exact)     # the exact targets stay last
            out[k:k] = turns[::-1]
        return out

    # --- the search ------------------------------------------------------------------
    def run(self, max_nodes: int | None = None) -> bool:
        """Test up to ``max_nodes`` more positions (all remaining if None); True when the
        search has finished."""
        t0 = time.perf_counter()
        tested = 0
        try:
            while not self.done:
                if max_nodes is not None and tested >= max_nodes:
                    return False
                if not self.stack:
                    self._finish(False, NO_PATH)  # backtracked past the start
                    break
                node_index = self.stack[-1]
                node = self.nodes[node_index]
                if node.candidates is None:
                    node.candidates = self._candidates(node)
                if not node.candidates:
                    self.stack.pop()  # all candidates used: backtrack
                    continue
                exact = node.exact > 0          # exact targets sit at the end: popped first
                point = node.candidates.pop()
                if exact:
                    node.exact -= 1
                    key = None
                elif isinstance(point, tuple):     # the hand turned in place
                    key = self._key(node.pose.wrist.tolist()) + point
                else:
                    cell = self._key(point)
                    if cell in self.blocked:
                        continue
                    key = cell + node.pose.hand if self.hand_continuity else cell
                if key is not None:
                    if key in self.visited:
                        continue
                    self.visited.add(key)
                tested += 1
                self.nodes_searched += 1
                if isinstance(point, tuple):
                    pose = self.generator.turn_hand(node.pose, point)
                elif self.hand_continuity:
                    pose = self.generator.solve(np.array(point), node.pose,
                                                hand_scale=self.generator.move_scale(
                                                    node.pose, point),
                                                toward=self._lead(point))
                else:
                    pose = self.generator.solve(np.array(point), node.pose)
                if pose is None:
                    if not isinstance(point, tuple):
                        node.failed.append(point)
                        if not self.generator.hand_blocked:
                            self.blocked.add(self._key(point))  # no hand can get there
                else:
                    self.nodes.append(_Node(pose, node_index,
                                            self._advance_guide(node.guide, pose.wrist),
                                            node.depth + 1))
                    self.stack.append(len(self.nodes) - 1)
                    d = math.dist(pose.wrist.tolist(), self.target_list)
                    if d < self.closest_distance - 1e-12:
                        self.closest_distance = d
                        self.closest = len(self.nodes) - 1
                        self.last_improvement = self.nodes_searched
                    if d <= self.tolerance:
                        self._finish(True, None)
                        break
                    if self.depth_limit is not None and node.depth + 1 >= self.depth_limit:
                        self._finish(False, None)  # far enough for now (chase)
                        break
                if self.nodes_searched >= self.node_budget or \
                        self.nodes_searched - self.last_improvement >= self.stall_budget:
                    self._finish(False, NO_PATH)
            return True
        finally:
            self.elapsed += time.perf_counter() - t0

    def _finish(self, success: bool, reason):
        self.done = True
        self.success = success
        self.reason = reason
        if not success and reason is not None and self.last_try:
            self._last_try()

    def _last_try(self) -> None:
        """Before a refusal (unless made with ``last_try=False``, as a chase's frames are:
        a pursuit keeps to its own steps and its own account of the gap), where the closest
        position is within a step of the target: the positions of :func:`last_tries`, each
        solved from the closest position's pose and counted as a node. Reaching any of
        them is a success: a target is not refused where its own point leaves the arm a
        fraction of a millimetre short of room while a pose within the tolerance fits, nor
        where the only clear swivel angles lie between the search's samples."""
        node = self.nodes[self.closest]
        if self.closest_distance > self.step:
            return
        for g, point in last_tries(self.generator, self.target):
            self.nodes_searched += 1
            pose = g.solve(point, node.pose, hand_scale=g.move_scale(node.pose, point.tolist())) \
                if self.hand_continuity else g.solve(point, node.pose)
            if pose is not None:
                self.nodes.append(_Node(pose, self.closest, node.guide, node.depth + 1))
                self.stack.append(len(self.nodes) - 1)
                self.closest = len(self.nodes) - 1
                self.closest_distance = math.dist(pose.wrist.tolist(), self.target_list)
                self.success, self.reason = True, None
                return

    def path_to(self, index: int) -> list:
        out = []
        while index >= 0:
            out.append(self.nodes[index].pose)
            index = self.nodes[index].parent
        return out[::-1]

    def result(self) -> SearchResult:
        """The search's outcome so far: the path to the target; after a depth-limited stop
        the path to the current node; otherwise the closest approach."""
        if self.success or (self.done and self.reason is None and self.stack):
            end = self.stack[-1]
        else:
            end = self.closest
        return SearchResult(self.success, None if self.success else self.reason,
                            self.path_to(end), self.nodes_searched, self.elapsed,
                            self.closest_distance, self.target, self.guides)
