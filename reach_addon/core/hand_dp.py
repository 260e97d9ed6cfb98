"""The dynamic programme of the hand pass (:mod:`~reach_addon.core.hand`): the least-cost
choice of the wrist's two angles over frames × states under the turn bounds.

States (:mod:`~reach_addon.core.hand_grid`): the grid of wrist angles, then each frame's own
hand (the validated path's). A transition may turn the hand, relative to the forearm, by at
most ``Settings.hand_turn_speed`` / fps degrees, and its whole orientation in space
(:func:`~reach_addon.core.arm.frame_turn`) by at most ``hand_space_turn_speed`` / fps. Cost
of a path: Σ (turn / bound)² / ease² + ``wrist_relax_weight`` · (bend from neutral / 45°)²
(neutral: the rig's rest alignment, ``ArmModel.hand_rest``)
(+ ``orientation_weight`` · (palm frame's error / 45°)² on the last frames with a goal,
:mod:`~reach_addon.core.orient`). Angles in degrees.
"""

from __future__ import annotations

import math

import numpy as np

from .arm import Pose, hand_coefficients, hand_orientation
from .hand_grid import HandGrid, wrist_turn
from .orient import best_roll_error, frame_weights


class HandDP:
    """The hand pass's DP over one motion's frames and its per-pose tables (each state's
    coefficients, orientation and orientation cost at a pose, kept by the pose's id).
    ``generators``, ``fps``, ``may_insert``, ``arcs``, ``escape`` and ``goal``: as for
    :class:`~reach_addon.core.hand.HandPass`."""

    #: Cost of a frame whose own hand (the validated path's) is chosen where only half
    #: the margin is kept: more than any bounded sequence of turns costs, so the full
    #: margin wins wherever some bounded, clear choice keeps it.
    LOOSE_COST = 1e6

    #: Least weight of the ease at the very start of a move (a turn there costs at most
    #: 1 / EASE_FLOOR² times more than at full speed).
    EASE_FLOOR = 0.05

    def __init__(self, generators, fps: float, may_insert: bool = True, arcs=None,
                 escape=None, goal=None):
        self.generators = generators
        gen = generators[0] if isinstance(generators, list) else generators
        self.arm, self.settings = gen.arm, gen.settings
        self.bound = self.settings.hand_turn_speed / fps
        self.space_bound = self.settings.hand_space_turn_speed / fps
        self.may_insert = may_insert
        self.arcs = None if arcs is None else list(arcs)
        self.escape = escape if self.arcs is not None else None
        self.goal = goal
        # caches, keyed by id(pose) (every such pose kept alive in _alive, _coefficients)
        self._dirs: dict = {}      # the states' hand orientations at a pose
        self._coefs: dict = {}     # the states' coefficients at a pose
        self._alive: list = []
        self._loose: set = set()   # poses whose own hand keeps only half the margin
        self._orient: dict = {}    # the states' orientation costs at a pose
        # (id(pose at k - 1), id(pose at k)) -> that transition's bounded edge costs
        # (:meth:`_dp`, before the ease): the same in every round of the pass
        self._edges: dict = {}

    def _gen(self, k):
        if self.escape is not None and self.arcs[min(k, len(self.arcs) - 1)] < self.escape[1]:
            return self.escape[0]
        g = self.generators
        return g[min(k, len(g) - 1)] if isinstance(g, list) else g

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

        States: the grid's, then each frame's own hand (:meth:`_coefficients`). Cost of a
        path: Σ (turn / bound)² over its transitions (:meth:`_transition_costs`) +
        ``wrist_relax_weight`` · (bend / 45°)² over its states (+ :attr:`LOOSE_COST` for an
        own hand clear with half the margin only) + the orientation cost on the last frames
        with a goal. ``feasible``: the clear states per frame; ``banned``: state pairs
        forbidden into a frame; ``lifted``: frames the turn bounds do not hold into;
        ``own_only``: frames reached only from the own hand, by the own hand."""
        s = self.settings
        own = len(grid.angles)
        edge, free = self._grid_edges(grid)
        node = np.append(s.wrist_relax_weight * (grid.bend / 45.0) ** 2, 0.0)
        cost = np.full(own + 1, np.inf)
        cost[grid.start] = 0.0
        if np.allclose(poses[0].hand, grid.angles[grid.start]):
            cost[own] = 0.0
        back = np.zeros((len(poses), own + 1), dtype=np.int64)
        cols = np.arange(own + 1)
        weights = frame_weights(len(poses)) if self.goal is not None else None
        lost = None
        prev_c = self._coefficients(poses[0], grid)
        for k in range(1, len(poses)):
            c = self._coefficients(poses[k], grid)
            m = cost[:, None] + self._transition_costs(poses, grid, k, c, prev_c, edge, free,
                                                       k in lifted)
            for i, j in banned.get(k, ()):
                if i >= 0:
                    m[i, j] = np.inf
            if k in own_only:
                keep = m[own, own]
                m[:] = np.inf
                m[own, own] = keep
            arg = np.argmin(m, axis=0)
            r0, r1, r2 = self.arm.rest_coefficients     # hand_grid.wrist_turn, on floats
            bend_own = math.degrees(math.acos(max(-1.0, min(1.0, float(
                c[own, 0] * r0 + c[own, 1] * r1 + c[own, 2] * r2)))))
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

    def _grid_edges(self, grid: HandGrid):
        """(bounded, free) transition costs (S + 1, S + 1) between the grid's states,
        (turn / bound)², infinite in ``bounded`` beyond the bound; the own hand's row and
        column are filled per frame (:meth:`_transition_costs`)."""
        n_grid = len(grid.angles)
        ratio = grid.turn / self.bound
        edge = np.empty((n_grid + 1, n_grid + 1))
        edge[:n_grid, :n_grid] = np.where(grid.turn <= self.bound + 1e-9, ratio * ratio, np.inf)
        free = np.empty((n_grid + 1, n_grid + 1))
        free[:n_grid, :n_grid] = ratio * ratio
        return edge, free

    def _transition_costs(self, poses, grid: HandGrid, k: int, c, prev_c, edge, free,
                          lifted: bool):
        """The cost (S + 1, S + 1) of every transition from a state at frame k - 1 to one at
        frame k (``prev_c``, ``c``: the states' coefficients there). (turn / bound)² of the
        turn relative to the forearm; unless the bound is ``lifted``, infinite beyond it or
        where the hand's whole orientation turns faster than ``hand_space_turn_speed``
        (:meth:`_bounded_edges`), and divided by the ease² (:meth:`_ease`)."""
        own = len(grid.angles)
        if lifted:
            turn_in = wrist_turn(grid.coefficients, c[own]) / self.bound   # grid -> own
            turn_out = wrist_turn(prev_c[own], c) / self.bound             # own -> all
            free[:own, own] = turn_in * turn_in
            free[own] = turn_out * turn_out
            return free
        key = (id(poses[k - 1]), id(poses[k]))
        bounded = self._edges.get(key)
        if bounded is None:
            bounded = self._bounded_edges(poses, grid, k, c, prev_c, edge)
            self._edges[key] = bounded
        # the hand eases in with the motion: at the start of a move a turn costs as much
        # more as the minimum-jerk speed there is below its peak, so the hand does not set
        # off faster than the arm unless clearance leaves it no other way
        ease = self._ease(k, len(poses))
        return bounded if ease == 1.0 else bounded / (ease * ease)

    def _bounded_edges(self, poses, grid: HandGrid, k: int, c, prev_c, edge):
        """The bounded transition costs into frame k (:meth:`_transition_costs`): ``edge``
        with the own hand's row and column filled in, infinite where the hand's whole
        orientation in space (the forearm's own turn and roll included, so no bone of the
        hand turns faster) would turn by more than ``space_bound`` degrees."""
        own = len(grid.angles)
        turn_in = wrist_turn(grid.coefficients, c[own]) / self.bound
        turn_out = wrist_turn(prev_c[own], c) / self.bound
        edge[:own, own] = np.where(turn_in <= 1.0 + 1e-9, turn_in * turn_in, np.inf)
        edge[own] = np.where(turn_out <= 1.0 + 1e-9, turn_out * turn_out, np.inf)
        a = self._orientations(poses[k - 1], grid)
        b = self._orientations(poses[k], grid)
        trace = a @ b.T                     # tr(A_i B_jᵀ) for every pair i, j
        space_cos = math.cos(math.radians(self.space_bound)) - 1e-12
        return np.where(trace >= 1.0 + 2.0 * space_cos, edge, np.inf)
