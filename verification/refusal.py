"""Is a refusal true? An independent cross-check of a failed reach's reason.

:func:`check_report` answers for every refused target of a bake's report, on the bake's
input file, with a :class:`Verdict` whose ``status`` is one of :data:`STATUSES`:

``confirmed``
    the check agrees (no path within its budget, no valid pose at the target at all, the
    start's skin meets an obstacle, the target lies inside a closed obstacle);
``false_refusal``
    the check contradicts it: a clear path exists (its length and goal state are given),
    or the start's arm and hand skin are clear of every obstacle;
``inconclusive``
    the check ran but cannot decide (a start the core's own test refuses for anything but
    its nearness to an obstacle; an arm without skin whose bones are clear);
``unchecked``
    the reason is not one this module checks (a later target of any task but a chase, a
    start inside the character's own body capsules, bad input). A chase's ``no_path``
    is a path claim to where the target ends, within the chase's frames at its limits
    (:func:`chase_frames`): a path found that does not fit them is inconclusive.

The path claim (:data:`PATH_REASONS`) is checked by :func:`check_path_claim`: OMPL's
RRTConnect in the core's seven joints with the core's own state test, on the planner's
problem rebuilt by the pipeline's readers (:func:`rebuild`), toward a goal region of valid
states with the wrist within the goal tolerance (:func:`goal_region`); ``budget_s``
seconds (and at most ``max_states`` states) where that region is not empty. A start the
core's test refuses for being nearer an obstacle than the clearance, or for its model
standing into one (a start in contact), is searched from with the obstacle part of that
test replaced by the arm's least clearance, held to the start's own
(:func:`_held_validity`): a way that never comes nearer, nor goes deeper, than the start.
A ``start_held`` whose model is deeper than a start may touch (a bone through an
obstacle's surface included) by :func:`check_deep_start`: the model's capsules at the
start against the obstacles, by this module's own geometry. The start
claim (``start_in_collision``) by :func:`check_start`: Blender's evaluated skin of the
reaching arm and hand against the obstacles' triangles (:mod:`verification.geometry`), or,
where the claim is that the chest lies inside a closed mesh, that point by ray parity;
where it is that an animated obstacle moves into the start pose on a later frame, the skin
as it starts against that obstacle on that frame; a later target's start (where the one
before it ended, at its own frame) is unchecked, unless no target before it moved the arm
(a plan refused at its start refuses every target with the start's claim): it is then
the rig's start, checked as the first target's is. The claim ``target_moved`` by
:func:`check_target_moved`: the target object as Blender evaluates it on the arrival
frame against the start frame.
``target_in_obstacle`` by :func:`check_target_inside`, and where the target lies inside no
closed obstacle by :func:`check_no_pose_at` (no valid state within the goal tolerance of
it). Obstacles are this module's own
reading of the README's rules (:func:`scene_obstacles`). The method in full, and why:
``docs/design.md``, *The refusal cross-check*.
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import asdict, dataclass

import numpy as np

from reach_addon.core import ik
from reach_addon.core.errors import (ARM_DOES_NOT_FIT, NEEDS_LEAN, NEEDS_STEP, NO_PATH,
                                     OUT_OF_REACH, START_HELD, START_IN_COLLISION,
                                     TARGET_IN_OBSTACLE, TARGET_MOVED)
from reach_addon.core.sampling import (JOINT_NAMES, JointSpace, StateValidity, checked_joints_of_one,
                                       joints_of, joints_of_one)
from reach_addon.core.settings import Settings

from . import geometry
from .race import JointSpace as OmplJointSpace
from .race import seed_ompl

#: The reasons whose claim is "no clear path": checked by OMPL (:func:`check_path_claim`).
PATH_REASONS = (NO_PATH, ARM_DOES_NOT_FIT, NEEDS_LEAN, NEEDS_STEP, OUT_OF_REACH, START_HELD)
#: Every reason this module answers for (the others are ``unchecked``).
CHECKED_REASONS = PATH_REASONS + (START_IN_COLLISION, TARGET_IN_OBSTACLE, TARGET_MOVED)
CONFIRMED, FALSE_REFUSAL = "confirmed", "false_refusal"
INCONCLUSIVE, UNCHECKED = "inconclusive", "unchecked"
STATUSES = (CONFIRMED, FALSE_REFUSAL, INCONCLUSIVE, UNCHECKED)
#: Seconds OMPL may search for a path where a goal region exists.
OMPL_BUDGET_S = 10.0
#: Most states the goal region keeps.
GOAL_STATES = 64
#: Chest rotation step of the goal region's IK (degrees).
CHEST_STEP_DEG = 5.0
#: Swivel step of the goal region's IK (degrees; the planner's default is 5).
SWIVEL_STEP_DEG = 2.0
#: Settings whose only use here is the metric of :func:`wrist_travel` (no limits read).
_NO_LIMITS = Settings()


@dataclass
class Verdict:
    """The cross-check of one refused target.

    ``status``: one of :data:`STATUSES`; ``detail``: one line saying why; ``method``:
    what decided (``ik`` no valid goal state, ``ompl`` a search, ``skin``, ``bones``,
    ``point_in_mesh``, ``object`` or ``none``); ``seconds``: wall time of this check. For the path
    claim: ``goal_states`` (valid states in the goal region), ``states_checked`` (validity
    tests, the goal region's and OMPL's), ``table1_chest_deg`` (Table 1's chest rotation at
    the target), and for a path found ``path_length`` (how far the wrist travels along it,
    arm lengths: :func:`wrist_travel`) and ``goal_state`` (the path's last state, 7 angles in degrees,
    :data:`~reach_addon.core.sampling.JOINT_NAMES`). For the start claim ``clearance``:
    the least distance between the arm's skin and the obstacles (arm lengths; 0 when they
    meet)."""

    target: str
    reason: str
    status: str
    detail: str
    method: str = "none"
    seconds: float = 0.0
    goal_states: int | None = None
    states_checked: int | None = None
    table1_chest_deg: float | None = None
    path_length: float | None = None
    goal_state: list | None = None
    clearance: float | None = None

    def to_dict(self) -> dict:
        return asdict(self)


# --- the path claim: the core's problem, OMPL's search ------------------------------------

@dataclass
class GoalRegion:
    """Valid goal states found by :func:`goal_region`: ``rows`` (N, 7) in degrees; how many
    legal arm poses the IK gave (``legal``), how many of those had the arm clear of the
    obstacles (``arm_clear``), and the chest rotations tried (``bodies``)."""

    rows: np.ndarray
    legal: int
    arm_clear: int
    bodies: list
    wrists: int


def _spread(n: int) -> np.ndarray:
    """An order of range(n) that spreads its first few over the whole range (golden-ratio
    steps), so that a goal region cut short still covers the swivel circle."""
    return np.argsort((np.arange(n) * 0.6180339887498949) % 1.0, kind="stable")


def goal_region(planner, validity: StateValidity, target_c, *, most: int = GOAL_STATES,
                chest_step: float = CHEST_STEP_DEG,
                swivel_step: float = SWIVEL_STEP_DEG) -> GoalRegion:
    """Valid states with the wrist within the goal tolerance of ``target_c`` (canonical),
    found by the core's IK (see the module docstring). ``planner`` gives the arm, the
    settings and the generator's hand samples and collision checker; ``validity`` (on the
    space widened by the start) decides each state. Returns a :class:`GoalRegion`."""
    arm, s = planner.arm, planner.settings
    target = np.asarray(target_c, dtype=float)
    found = _goal_rows(planner, validity, target, most, chest_step, swivel_step)
    if len(found.rows):
        return found
    tol = 0.95 * s.goal_tolerance * arm.arm_length
    toward = np.asarray(arm.shoulder, dtype=float) - target
    toward = toward / max(float(np.linalg.norm(toward)), 1e-12)
    ball = [target + tol * d for d in np.vstack([np.eye(3), -np.eye(3), toward[None]])]
    legal, arm_clear = found.legal, found.arm_clear
    for wrist in ball:
        part = _goal_rows(planner, validity, wrist, most, chest_step, swivel_step)
        legal += part.legal
        arm_clear += part.arm_clear
        if len(part.rows):
            return GoalRegion(part.rows, legal, arm_clear, part.bodies, 1 + len(ball))
    return GoalRegion(np.zeros((0, 7)), legal, arm_clear, found.bodies, 1 + len(ball))


def _goal_rows(planner, validity, wrist, most, chest_step, swivel_step) -> GoalRegion:
    arm, s, gen = planner.arm, planner.settings, planner.generator
    space = validity.space
    fine = s.replace(swivel_step=min(float(swivel_step), float(s.swivel_step)))
    lo, hi = float(space.lo[0]), float(space.hi[0])
    table1 = float(np.clip(ik.solve(arm, wrist[None], s).body[0], lo, hi))
    grid = np.arange(lo, hi, float(chest_step)).tolist() + [hi, table1]
    bodies = sorted({round(b, 9) for b in grid if lo <= b <= hi},
                    key=lambda b: (abs(b - table1) > 1e-9, abs(b - table1)))
    per = max(2, int(math.ceil(most / max(1, len(bodies)))))
    hands = sorted(gen.hand_samples, key=lambda h: (abs(h[0]) + abs(h[1]), h))
    checker = gen.checker
    per_body, legal_n, clear_n = [], 0, 0
    for body in bodies:
        sol = ik.solve(arm, wrist[None], fine, None, float(body))
        legal = np.flatnonzero(sol.legal[0])
        legal_n += len(legal)
        rows = []
        for k in legal[_spread(len(legal))]:
            config = sol.config(0, int(k)).as_array()
            config[3] = (config[3] + 180.0) % 360.0 - 180.0
            if not (np.all(config >= space.lo[:5] - 1e-9) and np.all(config <= space.hi[:5] + 1e-9)):
                continue
            joints = sol.joints(0, int(k))[0]
            if checker.collides(arm.to_world_points(joints), include_hand=False):
                continue                       # the arm itself is blocked: no hand helps
            clear_n += 1
            for hand in hands:
                q = np.concatenate([config, np.asarray(hand, dtype=float)])
                if validity.valid(q):
                    rows.append(q)
                    break
            if len(rows) >= per:
                break
        per_body.append(rows)
    out = []
    while any(per_body) and len(out) < most:
        for rows in per_body:
            if rows and len(out) < most:
                out.append(rows.pop(0))
    return GoalRegion(np.array(out).reshape(-1, 7), legal_n, clear_n, bodies, 1)


def why_invalid(validity: StateValidity, q) -> str:
    """Why the core's state test refuses configuration ``q`` (degrees): which of its parts
    (elevation, elbow side, the body's capsules, an obstacle) — for messages."""
    arm = validity.arm
    q = [float(v) for v in q]
    if math.hypot(q[1], q[2]) > validity.elevation_max:
        return "the elevation limit"
    joints = joints_of_one(arm, q)
    hit = validity.checker.first_hit(arm.to_world_points(checked_joints_of_one(arm, q, joints)))
    if hit is not None:
        return f"the {hit[0]} touches '{hit[1]}' (within the clearance)"
    if arm.body_capsules:
        return "the arm is inside the character's own body capsules, or the elbow off its side"
    return "the elbow is off its side"


def _wrist_goal_class():
    from ompl import base as ob

    class WristGoal(ob.GoalSampleableRegion):
        """OMPL's goal region: states whose wrist is within ``tolerance`` arm lengths of
        ``target`` (canonical); its samples cycle through ``coords`` (valid states found by
        :func:`goal_region`, in OMPL's coordinates)."""

        def __init__(self, si, space, target, tolerance, coords):
            super().__init__(si)
            self.space, self.target = space, np.asarray(target, dtype=float)
            self.length = space.arm.arm_length
            self.coords = [list(map(float, c)) for c in coords]
            self.scale = space.scale.tolist()
            self.drawn = 0
            self.setThreshold(float(tolerance))

        def distanceGoal(self, state):
            q = [state[i] / k for i, k in enumerate(self.scale)]
            wrist = joints_of_one(self.space.arm, q)[3]
            return math.dist(wrist, self.target.tolist()) / self.length

        def sampleGoal(self, state):
            c = self.coords[self.drawn % len(self.coords)]
            self.drawn += 1
            for i, x in enumerate(c):
                state[i] = x

        def maxSampleCount(self):
            return len(self.coords)

    return WristGoal



#: OMPL's simplifier is run this many times on a path found where a score rates the
#: result (a chase's frames), each seeded its own way, and the best kept (:func:`ompl_search`;
#: once where none does): it shortens the path in the metric, not in a chase's frames, and
#: fuzz seed 5804's way needed 25 to 30 frames by the seed (25 first at the 16th) ...
SIMPLIFY_TRIES = 16
#: ... each for at most this many state tests: a count, not a time, so that the path does
#: not depend on how busy the machine is.
SIMPLIFY_STATES = 20000


def ompl_search(validity: StateValidity, start_row, target_c, goals, *, budget_s: float,
                max_states: int | None = None, seed: int = 0, score=None):
    """RRTConnect from ``start_row`` (degrees) to the :class:`WristGoal` region of
    ``target_c`` sampled by ``goals`` (N, 7) in ``validity``'s space, for at most
    ``budget_s`` seconds (and ``max_states`` validity tests, if given); a path found is
    then shortened by OMPL's simplifier, seeded and stopped after :data:`SIMPLIFY_STATES`
    state tests (the same paths whatever the machine's load; fuzz seed 5804's chase needed
    25 frames in one run and 30 in another when the simplifier ran for a second); with
    ``score`` (angles (K, 7) → a number), :data:`SIMPLIFY_TRIES` times, each seeded its
    own way, and the one it rates lowest is kept. Returns
    (path (K, 7) in degrees or None, its length in the metric, states tested by the
    search)."""
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    space = validity.space
    ou.setLogLevel(ou.LOG_ERROR)
    seed_ompl(seed)
    state_space = space.ompl_space()
    si = ob.SpaceInformation(state_space)
    scale = space.scale.tolist()
    calls0 = validity.calls

    def valid(state):
        return validity.valid([state[i] / k for i, k in enumerate(scale)])

    si.setStateValidityChecker(valid)
    si.setup()
    setup = og.SimpleSetup(si)
    setup.setPlanner(og.RRTConnect(si))
    start = state_space.allocState()
    for i, x in enumerate(space.coordinates(start_row).tolist()):
        start[i] = x
    setup.setStartState(start)
    goal = _wrist_goal_class()(si, space, target_c, validity.settings.goal_tolerance,
                               space.coordinates(goals))
    setup.setGoal(goal)
    setup.setup()
    ptc = ob.timedPlannerTerminationCondition(float(budget_s))
    if max_states is not None:
        limit = int(max_states)
        ptc = ob.plannerOrTerminationCondition(
            ptc, ob.PlannerTerminationCondition(lambda: validity.calls - calls0 >= limit))
    setup.solve(ptc)
    tested = validity.calls - calls0
    if not setup.haveExactSolutionPath():
        return None, None, tested
    raw = setup.getSolutionPath()
    best = None
    for k in range(SIMPLIFY_TRIES if score is not None else 1):
        seed_ompl(seed + 1 + k)
        path = og.PathGeometric(raw)
        c0 = validity.calls
        og.PathSimplifier(si, goal).simplify(path, ob.PlannerTerminationCondition(
            lambda c0=c0: validity.calls - c0 >= SIMPLIFY_STATES))
        coords = np.array([[s[i] for i in range(len(JOINT_NAMES))] for s in path.getStates()])
        angles = space.angles(coords)
        value = float(path.length()) if score is None else float(score(angles))
        if best is None or value < best[0]:
            best = (value, angles, float(path.length()))
    return best[1], best[2], tested


def wrist_travel(arm, path, step: float) -> float:
    """How far the wrist travels (arm lengths) along ``path`` (K, 7, degrees), its states
    joined by straight joint-space motions sampled every ``step`` (arm lengths of the
    lever-arm metric; :class:`~reach_addon.core.sampling.JointSpace`)."""
    space = JointSpace(arm, _NO_LIMITS)
    rows = [np.asarray(path[0], dtype=float)]
    for qa, qb in zip(path[:-1], path[1:]):
        n = max(1, int(math.ceil(space.distance(qa, qb) / step)))
        rows += [qa + (qb - qa) * (k / n) for k in range(1, n + 1)]
    wrists = joints_of(arm, np.array(rows))[:, 3]
    return float(np.linalg.norm(np.diff(wrists, axis=0), axis=1).sum()) / arm.arm_length


def chase_frames(planner, path, fps: float, share: float = 0.25) -> int:
    """Frames a chase needs to follow ``path`` (K, 7, degrees) from its first state to its
    last at its limits: the wrist at most ``Settings.chase_max_speed``, each of the arm's
    five angles at most ``Settings.max_joint_step`` for each step length the wrist may go
    (``chase_max_speed / fps / step`` of them a frame), the hand's
    whole turn, roll included, at most ``Settings.hand_space_turn_speed``. The path is
    cut into pieces ``share`` of a step of the joint metric long; each piece takes the
    frames its tightest limit asks at a constant rate, so a motion along it in the sum of
    those frames keeps every limit. A bound from above: the chase may have quicker ways,
    not slower ones along this path."""
    from reach_addon.core.arm import ArmConfig, frame_turn

    arm, s = planner.arm, planner.settings
    gen = planner.generator
    wrist_bound = s.chase_max_speed / fps * arm.arm_length
    joint_bound = s.chase_max_speed / fps / s.step * s.max_joint_step
    hand_bound = s.hand_space_turn_speed / fps
    space = JointSpace(arm, _NO_LIMITS)
    rows = [np.asarray(path[0], dtype=float)]
    for qa, qb in zip(path[:-1], path[1:]):
        n = max(1, int(math.ceil(space.distance(qa, qb) / (share * s.step))))
        rows += [qa + (qb - qa) * (k / n) for k in range(1, n + 1)]
    poses = [gen.config_pose(ArmConfig.from_array(r[:5]), (float(r[5]), float(r[6])))
             for r in rows]
    total = 0.0
    for (ra, a), (rb, b) in zip(zip(rows, poses), zip(rows[1:], poses[1:])):
        total += max(math.dist(a.wrist.tolist(), b.wrist.tolist()) / wrist_bound,
                     float(np.abs(rb[:5] - ra[:5]).max()) / joint_bound,
                     frame_turn(a, b) / hand_bound)
    return int(math.ceil(total - 1e-9))


def _touches_along(planner, obstacles, path) -> bool:
    """Does the arm and hand, at every state of ``path`` (K, 7, degrees) and between them
    a step of the metric apart, touch ``obstacles`` (no margin) anywhere?"""
    from reach_addon.core.collision import CollisionChecker

    arm, s = planner.arm, planner.settings
    checker = CollisionChecker(arm, obstacles, s.replace(clearance=0.0))
    space = JointSpace(arm, _NO_LIMITS)
    for qa, qb in zip(path[:-1], path[1:]):
        n = max(1, int(math.ceil(space.distance(qa, qb) / s.step)))
        for k in range(n + 1):
            q = [float(x) for x in qa + (qb - qa) * (k / n)]
            if checker.first_hit(arm.to_world_points(checked_joints_of_one(arm, q))):
                return True
    return False


def _path_valid(validity: StateValidity, path) -> bool:
    """Is every state of ``path`` (K, 7, degrees) and every state between them, a step of
    the metric apart, valid by the core's test? (OMPL checked it so; this re-checks it
    outside OMPL, on the angles it returned.)"""
    space = validity.space
    step = space.settings.step
    for qa, qb in zip(path[:-1], path[1:]):
        n = max(1, int(math.ceil(space.distance(qa, qb) / step)))
        for k in range(n + 1):
            if not validity.valid(qa + (qb - qa) * (k / n)):
                return False
    return True


def _leaves_as_reach_does(held: HeldValidity, path):
    """For a path from a start in contact, searched with :class:`HeldValidity` (never
    deeper than the start): does it also leave contact as the planner's escape promises
    (:mod:`reach_addon.core.contact`), at every state a step of the metric apart: never
    deeper than the least depth it has reached, and never back in once out? The
    measure's tolerance is allowed either way. None if so; else (the share of the way
    where it breaks the rule, the clearance there, the best before it), in arm lengths.
    A path that slides out part way and back in is not one Reach would take: HeldValidity,
    a state test, cannot hold a rule about the path (fuzz seed 7074: a straight path to
    the chest's limit, never deeper than the start, which a chase from the escape's end
    could not follow in its frames)."""
    from reach_addon.core.collision import CLEARANCE_TOLERANCE

    arm, space = held.arm, held.space
    length = arm.arm_length
    tolerance = CLEARANCE_TOLERANCE * length
    step = space.settings.step
    total = sum(space.distance(a, b) for a, b in zip(path[:-1], path[1:])) or 1.0
    best, done = -math.inf, 0.0
    for qa, qb in zip(path[:-1], path[1:]):
        d = space.distance(qa, qb)
        n = max(1, int(math.ceil(d / step)))
        for k in range(n + 1):
            q = qa + (qb - qa) * (k / n)
            world = arm.to_world_points(checked_joints_of_one(arm, [float(x) for x in q]))
            c = held.checker.least_clearance(world, length)
            if best > -math.inf and c < min(best, 0.0) - tolerance:
                return (done + d * k / n) / total, c / length, best / length
            best = max(best, c)
        done += d
    return None


def check_path_claim(planner, start_row, target_c, *, target: str = "", reason: str = NO_PATH,
                     budget_s: float = OMPL_BUDGET_S, max_states: int | None = None,
                     seed: int = 0, search: bool = True, frames=None,
                     moving=None) -> Verdict:
    """Cross-check the refusal "no clear path from ``start_row`` to ``target_c``".

    ``planner``: a :class:`reach_addon.core.Planner` holding the problem (arm model,
    obstacles, settings); ``start_row``: the start configuration (7 angles, degrees, as
    :func:`reach_addon.core.sampling.pose_row` gives it); ``target_c``: the target in the
    canonical frame (figure units). ``budget_s`` / ``max_states``: OMPL's budget;
    ``seed``: OMPL's random seed. ``search`` False: only the goal region is checked (a
    start the caller does not know) — confirmed if it is empty, else unchecked. ``frames``:
    for a chase, (frames the chase had, frames per second): a path found is a false refusal
    only where the chase could follow it in those frames at its limits
    (:func:`chase_frames`), else inconclusive. ``moving``: where obstacles move (the
    planner's obstacles then hold every place they take), those places alone (a
    :class:`reach_addon.core.Obstacles`); a path found from a start in contact that touches
    any of them on its way is inconclusive: the promise is that the arm, once out of
    contact, is never touched again by an obstacle where it is on that frame, and a way
    in contact with some place the obstacle takes meets it or not by when it passes,
    which a search without time cannot tell (fuzz seed 9192: a box the start touches
    that moves off the upper arm and back onto it while the arm is on its way out).
    Returns a
    :class:`Verdict` (see the module docstring for the method)."""
    t0 = time.perf_counter()
    arm, s = planner.arm, planner.settings
    start_row = np.asarray(start_row, dtype=float)
    space = OmplJointSpace(arm, s, start_row)
    validity = StateValidity(arm, s, planner.generator.checker, space)
    target_c = np.asarray(target_c, dtype=float)
    table1 = float(ik.solve(arm, target_c[None], s).body[0])
    region = goal_region(planner, validity, target_c)
    v = Verdict(target, reason, CONFIRMED, "", "ik", goal_states=len(region.rows),
                table1_chest_deg=round(table1, 3))
    chest = f"chest {round(space.lo[0]) + 0}..{round(space.hi[0]) + 0}°"
    held = None
    if not len(region.rows):
        v.detail = (f"no valid goal state: the IK over the swivel circle ({SWIVEL_STEP_DEG:g}° "
                    f"steps), the chest range ({chest}, {CHEST_STEP_DEG:g}° steps) and "
                    f"{len(planner.generator.hand_samples)} hand samples at the target "
                    f"{'and its tolerance ball ' if region.wrists > 1 else ''}gave "
                    f"{region.legal} legal arm poses, {region.arm_clear} with the arm clear, "
                    "none valid with a hand")
    elif not search:
        v.status, v.method = UNCHECKED, "ik"
        v.detail = (f"{len(region.rows)} valid goal states exist; the start (where the "
                    "previous leg ended) is known only to the planner, so no path is searched")
    elif not validity.valid(start_row) and \
            (held := _held_validity(planner, space, start_row)) is None:
        v.status, v.method = INCONCLUSIVE, "ik"
        v.detail = (f"{len(region.rows)} valid goal states exist, but the start pose is not "
                    f"valid by the core's test ({why_invalid(validity, start_row)}): the "
                    "planner first moves such a start out of contact, which a search from it "
                    "cannot")
    else:
        # a start nearer an obstacle than the clearance, or whose model touches one, is
        # searched from with the test loosened to pass it (never nearer, never deeper)
        searcher, share = held if held is not None else (validity, None)
        keep = "" if share is None else (
            f" keeping at least the start's own clearance ({share:.4f} arm lengths)"
            if share >= 0.0 else
            f" never deeper in than Reach's model of the arm starts ({-share:.4f} arm lengths)")
        v.method = "ompl"
        score = None if frames is None else (   # a chase: the fewest frames, then shortest
            lambda q: chase_frames(planner, q, frames[1])
            + 1e-3 * sum(space.distance(a, b) for a, b in zip(q[:-1], q[1:])))
        path, length, tested = ompl_search(searcher, start_row, target_c, region.rows,
                                           budget_s=budget_s, max_states=max_states, seed=seed,
                                           score=score)
        budget = f"{budget_s:g} s" + (f" / {max_states} states" if max_states else "")
        if path is None:
            v.detail = (f"OMPL RRTConnect found no path in {budget} ({tested} states tested)"
                        f"{keep} to a goal region of {len(region.rows)} valid states ({chest})")
        elif not _path_valid(searcher, path) or math.dist(
                joints_of_one(arm, path[-1])[3], target_c.tolist()) > \
                s.goal_tolerance * arm.arm_length * (1 + 1e-6):
            v.status = INCONCLUSIVE
            v.detail = ("OMPL RRTConnect returned a path that the core's test refuses "
                        "between its states, or that ends off the target (not counted)")
        elif held is not None and (broke := _leaves_as_reach_does(held[0], path)) is not None:
            at, c, best = broke
            v.status = INCONCLUSIVE
            v.detail = (f"OMPL RRTConnect found a path{keep}, but {at:.0%} of the way along it "
                        f"the arm comes back to a clearance of {c:.4f} arm lengths after "
                        f"{best:.4f}: Reach leaves a contact never deeper than the least depth "
                        "it has reached, and never back in once out (not counted)")
        else:
            goal = path[-1]
            gap = math.dist(joints_of_one(arm, goal)[3], target_c.tolist()) / arm.arm_length
            travel = wrist_travel(arm, path, s.step)
            v.status = FALSE_REFUSAL
            v.path_length, v.goal_state = round(travel, 4), [round(float(x), 3) for x in goal]
            notes = [f"the wrist {gap:.4f} arm lengths from the target"]
            if abs(goal[0] - table1) > 1.0:
                notes.append(f"the chest turned {goal[0]:.1f}° where Table 1 gives {table1:.1f}°")
            if frames is not None:
                need = chase_frames(planner, path, frames[1])
                notes.append(f"a chase at its limits follows it in {need} frames, "
                             f"{frames[0]} were had")
                if need > frames[0]:
                    v.status = INCONCLUSIVE
            if moving is not None and share is not None and share < 0.0 and \
                    _touches_along(planner, moving, path):
                notes.append("a way out of contact that touches where an obstacle moves: "
                             "whether it is touched again depends on when it passes, not "
                             "decided")
                v.status = INCONCLUSIVE
            v.detail = (f"OMPL RRTConnect found a clear path{keep} in "
                        f"{time.perf_counter() - t0:.1f} s ({tested} states tested, {len(path)} "
                        f"waypoints, {length:.2f} long in the joint metric): the wrist travels "
                        f"{travel:.3f} arm lengths to the goal state "
                        + ", ".join(f"{n} {x:.1f}" for n, x in zip(JOINT_NAMES, goal))
                        + f" ({'; '.join(notes)})")
    v.states_checked = validity.calls + (held[0].calls if held is not None else 0)
    v.seconds = round(time.perf_counter() - t0, 4)
    return v


def check_no_pose_at(planner, start_row, target_c, inside: Verdict, *,
                     budget_s: float = OMPL_BUDGET_S, max_states: int | None = None,
                     seed: int = 0, search: bool = True) -> Verdict:
    """``target_in_obstacle`` where ray parity (``inside``, :func:`check_target_inside`)
    finds the target inside no closed obstacle: the claim's substance, that no valid
    state puts the wrist within the goal tolerance of it (the character's own body
    capsules, an open mesh read as solid), tested as :func:`check_path_claim` tests a
    path claim. No valid goal state: confirmed. Valid goal states and a clear path from
    the start (``search``): a false refusal. Valid goal states and no path within the
    budget: inconclusive (the target is not inside anything the core's own test refuses,
    but no way to it was found); with no start to search from (``search`` False),
    unchecked."""
    v = check_path_claim(planner, start_row, target_c, target=inside.target,
                         reason=TARGET_IN_OBSTACLE, budget_s=budget_s, max_states=max_states,
                         seed=seed, search=search)
    v.seconds = round((inside.seconds or 0.0) + (v.seconds or 0.0), 4)
    if v.status == CONFIRMED and v.method == "ompl":
        v.status = INCONCLUSIVE
        v.detail = (f"the target is inside no closed obstacle by ray parity, and "
                    f"{v.goal_states} valid states put the wrist on it, but " + v.detail
                    + ": not decided")
    elif v.status == CONFIRMED:
        v.detail = "the target is inside no closed obstacle by ray parity, but " + v.detail
    return v


class HeldValidity(StateValidity):
    """The core's state test for a search from a start in contact or nearer an obstacle
    than the clearance (:func:`_held_validity`): legal and clear of the body as the core's
    test has it, and, for the obstacles, the arm's least clearance
    (:meth:`~reach_addon.core.collision.CollisionChecker.least_clearance`, exact to within
    its tolerance, the capsules without the margin) no less than ``floor``."""

    def __init__(self, arm, settings, checker, space, floor: float):
        super().__init__(arm, settings, checker, space)
        self.floor = floor

    def clear(self, world_joints) -> bool:
        return self.checker.least_clearance(world_joints, self.arm.arm_length) >= self.floor


def _held_validity(planner, space, start_row):
    """For a start the core's test refuses only for its nearness to an obstacle: (a
    :class:`HeldValidity` whose floor is the start's own least clearance c, less the
    measure's tolerance, and c in arm lengths: negative where Reach's model of the arm
    stands into an obstacle). A way it passes never comes nearer, nor goes deeper, than the
    start, by the measure the planner's escape keeps to (:mod:`~reach_addon.core.contact`).
    None for a start refused for anything else, or deeper than a start may touch (a bone
    through an obstacle's surface is, as the planner has it:
    :func:`~reach_addon.core.contact.bone_touches`).

    Not the core's capsule test loosened (a thinner arm, a lower clearance) until it
    passes the start: that test is conservative (a short piece of a capsule settled by a
    sphere up to ~12 % wider, the margin), and no thinning passes a capsule whose axis
    crosses a thin obstacle (fuzz seed 5103, a forearm's axis through a plane: inconclusive
    while the search used it)."""
    from reach_addon.core.collision import CLEARANCE_TOLERANCE
    from reach_addon.core.contact import bone_touches

    arm, s = planner.arm, planner.settings
    length = arm.arm_length
    checker = planner.generator.checker
    world = arm.to_world_points(checked_joints_of_one(arm, [float(x) for x in start_row]))
    c = checker.least_clearance(world, length)
    if not -s.start_contact_depth * length <= c < s.clearance * length or \
            (c < 0.0 and bone_touches(checker, world)):
        return None
    held = HeldValidity(arm, s, checker, space, c - CLEARANCE_TOLERANCE * length)
    return (held, c / length) if held.valid(start_row) else None


# --- Blender: the obstacles by the README's rules, the character, the start's skin ---------

def character_objects_of(armature, scene) -> set:
    """Names of the character's objects: the armature, every object with an Armature
    modifier on it, and every object with it as an ancestor (this module's own reading of
    the README's rule)."""
    names = {armature.name}
    for ob in scene.objects:
        up = ob.parent
        while up is not None and up != armature:
            up = up.parent
        if up is not None or any(m.type == "ARMATURE" and m.object == armature
                                 for m in getattr(ob, "modifiers", ())):
            names.add(ob.name)
    return names


#: Blender object types with faces (an evaluated mesh): the README's obstacle table.
FACE_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META"}


def _mesh_arrays(mesh, matrix):
    """(world vertices (V, 3), triangles (T, 3) of vertex indices) of an evaluated mesh."""
    mesh.calc_loop_triangles()
    nv, nt = len(mesh.vertices), len(mesh.loop_triangles)
    co = np.empty(nv * 3, dtype=np.float64)
    mesh.vertices.foreach_get("co", co)
    idx = np.empty(nt * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("vertices", idx)
    m = np.asarray(matrix, dtype=float)
    return co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3], idx.reshape(-1, 3)


def scene_obstacles(context, exclude, collection=None) -> list:
    """The obstacles by the README's rules, read from Blender's evaluated depsgraph at the
    current frame: [(label, world triangles (T, 3, 3), closed?)], one entry per instance
    (an object, or each object a collection instance or geometry nodes draw, labelled
    ``owner/object``). An instance counts when its type has faces (:data:`FACE_TYPES`),
    its owner (the instancer, or the object itself) is visible, neither is in
    ``exclude`` (names: the character, the targets) and, with ``collection``, either is in
    it. Triangles with a NaN or infinite corner, or without area, are left out; ``closed``
    is :func:`verification.geometry.closed` of the instance's triangulation."""
    depsgraph = context.evaluated_depsgraph_get()
    allowed = None if collection is None else {ob.name for ob in collection.all_objects}
    out = []
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type not in FACE_TYPES:
            continue
        original = ob.original
        owner = inst.parent.original if inst.is_instance and inst.parent is not None else original
        names = {owner.name, original.name}
        if names & set(exclude) or (allowed is not None and not names & allowed) or \
                not owner.visible_get():
            continue
        try:
            mesh = ob.to_mesh()
        except RuntimeError:
            continue
        try:
            verts, tris = _mesh_arrays(mesh, np.array(inst.matrix_world))
        finally:
            ob.to_mesh_clear()
        if not len(tris):
            continue
        label = owner.name if owner.name == original.name else f"{owner.name}/{original.name}"
        world = verts[tris]
        ok = np.isfinite(world).all(axis=(1, 2))
        shut = geometry.closed(tris)
        world = world[ok]
        world = world[geometry.triangle_areas(world) > 0.0]
        if len(world):
            out.append((label, world, shut and bool(ok.all())))
    return out


def arm_bones(armature, info) -> set:
    """Names of the reaching arm's bones: the clavicle (or, without one, the upper arm)
    and every bone below it, with the rig adapter's arm bones, the bones it keys and the
    hand's bones and everything below them."""
    a = info.bones.arms[info.side]
    pose = armature.pose.bones
    roots = {a.clavicle or a.upper_arm, a.upper_arm, a.forearm, a.hand, *info.hand_bones}
    roots |= {a.keyed(r) for r in ("clavicle", "upper_arm", "forearm", "hand")} - {None}
    out = set()
    for name in roots:
        if name in pose:
            out.add(name)
            out |= {b.name for b in pose[name].children_recursive}
    return out


def arm_skin(context, armature, bones: set, every_vertex: bool = False):
    """(arm triangles (T, 3, 3), meshes that have some) of the character's meshes at the
    current frame (see the module docstring): a vertex counts as the arm's where its
    weights on bone vertex groups are at least half the arm's, a triangle where one of its
    vertices does (all three with ``every_vertex``); a mesh bone-parented (itself or an
    ancestor) to an arm bone is the arm's
    whole. A mesh whose evaluated vertices do not match its own (a modifier that adds
    geometry) is read by its nearest bone: a triangle whose centre lies nearer an arm bone
    than any other bone counts."""
    depsgraph = context.evaluated_depsgraph_get()
    mw = np.array(armature.matrix_world)
    all_bones = [(b.name, mw[:3, :3] @ np.array(b.head) + mw[:3, 3],
                  mw[:3, :3] @ np.array(b.tail) + mw[:3, 3]) for b in armature.pose.bones]
    parts, meshes = [], []
    for ob in context.scene.objects:
        if ob.type not in FACE_TYPES or not ob.visible_get():
            continue
        deformed = any(m.type == "ARMATURE" and m.object == armature and m.show_viewport
                       for m in getattr(ob, "modifiers", ()))
        whole, up, child = False, ob.parent, ob
        while up is not None:
            if up == armature:
                whole = child.parent_type == "BONE" and child.parent_bone in bones
                break
            child, up = up, up.parent
        if up is None and not deformed:
            continue                                        # not the character's
        if not (whole or deformed):
            continue                                        # rides the armature, not the arm
        ev = ob.evaluated_get(depsgraph)
        mesh = ev.to_mesh()
        try:
            verts, tris = _mesh_arrays(mesh, np.array(ev.matrix_world))
        finally:
            ev.to_mesh_clear()
        if not len(tris):
            continue
        if whole:
            pick = np.ones(len(tris), dtype=bool)
        elif len(verts) == len(ob.data.vertices):
            names = {g.index: g.name for g in ob.vertex_groups}
            bone_names = {b.name for b in armature.data.bones}
            arm_v = np.zeros(len(verts), dtype=bool)
            for v in ob.data.vertices:
                total = share = 0.0
                for g in v.groups:
                    name = names.get(g.group)
                    if name in bone_names:
                        total += g.weight
                        if name in bones:
                            share += g.weight
                arm_v[v.index] = total > 0 and share >= 0.5 * total
            pick = arm_v[tris].all(axis=1) if every_vertex else arm_v[tris].any(axis=1)
        else:
            centres = verts[tris].mean(axis=1)
            best = np.full(len(centres), np.inf)
            mine = np.zeros(len(centres), dtype=bool)
            for name, h, t in all_bones:
                d = geometry.point_segment_distance(centres, h, t)
                closer = d < best
                best = np.where(closer, d, best)
                mine = np.where(closer, name in bones, mine)
            pick = mine
        if pick.any():
            parts.append(verts[tris[pick]])
            meshes.append(ob.name)
    tris = np.concatenate(parts) if parts else np.zeros((0, 3, 3))
    return tris[geometry.triangle_areas(tris) > 0.0], meshes


#: The claim that an animated obstacle moves into the arm's start pose (core.sweep): its
#: name and the frame where it meets the pose.
MOVES_IN = re.compile(r"'(.+?)' moves into the arm's start pose \(at the [^)]*\) on frame (-?\d+)")


def check_start(context, armature, info, exclude, collection=None, *, target: str = "",
                message: str = "") -> Verdict:
    """Cross-check ``start_in_collision`` at the current frame (the start frame): the arm's
    skin and bones against the obstacles (see the module docstring); where the claim is
    that an animated obstacle moves into the start pose on a later frame (:data:`MOVES_IN`),
    the skin and bones as they are on the start frame against that obstacle on that frame
    (both instants the planner samples). ``info``: the rig adapter's
    :class:`~reach_addon.blender.rig.RigInfo` (which arm, its bones, its length);
    ``exclude``: object names that are not obstacles besides the character (the targets);
    ``collection``: the obstacle collection, or None. ``message``: the refusal's message,
    which says which claim it is (the character's own body, an obstacle moving into a
    chase: unchecked). Returns a :class:`Verdict`."""
    t0 = time.perf_counter()
    v = Verdict(target, START_IN_COLLISION, UNCHECKED, "", "none")
    coming = MOVES_IN.search(message)
    if not coming and ("own body" in message or "moves into the arm" in message):
        v.detail = ("a start inside the character's own body capsules, or an obstacle moving "
                    "into a chase, is a claim about the rig model or a later frame: not checked")
        v.seconds = round(time.perf_counter() - t0, 4)
        return v
    length = info.arm.arm_length
    scene = context.scene
    bones = arm_bones(armature, info)
    exclude = character_objects_of(armature, scene) | set(exclude)
    obstacles = scene_obstacles(context, exclude, collection)
    if ENCLOSED in message:
        return _check_enclosed(v, info, obstacles, message, t0)
    skin, meshes = arm_skin(context, armature, bones)
    mw = np.array(armature.matrix_world)
    segs = [(n, mw[:3, :3] @ np.array(armature.pose.bones[n].head) + mw[:3, 3],
             mw[:3, :3] @ np.array(armature.pose.bones[n].tail) + mw[:3, 3]) for n in sorted(bones)]
    where = ""
    if coming:
        name, frame = coming.group(1), int(coming.group(2))
        start = scene.frame_current
        obstacles = []
        for sub in (0.0, 0.5):
            scene.frame_set(frame, subframe=sub)
            obstacles += [o for o in scene_obstacles(context, exclude, collection) if o[0] == name]
        scene.frame_set(start)
        where = f" on frame {frame}, the arm held as it starts"
    hits, least = _start_hits(skin, meshes, segs, obstacles, length)
    if hits:
        v.status, v.method = CONFIRMED, "skin" if len(skin) else "bones"
        v.detail = "; ".join(hits[:4]) + where
        v.clearance = 0.0
    elif not len(skin):
        v.status, v.method = INCONCLUSIVE, "bones"
        v.detail = (f"the arm has no skin to check (no mesh deformed by or parented to its "
                    f"{len(bones)} bones) and its bones are clear of {len(obstacles)} obstacle(s)"
                    + where)
    else:
        v.status, v.method = FALSE_REFUSAL, "skin"
        v.clearance = round(least / length, 4)
        v.detail = (f"the arm's skin ({len(skin)} triangles of {', '.join(meshes)}) and its "
                    f"{len(bones)} bones are clear of {len(obstacles)} obstacle(s) "
                    f"({sum(len(t) for _l, t, _c in obstacles)} triangles){where}, the nearest "
                    + (f"{least / length:.4f} arm lengths away" if least < 0.5 * length
                       else "farther than half an arm length"))
    v.seconds = round(time.perf_counter() - t0, 4)
    return v


def _start_hits(skin, meshes, segs, obstacles, length) -> tuple:
    """(what meets what, as phrases; the least distance from the skin to an obstacle, at
    most half ``length``) of the arm's ``skin`` triangles (of ``meshes``) and bone
    segments ``segs`` [(name, head, tail)] against ``obstacles`` [(label, triangles,
    closed)]."""
    hits = []
    skin_lo = skin.reshape(-1, 3).min(0) if len(skin) else None
    skin_hi = skin.reshape(-1, 3).max(0) if len(skin) else None
    skin_points = np.unique(skin.reshape(-1, 3), axis=0) if len(skin) else np.zeros((0, 3))
    joints = np.array([p for _n, h, t in segs for p in (h, t)]).reshape(-1, 3)
    least = 0.5 * length
    for label, tris, shut in obstacles:
        if len(skin):
            ia, _ib = geometry.intersecting_pairs(skin, tris)
            if len(ia):
                hits.append(f"{len(ia)} arm skin triangle(s) of {', '.join(meshes)} meet '{label}'")
            elif shut:
                lo, hi = tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0)
                if np.all(skin_hi >= lo) and np.all(skin_lo <= hi):
                    inside = geometry.points_inside(skin_points, tris)
                    if inside.any():
                        hits.append(f"{int(inside.sum())} arm skin vertices inside the closed "
                                    f"'{label}'")
            least = min(least, geometry.least_distance(skin_points, tris, least),
                        geometry.least_distance(tris.reshape(-1, 3), skin, least))
        a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
        crossing = [n for n, h, t in segs if geometry.segments_cross_triangles(
            np.repeat(h[None], len(tris), 0), np.repeat(t[None], len(tris), 0), a, b, c).any()]
        if crossing:
            hits.append(f"bone(s) {', '.join(repr(n) for n in crossing[:3])} pass through '{label}'")
        if shut and len(joints) and geometry.points_inside(joints, tris).any():
            hits.append(f"a joint of the arm is inside the closed '{label}'")
    return hits, least


