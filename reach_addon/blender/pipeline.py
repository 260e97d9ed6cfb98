"""The one pipeline: scene + armature → rig model → obstacles → core plan → bake / preview.

The sidebar operators, the command line, batch workers and live mode all call
:func:`run` (or consume :func:`steps`, the same work as a generator that yields progress, for
callers that must stay responsive and may cancel). Nothing here plans or bakes on its own:
planning is :mod:`reach_addon.core`, keys are :mod:`.bake`, drawing is :mod:`.viz`.

Bad input raises :class:`~reach_addon.core.ReachError` *before* anything in the scene is
changed. The scene's current frame is restored when the work ends, however it ends.

A chase samples the target on every frame of its motion (``frame_set``, so keys, parents
and constraints all count) and the obstacles too: while none of them moves the chase is the
core's chase task; when one does (keys, a parent, a deforming modifier), each frame is
planned against the obstacles of that frame (:func:`reach_addon.core.tasks.chase_steps`), a
new BVH being built only for frames where the obstacles' signature changed.

A reach, sequence or guided task plans one motion: where obstacles are animated (keys on
them, their data, parents or constraint targets) past the start frame, the motion is
planned against every place they take while it lasts — each moving obstacle sampled
:data:`SWEEP_SAMPLES` times a frame over the motion's frames, added to the obstacles of
the start frame — and planned again if the new motion lasts longer than what was swept.

Targets carried by the character's own bones: one on a bone of the reaching arm (upper
arm, forearm, hand or below) would move with the hand, so the arm is refused (with
``auto``, the other arm is taken); one on a bone the chest carries (the neck, the head, the
other arm) would move as the chest turns, so the chest is kept still for that request.

A bake is refused, before anything is keyed, where the rig's own animation (a walk on the
hips, keys on the armature object, an NLA strip) would carry the arm off its plan by more
than the goal tolerance while it reaches (:func:`.body.check`). A drawn preview (Plan)
runs the same check on the plans a Bake would key and adds its message to
:attr:`Outcome.warnings` instead: the preview is drawn, and says the Bake would stop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..core import START_HELD, START_IN_COLLISION, Planner, ReachError, Settings, Task
from ..core import envelope as envelope_mod
from ..core.arm import REACH_SLACK, frame_angle, reach_sphere
from ..core.orient import palm_frame, wanted_axes
from ..core.steps import drain, relay
from ..core.chase import chase_steps
from . import bake as bake_mod
from . import body as body_mod
from . import rig as rig_mod
from . import viz
from .scene import (KEPT, ObstacleCache, character_objects, finite, gather_pieces,
                    obstacles_from_pieces, visit_obstacles)

TASKS = ("reach", "sequence", "guided", "chase")
#: Instants per frame at which moving obstacles are sampled for a reach (frame, half way).
SWEEP_SAMPLES = 2
#: Most times a reach is planned again because its motion outlasted the swept frames.
SWEEP_ROUNDS = 6
#: Radius of the drawn trajectory's tube, in arm lengths (6 mm on a 0.6 m arm; the target
#: markers are 0.04): it scales with the figure, as thin beside a 0.2 m figure's hand as
#: beside a grown-up's.
TUBE_RADIUS = 0.01


@dataclass
class Request:
    """What to do. Names refer to objects/collections of the scene."""

    armature: str
    targets: list
    task: str = "reach"
    side: str = "auto"                   # right | left | auto
    obstacles: str | None = None         # a collection name; None = all visible objects
    frame_start: int | None = None       # None = the scene's current frame
    duration_s: float | None = None      # per reach; None = automatic
    settings: Settings = field(default_factory=Settings)
    overrides: dict = field(default_factory=dict)
    new_action: bool = False
    bake_closest: bool = False
    show_guides: bool = False
    draw: bool = True                    # trajectory, markers (off for batch studies)


@dataclass
class TaskResult:
    """One target's outcome, as the report and the panel show it."""

    target: str
    arm: str
    success: bool
    reason: str | None
    message: str
    frame_start: int
    frame_end: int
    bones_keyed: list
    stats: dict
    #: what found the path: "best-first" (the paper's search), "sampling" (the fallback
    #: where it gave up) or "chase"
    method: str = "best-first"
    #: whether Arm: Auto chose ``arm`` (the message then names it, :func:`arm_note`)
    auto: bool = False

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class Outcome:
    request: Request
    rig: rig_mod.RigInfo
    plans: list                          # (Plan, first frame) per planned task
    results: list                        # TaskResult per target, in order
    baked: bool = False
    action: str | None = None
    failure: str | None = None           # why nothing was baked, when baking was asked for
    obstacles: list = field(default_factory=list)   # (name, triangles) of each obstacle used
    #: what a Plan (no keys) found that a Bake of it would refuse (:func:`.body.check`)
    warnings: list = field(default_factory=list)

    @property
    def success(self) -> bool:
        return all(r.success for r in self.results)

    def summary(self) -> dict:
        return {
            "armature": self.rig.armature_name, "arm": self.rig.side, "baked": self.baked,
            "action": self.action, "success": self.success,
            "tasks": [r.to_dict() for r in self.results],
            "obstacles": [{"name": n, "triangles": t} for n, t in self.obstacles],
            "warnings": list(self.warnings),
        }


