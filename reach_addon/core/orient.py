"""Match orientation: the palm arrives aligned with the target's axes
(``Settings.match_orientation``, opt-in).

Two of the target's local axes name the hand's frame: ``Settings.finger_axis``, the way the
fingers point, and ``Settings.palm_axis``, the way the palm faces (by default +Y and −Z: an
Empty drawn as *Plain Axes* reads as a hand on its XY plane, palm down). The rig's finger
direction and palm normal at the start (``Task.start_fingers``, ``Task.start_palm``,
canonical) have constant coordinates in the hand's frame (d, g, d × g) of
:func:`~reach_addon.core.arm.hand_frame` (:func:`hand_locals`). The hand pass seeks the
wanted direction on the last frames (a cost, :func:`frame_weights`,
:func:`best_roll_error`; never a constraint); the palm's roll ψ about the hand's axis is
chosen at the last frame (:func:`best_roll`) within the forearm's range
(:func:`roll_window`) and ramped in within the hand's turn bound (:func:`roll_increments`);
the error left is reported (``orientation_error_deg``, met within
``Settings.orientation_tolerance``). Angles in degrees.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .arm import frame_angle, frame_turn, hand_frame, roll_frames
from .numeric import cross
from .torso import minimum_jerk

#: The axis names a setting may take: the target's local axes, either way.
AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
#: Share of the palm's roll the bake gives the forearm bone (about its own axis); the hand
#: gets all of it. Real pronation turns the radius about the ulna, so the forearm's skin
#: twists more toward the wrist; half on the forearm keeps the wrist's skin from wringing.
FOREARM_SHARE = 0.5
#: Share of a reach's last frames on which the orientation is sought (its weight rising
#: from 0 to full at the last frame, :func:`frame_weights`).
APPROACH_SHARE = 0.35


def axis_vector(name: str) -> np.ndarray:
    """The unit vector of an axis name of :data:`AXES` ('+x' → (1, 0, 0), '-z' → (0, 0, -1))."""
    v = np.zeros(3)
    v["xyz".index(name[1])] = 1.0 if name[0] == "+" else -1.0
    return v


def wanted_axes(rotation, finger_axis: str, palm_axis: str):
    """(finger, palm) unit vectors of a target's rotation (3 × 3, columns its local axes;
    scale allowed): f = R e_finger / |·|, n = R e_palm made perpendicular to f."""
    r = np.asarray(rotation, dtype=float)
    f = r @ axis_vector(finger_axis)
    f = f / max(float(np.linalg.norm(f)), 1e-12)
    n = r @ axis_vector(palm_axis)
    n = n - (n @ f) * f
    return f, n / max(float(np.linalg.norm(n)), 1e-12)


def palm_frame(d, n) -> np.ndarray:
    """Columns (d, n, d × n) (..., 3, 3) of a hand's finger direction d and palm normal n
    (both unit, perpendicular)."""
    d, n = np.asarray(d, dtype=float), np.asarray(n, dtype=float)
    return np.stack([d, n, cross(d, n)], -1)


def best_roll(d, n, finger, palm):
    """The roll ψ (degrees) about d that best aligns the palm frame (d, n) with the wanted
    (f_w, n_w): with m = d × n and c_w = f_w × n_w, tr(A(ψ) Wᵀ) = d·f_w + cos ψ (n·n_w +
    m·c_w) + sin ψ (m·n_w − n·c_w), greatest at ψ* = atan2(m·n_w − n·c_w, n·n_w + m·c_w).
    Vectors (..., 3)."""
    d, n = np.asarray(d, dtype=float), np.asarray(n, dtype=float)
    m = cross(d, n)
    c_w = cross(np.asarray(finger, float), np.asarray(palm, float))
    sin = np.sum(m * palm, -1) - np.sum(n * c_w, -1)
    cos = np.sum(n * palm, -1) + np.sum(m * c_w, -1)
    return np.degrees(np.arctan2(sin, cos))


def clamp_roll(psi, lo: float, hi: float):
    """ψ (degrees, wrapped into (−180°, 180°]) limited to [lo, hi] (lo ≤ 0 ≤ hi): outside,
    the bound nearer ψ round the circle (the frame error grows with the angle from ψ*)."""
    psi = np.asarray(psi, dtype=float)
    inside = (psi >= lo) & (psi <= hi)
    gap_lo = np.abs((psi - lo + 180.0) % 360.0 - 180.0)
    gap_hi = np.abs((psi - hi + 180.0) % 360.0 - 180.0)
    return np.where(inside, psi, np.where(gap_lo < gap_hi, lo, hi))


def twist_of(frame, n) -> float:
    """The forearm's twist (degrees, supination +) of a palm normal n in the hand's frame
    (d, g, c = d × g): ψ_a = atan2(n·(−c), n·(−g)). At neutral (thumb up with the elbow bent
    at a right angle, palm down with the arm held out) the palm faces the elbow hinge's
    inner side −g; full supination turns it toward the side the elbow bends to, −c = g × d.
    A roll ψ about d (:func:`~reach_addon.core.arm.roll_frames`) adds ψ to it."""
    f = np.asarray(frame, dtype=float)
    n = np.asarray(n, dtype=float)
    return float(np.degrees(math.atan2(-(n @ f[:, 2]), -(n @ f[:, 1]))))


def roll_window(start_twist: float, settings) -> tuple:
    """(lo, hi): the rolls ψ (degrees, added to the start pose's twist ψ_a0) that keep the
    forearm within pronation and supination: [−pronation_max − ψ_a0, supination_max − ψ_a0],
    widened to hold 0 (a start pose already beyond a limit may stay, not go farther)."""
    lo = -settings.pronation_max - start_twist
    hi = settings.supination_max - start_twist
    return min(lo, 0.0), max(hi, 0.0)


@dataclass(frozen=True)
class OrientGoal:
    """What one reach should arrive with (canonical arm frame): the wanted finger direction
    and palm normal, the fingers' and the palm's coordinates in the hand's frame (constant
    as the hand is carried, :func:`hand_locals`) and the window of rolls
    (:func:`roll_window`)."""

    finger: np.ndarray
    palm: np.ndarray
    palm_local: np.ndarray
    lo: float
    hi: float
    tolerance: float
    weight: float
    finger_local: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))


def hand_locals(start_pose, start_palm=None, start_fingers=None) -> tuple:
    """(fingers, palm): the finger direction's and the palm normal's coordinates in the
    start pose's hand frame F = (d, g, d × g), Fᵀ v, the palm made perpendicular to the
    fingers. The fingers default to the hand's own direction d, (1, 0, 0); the palm to
    forearm neutral, (0, −1, 0). The fingers (the wrist to the middle finger's knuckle, as
    the rig adapter reads them) may point a few degrees off d, the axis of the hand's
    capsule (the mean of its finger joints)."""
    frame = hand_frame(start_pose)
    finger = np.array([1.0, 0.0, 0.0])
    if start_fingers is not None:
        f = frame.T @ np.asarray(start_fingers, dtype=float)
        if float(np.linalg.norm(f)) > 1e-9:
            finger = f / np.linalg.norm(f)
    palm = np.array([0.0, -1.0, 0.0])
    if start_palm is not None:
        palm = frame.T @ np.asarray(start_palm, dtype=float)
    palm = palm - (palm @ finger) * finger
    norm = float(np.linalg.norm(palm))
    if norm < 1e-9:
        palm = np.array([0.0, -1.0, 0.0]) - finger[1] * finger
        norm = float(np.linalg.norm(palm))
    return finger, palm / norm


def palm_in_hand(start_pose, start_palm=None) -> np.ndarray:
    """The palm normal's coordinates in the start pose's hand frame (d, g, d × g): Fᵀ n,
    with n made perpendicular to d; (0, −1, 0) (forearm neutral) without ``start_palm``."""
    return hand_locals(start_pose, start_palm)[1]


def goal_for(arm, settings, start_pose, rotation, start_palm=None,
             start_fingers=None) -> OrientGoal:
    """The :class:`OrientGoal` of a target whose world rotation is ``rotation`` (3 × 3), for
    a motion that starts at ``start_pose`` (whose hand carries ``start_palm`` and points
    its fingers along ``start_fingers``, canonical)."""
    finger, palm = wanted_axes(rotation, settings.finger_axis, settings.palm_axis)
    inverse = arm.to_world[:3, :3].T                     # rigid: a reflection allowed
    finger, palm = inverse @ finger, inverse @ palm
    finger_local, local = hand_locals(start_pose, start_palm, start_fingers)
    twist = twist_of(np.eye(3), local)
    lo, hi = roll_window(twist, settings)
    return OrientGoal(finger, palm, local, lo, hi, settings.orientation_tolerance,
                      settings.orientation_weight, finger_local)


def roll_about(d, m):
    """The roll ψ (degrees) about unit d (..., 3) that maximises tr(R_d(ψ) M) for M
    (..., 3, 3): with K = [d]×, R_d(ψ) = I + sin ψ K + (1 − cos ψ) K², so
    tr(R M) = tr M + tr K²M + a sin ψ − b cos ψ with a = tr(K M), b = tr(K² M), greatest at
    ψ* = atan2(a, −b). (:func:`best_roll` is the case of fingers along d.)"""
    d = np.asarray(d, dtype=float)
    m = np.asarray(m, dtype=float)
    z = np.zeros(d.shape[:-1])
    k = np.stack([np.stack([z, -d[..., 2], d[..., 1]], -1),
                  np.stack([d[..., 2], z, -d[..., 0]], -1),
                  np.stack([-d[..., 1], d[..., 0], z], -1)], -2)
    a = np.einsum("...ij,...ji->...", k, m)
    b = np.einsum("...ij,...ji->...", k @ k, m)
    return np.degrees(np.arctan2(a, -b))


def _achieved(frames, goal: OrientGoal):
    """The palm frames (..., 3, 3) of hand frames (columns d, g, c, any roll applied)."""
    return palm_frame(frames @ goal.finger_local, frames @ goal.palm_local)


def best_roll_error(frames, goal: OrientGoal):
    """For hand frames (..., 3, 3) of columns (d, g, c) (no roll): (ψ, error) — the best
    roll about d within the goal's window (:func:`roll_about`, :func:`clamp_roll`) and the
    angle (degrees) left between the rolled palm frame and the wanted one."""
    f = np.asarray(frames, dtype=float)
    d = f[..., :, 0]
    wanted = palm_frame(goal.finger, goal.palm)
    psi = clamp_roll(roll_about(d, _achieved(f, goal) @ np.swapaxes(wanted, -1, -2)),
                     goal.lo, goal.hi)
    return psi, frame_angle(_achieved(roll_frames(f, psi), goal), wanted)


def pose_error(pose, goal: OrientGoal) -> float:
    """The orientation error (degrees) of a pose, its roll included."""
    f = roll_frames(hand_frame(pose), pose.roll)
    return float(frame_angle(_achieved(f, goal), palm_frame(goal.finger, goal.palm)))


def wanted_hand_angles(axes, goal: OrientGoal, settings) -> tuple:
    """The wrist's two angles (degrees, :func:`~reach_addon.core.arm.hand_coefficients`)
    of the wanted finger direction at a pose whose hand frame rows are ``axes`` (f, p, h):
    β_w = atan2(d·p, d·f), σ_w = asin(d·h), each limited to the wrist's range. The hand's
    direction d is aimed so that its fingers (``goal.finger_local``, a few degrees off d)
    point along the wanted direction: d is the wanted direction turned back by the
    fingers' own angle from d, in the plane of the two."""
    want = np.asarray(goal.finger, dtype=float)
    fl = goal.finger_local
    off = math.degrees(math.acos(max(-1.0, min(1.0, float(fl[0])))))
    if off > 1e-6:
        # the fingers lean off d by `off` toward the hand frame's (0, fl_y, fl_z): lean the
        # wanted direction back the other way, about the axis the lean is about
        rows = np.asarray(axes, dtype=float)
        lean = rows[1] * fl[1] + rows[2] * fl[2]
        axis = cross(rows[0], lean)
        n = float(np.linalg.norm(axis))
        if n > 1e-9:
            axis = axis / n
            t = -math.radians(off)
            want = (want * math.cos(t) + cross(axis, want) * math.sin(t)
                    + axis * float(axis @ want) * (1.0 - math.cos(t)))
    c = np.asarray(axes, dtype=float) @ want
    bend = math.degrees(math.atan2(c[1], c[0]))
    side = math.degrees(math.asin(max(-1.0, min(1.0, float(c[2])))))
    return (max(-settings.wrist_bend_max, min(settings.wrist_bend_max, bend)),
            max(-settings.wrist_side_max, min(settings.wrist_side_max, side)))


