"""The step on a rig (:mod:`..core.step`): where a single reach is refused even with the
lean and the squat, the body steps toward the target, then reaches.

**Posing** a frame of the step (:func:`pose_step`) is :func:`.hips.pose_shift` with the
feet moved: the hips bone translated by the hips' offset, each foot's bones carried by the
foot's offset (:func:`.hips.foot_bones`), the knees solved between.

**Checks**, on every frame of the step as the bake poses it (:func:`plan`):

- the centre of mass (:func:`.balance.body_segments`) stays over the feet on the ground,
  read on that frame (:class:`.balance.Soles` of the planted legs only: one foot
  while the other swings), not below 0 nor below the rig's own margin as it stands;
- the character's skin (every bone's) keeps the clearance from the obstacles, exact about
  crossing between frames (:func:`~..core.lean.skin_hit`); the skin below the ankles keeps
  a quarter of it (:data:`.lean_balance.FEET_CLEARANCE`: feet stand on a floor).

**Then the reach**: with the rig posed where the step ends, it is read again
(:func:`.rig.build`: the arm's model, start and body frame move with it) and the task is
planned for it; where that is refused, the lean and the squat are tried from there
(:func:`.lean.plan`), as for a target that near.

**Keys** (:func:`key`): the hips bone's location and rotation, the legs' and feet's bones
(location where a bone is not connected to its parent; not a bone a constraint drives,
whose keys would do nothing) on every frame of the step, held
through the reach (where the lean does not key them after), recorded as Reach's own
(:mod:`.own_keys`).
"""

from __future__ import annotations

import dataclasses
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from ..core import Planner
from ..core import balance as core_balance
from ..core.hand_shape import with_shape
from ..core.hips import LegOverstretchedError
from ..core.step import Step, StepMotion, plan_step, step_motion
from ..core.whole_body import wants_step
from . import balance, own_keys, skin
from . import hips as hips_mod
from .bake import KeyedPlan
from .fcurves import Channels, ensure_action
from .lean import lean_bone
from .lean_balance import FEET_SLIDE, feet_apart_hit
from .own_keys import users_keys
from .rig_detect import constrained

@dataclass
class RigStep:
    """A step planned on a rig: the core's ``step`` and ``motion``, the ``hips`` bone and
    ``legs``, each moved bone's channel matrices on the step's frames (``bases``: name →
    (F, 4, 4)), the bones whose location is keyed, the ``frame_start``, the rig read where
    the step ends (``info``), and the least margin of the centre of mass over the planted
    feet over the step (world units)."""

    step: Step
    motion: StepMotion
    hips: str
    legs: tuple
    bases: dict
    located: set
    frame_start: int
    info: object
    margin: float
    lean: object = None

    @property
    def reach_first(self) -> int:
        """The frame the reach (or the lean) starts on: the step's last."""
        return self.frame_start + self.motion.frames


def step_bones(armature, legs, hips: str, up) -> list:
    """The bones a step moves, parent first: the hips bone, each leg's thigh and shank
    (:func:`.hips.leg_bones`), and its foot's (:func:`.hips.foot_bones`)."""
    out = [hips] + hips_mod.leg_bones(armature, legs)
    for leg in legs:
        out += [n for n in hips_mod.foot_bones(armature, leg, up) if n not in out]
    return out


def pose_step(context, armature, info, legs, hips, motion: StepMotion, frame: int) -> None:
    """Pose frame ``frame`` of the step ``motion`` (from the pose it starts from)."""
    hips_mod.pose_shift(context, armature, list(legs), hips, motion.hips[frame],
                        np.asarray(info.frame.ground, float), np.asarray(info.frame.forward, float),
                        motion.feet[frame])


def _why_not(armature, info, legs, hips) -> str | None:
    if not legs:
        return "Reach finds no legs on this rig, and steps only a body standing on its feet"
    if hips is None:
        return "Reach finds no bone that carries both legs and the trunk"
    up = np.asarray(info.frame.ground, float)
    standing = balance.standing_why_not(armature, legs, up, "step")
    if standing is not None:
        return standing
    keyed = next((n for n in step_bones(armature, legs, hips, up)
                  if users_keys(armature, n) or users_keys(armature, n, "location")), None)
    if keyed is not None:
        return f"bone '{keyed}', which the step moves, has keys of its own"
    return None