def arm_note(request: Request, info) -> str:
    """What begins every message of a request whose arm Auto chose, naming that arm
    ("Left arm (Auto): "); "" when the user chose the arm."""
    return f"{info.side.capitalize()} arm (Auto): " if request.side == "auto" else ""


def find_object(name, what):
    """The object called ``name``; a ReachError naming it as the ``what`` (armature,
    target) when the file has none."""
    ob = bpy.data.objects.get(name) if name else None
    if ob is None:
        raise ReachError(f"{what} '{name}' does not exist in this file; check the name")
    return ob


def validate(context, request: Request, bake: bool, need_targets: bool = True):
    """Check the request against the scene; returns (armature, target objects, obstacle
    collection). Raises ReachError naming what is wrong and what to do. ``need_targets``:
    whether a request without targets is an error (the reach envelope needs none)."""
    if request.task not in TASKS:
        raise ReachError(f"unknown task '{request.task}'; choose one of {', '.join(TASKS)}")
    if not request.armature:
        raise ReachError("no armature chosen; pick the character's armature")
    armature = find_object(request.armature, "armature")
    rig_mod.check_armature(armature)
    if not finite(np.array(armature.matrix_world)):
        raise ReachError(f"armature '{armature.name}' has a NaN or infinite transform; fix its "
                         "location, rotation and scale")
    if armature.name not in context.scene.objects:
        raise ReachError(f"armature '{armature.name}' is not in scene '{context.scene.name}'")
    if need_targets and not request.targets:
        raise ReachError("no target chosen; pick the object to reach for")
    targets = [find_object(n, "target") for n in request.targets]
    for t in targets:
        if t == armature:
            raise ReachError(f"the target '{t.name}' is the armature itself; pick the object to "
                             "reach for")
        m = np.array(t.matrix_world)
        if not finite(m):
            raise ReachError(f"target '{t.name}' has a NaN or infinite transform; fix its location")
    if request.side not in ("right", "left", "auto"):
        raise ReachError(f"arm must be right, left or auto, not '{request.side}'")
    collection = None
    if request.obstacles:
        collection = bpy.data.collections.get(request.obstacles)
        if collection is None:
            raise ReachError(f"obstacle collection '{request.obstacles}' does not exist; check "
                             "the name or plan against all visible objects")
    if bake:
        if armature.library is not None:
            raise ReachError(
                f"armature '{armature.name}' is linked from '{armature.library.filepath}' and "
                "cannot be keyed; make a library override (Object > Library Override) first")
        action = armature.animation_data.action if armature.animation_data else None
        if action is not None and action.library is not None and not request.new_action:
            raise ReachError(
                f"the action '{action.name}' of armature '{armature.name}' is linked from a "
                "library and cannot be changed; turn on 'Bake into a new action'")
    return armature, targets, collection