def frame_weights(n: int) -> np.ndarray:
    """The weight (0..1) of the orientation cost at each of a reach's ``n`` frames: 0
    before the last :data:`APPROACH_SHARE` of them, then (τ)² rising to 1 at the last frame,
    τ the share of that approach gone by: the hand turns toward the wanted direction as it
    arrives, not in a last-frame flick."""
    w = np.zeros(n)
    if n < 2:
        return np.ones(n)
    k0 = max(1, int(math.floor((1.0 - APPROACH_SHARE) * (n - 1))))
    span = max(1, n - 1 - k0)
    k = np.arange(k0, n)
    w[k0:] = ((k - k0 + 1) / (span + 1)) ** 2
    return w


def minimum_jerk_steps(n: int) -> np.ndarray:
    """Increments (n − 1,) of the minimum-jerk profile
    (:func:`~reach_addon.core.torso.minimum_jerk`) over n evenly spaced frames; they sum
    to 1."""
    return np.diff(minimum_jerk(np.linspace(0.0, 1.0, n)))


def roll_increments(delta: float, slack) -> np.ndarray:
    """Per-transition roll steps (degrees, len(slack)) that add up to ``delta`` (or as
    much of it as fits): the minimum-jerk profile scaled by λ and each step clipped to its
    transition's slack s_k ≥ 0, δ_k = sign(Δ) min(λ |Δ| w_k, s_k), with λ ≥ 1 found by
    bisection so that Σ δ_k = Δ. Where even Σ s_k < |Δ| every step is its slack."""
    slack = np.maximum(np.asarray(slack, dtype=float), 0.0)
    n = len(slack)
    if n == 0 or delta == 0.0:
        return np.zeros(n)
    w = minimum_jerk_steps(n + 1)
    need = abs(delta)
    if slack.sum() <= need:
        return math.copysign(1.0, delta) * slack
    lo, hi = 0.0, 1.0
    while np.minimum(hi * need * w, slack).sum() < need:
        hi *= 2.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if np.minimum(mid * need * w, slack).sum() < need:
            lo = mid
        else:
            hi = mid
    steps = np.minimum(hi * need * w, slack)
    steps *= need / steps.sum()
    return math.copysign(1.0, delta) * steps


