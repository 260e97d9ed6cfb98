"""Checks of a finished motion: each key's clearance, where the motion first touches an
obstacle (at a key or as two keys interpolate), and the :class:`~reach_addon.core.results.Stats`
they fill.
"""

from __future__ import annotations

import numpy as np

from .arm import ArmModel, Pose
from .elbow import wing_count
from .hand import HandReport
from .hand_shape import world_pose
from .keys import between
from .results import Stats


def first_contact(generator, poses, hand: HandReport, clearances, escaping: bool = False):
    """Where a motion first touches an obstacle: (frame, (part, obstacle)) of the first key
    whose arm or hand comes into contact (no margin) or the first pair of keys that touch
    as they interpolate (at half the clearance, :meth:`ConfigurationGenerator.transition_problem`,
    as the hand pass reports them); None if it never does. ``clearances``: each key's, from
    :func:`pose_clearances`. ``escaping``: the motion starts in contact and moves out of it
    (:mod:`~reach_addon.core.contact`); its first keys in contact, up to the first clear
    one, are that escape and do not count, but once any instant of it is clear no later
    one may touch (:func:`escape_contact`)."""
    arm = generator.arm
    checker = generator.checker
    touching = [c < 0.0 for c in clearances]
    first = 0
    if escaping:
        back = escape_contact(generator, poses, clearances)
        if back is not None:
            return back
        while first < len(poses) and touching[first]:
            first += 1
    unclear = sorted(k for k in hand.unclear_transitions if k >= first)
    bad = unclear[0] + 1 if unclear else len(poses)
    for k in range(first, bad):
        if touching[k]:
            world = world_pose(arm, poses[k])
            return k, checker.first_hit(world) or ("arm", "an obstacle")
    if unclear:
        k = unclear[0]
        return k + 1, _between_hit(generator, poses[k], poses[k + 1])
    return None


def escape_contact(generator, poses, clearances):
    """Where a motion that starts in contact touches again after leaving it: (frame,
    (part, obstacle)) of the first key, or the key ending the first span, with an instant
    in contact (no margin, :meth:`~reach_addon.core.collision.CollisionChecker.least_clearance`)
    after an instant clear; None if it never does. Every key and ``instants_per_frame``
    instants of each span (as Blender interpolates them, :func:`~reach_addon.core.keys.between`)
    are read, up to the first key clear with the whole margin; the hand pass checks the
    spans after it. The rule an independent check of the baked motion applies: a start in
    contact may stay in contact only while leaving it."""
    arm, checker = generator.arm, generator.checker
    horizon = 0.5 * arm.arm_length
    n = max(2, generator.settings.instants_per_frame)
    leaving = True
    for k, pose in enumerate(poses):
        world = world_pose(arm, pose)
        if clearances[k] >= 0.0:
            leaving = False
        elif not leaving:
            return k, checker.first_hit(world) or ("arm", "an obstacle")
        if k + 1 == len(poses) or not checker.collides(world):
            return None
        instants, _bends, _body = between(arm, pose, poses[k + 1], np.arange(1, n) / n)
        for joints in arm.to_world_points(instants):
            if checker.least_clearance(joints, horizon) >= 0.0:
                leaving = False
            elif not leaving:
                return k + 1, checker.first_hit(joints) or ("arm", "an obstacle")
    return None


def _between_hit(generator, a: Pose, b: Pose):
    """(part, obstacle) of the first contact between two keys as they interpolate (the
    instants of :meth:`ConfigurationGenerator.transition_problem`, at half the clearance)."""
    n = max(2, generator.settings.instants_per_frame)
    instants, _bends, _body = between(generator.arm, a, b, np.arange(1, n) / n)
    checker = generator.between_keys().checker
    for joints in generator.arm.to_world_points(instants):
        hit = checker.first_hit(joints)
        if hit is not None:
            return hit
    return (generator.transition_problem(a, b) or "hand", "the character's own body")


def pose_clearances(arm: ArmModel, poses, checkers) -> list:
    """Each pose's least clearance (figure units, no margin; ``inf`` where nothing is
    within half an arm length; a lower bound,
    :meth:`~reach_addon.core.collision.CollisionChecker.least_clearance`), measured by its
    own checker (one per pose: a chase against moving obstacles
    has one obstacle set per frame)."""
    horizon = 0.5 * arm.arm_length
    return [checker.least_clearance(world_pose(arm, p), horizon)
            for p, checker in zip(poses, checkers)]


def motion_stats(stats: Stats, arm: ArmModel, poses, checkers, motion_length: float,
                 wing_margin: float, hand: HandReport | None = None,
                 clearances=None) -> None:
    """Fill the motion part of ``stats``: frames, strength categories, chicken-wing
    frames (``wing_margin``: ``Settings.wing_margin``, :func:`~reach_addon.core.elbow.wing_count`)
    and the least clearance (``clearances`` if already measured, else
    :func:`pose_clearances` with ``checkers``), and what the hand pass reported."""
    length = arm.arm_length
    if hand is not None:
        stats.max_wrist_turn_deg_per_frame = hand.max_wrist_turn_deg
        stats.max_hand_turn_deg_per_frame = hand.max_hand_turn_deg
        stats.mean_wrist_bend_deg = hand.mean_wrist_bend_deg
        stats.max_wrist_bend_deg = hand.max_wrist_bend_deg
        stats.inserted_frames = hand.inserted_frames
        stats.unbounded_hand_turns = hand.unbounded_turns
        stats.touching_transitions = len(hand.unclear_transitions)
    stats.motion_path_length_arm_lengths = motion_length
    stats.frames = len(poses)
    stats.chicken_wing_frames = wing_count(poses, length, wing_margin) if poses else 0
    for p in poses:
        stats.strength_categories[max(0, min(2, int(p.f_r)))] += 1
    if clearances is None:
        clearances = pose_clearances(arm, poses, checkers)
    for c in clearances:
        stats.min_clearance_arm_lengths = min(stats.min_clearance_arm_lengths, c / length)
