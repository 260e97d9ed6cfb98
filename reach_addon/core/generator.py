"""The paper's Strength-based Configuration Generation Module.

It "takes a 3D position as input and outputs a valid arm configuration with wrist at this
position", one that satisfies the strength, motion-smoothness and collision-free
constraints. :meth:`ConfigurationGenerator.solve` does exactly that: the IK returns every
legal swivel candidate ranked by strength; the best one that is clear of the obstacles is
returned; if it collides, the next is tested, and so on (at most
``Settings.max_pose_tries``). Everything that needs a pose for a wrist position (the
search, shortcut smoothing, frame resampling, the workspace) goes through it.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from . import ik
from .arm import (ArmConfig, ArmModel, Pose, forward_kinematics, hand_coefficients,
                  pose_from_config)
from .body_capsules import body_capsules_at, segment_hits_body, self_collision
from .collision import CollisionChecker, Obstacles
from .distances import point_segment_distance
from .hand_checks import HandChecks
from .limits import smooth
from .strength import strength_category
from .torso import ChestPath, body_rotation_deg

#: Degrees between the chest rotations :meth:`ConfigurationGenerator.target_chest` tries.
CHEST_FIT_STEP = 5.0


class ConfigurationGenerator(HandChecks):
    """Legal, smooth, collision-free poses for wrist positions (canonical frame). The
    hand's tests are :class:`~reach_addon.core.hand_checks.HandChecks`'."""

    def __init__(self, arm: ArmModel, obstacles: Obstacles, settings):
        self.arm = arm
        self.obstacles = obstacles
        self.settings = settings
        self.checker = CollisionChecker(arm, obstacles, settings)
        self.step_length = settings.step * arm.arm_length
        b, side = settings.wrist_bend_max, settings.wrist_side_max
        # Hand directions tried at each pose: the wrist's range as a 5 × 3 grid, bent 0,
        # half and fully either way in the elbow's plane, each straight or fully sideways
        # (duplicates dropped when a limit is 0): the paper's "further search for a point
        # on a sphere" (docs/design/core.md, generator.py)
        samples = [(k * b, j * side) for k in (0.0, 0.5, -0.5, 1.0, -1.0)
                   for j in (0.0, 1.0, -1.0)]
        self.hand_samples = list(dict.fromkeys(samples))
        # (cos bend · cos side, sin bend · cos side, sin side) of each sample: the hand
        # direction's components along f, p and h (arm.hand_direction).
        self._hand_coefficients = {h: hand_coefficients(*h) for h in self.hand_samples}
        # each sample's bend from neutral (degrees): the most relaxed hand is tried first
        self._relax = {h: math.degrees(math.acos(max(-1.0, min(1.0, c[0]))))
                       for h, c in self._hand_coefficients.items()}
        self._hand_orders = {}
        self._capsule_cache = {}
        self._rotation = arm.to_world[:3, :3].tolist()
        self._offset = arm.to_world[:3, 3].tolist()
        c = self.checker
        self._check_hand = c.check_hand
        self._seg_clavicle, self._seg_upper = c.by_name["clavicle"], c.by_name["upper arm"]
        self._seg_fore, self._seg_hand = c.by_name["forearm"], c.by_name["hand"]
        self._r_fore = self._seg_fore.radius
        # (radius, length) of the clavicle, upper arm and forearm as plain floats: solve
        # reads them for every position tested
        self._sizes = tuple((g.radius, g.length) for g in
                            (self._seg_clavicle, self._seg_upper, self._seg_fore))
        self.chest = None
        self.hand_blocked = False
        self._target_chests: dict = {}

    def between_keys(self) -> ConfigurationGenerator:
        """This generator with half the clearance (the checker keeps at least
        :data:`~.collision.MIN_CLEARANCE`), for the instants between two keyed poses: the
        keys keep the whole margin, the arm and hand as the keys interpolate may use up to
        half of it (a pose planned right at the margin dips into it by a hair when
        interpolated toward its neighbour). Made once and kept."""
        loose = getattr(self, "_between_keys", None)
        if loose is None:
            loose = ConfigurationGenerator(
                self.arm, self.obstacles,
                self.settings.replace(clearance=0.5 * self.settings.clearance))
            self._between_keys = loose
        return loose

    def finer(self, swivel_step: float) -> ConfigurationGenerator:
        """This generator with the swivel circle sampled every ``swivel_step`` degrees and
        every legal candidate tried (for the last try before a refusal,
        :func:`~reach_addon.core.search.last_tries`). The chest follows this one's. Made
        once per step and kept."""
        kept = self.__dict__.setdefault("_finer", {})
        fine = kept.get(swivel_step)
        if fine is None:
            fine = ConfigurationGenerator(
                self.arm, self.obstacles,
                self.settings.replace(swivel_step=swivel_step,
                                      max_pose_tries=int(math.ceil(360.0 / swivel_step))))
            kept[swivel_step] = fine
        fine.chest = self.chest
        return fine

    def for_reach(self, start: Pose, target, fit_chest: bool = True) -> ConfigurationGenerator:
        """A view of this generator for one reach from ``start`` to ``target``: the chest
        rotation follows :class:`~reach_addon.core.torso.ChestPath` instead of Table 1
        alone (the search, the smoothing and the timing of that reach all use it), toward
        :meth:`target_chest` at the target with ``fit_chest`` (a chase's frames, planned
        many times a second toward a target that moves, keep to Table 1)."""
        view = copy.copy(self)
        arrival = self.target_chest(target) if fit_chest else None
        view.chest = ChestPath(self.arm.arm_length, self.arm.hand_length, self.settings,
                               start.wrist, start.config.body_rotation, target, arrival)
        return view

    def chest_candidates(self, wrist) -> list:
        """The chest rotations (degrees) a reach may arrive at ``wrist`` with, in the order
        they are tried: Table 1's (the paper's), then the rest of the chest's range
        (``Settings.chest_rotation_max`` either way) every :data:`CHEST_FIT_STEP` degrees
        and its ends, nearest to Table 1's first. Table 1's alone with body rotation off."""
        st = self.settings
        table = float(body_rotation_deg(np.asarray(wrist, dtype=float), self.arm.arm_length,
                                        self.arm.hand_length, st))
        if not st.chest_rotation:
            return [table]
        limit = float(st.chest_rotation_max)
        grid = {round(float(b), 9) for b in np.arange(-limit, limit + 1e-9, CHEST_FIT_STEP)}
        grid |= {-limit, limit}
        return [table] + sorted((b for b in grid if abs(b - table) > 1e-9),
                                key=lambda b: (abs(b - table), b))

    def target_chest(self, wrist) -> float | None:
        """The chest rotation a reach should arrive at ``wrist`` with: the first of
        :meth:`chest_candidates` at which a legal pose puts the arm and a hand there clear
        (:meth:`solve`, every ranked pose tried: whether a target fits does not depend on
        the search's speed limit ``max_pose_tries``). Table 1's wherever it fits (the
        paper's model, kept wherever it can be); where it puts no clear arm on the target
        (the shoulder turned out of reach, the elbow into a shelf board) the nearest
        rotation that does, as a person turns the trunk to get at a thing. None if none
        does. Remembered per target."""
        key = tuple(np.round(np.asarray(wrist, dtype=float), 12).tolist())
        cache = self._target_chests
        if key not in cache:
            if len(cache) >= 64:
                cache.clear()
            wrist = np.asarray(wrist, dtype=float)
            every = int(360.0 / self.settings.swivel_step) + 1    # every swivel candidate
            cache[key] = next((b for b in self.chest_candidates(wrist)
                               if self.solve(wrist, body_rotation=b, tries=every) is not None),
                              None)
        return cache[key]

    def move_scale(self, previous: Pose, wrist) -> float:
        """How many search steps a move of the wrist from ``previous`` spans (at least 1),
        rounded up to a quarter step so that the hand orders can be cached."""
        distance = math.dist(np.asarray(wrist, dtype=float).tolist(), previous.wrist.tolist())
        return max(1.0, math.ceil(4.0 * distance / self.step_length - 1e-9) / 4.0)

    def max_change(self, previous: Pose, wrist) -> float:
        """Smoothness bound for a move of the wrist from ``previous``: the bound per step,
        scaled up in proportion for moves longer than one step."""
        distance = math.dist(np.asarray(wrist, dtype=float).tolist(), previous.wrist.tolist())
        return self.settings.max_joint_step * max(1.0, distance / self.step_length)

    def hand_order(self, previous_hand, scale: float = 1.0, toward=None) -> list:
        """The hand samples within ``Settings.hand_step_turn`` × ``scale`` of the previous
        wrist angles (turn of the hand's direction relative to the forearm), in the order
        they are tried: the previous hand itself, then those that bend less than it
        (nearest first), then those that bend more (nearest first). So the hand stays as
        it is while it can, relaxes when it may, and bends only as far as it must; keeping
        it (rather than relaxing at every chance) spares the path a zig-zag of turns. A
        previous hand farther than the bound from every sample (a rig's own start pose) may
        go to the nearest samples, within half the bound beyond the nearest.

        ``toward``: a sample the hand should lead toward (the hand the target needs, see
        :class:`~reach_addon.core.search.BestFirstSearch`): the same samples, nearest to it
        first (ties: the smaller turn)."""
        key = (tuple(previous_hand), scale, toward)
        order = self._hand_orders.get(key)
        if order is None:
            c0 = hand_coefficients(*previous_hand)

            def turn(h):
                c = self._hand_coefficients[h]
                dot = c[0] * c0[0] + c[1] * c0[1] + c[2] * c0[2]
                return math.degrees(math.acos(max(-1.0, min(1.0, dot))))

            turns = {h: turn(h) for h in self.hand_samples}
            bend0 = math.degrees(math.acos(max(-1.0, min(1.0, c0[0]))))
            bound = self.settings.hand_step_turn * scale
            bound = max(bound, min(turns.values()) + 0.5 * bound)
            within = [h for h in self.hand_samples if turns[h] <= bound + 1e-9]
            if toward is None:
                order = sorted(within, key=lambda h: (turns[h] > 1e-9,
                                                      self._relax[h] > bend0 + 1e-9, turns[h]))
            else:
                g = self._hand_coefficients[toward]

                def to_goal(h):
                    c = self._hand_coefficients[h]
                    return math.acos(max(-1.0, min(1.0, c[0] * g[0] + c[1] * g[1] + c[2] * g[2])))
                order = sorted(within, key=lambda h: (round(to_goal(h), 9), turns[h]))
            if len(self._hand_orders) < 256:
                self._hand_orders[key] = order
        return order

    def _world(self, p):
        """A canonical point (3 floats) in world space, as a list of floats."""
        (r0, r1, r2), (o0, o1, o2) = self._rotation, self._offset
        x, y, z = p
        return [r0[0] * x + r0[1] * y + r0[2] * z + o0, r1[0] * x + r1[1] * y + r1[2] * z + o1,
                r2[0] * x + r2[1] * y + r2[2] * z + o2]

    def capsules_at(self, body: float):
        """The body's capsules at a chest rotation (:func:`body_capsules_at`), cached
        for the last few rotations (most positions of a reach share one)."""
        caps = self._capsule_cache.get(body)
        if caps is None:
            caps = body_capsules_at(self.arm, body) if self.arm.body_capsules else []
            if len(self._capsule_cache) >= 32:
                self._capsule_cache.clear()
            self._capsule_cache[body] = caps
        return caps

    def solve(self, wrist, previous: Pose | None = None, body_rotation=None,
              hand_scale: float | None = None, toward=None,
              tries: int | None = None, swivel: int | None = None,
              hand_sample=None) -> Pose | None:
        """The strongest legal, collision-free pose with the wrist at ``wrist`` (canonical)
        that is within the smoothness bound of ``previous`` (if given); None if there is
        none. After a None, :attr:`hand_blocked` says whether some arm pose there was clear
        and only the hand found no way (another hand might get there). ``body_rotation``
        (degrees) overrides the chest's (:attr:`chest`, else Table 1).

        ``hand_scale``: if given, the hand is kept continuous with ``previous``: it may turn
        by at most ``Settings.hand_step_turn`` × ``hand_scale``, and only through clear
        directions (:meth:`_place_hand`), leading toward the sample ``toward`` if given
        (:meth:`hand_order`). Without it any clear hand will do.

        The candidates of :func:`~reach_addon.core.ik.solve` are tried in strength order
        (at most ``tries``, by default ``Settings.max_pose_tries``): the arm (clavicle, upper arm, forearm)
        against the obstacles and the body, then the hand at each wrist angle, then the
        swing from ``previous`` (:meth:`_swing_clear`). Obstacle distances are measured
        once per joint and shared (:class:`~reach_addon.core.collision.CollisionChecker`):
        the wrist first, before any IK; the shoulder and sternum once per position; the
        elbow and the hand's end only where the bounds at the other joints leave a segment
        unsettled. ``swivel``, ``hand_sample``: only that swivel sample, that hand is tried
        (:mod:`.elbow` chooses them along a whole path)."""
        wrist = np.asarray(wrist, dtype=float)
        checker, st = self.checker, self.settings
        self.hand_blocked = False
        w_c = wrist.tolist()
        w_w = self._world(w_c)
        d_w = checker.distance(w_w, checker.bound_wrist)
        if d_w < self._r_fore:
            return None                          # the wrist itself is against an obstacle
        if body_rotation is None and self.chest is not None:
            body_rotation = self.chest(wrist)
        max_change = None if previous is None else self.max_change(previous, wrist)
        sol = ik.solve(self.arm, wrist[None], st, None if previous is None else previous.config,
                       body_rotation, max_change)
        order = sol.ranked(0, st.elbow_side)
        if swivel is not None:
            order = [swivel] if swivel in order else []
        order = order[: st.max_pose_tries if tries is None else tries]
        if not order:
            return None
        at = self._position(sol, w_c, w_w, d_w)
        if at is None:
            return None                          # the shoulder or the clavicle touches
        hands = None
        for k in order:
            e_c = self._clear_elbow(at, k)
            if e_c is None:
                continue
            bend = sol.bend_at(0, k).tolist()
            if not self._check_hand:
                lh, l2 = self.arm.hand_length, self.arm.forearm_length
                tip = [w_c[i] + lh * (w_c[i] - e_c[i]) / l2 for i in range(3)]
                hand = (0.0, 0.0)
            else:
                if hands is None:
                    hands = self.hand_order((0.0, 0.0), 180.0) \
                        if previous is None or hand_scale is None else \
                        self.hand_order(previous.hand, hand_scale, toward)
                    if hand_sample is not None:
                        hands = [hand_sample] if hand_sample in hands else []
                tip, hand = self._place_hand(at[3], e_c, w_c, w_w, d_w, bend, at[-1], hands,
                                             None if hand_scale is None else previous)
                if tip is None:
                    self.hand_blocked = True
                    continue
            config = sol.config(0, k)
            if previous is not None and not self._swing_clear(previous, config, e_c):
                continue
            joints = np.array(at[4] + at[3] + e_c + w_c + tip).reshape(5, 3)
            return Pose(config, joints, np.array(bend), sol.category(0, k), hand)
        return None

    def clear_swivels(self, wrist, body_rotation: float, around: Pose):
        """Every swivel sample at ``wrist`` (canonical) with the chest at ``body_rotation``
        whose arm (clavicle, upper arm, forearm; not the hand) is legal and clear of the
        obstacles and the body: (the :func:`~reach_addon.core.ik.solve` solutions, the
        sample indices, their joints (n, 5, 3)). The joint limits are widened to take in
        ``around`` as a move from it would widen them; no smoothness bound applies."""
        wrist = np.asarray(wrist, dtype=float)
        w_c = wrist.tolist()
        w_w = self._world(w_c)
        d_w = self.checker.distance(w_w, self.checker.bound_wrist)
        sol = ik.solve(self.arm, wrist[None], self.settings, around.config, body_rotation,
                       float("inf"))
        at = None if d_w < self._r_fore else self._position(sol, w_c, w_w, d_w)
        ks = [] if at is None else \
            [k for k in np.flatnonzero(sol.valid[0]).tolist() if self._clear_elbow(at, k)]
        return sol, ks, sol.joints(0, ks) if ks else np.zeros((0, 5, 3))

    def _position(self, sol, w_c, w_w, d_w):
        """What every candidate of :meth:`solve` at one wrist position shares, or None where
        the shoulder or the clavicle (the same for every candidate) touches an obstacle. A
        tuple: the wrist (canonical, world, its obstacle distance), the shoulder and sternum
        (canonical), the shoulder (world, its distance), a lower bound on every elbow's
        distance (Lipschitz: the shoulder's less L1, the wrist's less L2), whether that bound
        already clears both segments of every elbow, the elbow's circle (its coefficients
        and the swivel samples' cos φ and sin φ), and the body capsules near enough to touch
        the upper arm, the forearm and the hand (:meth:`_near_capsules`). Float lists."""
        arm, checker = self.arm, self.checker
        l1, l2 = arm.upper_arm_length, arm.forearm_length
        s_c, t_c = sol.shoulder[0].tolist(), sol.sternum[0].tolist()
        s_w = self._world(s_c)
        d_s = checker.distance(s_w, checker.bound_shoulder)
        (r_c, l_c), (r_u, _l_u), (r_f, _l_f) = self._sizes   # clavicle, upper arm, forearm
        if d_s < r_u:
            return None                          # the shoulder itself is against an obstacle
        d_t = d_s - l_c                          # Lipschitz bound at the sternum
        if not (d_t >= r_c and d_s + d_t - l_c >= 2.0 * r_c):
            t_w = self._world(t_c)
            d_t = checker.distance(t_w, checker.bound_sternum)
            if not checker.segment_clear(t_w, s_w, d_t, d_s, r_c, l_c):
                return None
        caps = self.capsules_at(float(sol.body[0]))
        near = self._near_capsules(caps, w_c)
        circle = (sol.elbow_coef[0].tolist(), ik.swivel_lists(float(self.settings.swivel_step)))
        d_e0 = max(d_s - l1, d_w - l2)           # Lipschitz bound at every elbow
        elbows_clear = (d_e0 >= r_u and d_e0 >= r_f and d_s + d_e0 - l1 >= 2.0 * r_u
                        and d_e0 + d_w - l2 >= 2.0 * r_f)
        return (w_c, w_w, d_w, s_c, t_c, s_w, d_s, d_e0, elbows_clear, circle) + near

    def _near_capsules(self, caps: list, w_c) -> tuple:
        """The body ``caps`` (:meth:`capsules_at`) that the upper arm's elbow half, the
        forearm and the hand can reach from the wrist ``w_c`` (every forearm point is within
        L2 of it, every hand point within the hand's length, every point of the upper arm's
        elbow half within L2 + L1/2): three lists, the others left out of those tests."""
        if not caps:
            return caps, caps, caps
        arm = self.arm
        l1, l2 = arm.upper_arm_length, arm.forearm_length
        far = [point_segment_distance(w_c, a, b) - r for a, b, _c, _h, r in caps]
        reach_u = l2 + 0.5 * l1 + arm.upper_arm_radius
        reach_f, reach_h = l2 + arm.forearm_radius, arm.hand_length + arm.hand_radius
        return ([c for c, d in zip(caps, far) if d < reach_u],
                [c for c, d in zip(caps, far) if d < reach_f],
                [c for c, d in zip(caps, far) if d < reach_h])

    def _clear_elbow(self, at: tuple, k: int):
        """The elbow (canonical float list) of candidate ``k`` at the position ``at``
        (:meth:`_position`) if its upper arm and forearm are clear of the obstacles and of
        the body, else None. The elbow's obstacle distance is measured only where the
        position's bound does not settle it."""
        w_c, w_w, d_w, s_c, _t_c, s_w, d_s, d_e0, elbows_clear, circle, caps_upper, \
            caps_fore, _caps_hand = at
        ((c0, c1, c2), (e1x, e1y, e1z), (e2x, e2y, e2z)), (cos_phi, sin_phi) = circle
        cp, sp = cos_phi[k], sin_phi[k]
        e_c = [c0 + cp * e1x + sp * e2x, c1 + cp * e1y + sp * e2y, c2 + cp * e1z + sp * e2z]
        if not elbows_clear:
            checker = self.checker
            (_r_c, _l_c), (r_u, l_u), (r_f, l_f) = self._sizes
            e_w = self._world(e_c)
            d_e = max(d_e0, checker.distance(e_w, checker.bound_elbow))
            if not checker.segment_clear(s_w, e_w, d_s, d_e, r_u, l_u) or \
                    not checker.segment_clear(e_w, w_w, d_e, d_w, r_f, l_f):
                return None
        arm = self.arm
        if caps_upper:
            mid = [0.5 * (s_c[0] + e_c[0]), 0.5 * (s_c[1] + e_c[1]), 0.5 * (s_c[2] + e_c[2])]
            if segment_hits_body(mid, e_c, arm.upper_arm_radius, caps_upper):
                return None
        if caps_fore and segment_hits_body(e_c, w_c, arm.forearm_radius, caps_fore):
            return None
        return e_c

    def _swing_clear(self, previous: Pose, config: ArmConfig, elbow) -> bool:
        """Is the arm clear halfway between ``previous`` and a candidate (their angles
        interpolated)? Checked only when the elbow swings farther than the upper arm's
        radius between them: a step of the wrist is short, but a turn of the swivel angle
        within the smoothness bound can carry the elbow several centimetres, round an
        obstacle's edge that neither end touches."""
        if math.dist(previous.elbow.tolist(), elbow) <= self.arm.upper_arm_radius:
            return True
        mid = 0.5 * (previous.config.as_array() + config.as_array())
        joints, _bend = forward_kinematics(self.arm, mid)
        return self.arm_clear(joints, float(mid[0]))

    def arm_clear(self, joints, body_rotation: float) -> bool:
        """Is the arm (sternum to wrist, without the hand) of a pose clear of the obstacles
        and of the body? ``joints`` (≥ 4, 3), canonical."""
        j = np.asarray(joints, dtype=float)
        full = np.vstack([j[:4], j[3:4]])
        if self_collision(self.arm, float(body_rotation), full[None], include_hand=False)[0]:
            return False
        return not self.checker.collides(self.arm.to_world_points(full), include_hand=False)

    def smooth_between(self, a: Pose, b: Pose) -> bool:
        """Is ``b`` within the smoothness bound of ``a``?"""
        if self._check_hand and b.hand not in self.hand_order(a.hand,
                                                              self.move_scale(a, b.wrist)):
            return False
        c = b.config
        ok = smooth(a.config, np.array([c.body_rotation]), np.array([[c.alpha]]),
                       np.array([[c.beta]]), np.array([[c.gamma]]), np.array([c.elbow]),
                       self.max_change(a, b.wrist))
        return bool(ok.all())

    def pose_collides(self, pose: Pose) -> bool:
        return self.checker.collides(self.world(pose))

    def start_problem(self, pose: Pose):
        """None if a start pose is usable, else (segment, obstacle) of its first contact or
        ('sternum', obstacle) when the body's root is inside an obstacle."""
        root = self.arm.to_world_points(pose.joints[0])
        if self.obstacles.point_inside(root):
            return "sternum", self.obstacles.enclosing_owner(root)
        return self.checker.first_hit(self.world(pose))

    def config_pose(self, config: ArmConfig, hand=(0.0, 0.0)) -> Pose:
        """The pose of a configuration (forward kinematics) with the wrist's two angles
        ``hand``, and its strength category."""
        level = strength_category(config.alpha, config.beta, self.settings)
        return pose_from_config(self.arm, config, int(level), tuple(hand))