def apply_roll(report, start_roll: float, goal, bound: float):
    """Give the poses of a hand pass's ``report`` (a :class:`~reach_addon.core.hand.HandReport`,
    changed in place) their palm roll: from ``start_roll`` (the pose the reach starts from)
    to the best roll at the last frame within the forearm's range (:func:`best_roll_error`;
    ``start_roll`` kept without a ``goal``), in steps of :func:`roll_increments` within what
    the hand's turn-speed bound in space (``bound``, degrees a frame) leaves at each frame.
    The hand's largest turn in space is measured again, the roll included."""
    poses = report.poses
    if len(poses) < 2:
        report.poses = [dataclasses.replace(p, roll=float(start_roll)) for p in poses]
        return report
    end = start_roll if goal is None else float(best_roll_error(hand_frame(poses[-1]), goal)[0])
    turns = np.array([frame_turn(a, b) for a, b in zip(poses[:-1], poses[1:])])
    steps = roll_increments(end - start_roll, bound - turns)
    rolls = start_roll + np.concatenate([[0.0], np.cumsum(steps)])
    report.poses = [dataclasses.replace(p, roll=float(r)) for p, r in zip(poses, rolls)]
    report.max_hand_turn_deg = max(frame_turn(a, b) for a, b in
                                   zip(report.poses[:-1], report.poses[1:]))
    return report
