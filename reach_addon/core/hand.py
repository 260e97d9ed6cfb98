"""The hand: the wrist's two angles at every frame of a motion, continuous, relaxed and clear
at every instant (:func:`plan_hand`, :class:`HandPass`).

After the timing (:func:`~reach_addon.core.motion.time_path`) the wrist's bend and side
bend (degrees, :func:`~reach_addon.core.arm.hand_direction`) are chosen again by dynamic
programming over frames × a grid of wrist angles (:mod:`~reach_addon.core.hand_dp`): every
state clear of the obstacles and the body at its frame, every transition within
``Settings.hand_turn_speed`` / fps relative to the forearm and ``hand_space_turn_speed`` /
fps in space. Each transition of the chosen path is then checked at
``Settings.instants_per_frame`` − 1 instants between its keys, as Blender interpolates them
(:func:`~reach_addon.core.keys.between`), against half the clearance. Where no bounded,
clear choice exists or a transition touches, the pass falls back step by step
(:class:`HandPass`): ban the hand pair, slow down (at most ``Settings.slowdown_budget`` ×
frames inserted), hold, keep the motion's own hands, lift the bound, accept. The
:class:`HandReport` says what it could not mend.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .arm import Pose, frame_turn, hand_coefficients
from .hand_dp import HandDP
from .hand_grid import HandGrid, hand_grid, wrist_turn
from .hand_tighten import HandTighten
from .orient import wanted_hand_angles


@dataclass
class HandReport:
    """What the hand pass did to one motion."""

    poses: list
    inserted_frames: int = 0
    max_wrist_turn_deg: float = 0.0      # largest turn relative to the forearm in one frame
    max_hand_turn_deg: float = 0.0       # largest turn of the hand in space, roll included
    mean_wrist_bend_deg: float = 0.0     # mean bend from the neutral wrist (arm.hand_rest)
    max_wrist_bend_deg: float = 0.0
    unbounded_turns: int = 0             # transitions where the bound had to be lifted
    unclear_transitions: list = field(default_factory=list)  # k: k → k + 1 still touching


def _interpolate(a: Pose, b: Pose, t: float):
    """The arm's five angles interpolated linearly between two poses at fraction ``t``."""
    return (1.0 - t) * a.config.as_array() + t * b.config.as_array()


