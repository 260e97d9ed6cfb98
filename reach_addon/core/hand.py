"""The hand: continuous, relaxed, and clear at every instant of the baked motion.

The paper leaves the hand free ("the position of the palm center is just a further search
for a point on a sphere"). Placed pose by pose it flipped from bent down to bent up between
two keys and swept through what it had turned away from. Reach makes it continuous in two
places:

1. **In the search** (:mod:`~reach_addon.core.search`, :mod:`~reach_addon.core.generator`):
   the hand is part of the state. A step may turn it by at most
   ``Settings.hand_step_turn``, its old direction must still be clear at the new pose and
   so must every direction it turns through; a hand that must turn *before* the arm can
   move turns in place (a move of its own). Positions are visited per hand. So the
   searched path never carries the hand into a pocket of clear directions that closes
   round it (an obstacle's edge passing over the hand as the wrist goes by), which no
   timing can undo. Where this finds no way (or a worse closest approach), the search is
   run once more with the hand free, and this pass reports what it cannot mend.
2. **Over the frames** (this module): after the timing
   (:func:`~reach_addon.core.motion.time_path`, frames sampled along the validated path),
   the wrist's two angles (bend in the elbow's plane, side bend across it,
   :func:`~reach_addon.core.arm.hand_direction`) are chosen again by dynamic programming
   over frames × a grid of wrist angles:

   * **States.** The grid spans the wrist's range (``Settings.wrist_bend_max``,
     ``wrist_side_max``) every ``Settings.hand_grid_step`` degrees of bend (side bends 2.5
     times wider); it holds the search's hand samples. The start state is the rig's own
     hand (anywhere, even outside the range), joined to the grid by a chain of states.
     One more state per frame is the frame's *own* hand, the one the validated path
     carries there (:class:`~reach_addon.core.motion.PathSampler`): continuous along the
     path and clear by construction, so that slowing down along the path always has a
     bounded, clear sequence to offer. A frame sampled between two of the path's poses
     may bring it within the margin (the arm's angles interpolated); there it counts as
     clear if it keeps half the margin (as between keys), at a cost above any bounded
     sequence of turns (:attr:`HandPass.LOOSE_COST`), so the full margin wins wherever
     some choice keeps it.
   * **Constraints.** A state must be clear of the obstacles and the body at its frame
     (:meth:`ConfigurationGenerator.hands_clear`); a transition may turn the hand, relative
     to the forearm, by at most ``Settings.hand_turn_speed`` / fps degrees, and its whole
     orientation in space (the forearm's turn and roll included,
     :func:`~reach_addon.core.arm.frame_turn`) by at most ``hand_space_turn_speed`` / fps,
     so no bone of the hand turns faster.
   * **Cost.** Σ (turn / bound)² + ``wrist_relax_weight`` · (bend from neutral / 45°)²:
     the hand turns no faster and no farther than it must, and drifts back toward neutral
     when it is free. With *Match orientation* (a ``goal``, :mod:`.orient`) the last
     frames also cost ``orientation_weight`` · (palm frame's error after the best roll /
     45°)², weighted up to the last frame (:func:`~reach_addon.core.orient.frame_weights`),
     and the grid holds one more state, the wanted direction within the wrist's range.
   * **Between keys** (lazy, as in lazy PRM: only the chosen path is checked). Each
     transition is checked at ``Settings.instants_per_frame`` − 1 instants between its
     keys, where Blender puts the arm on a linear span (each segment's rotation relative
     to its parent blended by nlerp, :func:`~reach_addon.core.keys.between`), against
     half the clearance
     (:meth:`ConfigurationGenerator.between_keys`): keys keep the whole margin. A hand
     that touches bans that transition and the DP runs again; after
     :attr:`HandPass.BANS_BEFORE_REFINING` bans the transition is refined instead.
   * **Slowing down.** Where no bounded, clear choice exists, or the arm touches between
     two keys, frames are inserted between them: on the validated path at the arc
     lengths between (so the arm slows through the tight spot instead of sweeping
     through it), or, where that did not help, holds of both keys (the arm waits while
     the hand turns). Where no choice exists into a frame but the own hand was lost at an
     earlier one (it turned faster than the bound there, in place or with the arm, and
     the branches left closed later), the frames are inserted where it was lost: a
     branch shut at a pocket's edge is not reopened by slowing down at the edge (the
     demo's guided reach on a real character lifted the bound there after 96 holds).
     At most ``Settings.slowdown_budget`` × frames are added; past that
     (or where frames are tied to the clock, as in a chase) the bound is lifted for that
     transition, and ``unbounded_hand_turns`` reports it; a hand that still touches
     between the two keys gives way to the motion's own hands at both of them, which the
     motion's own checks passed there (a chase's step checks its frames as the keys
     interpolate), and ``touching_transitions`` counts what even those do not mend.

Measured: a pass over the frames alone (a free hand in the search) could not mend the
pockets (the demo kept 130–140° flips); the hand bounded inside the search without turns
in place and per-hand visits trapped the search (3–30× the nodes, demo tasks lost on a
real character). Together they leave the search 1.3–3× the nodes of a free hand on the
demo tasks and every reach clear and bounded (``make bench``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .arm import Pose, frame_turn, hand_coefficients, hand_orientation
from .orient import best_roll_error, frame_weights, wanted_hand_angles


@dataclass
class HandReport:
    """What the hand pass did to one motion."""

    poses: list
    inserted_frames: int = 0
    max_wrist_turn_deg: float = 0.0      # largest turn relative to the forearm in one frame
    max_hand_turn_deg: float = 0.0       # largest turn of the hand in space, roll included
    mean_wrist_bend_deg: float = 0.0     # mean angle between hand and forearm
    max_wrist_bend_deg: float = 0.0
    unbounded_turns: int = 0             # transitions where the bound had to be lifted
    unclear_transitions: list = field(default_factory=list)  # k: k → k + 1 still touching


@dataclass(frozen=True)
class HandGrid:
    """The wrist-angle states: ``angles`` (S, 2) degrees, ``coefficients`` (S, 3) (see
    :func:`~reach_addon.core.arm.hand_coefficients`), ``turn`` (S, S) degrees between
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


