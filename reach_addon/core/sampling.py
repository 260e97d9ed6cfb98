"""Completeness where the paper's search gives up: a bidirectional sampling planner.

:func:`sampling_steps` runs RRT-Connect (Kuffner & LaValle, ICRA 2000) over the seven
joints the core animates (chest rotation, α, β, γ, elbow flexion and the wrist's two
angles, degrees), with the generator's validity (:class:`StateValidity`): one tree from the
start, one from a goal region (:func:`goal_configurations`), each extended toward random
configurations and greedily connected to the other. Distances approximate the wrist's
travel in arm lengths (:class:`JointSpace`); motions are checked at every search step. The
budget is ``Settings.sampling_budget`` states tested (counted, not timed) and random numbers
come from ``Settings.sampling_seed``, so the same input gives the same answer. The path is
shortcut and subdivided into the same dense, validated pose sequence the best-first search
hands to the timing.
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import ik
from .straight import goal_rows, straight_to_goal
from .arm import ArmConfig, Pose, forward_kinematics, hand_direction_floats
from .body_capsules import body_capsules_at, segment_hits_body
from .diagnosis import fit_within_tolerance
from .errors import NO_PATH
from .hand_shape import with_shape
from .limits import on_elbow_side, side_normal
from .numeric import SCALAR, cross
from .search import SearchResult

#: Joint order of a configuration row: the core's five angles, then the hand's two.
JOINT_NAMES = ("body", "alpha", "beta", "gamma", "elbow", "wrist_bend", "wrist_side")


class JointSpace:
    """The seven joints (degrees), their limits and the lever-arm metric.

    ``scale[i]`` turns degrees into coordinates: radians × lever arm, the lever being the
    farthest the joint can carry the wrist, in arm lengths — the chest turns the wrist
    about the spine axis (shoulder offset + arm), α and β swing the whole arm (1), γ and the
    elbow swing the forearm; the wrist angles move only the hand, by its length.

    ``start``: the configuration row (7,) a plan starts from. The box of limits, the
    elevation limit (:attr:`elevation_max`) and the elbow's side (:attr:`require_side`) are
    then widened to take it in, as the search widens them for a move from a pose outside
    them (:func:`~reach_addon.core.limits.move_limits`): the start is the rig's own pose.
    """

    def __init__(self, arm, settings, start=None):
        self.arm = arm
        self.settings = settings
        s, length = settings, arm.arm_length
        chest = s.chest_rotation_max if s.chest_rotation else 0.0
        limits = [(-chest, chest), (s.alpha_min, s.alpha_max), (s.beta_min, s.beta_max),
                  (s.gamma_min, s.gamma_max), (s.elbow_min, s.elbow_max),
                  (-s.wrist_bend_max, s.wrist_bend_max), (-s.wrist_side_max, s.wrist_side_max)]
        # a joint held fixed by the settings gets a sliver of room (samplers need lo < hi)
        self.lo = np.array([lo if hi > lo else lo - 1e-6 for lo, hi in limits])
        self.hi = np.array([hi if hi > lo else hi + 1e-6 for lo, hi in limits])
        self.elevation_max = float(s.elevation_max)
        self.require_side = s.elbow_side == "require"
        if start is not None:
            q = np.asarray(start, dtype=float).copy()
            q[3] = (q[3] + 180.0) % 360.0 - 180.0
            self.lo, self.hi = np.minimum(self.lo, q), np.maximum(self.hi, q)
            self.elevation_max = max(self.elevation_max, math.hypot(q[1], q[2]))
            if self.require_side:
                self.require_side = on_elbow_side(arm, ArmConfig.from_array(q[:5]))
        spine = float(np.hypot(arm.shoulder[0], arm.shoulder[1]))
        fore = arm.forearm_length / length
        hand = max(arm.hand_length / length, 0.05)
        self.lever = np.array([(spine + length) / length, 1.0, 1.0, fore, fore, hand, hand])
        self.scale = np.radians(1.0) * self.lever

    def coordinates(self, q) -> np.ndarray:
        """Metric coordinates of configurations ``q`` (..., 7) in degrees."""
        return np.asarray(q, dtype=float) * self.scale

    def angles(self, x) -> np.ndarray:
        """Degrees of metric coordinates ``x`` (..., 7)."""
        return np.asarray(x, dtype=float) / self.scale

    def distance(self, qa, qb) -> float:
        """Distance between two configurations: about the wrist's travel (arm lengths)."""
        return float(np.linalg.norm(self.coordinates(qb) - self.coordinates(qa)))


