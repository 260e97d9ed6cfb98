"""Reach against OMPL's RRTConnect on the paper's four tasks: one race per task.

``python -m bench.ompl_race`` plans the four demo tasks (:func:`reach_addon.demo.demo_tasks`,
the workplace of :data:`reach_addon.demo.WORKPLACE`) with Reach's planner and with the Open
Motion Planning Library, then measures both paths the same way and prints a table.
:func:`race` is what the full benchmark calls (repeatedly, for medians).

What each side does
-------------------
* **Reach**: ``Planner.plan(task)`` on a fresh planner, timed from the call to the
  returned plan: the workspace grid where the task builds it (the paper's preprocessing,
  also reported on its own as ``reach_preprocess_time_s``), the best-first search,
  shortcut smoothing, minimum-jerk timing into frames, the hand and the plan's statistics.
* **OMPL**: ``RRTConnect`` in a ``SimpleSetup``, then ``simplifySolution()``: OMPL's path
  simplifier (shortcuts, vertex reduction, smoothing) with no time limit, which runs until
  nothing improves, so the result does not depend on the machine's speed. The state
  space, ``SpaceInformation`` and ``SimpleSetup`` are built before the clock starts; the
  clock runs from the goal region's inverse kinematics to the simplified path. OMPL's
  random numbers are seeded (``ompl.util.RNG.setSeed``) before every leg, so a race is
  repeatable, and the bench races with many seeds (medians and spread).

How the comparison is made fair
-------------------------------
* **Same joint space.** OMPL plans over the configuration the core animates: body (chest)
  rotation, the shoulder angles α, β, γ and elbow flexion of :mod:`reach_addon.core.arm`,
  plus the hand's two wrist angles, which the core also chooses per pose (it turns the hand
  to clear obstacles). The bounds are the joint limits of ``Settings``; the elevation limit
  √(α² + β²) ≤ ``Settings.elevation_max`` and, when ``Settings.elbow_side`` is
  ``"require"``, Algorithm 1's elbow side are part of validity, because the core never
  accepts a pose that breaks them either. Forward kinematics follows the same formulas
  (the test checks it against :func:`reach_addon.core.arm.forward_kinematics`).
* **Same collision test.** A state is valid when the core would accept the pose: the
  body's own capsules tested as :class:`~reach_addon.core.generator.ConfigurationGenerator`
  tests them (:func:`reach_addon.core.ik.segment_hits_body`), and the arm and hand against
  the obstacles by the core's :class:`~reach_addon.core.collision.CollisionChecker`, with
  the same clearance margin.
* **Same start, the same goal.** The first leg starts from the task's start pose, as
  the core's does; each later leg from where OMPL's previous leg ended. Reach may end in
  any legal, clear pose with the wrist on the target, so OMPL's goal is a region of such
  poses (:func:`goal_rows`): the core generator's own pose for the target and up to
  :data:`GOAL_STATES` - 1 other legal swivel solutions of the same IK, each with a clear
  hand, found without knowledge of any path.
* **Comparable motion resolution.** Each joint's coordinate is its angle in radians times
  the farthest it can carry the wrist (its lever arm, in arm lengths; the wrist angles by
  the hand's length), so a distance in OMPL's space approximates wrist travel in arm
  lengths. OMPL's motion validator checks states every ``Settings.step`` (0.02) of that
  distance: the core's step between search positions.
* **Same count of work.** OMPL's states checked are reported (the goal region's
  included), and with ``count_queries`` both planners' BVH queries, counted the same way
  on an untimed re-run (:func:`obstacle_queries`); Reach's nodes searched beside them.
* **Only passing paths are compared.** A path that fails or touches by the independent
  check is shown as a failure; the time and length ratios are given only where both pass.
* **Same yardstick.** Both paths are interpolated linearly in joint space, densely enough
  that the wrist moves at most 0.002 arm lengths between samples (Reach's between its
  frames, OMPL's between its waypoints), and every sample is measured the same way: wrist
  path length in arm lengths, mean strength category f_R (``core.strength.strength_category``) and
  contacts found by an independent check (below).

The independent check
---------------------
Every sample's four segments (clavicle, upper arm, forearm, hand, with the arm's radii)
are measured against the obstacle triangles by exact segment–triangle distance
(:func:`verification.clearance.independent_check`, numpy, sharing no code with the
planner's BVH checker). A sample *collides* when
some segment comes closer to a triangle than its radius (no clearance margin: actual
contact). The chain starts at the sternum, outside every obstacle, so a segment inside a
closed obstacle implies a segment crossing its surface, which the test sees. The body's own
capsules are not part of this check.

What differs (and is not hidden)
--------------------------------
* The core ranks poses by shoulder strength, keeps joint changes within its smoothness
  bound and turns the chest by Table 1; OMPL only needs valid states. The chest rotation is
  a free joint for OMPL (within ``Settings.chest_rotation_max``). The f_R and path length
  columns show what those preferences buy.
* Reach's time includes turning the path into timed frames and the plan's statistics;
  OMPL produces no timing.
* Multi-target tasks (``sequence``): Reach plans the whole task in one call; OMPL plans
  each leg, and its times and paths are summed. A chase re-plans every
  frame, which has no OMPL counterpart: both planners instead race a few representative
  legs, from the start pose through the target's positions at ``chase_waypoints`` evenly
  spaced frames (Reach plans them as one ``sequence`` task), and the row says so.
"""