#: The words of the claim that the chest lies inside a closed mesh (core.planner).
ENCLOSED = "is enclosed by the mesh"


def _check_enclosed(v: Verdict, info, obstacles, message: str, t0: float) -> Verdict:
    """The claim that the chest (the arm's root, the rig model's sternum) lies inside the
    closed mesh the message names: confirmed when ray parity puts that point inside it,
    a false refusal when the mesh is closed and the point outside, unchecked when the
    mesh is not one this module reads as closed."""
    arm = info.arm
    sternum = arm.to_world[:3, :3] @ arm.sternum + arm.to_world[:3, 3]
    named = message.split(ENCLOSED, 1)[1].split("'")[1]
    v.method = "point_in_mesh"
    found = [(tris, shut) for label, tris, shut in obstacles if label == named]
    if not found or not found[0][1]:
        v.detail = (f"'{named}' is not a closed obstacle by this module's reading: the chest "
                    "inside it is not checked")
    elif geometry.points_inside(sternum[None], found[0][0])[0]:
        v.status, v.clearance = CONFIRMED, 0.0
        v.detail = f"the chest (the arm's root) is inside the closed '{named}' by ray parity"
    else:
        v.status = FALSE_REFUSAL
        v.detail = f"the chest (the arm's root) is outside the closed '{named}' by ray parity"
    v.seconds = round(time.perf_counter() - t0, 4)
    return v