def pose_row(pose: Pose) -> np.ndarray:
    """A :class:`~reach_addon.core.arm.Pose` as a configuration row (7,), degrees."""
    return np.concatenate([pose.config.as_array(), np.asarray(pose.hand, dtype=float)])


def joints_of(arm, q, shaped: bool = False) -> np.ndarray:
    """Canonical joint positions (N, 5, 3) of configuration rows (N, 7): the core's forward
    kinematics, with the hand turned by its two wrist angles as in
    :func:`reach_addon.core.arm.hand_direction`. ``shaped``: followed by the ends of the
    hand shape's capsules (:func:`~reach_addon.core.hand_shape.with_shape`), what the
    collision checker takes."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    joints, bend = forward_kinematics(arm, q[:, :5])
    s, e, w = joints[:, 1], joints[:, 2], joints[:, 3]
    u = (e - s) / arm.upper_arm_length
    f = (w - e) / arm.forearm_length
    h = cross(u, bend)
    h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-12)
    p = cross(h, f)
    fb, fs = np.radians(q[:, 5:6]), np.radians(q[:, 6:7])
    d = f * np.cos(fb) * np.cos(fs) + p * np.sin(fb) * np.cos(fs) + h * np.sin(fs)
    joints[:, 4] = w + arm.hand_length * d
    return with_shape(arm, joints, bend) if shaped else joints


def checked_joints_of_one(arm, q, joints=None):
    """What the collision checker takes for one configuration ``q`` (7,): its joints
    (:func:`joints_of_one`, or ``joints`` already found), followed by the hand shape's
    rows where the arm has one (:func:`joints_of`)."""
    if arm.hand_shape:
        return joints_of(arm, q, shaped=True)[0]
    return np.array(joints_of_one(arm, q) if joints is None else joints)


def joints_of_one(arm, q) -> list:
    """:func:`joints_of` for one configuration on plain floats (a validity test runs it
    thousands of times; numpy costs about a microsecond per call on tiny arrays).
    Returns five [x, y, z] lists, canonical frame."""
    body, alpha, beta, gamma, flex, wb, ws = (float(v) for v in q)
    theta = math.radians(math.hypot(alpha, beta))
    phi = math.atan2(beta, alpha)
    st = math.sin(theta)
    ux, uy, uz = st * math.cos(phi), st * math.sin(phi), -math.cos(theta)
    k = 1.0 / max(1.0 - uz, 1e-12)
    rx, ry, rz = -ux * uy * k, -uz + ux * ux * k, uy           # swing reference
    ax, ay, az = -ux, -uy, -uz                                  # twist axis -u
    cx, cy, cz = ay * rz - az * ry, az * rx - ax * rz, ax * ry - ay * rx
    g = math.radians(gamma)
    cg, sg = math.cos(g), math.sin(g)
    bx, by, bz = rx * cg + cx * sg, ry * cg + cy * sg, rz * cg + cz * sg
    e = math.radians(flex)
    ce, se = math.cos(e), math.sin(e)
    fx, fy, fz = ux * ce + bx * se, uy * ce + by * se, uz * ce + bz * se
    dx, dy, dz = hand_direction_floats((ux, uy, uz), (bx, by, bz), (fx, fy, fz), wb, ws)
    t = math.radians(body)
    c, s = math.cos(t), math.sin(t)
    l1, l2, lh = arm.upper_arm_length, arm.forearm_length, arm.hand_length
    st0, sh0 = arm.sternum.tolist(), arm.shoulder.tolist()
    sternum = [c * st0[0] + s * st0[1], -s * st0[0] + c * st0[1], st0[2]]
    shoulder = [c * sh0[0] + s * sh0[1], -s * sh0[0] + c * sh0[1], sh0[2]]
    elbow = [shoulder[0] + l1 * (c * ux + s * uy), shoulder[1] + l1 * (-s * ux + c * uy),
             shoulder[2] + l1 * uz]
    wrist = [elbow[0] + l2 * (c * fx + s * fy), elbow[1] + l2 * (-s * fx + c * fy),
             elbow[2] + l2 * fz]
    hand = [wrist[0] + lh * (c * dx + s * dy), wrist[1] + lh * (-s * dx + c * dy),
            wrist[2] + lh * dz]
    return [sternum, shoulder, elbow, wrist, hand]


class StateValidity:
    """Would the core accept this configuration?

    Legal (the elevation limit and, if required, the elbow side of Algorithm 1; the box of
    :class:`JointSpace`'s bounds is the sampler's, which never leaves it), clear of the
    body's own capsules as the configuration generator tests them
    (:func:`~reach_addon.core.body_capsules.segment_hits_body`), and clear of the obstacles
    by the core's :class:`~reach_addon.core.collision.CollisionChecker` (arm and, if it is
    checked, hand, with the clearance margin). ``calls`` counts the states tested.
    """

    def __init__(self, arm, settings, checker, space: JointSpace | None = None):
        self.arm = arm
        self.settings = settings
        self.checker = checker
        self.space = space if space is not None else JointSpace(arm, settings)
        self.elbow_rule = self.space.require_side
        self.elevation_max = self.space.elevation_max
        self.waist = tuple(arm.waist.tolist())
        self.calls = 0

    def valid(self, q) -> bool:
        """Is configuration ``q`` (7 angles, degrees) valid?"""
        self.calls += 1
        arm = self.arm
        q = [float(v) for v in q]
        if math.hypot(q[1], q[2]) > self.elevation_max:
            return False
        sternum, shoulder, elbow, wrist, hand = joints = joints_of_one(arm, q)
        if self.elbow_rule:
            nx, ny, nz, degenerate = side_normal(wrist, shoulder, self.waist, m=SCALAR)
            side = ((elbow[0] - shoulder[0]) * nx + (elbow[1] - shoulder[1]) * ny
                    + (elbow[2] - shoulder[2]) * nz)
            if not (side > 0 or degenerate):
                return False
        if arm.body_capsules:
            caps = body_capsules_at(arm, q[0])
            mid = [0.5 * (shoulder[i] + elbow[i]) for i in range(3)]
            if segment_hits_body(mid, elbow, arm.upper_arm_radius, caps) or \
                    segment_hits_body(elbow, wrist, arm.forearm_radius, caps) or \
                    (self.checker.check_hand and
                     segment_hits_body(wrist, hand, arm.hand_radius, caps)):
                return False
        return self.clear(arm.to_world_points(checked_joints_of_one(arm, q, joints)))

    def clear(self, world_joints) -> bool:
        """The obstacle part of :meth:`valid`: is the pose (world joints, (5, 3), or more with
        a hand shape: :func:`checked_joints_of_one`) clear
        by the core's checker, arm and hand, with the clearance margin?"""
        return not self.checker.collides(world_joints, include_hand=True)