def _animation_end(ob, seen=None):
    """Last frame of the animation that moves ``ob``: its own action and its data's (a
    curve's path time), its parents' and its constraints' targets', followed recursively;
    None if nothing is animated."""
    seen = set() if seen is None else seen
    if ob is None or ob.name in seen:
        return None
    seen.add(ob.name)
    ends = []
    for block in (ob, ob.data):
        ad = getattr(block, "animation_data", None) if block is not None else None
        if ad is not None and ad.action is not None:
            ends.append(ad.action.frame_range[1])
    for other in [ob.parent] + [getattr(c, "target", None) for c in ob.constraints if not c.mute]:
        end = _animation_end(other, seen)
        if end is not None:
            ends.append(end)
    return max(ends) if ends else None


def _chase_range(context, target, frame_start):
    """Frames of a chase: from the start frame to the end of the animation that moves the
    target (keys on it or its data, a parent, a constraint's target such as the curve of a
    Follow Path), else to the scene's end frame."""
    end = _animation_end(target)
    if end is None:
        end = context.scene.frame_end
    end = int(math.ceil(end))
    if end <= frame_start:
        raise ReachError(f"chase target '{target.name}' has no animation after frame "
                         f"{frame_start}; animate it or start earlier")
    return frame_start, end


def reach_bounds(arm, settings: Settings, targets) -> tuple:
    """(centre, radius, target positions), world space: what :meth:`.scene.KeptObstacles.get`
    keeps obstacles within — the arm's reach sphere (:func:`~reach_addon.core.arm.reach_sphere`)
    with :data:`~reach_addon.core.arm.REACH_SLACK` and the clearance to spare, and any
    object holding a target."""
    centre, radius = reach_sphere(arm, REACH_SLACK + settings.clearance)
    return centre, radius, np.array([np.array(t.matrix_world.translation) for t in targets])


