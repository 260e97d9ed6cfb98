"""Plan a motion among obstacles that move while it lasts (:func:`plan_among_moving`).

Obstacles are *pieces*: ``(label, vertices, triangles)`` with world-space vertices (n, 3)
and triangles (m, 3) of vertex indices; the same label may come several times, as one
obstacle at several instants. Where the moving obstacles are over a range of frames comes
from the caller (a callback), so nothing here reads a scene.
"""

from __future__ import annotations

import re

import numpy as np

from . import NO_PATH, START_IN_COLLISION, Obstacles, Planner
from .collision import CollisionChecker

#: Most times a motion is planned again because it outlasted the frames swept so far.
SWEEP_ROUNDS = 6


def obstacles_from_pieces(pieces) -> Obstacles:
    """One BVH (:class:`~reach_addon.core.Obstacles`) of ``pieces`` [(label, vertices,
    triangles)], each label one obstacle; ``Obstacles(None)`` (nothing) for no pieces."""
    if not pieces:
        return Obstacles(None)
    labels: dict[str, int] = {}
    verts, tris, owners, parts = [], [], [], []
    offset = 0
    for k, (label, v, t) in enumerate(pieces):
        owner = labels.setdefault(label, len(labels))
        verts.append(v)
        tris.append(t + offset)
        owners.append(np.full(len(t), owner))
        parts.append(np.full(len(t), k))
        offset += len(v)
    return Obstacles.from_triangles(np.concatenate(verts), np.concatenate(tris),
                                    np.concatenate(owners), list(labels), np.concatenate(parts))


def plan_among_moving(planner, task, first_frame: int, still, moving, sweep):
    """Plan ``task`` with ``planner`` and, where obstacles move while the motion lasts,
    again against every place they take: a step generator (yields the planners' progress,
    (fraction, message)) that returns ``(plan, planner)``, the plan and the planner that
    made it.

    Inputs: ``planner`` (:class:`~reach_addon.core.Planner`) among the obstacles of the
    first frame; ``first_frame`` the frame of the motion's first pose; ``still`` the pieces
    the first planner's obstacles were built from; ``moving`` the names of the obstacles
    that move (for messages; empty: nothing moves, the first plan is the answer);
    ``sweep(f0, f1)`` a callback returning ``{frame: [pieces at each instant sampled in
    that frame, the frame itself first]}`` of the moving obstacles, for frames f0..f1.

    When the first plan has a reach that succeeds, the frames its motion lasts are swept
    (twice as many as it needs, so a slower motion still fits), the task is planned again
    among ``still`` and every swept piece, and again, with more frames swept, while the
    new motion outlasts them (at most :data:`SWEEP_ROUNDS` times). The result is then
    checked frame by frame (:func:`check_moving`)."""
    plan = yield from planner.plan_steps(task)
    if not moving or not any(seg.success for seg in plan.segments):
        return plan, planner
    clear_start = {seg.index for seg in plan.segments if seg.reason != START_IN_COLLISION}
    swept, covered = {}, first_frame - 1
    for _round in range(SWEEP_ROUNDS):
        last = first_frame + len(plan.poses) - 1
        if last <= covered:
            break
        upto = first_frame + 2 * (len(plan.poses) - 1)
        swept.update(sweep(covered + 1, upto))
        covered = upto
        union = list(still) + [p for instants in swept.values() for ps in instants for p in ps]
        planner = Planner(planner.arm, obstacles_from_pieces(union), planner.settings)
        plan = yield from planner.plan_steps(task)
    _name_what_comes(plan, first_frame, swept, clear_start, planner.settings)
    check_moving(plan, first_frame, swept, covered, moving, planner.settings)
    return plan, planner


def coming_into(message: str):
    """(obstacle name, frame) of a refusal :func:`_name_what_comes` worded (an obstacle
    that moves into the start pose on a later frame), else None."""
    found = _COMING.search(message or "")
    return (found.group(1), int(found.group(2))) if found else None


_COMING = re.compile(r"'(.+?)' moves into the arm's start pose \(at the [^)]*\) on frame (-?\d+)")


def _name_what_comes(plan, first_frame: int, swept, clear_start, settings) -> None:
    """A start refused among every place the moving obstacles take, clear on its own frame
    (segments ``clear_start``): the obstacle moves into the start pose later. Say so, and
    on which frame (the first of ``swept`` whose pieces meet the start pose), in place of
    "the start pose touches", which the start frame belies."""
    start = plan.world_joints()[0]
    touching = settings.replace(clearance=0.0)
    for seg in plan.segments:
        if seg.reason != START_IN_COLLISION or seg.index not in clear_start:
            continue
        for frame in sorted(swept):
            pieces = [p for ps in swept[frame] for p in ps]
            hit = CollisionChecker(plan.arm, obstacles_from_pieces(pieces), touching) \
                .first_hit(start) if pieces else None
            if hit is not None:
                seg.message = (
                    f"'{hit[1]}' moves into the arm's start pose (at the {hit[0]}) on frame "
                    f"{frame}, while the reach for '{seg.name}' lasts (it starts on frame "
                    f"{first_frame}, clear): Reach moves the arm, not the body, so the body "
                    "cannot get out of its way; stop its animation during the reach, or move "
                    "the character")
                break


def check_moving(plan, first_frame: int, swept, covered: int, moving, settings) -> None:
    """Fail, in place, each successful segment of ``plan`` (first pose on ``first_frame``)
    whose motion touches a moving obstacle where that obstacle is on that frame
    (``swept[frame][0]``: its pieces on the frame, as :func:`plan_among_moving` sweeps
    them), or outlasts the last frame swept (``covered``). Contact on the first frames is
    allowed while the arm leaves a contact it starts in. Only the frames of the segments
    that succeeded are checked. A failed segment gets :data:`~reach_addon.core.NO_PATH`
    and a message naming the ``moving`` obstacles, what happened and what to do.
    ``settings``: the planner's (its clearance is not used: contact is what counts)."""
    done = [seg for seg in plan.segments if seg.success]
    if not done:
        return
    checked = {i for seg in done for i in range(seg.frame_start, seg.frame_end + 1)}
    problem = None
    if first_frame + max(checked) > covered:
        problem = "outlasts every frame swept"
    else:
        problem = _first_touch(plan, first_frame, swept, checked, settings.replace(clearance=0.0))
    if problem is None:
        return
    names = ", ".join(f"'{n}'" for n in sorted(moving))
    for seg in plan.segments:
        if seg.success:
            seg.success, seg.reason = False, NO_PATH
            seg.message = (f"{names} {'moves' if len(moving) == 1 else 'move'} while the arm "
                           f"reaches for '{seg.name}' and the "
                           f"best motion clear of every place they take {problem}; stop "
                           "their animation during the reach, or move the target")


def _first_touch(plan, first_frame, swept, checked, touching):
    """Where the plan's first pose among ``checked`` (pose indices) touches the moving
    obstacles of its frame, after any contact it starts in: "meets '<obstacle>' at frame
    <f> (its <part>)"; None if none does."""
    leaving = True
    for i, joints in enumerate(plan.world_joints()):
        if i not in checked:
            leaving = False
            continue
        at = swept.get(first_frame + i, [[]])[0]
        hit = (CollisionChecker(plan.arm, obstacles_from_pieces(at), touching)
               .first_hit(joints) if at else None)
        if hit is None:
            leaving = False
        elif not leaving:
            return f"meets '{hit[1]}' at frame {first_frame + i} (its {hit[0]})"
    return None