def goal_configurations(generator, target, start: Pose, validity: StateValidity,
                        chests=()) -> list:
    """The goal region: configuration rows (7,) with the wrist on ``target`` (canonical)
    that ``validity`` accepts, strongest first, at most ``Settings.sampling_goals``.

    The IK's legal swivel solutions (:func:`reach_addon.core.ik.solve`) at the chest
    rotation of ``generator.chest`` (Table 1 along this reach), at the start's and at each
    of ``chests`` (degrees); for each,
    the most relaxed hand sample that is clear. Taken round-robin over the chest rotations
    and, within one, spread over the swivel circle (every other ranked solution first) so
    that the region is not one narrow cluster."""
    s = generator.settings
    target = np.asarray(target, dtype=float)
    bodies = [start.config.body_rotation, *map(float, chests)]
    if generator.chest is not None:
        bodies.insert(0, float(generator.chest(target)))
    if s.chest_rotation:
        bodies = list(dict.fromkeys(round(b, 9) for b in bodies))
    else:
        bodies = [0.0]
    per_body = [goal_rows(generator, target, body, validity, spread=True) for body in bodies]
    out = []
    while any(per_body) and len(out) < s.sampling_goals:
        for rows in per_body:
            if rows and len(out) < s.sampling_goals:
                out.append(rows.pop(0))
    return out