def check_target_inside(context, armature, point, exclude, collection=None, *, target: str = "",
                        message: str = "") -> Verdict:
    """Cross-check ``target_in_obstacle`` for the target at world ``point``: confirmed when
    it lies inside a closed obstacle (ray parity; obstacles as :func:`scene_obstacles`),
    else unchecked (see the module docstring)."""
    t0 = time.perf_counter()
    v = Verdict(target, TARGET_IN_OBSTACLE, UNCHECKED, "", "point_in_mesh")
    names = [label for label, tris, shut in scene_obstacles(
        context, character_objects_of(armature, context.scene) | set(exclude), collection)
        if shut and geometry.points_inside(np.asarray(point, dtype=float)[None], tris)[0]]
    if names:
        v.status, v.detail = CONFIRMED, f"the target is inside the closed '{names[0]}'"
    else:
        v.detail = ("the target is inside no closed obstacle by ray parity; Reach also counts "
                    "the character's own body" + (" (as its message says)"
                                                  if "own body" in message else "")
                    + ": not checked further")
    v.seconds = round(time.perf_counter() - t0, 4)
    return v


# --- the planner's problem, rebuilt from a report ------------------------------------------

@dataclass
class Problem:
    """A scene's planning problem as the pipeline builds it (:func:`rebuild`): the rig
    model (``info``), ``settings`` (the report's, with the chest kept still where the
    pipeline keeps it), the :class:`reach_addon.core.Planner` on the pipeline's obstacles
    (``planner``; swept over the animation where obstacles move: ``moving``), the start
    row (degrees), the start ``frame``, the target objects' names and the names left out
    of the obstacles (``exclude``: the character, the targets), and the obstacles'
    ``pieces`` the planner was built on [(label, world vertices, triangles)]."""

    info: object
    settings: object
    planner: object
    start_row: np.ndarray
    frame: int
    targets: list
    exclude: set
    collection: object
    moving: set
    pieces: list = ()


