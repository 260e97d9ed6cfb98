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
from .arm import ArmConfig, ArmModel, Pose, hand_direction, pose_from_config
from .collision import CollisionChecker, Obstacles
from .errors import OUT_OF_REACH, TARGET_IN_OBSTACLE
from .strength import f_r
from .torso import ChestPath


class ConfigurationGenerator:
    """Legal, smooth, collision-free poses for wrist positions (canonical frame)."""

    def __init__(self, arm: ArmModel, obstacles: Obstacles, settings):
        self.arm = arm
        self.obstacles = obstacles
        self.settings = settings
        self.checker = CollisionChecker(arm, obstacles, settings)
        self.step_length = settings.step * arm.arm_length
        b, side = settings.wrist_bend_max, settings.wrist_side_max
        # Hand directions tried at each pose: neutral, bent half and fully either way in the
        # elbow's plane, then sideways (duplicates dropped when a limit is 0).
        samples = [(0.0, 0.0), (0.5 * b, 0.0), (-0.5 * b, 0.0), (b, 0.0), (-b, 0.0),
                   (0.0, side), (0.0, -side)]
        self.hand_samples = list(dict.fromkeys(samples))
        self.chest = None

    def for_reach(self, start: Pose, target) -> ConfigurationGenerator:
        """A view of this generator for one reach from ``start`` to ``target``: the chest
        rotation follows :class:`~reach_addon.core.torso.ChestPath` instead of Table 1
        alone (the search, the smoothing and the timing of that reach all use it)."""
        view = copy.copy(self)
        view.chest = ChestPath(self.arm.arm_length, self.settings, start.wrist,
                               start.config.body_rotation, target)
        return view

    def max_change(self, previous: Pose, wrist) -> float:
        """Smoothness bound for a move of the wrist from ``previous``: the bound per step,
        scaled up in proportion for moves longer than one step."""
        distance = float(np.linalg.norm(np.asarray(wrist) - previous.wrist))
        return self.settings.max_joint_step * max(1.0, distance / self.step_length)

    def hand_order(self, previous_hand) -> list:
        """The hand samples, nearest the previous wrist angles first (stable)."""
        pb, ps = previous_hand
        return sorted(self.hand_samples, key=lambda h: math.hypot(h[0] - pb, h[1] - ps))

    def solve(self, wrist, previous: Pose | None = None, body_rotation=None) -> Pose | None:
        """The strongest legal, collision-free pose with the wrist at ``wrist`` that is
        within the smoothness bound of ``previous`` (if given); None if there is none.

        Candidates are tried in strength order: the arm (clavicle, upper arm, forearm)
        against the body and the obstacles, then the hand at each wrist angle, the previous
        one first, until one is clear."""
        wrist = np.asarray(wrist, dtype=float)
        if body_rotation is None and self.chest is not None:
            body_rotation = self.chest(wrist)
        max_change = None if previous is None else self.max_change(previous, wrist)
        sol = ik.solve(self.arm, wrist[None], self.settings,
                       None if previous is None else previous.config, body_rotation, max_change)
        order = sol.order(0, self.settings.elbow_side)
        if order.size == 0:
            return None
        order = order[: self.settings.max_pose_tries]
        joints = sol.joints(0, order)
        world = self.arm.to_world_points(joints)
        body = float(sol.body[0])
        caps = ik.body_capsules_at(self.arm, body) if self.arm.body_capsules else []
        check_hand = self.checker.check_hand
        hands = self.hand_order(previous.hand if previous is not None else (0.0, 0.0))
        length_hand = self.arm.hand_length
        for n, k in enumerate(order):
            j = joints[n]
            if caps:
                sh, el, wr = j[1].tolist(), j[2].tolist(), j[3].tolist()
                mid = [0.5 * (sh[i] + el[i]) for i in range(3)]
                if ik.segment_hits_body(mid, el, self.arm.upper_arm_radius, caps) or \
                        ik.segment_hits_body(el, wr, self.arm.forearm_radius, caps):
                    continue
            if self.checker.collides(world[n], include_hand=False):
                continue
            if not check_hand:
                return sol.pose(0, int(k), j)
            upper = (j[2] - j[1]) / self.arm.upper_arm_length
            fore = (j[3] - j[2]) / self.arm.forearm_length
            bend = sol.bend[0, :, k]
            for hand in hands:
                tip = j[3] + length_hand * (fore if hand == (0.0, 0.0) else
                                            hand_direction(upper, bend, fore, *hand))
                if caps and ik.segment_hits_body(j[3].tolist(), tip.tolist(),
                                                 self.arm.hand_radius, caps):
                    continue
                if self.checker.hand_hit(world[n][3], self.arm.to_world_points(tip)):
                    continue
                j = j.copy()
                j[4] = tip
                return sol.pose(0, int(k), j, hand)
        return None

    def smooth_between(self, a: Pose, b: Pose) -> bool:
        """Is ``b`` within the smoothness bound of ``a``?"""
        c = b.config
        ok = ik.smooth(a.config, np.array([c.body_rotation]), np.array([[c.alpha]]),
                       np.array([[c.beta]]), np.array([[c.gamma]]), np.array([c.elbow]),
                       self.max_change(a, b.wrist))
        return bool(ok.all())

    def pose_collides(self, pose: Pose) -> bool:
        return self.checker.collides(self.arm.to_world_points(pose.joints))

    def diagnose_target(self, wrist):
        """Why a wrist position can never be reached, or None if some pose there is legal
        and clear. Returns (reason, detail): ``OUT_OF_REACH`` with the distance from the
        shoulder, or ``TARGET_IN_OBSTACLE`` with the obstacle's name."""
        wrist = np.asarray(wrist, dtype=float)
        world = self.arm.to_world_points(wrist)
        if self.obstacles.point_inside(world):
            return TARGET_IN_OBSTACLE, self.obstacles.enclosing_owner(world)
        sol = ik.solve(self.arm, wrist[None], self.settings)
        legal = np.flatnonzero(sol.legal[0])
        if legal.size == 0:
            return OUT_OF_REACH, float(np.linalg.norm(wrist - sol.shoulder[0]))
        joints = sol.joints(0, legal)
        clear_of_body = ~ik.self_collision(self.arm, float(sol.body[0]), joints,
                                           include_hand=False)
        hit = ("arm", "the body itself")
        for j in self.arm.to_world_points(joints[clear_of_body]):
            hit = self.checker.first_hit(j, include_hand=False)
            if hit is None:
                return None
        # Every legal pose with the wrist there touches something.
        return TARGET_IN_OBSTACLE, hit[1]

    def start_problem(self, pose: Pose):
        """None if a start pose is usable, else (segment, obstacle) of its first contact or
        ('sternum', obstacle) when the body's root is inside an obstacle."""
        root = self.arm.to_world_points(pose.joints[0])
        if self.obstacles.point_inside(root):
            return "sternum", self.obstacles.enclosing_owner(root)
        return self.checker.first_hit(self.arm.to_world_points(pose.joints))

    def config_pose(self, config: ArmConfig) -> Pose:
        """The pose of a configuration (forward kinematics), with its strength category."""
        level = f_r(config.alpha, config.beta, self.settings.preferred_level_h,
                    self.settings.preferred_level_v)
        return pose_from_config(self.arm, config, int(level))