def plan(context, armature, info, planner, keyed, reread, bake_closest=False):
    """Try a step where ``keyed`` (a single reach's :class:`.bake.KeyedPlan`) was refused
    for a target beyond the arm and the body (``needs_step``; or one the lean and squat
    were tried for, :func:`~..core.whole_body.wants_body`), with ``Settings.lean`` and
    ``Settings.stepping`` on. ``reread()``: the rig read again as posed now (:func:`.rig.
    build` with the request's side and bones). Returns (:class:`RigStep`, the reach's
    KeyedPlan after it); or (None, ``keyed``) with its message saying why no step was taken.
    The rig's pose is put back either way."""
    s = planner.settings
    failed, task = keyed.plan, keyed.plan.task
    if not wants_step(s, task, failed, info.arm):
        return None, keyed
    legs = balance.find_legs(armature, info.bones, info.frame)
    bone = lean_bone(armature, info.bones, legs)
    hips = None if bone is None else hips_mod.hips_bone(armature, legs, bone)
    why = _why_not(armature, info, legs, hips)
    result = None
    if why is None:
        result, why = _plan(context, armature, info, planner, keyed, legs, hips, reread,
                            bake_closest)
    if result is not None:
        return result
    for seg in failed.segments:
        if seg.reason == failed.reason:
            seg.message += f"; stepping toward it: {why}"
    return None, keyed


#: Where the step leaves the target, tried in turn (arm lengths from the shoulder, the
#: first ``Settings.step_reach``): where the body, the arm held as it stands, would touch
#: or tip, or the arm find no way, a shorter step, the arm reaching farther (with the lean
#: for the rest past 1). A hanging arm carried by the step sweeps the ground beside the
#: body, and a stand under the target stops a full step (the A-posed Cesium and Knight
#: over the step test's pedestal).
STEP_SHORTER = (1.0, 1.15)


def _plan(context, armature, info, planner, keyed, legs, hips, reread, bake_closest):
    s, task = planner.settings, keyed.plan.task
    ankles, leg_length = balance.ankles_now(armature, legs)
    whys = []
    for reach in (s.step_reach,) + tuple(r for r in STEP_SHORTER if r > s.step_reach):
        step, why = plan_step(info.joints_world["shoulder"], task.targets[0], ankles,
                              np.asarray(info.frame.ground, float), info.arm.arm_length,
                              leg_length, s, reach)
        if step is None:
            whys.append(why)
            break
        try:
            found, why = _try(context, armature, info, planner, keyed, legs, hips, reread,
                              bake_closest, step, ankles, leg_length)
        except LegOverstretchedError:      # the weight shift over the foot that stays (seed 40044)
            found, why = None, (
                f"{step.count} step{'s' if step.count > 1 else ''} "
                f"{float(np.linalg.norm(step.shift)) / info.arm.arm_length:.2f} arm lengths "
                "toward it: keeping the weight over the foot that stays would carry the hips "
                "farther from the other ankle than its leg reaches")
        if found is not None:
            return found, None
        if why not in whys:
            whys.append(why)
    return None, "; and a shorter step: ".join(whys)