def rebuild(context, report: dict, task: str = "reach", obstacles: str | None = None,
            overrides: dict | None = None) -> Problem:
    """Rebuild the planner's problem of a bake report (``python -m reach_addon bake
    --report``) on the open file, which must be the bake's input: the armature
    (``report['armature']``) read by ``reach_addon.blender.rig.build`` on the reported arm
    at the first task's start frame, the settings of the report (``Settings.from_dict``),
    the pipeline's handling of targets carried by the character's bones, and the
    pipeline's obstacle gathering (the character and the targets left out, objects beyond
    the arm's reach sphere unread; ``obstacles``: the collection name of ``--obstacles``).
    Where obstacles move after the start frame, every place they take until their
    animation ends is added (sampled twice a frame), so a path clear of these is clear
    whenever it runs. ``task``: the bake's ``--task``;
    ``overrides``: its ``--bone`` pairs. Leaves the scene at the start frame."""
    import bpy

    from reach_addon.blender import pipeline
    from reach_addon.blender.carried import carried_targets
    from reach_addon.blender import rig as rig_mod
    from reach_addon.blender.scene import (KEPT, character_objects, gather_pieces,
                                           obstacles_from_pieces)
    from reach_addon.core import Planner, Settings
    from reach_addon.core.sampling import pose_row

    scene = context.scene
    frame = int(min(t["frame_start"] for t in report["tasks"]))
    scene.frame_set(frame)
    context.view_layer.update()
    armature = bpy.data.objects[report["armature"]]
    names = list(dict.fromkeys(t["target"] for t in report["tasks"]))
    targets = [bpy.data.objects[n] for n in names]
    settings = Settings.from_dict(report["settings"])
    request = pipeline.Request(armature.name, names, task=task, side=report["arm"],
                               obstacles=obstacles, settings=settings,
                               overrides=dict(overrides or {}))
    first = np.array(targets[0].matrix_world.translation)
    info = rig_mod.build(armature, report["arm"], request.overrides, target=first)
    info, settings, _note = carried_targets(armature, targets, info, request, first)
    collection = bpy.data.collections.get(obstacles) if obstacles else None
    exclude = character_objects(armature, scene) | set(names)
    # as the pipeline reads them: objects wholly beyond the arm's reach sphere are not read
    pieces, _obstacles, _built = KEPT.get(context, exclude, collection,
                                          within=pipeline.reach_bounds(info.arm, settings, targets))
    pieces = list(pieces)
    moving = pipeline._moving_owners(context, exclude, collection, frame)
    if moving:
        ends = [pipeline._animation_end(bpy.data.objects.get(n)) for n in moving]
        end = int(math.ceil(max([e for e in ends if e is not None], default=frame)))
        for f in range(frame, end + 1):
            for k in range(2):
                scene.frame_set(f, subframe=k / 2)
                pieces += gather_pieces(context, exclude, collection, only=moving)
        scene.frame_set(frame)
        context.view_layer.update()
    planner = Planner(info.arm, obstacles_from_pieces(pieces), settings)
    start_row = pose_row(planner.generator.config_pose(info.start, info.start_hand))
    return Problem(info, settings, planner, start_row, frame, names, exclude, collection, moving,
                   pieces)


