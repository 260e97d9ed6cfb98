"""Reach's planner: the method of Zhao, Liu & Badler (SAE 2005) as pure Python.

This package never imports ``bpy``. It works on numpy arrays, plain settings and, for
collisions, a ``mathutils.bvhtree.BVHTree`` handed in by the caller (``mathutils`` is part
of Blender; with the bpy wheel it becomes importable once ``bpy`` has been imported).

Entry point: :func:`plan` (or a :class:`Planner`, which keeps the workspace between plans).
Why each module is built as it is: ``docs/design/core.md``.
"""

from .arm import ArmConfig, ArmModel, Capsule, Pose, config_from_joints, forward_kinematics
from .collision import Obstacles
from .errors import (ARM_DOES_NOT_FIT, NEEDS_LEAN, NEEDS_STEP, NO_PATH, OUT_OF_REACH, REASONS,
                     RIG_OFF_TARGET, START_HELD, START_IN_COLLISION, TARGET_IN_OBSTACLE,
                     TARGET_MOVED, ReachError)
from .settings import Settings
from .planner import Planner, plan
from .results import Plan, Segment, Stats
from .tasks import TASK_KINDS, Task

__all__ = [
    "ArmConfig", "ArmModel", "Capsule", "Pose", "config_from_joints", "forward_kinematics",
    "Obstacles", "ReachError", "REASONS", "OUT_OF_REACH", "TARGET_IN_OBSTACLE", "NO_PATH",
    "START_IN_COLLISION", "START_HELD", "NEEDS_LEAN", "NEEDS_STEP", "ARM_DOES_NOT_FIT",
    "RIG_OFF_TARGET", "TARGET_MOVED",
    "Settings", "TASK_KINDS", "Plan", "Planner", "Segment", "Stats",
    "Task", "plan",
]
