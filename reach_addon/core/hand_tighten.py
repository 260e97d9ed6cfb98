"""The hand pass's last step: each chosen hand turned nearer the rig's rest alignment where
both turn bounds and the clearance allow (:class:`HandTighten`, a part of
:class:`~reach_addon.core.hand.HandPass`).

The DP (:mod:`~reach_addon.core.hand_dp`) chooses hands on a grid a step apart; between
the grid's states a hand may relax further. :meth:`HandTighten._tighten` turns each frame's
hand toward rest along the line of the wrist's two angles as far as its neighbours' turn
bounds let it, then (:meth:`HandTighten._descend`) off that line where a bound or an
obstacle stops it. A hand is only ever made less bent, so every bound and clearance the DP
kept still holds.
"""

from __future__ import annotations

import numpy as np

from .arm import Pose, frame_turn, hand_coefficients
from .hand_grid import wrist_turn
from .orient import frame_weights as _goal_weights


class HandTighten:
    """The tightening methods of :class:`~reach_addon.core.hand.HandPass`, which gives them
    ``arm``, ``settings``, ``escape``, ``arcs``, ``goal``, ``bound``, ``space_bound``,
    ``_gen`` and ``_ease``."""

    #: The shares of the most :meth:`_tighten` may turn a hand back (the bounds' limit)
    #: that it tries, most first, where the clearance refuses the whole of it.
    TIGHTEN_SHARES = (1.0, 0.875, 0.75, 0.5, 0.25)

    def _tighten(self, poses, hands) -> list:
        """The DP's hands, each turned nearer the rig's rest alignment where that is
        allowed: frame by frame, forward then back, a frame bent by a grid step or more
        turns back toward the rig's rest alignment (the wrist's two angles blended) as far
        as the turns to both neighbours' hands keep both bounds (against the forearm and in
        space, roll included), each scaled by the transition's ease (:meth:`_turns_fit`,
        :meth:`_most_share`), or the first of :data:`TIGHTEN_SHARES`
        of that whose key is clear with the whole margin and whose instants to both
        neighbours are clear as the keys interpolate. The grid's states lie a step
        apart (5° at 24 fps), and where the forearm's own turn takes part of the bound in
        space, a relaxing hand on the grid moves a step a frame, or none (goblin's shelf
        held 70.4° a frame longer, and robot's relaxed 4.4° a frame, where a hand between
        the states could go faster).
        Frames of a start's escape and the last frames of an orientation goal keep the
        DP's hands. Only ever less bent: every bound and clearance the DP kept still holds."""
        rest = np.array(self.arm.hand_rest, dtype=float)
        rest_c = np.array(self.arm.rest_coefficients)
        step = self.settings.hand_grid_step
        hands = [np.array(h, dtype=float) for h in hands]
        built = [self._with_hand(p, h) for p, h in zip(poses, hands)]
        n = len(poses)
        last = n if self.goal is None else n - int(np.count_nonzero(
            np.asarray(_goal_weights(n)) > 0.0))
        for order in (range(1, last), range(last - 1, 0, -1)):
            for k in order:
                if self.escape is not None and \
                        self.arcs[min(k, len(self.arcs) - 1)] < self.escape[1]:
                    continue
                bend = float(wrist_turn(np.array(hand_coefficients(*hands[k])), rest_c))
                if bend < step:
                    continue
                most = self._most_share(k, poses[k], hands[k], rest, built)
                for share in (most * f for f in self.TIGHTEN_SHARES):
                    if share * bend < 0.5:
                        break
                    hand = hands[k] + share * (rest - hands[k])
                    pose = self._with_hand(poses[k], hand)
                    if self._fits(k, pose, built):
                        hands[k], built[k] = hand, pose
                        break
                self._descend(k, poses[k], hands, built, rest_c)
        return [tuple(h.tolist()) for h in hands]

    #: Steps (degrees of the wrist's two angles) of :meth:`_descend`'s compass search,
    #: largest first, and how many moves it makes at each at most.
    DESCENT_STEPS = (4.0, 2.0, 1.0, 0.5)
    DESCENT_MOVES = 6
    #: Eight directions in the plane of the wrist's two angles.
    DESCENT_DIRECTIONS = np.array([(np.cos(t), np.sin(t))
                                   for t in np.arange(8) * (np.pi / 4.0)])
    #: Degrees of bend from rest beyond which :meth:`_descend` searches (RULA scores a
    #: wrist beyond 15° from neutral as a risk).
    DESCENT_FROM = 15.0

    def _descend(self, k: int, pose: Pose, hands: list, built: list, rest_c) -> None:
        """Where frame ``k``'s hand, turned toward rest as far as :meth:`_tighten` could,
        is still bent beyond :data:`DESCENT_FROM`, bend it less by a compass search of the
        wrist's two angles: each move takes, of eight directions a step away, the least
        bent hand that :meth:`_fits` (both bounds to both neighbours, the key and its
        instants clear) within the wrist's ranges, at each of :data:`DESCENT_STEPS` in
        turn. The way toward rest is one line; where a neighbour's turn bound or an
        obstacle stops it, the least bent hand both allow lies off it (GoMakeHuman's
        shelf, frame 25: 44.4° on the line, 41.4° off it, where the bones read 1.8° more
        than the model)."""
        s = self.settings
        hand = hands[k]
        bend = self._bend_of(hand, rest_c)
        if bend <= self.DESCENT_FROM:
            return
        limits = np.array([s.wrist_bend_max, s.wrist_side_max])
        for step in self.DESCENT_STEPS:
            for _move in range(self.DESCENT_MOVES):
                options = sorted((self._bend_of(h, rest_c), i, h) for i, h in enumerate(
                    hand + step * self.DESCENT_DIRECTIONS) if np.all(np.abs(h) <= limits))
                found = next(((b, h, m) for b, _i, h in options if b < bend - 1e-6
                              for m in [self._with_hand(pose, h)] if self._fits(k, m, built)),
                             None)
                if found is None:
                    break
                bend, hand, built[k] = found
        hands[k] = hand

    @staticmethod
    def _bend_of(hand, rest_c) -> float:
        """Degrees ``hand`` (the wrist's two angles) is bent from the rig's rest
        alignment (coefficients ``rest_c``)."""
        return float(wrist_turn(np.array(hand_coefficients(*hand)), rest_c))

    def _most_share(self, k: int, pose: Pose, hand, rest, built, halvings: int = 12) -> float:
        """The largest share of the way from ``hand`` to ``rest`` (0 to 1, found by
        bisection) at which frame ``k``'s hand keeps both turn bounds to both neighbours in
        ``built`` (:meth:`_tighten`; the clearance is asked after)."""
        def within(share):
            return self._turns_fit(k, self._with_hand(pose, hand + share * (rest - hand)),
                                   built)

        if within(1.0):
            return 1.0
        lo, hi = 0.0, 1.0
        for _ in range(halvings):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if within(mid) else (lo, mid)
        return lo

    def _with_hand(self, pose: Pose, hand) -> Pose:
        """``pose`` with the wrist's two angles ``hand`` (its hand's end moved to match)."""
        hand = (float(hand[0]), float(hand[1]))
        axes = self._gen(0).hand_axes(pose.joints, pose.bend)
        joints = pose.joints.copy()
        joints[4] = joints[3] + self.arm.hand_length * (np.array(hand_coefficients(*hand)) @ axes)
        return Pose(pose.config, joints, pose.bend, pose.f_r, hand)

    def _turns_fit(self, k: int, pose: Pose, built: list) -> bool:
        """Do frame ``k``'s ``pose`` and its neighbours in ``built`` turn the hand within
        both bounds (against the forearm and in space), each taken at the ease of the
        transition (:meth:`_ease`: at the start of a move the DP eases the hand in with
        the motion, and this pass must not undo that: a bake joined to the user's
        animation would start with a jump)?"""
        c = np.array(hand_coefficients(*pose.hand))
        n = len(built)
        for j in (k - 1, k + 1):
            if 0 <= j < n:
                other = built[j]
                ease = self._ease(max(j, k), n)
                rel = float(wrist_turn(c, np.array(hand_coefficients(*other.hand))))
                if rel > ease * self.bound + 1e-9 or \
                        frame_turn(other, pose) > ease * self.space_bound + 1e-9:
                    return False
        return True

    def _fits(self, k: int, pose: Pose, built: list) -> bool:
        """May frame ``k`` take ``pose`` (its hand changed) between its neighbours in
        ``built``: both turn bounds to each, its key clear with the whole margin, and the
        instants to each clear? (:meth:`_tighten`)"""
        gen = self._gen(k)
        c = np.array(hand_coefficients(*pose.hand))
        if not self._turns_fit(k, pose, built):
            return False
        if not gen.hands_clear(pose.joints, pose.bend, pose.config.body_rotation, c[None])[0]:
            return False
        n = self.settings.instants_per_frame
        if k > 0 and self._gen(k).transition_problem(built[k - 1], pose, instants=n,
                                                     arm=False) is not None:
            return False
        return not (k + 1 < len(built) and self._gen(k + 1).transition_problem(
            pose, built[k + 1], instants=n, arm=False) is not None)