#: Why the start claim of a later target is not checked.
LATER_START = ("a later target's start is where the one before it ended, at its own frame, "
               "which only the planner knows: not checked")


def _moving_places(problem):
    """Every place the moving obstacles of ``problem`` take (its pieces of them), as
    :class:`reach_addon.core.Obstacles`; None where nothing moves."""
    from reach_addon.core.sweep import obstacles_from_pieces

    mine = [p for p in problem.pieces if p[0] in problem.moving
            or p[0].split("/")[0] in problem.moving]
    return obstacles_from_pieces(mine) if mine else None


def check_deep_start(problem, *, target: str = "", spacing: float = 0.01) -> Verdict:
    """Cross-check ``start_held`` for a start whose model stands deeper in an obstacle
    than a start may touch (the message holds ``reach_addon.blender.results.DEEP_START``):
    confirmed where, by this module's own geometry (:mod:`verification.geometry`, exact
    segment-to-triangle distances), against the obstacles the planner had (the rebuilt
    problem's pieces: where obstacles move, every place they take while the reach lasts,
    as the claim is made against them), a capsule of Reach's
    model of the arm at the start (the rebuilt problem's start configuration) reaches
    deeper than ``Settings.start_contact_depth``, its bone (the capsule's axis) meets an
    obstacle's surface, or a point of a bone (every ``spacing`` arm lengths) lies inside a
    closed obstacle by ray parity; else a false refusal."""
    t0 = time.perf_counter()
    arm, s = problem.info.arm, problem.settings
    length = arm.arm_length
    v = Verdict(target, START_HELD, FALSE_REFUSAL, "", "model")
    world = arm.to_world_points(checked_joints_of_one(
        arm, [float(x) for x in problem.start_row]))
    obstacles = [(label, np.asarray(v, float)[np.asarray(t)], None)
                 for label, v, t in problem.pieces]
    caps = [(name, world[a], world[b], r) for name, a, b, r in _model_capsules(arm)]
    touch = length * 1e-4
    deepest, where = -math.inf, ""
    for label, tris, shut in obstacles:
        d = geometry.segment_triangle_distances([c[1] for c in caps], [c[2] for c in caps],
                                                tris, horizon=length)
        for (name, p, q, r), di in zip(caps, d):
            if di <= touch:
                v.status, v.clearance = CONFIRMED, round(-r / length, 4)
                v.detail = (f"the model's {name} bone meets '{label}' (segment to triangle "
                            f"{di / length:.5f} arm lengths)")
            elif r - di > deepest:
                deepest, where = r - di, f"its {name} in '{label}'"
            if v.status != CONFIRMED and (shut if shut is not None else
                                          (shut := geometry.closed(tris))):
                n = max(2, int(math.ceil(float(np.linalg.norm(q - p)) / (spacing * length))) + 1)
                pts = p + np.linspace(0.0, 1.0, n)[:, None] * (q - p)
                if geometry.points_inside(pts, tris).any():
                    v.status = CONFIRMED
                    v.detail = f"a point of the model's {name} bone is inside the closed '{label}'"
        if v.status == CONFIRMED:
            break
    if v.status != CONFIRMED:
        limit = s.start_contact_depth * length
        v.clearance = round(-deepest / length, 4) if deepest > -math.inf else None
        if deepest >= limit * (1 - 1e-6):
            v.status = CONFIRMED
            v.detail = (f"the model's capsules stand {deepest / length:.4f} arm lengths deep "
                        f"({where}), beyond the {s.start_contact_depth:g} a start may touch")
        else:
            v.detail = (f"the model's capsules stand at most {max(deepest, 0.0) / length:.4f} "
                        f"arm lengths deep ({where or 'nowhere'}), within the "
                        f"{s.start_contact_depth:g} a start may touch, no bone meets an "
                        "obstacle and none lies inside a closed one")
    v.seconds = round(time.perf_counter() - t0, 4)
    return v


