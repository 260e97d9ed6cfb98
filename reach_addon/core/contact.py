"""Starting in contact: a hand resting on a table, fingertips a centimetre from a wall.

A start nearer an obstacle than the clearance is moved out of contact before planning.
Deeper than ``Settings.start_contact_depth`` (:func:`start_clearance`, negative inside)
it is refused (:func:`depth_message`). Otherwise :func:`escape` takes search steps with a
generator for a thinner arm (every radius less by what the start lacks) — the wrist's
steps at the chest as it is, and only where none of them gets on, with the chest turned a
little either way — each the step that most increases the real arm's clearance and, while
it touches, never one that decreases it (where none increases it, the one that takes the
wrist farthest, keeping the clearance while it touches and never touching again once out),
until the real arm is clear with the whole margin, at most ``max_steps`` steps. Where
that greedy way is stuck or runs out of steps, a best-first search over the same steps,
under the same rule, with chest turns from every pose (:func:`_search`); and where that
finds none, straight lines in joint space toward clear poses at the target, under the
same rule (:func:`_straight`). The escape's poses lead the motion; the hand pass checks
their frames with the thinner arm.
"""

from __future__ import annotations

import dataclasses
import heapq
import itertools
import math

import numpy as np

from .arm import ArmConfig, Pose
from .body_capsules import self_collision
from .collision import CLEARANCE_TOLERANCE
from .generator import ConfigurationGenerator
from .hand_shape import world_pose
from .search import sphere_directions
from .torso import body_rotation_deg


@dataclasses.dataclass
class Escape:
    """The way out of a start in contact: ``poses`` (the start first, the last clear with
    the whole margin), the thinner arm's ``generator``, the start's clearance and the
    obstacle it touched."""

    poses: list
    generator: ConfigurationGenerator
    start_clearance: float
    obstacle: str


def start_clearance(generator: ConfigurationGenerator, pose: Pose) -> float:
    """The least distance (figure units) between the pose's capsules (arm and hand, without
    the margin) and the obstacles; negative where a capsule is inside one. A lower bound
    (:meth:`~reach_addon.core.collision.CollisionChecker.least_clearance`): an escape
    that never lets it fall never lets the true clearance fall by more than its
    tolerance."""
    return generator.checker.least_clearance(world_pose(generator.arm, pose),
                                             generator.arm.arm_length)


def thinner(generator: ConfigurationGenerator, by: float) -> ConfigurationGenerator:
    """A generator for the same arm with every capsule's radius (the hand shape's too) less
    by ``by`` (kept at least a tenth of itself)."""
    arm = generator.arm
    radii = {k: max(getattr(arm, k) - by, 0.1 * getattr(arm, k))
             for k in ("upper_arm_radius", "forearm_radius", "hand_radius")}
    shape = tuple((a, b, max(r - by, 0.1 * r)) for a, b, r in arm.hand_shape)
    return ConfigurationGenerator(dataclasses.replace(arm, hand_shape=shape, **radii),
                                  generator.obstacles, generator.settings)


def escape(generator: ConfigurationGenerator, start: Pose, obstacle: str,
           max_steps: int = 40, max_expansions: int = 30, target=None) -> Escape | None:
    """Move out of contact (see the module docstring): the greedy way first
    (:func:`_greedy`, at most ``max_steps`` steps), and where it is stuck or runs out of
    steps, a best-first search (:func:`_search`, at most ``max_expansions`` poses
    expanded), and where that finds none, straight lines in joint space toward the target
    (``target``, canonical; :func:`_straight`). None if none gets the real arm clear."""
    c0, loose = _loose_start(generator, start)
    poses = _greedy(loose, generator, start, c0, max_steps)
    if poses is None:
        poses = _search(loose, generator, start, c0, max_expansions)
    if poses is None and target is not None:
        poses = _straight(loose, generator, start, c0, _goals(loose, start, target))
    return None if poses is None else Escape(poses, loose, c0, obstacle)