class _Tree:
    """A tree of configurations with parent links, its coordinates kept in one array for
    nearest-neighbour queries (a linear scan: the trees stay in the thousands)."""

    def __init__(self, space: JointSpace, roots):
        self.space = space
        self.q = [np.asarray(r, dtype=float) for r in roots]
        self.parent = [-1] * len(self.q)
        self._x = np.zeros((max(64, 2 * len(self.q)), 7))
        self._x[:len(self.q)] = space.coordinates(np.array(self.q))

    def __len__(self):
        return len(self.q)

    def add(self, q, parent: int) -> int:
        n = len(self.q)
        if n == len(self._x):
            grown = np.zeros((2 * n, 7))
            grown[:n] = self._x
            self._x = grown
        self._x[n] = self.space.coordinates(q)
        self.q.append(q)
        self.parent.append(parent)
        return n

    def nearest(self, q) -> int:
        d = self._x[:len(self.q)] - self.space.coordinates(q)
        return int(np.argmin(np.einsum("ij,ij->i", d, d)))

    def branch(self, index: int) -> list:
        out = []
        while index >= 0:
            out.append(self.q[index])
            index = self.parent[index]
        return out


class SamplingPlanner:
    """RRT-Connect from ``start`` (a row (7,)) to any of ``goals`` (rows), see the module
    docstring. :meth:`run` returns the joint-space path (rows) or None."""

    def __init__(self, validity: StateValidity, start, goals, rng, budget: int,
                 reach: float, resolution: float, lo=None, hi=None, near=None,
                 near_share: float = 0.0, seed_path=(), seed_reaches: bool = False,
                 path_share: float = 0.0):
        self.validity = validity
        self.space = validity.space
        self.start = np.asarray(start, dtype=float)
        self.goals = [np.asarray(g, dtype=float) for g in goals]
        self.rng = rng
        self.budget = int(budget)
        self.reach = float(reach)
        self.resolution = float(resolution)
        self.lo = self.space.lo if lo is None else np.asarray(lo, dtype=float)
        self.hi = self.space.hi if hi is None else np.asarray(hi, dtype=float)
        self.near = near
        self.near_share = float(near_share)
        self.seed_path = [np.asarray(q, dtype=float) for q in seed_path]
        self.seed_reaches = bool(seed_reaches)
        self.path_share = float(path_share)
        self.calls0 = validity.calls

    @property
    def used(self) -> int:
        return self.validity.calls - self.calls0

    def motion_valid(self, qa, qb) -> bool:
        """Is the straight joint-space motion from ``qa`` to ``qb`` valid at every
        ``resolution`` of the metric (``qa`` itself taken as valid)?"""
        n = int(math.ceil(self.space.distance(qa, qb) / self.resolution - 1e-12))
        for k in range(1, n + 1):
            if not self.validity.valid(qa + (qb - qa) * (k / n)):
                return False
        return True

    def _steer(self, qa, qb):
        d = self.space.distance(qa, qb)
        if d <= self.reach:
            return qb, True
        return qa + (qb - qa) * (self.reach / d), False

    def _extend(self, tree: _Tree, q):
        """One step of ``tree`` toward ``q``: ('reached' | 'advanced' | 'trapped', index)."""
        i = tree.nearest(q)
        new, whole = self._steer(tree.q[i], q)
        if not self.motion_valid(tree.q[i], new):
            return "trapped", i
        j = tree.add(new, i)
        return ("reached" if whole else "advanced"), j

    def _connect(self, tree: _Tree, q):
        while True:
            state, j = self._extend(tree, q)
            if state != "advanced" or self.used >= self.budget:
                return state, j

    def steps(self, chunk: int = 0):
        """Plan, yielding the states tested so far about every ``chunk`` of them (never,
        if 0); returns the joint-space path (rows, start first) or None."""
        if not self.goals or not self.validity.valid(self.start):
            return None
        a, b = _Tree(self.space, [self.start]), _Tree(self.space, self.goals)
        tip = self._seed(a)
        if self.seed_reaches and tip < len(self.seed_path):
            self._seed_back(b, self.seed_path[tip:])
        # a straight connection first: the start (or the seed path's end) may see a goal
        for root in dict.fromkeys((0, tip)):
            for g in self.goals:
                if self.used >= self.budget:
                    return None
                if self.motion_valid(a.q[root], g):
                    return a.branch(root)[::-1] + [g]
        forward = True                    # is tree a the start's?
        reported = self.used
        while self.used < self.budget:
            if chunk and self.used - reported >= chunk:
                reported = self.used
                yield reported
            q = self.sample(goal_side=not forward)
            state, i = self._extend(a, q)
            if state != "trapped":
                state, j = self._connect(b, a.q[i])
                if state == "reached":
                    start_half, goal_half = (a, i), (b, j)
                    if not forward:
                        start_half, goal_half = goal_half, start_half
                    path = start_half[0].branch(start_half[1])[::-1]
                    path += goal_half[0].branch(goal_half[1])[1:]
                    return path
            a, b, forward = b, a, not forward
        return None

    def _grow_along(self, tree: _Tree, tip: int, states) -> int:
        """Grow ``tree`` from its state ``tip`` along ``states`` as far as the motions are
        valid; the index of the last state added (``tip`` if none)."""
        for q in states:
            if self.used >= self.budget:
                break
            if self.space.distance(tree.q[tip], q) < 1e-9:
                continue
            if not self.motion_valid(tree.q[tip], q):
                break
            tip = tree.add(q, tip)
        return tip

    def _seed(self, tree: _Tree) -> int:
        """Grow ``tree`` (the start's) along ``seed_path``; the index of the last state
        added (0, the start, if none)."""
        return self._grow_along(tree, 0, self.seed_path)

    def _seed_back(self, tree: _Tree, rest: list) -> None:
        """Grow the goals' ``tree`` from the seed path's end (a pose on the target: one more
        goal) back along ``rest`` as far as its motions are valid, so that only the gap
        where the seed path failed is left to the sampling."""
        if self.used >= self.budget or not self.validity.valid(rest[-1]):
            return
        self._grow_along(tree, tree.add(rest[-1], -1), rest[-2::-1])

    def _about_path(self):
        """A configuration about one of the seed path's states (uniformly chosen): normal
        in the metric's coordinates with the sampling reach as deviation, and half the time
        the hand's two angles drawn anywhere in their range (the turn over the search's path
        left out), within the box."""
        q = self.seed_path[int(self.rng.integers(len(self.seed_path)))]
        out = self.space.angles(self.space.coordinates(q) + self.rng.normal(0.0, self.reach, 7))
        if self.rng.random() < 0.5:
            out[5:] = self.lo[5:] + self.rng.random(2) * (self.hi[5:] - self.lo[5:])
        return np.clip(out, self.lo, self.hi)

    def sample(self, goal_side: bool):
        """A random configuration for the tree of the start or, if ``goal_side``, of the
        goals: for the goals' tree, with probability ``near_share``, from ``near`` (a
        configuration whose wrist is near the target, or None), else uniform in the box.
        (The goals' tree grows out of the narrow place through the near samples; the
        start's would only run into its walls toward them.)"""
        if self.seed_path and self.rng.random() < self.path_share:
            return self._about_path()
        if goal_side and self.near is not None and self.rng.random() < self.near_share:
            q = self.near(self.rng, self.lo, self.hi)
            if q is not None:
                return q
        return self.lo + self.rng.random(7) * (self.hi - self.lo)

    def shortcut(self, path: list, attempts: int) -> list:
        """Random shortcuts (``attempts`` pairs), then a greedy pass from the start: a
        pair of waypoints is joined straight where the motion between them is valid."""
        path = list(path)
        for _ in range(attempts):
            if len(path) < 3:
                break
            i, j = sorted(self.rng.choice(len(path), 2, replace=False).tolist())
            if j - i > 1 and self.motion_valid(path[i], path[j]):
                path = path[:i + 1] + path[j:]
        out, i = [path[0]], 0
        while i < len(path) - 1:
            j = len(path) - 1
            while j > i + 1 and not self.motion_valid(path[i], path[j]):
                j -= 1
            out.append(path[j])
            i = j
        return out


