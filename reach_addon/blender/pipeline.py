"""The one pipeline: scene + armature → rig model → obstacles → core plan → bake / preview.

The sidebar operators, the command line, batch workers and live mode all call :func:`run`
(or consume :func:`steps`, the same work as a generator that yields progress, for callers
that must stay responsive and may cancel). The work is done in named stages
(:class:`PipelineRun`); planning is :mod:`reach_addon.core`, keys are :mod:`.bake`,
drawing is :mod:`.viz`, the results :mod:`.results`.

Bad input raises :class:`~reach_addon.core.ReachError` *before* anything in the scene is
changed. The scene's current frame is restored when the work ends, however it ends. Why
chases, moving obstacles and carried targets are read as they are: ``docs/design/blender.md``.
"""

from __future__ import annotations

import math
from contextlib import nullcontext
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..core import Planner, ReachError, Settings, Task
from ..core import envelope as envelope_mod
from ..core.steps import drain, relay
from ..core.chase import chase_steps
from ..core.sweep import plan_among_moving
from . import bake as bake_mod
from . import body_stage
from . import body as body_mod
from . import gaze as gaze_mod
from . import other_arm as other_arm_mod
from . import lean as lean_mod
from . import step as step_mod
from . import own_keys, spine_share
from .fcurves import ensure_action
from . import rig as rig_mod
from . import viz
from .bake import KeyedPlan
from .carried import carried_targets
from .envelope import read_stance
from .results import arm_note, measure_baked, start_as_it_shows, task_results
from .scene import (KEPT, ObstacleCache, body_extent, character_objects, finite, gather_pieces,
                    reach_bounds, visit_obstacles)

TASKS = ("reach", "sequence", "guided", "chase")
#: Instants per frame at which moving obstacles are sampled for a reach (frame, half way).
SWEEP_SAMPLES = 2


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