def _model_capsules(arm) -> list:
    """(name, first joint, second joint, radius) of Reach's model of the arm, as the README
    describes it: the clavicle at the upper arm's radius, the upper arm, the forearm and
    the hand: its shape's capsules where it has one (their ends the rows after the five
    joints, ``reach_addon.core.hand_shape.with_shape``), else its axis capsule."""
    caps = [("clavicle", 0, 1, arm.upper_arm_radius), ("upper arm", 1, 2, arm.upper_arm_radius),
            ("forearm", 2, 3, arm.forearm_radius)]
    if arm.hand_shape:
        return caps + [("hand", 5 + 2 * i, 6 + 2 * i, r)
                       for i, (_a, _b, r) in enumerate(arm.hand_shape)]
    return caps + [("hand", 3, 4, arm.hand_radius)]


def check_target_moved(context, problem, name: str, point, frame: int) -> Verdict:
    """The claim ``target_moved``: target ``name``, at ``point`` on the start frame, is
    farther from there on ``frame`` (the arrival) than the goal tolerance, as Blender
    evaluates the object. Confirmed if so, else a false refusal. Leaves the scene at the
    start frame."""
    import bpy

    t0 = time.perf_counter()
    scene = context.scene
    scene.frame_set(frame)
    there = np.array(bpy.data.objects[name].matrix_world.translation)
    scene.frame_set(problem.frame)
    length = problem.info.arm.arm_length
    moved = float(np.linalg.norm(there - np.asarray(point, dtype=float))) / length
    tolerance = problem.planner.settings.goal_tolerance
    status = CONFIRMED if moved > tolerance else FALSE_REFUSAL
    return Verdict(name, TARGET_MOVED, status,
                   f"the target is {moved:.4f} arm lengths from its start on frame {frame} "
                   f"(goal tolerance {tolerance:g})", "object",
                   seconds=time.perf_counter() - t0)


