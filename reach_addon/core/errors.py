"""The core's one exception type.

Everything the planner rejects as *bad input* (NaN coordinates, a zero-length bone, an
unknown setting) raises :class:`ReachError` with a message a user can act on: it names the
thing that is wrong and says what to do. The Blender operators turn it into
``self.report({'ERROR'}, ...)``; the command line prints it on one stderr line and exits
with status 2.

A target the arm cannot reach is *not* an error: the planner answers it with a failed
:class:`~reach_addon.core.results.Plan` and one of the reasons in :data:`REASONS`.
"""

from __future__ import annotations

import numpy as np

#: Why a plan failed. Each is a distinct, documented outcome (never raised).
OUT_OF_REACH = "out_of_reach"              # too high or too low even stepping, or joint limits
NEEDS_LEAN = "needs_lean"                  # beyond the arm; leaning the trunk would reach it
NEEDS_STEP = "needs_step"                  # beyond the arm and a lean; a step closer would
TARGET_IN_OBSTACLE = "target_in_obstacle"  # inside an obstacle (or the character's body)
ARM_DOES_NOT_FIT = "arm_does_not_fit"      # in free space, but the arm or hand has no room
NO_PATH = "no_path"
START_IN_COLLISION = "start_in_collision"
START_HELD = "start_held"                  # clear, but no step from the start is; names what
#: planned and keyed, but the rig as Blender evaluates the keys puts the wrist off the
#: target (its constraints move the arm otherwise than Reach models them): a fault of
#: Reach's reading of the rig, reported rather than called a success
RIG_OFF_TARGET = "rig_off_target"
#: planned and keyed to where the target stood on the start frame, but the target as
#: Blender evaluates it has moved away by the frame the wrist arrives (keys, a parent, a
#: constraint): a reach for a target that stands still, reported rather than called a
#: success (the chase task follows a moving target)
TARGET_MOVED = "target_moved"
REASONS = (OUT_OF_REACH, NEEDS_LEAN, NEEDS_STEP, TARGET_IN_OBSTACLE, ARM_DOES_NOT_FIT, NO_PATH,
           START_IN_COLLISION, START_HELD, RIG_OFF_TARGET, TARGET_MOVED)


class ReachError(ValueError):
    """Bad input to the planner: the message names the culprit and the fix."""


def require_finite(name: str, values) -> np.ndarray:
    """Return ``values`` as a float array, or raise :class:`ReachError` if it holds NaN/inf.

    ``name`` is what the user knows the value as (``"target 'Cup'"``, ``"upper arm length"``).
    """
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ReachError(f"{name} is not a number ({values!r})") from exc
    if not np.isfinite(array).all():
        raise ReachError(
            f"{name} is not finite ({np.round(array, 6).tolist()}); "
            "fix the transform or value that produced it"
        )
    return array