def _try(context, armature, info, planner, keyed, legs, hips, reread, bake_closest, step,
         ankles, leg_length):
    """One ``step``: its motion, checked (:func:`_walk`), then the reach from where it ends
    (and a lean, :func:`.lean.plan`): ((:class:`RigStep`, the reach's KeyedPlan), None),
    or (None, why not)."""
    from . import lean as lean_mod

    s, task = planner.settings, keyed.plan.task
    up = np.asarray(info.frame.ground, float)
    length = info.arm.arm_length
    motion = step_motion(ankles, step, up, s, task.fps, leg_length)
    names = step_bones(armature, legs, hips, up)
    extra = np.zeros((2 * step.count + 1, 3))
    for _round in range(WEIGHT_ROUNDS):       # the legs' and hips' drop are not linear
        extra = extra + _weight_over_foot(context, armature, info, legs, hips, motion, names, s)
        motion = step_motion(ankles, step, up, s, task.fps, leg_length, extra)
    far = float(np.linalg.norm(step.shift)) / length
    said = f"{step.count} step{'s' if step.count > 1 else ''} {far:.2f} arm lengths toward it"
    start = planner.generator.config_pose(task.start, task.start_hand)
    held = info.arm.to_world_points(with_shape(info.arm, start.joints, start.bend, start.roll))
    with hips_mod.Posed(context, armature, names):
        bases, margin, why = _walk(context, armature, info, legs, hips, motion, names,
                                   planner.generator.checker, held)
        if why is not None:
            return None, f"{said}: {why}"
        pose_step(context, armature, info, legs, hips, motion, motion.frames)
        off = _feet_off(armature, legs, ankles, motion.feet[motion.frames])
        if off > FEET_SLIDE * length:
            return None, (f"{said}: the feet of '{armature.name}' do not follow the step "
                          f"(an ankle ends {off / length:.2f} arm lengths from where it steps "
                          "to): its foot bones follow constraints, and Reach keys the feet's "
                          "bones, not a foot IK control it does not find")
        info2 = reread()
        left = _arm_left_behind(info, info2)
        if left > FEET_SLIDE * length:
            return None, (f"{said}: the {info.side} arm of '{armature.name}' does not move "
                          f"with the body (its wrist falls {left / length:.2f} arm lengths "
                          "behind: the hand follows a control the step leaves, an IK hand); "
                          "switch the arm to FK")
        planner2 = Planner(info2.arm, planner.obstacles, s)
        task2 = dataclasses.replace(task, start=info2.start, start_hand=info2.start_hand,
                                    start_palm=info2.start_palm,
                                    start_fingers=info2.start_fingers)
        first = keyed.first_frame + motion.frames
        plan2 = planner2.plan(task2)
        keyed2 = KeyedPlan(plan2, first, (planner2.generator.checker,),
                           plan2.success or bake_closest)
        lean = None
        if not plan2.success:
            lean, keyed2 = lean_mod.plan(context, armature, info2, planner2, keyed2)
    if not keyed2.plan.success:
        return None, f"{said}, the arm still finds no way: {keyed2.plan.message}"
    located = {n for n in names if not armature.data.bones[n].use_connect and
               np.abs(bases[n][:, :3, 3] - bases[n][0, :3, 3]).max() > 1e-9}
    rig_step = RigStep(step, motion, hips, tuple(legs), bases, located, keyed.first_frame,
                       info2, margin, lean)
    return (rig_step, keyed2), None


def _arm_left_behind(before, after) -> float:
    """How far the wrist's place relative to the shoulder changed between the rig read as
    it stood (``before``, a :class:`.rig.RigInfo`) and where the step ends (``after``):
    the step moves the trunk along the ground, which carries an arm its parents move
    (world units)."""
    def arm(info):
        return np.asarray(info.joints_world["wrist"]) - np.asarray(info.joints_world["shoulder"])

    return float(np.linalg.norm(arm(after) - arm(before)))


def _feet_off(armature, legs, ankles, offsets) -> float:
    """How far the ankle that ends farthest from its place (``ankles`` moved by the step's
    ``offsets``, world) is from it, as Blender evaluates the pose now (world units)."""
    now = balance.ankles_now(armature, legs)[0]
    return float(np.linalg.norm(now - (np.asarray(ankles) + np.asarray(offsets)), axis=1).max())


#: Rounds of :func:`_weight_over_foot`'s correction, each measured on the motion the last
#: one made (one left the Alien's centre of mass 0.09 arm lengths past the foot it stood
#: on: its hips came down as they moved over it).
WEIGHT_ROUNDS = 2


