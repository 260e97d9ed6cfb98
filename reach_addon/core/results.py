"""What a plan returns: :class:`Plan` (poses per frame, :class:`Segment` per target,
:class:`Stats`) and :class:`Route`, the result of one search with its fallbacks.

Poses are in the canonical arm frame (:meth:`Plan.world_joints` gives world space);
lengths in :class:`Stats` are in arm lengths, times in seconds, angles in degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .arm import ArmModel
from .hand_shape import world_pose
from .search import SearchResult
from .settings import Settings
from .tasks import Task
from .workspace import Workspace


class Route(NamedTuple):
    """What :meth:`Planner.route_steps` found: the search's (or the sampler's) result, the
    target's diagnosis (None: reachable, or not needed because the path was found) and
    whether the sampling planner ran."""

    result: SearchResult
    diagnosis: object
    sampled: bool


@dataclass
class Stats:
    """Table 2's statistics (first five fields) and more, for a segment or a whole plan.
    Lengths are in arm lengths."""

    search_time_s: float = 0.0
    preprocess_time_s: float = 0.0
    nodes_searched: int = 0
    nodes_in_solution: int = 0
    path_length_arm_lengths: float = 0.0
    motion_path_length_arm_lengths: float = 0.0
    frames: int = 0
    strength_categories: list = field(default_factory=lambda: [0, 0, 0])
    min_clearance_arm_lengths: float = math.inf
    planning_time_s: float = 0.0
    # the hand (core.hand): turns per frame relative to the forearm and in space, the
    # wrist's bend from neutral, frames added to slow through tight spots, and what the
    # pass could not bring within its bounds
    max_wrist_turn_deg_per_frame: float = 0.0
    max_hand_turn_deg_per_frame: float = 0.0
    mean_wrist_bend_deg: float = 0.0
    max_wrist_bend_deg: float = 0.0
    inserted_frames: int = 0
    unbounded_hand_turns: int = 0
    touching_transitions: int = 0
    # frames with the elbow lifted over a low hand (core.elbow.chicken_wing)
    chicken_wing_frames: int = 0
    # states the sampling fallback (core.sampling) tested, beyond the nodes searched
    sampling_states: int = 0
    # match orientation (core.orient): the angle left between the palm's frame and the
    # wanted one at the last frame, and whether it is within the tolerance (None: not asked)
    orientation_error_deg: float | None = None
    orientation_met: bool | None = None

    @property
    def mean_f_r(self) -> float:
        n = sum(self.strength_categories)
        return (self.strength_categories[1] + 2 * self.strength_categories[2]) / n if n else 0.0

    def add(self, other: Stats) -> None:
        n = self.frames + other.frames
        if n:
            self.mean_wrist_bend_deg = (self.mean_wrist_bend_deg * self.frames
                                        + other.mean_wrist_bend_deg * other.frames) / n
        for name in ("max_wrist_turn_deg_per_frame", "max_hand_turn_deg_per_frame",
                     "max_wrist_bend_deg"):
            setattr(self, name, max(getattr(self, name), getattr(other, name)))
        for name in ("inserted_frames", "unbounded_hand_turns", "touching_transitions",
                     "chicken_wing_frames", "sampling_states",
                     "search_time_s", "preprocess_time_s", "nodes_searched",
                     "nodes_in_solution", "path_length_arm_lengths",
                     "motion_path_length_arm_lengths", "frames",
                     "planning_time_s"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.strength_categories = [a + b for a, b in
                                    zip(self.strength_categories, other.strength_categories)]
        self.min_clearance_arm_lengths = min(self.min_clearance_arm_lengths,
                                             other.min_clearance_arm_lengths)
        if other.orientation_error_deg is not None:       # the worst target's
            self.orientation_error_deg = max(self.orientation_error_deg or 0.0,
                                             other.orientation_error_deg)
            self.orientation_met = self.orientation_met is not False and bool(other.orientation_met)

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in self.__dataclass_fields__}
        d["mean_f_r"] = self.mean_f_r
        if math.isinf(d["min_clearance_arm_lengths"]):
            d["min_clearance_arm_lengths"] = None
        return d


@dataclass
class Segment:
    """One target's part of a plan: frames ``frame_start``..``frame_end`` (indices into
    ``Plan.poses``; the wrist arrives at the target on ``frame_end`` when successful)."""

    index: int
    name: str
    target: np.ndarray
    success: bool
    reason: str | None
    message: str
    frame_start: int
    frame_end: int
    stats: Stats
    search_path: np.ndarray       # world wrist positions of the searched solution path
    guiding_nodes: np.ndarray     # world positions
    #: what found the path: "best-first" (the paper's search) or "sampling" (the
    #: fallback of core.sampling); for a chase, "chase"
    method: str = "best-first"


@dataclass
class Plan:
    """Poses per frame (frame 0 = the start pose) + statistics + success / reason."""

    task: Task
    arm: ArmModel
    settings: Settings
    poses: list
    segments: list
    stats: Stats
    workspace: Workspace | None = None

    @property
    def success(self) -> bool:
        return all(s.success for s in self.segments)

    @property
    def reason(self) -> str | None:
        return next((s.reason for s in self.segments if not s.success), None)

    @property
    def message(self) -> str:
        failed = [s.message for s in self.segments if not s.success]
        if failed:
            return "; ".join(failed)
        return f"reached {len(self.segments)} target(s) in {len(self.poses)} frames"

    def world_joints(self) -> np.ndarray:
        """Joint positions per frame in world space, (frames, 5, 3) in JOINTS order, each
        followed by the hand shape's rows where the arm has one (:mod:`.hand_shape`:
        (frames, 5 + 2K, 3)), as the collision checker takes them."""
        return np.array([world_pose(self.arm, p) for p in self.poses]).reshape(
            len(self.poses), -1, 3)

    def world_bends(self) -> np.ndarray:
        """Forearm bend direction per frame in world space, (frames, 3)."""
        return self.arm.to_world_vectors(np.array([p.bend for p in self.poses]))

    def wrist_trajectory(self) -> np.ndarray:
        return self.world_joints()[:, 3]

    def search_path(self) -> np.ndarray:
        parts = [s.search_path for s in self.segments if len(s.search_path)]
        return np.concatenate(parts) if parts else np.zeros((0, 3))

    def guiding_nodes(self) -> np.ndarray:
        parts = [s.guiding_nodes for s in self.segments if len(s.guiding_nodes)]
        return np.concatenate(parts) if parts else np.zeros((0, 3))
