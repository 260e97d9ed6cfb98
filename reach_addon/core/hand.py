"""The hand over a finished arm motion: continuous, relaxed, and clear at every instant.

The paper leaves the hand free ("the position of the palm center is just a further search
for a point on a sphere"). The search places a hand at every node it tries (the first clear
direction of a few samples, :meth:`ConfigurationGenerator._place_hand`), which is enough to
know a wrist position is usable but says nothing about how the hand moves from one frame
to the next: chosen frame by frame, it flipped from bent down to bent up between two keys
and swept through what it had turned away from.

Design: the wrist's two angles (bend in the elbow's plane, side bend across it,
:func:`~reach_addon.core.arm.hand_direction`) are chosen in one pass over the finished,
timed arm motion, by dynamic programming over frames × a grid of wrist angles:

* **States.** The grid spans the wrist's range (``Settings.wrist_bend_max``,
  ``wrist_side_max``) every ``Settings.hand_grid_step`` degrees of bend (side bends 2.5
  times wider); it holds the search's own hand samples, so every frame the search or the
  timing produced has at least one clear state. The start state is the rig's own hand
  (anywhere, even outside the range), joined to the grid by a chain of states.
* **Constraints.** A state must be clear of the obstacles and the body at its frame
  (:meth:`ConfigurationGenerator.hands_clear`). A transition may turn the hand, relative to
  the forearm, by at most ``Settings.hand_turn_speed`` / fps degrees.
* **Cost.** Σ (turn / bound)² + ``wrist_relax_weight`` · (bend from neutral / 45°)²: the
  hand turns no faster and no farther than it must, and drifts back toward neutral when
  it is free.
* **Between keys** (lazy, as in lazy PRM: only the chosen path is checked). Each
  transition is checked at ``Settings.instants_per_frame`` − 1 instants between the two
  keys, the arm's five angles and the wrist's two interpolated linearly (what Blender's
  interpolation of the keyed rotations does, to within the clearance, for moves this
  small). A hand that touches between keys bans that transition and the pass runs again.
* **Slowing down.** Where no bounded, clear choice exists (the hand would have to turn
  faster than the bound), or the arm itself touches something between two keys, a frame
  is inserted between them (the arm's angles halfway, or, if that pose is not clear, a
  solved pose halfway along the wrist path): the motion slows through the tight spot
  instead of sweeping through it. At most ``Settings.slowdown_budget`` × frames are
  added; past that (or where frames are tied to the clock, as in a chase) the bound is
  lifted for that transition and the excess is reported.

Measured before committing to it: bounding the hand inside the search (as a per-step
limit) trapped the search in narrow gaps and searched ~7× more nodes; as a pass over the
finished path it leaves the search alone and costs one grid test per frame near obstacles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .arm import Pose, forward_kinematics
from .generator import hand_coefficients


@dataclass
class HandReport:
    """What the hand pass did to one motion."""

    poses: list
    inserted_frames: int = 0
    max_wrist_turn_deg: float = 0.0      # largest turn relative to the forearm in one frame
    max_hand_turn_deg: float = 0.0       # largest turn of the hand's direction in space
    mean_wrist_bend_deg: float = 0.0     # mean angle between hand and forearm
    max_wrist_bend_deg: float = 0.0
    unbounded_turns: int = 0             # transitions where the bound had to be lifted
    unclear_transitions: list = field(default_factory=list)  # k: k → k + 1 still touching


@dataclass(frozen=True)
class HandGrid:
    """The wrist-angle states: ``angles`` (S, 2) degrees, ``coefficients`` (S, 3) (see
    :func:`~reach_addon.core.generator.hand_coefficients`), ``turn`` (S, S) degrees between
    their directions, ``bend`` (S,) degrees from neutral; ``start`` the start state."""

    angles: np.ndarray
    coefficients: np.ndarray
    turn: np.ndarray
    bend: np.ndarray
    start: int


def wrist_turn(coefficients_a, coefficients_b):
    """Angle (degrees) between hand directions given by their coefficients (…, 3)."""
    dot = np.einsum("...i,...i->...", coefficients_a, coefficients_b)
    return np.degrees(np.arccos(np.clip(dot, -1.0, 1.0)))


def hand_grid(settings, start_hand, bound: float) -> HandGrid:
    """The grid of wrist angles, plus the start hand and a chain of states (at most half
    the bound apart) from it to the nearest grid state."""
    step = settings.hand_grid_step
    b_max, s_max = settings.wrist_bend_max, settings.wrist_side_max
    bends = np.linspace(-b_max, b_max, 2 * math.ceil(b_max / step) + 1) if b_max > 0 else [0.0]
    n_side = 2 * math.ceil(s_max / (2.5 * step)) + 1 if s_max > 0 else 1
    sides = np.linspace(-s_max, s_max, n_side) if s_max > 0 else [0.0]
    grid = [(float(b), float(s)) for b in bends for s in sides]
    coef = np.array([hand_coefficients(b, s) for b, s in grid])
    start = (float(start_hand[0]), float(start_hand[1]))
    c0 = np.array(hand_coefficients(*start))
    near = int(np.argmin(wrist_turn(coef, c0)))
    gap = float(wrist_turn(coef[near], c0))
    chain = []
    n = math.ceil(gap / (0.5 * bound)) if gap > 1e-6 else 0
    for k in range(n):
        t = k / n
        chain.append((start[0] + t * (grid[near][0] - start[0]),
                      start[1] + t * (grid[near][1] - start[1])))
    if not chain:
        chain = [start]
    angles = np.array(grid + chain)
    coefficients = np.vstack([coef, [hand_coefficients(b, s) for b, s in chain]])
    turn = wrist_turn(coefficients[:, None], coefficients[None])
    bend = np.degrees(np.arccos(np.clip(coefficients[:, 0], -1.0, 1.0)))
    return HandGrid(angles, coefficients, turn, bend, len(grid))


def _interpolate(a: Pose, b: Pose, t: float):
    """The arm's five angles interpolated linearly between two poses at fraction ``t``."""
    return (1.0 - t) * a.config.as_array() + t * b.config.as_array()