class PipelineRun:
    """One run of the pipeline (:func:`steps`): the request, what each stage has read or
    made, and the outcome. The stages are methods named for their job, run in this order:

    1. :meth:`read_rig` — the rig at the start frame, and targets the character carries;
    2. :meth:`gather_obstacles` — the obstacles within reach, and which of them move;
    3. :meth:`make_tasks` — the core tasks (a chase's path sampled frame by frame);
    4. :meth:`plan` — each task planned, among moving obstacles swept over its motion;
    5. :meth:`check_body` — the rig's own animation must not carry the arm off its plan;
    6. :meth:`bake_keys` — the keys (a Bake), or why nothing was keyed;
    7. :meth:`report` — a :class:`.results.TaskResult` per target, the :class:`Outcome`;
    8. :meth:`draw` — the trajectory, markers and guides.

    Stages 1–5 only read the scene (they set its frame, which :meth:`restore_frame` puts
    back); 6–8 change it and never yield. ``bake``: whether keys are wanted (a Bake) or a
    preview (a Plan). Raises ReachError for bad input (:func:`validate`) before any stage."""

    def __init__(self, context, request: Request, bake: bool):
        self.context, self.request, self.bake = context, request, bake
        self.armature, self.targets, self.collection = validate(context, request, bake)
        scene = context.scene
        self.original_frame = scene.frame_current
        self.frame_start = scene.frame_current if request.frame_start is None \
            else int(request.frame_start)
        self.warnings = []            # what a Bake of this preview would refuse
        self.lean = None              # a lean planned before the reach (.lean.RigLean)
        self.step = None              # a step planned before them (.step.RigStep)
        self.turns = {}               # the head's and other arm's turns, for the report
        self.outcome = None

    def read_rig(self):
        """Stage 1 (yields once): the rig read on the start frame (:func:`.rig.build`), with
        the arm and settings :func:`.carried.carried_targets` chooses: ``info``, ``settings`` and
        ``still`` (the note for the results, or None)."""
        scene = self.context.scene
        if scene.frame_current != self.frame_start:
            scene.frame_set(self.frame_start)
        self.context.view_layer.update()
        first = np.array(self.targets[0].matrix_world.translation)
        info = rig_mod.build(self.armature, self.request.side, self.request.overrides,
                             target=first)
        self.info, self.settings, self.still = carried_targets(
            self.armature, self.targets, info, self.request, first)
        yield 0.02, "reading the rig"

    def gather_obstacles(self):
        """Stage 2 (yields once): the obstacle pieces and their BVH on the start frame, the
        character, its targets and whatever is beyond the arm's reach left out
        (:meth:`.scene.KeptObstacles.get`, :func:`reach_bounds`): ``pieces``,
        ``obstacles``; and the names of those animated after it (``moving``; none for a
        chase, which samples every frame)."""
        context = self.context
        self.names = tuple(t.name for t in self.targets)
        self.exclude = character_objects(self.armature, context.scene) | set(self.names)
        self.pieces, self.obstacles, _built = KEPT.get(
            context, self.exclude, self.collection,
            within=reach_bounds(self.info.arm, self.settings, self.targets,
                                body_extent(self.armature, self.info.joints_world["shoulder"])))
        self.moving = set() if self.request.task == "chase" else \
            _moving_owners(context, self.exclude, self.collection, self.frame_start)
        yield 0.05, f"{self.obstacles.triangle_count} obstacle triangles"

    def make_tasks(self):
        """Stage 3: the core :class:`~reach_addon.core.Task` list (``tasks``): one per target
        for a reach, one for a sequence or guided task, and for a chase the target's path
        and the obstacles on every frame of it (``frame_obstacles``, :func:`_sample_chase`)."""
        scene, info, request, names = self.context.scene, self.info, self.request, self.names
        fps = scene.render.fps / scene.render.fps_base
        self.frame_obstacles = None
        if request.task == "chase":
            f0, f1 = _chase_range(self.context, self.targets[0], self.frame_start)
            path, self.frame_obstacles = _sample_chase(self.context, self.targets[0], self.exclude,
                                                       self.collection, self.obstacles, f0, f1)
            scene.frame_set(self.frame_start)
            self.tasks = [Task("chase", np.array(path), info.start, fps, names=names[:1],
                               start_hand=info.start_hand)]
            return
        positions = np.array([np.array(t.matrix_world.translation) for t in self.targets])
        rotations = target_rotations(self.targets) if self.settings.match_orientation else None
        if request.task == "reach":
            self.tasks = [Task("reach", positions[i:i + 1], info.start, fps, request.duration_s,
                               names=names[i:i + 1], start_hand=info.start_hand,
                               orientations=None if rotations is None else rotations[i:i + 1],
                               start_palm=info.start_palm, start_fingers=info.start_fingers)
                          for i in range(len(self.targets))]
        else:
            self.tasks = [Task(request.task, positions, info.start, fps, request.duration_s,
                               names=names, start_hand=info.start_hand, orientations=rotations,
                               start_palm=info.start_palm, start_fingers=info.start_fingers)]

    def plan(self):
        """Stage 4 (yields the planners' progress): each task planned in turn, each one's
        motion starting on the frame after the last one's: ``plans``, a
        :class:`.bake.KeyedPlan` per task. A chase among obstacles that move is planned
        frame by frame among each frame's obstacles (:func:`~reach_addon.core.chase.
        chase_steps`); any other task among the places moving obstacles take
        (:func:`~reach_addon.core.sweep.plan_among_moving`). ``planner``: the last one used.
        A start the skin shows clear is ``start_held`` (:func:`.results.start_as_it_shows`).
        Then the body: a lean, squat or step where one reach's target is beyond the arm
        (:func:`.body_stage.plan`: ``lean``, ``step``)."""
        self.planner = Planner(self.info.arm, self.obstacles, self.settings)
        self.plans = []
        frame = self.frame_start
        for k, task in enumerate(self.tasks):
            frame_planners = None
            if self.frame_obstacles is not None and \
                    any(o is not self.obstacles for o in self.frame_obstacles):
                frame_planners = self._frame_planners()
                plan = yield from _progress(chase_steps(frame_planners, task), k, len(self.tasks))
            else:
                plan, self.planner = yield from _progress(plan_among_moving(
                    self.planner, task, frame, self.pieces, self.moving, self._sweep),
                    k, len(self.tasks))
            checkers = tuple(p.generator.checker for p in (frame_planners or [self.planner]))
            self.plans.append(KeyedPlan(plan, frame, checkers,
                                        plan.success or self.request.bake_closest))
            frame += len(plan.poses)
        start_as_it_shows(self.armature, self.info, [k.plan for k in self.plans],
                          self.obstacles, self._sweep if self.moving else None)
        body_stage.plan(self)                 # the body under the arm (issue 41)

    def _frame_planners(self) -> list:
        """A planner per frame of a chase, one per distinct set of obstacles."""
        planners = {id(self.obstacles): self.planner}
        for o in self.frame_obstacles:
            planners.setdefault(id(o), Planner(self.info.arm, o, self.settings))
        return [planners[id(o)] for o in self.frame_obstacles]

    def _sweep(self, f0: int, f1: int) -> dict:
        """{frame: [pieces of the moving obstacles at each of :data:`SWEEP_SAMPLES` instants
        of the frame, the frame itself first]} for frames f0..f1 (keys, parents and
        constraints evaluated by ``frame_set``); the scene back on the start frame."""
        scene = self.context.scene
        out = {}
        for f in range(f0, f1 + 1):
            out[f] = []
            for k in range(SWEEP_SAMPLES):
                scene.frame_set(f, subframe=k / SWEEP_SAMPLES)
                out[f].append(gather_pieces(self.context, self.exclude, self.collection,
                                            only=self.moving))
        scene.frame_set(self.frame_start)
        return out

    def check_body(self):
        """Stage 5: the plans a Bake keys (``to_key``) checked against the rig's own
        animation (:func:`.body.check`): a Bake it refuses raises ReachError; a drawn
        preview records the refusal in ``warnings``."""
        self.to_key = [k for k in self.plans if k.keyable]
        if self.bake or self.request.draw:
            with (nullcontext() if self.step is None else
                  step_mod.posed_at_end(self.context, self.armature, self.step)):
                try:
                    body_mod.check(self.context, self.armature, self.info,
                                   [k.pair for k in self.to_key], self.settings,
                                   self.frame_start)
                except ReachError as exc:
                    if self.bake:
                        raise
                    self.warnings.append(f"a Bake of this plan would stop: {exc}")

    def bake_keys(self) -> None:
        """Stage 6 (changes the scene): with ``bake``, the keyable plans keyed
        (:func:`.bake.bake`; ``baked``), or, where there are none, ``failure`` saying why
        and nothing drawn. ``drawing``: whether :meth:`draw` draws."""
        self.baked, self.failure, self.drawing = None, None, self.request.draw
        if not self.bake:
            return
        new_action = self.request.new_action
        if self.to_key and own_keys.overlapping(self.armature, self.frame_start, self._last()):
            # an earlier bake's body keys over these frames go (from the copy, with New
            # action: the user's action stays as it was)
            if new_action:
                ensure_action(self.armature, True)
                new_action = False
            own_keys.clear_overlapping(self.armature, self.frame_start, self._last())
            self.context.view_layer.update()
        if self.to_key and self.step is not None:    # the step's keys first
            new_action = step_mod.key_first(self.context, self.armature, self.step,
                                            self._last(), new_action)
            # the reach is keyed from where the step ends: a rig whose constraints the bake
            # evaluates (Rigify's) is read there, not where the step starts
            self.context.scene.frame_set(self.step.reach_first)
        spine = spine_share.for_rig(self.armature, self.info, self.settings,
                                     self.lean is not None or self.step is not None)
        if self.to_key and self.lean is not None:
            self.baked = lean_mod.bake(self.context, self.armature, self.info, self.lean,
                                       self.to_key, new_action, spine)
        elif self.to_key:
            self.baked = bake_mod.bake(self.context, self.armature, self.info, self.to_key,
                                       new_action, spine=spine)
        if self.to_key and self.step is not None:
            self.baked.frames = (self.step.frame_start, self.baked.frames[1])
        if self.to_key:
            self.turns |= self.baked.spine
            if self.lean is not None:
                self.turns.update(other_arm_mod.key(
                    self.context, self.armature, self.info, self.lean.lean_first,
                    self.baked.frames[1], self.settings, self.planner.generator.checker))
            if self.settings.gaze:
                self.turns |= gaze_mod.key(self.context, self.armature, self.info, self.to_key,
                                         self.baked.frames, self.settings,
                                         self.planner.generator.checker, self.tasks[0].fps,
                                         self.targets)
            return
        # Nothing the user asked for can be baked: leave the scene as it was.
        failed = next(k.plan for k in self.plans if not k.plan.success)
        self.failure = (f"{arm_note(self.request, self.info)}{failed.message}; nothing was "
                        "baked (turn on 'Bake closest approach' to bake the motion that gets "
                        "closest)")
        self.drawing = False

    def _last(self) -> int:
        """The last frame the keyable plans take."""
        return max(k.first_frame + len(k.plan.poses) - 1 for k in self.to_key)

    def report(self) -> None:
        """Stage 7: the :class:`Outcome` (``outcome``), a result per target; a baked result's
        orientation, naturalness and balance measured on the evaluated bones
        (:func:`.results.measure_baked`);
        the carried-target note added to every message."""
        baked = self.baked
        outcome = Outcome(self.request, self.info, [k.pair for k in self.plans], [],
                          obstacles=self.obstacles.triangle_counts(), warnings=self.warnings)
        outcome.failure = self.failure
        if baked is not None:
            outcome.baked, outcome.action = True, baked.action
        plans = lean_mod.reported(self.plans, self.lean)     # a sequence's upright part too
        outcome.results = task_results(self.info, plans, baked.bones if baked else [],
                                       self.request, baked)
        step_mod.report(outcome.results, self.step)          # first: it comes first
        lean_mod.report(outcome.results, self.lean, self.info.arm.arm_length)
        for r in outcome.results:
            r.stats.update(self.turns)
            if "gaze_note" in self.turns:
                r.message += f"; the head does not turn: {self.turns['gaze_note']}"
            elif self.turns.get("gaze_share", 1.0) < 1.0:
                r.message += ", the head turned half way toward it (farther would touch)"
        if outcome.baked:
            measure_baked(self.context, self.armature, self.info, outcome.results,
                          self.settings, self.obstacles, plans)
        for r in outcome.results if self.still else ():
            r.message += f"; {self.still}"
        self.outcome = outcome

    def draw(self) -> None:
        """Stage 8 (changes the scene): what was drawn before replaced by these plans
        (:func:`.viz.draw_plans`), unless drawing is off or a Bake keyed nothing."""
        if self.drawing:
            viz.draw_plans(self.context.scene, self.info, [k.pair for k in self.plans],
                           self.planner, self.request.show_guides)

    def restore_frame(self) -> None:
        """The scene back on the frame it was on before the run."""
        scene = self.context.scene
        if scene.frame_current != self.original_frame:
            scene.frame_set(self.original_frame)