def line_escape(generator: ConfigurationGenerator, start: Pose, obstacle: str,
                target) -> Escape | None:
    """A second way out, for a reach that failed from :func:`escape`'s: straight lines in
    joint space (:func:`_straight`) toward clear poses at ``target`` (canonical) with the
    chest every :data:`LINE_CHEST_STEP` degrees over its range (:func:`_line_goals`). The
    greedy escape takes whatever way gets clear soonest, which may turn the chest away from
    the only way in (fuzz seed 7624: a clavicle in a mesh, left by turning the chest 40°
    one way where the target is reached only with it turned 30° the other, as the
    cross-check's OMPL went, straight and never deeper; 2959, a chase). None if no line
    gets the real arm clear."""
    c0, loose = _loose_start(generator, start)
    poses = _straight(loose, generator, start, c0, _line_goals(loose, start, target))
    return None if poses is None else Escape(poses, loose, c0, obstacle)


def _loose_start(generator: ConfigurationGenerator, start: Pose) -> tuple:
    """(the start's clearance, the escape's arm): an arm thinner by what the start lacks
    of the margin, and thinner still until its own test passes the start (:func:`_passing`):
    the hand pass checks the escape's frames with it, and a start its test refuses would
    fail the first frames the timing holds there (fuzz seed 3441: an upper arm 0.0137 arm
    lengths from a box)."""
    margin = generator.checker.margin
    c0 = start_clearance(generator, start)
    return c0, _passing(generator, start,
                        margin - min(c0, margin) + 1e-3 * generator.arm.arm_length)


def _clear_poses(loose, target, body: float, start: Pose) -> list:
    """Every clear swivel pose at ``target`` (canonical) with the chest at ``body``
    (:meth:`~.generator.ConfigurationGenerator.clear_swivels`), the start's hand held."""
    sol, ks, _joints = loose.clear_swivels(np.asarray(target, dtype=float), float(body), start)
    return [sol.pose(0, k, hand=start.hand) for k in ks]


#: The chest rotations (degrees apart) of :func:`line_escape`'s goal poses.
LINE_CHEST_STEP = 10.0


def _line_goals(loose, start: Pose, target) -> list:
    """Clear poses at ``target`` (canonical) with the chest every :data:`LINE_CHEST_STEP`
    degrees over its range, at its ends and as it starts (kept still without chest
    rotation), the start's hand held: the first swivel sample of each chest in turn (the
    chest nearest the start's first), then the next of each, at most
    :data:`LINE_ESCAPE_GOALS`."""
    s = loose.settings
    limit = float(s.chest_rotation_max) if s.chest_rotation else 0.0
    n = int(math.floor(limit / LINE_CHEST_STEP))
    bodies = list(dict.fromkeys([k * LINE_CHEST_STEP for k in range(-n, n + 1)]
                                + [-limit, limit, start.config.body_rotation]))
    bodies.sort(key=lambda b: abs(b - start.config.body_rotation))
    per_body = [_clear_poses(loose, target, body, start) for body in bodies]
    # one of each chest's in turn: which lines stay out of contact is not told by how far
    # they go (seed 7624: the 46 of 258 that do lie 98th to 203rd by any joint distance,
    # all with the chest at -30° or beyond), but by the chest they turn to
    out = [p for rank in itertools.zip_longest(*per_body) for p in rank if p is not None]
    return out[:LINE_ESCAPE_GOALS]


#: The most goal poses :func:`line_escape` heads for.
LINE_ESCAPE_GOALS = 128


#: The most a joint turns (degrees) between two poses of :func:`_straight`'s lines.
LINE_ANGLE_STEP = 2.0


#: The most goal poses :func:`_straight` heads for.
LINE_GOALS = 64


