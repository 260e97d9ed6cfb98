"""The race harness: Reach's planner and OMPL's RRTConnect on one problem, measured alike.

:func:`race` plans one task (:class:`reach_addon.core.Task`) with a fresh Reach planner and
with OMPL (RRTConnect, then its path simplifier), from the same start to a goal region of
the same IK's legal, clear poses (:func:`goal_rows`), in the seven joints the core animates
(:class:`JointSpace`: chest rotation, α, β, γ, elbow flexion, the wrist's two angles;
degrees) with the core's own state test (:class:`Validity`), timed by the same clock. Both
paths are then interpolated densely (:data:`DENSE_SPACING` arm lengths of joint travel)
and measured by one yardstick (:class:`PathMeasure`): wrist path length and least
clearance in arm lengths, mean strength category f_R, and contacts by the independent
check (:func:`verification.clearance.independent_check`). ``bench/ompl_race.py`` and
``make bench`` run it; the tight scenes (:mod:`verification.tight`) and the refusal
cross-check (:mod:`verification.refusal`) use its OMPL pieces. How the race is made fair
and what differs: ``docs/design.md``, *The race against OMPL*.
"""

from __future__ import annotations

import hashlib
import math
import time
from functools import lru_cache

import numpy as np

from reach_addon.core import Planner, Task, ik
from reach_addon.core.sampling import (JOINT_NAMES, StateValidity, densify_rows, joints_of,
                                      pose_row)
from reach_addon.core.sampling import JointSpace as CoreJointSpace
from reach_addon.core.strength import strength_category

from .clearance import independent_check

#: Keys of the dictionary :func:`race` returns (the numbers are plain Python floats/ints).
KEYS = ("task", "reach_time_s", "ompl_time_s", "reach_path_length", "ompl_path_length",
        "reach_mean_f_r", "ompl_mean_f_r", "reach_collisions", "ompl_collisions",
        "time_ratio", "path_length_ratio", "f_r_difference",
        "reach_success", "ompl_success", "reach_arm_collisions", "ompl_arm_collisions",
        "reach_min_clearance", "ompl_min_clearance",
        "reach_preprocess_time_s", "ompl_validity_checks", "legs", "note",
        "reach_passed", "ompl_passed", "reach_nodes_searched")

#: Wrist spacing of the dense interpolation measured by the independent check (arm lengths).
DENSE_SPACING = 0.002
#: Targets of a chase raced as legs (evenly spaced frames of its trajectory).
CHASE_WAYPOINTS = 4
#: The independent check reports clearances up to this far (arm lengths); beyond, "far".
CLEARANCE_HORIZON = 0.05
# --- the joint space: the core's sampling planner's (core.sampling), with OMPL's view -------

class JointSpace(CoreJointSpace):
    """The seven joints, their limits and the lever-arm metric
    (:class:`reach_addon.core.sampling.JointSpace`), as an OMPL state space."""

    def ompl_space(self):
        """A bounded ``RealVectorStateSpace`` whose motion checks are a core step apart."""
        from ompl import base as ob

        space = ob.RealVectorStateSpace(len(JOINT_NAMES))
        bounds = ob.RealVectorBounds(len(JOINT_NAMES))
        bounds.low = self.coordinates(self.lo).tolist()
        bounds.high = self.coordinates(self.hi).tolist()
        space.setBounds(bounds)
        for i, name in enumerate(JOINT_NAMES):
            space.setDimensionName(i, name)
        space.setLongestValidSegmentFraction(self.settings.step / space.getMaximumExtent())
        return space


class Validity(StateValidity):
    """OMPL's state validity checker: the core's own test of a configuration
    (:class:`reach_addon.core.sampling.StateValidity`, which the core's sampling fallback
    uses), on OMPL's coordinates. ``calls`` counts the states checked."""

    def __init__(self, planner: Planner, space: JointSpace):
        super().__init__(planner.arm, planner.settings, planner.generator.checker, space)
        self.scale = space.scale.tolist()

    def __call__(self, state) -> bool:
        return self.valid([state[i] / k for i, k in enumerate(self.scale)])


def densify(space: JointSpace, path, spacing):
    """Configurations (N, 7) along ``path`` (K, 7) by linear interpolation in joint space,
    subdivided until no joint (elbow, wrist, the hand's far end) moves more than
    ``spacing`` (figure units) between samples (:func:`reach_addon.core.sampling.densify_rows`:
    a hand turning about a still wrist is sampled as densely as a moving wrist)."""
    return densify_rows(space.arm, path, spacing)