from __future__ import annotations

import argparse
import hashlib
import math
import sys
import time
from functools import lru_cache

import numpy as np

from reach_addon.core import Planner, Task, ik
from reach_addon.core.sampling import (JOINT_NAMES, StateValidity, densify_rows, joints_of,
                                      pose_row)
from reach_addon.core.sampling import JointSpace as CoreJointSpace
from reach_addon.core.strength import strength_category
from verification.clearance import independent_check

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
        joints = joints_of(arm, dense)
        wrists = joints[:, 3]
        travel = float(np.linalg.norm(np.diff(wrists, axis=0), axis=1).sum()) if len(dense) > 1 else 0.0
        levels = strength_category(dense[:, 1], dense[:, 2], st)
        hits, arm_hits, least = independent_check(arm, arm.to_world_points(joints), self.tris,
                                                  self.include_hand, CLEARANCE_HORIZON * length)
        return {"path_length": travel / length, "mean_f_r": float(np.mean(levels)),
                "collisions": int(hits), "arm_collisions": int(arm_hits),
                "min_clearance": least / length,
                "samples": int(len(dense))}


# --- OMPL ----------------------------------------------------------------------------------

def _seed_ompl(seed: int) -> None:
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
    _seed_ompl(seed)
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


# --- command line --------------------------------------------------------------------------

def _ratio(x) -> str:
    return "–" if x is None else f"{x:.2f}"


def _hits(total: int, arm: int) -> str:
    return f"{total} ({arm})"


def format_table(rows) -> str:
    """The race results as a text table, with notes."""
    head = (f"{'task':15s} {'legs':>4s} {'Reach s':>8s} {'OMPL s':>8s} {'×':>6s} "
            f"{'Reach len':>9s} {'OMPL len':>8s} {'Reach f_R':>9s} {'OMPL f_R':>8s} "
            f"{'Reach hits':>10s} {'OMPL hits':>9s}")
    lines = [head, "-" * len(head)]
    for r in rows:
        flag = "" if r["reach_success"] and r["ompl_success"] else (
            "  (" + ", ".join(k for k, ok in (("Reach failed", r["reach_success"]),
                                              ("OMPL failed", r["ompl_success"])) if not ok) + ")")
        lines.append(
            f"{r['task']:15s} {r['legs']:4d} {r['reach_time_s']:8.3f} {r['ompl_time_s']:8.3f} "
            f"{_ratio(r['time_ratio']):>6s} {r['reach_path_length']:9.2f} {r['ompl_path_length']:8.2f} "
            f"{r['reach_mean_f_r']:9.2f} {r['ompl_mean_f_r']:8.2f} "
            f"{_hits(r['reach_collisions'], r['reach_arm_collisions']):>10s} "
            f"{_hits(r['ompl_collisions'], r['ompl_arm_collisions']):>9s}{flag}")
    lines.append("")
    lines.append("times in seconds (× = OMPL / Reach); lengths: wrist path in arm lengths; f_R: "
                 "mean strength category along the path (0 strongest, 2 weakest); hits: densely "
                 f"interpolated poses ({DENSE_SPACING} arm lengths of wrist travel apart) that "
                 "touch an obstacle by the independent check, (n) of them with the arm, the "
                 "rest with the hand alone")
    lines += [f"note: {r['note']}" for r in rows if r["note"]]
    return "\n".join(lines)


def main(argv=None) -> int:
    """Race the four demo tasks and print the table."""
    parser = argparse.ArgumentParser(prog="python -m bench.ompl_race", description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, default=0, help="OMPL's random seed (default 0)")
    parser.add_argument("--time-limit", type=float, default=10.0,
                        help="seconds OMPL may spend on one leg (default 10)")
    parser.add_argument("--task", action="append", default=None,
                        help="race only this task (repeatable): collision_free, rotation, "
                             "guided, chase")
    args = parser.parse_args(argv)

    import bpy  # noqa: F401  (mathutils and its BVH tree, for the core's obstacles)

    from reach_addon.core import Settings
    from reach_addon.demo import WORKPLACE, demo_tasks
    from reach_addon.samples import obstacles, standard_arm

    tasks = [(n, t) for n, t in demo_tasks() if args.task is None or n in args.task]
    if not tasks:
        print(f"no task named {', '.join(args.task)}; choose from collision_free, rotation, "
              "guided, chase", file=sys.stderr)
        return 2
    rows = [race(name, Planner(standard_arm(), obstacles(WORKPLACE), Settings()), task,
                 seed=args.seed, time_limit_s=args.time_limit, count_queries=True)
            for name, task in tasks]
    print(format_table(rows))
    print("\nwork: " + "; ".join(
        f"{r['task']} Reach {r['reach_nodes_searched']} nodes, "
        f"{r['reach_obstacle_queries']} BVH queries (grid {1000 * r['reach_preprocess_time_s']:.0f}"
        f" ms in its time) / OMPL {r['ompl_validity_checks']} states checked, "
        f"{r['ompl_obstacle_queries']} BVH queries" for r in rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