def _goals(loose, start: Pose, target) -> list:
    """Poses at ``target`` (canonical) for :func:`_straight` to head for: every swivel
    whose arm is legal and clear there (:meth:`~.generator.ConfigurationGenerator.
    clear_swivels`), with the chest as Table 1 turns it there, as it starts and at either
    end of its range (fuzz seed 6288, whose cross-check's OMPL left with the chest at 60°), the
    start's hand held; and the start's own arm with the chest at either end of its range
    (a line that need not reach the target: it ends at its first clear pose). The nearest
    the start in joint space first, at most :data:`LINE_GOALS`."""
    target = np.asarray(target, dtype=float)
    arm = loose.arm
    table1 = float(body_rotation_deg(target, arm.arm_length, arm.hand_length, loose.settings))
    out = []
    bodies = [table1, start.config.body_rotation]
    if loose.settings.chest_rotation:
        bodies += [-loose.settings.chest_rotation_max, loose.settings.chest_rotation_max]
    for body in dict.fromkeys(round(float(b), 9) for b in bodies):
        out += _clear_poses(loose, target, body, start)
    a = start.config.as_array()
    if loose.settings.chest_rotation:
        # the arm as it starts, carried by the chest turned to either end of its range: a
        # clavicle in a box leaves as the trunk turns, whatever the arm does (fuzz seed
        # 8331, clear by a turn of 40° that never goes deeper)
        for end in (-1.0, 1.0):
            turned = a.copy()
            turned[0] = end * float(loose.settings.chest_rotation_max)
            out.append(loose.config_pose(ArmConfig.from_array(turned), start.hand))
    out.sort(key=lambda p: float(np.abs(p.config.as_array() - a).max()))
    return out[:LINE_GOALS]


def _straight(loose, generator, start: Pose, c0: float, goals) -> list | None:
    """Where the wrist's steps find no way out (the IK picks the strongest swivel at each
    wrist, and an upper arm against a box may leave only by a swivel and twist the
    strength order never reaches: fuzz seeds 863 and 2588, whose cross-check's OMPL left by
    a straight line in joint space): the straight line in joint space (the chest, the
    shoulder's three angles, the elbow and the wrist's two) from ``start`` toward each of
    ``goals`` in turn, at most a search step of the wrist and :data:`LINE_ANGLE_STEP` of a
    joint apart, each pose clear of the body and under the escape's rule on the real arm
    (never deeper than the least depth it has reached while it touches, never back in once
    out): the poses up to the first the real arm's test calls clear, or None. (No thinner
    arm's test: a start whose thinnest arm still touches leaves by that rule alone, as the
    cross-check's search does.)"""
    arm = generator.arm
    noise = _noise(generator)
    a = np.append(start.config.as_array(), start.hand)
    for goal in goals:
        b = np.append(goal.config.as_array(), goal.hand)
        travel = math.dist(start.wrist.tolist(), goal.wrist.tolist())
        n = max(2, int(math.ceil(travel / generator.step_length)),
                int(math.ceil(float(np.abs(b - a).max()) / LINE_ANGLE_STEP)))
        poses, clearance = [start], c0
        for k in range(1, n + 1):
            q = a + (b - a) * (k / n)
            pose = generator.config_pose(ArmConfig.from_array(q[:5]), (float(q[5]), float(q[6])))
            if self_collision(arm, pose.config.body_rotation, pose.joints[None])[0]:
                break
            c = start_clearance(generator, pose)
            if c < min(clearance, 0.0) - noise:
                break
            clearance = max(clearance, c)
            poses.append(pose)
            if not generator.checker.collides(world_pose(arm, pose)):
                return poses
    return None


def _offsets(generator: ConfigurationGenerator, prev: Pose) -> np.ndarray:
    """The wrist's escape steps from ``prev``: the search's directions, and along the
    limbs (a hand in a sleeve or a slot slides out only along it, which no direction of
    the sphere follows closely enough)."""
    along = [prev.wrist - prev.elbow, prev.joints[4] - prev.wrist]
    along = [generator.step_length * s * v / max(float(np.linalg.norm(v)), 1e-12)
             for v in along for s in (1.0, -1.0)]
    return np.vstack([generator.step_length * sphere_directions(int(generator.settings.directions))]
                     + along)


def _noise(generator: ConfigurationGenerator) -> float:
    """What the clearance's measure may err by (it errs low): a step that keeps the
    clearance (a hand sliding along a plane) reads as that much nearer or farther."""
    return CLEARANCE_TOLERANCE * generator.arm.arm_length