class PathMeasure:
    """Path length, mean f_R and independent contacts of joint-space paths, cached by path
    (Reach's paths are deterministic, so repeated races measure each only once)."""

    def __init__(self, space: JointSpace, tris, include_hand: bool):
        self.space = space
        self.tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
        self.include_hand = include_hand
        self._cache: dict = {}

    def __call__(self, path) -> dict:
        path = np.atleast_2d(np.asarray(path, dtype=float))
        key = hashlib.sha1(path.tobytes()).hexdigest()
        if key not in self._cache:
            if len(self._cache) > 64:
                self._cache.clear()
            self._cache[key] = self._measure(path)
        return dict(self._cache[key])

    def _measure(self, path) -> dict:
        arm, st = self.space.arm, self.space.settings
        length = arm.arm_length
        dense = densify(self.space, path, DENSE_SPACING * length)
        joints = joints_of(arm, dense, shaped=True)
        wrists = joints[:, 3]
        travel = float(np.linalg.norm(np.diff(wrists, axis=0), axis=1).sum()) if len(dense) > 1 else 0.0
        levels = strength_category(dense[:, 1], dense[:, 2], st)
        return {"path_length": travel / length, "mean_f_r": float(np.mean(levels)),
                **_contacts(arm, self.tris, joints, self.include_hand)}


def _contacts(arm, tris, joints, include_hand: bool) -> dict:
    """The independent check of canonical joints (N, 5, 3) as :func:`path_contacts` gives it."""
    length = arm.arm_length
    hits, arm_hits, least = independent_check(arm, arm.to_world_points(joints), tris,
                                              include_hand, CLEARANCE_HORIZON * length)
    return {"collisions": int(hits), "arm_collisions": int(arm_hits),
            "min_clearance": least / length, "samples": int(len(joints))}


def path_contacts(space: JointSpace, tris, path, include_hand: bool) -> dict:
    """The independent check of a joint-space path (K, 7, degrees), densely interpolated
    (:func:`densify`, :data:`DENSE_SPACING` arm lengths), against world triangles
    (T, 3, 3): ``collisions`` (samples touching an obstacle), ``arm_collisions`` (those
    touching with the arm), ``min_clearance`` (arm lengths, at most
    :data:`CLEARANCE_HORIZON`) and ``samples``."""
    arm = space.arm
    dense = densify(space, path, DENSE_SPACING * arm.arm_length)
    return _contacts(arm, np.asarray(tris, dtype=float).reshape(-1, 3, 3),
                     joints_of(arm, dense, shaped=True),
                     include_hand)


# --- OMPL ----------------------------------------------------------------------------------

def seed_ompl(seed: int) -> None:
    """Seed OMPL's random numbers (OMPL rejects 0, so seed + 1 is passed). OMPL logs an
    error when reseeding after its first draw, although the sequence from here on is
    then still determined by the seed; the message is silenced."""
    from ompl import util as ou

    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        ou.RNG.setSeed(int(seed) + 1)
    finally:
        ou.setLogLevel(level)


def rrt_connect(space: JointSpace, validity: Validity, seed: int, log_level):
    """An OMPL ``SimpleSetup`` with RRTConnect over ``space`` (checked by ``validity``),
    OMPL seeded with ``seed``, and a function turning a configuration row (degrees) into
    an OMPL state of it. Returns (setup, state of row)."""
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(log_level)
    seed_ompl(seed)
    state_space = space.ompl_space()
    si = ob.SpaceInformation(state_space)
    si.setStateValidityChecker(validity)
    si.setup()
    setup = og.SimpleSetup(si)
    setup.setPlanner(og.RRTConnect(si))

    def state(row):
        st = state_space.allocState()
        for i, x in enumerate(space.coordinates(row).tolist()):
            st[i] = x
        return st

    return setup, state


#: Most goal states OMPL's goal region holds (:func:`goal_rows`).
GOAL_STATES = 10


def goal_rows(planner: Planner, validity: Validity, target_c) -> list:
    """OMPL's goal region for a wrist target (canonical): the configurations Reach itself
    may end in, found by the same IK. The core generator's pose at the target first, then
    other legal swivel candidates of the same IK (Table 1's chest turn) in strength order,
    each with the first clear hand of the generator's samples; at most
    :data:`GOAL_STATES`, spread over the candidates."""
    gen, settings = planner.generator, planner.settings
    rows = []
    first = gen.solve(target_c)
    if first is not None:
        rows.append(pose_row(first))
    sol = ik.solve(planner.arm, np.asarray(target_c, float)[None], settings)
    others = []
    for k in sol.ranked(0, settings.elbow_side):
        config = list(sol.config(0, k).as_array())
        for hand in gen.hand_samples:
            row = config + list(hand)
            if validity.valid(row):
                others.append(np.array(row))
                break
    if others:
        keep = GOAL_STATES - len(rows)
        pick = np.unique(np.linspace(0, len(others) - 1, min(keep, len(others))).round().astype(int))
        rows += [others[i] for i in pick]
    return rows