def steps(context, request: Request, bake: bool = True):
    """The pipeline as a generator: yields (fraction, message), returns an :class:`Outcome`.
    Closing it early (a cancelled modal operator, at any of its yields) leaves the scene as
    it was: every yield comes before the first change to the scene (keys, drawing), and
    the keys and the drawing are made in the one last step, which does not yield."""
    scene = context.scene
    armature, targets, collection = validate(context, request, bake)
    original_frame = scene.frame_current
    frame_start = scene.frame_current if request.frame_start is None else int(request.frame_start)
    try:
        if scene.frame_current != frame_start:
            scene.frame_set(frame_start)
        context.view_layer.update()
        first = np.array(targets[0].matrix_world.translation)
        info = rig_mod.build(armature, request.side, request.overrides, target=first)
        info, settings, still = _carried_targets(armature, targets, info, request, first)
        yield 0.02, "reading the rig"

        fps = scene.render.fps / scene.render.fps_base
        names = tuple(t.name for t in targets)
        exclude = character_objects(armature, scene) | set(names)
        # Kept from the last run while nothing in them changed (scene.KeptObstacles);
        # objects beyond every pose's reach are left out (core.arm.reach_sphere).
        pieces, obstacles, _built = KEPT.get(context, exclude, collection,
                                             within=reach_bounds(info.arm, settings, targets))
        moving = set() if request.task == "chase" else \
            _moving_owners(context, exclude, collection, frame_start)
        yield 0.05, f"{obstacles.triangle_count} obstacle triangles"

        frame_obstacles = None
        if request.task == "chase":
            f0, f1 = _chase_range(context, targets[0], frame_start)
            path, frame_obstacles = _sample_chase(context, targets[0], exclude, collection,
                                                  obstacles, f0, f1)
            scene.frame_set(frame_start)
            tasks = [Task("chase", np.array(path), info.start, fps, names=names[:1],
                          start_hand=info.start_hand)]
        else:
            positions = np.array([np.array(t.matrix_world.translation) for t in targets])
            rotations = target_rotations(targets) if settings.match_orientation else None
            if request.task == "reach":
                tasks = [Task("reach", positions[i:i + 1], info.start, fps, request.duration_s,
                              names=names[i:i + 1], start_hand=info.start_hand,
                              orientations=None if rotations is None else rotations[i:i + 1],
                              start_palm=info.start_palm, start_fingers=info.start_fingers)
                         for i in range(len(targets))]
            else:
                tasks = [Task(request.task, positions, info.start, fps, request.duration_s,
                              names=names, start_hand=info.start_hand, orientations=rotations,
                              start_palm=info.start_palm, start_fingers=info.start_fingers)]

        planner = Planner(info.arm, obstacles, settings)
        plans = []
        # per plan, the checkers of its obstacles (one per pose, or one for all), for the
        # bake's check between keys (which measures without their margin)
        checkers = []
        frame = frame_start
        for k, task in enumerate(tasks):
            if frame_obstacles is not None and any(o is not obstacles for o in frame_obstacles):
                # Obstacles that move: each frame of the chase against its own obstacles.
                planners = {id(obstacles): planner}
                for o in frame_obstacles:
                    planners.setdefault(id(o), Planner(info.arm, o, settings))
                frame_planners = [planners[id(o)] for o in frame_obstacles]
                plan_steps = chase_steps(frame_planners, task)
            else:
                frame_planners = None
                plan_steps = planner.plan_steps(task)
            plan = yield from _progress(plan_steps, k, len(tasks))
            if moving and any(seg.success for seg in plan.segments):
                # Obstacles that move while the arm does: plan against every place they
                # take over the motion's frames, again if the motion outlasts them; then
                # check each frame's pose against that frame's obstacles. (A motion that
                # fails among the still obstacles fails among more.) Any reach of the plan
                # that succeeded counts: one target of a sequence may fail while the next
                # succeeds, and with "bake closest" both are keyed.
                swept, covered = {}, frame - 1
                for _round in range(SWEEP_ROUNDS):
                    last = frame + len(plan.poses) - 1
                    if last <= covered:
                        break
                    upto = frame + 2 * (len(plan.poses) - 1)
                    swept.update(_sweep(context, exclude, collection, moving, covered + 1, upto))
                    covered = upto
                    scene.frame_set(frame_start)
                    union = pieces + [p for ps in swept.values() for p in ps]
                    planner = Planner(info.arm, obstacles_from_pieces(union), settings)
                    plan = yield from _progress(planner.plan_steps(task), k, len(tasks))
                _check_moving(plan, frame, swept, covered, moving, settings)
            checkers.append([p.generator.checker
                            for p in (frame_planners or [planner])])
            plans.append((plan, frame))
            frame += len(plan.poses)

        _start_as_it_shows(armature, info, plans, obstacles)
        outcome = Outcome(request, info, plans, [], obstacles=obstacles.triangle_counts())
        keyed, baked_result = [], None
        draw = request.draw
        keyable = [p.success or request.bake_closest for p, _f in plans]
        to_key = [pf for pf, k in zip(plans, keyable) if k]
        baked = to_key if bake else []
        checkers = [c for c, k in zip(checkers, keyable) if k]
        # the rig's own animation must not carry the arm off the plan (body.check refuses);
        # a drawn preview (Plan) says so beforehand, for the plans a Bake would key
        if bake or draw:
            try:
                body_mod.check(context, armature, info, to_key, settings, frame_start)
            except ReachError as exc:
                if bake:
                    raise
                outcome.warnings.append(f"a Bake of this plan would stop: {exc}")
        # The last yield: from here on the scene changes (keys, drawing), so nothing below
        # yields and a caller that stops at any yield has changed nothing.
        yield 0.92, "baking keys" if baked else "drawing"
        if bake:
            if baked:
                result = bake_mod.bake(context, armature, info, baked, request.new_action,
                                       checkers=checkers)
                outcome.baked, outcome.action, keyed = True, result.action, result.bones
                baked_result = result
            else:
                # Nothing the user asked for can be baked: leave the scene as it was.
                failed = next(p for p, _f in plans if not p.success)
                outcome.failure = (f"{arm_note(request, info)}{failed.message}; nothing was "
                                   "baked (turn on 'Bake closest approach' to bake the motion "
                                   "that gets closest)")
                draw = False
        outcome.results = _results(info, plans, keyed, request, baked_result)
        if outcome.baked:
            measure_orientation(context, armature, info, outcome.results, settings)
        for r in outcome.results if still else ():
            r.message += f"; {still}"
        if draw:
            _draw(scene, info, plans, planner, request)
        return outcome
    finally:
        if scene.frame_current != original_frame:
            scene.frame_set(original_frame)