def _weight_over_foot(context, armature, info, legs, hips, motion, names,
                      settings) -> np.ndarray:
    """How much farther the hips go on each shift of the weight (:func:`~..core.step.
    step_motion`'s ``extra``) to bring the centre of mass over the middle of the foot that
    stays, measured as each swing lifts off, at its middle and as it touches down (the
    swinging leg carries mass out and back): the mean of the centre of mass's ground
    offsets from the middle of that foot's sole (:class:`.balance.Soles`), over the share of the
    mass the hips carry (:data:`.hips.PLANTED_SHARE` stays); and where the body, back
    between its feet at the end, would stand less than ``Settings.balance_margin`` inside
    them (a rig posed past its heels), the hips move on toward their middle until it does
    (:func:`toward_margin`)."""
    up = np.asarray(info.frame.ground, float)
    basis = core_balance.ground_basis(up)
    hands = balance.hands_now(armature, info.bones)
    soles = balance.Soles(armature, legs, up)
    out = []
    for first, last in motion.swings:
        offsets = []
        for f in (first, (first + last) // 2, last - 1):   # lift-off, mid-swing, touch-down
            with hips_mod.Posed(context, armature, names):
                pose_step(context, armature, info, legs, hips, motion, f)
                planted = [leg for leg, on in zip(legs, motion.planted[f]) if on]
                com = core_balance.centre_of_mass(balance.body_segments(armature, info.bones,
                                                                        legs, hands))
                middle = basis.T @ soles.polygon(planted).mean(axis=0)
            offsets.append(middle - basis.T @ (basis @ com))
        out.append(np.mean(offsets, axis=0) / (1.0 - hips_mod.PLANTED_SHARE))
    with hips_mod.Posed(context, armature, names):
        pose_step(context, armature, info, legs, hips, motion, motion.frames)
        com = core_balance.centre_of_mass(balance.body_segments(armature, info.bones, legs,
                                                                hands))
        polygon = soles.polygon()
    goal = settings.balance_margin * info.arm.arm_length
    out.append(toward_margin(com, polygon, up, goal) / (1.0 - hips_mod.PLANTED_SHARE))
    return np.array(out)


def toward_margin(point, polygon, up, goal: float, samples: int = 64) -> np.ndarray:
    """The least move (world, along the ground of ``up``) of ``point`` straight toward the
    middle of ``polygon`` (:func:`~..core.balance.ground_basis` coordinates) that brings its
    margin inside (:func:`~..core.balance.balance_margin`) to ``goal``, to within a
    ``samples``-th of the way; as far as the middle where none does; none where it already
    is."""
    basis = core_balance.ground_basis(up)
    q = np.asarray(point, dtype=float)
    way = basis.T @ (np.asarray(polygon, dtype=float).mean(axis=0) - basis @ q)

    def margin(t):
        return core_balance.balance_margin(q + t * way, polygon, up)

    if margin(0.0) >= goal:
        return np.zeros(3)
    t = next((t for t in np.linspace(0.0, 1.0, samples + 1)[1:] if margin(t) >= goal), 1.0)
    return t * way


def _walk(context, armature, info, legs, hips, motion, names, checker, held):
    """Every frame of the step posed (see the module docstring): (each bone's channel
    matrices, the least margin over the planted feet, None), or (…, …, why not). ``held``:
    the arm's joints (world, hand shape included) as it stands, which the step carries
    with the hips (:func:`_arm_hit`)."""
    up = np.asarray(info.frame.ground, float)
    length = info.arm.arm_length
    standing = balance.margin_now(armature, info.bones, legs, up)
    floor = None
    bases = {n: [] for n in names}
    everything = {b.name for b in armature.data.bones}
    world, carried, least = [], [], np.inf
    hands = balance.hands_now(armature, info.bones)
    soles = balance.Soles(armature, legs, up)
    ankle0 = min(float(balance.point_of(armature, leg.ankle) @ up) for leg in legs)
    chosen = {}                      # the skin's vertices, chosen once for every frame
    for f in range(len(motion.hips)):
        with hips_mod.Posed(context, armature, names):
            pose_step(context, armature, info, legs, hips, motion, f)
            for n in names:
                bases[n].append(np.array(armature.pose.bones[n].matrix_basis))
            planted = [leg for leg, on in zip(legs, motion.planted[f]) if on]
            com = core_balance.centre_of_mass(balance.body_segments(armature, info.bones,
                                                                    legs, hands))
            polygon = soles.polygon(planted)
            margin = core_balance.balance_margin(com, polygon, up)
            world.append(skin.skin_points(armature, everything, 0.5, True, chosen))
            carried.append(balance.point_of(armature, (hips, "head")))
        least = min(least, margin)
        # not below 0, nor below the rig's own as it stands (posed by the step's IK: a
        # straight knee comes just short of straight)
        floor = min(0.0, standing, margin) if floor is None else floor
        if margin < floor - 1e-9:
            return None, least, (f"stepping would carry the centre of mass "
                                 f"{-margin / length:.3f} arm lengths past the "
                                 f"{'feet' if len(planted) == 2 else 'foot that stays'} on "
                                 f"its frame {f}")
    hit = None if checker is None else _arm_hit(held, np.array(carried), checker)
    if hit is not None:
        return None, least, f"the {hit[1]} would touch '{hit[2]}' on the step's frame {hit[0]}"
    world = np.array(world)
    if world.shape[1] and checker is not None:
        found = feet_apart_hit(world, world[0] @ up <= ankle0, checker, "body")
        if found is not None:
            part, hit = found
            return None, least, (f"the {part} would touch '{hit[1]}' on the step's "
                                 f"frame {hit[0]}")
    return {n: np.array(v) for n, v in bases.items()}, least, None


#: Instants checked between two frames of the step for the arm (besides the frames).
ARM_SUBSTEPS = 4


def _arm_hit(held, hips, checker):
    """The first instant the reaching arm, held as it stands (``held``: its joints, world)
    and carried by the hips (``hips``: the hips bone's head on each frame of the step),
    comes within the clearance of an obstacle, its capsules as the planner tests them
    (``checker.first_hit``), on every frame and :data:`ARM_SUBSTEPS` instants between:
    (frame, part, obstacle), or None."""
    moved = np.asarray(hips, dtype=float) - hips[0]
    steps = np.linspace(0.0, 1.0, ARM_SUBSTEPS + 2)[:-1]
    for f in range(len(moved)):
        for t in steps if f + 1 < len(moved) else (0.0,):
            at = moved[f] + t * (moved[min(f + 1, len(moved) - 1)] - moved[f])
            hit = checker.first_hit(held + at)
            if hit is not None:
                return f, hit[0], hit[1]
    return None


@contextmanager
def posed_at_end(context, armature, rig_step: RigStep):
    """The rig posed where the step ends (its bones' last channel matrices) within the
    ``with`` block, as it was after (:class:`.hips.Posed`)."""
    from mathutils import Matrix

    with hips_mod.Posed(context, armature, list(rig_step.bases)):
        for n, b in rig_step.bases.items():
            armature.pose.bones[n].matrix_basis = Matrix(b[-1].tolist())
        context.view_layer.update()
        yield


def key(context, armature, rig_step: RigStep, last: int, keyed_after=()) -> None:
    """Key the step: each moved bone's rotation (and location where it moves, not
    connected) on the step's frames (:func:`.lean.key_bone`), the last held to ``last``
    (the reach's last frame) unless the lean keys it after (``keyed_after``: bone names);
    recorded as Reach's own."""
    from .lean import key_bone

    channels = Channels(armature, ensure_action(armature, False))
    frames = rig_step.frame_start + np.arange(len(rig_step.motion.hips), dtype=float)
    end = rig_step.reach_first
    for name, bases in rig_step.bases.items():
        if constrained(armature.pose.bones[name]):
            continue                 # posed for the checks; its keys would do nothing
        hold = [end, last] if last > end and name not in keyed_after else []
        key_bone(channels, armature.pose.bones[name], bases, frames, hold,
                 name in rig_step.located)
    own_keys.record(channels.action, list(rig_step.bases), rig_step.frame_start, last)
    context.view_layer.update()


def key_first(context, armature, rig_step: RigStep, last: int, new_action: bool) -> bool:
    """Key the step (:func:`key`) into the action the bake keys (a new one with
    ``new_action``), before the reach is baked: the bake's checks between keys evaluate
    the body where the step takes it. Returns the bake's ``new_action`` (False: made)."""
    ensure_action(armature, new_action)
    lean = rig_step.lean
    after = set() if lean is None or lean.hips is None else \
        {lean.hips, *hips_mod.leg_bones(armature, list(lean.legs))}
    key(context, armature, rig_step, last, after)
    return False


def report(results, rig_step: RigStep | None) -> None:
    """Put the step into the reach's result, in place: ``step_count``, ``step_frames``,
    ``step_distance`` (arm lengths, the body's move along the ground), ``step_com_margin``
    (arm lengths: the least margin of the centre of mass over the planted feet as planned);
    the message says so, and the frames start with the step's."""
    if rig_step is None:
        return
    length = rig_step.info.arm.arm_length
    far = float(np.linalg.norm(rig_step.step.shift)) / length
    for r in results:
        r.frame_start = rig_step.frame_start
        r.stats.update(step_count=rig_step.step.count, step_frames=rig_step.motion.frames,
                       step_distance=round(far, 4),
                       step_com_margin=round(float(rig_step.margin) / length, 4))
        n = rig_step.step.count
        r.message += (f", stepping {far:.2f} arm lengths toward it first "
                      f"({n} step{'s' if n > 1 else ''})")