def prepare_query(setup, state, start, goals) -> None:
    """Give a ``setup`` from :func:`rrt_connect` its start (a configuration row, degrees)
    and a goal region of the rows ``goals``, and set it up for :func:`run_query`."""
    from ompl import base as ob

    goal = ob.GoalStates(setup.getSpaceInformation())
    for row in goals:
        goal.addState(state(row))
    setup.setStartState(state(start))
    setup.setGoal(goal)
    setup.setup()


def run_query(setup, space: JointSpace, terminate, simplify: bool) -> tuple:
    """Solve a prepared query (:func:`prepare_query`) until ``terminate`` (seconds of wall
    time, or an OMPL termination condition); with ``simplify`` the path is then simplified
    (OMPL's shortcuts and smoothing, run until nothing improves). Returns (exact solution
    found, path (K, 7) in degrees, or None)."""
    setup.solve(terminate)
    if not setup.haveExactSolutionPath():
        return False, None
    if simplify:
        setup.simplifySolution()
    states = setup.getSolutionPath().getStates()
    coords = np.array([[s[i] for i in range(len(JOINT_NAMES))] for s in states])
    return True, space.angles(coords)


class CountingTree:
    """A BVH tree that counts the queries made of it (``queries``): put in place of an
    obstacle set's tree for a run that is not timed, it gives both planners' obstacle
    queries on one yardstick."""

    def __init__(self, tree):
        self.tree, self.queries = tree, 0

    def __getattr__(self, name):
        method = getattr(self.tree, name)

        def counted(*args, **kwargs):
            self.queries += 1
            return method(*args, **kwargs)
        return counted


def obstacle_queries(obstacles, run) -> int:
    """How many BVH queries ``run()`` makes of ``obstacles`` (its tree swapped for a
    :class:`CountingTree` while it runs)."""
    tree = obstacles.tree
    if tree is None:
        run()
        return 0
    counting = CountingTree(tree)
    obstacles.tree = counting
    try:
        run()
    finally:
        obstacles.tree = tree
    return counting.queries


# --- the race ------------------------------------------------------------------------------

@lru_cache(maxsize=1)
def workplace_triangles() -> np.ndarray:
    """Triangles (T, 3, 3) of the demo workplace, world space."""
    from reach_addon.demo import WORKPLACE
    from reach_addon.samples import triangle_soup

    verts, tris, _owners, _names = triangle_soup(WORKPLACE)
    return verts[tris]


_CONTEXT: dict = {}


def _context(planner: Planner, tris):
    """Joint space, validity checker and path measure of one planner, built once."""
    key = (id(planner), hashlib.sha1(np.ascontiguousarray(tris).tobytes()).hexdigest())
    ctx = _CONTEXT.get(key)
    if ctx is None or ctx[0] is not planner:
        space = JointSpace(planner.arm, planner.settings)
        ctx = (planner, space, Validity(planner, space),
               PathMeasure(space, tris, planner.generator.checker.check_hand))
        _CONTEXT.clear()
        _CONTEXT[key] = ctx
    return ctx[1:]


def race_targets(task: Task, chase_waypoints: int = CHASE_WAYPOINTS):
    """The targets both planners are given, in order, and a note on what was raced: a
    chase's trajectory is sampled at ``chase_waypoints`` evenly spaced frames."""
    if task.kind != "chase":
        return task.targets, ""
    n = len(task.targets)
    frames = np.unique(np.round(np.linspace(0, n - 1, chase_waypoints + 1)[:-1]).astype(int))
    note = (f"chase raced as {len(frames)} legs through the target's positions at frames "
            f"{', '.join(map(str, frames.tolist()))} of {n} (both planners)")
    return task.targets[frames], note