@dataclass
class EnvelopeOutcome:
    """The reach envelope of one arm (:mod:`reach_addon.core.envelope`) with where its points
    are: ``world`` (n, 3) and ``shoulder`` (n, 3), the shoulder-frame coordinates (forward,
    outward, up; arm lengths) a batch study's shoulder grid uses."""

    request: Request
    rig: rig_mod.RigInfo
    envelope: envelope_mod.Envelope
    world: np.ndarray
    shoulder: np.ndarray


def envelope_steps(context, request: Request, chunk: int = 64, world=None):
    """The reach envelope of the request's arm at the current frame, as a generator like
    :func:`steps` (yields (fraction, message), returns an :class:`EnvelopeOutcome`). The
    same rig adapter, obstacles and planner as a plan (the request's obstacles, the
    character and its targets left out); the grid and its classes are the core's
    (:func:`reach_addon.core.envelope.envelope_steps`). ``world``: classify these points
    (k, 3) instead of the grid (a batch task's target). Changes nothing in the scene."""
    armature, targets, collection = validate(context, request, bake=False, need_targets=False)
    context.view_layer.update()
    first = np.array(targets[0].matrix_world.translation) if targets else None
    info = rig_mod.build(armature, request.side, request.overrides, target=first)
    yield 0.02, "reading the rig"
    exclude = character_objects(armature, context.scene) | {t.name for t in targets}
    _pieces, obstacles, _built = KEPT.get(context, exclude, collection)
    yield 0.05, f"{obstacles.triangle_count} obstacle triangles"
    s = request.settings
    if world is None:
        coords = envelope_mod.grid_coordinates(s.envelope_resolution, s.envelope_extent)
        points = envelope_mod.shoulder_frame_to_canonical(info.arm, coords)
    else:
        points = info.arm.to_canonical_points(np.atleast_2d(np.asarray(world, dtype=float)))
        coords = envelope_mod.canonical_to_shoulder_frame(info.arm, points)
    planner = Planner(info.arm, obstacles, envelope_mod.exhaustive(s))
    env = yield from relay(envelope_mod.envelope_steps(planner.generator, points, chunk),
                           lambda done: (0.05 + 0.95 * done, f"{round(done * len(points))} of "
                                         f"{len(points)} points"))
    return EnvelopeOutcome(request, info, env, info.arm.to_world_points(points), coords)


def envelope(context, request: Request, world=None) -> EnvelopeOutcome:
    """:func:`envelope_steps` run to its end."""
    return drain(envelope_steps(context, request, world=world))


def target_rotations(targets) -> np.ndarray:
    """The targets' world rotations (k, 3, 3) for *Match orientation*: each object's world
    matrix with its scale divided out of the columns (its local axes in world space; a
    mirrored object keeps its mirrored axes, as the viewport draws them). A target scaled
    to nothing on an axis has no orientation: ReachError naming it."""
    out = []
    for t in targets:
        m = np.array(t.matrix_world)[:3, :3]
        scale = np.linalg.norm(m, axis=0)
        if not (scale > 1e-9).all():
            raise ReachError(f"target '{t.name}' is scaled to zero on an axis, so it has no "
                             "orientation to match; give it a non-zero scale or turn off "
                             "Match orientation")
        out.append(m / scale)
    return np.array(out)


def _progress(plan_steps, k: int, count: int):
    """Drive a planner's steps for task ``k`` of ``count``, yielding the pipeline's
    progress; returns the plan."""
    return relay(plan_steps, lambda progress: (0.05 + 0.85 * (k + progress[0]) / count,
                                               progress[1]))