def hand_grid(settings, start_hand, bound: float, extra=()) -> HandGrid:
    """The grid of wrist angles, plus the start hand and a chain of states (at most half
    the bound apart) from it to the nearest grid state, then the ``extra`` states (the
    wanted hand of :mod:`.orient`, when the hand is matched to a target's orientation)."""
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
    chain += [(float(b), float(s)) for b, s in extra]
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

    #: Hand choices banned on one transition (they touch between its keys) before the
    #: transition is refined instead (a pose inserted between its two keys).
    BANS_BEFORE_REFINING = 4

    def __init__(self, generators, fps: float, may_insert: bool = True, arcs=None,
                 sampler=None, escape=None, goal=None):
        self.generators = generators
        gen = generators[0] if isinstance(generators, list) else generators
        self.arm, self.settings = gen.arm, gen.settings
        self.bound = self.settings.hand_turn_speed / fps
        self.space_bound = self.settings.hand_space_turn_speed / fps
        self._dirs: dict = {}
        self.may_insert = may_insert
        # where the frames lie along the motion (arc lengths of the validated path, or a
        # chase's frame numbers), and with a sampler a way to put poses between them
        self.sampler = sampler
        self.arcs = None if arcs is None else list(arcs)
        # (generator, arc length): frames before that arc are the way out of a start in
        # contact, checked with that (thinner arm's) generator (core.contact)
        self.escape = escape if self.arcs is not None else None
        self._clear: set = set()
        self._coefs: dict = {}     # id(pose) -> the states' coefficients there
        self._alive: list = []     # every pose whose id is a key (see _coefficients)
        self._loose: set = set()   # ids of poses whose own hand keeps only half the margin
        # the orientation the hand should arrive with (core.orient.OrientGoal), or None;
        # its cost per state at each pose, kept per pose
        self.goal = goal
        self._orient: dict = {}
        # (id(pose at k - 1), id(pose at k)) -> that transition's bounded edge costs
        # (:meth:`_dp`, before the ease): the same in every round of the pass
        self._edges: dict = {}

    def _gen(self, k):
        if self.escape is not None and self.arcs[min(k, len(self.arcs) - 1)] < self.escape[1]:
            return self.escape[0]
        g = self.generators
        return g[min(k, len(g) - 1)] if isinstance(g, list) else g

    def run(self, poses: list) -> HandReport:
        s = self.settings
        poses = list(poses)
        if len(poses) < 2 or not self._gen(0).checker.check_hand:
            return self._report(poses, [p.hand for p in poses], 0, 0, [])
        extra = () if self.goal is None else \
            (wanted_hand_angles(self._gen(0).hand_axes(poses[-1].joints, poses[-1].bend),
                                self.goal, s),)
        grid = self._grid = hand_grid(s, poses[0].hand, self.bound, extra)
        budget = int(s.slowdown_budget * len(poses)) if self.may_insert else 0
        inserted = 0
        feasible = [None] + [self._feasible(k, p, grid) for k, p in enumerate(poses) if k]
        banned: dict = {}          # frame k -> {(state at k - 1, state at k)} that touch
        lifted: set = set()        # frames k whose turn from k - 1 may exceed the bound
        own_only: set = set()      # frames k reached only from the own hand, by the own hand
        accepted: set = set()      # transitions k -> k + 1 left touching (nothing helped)
        path = None

        refined: set = set()       # ids of poses inserted between two others

        def slow_down(k, count=1, hold=False) -> bool:
            """Insert ``count`` frames between k and k + 1 (fewer if the budget is short):
            poses between the two, or with ``hold`` copies of both ends (the arm waits
            while the hand turns, before and after the move); renumber what is kept."""
            nonlocal banned, lifted, accepted, inserted, own_only
            count = min(count, budget - inserted)
            if count <= 0:
                return False
            if hold:
                added = self._hold(poses, feasible, k, count)
            else:
                added = self._insert(poses, feasible, grid, k, count)
                refined.update(id(p) for p in poses[k + 1:k + 1 + added])
            if not added:
                return False
            inserted += added
            banned = {(j + added if j > k else j): v for j, v in banned.items()}
            lifted = {j + added if j > k else j for j in lifted}
            own_only = {j + added if j > k else j for j in own_only}
            accepted = {j + added if j > k else j for j in accepted}
            return True

        # (frame, its earliest frame lifted for it, the frames lifted for it) just forced
        forced = None
        own = len(grid.angles)     # the state index of the motion's own hand
        for _round in range(64 + 4 * len(poses)):
            path, fail = self._dp(poses, grid, feasible, banned, lifted, own_only)
            if path is None and forced is not None:
                j, low, lifts = forced
                at = fail[0]
                if at not in lifted and abs(at - j) <= self.OWN_REACH:
                    # no bounded way on from (or into) the own hand there: lift the bound
                    # where the way stops (clearance comes before the turn's speed; the
                    # report counts it)
                    lifted.add(at)
                    lifts.append(at)
                    continue
                if low > 1 and j - low < self.OWN_REACH:
                    low -= 1                       # ... else a frame earlier
                    if low not in lifted:
                        lifted.add(low)
                        lifts.append(low)
                    forced = (j, low, lifts)
                    continue
                own_only.discard(j)
                lifted.difference_update(lifts)
                accepted.add(j - 1)
                forced = None
                continue
            forced = None
            if path is None:
                fail, reachable, lost = fail
                if lost is not None and slow_down(lost - 1, self._own_need(poses, lost)):
                    # the motion's own hand, bounded and clear up to frame lost - 1, could
                    # not follow into frame `lost` (too fast a turn, in place or with the
                    # arm): the branch the DP was left with failed later, at `fail`, where
                    # no slowing down can mend it. Slow down where the own hand was lost:
                    # poses between, on the path, so it turns more slowly.
                    continue
                # no bounded, clear choice into frame `fail`: slow down there (as many
                # frames as the least turn needed takes at the bound), else lift the bound
                # (poses between first; where those did not help, the arm waits)
                n_grid = len(grid.angles)
                gap = grid.turn[np.ix_(reachable[:n_grid], feasible[fail][:n_grid])]
                need = math.ceil(float(gap.min()) / self.bound - 1e-9) - 1 if gap.size else 1
                hold = id(poses[fail - 1]) in refined or id(poses[fail]) in refined
                if not slow_down(fail - 1, max(1, need), hold):
                    if fail in lifted:
                        # nothing changed this round (no frame could be added and the
                        # bound into `fail` is lifted already): every further round
                        # would fail the same way, so go to the unbounded path now
                        break
                    lifted.add(fail)
                continue
            problem = self._between(poses, grid, path, accepted)
            if problem is None:
                break
            k, what = problem
            if (k + 1) in own_only:
                accepted.add(k)                    # the own hands touch there themselves
            elif what == "hand" and (k + 1) not in lifted and \
                    len(banned.get(k + 1, ())) < self.BANS_BEFORE_REFINING:
                banned.setdefault(k + 1, set()).add((path[k], path[k + 1]))
            elif slow_down(k):
                pass
            elif what == "hand" and (path[k], path[k + 1]) != (own, own):
                # nothing slows it (a chase, or the budget spent): the motion's own hands,
                # which its checks passed between these keys, at both ends (the bound
                # lifted only where the own hands turn faster than it); undone if the DP
                # then finds no way
                own_only.add(k + 1)
                within = (k + 1) in lifted or self._own_turn(poses, k + 1) <= 1.0 + 1e-9
                lifts = [] if within else [k + 1]
                lifted.update(lifts)
                forced = (k + 1, k + 1, lifts)
            else:
                accepted.add(k)
        if path is None:
            # out of rounds: the least-cost path through clear states, turns unbounded
            lifted = set(range(1, len(poses)))
            path, _fail = self._dp(poses, grid, feasible, {}, lifted, own_only)
        skip = set()
        if path is None:
            # no clear choice at some frame even unbounded: every frame keeps its own hand
            # (the last state) and is checked between keys like any other path, except
            # where a key itself touches (a start in contact or in the body being left,
            # which the motion's own checks answer for)
            path = [len(grid.angles)] * len(poses)
            touching = [self._key_touches(k, p) for k, p in enumerate(poses)]
            skip = {k for k in range(len(poses) - 1) if touching[k] or touching[k + 1]}
        # what is reported touching: every transition of the final path that touches
        accepted = set()
        while (problem := self._between(poses, grid, path, skip)) is not None:
            accepted.add(problem[0])
            skip.add(problem[0])
        hands = [self._angles(p, grid, i) for p, i in zip(poses, path)]
        return self._report(poses, hands, inserted, len(lifted), sorted(accepted))

    # --- the pieces -------------------------------------------------------------------

    def _key_touches(self, k, pose: Pose) -> bool:
        """Does frame ``k``'s own pose, its own hand included, touch the body or an
        obstacle within half the margin (what the instants between keys may use)?"""
        return not self._gen(k).key_clear(pose)

    def _feasible(self, k, pose: Pose, grid: HandGrid) -> np.ndarray:
        """Which states are clear at frame ``k`` (``pose``): the grid's, then the pose's
        own hand (the last state, :meth:`_coefficients`). The own hand counts as clear
        where it is clear with half the margin (it is the validated path's, sampled
        between two of its poses, :class:`~reach_addon.core.motion.PathSampler`), but
        costs :attr:`LOOSE_COST` there (:attr:`_loose`)."""
        gen = self._gen(k)
        coefficients = self._coefficients(pose, grid)
        clear = gen.hands_clear(pose.joints, pose.bend, pose.config.body_rotation,
                                coefficients)
        if not clear[-1]:
            clear[-1] = gen.between_keys().hands_clear(
                pose.joints, pose.bend, pose.config.body_rotation, coefficients[-1:])[0]
            if clear[-1]:
                self._loose.add(id(pose))
        if self.escape is not None and self.arcs[min(k, len(self.arcs) - 1)] < self.escape[1]:
            # on the way out of a start in contact the hand keeps the escape's own, which
            # only ever gets farther from what it touched: the states nearest it
            turn = wrist_turn(coefficients, coefficients[-1])
            clear &= turn <= max(float(turn.min()), 0.5 * self.settings.hand_grid_step) + 1e-9
        return clear

    #: Frames about one held to the motion's own hand over which the bound may be lifted
    #: so that the hand gets to and from the own hand there (else the touching transition
    #: stands and is reported).
    OWN_REACH = 8

    #: Cost of a frame whose own hand (the validated path's) is chosen where only half
    #: the margin is kept: more than any bounded sequence of turns costs, so the full
    #: margin wins wherever some bounded, clear choice keeps it.
    LOOSE_COST = 1e6

    def _coefficients(self, pose: Pose, grid: HandGrid) -> np.ndarray:
        """The states' coefficients at ``pose`` (S + 1, 3): the grid's, then the pose's
        own hand, the one the validated path carries (by construction clear and continuous
        along it, turning in place where it must), so that slowing down along the path
        always has a bounded, clear way to offer the DP.

        Every pose seen here is kept alive for the whole pass: the pass's caches are keyed
        by ``id(pose)``, and a pose dropped (one of an insertion that failed) would free its
        id for a new pose, which would then read the dropped pose's entries."""
        c = self._coefs.get(id(pose))
        if c is None:
            c = np.vstack([grid.coefficients, [hand_coefficients(*pose.hand)]])
            self._coefs[id(pose)] = c
            self._alive.append(pose)
        return c

    def _angles(self, pose: Pose, grid: HandGrid, state: int) -> tuple:
        """The wrist's two angles of ``state`` at ``pose``."""
        if state >= len(grid.angles):
            return (float(pose.hand[0]), float(pose.hand[1]))
        return tuple(grid.angles[state])

    def _own_turn(self, poses, k: int) -> float:
        """The own hand's turn from frame k - 1 to frame ``k`` in units of its bound: the
        larger of its turn relative to the forearm and its turn in space, each over its
        bound (≤ 1: within both)."""
        a, b = poses[k - 1], poses[k]
        rel = float(wrist_turn(np.array(hand_coefficients(*a.hand)),
                               np.array(hand_coefficients(*b.hand))))
        return max(rel / self.bound, frame_turn(a, b) / self.space_bound)

    def _own_need(self, poses, k: int) -> int:
        """Frames to insert before frame ``k`` so that the own hand turns within the
        bounds (relative to the forearm and in space) from frame k - 1."""
        return max(1, math.ceil(self._own_turn(poses, k) - 1e-9) - 1)

    #: Least weight of the ease at the very start of a move (a turn there costs at most
    #: 1 / EASE_FLOOR² times more than at full speed).
    EASE_FLOOR = 0.05

    def _ease(self, k: int, n: int) -> float:
        """How freely the hand may turn into frame ``k`` of ``n``, in the first half of a
        move: the minimum-jerk speed there relative to its peak, 16 τ² (1 - τ)² at the
        transition's middle, τ = (k - ½) / (n - 1), at least :attr:`EASE_FLOOR`; 1 in the
        second half (the hand may relax as the reach ends) and in a chase (whose frames
        are the target's)."""
        if not self.may_insert or n < 3:
            return 1.0
        tau = (k - 0.5) / (n - 1)
        if tau >= 0.5:
            return 1.0
        return max(self.EASE_FLOOR, min(1.0, 16.0 * tau * tau * (1.0 - tau) ** 2))

    def _orientations(self, pose: Pose, grid: HandGrid) -> np.ndarray:
        """Every state's hand orientation at ``pose``, flattened (S, 9): the frame of
        :func:`~reach_addon.core.arm.hand_orientation` (columns: its direction d, the
        elbow's hinge made perpendicular to it g, and d × g) per state, canonical frame
        (rigid to world, so its rotations are the rotations in space); kept per pose.
        Flat and contiguous, tr(A Bᵀ) for every pair of states is one matrix product."""
        o = self._dirs.get(id(pose))
        if o is None:
            axes = self._gen(0).hand_axes(pose.joints, pose.bend)     # rows f, p, h
            d = self._coefficients(pose, grid) @ axes
            o = np.ascontiguousarray(hand_orientation(d, axes[2][None, :]).reshape(len(d), 9))
            self._dirs[id(pose)] = o
        return o

    def _orient_cost(self, pose: Pose, grid: HandGrid) -> np.ndarray:
        """Every state's orientation cost at ``pose`` (S + 1,): ``orientation_weight`` ·
        (error / 45°)², the error being the palm frame's angle from the wanted one after
        the best roll within the forearm's range (:func:`~reach_addon.core.orient.best_roll_error`);
        kept per pose."""
        c = self._orient.get(id(pose))
        if c is None:
            frames = self._orientations(pose, grid).reshape(-1, 3, 3)
            _psi, error = best_roll_error(frames, self.goal)
            c = self.goal.weight * (error / 45.0) ** 2
            self._orient[id(pose)] = c
        return c

    def _dp(self, poses, grid: HandGrid, feasible, banned, lifted, own_only=()):
        """(least-cost state path (a state index per frame), None), or (None, (k,
        reachable, lost)) with the first frame ``k`` no bounded, clear state can reach,
        the mask of the states reachable at frame k - 1, and the frame (≤ k) where the own
        hand (the last state) last stopped being reachable though clear there, or None.

        States: the grid's, then each frame's own hand (:meth:`_coefficients`)."""
        s = self.settings
        n_grid = len(grid.angles)
        own = n_grid
        ratio = grid.turn / self.bound
        # edges between the states at k - 1 and at k: the grid's among themselves here,
        # the own hands' (which change from frame to frame) filled in per frame
        edge = np.empty((n_grid + 1, n_grid + 1))
        edge[:n_grid, :n_grid] = np.where(grid.turn <= self.bound + 1e-9, ratio * ratio, np.inf)
        free = np.empty((n_grid + 1, n_grid + 1))
        free[:n_grid, :n_grid] = ratio * ratio
        node = np.append(s.wrist_relax_weight * (grid.bend / 45.0) ** 2, 0.0)
        cost = np.full(n_grid + 1, np.inf)
        cost[grid.start] = 0.0
        if np.allclose(poses[0].hand, grid.angles[grid.start]):
            cost[own] = 0.0
        back = np.zeros((len(poses), n_grid + 1), dtype=np.int64)
        cols = np.arange(n_grid + 1)
        space_cos = math.cos(math.radians(self.space_bound)) - 1e-12
        weights = frame_weights(len(poses)) if self.goal is not None else None
        lost = None
        prev_c = self._coefficients(poses[0], grid)
        for k in range(1, len(poses)):
            c = self._coefficients(poses[k], grid)
            if k in lifted:
                turn_in = wrist_turn(grid.coefficients, c[own]) / self.bound   # grid -> own
                turn_out = wrist_turn(prev_c[own], c) / self.bound             # own -> all
                free[:n_grid, own] = turn_in * turn_in
                free[own] = turn_out * turn_out
                m = cost[:, None] + free
            else:
                key = (id(poses[k - 1]), id(poses[k]))
                bounded = self._edges.get(key)
                if bounded is None:
                    turn_in = wrist_turn(grid.coefficients, c[own]) / self.bound
                    turn_out = wrist_turn(prev_c[own], c) / self.bound
                    edge[:n_grid, own] = np.where(turn_in <= 1.0 + 1e-9, turn_in * turn_in,
                                                  np.inf)
                    edge[own] = np.where(turn_out <= 1.0 + 1e-9, turn_out * turn_out, np.inf)
                    # the hand's whole orientation in space may turn no faster either (so
                    # no bone of the hand, finger or thumb, turns faster): the forearm's
                    # own turn and roll count there, and the hand turns against them
                    # where it can
                    a = self._orientations(poses[k - 1], grid)
                    b = self._orientations(poses[k], grid)
                    trace = a @ b.T                 # tr(A_i B_jᵀ) for every pair i, j
                    bounded = np.where(trace >= 1.0 + 2.0 * space_cos, edge, np.inf)
                    self._edges[key] = bounded
                # and it eases in with the motion: at the start of a move a turn costs as
                # much more as the minimum-jerk speed there is below its peak, so the hand
                # does not set off faster than the arm (the motion joins what came before
                # without a jump in speed) unless clearance leaves it no other way
                ease = self._ease(k, len(poses))
                m = cost[:, None] + (bounded if ease == 1.0 else bounded / (ease * ease))
            for i, j in banned.get(k, ()):
                if i >= 0:
                    m[i, j] = np.inf
            if k in own_only:
                keep = m[own, own]
                m[:] = np.inf
                m[own, own] = keep
            arg = np.argmin(m, axis=0)
            bend_own = math.degrees(math.acos(max(-1.0, min(1.0, float(c[own, 0])))))
            node[own] = s.wrist_relax_weight * (bend_own / 45.0) ** 2 + \
                (self.LOOSE_COST if id(poses[k]) in self._loose else 0.0)
            best = m[arg, cols] + node
            if self.goal is not None and weights[k] > 0.0:
                best = best + weights[k] * self._orient_cost(poses[k], grid)
            best[~feasible[k]] = np.inf
            if np.isfinite(cost[own]) and not np.isfinite(best[own]) and feasible[k][own]:
                lost = k
            elif np.isfinite(best[own]) or not feasible[k][own]:
                lost = None
            if not np.isfinite(best).any():
                return None, (k, np.isfinite(cost), lost)
            back[k] = arg
            cost = best
            prev_c = c
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
        for k in range(len(poses) - 1):
            if k in skip:
                continue
            a, b = poses[k], poses[k + 1]
            key = (id(a), id(b))
            hand_key = key + (path[k], path[k + 1])
            if hand_key in self._clear:
                continue
            problem = self._gen(k + 1).transition_problem(
                a, b, self._angles(a, grid, path[k]), self._angles(b, grid, path[k + 1]), n,
                arm=key not in self._clear)
            if problem == "arm":
                return k, "arm"
            self._clear.add(key)
            if problem == "hand":
                return k, "hand"
            self._clear.add(hand_key)
        return None

    def _hold(self, poses, feasible, k, count: int) -> int:
        """Insert ``count`` copies of pose k after it and as many of pose k + 1 before it
        (2 × ``count`` frames at most, within the budget the caller passes as ``count``):
        the hand may turn while the arm waits at either end of the move."""
        if k < 0 or k + 1 >= len(poses):
            return 0
        before = (count + 1) // 2
        after = count - before
        poses[k + 1:k + 1] = [poses[k]] * before + [poses[k + 1]] * after
        if self.arcs is not None:
            self.arcs[k + 1:k + 1] = [self.arcs[k]] * before + [self.arcs[k + 1]] * after
        feasible[k + 1:k + 1] = [feasible[k] if k else
                                 self._feasible(k, poses[k], self._grid)] * before + \
            [feasible[k + 1]] * after
        return count

    def _insert(self, poses, feasible, grid, k, count: int = 1) -> int:
        """Insert ``count`` poses evenly between frames k and k + 1: on the validated path
        at the arc lengths between theirs when the frames came from one
        (:class:`~reach_addon.core.motion.PathSampler`); otherwise (a chase) the arm's
        angles interpolated where that pose is clear, else a pose solved at the
        interpolated wrist position. Returns how many were inserted (0 if some could not
        be)."""
        if k < 0 or k + 1 >= len(poses):
            return 0
        a, b = poses[k], poses[k + 1]
        gen = self._gen(k + 1)
        new, clears, arcs = [], [], []
        prev = a
        for j in range(1, count + 1):
            t = j / (count + 1)
            if self.arcs is not None:
                arcs.append((1.0 - t) * self.arcs[k] + t * self.arcs[k + 1])
            if self.sampler is not None:
                mid = self.sampler(arcs[-1])
                clear = self._feasible(k + 1, mid, grid)
            else:
                config = _interpolate(a, b, t)
                mid = gen.config_pose(type(a.config).from_array(config))
                clear = self._feasible(k + 1, mid, grid) \
                    if gen.arm_clear(mid.joints, config[0]) else None
                if clear is None or not clear.any():
                    wrist = (1.0 - t) * a.wrist + t * b.wrist
                    mid = gen.solve(wrist, prev, body_rotation=float(config[0]),
                                    hand_scale=1.0) \
                        or gen.solve(wrist, prev, hand_scale=1.0) \
                        or gen.solve(wrist, b, hand_scale=1.0)
                    if mid is None:
                        return 0
                    clear = self._feasible(k + 1, mid, grid)
            new.append(mid)
            clears.append(clear)
            prev = mid
        poses[k + 1:k + 1] = new
        feasible[k + 1:k + 1] = clears
        if self.arcs is not None:
            self.arcs[k + 1:k + 1] = arcs
        return count

    def _report(self, poses, hands, inserted, lifted, unclear):
        arm = self.arm
        out = []
        for pose, hand in zip(poses, hands):
            hand = (float(hand[0]), float(hand[1]))
            axes = self._gen(0).hand_axes(pose.joints, pose.bend)
            d = np.array(hand_coefficients(*hand)) @ axes
            joints = pose.joints.copy()
            joints[4] = joints[3] + arm.hand_length * d
            out.append(Pose(pose.config, joints, pose.bend, pose.f_r, hand))
        coef = np.array([hand_coefficients(*h) for h in hands])
        bends = np.degrees(np.arccos(np.clip(coef[:, 0], -1.0, 1.0)))
        rel = wrist_turn(coef[1:], coef[:-1]) if len(coef) > 1 else np.zeros(1)
        # in space: the hand's whole turn, its roll included (what any bone of it shows)
        world = np.array([frame_turn(a, b) for a, b in zip(out[:-1], out[1:])] or [0.0])
        return HandReport(out, inserted, float(rel.max(initial=0.0)),
                          float(world.max(initial=0.0)), float(bends.mean()),
                          float(bends.max()), lifted, list(unclear))


def plan_hand(generators, poses, fps: float, may_insert: bool = True, arcs=None,
              sampler=None, escape=None, goal=None) -> HandReport:
    """Run the hand pass over ``poses`` (see the module docstring); ``arcs`` and
    ``sampler`` (from :func:`~reach_addon.core.motion.time_path`) let it slow down along
    the validated path. ``goal`` (:class:`~reach_addon.core.orient.OrientGoal`): the
    orientation the hand should arrive with, sought on the last frames (a cost, never a
    constraint; :mod:`.orient`)."""
    return HandPass(generators, fps, may_insert, arcs, sampler, escape, goal).run(poses)
