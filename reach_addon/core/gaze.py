"""The head's gaze: the neck turns the head toward the target, within the neck's limits
(issue "Reach past the arm", item 1: *head and neck looking at the target*).

People look at what they reach for, and the head leads the hand: the eyes and head turn to
a new target first, the hand follows (Land & Hayhoe 2001, *In what ways do eye movements
contribute to everyday activities?*, Vision Res 41: 3559). Reach turns the head with the
cervical spine as one joint at the neck's base, the whole head chain carried rigidly:

- **The aim** (:func:`gaze_angles`) is read in the neck's own frame as the trunk carries
  it (its forward and up where the figure stood at the start, turned by the lean and the
  chest): the yaw ``ψ`` about its up axis ``u`` and the pitch ``φ`` about its side axis
  ``s = f × u`` (up positive) after which the eyes, at ``e`` from the neck's base, look
  along the forward axis ``f`` at the target, at ``d`` from the base. The eyes turn with
  the head, so their offset across the line of sight stays what it was: with
  ``l = u × f``, ``d_h = \\sqrt{(d·f)^2 + (d·l)^2}`` and ``ρ = |d|``,

  .. math:: ψ = \\operatorname{atan2}(d·l,\\ d·f) - \\arcsin\\frac{e·l}{d_h},\\qquad
            φ = \\operatorname{atan2}(d·u,\\ d_h) - \\arcsin\\frac{e·u}{ρ}

  (the line of sight, ``e·u`` above and ``e·l`` beside the neck's base, passes through
  the target).

- **The limits** (:func:`clip_gaze`) are the American Academy of Orthopaedic Surgeons'
  averages for the cervical spine (*Joint Motion: Method of Measuring and Recording*,
  1965): rotation 60°, flexion 45°, extension 45° (``Settings.gaze_turn_max``,
  ``gaze_down_max``, ``gaze_up_max``). The eyes cover the rest of a target beyond them.
- **The turn** (:func:`gaze_rotation`) is :math:`R_u(ψ)\\,R_s(φ)` in the neck's frame.
- **The timing** (:func:`gaze_blend`): toward each new target the head turns on a
  minimum-jerk curve over ``Settings.gaze_time`` seconds from the frame the target is
  taken up (0.4 s: head movements of a 40-60° gaze shift last 0.3-0.5 s, Zangemeister,
  Lehman & Stark 1981, *Simulation of head movement trajectories: model and fit to main
  sequence*, Biol Cybern 41: 19), then follows it (a chased target, the trunk moving),
  never faster than ``Settings.gaze_speed`` (250°/s, within the peak head velocities of
  such gaze shifts, ibid.): a target nearly straight below the eyes turns the aim's yaw
  quickly as the trunk turns under it.
"""

from __future__ import annotations

import math

import numpy as np

from .torso import minimum_jerk


def gaze_angles(target, forward, up, eyes=None) -> tuple:
    """(yaw, pitch) in degrees after which the eyes (at ``eyes`` from the pivot, none by
    default) look along the turned ``forward`` at ``target`` (from the pivot; all in one
    frame, ``forward`` and ``up`` unit and at right angles): the yaw about ``up`` (toward
    ``up × forward`` positive), then the pitch about the side axis ``forward × up`` (up
    positive). See the module docstring; a target nearer the pivot than the eyes' offset
    is aimed at as if from the pivot."""
    d = np.asarray(target, dtype=float)
    f = np.asarray(forward, dtype=float)
    u = np.asarray(up, dtype=float)
    e = np.zeros(3) if eyes is None else np.asarray(eyes, dtype=float)
    left = np.cross(u, f)
    x, y, z = float(d @ f), float(d @ left), float(d @ u)
    h, rho = math.hypot(x, y), math.sqrt(x * x + y * y + z * z)

    def across(offset, distance):
        return math.asin(offset / distance) if abs(offset) < distance else 0.0

    yaw = math.atan2(y, x) - across(float(e @ left), h)
    pitch = math.atan2(z, h) - across(float(e @ u), rho)
    return math.degrees(yaw), math.degrees(pitch)


def clip_gaze(yaw: float, pitch: float, settings) -> tuple:
    """(yaw, pitch) within the neck's limits: ``|yaw| ≤ gaze_turn_max``,
    ``-gaze_down_max ≤ pitch ≤ gaze_up_max`` (degrees)."""
    return (float(np.clip(yaw, -settings.gaze_turn_max, settings.gaze_turn_max)),
            float(np.clip(pitch, -settings.gaze_down_max, settings.gaze_up_max)))


def axis_rotation(axis, angle_deg) -> np.ndarray:
    """The 3×3 rotation by ``angle_deg`` about the unit ``axis`` (Rodrigues)."""
    k = np.asarray(axis, dtype=float)
    t = math.radians(float(angle_deg))
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(t) * kx + (1.0 - math.cos(t)) * (kx @ kx)


def gaze_rotation(forward, up, yaw: float, pitch: float) -> np.ndarray:
    """The head's turn :math:`R_u(ψ)\\,R_s(φ)` (3×3, in the frame of ``forward`` and
    ``up``): it takes ``forward`` to the direction :func:`gaze_angles` read."""
    f = np.asarray(forward, dtype=float)
    u = np.asarray(up, dtype=float)
    return axis_rotation(u, yaw) @ axis_rotation(np.cross(f, u), pitch)


def gaze_blend(aims, starts, fps: float, settings) -> np.ndarray:
    """The (yaw, pitch) the head takes on each frame (F, 2): ``aims`` (F, 2) the clipped
    aim at each frame's target, ``starts`` (F,) the frame (index) its target was taken up
    on. From each start the head goes from where it was the frame before (neutral, 0, on
    the first) to the aim on a minimum-jerk curve over ``Settings.gaze_time`` seconds,
    following the aim as it moves, then keeps to it; each angle changes by at most
    ``Settings.gaze_speed / fps`` a frame."""
    aims = np.asarray(aims, dtype=float)
    out = np.zeros_like(aims)
    frames = max(1.0, float(settings.gaze_time) * float(fps))
    most = float(settings.gaze_speed) / float(fps)
    held, start = np.zeros(2), None
    for k, s in enumerate(starts):
        if s != start:
            start = s
            held = out[k - 1] if k > 0 else np.zeros(2)
        w = minimum_jerk((k - start) / frames)
        out[k] = held + w * (aims[k] - held)
        before = out[k - 1] if k > 0 else np.zeros(2)
        out[k] = before + np.clip(out[k] - before, -most, most)
    return out