def steps(context, request: Request, bake: bool = True):
    """The pipeline as a generator: yields (fraction, message), returns an :class:`Outcome`.
    Closing it early (a cancelled modal operator, at any of its yields) leaves the scene as
    it was: every yield comes before the first change to the scene (keys, drawing), and
    the keys and the drawing are made after the last yield. The stages:
    :class:`PipelineRun`."""
    run = PipelineRun(context, request, bake)
    try:
        yield from run.read_rig()
        yield from run.gather_obstacles()
        run.make_tasks()
        yield from run.plan()
        run.check_body()
        # The last yield: from here on the scene changes (keys, drawing), so nothing below
        # yields and a caller that stops at any yield has changed nothing.
        yield 0.92, "baking keys" if bake and run.to_key else "drawing"
        run.bake_keys()
        run.report()
        run.draw()
        return run.outcome
    finally:
        run.restore_frame()


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


@dataclass
class EnvelopeOutcome:
    """The reach envelope of one arm (:mod:`reach_addon.core.envelope`) with where its points
    are: ``world`` (n, 3) and ``shoulder`` (n, 3), the shoulder-frame coordinates (forward,
    outward, up; arm lengths) a batch study's shoulder grid uses, and the configuration
    generator that classified them (the planner's, with every ranked pose tried)."""

    request: Request
    rig: rig_mod.RigInfo
    envelope: envelope_mod.Envelope
    world: np.ndarray
    shoulder: np.ndarray
    generator: object = None


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
    stance = read_stance(armature, info, s)
    # a body that cannot lean (no legs or no lean bone, not standing: read_stance) has no
    # lean class, as a reach refuses to lean there
    lean_as_reach = s if stance is not None else s.replace(lean=False)
    planner = Planner(info.arm, obstacles, envelope_mod.exhaustive(lean_as_reach))
    env = yield from relay(envelope_mod.envelope_steps(planner.generator, points, chunk, stance),
                           lambda done: (0.05 + 0.95 * done, f"{round(done * len(points))} of "
                                         f"{len(points)} points"))
    return EnvelopeOutcome(request, info, env, info.arm.to_world_points(points), coords,
                           planner.generator)


def envelope(context, request: Request, world=None) -> EnvelopeOutcome:
    """:func:`envelope_steps` run to its end."""
    return drain(envelope_steps(context, request, world=world))