def _greedy(loose, generator, start: Pose, c0: float, max_steps: int) -> list | None:
    """The greedy escape of the module docstring: the poses from ``start`` to the first
    the real arm's test calls clear, or None."""
    arm = generator.arm
    poses, clearance = [start], c0
    noise = _noise(generator)
    for step in range(max_steps + 1):
        if not generator.checker.collides(world_pose(arm, poses[-1])):
            return poses
        if step == max_steps:
            return None
        prev = poses[-1]
        body = prev.config.body_rotation
        offsets = _offsets(generator, prev)
        # the wrist's steps with the chest as it is; only where none gets on, with the
        # chest turned a little either way too
        best, best_key = _best_step(loose, generator, prev, start, clearance, noise,
                                    [(w, body) for w in prev.wrist + offsets])
        stuck = best is None or (not best_key[0] and best_key[2] <= math.dist(
            prev.wrist.tolist(), start.wrist.tolist()) + 1e-9)
        turns = _chest_turns(generator.settings, body)
        if stuck and turns:
            best, best_key = _best_step(loose, generator, prev, start, clearance, noise,
                                        [(w, b) for b in turns for w in prev.wrist
                                         + np.vstack([np.zeros((1, 3)), offsets])])
            stuck = best is None or not best_key[0]
        if stuck:
            return None                          # nothing farther from it, nor out along it
        poses.append(best)
        clearance = max(clearance, best_key[1])
    return None


def _search(loose, generator, start: Pose, c0: float, max_expansions: int) -> list | None:
    """Where the greedy escape is stuck: a best-first search over the same steps, the
    wrist's and, from every pose, the chest turned :data:`ESCAPE_CHEST_STEP` either way
    (with the wrist kept or stepped). A step is legal by the greedy way's rule: while the
    real arm touches, never deeper than the least depth it has reached on its way, and once a
    pose on its way is out of contact, never in contact again (the rule
    :func:`~reach_addon.core.motion_check.escape_contact` holds the motion to). The
    pose of greatest real clearance is expanded first (ties: the wrist farthest from the
    start), each wrist cell (half a step) and chest turn once; the first pose the real
    arm's test calls clear ends it, and its way back to the start is the escape. Fuzz seeds
    5045 (an upper arm along a thin wall, whose way out gains clearance only every few
    slides) and 5235 (a clavicle in a mesh, which only the chest moves) escape here."""
    arm = generator.arm
    noise = _noise(generator)
    cell = 0.5 * generator.step_length

    def key(pose):
        return tuple(np.round(pose.wrist / cell).astype(int).tolist()) + (
            round(pose.config.body_rotation / ESCAPE_CHEST_STEP),)

    nodes = [(start, -1, c0)]
    seen = {key(start)}
    heap = [(-c0, 0.0, 0)]
    for _ in range(max_expansions):
        if not heap:
            return None
        _c, _far, i = heapq.heappop(heap)
        prev, _parent, c_prev = nodes[i]
        body = prev.config.body_rotation
        offsets = _offsets(generator, prev)
        tries = [(w, body) for w in prev.wrist + offsets]
        tries += [(w, b) for b in _chest_turns(generator.settings, body)
                  for w in prev.wrist + np.vstack([np.zeros((1, 3)), offsets])]
        floor = min(c_prev, 0.0)
        for w, b in tries:
            pose = loose.solve(w, prev, body_rotation=b, hand_scale=1.0)
            if pose is None or key(pose) in seen:
                continue
            c = start_clearance(generator, pose)
            if c < floor - noise:
                continue
            seen.add(key(pose))
            nodes.append((pose, i, max(c, c_prev)))
            if not generator.checker.collides(world_pose(arm, pose)):
                way, j = [], len(nodes) - 1
                while j >= 0:
                    way.append(nodes[j][0])
                    j = nodes[j][1]
                return way[::-1]
            heapq.heappush(heap, (-c, -math.dist(pose.wrist.tolist(), start.wrist.tolist()),
                                  len(nodes) - 1))
    return None