class HandPass:
    """Choose the hand at every frame of a motion (see the module docstring).

    ``generators``: one :class:`ConfigurationGenerator` for every frame, or one for all
    (a chase against moving obstacles has one per frame). ``fps``: frames per second.
    ``may_insert``: may frames be added (not in a chase, whose frames are the target's)."""

    def __init__(self, generators, fps: float, may_insert: bool = True):
        self.generators = generators
        gen = generators[0] if isinstance(generators, list) else generators
        self.arm, self.settings = gen.arm, gen.settings
        self.bound = self.settings.hand_turn_speed / fps
        self.may_insert = may_insert
        self._clear: set = set()

    def _gen(self, k):
        g = self.generators
        return g[min(k, len(g) - 1)] if isinstance(g, list) else g

    def run(self, poses: list) -> HandReport:
        s = self.settings
        poses = list(poses)
        if len(poses) < 2 or not self._gen(0).checker.check_hand:
            return self._report(poses, [p.hand for p in poses], 0, 0, [])
        grid = hand_grid(s, poses[0].hand, self.bound)
        budget = int(s.slowdown_budget * len(poses)) if self.may_insert else 0
        inserted = 0
        feasible = [None] + [self._feasible(k, p, grid) for k, p in enumerate(poses) if k]
        banned: dict = {}          # frame k -> {(state at k - 1, state at k)} that touch
        lifted: set = set()        # frames k whose turn from k - 1 may exceed the bound
        accepted: set = set()      # transitions k -> k + 1 left touching (nothing helped)
        path = None

        def slow_down(k, count=1) -> bool:
            """Insert ``count`` frames between k and k + 1 (fewer if the budget is short)
            and renumber what is kept by frame."""
            nonlocal banned, lifted, accepted, inserted
            count = min(count, budget - inserted)
            if count <= 0:
                return False
            added = self._insert(poses, feasible, grid, k, count)
            if not added:
                return False
            inserted += added
            banned = {(j + added if j > k else j): v for j, v in banned.items()}
            lifted = {j + added if j > k else j for j in lifted}
            accepted = {j + added if j > k else j for j in accepted}
            return True

        for _round in range(64 + 4 * len(poses)):
            path, fail = self._dp(poses, grid, feasible, banned, lifted)
            if path is None:
                # no bounded, clear choice into frame `fail`: slow down there (as many
                # frames as the least turn needed takes at the bound), else lift the bound
                fail, reachable = fail
                gap = grid.turn[np.ix_(reachable, feasible[fail])]
                need = math.ceil(float(gap.min()) / self.bound - 1e-9) - 1 if gap.size else 1
                if not slow_down(fail - 1, max(1, need)):
                    lifted.add(fail)
                continue
            problem = self._between(poses, grid, path, accepted)
            if problem is None:
                break
            k, what = problem
            if what == "hand" and (k + 1) not in lifted:
                banned.setdefault(k + 1, set()).add((path[k], path[k + 1]))
            elif not slow_down(k):
                accepted.add(k)
        if path is None:
            # out of rounds: the least-cost path through clear states, turns unbounded
            lifted = set(range(1, len(poses)))
            path, _fail = self._dp(poses, grid, feasible, {}, lifted)
        if path is not None:
            # what is reported touching: every transition of the final path that touches
            accepted, skip = set(), set()
            while (problem := self._between(poses, grid, path, skip)) is not None:
                accepted.add(problem[0])
                skip.add(problem[0])
        hands = [tuple(grid.angles[i]) for i in path] if path is not None else \
            [p.hand for p in poses]
        return self._report(poses, hands, inserted, len(lifted), sorted(accepted))

    # --- the pieces -------------------------------------------------------------------
    def _feasible(self, k, pose: Pose, grid: HandGrid) -> np.ndarray:
        return self._gen(k).hands_clear(pose.joints, pose.bend, pose.config.body_rotation,
                                        grid.coefficients)

    def _dp(self, poses, grid: HandGrid, feasible, banned, lifted):
        """(least-cost state path (a state index per frame), None), or (None, (k,
        reachable)) with the first frame ``k`` no bounded, clear state can reach and the
        mask of the states reachable at frame k - 1."""
        s = self.settings
        n_states = len(grid.angles)
        ratio = grid.turn / self.bound
        edge = np.where(grid.turn <= self.bound + 1e-9, ratio * ratio, np.inf)
        free = ratio * ratio
        node = s.wrist_relax_weight * (grid.bend / 45.0) ** 2
        cost = np.full(n_states, np.inf)
        cost[grid.start] = 0.0
        back = np.zeros((len(poses), n_states), dtype=np.int64)
        cols = np.arange(n_states)
        for k in range(1, len(poses)):
            m = cost[:, None] + (free if k in lifted else edge)
            for i, j in banned.get(k, ()):
                if i >= 0:
                    m[i, j] = np.inf
            arg = np.argmin(m, axis=0)
            best = m[arg, cols] + node
            best[~feasible[k]] = np.inf
            if not np.isfinite(best).any():
                return None, (k, np.isfinite(cost))
            back[k] = arg
            cost = best
        path = [int(np.argmin(cost))]
        for k in range(len(poses) - 1, 0, -1):
            path.append(int(back[k, path[-1]]))
        return path[::-1], None

    def _between(self, poses, grid: HandGrid, path, skip=()):
        """The first transition (k, 'arm' or 'hand'), other than those in ``skip``, that
        touches something at an instant between its two keys, or None. Transitions found
        clear are remembered (by their poses and states), so each is checked once."""
        n = self.settings.instants_per_frame
        if n <= 1:
            return None
        fractions = np.arange(1, n) / n
        for k in range(len(poses) - 1):
            if k in skip:
                continue
            a, b = poses[k], poses[k + 1]
            key = (id(a), id(b))
            hand_key = key + (path[k], path[k + 1])
            if hand_key in self._clear:
                continue
            gen = self._gen(k + 1)
            configs = (1.0 - fractions)[:, None] * a.config.as_array() + \
                fractions[:, None] * b.config.as_array()
            joints, bends = forward_kinematics(self.arm, configs)
            if key not in self._clear:
                if not all(gen.arm_clear(j, c[0]) for j, c in zip(joints, configs)):
                    return k, "arm"
                self._clear.add(key)
            ha, hb = grid.angles[path[k]], grid.angles[path[k + 1]]
            for t, j, bend, c in zip(fractions, joints, bends, configs):
                coef = np.array([hand_coefficients(*((1.0 - t) * ha + t * hb))])
                if not gen.hands_clear(j, bend, c[0], coef)[0]:
                    return k, "hand"
            self._clear.add(hand_key)
        return None

    def _insert(self, poses, feasible, grid, k, count: int = 1) -> int:
        """Insert ``count`` poses evenly between frames k and k + 1: the arm's angles
        interpolated where that pose is clear, else a pose solved at the interpolated
        wrist position. Returns how many were inserted (0 if some could not be)."""
        if k < 0 or k + 1 >= len(poses):
            return 0
        a, b = poses[k], poses[k + 1]
        gen = self._gen(k + 1)
        new, clears = [], []
        prev = a
        for j in range(1, count + 1):
            t = j / (count + 1)
            config = _interpolate(a, b, t)
            mid = gen.config_pose(type(a.config).from_array(config))
            clear = self._feasible(k + 1, mid, grid) if gen.arm_clear(mid.joints, config[0]) \
                else None
            if clear is None or not clear.any():
                wrist = (1.0 - t) * a.wrist + t * b.wrist
                mid = gen.solve(wrist, prev, body_rotation=float(config[0]), hand_scale=1.0) \
                    or gen.solve(wrist, prev, hand_scale=1.0) or gen.solve(wrist, b, hand_scale=1.0)
                if mid is None:
                    return 0
                clear = self._feasible(k + 1, mid, grid)
            new.append(mid)
            clears.append(clear)
            prev = mid
        poses[k + 1:k + 1] = new
        feasible[k + 1:k + 1] = clears
        return count

    def _report(self, poses, hands, inserted, lifted, unclear):
        arm = self.arm
        out = []
        dirs = []
        for pose, hand in zip(poses, hands):
            hand = (float(hand[0]), float(hand[1]))
            gen = self._gen(0)
            axes = gen.hand_axes(pose.joints, pose.bend)
            d = np.array(hand_coefficients(*hand)) @ axes
            joints = pose.joints.copy()
            joints[4] = joints[3] + arm.hand_length * d
            out.append(Pose(pose.config, joints, pose.bend, pose.f_r, hand))
            dirs.append(d)
        coef = np.array([hand_coefficients(*h) for h in hands])
        bends = np.degrees(np.arccos(np.clip(coef[:, 0], -1.0, 1.0)))
        rel = wrist_turn(coef[1:], coef[:-1]) if len(coef) > 1 else np.zeros(1)
        dirs = np.array(dirs)
        world = wrist_turn(dirs[1:], dirs[:-1]) if len(dirs) > 1 else np.zeros(1)
        return HandReport(out, inserted, float(rel.max(initial=0.0)),
                          float(world.max(initial=0.0)), float(bends.mean()),
                          float(bends.max()), lifted, list(unclear))


def plan_hand(generators, poses, fps: float, may_insert: bool = True) -> HandReport:
    """Run the hand pass over ``poses`` (see the module docstring)."""
    return HandPass(generators, fps, may_insert).run(poses)