def near_target(arm, settings, target, radius: float):
    """A sampler of configurations whose wrist is near ``target``: a wrist position drawn
    uniformly in the ball of ``radius`` about it, a chest rotation uniformly in the box, one
    of the IK's legal swivel solutions there at random, the wrist's angles uniformly.

    In a reach the narrow passage is where the hand goes in: the wrist inside a cubby's
    opening or a hole, the elbow swung round so the forearm lines up with it. Uniform
    samples of seven angles almost never land there; samples of the wrist there, through
    the analytic IK, always do (the informed half of the samples; ``near_share``)."""
    target = np.asarray(target, dtype=float)

    def near(rng, lo, hi):
        direction = rng.standard_normal(3)
        direction /= max(float(np.linalg.norm(direction)), 1e-12)
        wrist = target + direction * radius * rng.random() ** (1.0 / 3.0)
        body = float(lo[0] + rng.random() * (hi[0] - lo[0]))
        sol = ik.solve(arm, wrist[None], settings, None, body)
        legal = sol.ranked(0, settings.elbow_side)
        if not legal:
            return None
        k = legal[int(rng.integers(len(legal)))]
        hand = lo[5:] + rng.random(2) * (hi[5:] - lo[5:])
        return np.concatenate([sol.config(0, k).as_array(), hand])

    return near


