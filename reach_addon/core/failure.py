"""Why a reach failed, in words: the reason (one of
:data:`~reach_addon.core.errors.REASONS`) and a message that says what to do.

:func:`explain_failure` reads the target's diagnosis
(:func:`~reach_addon.core.diagnosis.diagnose_target`), else what holds
an arm that never left its start (:class:`~reach_addon.core.diagnosis.Hold`), else
``no_path``. Sizes in messages are given in centimetres and arm lengths.
"""

from __future__ import annotations

import numpy as np

from .arm import ArmModel, Pose
from .body_capsules import body_capsules_at, body_hit
from .diagnosis import what_holds
from .errors import (ARM_DOES_NOT_FIT, NEEDS_LEAN, NEEDS_STEP, NO_PATH, OUT_OF_REACH, START_HELD,
                     START_IN_COLLISION, TARGET_IN_OBSTACLE)
from .search import SearchResult, sphere_directions


#: The tasks the body leans and squats for, as the refusals name them
#: (``whole_body.BODY_TASKS``).
BODY_TASKS_SAID = "a single reach, a sequence or a guided reach"
#: The tasks the body steps for (``whole_body.STEP_TASKS``).
ONE_TARGET = "a reach or guided reach to one target"


def explain_failure(generator, name: str, result: SearchResult, diagnosis, start: Pose):
    """(reason, message) of the failed reach to target ``name`` from ``start``, planned
    with ``generator`` (its arm and settings): the ``diagnosis``'s
    (:func:`~reach_addon.core.diagnosis.diagnose_target`, None: reachable), else what holds an
    arm whose ``result`` never left the start, else ``no_path``."""
    arm, settings = generator.arm, generator.settings
    length = arm.arm_length
    gap = result.closest_distance / length
    closest = f"closest approach {gap:.2f} arm lengths"

    def size(x):     # figure units, as centimetres and arm lengths
        return f"{100.0 * x * arm.metres_per_unit:.1f} cm, {x / length:.3f} arm lengths"

    d = diagnosis
    inside = body_contact(arm, start) if d is None else None
    if inside is not None:
        # a start inside the character's own body capsules: the search cannot leave it
        # (every step it tries is inside too), which is the start's fault, not the path's
        part, capsule = inside
        return START_IN_COLLISION, (
            f"the start pose has the {part} inside the character's own body (its "
            f"'{capsule}' capsule, sized from the shoulder width), so no clear path to "
            f"target '{name}' leaves it ({result.nodes_searched} tested positions, "
            f"{closest}); pose the arm clear of the body on the start frame, or start "
            "from a frame where it is")
    held = what_holds(generator.for_reach(start, result.target), start,
                      sphere_directions(int(settings.directions))) \
        if d is None and len(result.path) == 1 else None
    if held is not None:
        return START_HELD, held_message(settings, name, held, closest)
    if d is None:
        return NO_PATH, (
            f"no collision-free path to target '{name}' within {result.nodes_searched} "
            f"tested positions and {result.states_tested} sampled states ({closest}); "
            "try the guided task, a larger sampling budget or a smaller clearance")
    if d.reason == NEEDS_LEAN:
        return NEEDS_LEAN, (
            f"target '{name}' is out of reach by {size(d.missing)} without leaning "
            f"({d.distance / length:.2f} arm lengths from the shoulder): leaning the trunk "
            f"about {d.lean_deg:.0f}° would reach it ({closest}); " + (
                f"with Lean on {BODY_TASKS_SAID} leans" if settings.lean else
                f"turn on Lean to lean first ({BODY_TASKS_SAID})") +
            ", or move the target or the character closer")
    if d.reason == NEEDS_STEP:
        return NEEDS_STEP, (
            f"target '{name}' is out of reach even leaning {settings.lean_max:.0f}° "
            f"({d.distance / length:.2f} arm lengths from the shoulder): it needs a step "
            f"of at least {size(d.missing)} toward it ({closest}); " + (
                f"with Lean and Step on {ONE_TARGET} steps toward it"
                if settings.lean and settings.stepping else
                f"turn on Lean and Step to step toward it first ({ONE_TARGET})") +
            ", or move the character or the target")
    if d.reason == OUT_OF_REACH:
        if d.missing <= 0:
            where = "no legal arm pose puts the wrist there (joint limits)"
        elif d.above:
            where = f"{size(d.missing)} above what the arm reaches from the shoulder"
        else:
            where = (f"{size(d.missing)} below what the arm reaches from the shoulder, and "
                     f"leaning {settings.lean_max:.0f}° does not bring it within reach: "
                     "only a squat or a knee down would" + (
                         f": with Lean and Squat on {BODY_TASKS_SAID} squats"
                         if settings.lean and settings.squat else
                         f": turn on Lean and Squat to squat first ({BODY_TASKS_SAID})"))
        return OUT_OF_REACH, (
            f"target '{name}' is out of reach: {where} ({closest}); move the target")
    if d.reason == ARM_DOES_NOT_FIT:
        radius = {"hand": arm.hand_radius, "upper arm": arm.upper_arm_radius}.get(
            d.part, arm.forearm_radius)
        return ARM_DOES_NOT_FIT, (
            f"the {d.part} does not fit at target '{name}' (the target is in free space): "
            f"its best pose there lacks {size(d.missing)} of room against '{d.obstacle}' "
            f"(the {d.part}'s radius is {size(radius)}, the clearance "
            f"{size(generator.checker.margin)}); widen the gap, move the target or lower the "
            "clearance")
    return TARGET_IN_OBSTACLE, (
        f"target '{name}' is inside obstacle '{d.obstacle}': no pose puts the wrist there "
        f"({closest}); move the target out of it")

