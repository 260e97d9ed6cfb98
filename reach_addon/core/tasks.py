"""The task a caller asks the planner for: :class:`Task` and the four kinds of
:data:`TASK_KINDS`.

* ``reach`` — collision-free reach toward one target (straight, or through the guiding
  nodes where an obstacle lies across the straight line);
* ``sequence`` — rotation reach: several targets in order, each reach starting where the
  last ended;
* ``guided`` — guided reach: the search follows the workspace's guiding nodes;
* ``chase`` — chase reach: one target position per frame, re-planned every frame.

Targets are in **world space**; the start is a configuration of the canonical arm frame
(:mod:`~reach_addon.core.arm`). :class:`Task` checks its input and raises
:class:`~reach_addon.core.errors.ReachError` with what to fix.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .arm import ArmConfig
from .errors import ReachError, require_finite

TASK_KINDS = ("reach", "sequence", "guided", "chase")


@dataclass(frozen=True)
class Task:
    """What to plan. ``targets``: world positions (k, 3) — one for ``reach``, one or more in
    order for ``sequence`` and ``guided``, one per frame for ``chase`` (frame 0 first).
    ``start``: the arm's configuration at the first frame. ``duration_s``: seconds per
    reach (None = from the path length, :func:`~reach_addon.core.motion.auto_duration`).
    ``names``: what the user calls each target (for messages). ``start_hand``: the wrist's
    two angles at the first frame (:func:`~reach_addon.core.arm.hand_angles`; the rig's
    own hand), which the motion starts from. ``orientations``: the targets' world rotations
    (k, 3, 3), for ``Settings.match_orientation`` (:mod:`~reach_addon.core.orient`; None:
    positions only). ``start_palm``: the palm's normal at the first frame (canonical; the
    rig's, :func:`~reach_addon.blender.hand_reading.palm_normal`), None for the palm at forearm
    neutral; ``start_fingers``: the fingers' direction then (canonical; the wrist to the
    middle finger's knuckle, :func:`~reach_addon.blender.hand_reading.finger_axis`), None for the
    hand's own direction."""

    kind: str
    targets: np.ndarray
    start: ArmConfig
    fps: float = 24.0
    duration_s: float | None = None
    names: tuple = ()
    start_hand: tuple = (0.0, 0.0)
    orientations: np.ndarray | None = None
    start_palm: np.ndarray | None = None
    start_fingers: np.ndarray | None = None

    def __post_init__(self):
        if self.kind not in TASK_KINDS:
            raise ReachError(f"unknown task '{self.kind}'; choose one of {', '.join(TASK_KINDS)}")
        targets = require_finite("target position", self.targets).reshape(-1, 3)
        if len(targets) == 0:
            raise ReachError(f"the {self.kind} task has no target; give at least one")
        if self.kind == "reach" and len(targets) != 1:
            raise ReachError("a reach task takes exactly one target; use 'sequence' for several")
        if self.kind == "chase" and len(targets) < 2:
            raise ReachError("a chase needs the target's position on at least two frames")
        object.__setattr__(self, "targets", targets)
        require_finite("start configuration", self.start.as_array())
        if not (self.fps > 0 and math.isfinite(self.fps)):
            raise ReachError(f"frame rate must be positive, got {self.fps}")
        if self.duration_s is not None and not (self.duration_s > 0):
            raise ReachError(f"duration must be positive seconds, got {self.duration_s}")
        if self.orientations is not None:
            rot = require_finite("target rotation", self.orientations).reshape(-1, 3, 3)
            if len(rot) != len(targets):
                raise ReachError(f"{len(rot)} target rotations for {len(targets)} targets; "
                                 "give one per target")
            object.__setattr__(self, "orientations", rot)
        if self.start_palm is not None:
            object.__setattr__(self, "start_palm", require_finite("palm normal", self.start_palm))
        if self.start_fingers is not None:
            object.__setattr__(self, "start_fingers",
                               require_finite("finger direction", self.start_fingers))

    def name(self, i: int) -> str:
        return self.names[i] if i < len(self.names) else f"target {i + 1}"
