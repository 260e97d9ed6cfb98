"""The hand's tests of the configuration generator: where the hand may point at an arm
pose, whether it turns clear, and whether it is clear between two keys.

A mixin of :class:`~reach_addon.core.generator.ConfigurationGenerator` (its ``arm``,
``checker``, ``settings``, body capsules and world transform). The hand is the checker's:
its axis capsule (wrist → far end, ``hand_radius``), or where the arm has one its shape as
skinned (:mod:`.hand_shape`), whose capsules ride the hand's frame. Against the body's own
capsules the axis capsule stands for the hand either way.
"""

from __future__ import annotations

import math

import numpy as np

from . import keys
from .arm import Pose, hand_basis, hand_coefficients
from .body_capsules import segment_hits_body
from .distances import fan_segment_distances, point_segment_distance
from .hand_shape import tip_shape_ends, tip_shape_points, with_shape


class HandChecks:
    """The hand's tests (see the module docstring)."""

    def _place_hand(self, s_c, e_c, w_c, w_w, d_w, b, caps, hands, previous=None):
        """(hand end, wrist angles) of the first hand direction in ``hands`` that is clear
        of the body and the obstacles, or (None, None). ``b``: the bend direction.

        With ``previous`` (the pose at the previous position), the hand must also get from
        its angles there to the new ones without passing through anything: its old
        direction clear at the new pose, and every direction between, ``hand_grid_step`` ×
        3 degrees apart, clear there too (the step itself, at most one search step, moves
        it with its angles fixed and clear at both ends). A hand that must turn *before*
        a step turns in place first: :meth:`turn_hand`, a move of the search."""
        arm, checker, seg = self.arm, self.checker, self._seg_hand
        l1, l2, lh = arm.upper_arm_length, arm.forearm_length, arm.hand_length
        u = [(e_c[i] - s_c[i]) / l1 for i in range(3)]
        f = [(w_c[i] - e_c[i]) / l2 for i in range(3)]
        # the hand turns toward p in the elbow's plane and toward h across it
        _f, (px, py, pz), (hx, hy, hz) = hand_basis(u, b, f)
        shaped = bool(checker.hand_shape)
        # no hand direction can reach an obstacle
        clear_far = d_w >= checker.hand_reach if shaped else d_w - lh >= seg.radius

        def tip_of(coefficients):
            cf, cp, ch = coefficients
            return [w_c[0] + lh * (f[0] * cf + px * cp + hx * ch),
                    w_c[1] + lh * (f[1] * cf + py * cp + hy * ch),
                    w_c[2] + lh * (f[2] * cf + pz * cp + hz * ch)]

        def clear(tip):
            if caps and segment_hits_body(w_c, tip, arm.hand_radius, caps):
                return False
            if not clear_far and shaped:
                return self._shape_clear([self._world(e) for e in tip_shape_ends(
                    arm, w_c, tip, (hx, hy, hz))], d_w)
            if not clear_far:
                t_w = self._world(tip)
                if not checker.segment_clear(w_w, t_w, d_w, checker.distance(t_w, checker.bound_hand),
                                             seg.radius, seg.length):
                    return False
            return True

        sweep_step = 3.0 * self.settings.hand_grid_step
        previous_hand = None if previous is None else previous.hand
        if previous_hand is not None and not clear_far and \
                not clear(tip_of(hand_coefficients(*previous_hand))):
            # every sweep starts from the previous hand: where it is not clear at this
            # pose, no hand gets anywhere (one test instead of one per sample)
            return None, None
        for hand in hands:
            tip = tip_of(self._hand_coefficients[hand])
            if hand == previous_hand and not clear_far:
                return tip, hand                 # tested just above
            if not clear(tip):
                continue
            if previous_hand is not None and hand != previous_hand and not clear_far:
                db, ds = hand[0] - previous_hand[0], hand[1] - previous_hand[1]
                n = max(1, int(math.ceil(max(abs(db), abs(ds)) / sweep_step)))
                between = [hand_coefficients(previous_hand[0] + db * t / n,
                                             previous_hand[1] + ds * t / n) for t in range(1, n)]
                if not all(clear(tip_of(c)) for c in between):
                    continue
            return tip, hand
        return None, None

    def turn_hand(self, pose: Pose, hand) -> Pose | None:
        """``pose`` with the hand turned in place to the sample ``hand`` (its arm
        unchanged), or None if a direction on the way, ``hand_grid_step`` × 3 degrees
        apart, touches the body or an obstacle. Used by the search when the hand must turn
        before the arm can move on."""
        a = pose.hand
        db, ds = hand[0] - a[0], hand[1] - a[1]
        n = max(1, int(math.ceil(max(abs(db), abs(ds)) / (3.0 * self.settings.hand_grid_step))))
        coef = [hand_coefficients(a[0] + db * t / n, a[1] + ds * t / n) for t in range(1, n + 1)]
        if not self.hands_clear(pose.joints, pose.bend, pose.config.body_rotation, coef).all():
            return None
        joints = pose.joints.copy()
        joints[4] = joints[3] + self.arm.hand_length * (np.array(coef[-1]) @
                                                        self.hand_axes(pose.joints, pose.bend))
        return Pose(pose.config, joints, pose.bend, pose.f_r, tuple(hand))

    def hand_axes(self, joints, bend):
        """The hand's frame at a pose, rows (f, p, h) (canonical): the forearm direction,
        the in-plane direction the hand bends toward and the elbow's hinge axis
        (:func:`~reach_addon.core.arm.hand_direction`). ``joints`` (≥ 4, 3), ``bend`` (3,)."""
        s, e, w = (np.asarray(joints[i], dtype=float) for i in (1, 2, 3))
        u = (e - s) / np.linalg.norm(e - s)
        f = (w - e) / np.linalg.norm(w - e)
        return np.array(hand_basis(u.tolist(), np.asarray(bend, dtype=float).tolist(), f.tolist()))

    def hands_clear(self, joints, bend, body_rotation: float, coefficients) -> np.ndarray:
        """For each hand direction (rows of ``coefficients``, components along the rows of
        :meth:`hand_axes`): is the hand, wrist to its far end, clear of the body and the
        obstacles at this arm pose? One obstacle query at the wrist settles every direction
        when nothing is within a hand's length of it."""
        coefficients = np.asarray(coefficients, dtype=float)
        if not self._check_hand:
            return np.ones(len(coefficients), dtype=bool)
        tips = np.asarray(joints[3], dtype=float) + \
            self.arm.hand_length * coefficients @ self.hand_axes(joints, bend)
        return self.tips_clear(joints, body_rotation, tips, bend)

    def tips_clear(self, joints, body_rotation: float, tips, bend=None,
                   hinge=None) -> np.ndarray:
        """For each hand end (rows of ``tips``, canonical): is the hand, from the wrist
        (``joints[3]``) to it, clear of the body and the obstacles
        (:meth:`hands_clear`)? ``bend``: the pose's bend direction, whose hinge
        (u × b) sets the hand's frame (:mod:`.hand_shape`; the palm unrolled), or
        ``hinge``: the elbow's hinge axis of each tip's pose ((3,) or (N, 3)); one of them
        is needed where the arm has a hand shape."""
        out = np.ones(len(tips), dtype=bool)
        if not self._check_hand:
            return out
        arm, checker, seg = self.arm, self.checker, self._seg_hand
        w_c = np.asarray(joints[3], dtype=float)
        reach = arm.hand_length + arm.hand_radius
        wl = w_c.tolist()
        caps = [c for c in self.capsules_at(float(body_rotation))     # (a, b, centre, half, r)
                if point_segment_distance(wl, c[0], c[1]) - c[4] < reach]
        if caps and len(tips) > 2:
            # many directions (the hand pass's grid): every hand against every capsule
            # in one array expression
            gap = fan_segment_distances(wl, tips, [c[0] for c in caps], [c[1] for c in caps])
            out &= ~(gap < arm.hand_radius + np.array([c[4] for c in caps])).any(1)
        elif caps:
            for i, tip in enumerate(tips.tolist()):
                if segment_hits_body(wl, tip, arm.hand_radius, caps):
                    out[i] = False
        w_w = self._world(wl)
        d_w = checker.distance(w_w, checker.bound_wrist)
        if checker.hand_shape:
            if d_w < checker.hand_reach:
                if hinge is None:
                    j = np.asarray(joints, dtype=float)
                    hinge = np.cross(j[2] - j[1], np.asarray(bend, dtype=float))
                hinge = np.asarray(hinge, dtype=float)
                hinge = hinge / np.linalg.norm(hinge, axis=-1, keepdims=True)
                ends = self._shape_world(tip_shape_points(arm, w_c, tips, hinge))
                for i in range(len(tips)):
                    if out[i] and not self._shape_clear(ends[i], d_w):
                        out[i] = False
            return out
        if d_w < seg.radius:
            out[:] = False
        elif d_w - arm.hand_length < seg.radius:
            for i, tip in enumerate(self.arm.to_world_points(tips).tolist()):
                if out[i] and not checker.segment_clear(
                        w_w, tip, d_w, checker.distance(tip, checker.bound_hand), seg.radius,
                        seg.length):
                    out[i] = False
        return out

    def _shape_world(self, ends) -> list:
        """The ends (..., 2K, 3) of the hand shape's capsules, canonical, in world space
        (nested lists of floats, for :meth:`_shape_clear`)."""
        return self.arm.to_world_points(ends).tolist()

    def _shape_clear(self, pts, d_w: float) -> bool:
        """Are the capsules of the hand's shape (:mod:`.hand_shape`), their ends ``pts``
        (2K lists of 3 floats) in world space, clear of the obstacles? ``d_w``: a lower
        bound of the wrist's distance to the obstacles; the capsules all lie within
        ``checker.hand_reach`` of it, so a wrist at least that far from everything needs
        no further test."""
        checker = self.checker
        if d_w >= checker.hand_reach:
            return True
        for seg in checker.hand_segments:
            p, q = pts[seg.a - 5], pts[seg.b - 5]
            bound = seg.length + seg.radius
            if not checker.segment_clear(p, q, checker.distance(p, bound),
                                         checker.distance(q, bound), seg.radius, seg.length):
                return False
        return True

    def hand_rows_clear(self, joints, body_rotation: float) -> bool:
        """Is the hand of a pose whose joints carry the shape's rows
        (:func:`.hand_shape.with_shape`, or :func:`.keys.between`'s) clear of the body
        (its axis capsule) and the obstacles (its shape)?"""
        j = np.asarray(joints, dtype=float)
        caps = self.capsules_at(float(body_rotation)) if self.arm.body_capsules else []
        if caps and segment_hits_body(j[3].tolist(), j[4].tolist(), self.arm.hand_radius, caps):
            return False
        w_w = self._world(j[3].tolist())
        d_w = self.checker.distance(w_w, self.checker.bound_wrist)
        return d_w >= self.checker.hand_reach or self._shape_clear(self._shape_world(j[5:]), d_w)

    def transition_problem(self, a: Pose, b: Pose, hand_a=None, hand_b=None,
                           instants: int | None = None, arm: bool = True):
        """What touches between two keyed poses as they interpolate — None, 'arm' or
        'hand' — at ``instants`` − 1 (default ``Settings.instants_per_frame`` − 1) evenly
        spaced instants, against half the clearance (:meth:`between_keys`). The arm and
        hand at those instants are Blender's on a linear span: each segment's rotation
        relative to its parent blended by nlerp (:func:`~reach_addon.core.keys.between`),
        with the wrist's angles ``hand_a`` → ``hand_b`` at the keys (default the poses'
        own). ``arm=False`` skips the arm (already found clear)."""
        n = self.settings.instants_per_frame if instants is None else instants
        if n <= 1:
            return None
        loose = self.between_keys()
        joints, bends, body = keys.between(self.arm, a, b, np.arange(1, n) / n, hand_a, hand_b)
        if arm and not all(loose.arm_clear(j, c) for j, c in zip(joints, body)):
            return "arm"
        for j, c, bend in zip(joints, body, bends):
            if not (loose.hand_rows_clear(j, c) if self.checker.hand_shape else
                    loose.tips_clear(j, c, j[4:5], bend)[0]):
                return "hand"
        return None

    def key_clear(self, pose: Pose) -> bool:
        """Is ``pose``, its own hand included, clear with half the clearance (what the
        instants between keys keep, :meth:`transition_problem`)? A pose held over a frame
        is its own instants between."""
        loose = self.between_keys()
        body = pose.config.body_rotation
        if not loose.arm_clear(pose.joints, body):
            return False
        if self.checker.hand_shape:
            return loose.hand_rows_clear(self.shaped(pose), body)
        return bool(loose.tips_clear(pose.joints, body, pose.joints[4:5], pose.bend)[0])

    def shaped(self, pose: Pose) -> np.ndarray:
        """The pose's joints with its hand shape's rows (:func:`.hand_shape.with_shape`,
        its palm roll included): what the collision checker takes (canonical)."""
        return with_shape(self.arm, pose.joints, pose.bend, pose.roll)

    def world(self, pose: Pose) -> np.ndarray:
        """:meth:`shaped` in world space."""
        return self.arm.to_world_points(self.shaped(pose))