def race(task_name: str, planner: Planner, task: Task, seed: int = 0,
         time_limit_s: float = 10.0, *, triangles=None,
         chase_waypoints: int = CHASE_WAYPOINTS, count_queries: bool = False) -> dict:
    """Race Reach's planner against OMPL's RRTConnect on one task (see the module
    docstring). ``planner`` should be fresh: the workspace grid, where the task uses it, is
    built inside Reach's plan and counted in its time (``reach_preprocess_time_s`` says how
    much of it). ``time_limit_s`` bounds each OMPL leg. ``triangles`` (T, 3, 3), world
    space, are the obstacles for the independent check; by default the demo workplace's,
    which must then be what ``planner`` was built on. ``count_queries``: also run both
    again, untimed, counting their BVH queries. Returns plain numbers under :data:`KEYS`;
    ratios are OMPL over Reach, and None unless both paths pass the independent check."""
    from ompl import util as ou

    tris = workplace_triangles() if triangles is None else np.asarray(triangles, float)
    tris = tris.reshape(-1, 3, 3)
    if triangles is None and planner.obstacles.triangle_count != len(tris):
        raise ValueError(
            f"race(): the planner's obstacles have {planner.obstacles.triangle_count} "
            f"triangles, the demo workplace {len(tris)}; pass triangles=(T, 3, 3) world-space "
            "triangles of the planner's obstacles for the independent check")
    space, validity, measure = _context(planner, tris)
    targets, note = race_targets(task, chase_waypoints)
    if task.kind == "chase":
        task = Task("sequence", targets, task.start, task.fps,
                    names=tuple(f"frame {k}" for k in range(len(targets))))

    # Reach: the whole plan, the grid included where the task builds it.
    t0 = time.perf_counter()
    plan = planner.plan(task)
    reach_time = time.perf_counter() - t0
    preprocess = float(getattr(plan.stats, "preprocess_time_s", 0.0) or 0.0)
    reach = measure(np.array([pose_row(p) for p in plan.poses]))

    # OMPL: leg by leg from the same start, each to the goal region of the same IK.
    generator = planner.generator
    start = pose_row(generator.config_pose(task.start))

    def ompl_legs():
        path, seconds, ok = [start], 0.0, True
        for leg, target in enumerate(targets):
            # the planner and its spaces are set up before the clock starts
            setup, state = rrt_connect(space, validity, seed + leg, ou.LOG_ERROR)
            t0 = time.perf_counter()
            goals = goal_rows(planner, validity, planner.arm.to_canonical_points(target))
            exact, leg_path = False, None
            if goals:
                prepare_query(setup, state, path[-1], goals)
                exact, leg_path = run_query(setup, space, float(time_limit_s), simplify=True)
            seconds += time.perf_counter() - t0
            ok &= exact
            if leg_path is not None:
                path += list(leg_path[1:])
        return path, seconds, ok

    checks0 = validity.calls
    path, ompl_time, ompl_ok = ompl_legs()
    checks = validity.calls - checks0
    ompl = measure(np.array(path))

    queries = {}
    if count_queries:
        fresh = Planner(planner.arm, planner.obstacles, planner.settings)
        queries["reach_obstacle_queries"] = obstacle_queries(
            planner.obstacles, lambda: fresh.plan(task))
        queries["ompl_obstacle_queries"] = obstacle_queries(planner.obstacles, ompl_legs)

    reach_passed = bool(plan.success) and reach["collisions"] == 0
    ompl_passed = bool(ompl_ok) and ompl["collisions"] == 0

    def ratio(x, y):
        if not (reach_passed and ompl_passed):
            return None
        return float(x / y) if y > 0 else math.inf

    return {
        "task": str(task_name),
        "reach_time_s": float(reach_time),
        "ompl_time_s": float(ompl_time),
        "reach_path_length": reach["path_length"],
        "ompl_path_length": ompl["path_length"],
        "reach_mean_f_r": reach["mean_f_r"],
        "ompl_mean_f_r": ompl["mean_f_r"],
        "reach_collisions": reach["collisions"],
        "ompl_collisions": ompl["collisions"],
        "time_ratio": ratio(ompl_time, reach_time),
        "path_length_ratio": ratio(ompl["path_length"], reach["path_length"]),
        "f_r_difference": ompl["mean_f_r"] - reach["mean_f_r"],
        "reach_success": bool(plan.success),
        "ompl_success": bool(ompl_ok),
        "reach_passed": reach_passed,
        "ompl_passed": ompl_passed,
        "reach_arm_collisions": reach["arm_collisions"],
        "ompl_arm_collisions": ompl["arm_collisions"],
        "reach_min_clearance": reach["min_clearance"],
        "ompl_min_clearance": ompl["min_clearance"],
        "reach_preprocess_time_s": preprocess,
        "reach_nodes_searched": int(plan.stats.nodes_searched),
        "ompl_validity_checks": int(checks),
        "legs": int(len(targets)),
        "note": note,
        **queries,
    }