def _passing(generator: ConfigurationGenerator, start: Pose, by: float,
             grow: float = 1.5) -> ConfigurationGenerator:
    """The :func:`thinner` generator, less by ``by`` and then by ``grow`` times as much
    again until its own test passes ``start`` (the start pose itself, and a solve with the
    wrist where it is, the chest as it is), or, where none does before every radius is
    at its floor, the thinnest (a hand sunk
    into a table leaves by turning, which the start's own hand cannot). The generator's
    capsule test is conservative (a short piece of a capsule is settled by a sphere up to
    ~12 % wider than its radius), so an arm thinned by exactly what the start lacks may
    still refuse a pose as deep as the start (fuzz seed 5235: a clavicle 0.018 arm lengths
    into a mesh, which the wrist's steps never move). Only the solve uses the thinner arm;
    every step is measured on the real one."""
    arm = generator.arm
    world = world_pose(arm, start)
    while True:
        loose = thinner(generator, by)
        if (not loose.checker.collides(world) and loose.solve(
                start.wrist, start, body_rotation=start.config.body_rotation,
                hand_scale=1.0) is not None) or all(
                getattr(loose.arm, k) <= 0.1 * getattr(arm, k) * (1 + 1e-9)
                for k in ("upper_arm_radius", "forearm_radius", "hand_radius")):
            return loose
        by *= grow


def _best_step(loose, generator, prev: Pose, start: Pose, clearance: float, noise: float,
               tries) -> tuple:
    """(pose, key) of the best escape step among ``tries`` [(wrist, chest rotation)] from
    ``prev`` (:func:`escape`), or (None, None)."""
    best, best_key = None, None
    for w, b in tries:
        pose = loose.solve(w, prev, body_rotation=b, hand_scale=1.0)
        if pose is None:
            continue
        c = start_clearance(generator, pose)
        if c < min(clearance, 0.0) - noise:
            continue            # never nearer what it touches, nor back into it once out
        # the farthest from what it touches; where no step gets farther (a hand in a
        # sleeve, its faces parallel to the walls; an arm out of contact at the top of
        # its clearance, within the margin still), the farthest from the start, so that
        # it slides on out
        farther = c > clearance + noise
        key = (farther, c if farther else -math.inf,
               math.dist(w.tolist(), start.wrist.tolist()), c)
        if best_key is None or key > best_key:
            best, best_key = pose, key
    return best, best_key


#: The chest's turn (degrees) an escape step may take, either way (:func:`_chest_turns`).
ESCAPE_CHEST_STEP = 5.0


def _chest_turns(settings, body: float) -> list:
    """The chest rotations an escape step may turn to from ``body``: a
    :data:`ESCAPE_CHEST_STEP` either way within ``Settings.chest_rotation_max`` (a clavicle or
    upper arm against a box the wrist's steps cannot move off; fuzz seed 7074, where the
    cross-check's OMPL left with the chest turned); none with the chest kept still."""
    if not settings.chest_rotation:
        return []
    limit = float(settings.chest_rotation_max)
    return [b for b in (body - ESCAPE_CHEST_STEP, body + ESCAPE_CHEST_STEP)
            if -limit - 1e-9 <= b <= limit + 1e-9]


def bone_touches(checker, world_joints) -> bool:
    """Does any capsule's axis (a bone: sternum to shoulder, shoulder to elbow, elbow to
    wrist, wrist to the hand's end) come within :data:`CLEARANCE_TOLERANCE` arm lengths of
    an obstacle's surface? Such a start is refused whatever its depth reads: the capsule's
    depth is at most its radius however far the bone runs through a thin obstacle, so no
    step's depth says which way is out (fuzz seeds 5103, 5117: a forearm's bone through a
    plane, 0.075 arm lengths "deep", which a way out never deeper than that could pass
    straight through)."""
    length = checker.arm.arm_length
    tolerance = CLEARANCE_TOLERANCE * length
    j = np.asarray(world_joints, dtype=float)
    return any(checker.axis_distance(j[seg.a], j[seg.b], 2.0 * tolerance, 0.5 * tolerance)
               <= tolerance for seg in checker.segments)


def depth_message(obstacle: str, part: str, depth: float, limit: float,
                  how: str | None = None) -> str:
    """Why a start in contact is refused: how deep it is (``how``, else the depth, or
    "inside" where it is infinite), and what to do."""
    how = how or ("inside" if depth == float("inf") else f"{depth:.2f} arm lengths into")
    return (f"the start pose is {how} '{obstacle}' (at the {part}), deeper than the "
            f"{limit:.2f} arm lengths a start may touch (Start contact tolerance); move the "
            "arm or the obstacle apart before planning")

