"""The body's balance and clearance under a lean on a rig (:mod:`.lean`): the centre of mass
as the lean and the reach pose it, the check each lean is held to, and the estimate the
core's hips' shift and squat are sized by.

**Balance.** A lean is refused where it would leave the centre of mass past the feet
(:func:`.balance.margin_now`), and farther past them than the rig stands as posed: a
template or a rig whose feet Reach reads poorly may stand past its own feet, and is then
held to that. It is weighed at the full lean with the arm at its start, on the way there
where the hips move, and on every pose of the planned reach.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..core import balance as core_balance
from ..core import hips as core_hips
from ..core.lean import skin_hit
from ..core.whole_body import BALANCE, SLIDE, TOUCH, Why
from . import balance, skin
from . import hips as hips_mod
from .lean_pose import lean_basis, pose_lean, pose_leaned, shift_world, world_rotations


def reaching_segments(armature, info, legs, target=None) -> list:
    """The body's segments now (:func:`.balance.body_segments`), the reaching arm held
    straight from its shoulder toward ``target`` (world), the wrist at most on it (an
    estimate of where the arm ends, for the hips' shift); as it is without a target."""
    out = balance.body_segments(armature, info.bones, legs)
    if target is None:
        return out
    k = 3 * list(info.bones.arms).index(info.side)
    lengths = [float(np.linalg.norm(np.asarray(b) - np.asarray(a))) for _k, a, b in out[k:k + 3]]
    out[k:k + 3] = core_balance.arm_toward(out[k][1], lengths, target)
    return out


def posed_segments(segments, info, joints, turned=None) -> list:
    """``segments`` (:func:`.balance.body_segments`) with the reaching arm's at the core's
    ``joints`` (world: sternum, shoulder, elbow, wrist, hand's end), and the other arms'
    and the head's points mapped by ``turned`` (world points → where the chest's turn takes
    them) where given."""
    out = list(segments)
    k = 3 * list(info.bones.arms).index(info.side)
    if turned is not None:
        carried = [i for i in range(3 * len(info.bones.arms)) if not k <= i < k + 3]
        carried += [i for i, seg in enumerate(out) if seg[0] == "head_neck"]
        for i in carried:
            kind, a, b = out[i]
            a, b = turned(np.array([a, b], dtype=float))
            out[i] = (kind, a, b)
    s, e, w, tip = (np.asarray(p, dtype=float) for p in np.asarray(joints)[1:5])
    out[k:k + 3] = [("upper_arm", s, e), ("forearm", e, w), ("hand", w, tip)]
    return out


def margin_reaching(armature, info, legs, arm_world=None, turned=None) -> tuple:
    """(the centre of mass's least margin over the feet now, world units; the pose it is
    least on; the centre of mass there, world): the arm as it is (pose None) where
    ``arm_world`` is None, else on each of its poses (P, 5, 3), the chest turned by
    ``turned(points, k)`` (:func:`posed_segments`)."""
    up = np.asarray(info.frame.ground, float)
    polygon = balance.support_now(armature, legs, up)[0]
    segments = balance.body_segments(armature, info.bones, legs)
    if arm_world is None:
        com = core_balance.centre_of_mass(segments)
        return core_balance.balance_margin(com, polygon, up), None, com
    coms = [core_balance.centre_of_mass(posed_segments(
        segments, info, joints, None if turned is None else lambda p, k=k: turned(p, k)))
        for k, joints in enumerate(np.asarray(arm_world, dtype=float))]
    margins = [core_balance.balance_margin(c, polygon, up) for c in coms]
    k = int(np.argmin(margins))
    return float(margins[k]), k, coms[k]


class BalanceCheck:
    """``check(lean, arm_world=None, turned=None)``: why a lean (:class:`~..core.lean.
    Lean`) may not be taken (a :class:`~..core.whole_body.Why`: its balance, or the body
    below the trunk touching), or None: the centre of mass's margin over the feet with the
    trunk at the full lean (the hips moved back by the lean's shift) may not fall below 0
    nor below the rig's own as it stands (see the module docstring): the arm at its start,
    or on each pose of the reach planned after the lean (``arm_world``, ``turned``:
    :func:`margin_reaching`). ``margins``: each lean's margin, in turn.

    ``correction``: where the reach after a lean (its hips not moved) was weighed, its
    least-balanced pose's centre of mass less :class:`BalanceBody`'s estimate for the same
    lean (the arm straight toward ``target``, the chest unturned): the estimate's error,
    which :class:`BalanceBody` adds, so the hips move back by what the planned arm needs
    (on the Quaternius alien the estimate put the centre of mass 0.04 arm lengths too far
    forward: its chest turns 55° and brings the other arm back)."""

    def __init__(self, context, armature, info, legs, bone, target=None, checker=None):
        self.context, self.armature, self.info, self.legs, self.bone = \
            context, armature, info, legs, bone
        self.target = None if target is None else np.asarray(target, dtype=float)
        self.checker = checker
        self.standing = balance.margin_now(armature, info.bones, legs,
                                           np.asarray(info.frame.ground, float))
        self.hips = hips_mod.hips_bone(armature, legs, bone)
        self.ankles = balance.ankles_now(armature, legs)[0]
        self.margins = []
        self.correction = None

    def __call__(self, lean, arm_world=None, turned=None):
        basis = lean_basis(self.armature, self.bone, world_rotations(self.info, lean, [1.0]))[0]
        moved = bool(np.any(lean.shift))
        bones = [self.bone] + ([self.hips] + hips_mod.leg_bones(self.armature, self.legs)
                               if moved else [])
        with hips_mod.Posed(self.context, self.armature, bones):
            pose_leaned(self.context, self.armature, self.info, self.bone, basis, self.legs,
                        self.hips if moved else None, shift_world(self.info, lean))
            slide = self.slide() if moved else 0.0
            margin, pose, com = margin_reaching(self.armature, self.info, self.legs,
                                                arm_world, turned)
            if pose is not None and not moved and self.target is not None:
                self.correction = com - core_balance.centre_of_mass(
                    reaching_segments(self.armature, self.info, self.legs, self.target))
        self.margins.append(margin)
        length = self.info.arm.arm_length
        if slide > FEET_SLIDE * length:
            return Why(f"moving the hips {np.linalg.norm(np.asarray(lean.shift)[:2]) / length:.2f} "
                       f"arm lengths back would slide the feet {slide / length:.3f} arm "
                       f"lengths: the legs of '{self.armature.name}' do not keep them planted "
                       "(its leg bones follow constraints: set its legs to IK)", SLIDE)
        if margin >= min(0.0, self.standing):
            if not moved or arm_world is not None:
                return None
            hit, least, fraction = self.along(lean)
            if hit is not None:
                return Why(f"leaning {lean.angle:.0f}° with the hips "
                           f"{np.linalg.norm(np.asarray(lean.shift)[:2]) / length:.2f} arm "
                           f"lengths back, the {hit[0]} would touch '{hit[1]}'", TOUCH)
            if least >= min(0.0, self.standing):
                return None
            margin, pose = least, None
            why = (f"leaning {lean.angle:.0f}° with the hips moved would carry the centre "
                   f"of mass {-margin / length:.3f} arm lengths past the feet "
                   f"{fraction:.0%} of the way")
        else:
            why = ((f"leaning {lean.angle:.0f}°" if lean.angle > 0.0 else "upright")
                   + " would carry the centre of mass "
                   + ("" if pose is None else "(the arm on the "
                      + ("" if lean.angle > 0.0 else "ready ") + f"reach's frame {pose}) ")
                   + f"{-margin / length:.3f} arm lengths past the feet"
                   + ("" if moved else ", the hips not moved back"))
        if self.standing < 0.0:
            why += f" (the rig as posed stands {-self.standing / length:.3f} arm lengths past them)"
        return Why(why, BALANCE)

    def slide(self) -> float:
        """How far the ankle that moved most is from where it stood (world units), as
        Blender evaluates the pose now: a rig whose legs follow constraints (a generated
        Rigify rig's in FK) carries its feet with the hips' shift, which :func:`.hips.
        pose_shift` poses on the bones the constraints override."""
        now = balance.ankles_now(self.armature, self.legs)[0]
        return float(np.linalg.norm(now - self.ankles, axis=1).max())

    def along(self, lean):
        """The body on the way to a lean that moves the hips, at :data:`BALANCE_SAMPLES`
        instants of it posed as the bake poses them, the arm at its start: (where the skin
        below the trunk would touch, :meth:`lower_hit`'s; the least margin of the centre of
        mass over the feet, world units; the fraction of the lean it is at). The trunk's
        weight and the hips do not move in proportion (:meth:`~..core.lean.Lean.
        shift_share` keeps them close): the full lean's balance does not vouch for the way
        to it."""
        if self.hips is None:
            return None, np.inf, 1.0
        fractions = np.linspace(0.0, 1.0, BALANCE_SAMPLES)
        bases = lean_basis(self.armature, self.bone, world_rotations(self.info, lean, fractions))
        moved = [self.bone, self.hips] + hips_mod.leg_bones(self.armature, self.legs)
        up = np.asarray(self.info.frame.ground, float)
        least, at = np.inf, 1.0
        for basis, fraction in zip(bases[1:], fractions[1:]):
            with hips_mod.Posed(self.context, self.armature, moved):
                pose_leaned(self.context, self.armature, self.info, self.bone, basis,
                            self.legs, self.hips, shift_world(self.info, lean, fraction))
                margin = balance.margin_now(self.armature, self.info.bones, self.legs, up)
            if margin < least:
                least, at = margin, float(fraction)
        return self.lower_hit(lean), least, at

    def lower_hit(self, lean):
        """(part, obstacle) where the skin below the trunk (the hips bone's and every bone
        it carries that the lean bone does not: the pelvis and the legs, :func:`.hips.
        lower_bones`) would come within the clearance of an obstacle as the lean moves the
        hips back (:data:`LOWER_SAMPLES` instants of it, posed as the bake poses them, then
        :func:`~..core.lean.skin_hit`, exact about crossing between them), else None.
        A wall just behind the hips is what this finds, and a floor under a squat."""
        if self.checker is None or self.hips is None:
            return None
        fractions = np.linspace(0.0, 1.0, LOWER_SAMPLES)
        bases = lean_basis(self.armature, self.bone, world_rotations(self.info, lean, fractions))
        names = hips_mod.lower_bones(self.armature, self.hips, self.bone)
        moved = [self.bone, self.hips] + hips_mod.leg_bones(self.armature, self.legs)
        world, chosen = [], {}
        for basis, fraction in zip(bases, fractions):
            with hips_mod.Posed(self.context, self.armature, moved):
                pose_leaned(self.context, self.armature, self.info, self.bone, basis,
                            self.legs, self.hips, shift_world(self.info, lean, fraction))
                world.append(skin.skin_points(self.armature, names, 0.5, True, chosen))
        return lower_body_hit(self.armature, self.legs, world, self.checker,
                              self.info.frame.ground)


def lower_body_hit(armature, legs, world, checker, up):
    """(part, obstacle) where the lower body's skin ``world`` (instants, points, 3: the
    first as the figure stands) comes within ``checker``'s clearance of an obstacle
    (:func:`~..core.lean.skin_hit`, exact about crossing between instants), else None: the
    points below the ankles (``up``: the ground's normal) held to :data:`FEET_CLEARANCE` of
    it, as planted feet are."""
    if not len(world[0]):
        return None
    world = np.array(world)
    up = np.asarray(up, dtype=float)
    ankles = max(float(balance.point_of(armature, leg.ankle) @ up) for leg in legs)
    hit = feet_apart_hit(world, world[0] @ up <= ankles, checker, "lower body")
    return None if hit is None else (hit[0], hit[1][1])


def feet_apart_hit(world, feet, checker, body: str):
    """(part, (instant, obstacle)) where the skin ``world`` (instants, points, 3) comes
    within ``checker``'s clearance of an obstacle (:func:`~..core.lean.skin_hit`), the
    points ``feet`` (a mask) held to :data:`FEET_CLEARANCE` of it, the others (the
    ``body``) to all of it; else None."""
    feet_checker = SimpleNamespace(obstacles=checker.obstacles,
                                   margin=FEET_CLEARANCE * checker.margin)
    for part, held, check in ((body, ~feet, checker), ("feet", feet, feet_checker)):
        hit = skin_hit(world[:, held], check) if held.any() else None
        if hit is not None:
            return part, hit
    return None


#: How far (arm lengths) an ankle may move as the hips move before :class:`BalanceCheck`
#: refuses the lean as sliding the feet (the issue's bound on planted feet is 0.02).
FEET_SLIDE = 0.002

#: The share of the clearance the skin below the ankles keeps from the obstacles as the
#: hips move (:meth:`BalanceCheck.lower_hit`). It is the feet's, planted on the ground;
#: where the rig blends the heel's skin between the foot and the shank, the shank's tipping
#: over the foot in a squat carries it toward the floor a little (1.5 mm on the Knight at
#: 12° of dorsiflexion), and a whole clearance (1 cm on an adult) would refuse every squat.
FEET_CLEARANCE = 0.25

#: The instants of a lean that moves the hips at which the balance is weighed on the way
#: (:meth:`BalanceCheck.along`): a sixteenth of the way apart. At an eighth, the metarig,
#: weighed along its spine's axis, where it stood 0.037 arm lengths behind its heels, came
#: 0.0001 farther behind them on a frame between two (the hips start back a little ahead of
#: the trunk's weight coming forward).
BALANCE_SAMPLES = 17

#: The instants of a lean at which the skin below the trunk is read for its obstacle test
#: (:meth:`BalanceCheck.lower_hit`); between them the test adds its own where a point
#: moves more than the clearance allows.
LOWER_SAMPLES = 9


class BalanceBody:
    """The rig's balance for :func:`~..core.hips.shifted_lean` (world frame): the centre of
    mass with the trunk leaned (the lean bone posed, measured, put back; the arm straight
    toward the target, corrected by the ``check``'s :attr:`BalanceCheck.correction` where
    it has one), the support polygon and up as the rig stands, the planted share, the
    margin to keep (``Settings.balance_margin`` arm lengths over the ``floor``: 0, or the
    rig's own where that is below 0), and how far the hips come down for a shift."""

    def __init__(self, context, armature, info, legs, lean_bone, hips, settings,
                 check: BalanceCheck):
        self.target, self.check = check.target, check
        self.context, self.armature, self.info, self.legs = context, armature, info, legs
        self.lean_bone, self.hips = lean_bone, hips
        self.up = np.asarray(info.frame.ground, dtype=float)
        self.polygon = balance.support_now(armature, legs, self.up)[0]
        self.planted_share = hips_mod.PLANTED_SHARE
        self.floor = min(0.0, check.standing)
        self.margin = self.floor + settings.balance_margin * info.arm.arm_length
        self.leg_joints = hips_mod.leg_joints(armature, legs, np.asarray(info.frame.forward,
                                                                         dtype=float))

    def com(self, lean) -> np.ndarray:
        """The centre of mass (world) with the trunk leaned by ``lean`` (its turn only)."""
        basis = lean_basis(self.armature, self.lean_bone,
                           world_rotations(self.info, lean, [1.0]))[0]
        with hips_mod.Posed(self.context, self.armature, [self.lean_bone]):
            pose_lean(self.context, self.armature, self.lean_bone, basis)
            com = core_balance.centre_of_mass(
                reaching_segments(self.armature, self.info, self.legs, self.target))
        return com if self.check.correction is None else com + self.check.correction

    def com_posed(self, lean) -> np.ndarray:
        """The centre of mass (world) of the whole posture of ``lean`` as the rig takes
        it (the trunk leaned, the hips moved, the knees where the legs put them; the arm
        as :meth:`com` has it), measured and put back."""
        basis = lean_basis(self.armature, self.lean_bone,
                           world_rotations(self.info, lean, [1.0]))[0]
        moved = [self.lean_bone, self.hips] + hips_mod.leg_bones(self.armature, self.legs)
        with hips_mod.Posed(self.context, self.armature, moved):
            pose_leaned(self.context, self.armature, self.info, self.lean_bone, basis,
                        self.legs, self.hips, shift_world(self.info, lean))
            com = core_balance.centre_of_mass(
                reaching_segments(self.armature, self.info, self.legs, self.target))
        return com if self.check.correction is None else com + self.check.correction

    def drop(self, shift_world) -> float:
        """How far the hips come down for ``shift_world`` (:func:`~..core.hips.hips_drop`),
        on the legs as they stand (:attr:`leg_joints`)."""
        return core_hips.legs_drop(self.leg_joints, shift_world, self.up)