def _carrying_bone(ob, armature, seen=None):
    """The bone of ``armature`` that carries ``ob``: the bone it (or a parent of it, at any
    depth, or the target of one of their constraints) is parented to or constrained to;
    None if no bone of ``armature`` moves it."""
    seen = set() if seen is None else seen
    while ob is not None and ob.name not in seen:
        seen.add(ob.name)
        for c in getattr(ob, "constraints", ()):
            other = getattr(c, "target", None)
            if c.mute or c.influence <= 0.0 or other is None:
                continue
            if other == armature:
                if getattr(c, "subtarget", ""):
                    return c.subtarget
            else:
                bone = _carrying_bone(other, armature, seen)
                if bone is not None:
                    return bone
        if ob.parent == armature:
            return ob.parent_bone if ob.parent_type == "BONE" and ob.parent_bone else None
        ob = ob.parent
    return None


def _under(armature, bone_name, names) -> bool:
    """Is bone ``bone_name`` one of ``names`` or below one of them?"""
    bone = armature.data.bones.get(bone_name)
    while bone is not None:
        if bone.name in names:
            return True
        bone = bone.parent
    return False


def _carried_targets(armature, targets, info, request, first):
    """Targets carried by the character's bones (see the module doc). Returns the rig
    (the other arm's, with ``auto``, when the chosen one carries a target) and the
    settings (chest rotation off when the chest carries a target) and a note saying so for
    the results (else None)."""
    settings = request.settings
    carried = [(t, b) for t in targets if (b := _carrying_bone(t, armature)) is not None]
    if not carried:
        return info, settings, None

    def on_arm(rig):
        a = rig.bones.arms[rig.side]
        names = {a.upper_arm, a.forearm, a.hand} | {a.keyed(r) for r in ("upper_arm", "forearm",
                                                                          "hand")}
        return [(t, b) for t, b in carried if _under(armature, b, names)]

    if on_arm(info) and request.side == "auto":
        other = rig_mod.build(armature, "left" if info.side == "right" else "right",
                              request.overrides, target=first)
        if not on_arm(other):
            info = other
    held = on_arm(info)
    if held:
        t, b = held[0]
        raise ReachError(f"target '{t.name}' is carried by bone '{b}' of the {info.side} arm, "
                         "which the reach moves, so the hand could never arrive on it; parent "
                         "it to something that stays still, or reach with the other arm")
    a = info.bones.arms[info.side]
    chest = {info.bones.chest, info.bones.keyed_chest, a.clavicle, a.keyed("clavicle")} - {None}
    on_chest = [(t, b) for t, b in carried if _under(armature, b, chest)]
    if settings.chest_rotation and on_chest:
        t, b = on_chest[0]
        return info, settings.replace(chest_rotation=False), (
            f"the chest was kept still: target '{t.name}' is carried by bone '{b}', which "
            "turns with the chest, so turning the chest would move it; parent the target to "
            "something that stays still to let the chest turn")
    return info, settings, None


def _moving_owners(context, exclude, collection, frame) -> set:
    """Owners of obstacle pieces animated after ``frame``: keys on the object or its data,
    a parent or a constraint target (:func:`_animation_end`), of the owner or of the
    object an instance comes from."""
    moving = set()
    for _piece, (owner, name) in visit_obstacles(context, lambda p, _ob: (p.owner, p.name),
                                                 exclude, collection):
        for n in {owner, name}:
            end = _animation_end(bpy.data.objects.get(n))
            if end is not None and end > frame:
                moving.add(owner)
    return moving


def _sweep(context, exclude, collection, moving, f0, f1) -> dict:
    """{(frame, sample): pieces of the ``moving`` obstacles} at :data:`SWEEP_SAMPLES`
    instants of every frame f0..f1."""
    scene = context.scene
    out = {}
    for f in range(f0, f1 + 1):
        for k in range(SWEEP_SAMPLES):
            scene.frame_set(f, subframe=k / SWEEP_SAMPLES)
            out[(f, k)] = gather_pieces(context, exclude, collection, only=moving)
    return out