def held_message(settings, name: str, held, closest: str) -> str:
    """The message of a reach whose arm cannot move from its start pose (``held``, a
    :class:`~reach_addon.core.diagnosis.Hold`): what holds it and what to do."""
    share = f"{held.steps} of the {held.tried} steps the search tries from it"
    st = settings
    if held.kind == "obstacle":
        cause = (f"'{held.what}' is in the way of the {held.part} ({share}); move "
                 f"'{held.what}' back or pose the arm clear of it on the start frame")
    elif held.kind == "body":
        cause = (f"the {held.part} would pass through the character's own body (its "
                 f"'{held.what}' capsule; {share}); pose the arm away from the body on "
                 "the start frame")
    elif held.kind == "hand":
        cause = (f"the hand has no clear way to turn ({share}); pose the hand clear of "
                 "what is near it on the start frame")
    elif held.kind == "smoothness":
        cause = (f"every step would turn a joint more than {st.max_joint_step:g}° at once, "
                 f"the Smoothness setting ({share}): raise it, or, if the arm starts "
                 "straight at the edge of its reach, bend the elbow a little on the start "
                 "frame")
    elif held.kind == "reach":
        cause = f"the wrist is at the edge of the arm's reach ({share})"
    else:
        cause = (f"no pose a step from it is within the joint limits ({share}); pose the "
                 "arm inside its limits on the start frame or widen them (body presets)")
    return (f"the arm cannot move from its start pose toward target '{name}': {cause} "
            f"({closest})")


def body_contact(arm: ArmModel, pose: Pose):
    """(part, capsule name) of the first part of ``pose`` (the elbow half of the upper arm,
    the forearm, the hand) inside one of the character's own body capsules
    (:func:`~reach_addon.core.body_capsules.body_hit`), or None."""
    if not arm.body_capsules:
        return None
    hit = body_hit(arm, np.asarray(pose.joints, dtype=float).tolist(),
                   body_capsules_at(arm, pose.config.body_rotation))
    return None if hit is None else (hit[0], arm.body_capsules[hit[1]].name)