def densify_rows(arm, rows, spacing: float, max_arm_deg: float = math.inf,
                 max_hand_deg: float = math.inf) -> np.ndarray:
    """Configuration rows (N, 7) along ``rows`` (K, 7), by linear interpolation in joint
    space (the ends kept, repeated rows dropped), each piece subdivided until between
    neighbours no joint — elbow, wrist or the hand's far end — moves more than ``spacing``
    (figure units), no arm angle more than ``max_arm_deg`` and neither wrist angle more than
    ``max_hand_deg``. The sampling planner's path is made of neighbours this close (one
    search step, within the smoothness bounds); the benchmarks check paths at this
    spacing."""
    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    out = [rows[:1]]
    for qa, qb in zip(rows[:-1], rows[1:]):
        if np.array_equal(qa, qb):
            continue
        delta = qb - qa
        n = max(1, int(math.ceil(max(np.abs(delta[:5]).max() / max_arm_deg,
                                     np.abs(delta[5:]).max() / max_hand_deg) - 1e-12)))
        while True:
            seg = qa + np.linspace(0.0, 1.0, n + 1)[1:, None] * delta
            seg[-1] = qb
            joints = joints_of(arm, np.vstack([qa[None], seg]))[:, 2:5]
            moved = float(np.linalg.norm(np.diff(joints, axis=0), axis=2).max())
            if moved <= spacing * (1 + 1e-9) or n >= 65536:
                break
            n = max(n + 1, int(math.ceil(n * moved / spacing)))
        out.append(seg)
    return np.concatenate(out)


def _goals_elsewhere(generator, target, start: Pose, validity: StateValidity) -> list:
    """Goal rows where neither this reach's chest nor the start's has one: at the chest
    rotation that fits the target (``target_chest``), else at the first of the search's
    last tries within the goal tolerance that fits
    (:func:`~reach_addon.core.diagnosis.fit_within_tolerance`, with its swivel step), so
    the sampling planner is not left without a goal where the diagnosis found a pose."""
    chest = generator.target_chest(target)
    if chest is not None:
        return goal_configurations(generator, target, start, validity, (chest,))
    near = fit_within_tolerance(generator, target)
    if near is None:
        return []
    fine, point, chest = near
    return goal_configurations(fine, point, start, validity, (chest,))