def _check_moving(plan, frame, swept, covered, moving, settings):
    """Fail a successful ``plan`` (first frame ``frame``) whose pose on some frame touches
    a moving obstacle where that obstacle is on that frame, or whose motion outlasted the
    swept frames (what it meets after them is unknown). Contact on the first frames is
    allowed while the arm leaves a contact it starts in, as with still obstacles. Only the
    frames of the reaches that succeeded are checked (a failed one's closest motion is
    reported as failed already)."""
    done = [seg for seg in plan.segments if seg.success]
    if not done:
        return
    checked = {i for seg in done for i in range(seg.frame_start, seg.frame_end + 1)}
    from ..core import NO_PATH
    from ..core.collision import CollisionChecker

    touching = settings.replace(clearance=0.0)
    problem = None
    if frame + max(checked) > covered:
        problem = "outlasts every frame swept"
    else:
        leaving = True
        for i, joints in enumerate(plan.world_joints()):
            if i not in checked:
                leaving = False
                continue
            at = swept.get((frame + i, 0), [])
            hit = (CollisionChecker(plan.arm, obstacles_from_pieces(at), touching)
                   .first_hit(joints) if at else None)
            if hit is None:
                leaving = False
            elif not leaving:
                problem = f"meets '{hit[1]}' at frame {frame + i} (its {hit[0]})"
                break
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


def _sample_chase(context, target, exclude, collection, obstacles, f0, f1):
    """The target's world position on every frame f0..f1 (keys, parents, constraints all
    evaluated by ``frame_set``), and the obstacles on every frame: the same
    :class:`~reach_addon.core.Obstacles` while nothing moves, a new BVH for frames where an
    obstacle moved or changed shape (the signature of :class:`.scene.ObstacleCache`)."""
    scene = context.scene
    cache = ObstacleCache(exclude, collection.name if collection is not None else None)
    path, frames = [], []
    for f in range(f0, f1 + 1):
        scene.frame_set(f)
        path.append(np.array(target.matrix_world.translation))
        if f == f0:
            cache.obstacles = obstacles
            cache.signature = cache.compute_signature(context, geometry=True)
        frames.append(cache.get(context, geometry=True)[0])
    return path, frames


def run(context, request: Request, bake: bool = True) -> Outcome:
    """Run the pipeline to the end (see :func:`steps`)."""
    return drain(steps(context, request, bake))


def _results(info, plans, keyed, request, baked_result=None):
    """A :class:`TaskResult` per target; a failed one's message begins with the arm when
    Auto chose it (:func:`arm_note`). ``baked_result``: the bake's
    :class:`.bake.BakeResult`, in each baked task's statistics as
    ``rig_residual_arm_lengths`` (how far the rig put a planned joint; 0 on rigs whose keys
    carry the arm exactly), ``linear_spans`` (spans between keys made linear so that
    Blender's curve keeps clear, :func:`.bake.straighten`) and ``close_spans`` (spans
    still too close after it; 0 when every instant is clear)."""
    out = []
    index = -1           # the plan's place among the baked ones
    for plan, first in plans:
        baked = plan.success or request.bake_closest
        index += baked
        for seg in plan.segments:
            stats = seg.stats.to_dict()
            if baked and baked_result is not None:
                stats["rig_residual_arm_lengths"] = float(baked_result.residual)
                if index < len(baked_result.linear_spans):
                    stats["linear_spans"] = baked_result.linear_spans[index]
                    stats["close_spans"] = baked_result.close_spans[index]
            message = seg.message if seg.success else arm_note(request, info) + seg.message
            out.append(TaskResult(
                seg.name, info.side, seg.success, seg.reason, message,
                first + seg.frame_start, first + seg.frame_end,
                list(keyed) if baked else [], stats, seg.method, request.side == "auto"))
    return out