class HandPass(HandDP, HandTighten):
    """Choose the hand at every frame of a motion (see the module docstring).

    ``generators``: one :class:`ConfigurationGenerator` for every frame, or one for all
    (a chase against moving obstacles has one per frame). ``fps``: frames per second.
    ``may_insert``: may frames be added (not in a chase, whose frames are the target's).
    ``arcs``: where the frames lie along the motion (arc lengths of the validated path, or
    a chase's frame numbers); ``sampler``: poses anywhere along the validated path
    (:class:`~reach_addon.core.motion.PathSampler`); ``escape``: (generator, arc length),
    the frames before that arc being the way out of a start in contact, checked with that
    thinner arm's generator (:mod:`~reach_addon.core.contact`); ``goal``: the orientation
    the hand should arrive with (:class:`~reach_addon.core.orient.OrientGoal`) or None.

    :meth:`run` is :meth:`begin`, then rounds of the DP (:meth:`_dp`), each mended by one
    of the fallback steps, :meth:`ban`, :meth:`slow_down`, :meth:`hold`, :meth:`keep_own`
    (undone by :meth:`release_own`), :meth:`lift` and :meth:`accept`, which change the
    pass's state: the frames (:attr:`poses`, :attr:`feasible`) and the sets of frame
    numbers :attr:`banned`, :attr:`lifted`, :attr:`own_only`, :attr:`accepted`, renumbered
    when frames are inserted."""

    #: Hand choices banned on one transition (they touch between its keys) before the
    #: transition is refined instead (a pose inserted between its two keys).
    BANS_BEFORE_REFINING = 4

    #: Frames about one held to the motion's own hand over which the bound may be lifted
    #: so that the hand gets to and from the own hand there (else the touching transition
    #: stands and is reported).
    OWN_REACH = 8

    def __init__(self, generators, fps: float, may_insert: bool = True, arcs=None,
                 sampler=None, escape=None, goal=None):
        super().__init__(generators, fps, may_insert, arcs, escape, goal)
        self.sampler = sampler
        self._clear: set = set()   # transitions (and their hands) found clear between keys
        # the pass's state (:meth:`begin`)
        self.poses: list = []
        self.feasible: list = []   # per frame, which states are clear (None at frame 0)
        self.grid: HandGrid | None = None
        self.budget = 0            # frames that may be inserted
        self.inserted = 0
        self.banned: dict = {}     # frame k -> {(state at k - 1, state at k)} that touch
        self.lifted: set = set()   # frames k whose turn from k - 1 may exceed the bound
        self.own_only: set = set()  # frames k reached only from the own hand, by the own hand
        self.accepted: set = set()  # transitions k -> k + 1 left touching (nothing helped)
        self.refined: set = set()  # ids of poses inserted between two others
        #: the last :meth:`keep_own`: (its frame, the earliest frame lifted for it, the
        #: frames lifted for it), or None. Settled in the next round, before any frame is
        #: inserted, so it is never renumbered.
        self.forced = None

    def run(self, poses: list) -> HandReport:
        """The hand at every frame of ``poses`` (frames may be inserted): a
        :class:`HandReport`."""
        poses = list(poses)
        if len(poses) < 2 or not self._gen(0).checker.check_hand:
            return self._report(poses, [p.hand for p in poses], 0, 0, [])
        self.begin(poses)
        path = None
        for _round in range(64 + 4 * len(poses)):
            path, fail = self._dp(self.poses, self.grid, self.feasible, self.banned,
                                  self.lifted, self.own_only)
            if path is None and self.forced is not None:
                self._retreat_from_own(fail[0])
                continue
            self.forced = None
            if path is None:
                if not self._mend_no_way(*fail):
                    break
                continue
            problem = self._between(self.poses, self.grid, path, self.accepted)
            if problem is None:
                break
            self._mend_touch(path, *problem)
        return self._finish(path)

    def begin(self, poses: list) -> None:
        """Start a pass over ``poses`` (at least two): the grid of states (the wanted hand
        among them with a goal), the frame budget and each frame's clear states; no frame
        banned, lifted, held or accepted yet."""
        s = self.settings
        self.poses = list(poses)
        extra = () if self.goal is None else \
            (wanted_hand_angles(self._gen(0).hand_axes(poses[-1].joints, poses[-1].bend),
                                self.goal, s),)
        self.grid = hand_grid(s, poses[0].hand, self.bound, extra,
                              self._gen(0).arm.rest_coefficients)
        self.budget = int(s.slowdown_budget * len(poses)) if self.may_insert else 0
        self.inserted = 0
        self.feasible = [None] + [self._feasible(k, p, self.grid)
                                  for k, p in enumerate(self.poses) if k]
        self.banned, self.lifted, self.own_only, self.accepted = {}, set(), set(), set()
        self.refined = set()
        self.forced = None

    # --- the fallback steps -----------------------------------------------------------

    def ban(self, k: int, pair: tuple) -> None:
        """Forbid the states ``pair`` (at frame k, at frame k + 1) on the transition
        k → k + 1: the hand touches something between its keys."""
        self.banned.setdefault(k + 1, set()).add(pair)

    def slow_down(self, k: int, count: int = 1) -> bool:
        """Insert ``count`` poses between frames k and k + 1 (fewer if the budget is short),
        on the validated path where there is one (:meth:`_insert_between`), so the arm
        passes there more slowly and the hand has more frames to turn in. False if none
        could be inserted."""
        count = min(count, self.budget - self.inserted)
        if count <= 0:
            return False
        added = self._insert_between(k, count)
        self.refined.update(id(p) for p in self.poses[k + 1:k + 1 + added])
        return self._renumber(k, added)

    def hold(self, k: int, count: int = 1) -> bool:
        """Insert ``count`` frames between frames k and k + 1 (fewer if the budget is
        short) that repeat pose k, then pose k + 1 (:meth:`_insert_holds`): the arm waits
        while the hand turns, before and after the move. False if none could be
        inserted."""
        count = min(count, self.budget - self.inserted)
        if count <= 0:
            return False
        return self._renumber(k, self._insert_holds(k, count))

    def keep_own(self, k: int) -> None:
        """Keep the motion's own hands (the last state) at both keys of transition
        k → k + 1, which the motion's own checks passed between them: frame k + 1 is
        reached only from the own hand, by the own hand (:attr:`own_only`), the bound into
        it lifted only where the own hands turn faster than it. :attr:`forced` records it;
        :meth:`release_own` undoes it."""
        self.own_only.add(k + 1)
        within = (k + 1) in self.lifted or self._own_turn(self.poses, k + 1) <= 1.0 + 1e-9
        lifts = [] if within else [k + 1]
        self.lifted.update(lifts)
        self.forced = (k + 1, k + 1, lifts)

    def release_own(self) -> None:
        """Undo the last :meth:`keep_own` (the DP found no way with it): its frame is free
        again, the bounds lifted for it are restored, and its transition is accepted as
        touching."""
        j, _low, lifts = self.forced
        self.own_only.discard(j)
        self.lifted.difference_update(lifts)
        self.accept(j - 1)
        self.forced = None

    def lift(self, k: int) -> None:
        """Lift the turn bounds into frame k: clearance comes before the turn's speed
        (the report counts the lifted frames as ``unbounded_turns``)."""
        self.lifted.add(k)

    def accept(self, k: int) -> None:
        """Leave the transition k → k + 1 as it is, touching: nothing mends it (the DP's
        checks between keys skip it; the report lists what still touches)."""
        self.accepted.add(k)

    # --- which step, when -------------------------------------------------------------

    def _mend_touch(self, path: list, k: int, what: str) -> None:
        """The transition k → k + 1 of ``path`` touches something between its keys
        (``what``: 'arm' or 'hand'). Accept it where frame k + 1 keeps the own hands
        already; ban its hand pair (at most :attr:`BANS_BEFORE_REFINING` times, not where
        the bound is lifted); else slow down there; else (the hand, not already the own
        hands: a chase, or the budget spent) keep the own hands; else accept it."""
        own = len(self.grid.angles)
        if (k + 1) in self.own_only:
            self.accept(k)
        elif what == "hand" and (k + 1) not in self.lifted and \
                len(self.banned.get(k + 1, ())) < self.BANS_BEFORE_REFINING:
            self.ban(k, (path[k], path[k + 1]))
        elif self.slow_down(k):
            pass
        elif what == "hand" and (path[k], path[k + 1]) != (own, own):
            self.keep_own(k)
        else:
            self.accept(k)

    def _mend_no_way(self, fail: int, reachable, lost) -> bool:
        """No bounded, clear state at frame ``fail`` can be reached (``reachable``: the
        states reachable at fail - 1). Where the own hand was lost at frame ``lost`` (it
        turned faster than the bound there and the branches left closed later), slow down
        there: a branch shut at a pocket's edge is not reopened by slowing down at the
        edge. Else slow down into ``fail`` by as many frames as the least turn needed takes
        at the bound (holds where poses between were inserted there already), else lift
        the bound into it. False when nothing changed and nothing can (no frame could be
        added and the bound is lifted already): the rounds end."""
        if lost is not None and self.slow_down(lost - 1, self._own_need(self.poses, lost)):
            return True
        grid, poses = self.grid, self.poses
        n_grid = len(grid.angles)
        gap = grid.turn[np.ix_(reachable[:n_grid], self.feasible[fail][:n_grid])]
        need = math.ceil(float(gap.min()) / self.bound - 1e-9) - 1 if gap.size else 1
        refined = id(poses[fail - 1]) in self.refined or id(poses[fail]) in self.refined
        if (self.hold if refined else self.slow_down)(fail - 1, max(1, need)):
            return True
        if fail in self.lifted:
            return False
        self.lift(fail)
        return True

    def _retreat_from_own(self, at: int) -> None:
        """The DP found no way after :meth:`keep_own` (its first frame without one: ``at``).
        Lift the bound there if it is within :attr:`OWN_REACH` of the kept frame (no
        bounded way on from, or into, the own hand there); else lift it a frame earlier
        each round, down to :attr:`OWN_REACH` before the kept frame; else release the own
        hands (:meth:`release_own`)."""
        j, low, lifts = self.forced
        if at not in self.lifted and abs(at - j) <= self.OWN_REACH:
            self.lift(at)
            lifts.append(at)
        elif low > 1 and j - low < self.OWN_REACH:
            low -= 1
            if low not in self.lifted:
                self.lift(low)
                lifts.append(low)
            self.forced = (j, low, lifts)
        else:
            self.release_own()

    def _renumber(self, k: int, added: int) -> bool:
        """Count ``added`` frames inserted after frame k, and renumber the frames after
        them in :attr:`banned`, :attr:`lifted`, :attr:`own_only` and :attr:`accepted`.
        False if none were added."""
        if not added:
            return False
        self.inserted += added
        self.banned = {(j + added if j > k else j): v for j, v in self.banned.items()}
        self.lifted = {j + added if j > k else j for j in self.lifted}
        self.own_only = {j + added if j > k else j for j in self.own_only}
        self.accepted = {j + added if j > k else j for j in self.accepted}
        return True

    def _finish(self, path) -> HandReport:
        """The report of the pass ending with the DP's ``path`` (None: no bounded, clear
        one). Without one: the least-cost path through clear states with every turn
        unbounded; without even that, every frame keeps its own hand (the last state),
        checked between keys like any other path except where a key itself touches (a
        start in contact or in the body being left, which the motion's own checks answer
        for). Every transition of the final path that touches is reported."""
        poses, grid = self.poses, self.grid
        if path is None:
            self.lifted = set(range(1, len(poses)))
            path, _fail = self._dp(poses, grid, self.feasible, {}, self.lifted, self.own_only)
        skip = set()
        if path is None:
            path = [len(grid.angles)] * len(poses)
            touching = [self._key_touches(k, p) for k, p in enumerate(poses)]
            skip = {k for k in range(len(poses) - 1) if touching[k] or touching[k + 1]}
        unclear = set()
        while (problem := self._between(poses, grid, path, skip)) is not None:
            unclear.add(problem[0])
            skip.add(problem[0])
        hands = [self._angles(p, grid, i) for p, i in zip(poses, path)]
        if not self.lifted and not unclear:
            hands = self._tighten(poses, hands)
        return self._report(poses, hands, self.inserted, len(self.lifted), sorted(unclear))

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

    def _insert_holds(self, k: int, count: int) -> int:
        """Insert ``count`` copies of pose k after it and as many of pose k + 1 before it
        (2 × ``count`` frames at most, within the budget the caller passes as ``count``):
        the hand may turn while the arm waits at either end of the move."""
        poses, feasible = self.poses, self.feasible
        if k < 0 or k + 1 >= len(poses):
            return 0
        before = (count + 1) // 2
        after = count - before
        poses[k + 1:k + 1] = [poses[k]] * before + [poses[k + 1]] * after
        if self.arcs is not None:
            self.arcs[k + 1:k + 1] = [self.arcs[k]] * before + [self.arcs[k + 1]] * after
        feasible[k + 1:k + 1] = [feasible[k] if k else
                                 self._feasible(k, poses[k], self.grid)] * before + \
            [feasible[k + 1]] * after
        return count

    def _insert_between(self, k: int, count: int = 1) -> int:
        """Insert ``count`` poses evenly between frames k and k + 1: on the validated path
        at the arc lengths between theirs when the frames came from one
        (:class:`~reach_addon.core.motion.PathSampler`); otherwise (a chase) the arm's
        angles interpolated where that pose is clear, else a pose solved at the
        interpolated wrist position. Returns how many were inserted (0 if some could not
        be)."""
        poses, feasible, grid = self.poses, self.feasible, self.grid
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
            out.append(self._with_hand(pose, hand))
        coef = np.array([hand_coefficients(*h) for h in hands])
        bends = wrist_turn(coef, arm.rest_coefficients)     # the bend from the neutral wrist
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