def straight_poses(generator, start: Pose, target) -> list | None:
    """A straight line in joint space from ``start`` to a goal pose at ``target``
    (canonical; :func:`~.straight.straight_to_goal`) as dense poses (``start`` first, each a step of
    the wrist and of the joints apart, :func:`densify_rows`), or None."""
    s, arm = generator.settings, generator.arm
    start_row = pose_row(start)
    space = JointSpace(arm, s, start_row)
    validity = StateValidity(arm, s, generator.checker, space)
    path = straight_to_goal(generator, target, start_row, validity, space)
    if path is None:
        return None
    rows = densify_rows(arm, path, generator.step_length, s.max_joint_step, s.hand_step_turn)
    return [start] + [generator.config_pose(ArmConfig.from_array(q[:5]),
                                            (float(q[5]), float(q[6]))) for q in rows[1:]]


def sampling_steps(generator, start: Pose, target, chunk: int = 0, seed=(),
                   seed_reaches: bool = False):
    """A path from ``start`` to ``target`` (canonical) by :class:`SamplingPlanner`, as a
    :class:`~reach_addon.core.search.SearchResult` of dense poses (``method`` =
    ``"sampling"``; ``nodes_searched`` counts the states tested). ``generator`` is the
    reach's view (:meth:`ConfigurationGenerator.for_reach`): its chest path chooses the
    chest rotation of the goal region. ``seed``: poses from ``start`` of a path the search
    found (reaching the target, or its closest approach): the start's tree is first grown
    along it, as far as its motions pass this planner's checks (the hand and arm
    interpolated together, at every step), so that a path the search nearly had is repaired
    where it fails rather than found again from nothing (a hand that cannot follow the
    search's path clear is usually caught in the last tenth of it). With ``seed_reaches``
    (the seed ends on the target) its end is one more goal, and the goals' tree is grown
    back along it likewise, so only the gap where it fails is left to sample. A generator:
    yields the states tested so far about every ``chunk`` states (never, if 0), returns the
    result."""
    s = generator.settings
    t0 = time.perf_counter()
    arm = generator.arm
    target = np.asarray(target, dtype=float)
    start_row = pose_row(start)
    space = JointSpace(arm, s, start_row)
    validity = StateValidity(arm, s, generator.checker, space)
    rng = np.random.default_rng(int(s.sampling_seed))
    goals = goal_configurations(generator, target, start, validity)
    if not goals:
        goals = _goals_elsewhere(generator, target, start, validity)
    path = straight_to_goal(generator, target, start_row, validity, space)
    if path is None and goals:
        bodies = [start_row[0]] + [g[0] for g in goals]
        lo, hi = space.lo.copy(), space.hi.copy()
        lo[0] = max(lo[0], min(bodies) - s.sampling_chest_slack)
        hi[0] = min(hi[0], max(bodies) + s.sampling_chest_slack)
        if hi[0] <= lo[0]:
            hi[0] = lo[0] + 1e-6
        near = near_target(arm, s, target, s.sampling_near_radius * arm.arm_length)
        rrt = SamplingPlanner(validity, start_row, goals, rng, s.sampling_budget,
                              s.sampling_range, s.step, lo, hi, near, s.sampling_near_share,
                              [pose_row(p) for p in seed], seed_reaches, s.sampling_path_share)
        path = yield from rrt.steps(chunk)
        if path is not None:
            path = rrt.shortcut(path, s.sampling_shortcuts)
    tested = validity.calls
    if path is None:
        closest = float(np.linalg.norm(start.wrist - target))
        return SearchResult(False, NO_PATH, [start], tested, time.perf_counter() - t0, closest,
                            target, method="sampling")
    rows = densify_rows(arm, path, generator.step_length, s.max_joint_step, s.hand_step_turn)
    poses = [start] + [generator.config_pose(ArmConfig.from_array(q[:5]),
                                             (float(q[5]), float(q[6]))) for q in rows[1:]]
    closest = float(np.linalg.norm(poses[-1].wrist - target))
    return SearchResult(True, None, poses, tested, time.perf_counter() - t0, closest, target,
                        method="sampling")