def check_report(context, report: dict, task: str = "reach", obstacles: str | None = None, *,
                 overrides: dict | None = None, budget_s: float = OMPL_BUDGET_S,
                 max_states: int | None = None, seed: int = 0) -> list:
    """Cross-check every refused target of a bake report on the open file (the bake's
    input; see :func:`rebuild` for ``task``, ``obstacles``, ``overrides``). Returns one
    :class:`Verdict` per failed task, in the report's order. The path claim is searched
    from the rig's start pose; a later target of any task but a chase starts where the one
    before it ended, which only the planner knows, so only its goal region is checked
    there (its start claim is unchecked). A chase's ``no_path`` (the wrist did not catch up) is unchecked; its
    other reasons are about the target's last position, searched from the start. Leaves
    the scene at the start frame. A later target whose targets before it never moved the
    arm (a plan refused at its start refuses every target alike) starts at the rig's
    start pose and is checked as the first is."""
    import bpy

    from reach_addon.blender.results import DEEP_START

    failed = [(i, t) for i, t in enumerate(report.get("tasks", ())) if not t["success"]]
    if not failed:
        return []
    problem = rebuild(context, report, task, obstacles, overrides)
    arm = problem.info.arm
    armature = bpy.data.objects[report["armature"]]
    scene = context.scene
    out, start_verdict = [], None
    tasks = report["tasks"]
    for i, t in failed:
        reason, name, message = t["reason"], t["target"], t.get("message") or ""
        # a later target starts where the one before it ended: the rig's own start pose
        # where no target before it moved the arm (a plan refused at its start refuses
        # every target with the same claim)
        later = task != "chase" and any(p["frame_end"] > p["frame_start"] for p in tasks[:i])
        if reason == START_IN_COLLISION and later:
            out.append(Verdict(name, reason, UNCHECKED, LATER_START))
            continue
        if reason == START_IN_COLLISION:
            if start_verdict is None or "own body" in message or "moves into" in message:
                start_verdict = check_start(context, armature, problem.info, problem.targets,
                                            problem.collection, target=name, message=message)
            out.append(Verdict(**{**start_verdict.to_dict(), "target": name}))
            continue
        if reason == START_HELD and DEEP_START in message:
            out.append(Verdict(name, reason, UNCHECKED, LATER_START) if later else
                       check_deep_start(problem, target=name))
            continue
        point = np.array(bpy.data.objects[name].matrix_world.translation)
        if reason == TARGET_MOVED:
            out.append(check_target_moved(context, problem, name, point, int(t["frame_end"])))
            continue
        if task == "chase":
            scene.frame_set(int(t["frame_end"]))
            point = np.array(bpy.data.objects[name].matrix_world.translation)
            scene.frame_set(problem.frame)
        if reason == TARGET_IN_OBSTACLE:
            v = check_target_inside(context, armature, point, problem.targets,
                                    problem.collection, target=name, message=message)
            if v.status == UNCHECKED:
                v = check_no_pose_at(problem.planner, problem.start_row,
                                     arm.to_canonical_points(point), v, budget_s=budget_s,
                                     max_states=max_states, seed=seed,
                                     search=not later)
            out.append(v)
        elif reason in PATH_REASONS:
            # a chase's no_path: the wrist did not catch the target by the last frame, at
            # the chase's limits; a way to where the target ends that a chase at those
            # limits follows within the chase's frames belies it (the wrist may wait there)
            timing = ((int(t["frame_end"]) - int(t["frame_start"]),
                       scene.render.fps / scene.render.fps_base)
                      if task == "chase" and reason == NO_PATH else None)
            out.append(check_path_claim(problem.planner, problem.start_row,
                                        arm.to_canonical_points(point), target=name,
                                        reason=reason, budget_s=budget_s,
                                        max_states=max_states, seed=seed, search=not later,
                                        frames=timing, moving=_moving_places(problem)))
        else:
            out.append(Verdict(name, str(reason), UNCHECKED, "not a reason this module checks"))
    return out