def _start_as_it_shows(armature, info, plans, obstacles) -> None:
    """Where a plan refuses its start as touching an obstacle (``start_in_collision``)
    while the arm's skin, as Blender shows it on the start frame, touches nothing
    (:func:`.rig.skin_clearance`), the refusal is a claim about Reach's model of the arm,
    not about what the user sees: it becomes ``start_held``, saying so. (A capsule has one
    radius along its segment, read from the skin's bulk; a tapering limb's is fuller than
    its skin near its thin end: CesiumMan's upper arm touched a plane its skin kept 5 cm
    from.) The character's own body, an enclosed chest and an obstacle moving into a
    chase are left as they are."""
    length = info.arm.arm_length
    skin = None
    for plan, _first in plans:
        for seg in plan.segments:
            if seg.reason != START_IN_COLLISION or "already touches" not in seg.message:
                continue
            if skin is None:
                skin = rig_mod.skin_clearance(info, armature, obstacles, 0.5 * length)
            if skin <= 0.0:
                continue
            seg.reason = START_HELD
            seg.message = (f"{seg.message.split(';')[0]} as Reach models the arm (one capsule "
                           f"per segment, fuller than the skin there), although its skin is "
                           f"{100.0 * skin * info.arm.metres_per_unit:.1f} cm "
                           f"({skin / length:.3f} arm lengths) clear, and no move of the model "
                           "leaves it: the arm cannot move from its start pose; move the arm or "
                           "the obstacle a little apart, or lower the clearance")


def measure_orientation(context, armature, info, results, settings) -> None:
    """Replace the planned ``orientation_error_deg`` and ``orientation_met`` of each baked
    result that has them by what Blender's evaluated bones show at its last frame: the
    fingers' direction (:func:`.rig.finger_axis`) and the palm (:func:`.rig.palm_normal`), read from
    the evaluated pose as they were read from the start pose, against the target's axes
    (:func:`~reach_addon.core.orient.wanted_axes`). A palm read wrongly, or a bake that
    turns the hand off its plan, then shows as an error instead of a success."""
    scene = context.scene
    hands = info.hand_bones or (info.bones.arms[info.side].hand,)
    to_world = info.arm.to_world[:3, :3]
    for r in results:
        if r.stats.get("orientation_error_deg") is None or not r.bones_keyed:
            continue
        target = bpy.data.objects.get(r.target)
        if target is None:
            continue
        scene.frame_set(r.frame_end)
        axis, _l, _s = rig_mod.hand_shape(armature, hands[0], info.arm.forearm_length, hands)
        d = rig_mod.finger_axis(armature, hands, axis)
        n, _source = rig_mod.palm_normal(armature, hands, axis, info.frame.up, to_world.T)
        finger, palm = wanted_axes(np.array(target.matrix_world)[:3, :3], settings.finger_axis,
                                   settings.palm_axis)
        error = float(frame_angle(palm_frame(d, to_world @ n), palm_frame(finger, palm)))
        r.stats["orientation_error_deg"] = error
        r.stats["orientation_met"] = error <= settings.orientation_tolerance


def _draw(scene, info, plans, planner, request):
    viz.clear(scene)
    wrists = [p.wrist_trajectory() for p, _f in plans]
    if wrists:
        viz.trajectory(scene, np.concatenate(wrists), TUBE_RADIUS * info.arm.arm_length)
    targets = np.concatenate([p.task.targets[-1:] if p.task.kind == "chase" else p.task.targets
                              for p, _f in plans])
    viz.markers(scene, targets, radius=0.04 * info.arm.arm_length)
    guides = np.concatenate([p.guiding_nodes() for p, _f in plans] + [np.zeros((0, 3))])
    if len(guides):
        viz.markers(scene, guides, name="Reach Guiding Nodes", radius=0.03 * info.arm.arm_length)
    if request.show_guides:
        ws = planner.workspace
        if ws.valid.any():
            centres = info.arm.to_world_points(ws.valid_centers())
            viz.wire_cubes(scene, centres, _cell_size_world(info, ws), name="Reach Workspace")


def _cell_size_world(info, ws):
    return np.abs(info.arm.to_world[:3, :3]) @ ws.cell
