"""The rig adapter: read an armature at the current frame into the core's model of one
arm (:func:`build` → :class:`RigInfo`).

It puts together the bone map (:mod:`.rig_detect`), the body frame (:mod:`.body_frame`),
the hand (:mod:`.hand_reading`) and the skin (:mod:`.skin`), and sizes the arm's and the
body's capsules. Armatures Reach cannot read are refused first (:func:`check_armature`).
Why each choice: ``docs/design/blender.md``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import bpy
import numpy as np

from ..core import ArmConfig, ArmModel, Capsule, ReachError, config_from_joints
from ..core.arm import forward_kinematics, hand_angles
from ..core.distances import segment_distance_float
from ..core.hand_shape import fit_hand_shape, hand_frames
from .body_frame import BodyFrame, body_frame, pose_heads
from .hand_reading import finger_axis, hand_group, hand_shape, palm_normal
from .rig_detect import SIDES, BoneMap, detect_bones
from .skin import skin_points, skin_radius, skin_triangles, surface_samples


@dataclass
class RigInfo:
    """Everything Reach knows about one armature at one frame."""

    armature_name: str
    bones: BoneMap
    frame: BodyFrame
    arm: ArmModel
    side: str
    start: ArmConfig
    joints_world: dict       # role -> world position at the start (shoulder, elbow, wrist)
    start_hand: tuple = (0.0, 0.0)   # the wrist's two angles at the start (core.arm.hand_angles)
    hand_bones: tuple = ()   # the hand's bones (hand_group): the hand bone, then its palm siblings
    start_palm: np.ndarray | None = None   # the palm's normal at the start (canonical; palm_normal)
    palm_source: str = "rest pose"         # what the palm was read from (palm_normal)
    start_fingers: np.ndarray | None = None  # the fingers' direction (canonical; finger_axis)
    # the hand bone's world rotation (3×3, scale divided out) at the start: the hand shape
    # (ArmModel.hand_shape) is placed on the start pose and turns with it from there
    start_hand_rotation: np.ndarray | None = None


#: Room (arm lengths) left between the arm in its start pose and a body capsule that had to
#: be narrowed for it (:func:`clear_of_start`): one search step (``Settings.step``).
START_BODY_GAP = 0.02
#: The least a body capsule is narrowed to, as a share of its proportional radius.
MIN_BODY_RADIUS = 0.25


def clear_of_start(capsules, segments, arm_length):
    """The body capsules, each one that the arm's own start pose passes through narrowed
    until the arm clears it by :data:`START_BODY_GAP` arm lengths (never below
    :data:`MIN_BODY_RADIUS` of its radius). A capsule the start pose clears, or touches by
    less than 10⁻⁴ arm lengths (a pose the planner left right at it, read back from the
    bones), is unchanged: on a rig whose arm starts clear of its body nothing changes.

    ``segments``: (a, b, radius) of the arm's parts the planner keeps out of the body — the
    elbow half of the upper arm, the forearm and the hand — in the start pose (canonical
    frame, the chest unturned, as the capsules are). ``arm_length``: figure units. Returns
    the capsules, in order."""
    out = []
    for c in capsules:
        gap = min(segment_distance_float(a, b, c.a, c.b) - r for a, b, r in segments) - c.radius
        if gap < -1e-4 * arm_length:
            radius = max(c.radius + gap - START_BODY_GAP * arm_length, MIN_BODY_RADIUS * c.radius)
            c = Capsule(c.name, c.a, c.b, radius, c.turns_with_chest)
        out.append(c)
    return tuple(out)


def build(armature, side="auto", overrides=None, target=None) -> RigInfo:
    """Read ``armature`` (an armature object) at the current frame into the core's model
    of one arm: a :class:`RigInfo`, whose arm model starts exactly where the arm is (the
    chest rotation counted from the current pose).

    ``side``: 'right', 'left' or 'auto' (the shoulder nearer ``target``, a world point;
    right without one). ``overrides``: bone names by ``chest`` / ``<role>_<side>``
    (:func:`.rig_detect.detect_bones`). Raises ReachError, naming what to do, for an
    armature Reach cannot read (:func:`check_armature`), bones it cannot find, or an arm
    with a zero-length segment."""
    check_armature(armature)
    bmap = detect_bones(armature, overrides)
    frame = body_frame(armature, bmap)
    side = _choose_side(armature, bmap, side, target)
    arm_bones = bmap.arms[side]
    pos = pose_heads(armature, [arm_bones.clavicle, arm_bones.upper_arm, arm_bones.forearm,
                                arm_bones.hand])
    shoulder, elbow, wrist = pos[arm_bones.upper_arm], pos[arm_bones.forearm], pos[arm_bones.hand]
    l1 = float(np.linalg.norm(elbow - shoulder))
    l2 = float(np.linalg.norm(wrist - elbow))
    if l1 < 1e-9 or l2 < 1e-9:
        raise ReachError(f"the {side} arm of armature '{armature.name}' has a zero-length "
                         "segment (shoulder, elbow and wrist must be different joints)")
    to_world = frame.to_world(side)
    inv = np.linalg.inv(to_world)

    def canon(p):
        return inv[:3, :3] @ p + inv[:3, 3]

    half = frame.shoulder_half_width
    hands = hand_group(armature, arm_bones.hand)
    hand_axis, lh, spread = hand_shape(armature, arm_bones.hand, l2, hands)
    sternum = canon(pos[arm_bones.clavicle]) if arm_bones.clavicle else \
        np.array([0.0, 0.35 * half, canon(shoulder)[2]])
    if np.linalg.norm(sternum - canon(shoulder)) < 0.05 * half:
        sternum = np.array([0.0, 0.35 * half, canon(shoulder)[2]])
    radii = _arm_radii(armature, arm_bones, hands, (shoulder, elbow, wrist),
                       hand_axis, (l1, l2, lh), spread)
    hand_end = canon(wrist) + inv[:3, :3] @ hand_axis * lh
    capsules = clear_of_start(_body_capsules(half), (
        (0.5 * (canon(shoulder) + canon(elbow)), canon(elbow), radii[0]),
        (canon(elbow), canon(wrist), radii[1]),
        (canon(wrist), hand_end, radii[2]),
    ), l1 + l2)
    arm = ArmModel(
        sternum=sternum, shoulder=canon(shoulder), waist=np.array([0.0, 0.0, -2.4 * half]),
        upper_arm_length=l1, forearm_length=l2, hand_length=lh,
        upper_arm_radius=radii[0], forearm_radius=radii[1], hand_radius=radii[2],
        to_world=to_world, body_capsules=capsules, side=side,
        name=f"{armature.name} {side} arm", metres_per_unit=_metres_per_unit(armature))
    start = config_from_joints(arm, canon(elbow), canon(wrist), 0.0)
    joints, bend = forward_kinematics(arm, start.as_array())
    start_hand = hand_angles(joints[2] - joints[1], bend, joints[3] - joints[2],
                             inv[:3, :3] @ hand_axis)
    # the rig's neutral wrist: the hand as its rest pose holds it on the forearm
    arm = dataclasses.replace(arm, hand_rest=hand_angles(
        joints[2] - joints[1], bend, joints[3] - joints[2],
        inv[:3, :3] @ rest_hand_axis(armature, arm_bones, hand_axis)))
    arm = dataclasses.replace(arm, hand_shape=skinned_hand(
        armature, hands, joints, bend, inv[:3, :3] @ hand_axis, canon))
    palm, palm_source = palm_normal(armature, hands, hand_axis, frame.up, inv[:3, :3])
    fingers = inv[:3, :3] @ finger_axis(armature, hands, hand_axis)
    hand_rotation = np.array(armature.matrix_world)[:3, :3] @ \
        np.array(armature.pose.bones[arm_bones.hand].matrix)[:3, :3]
    return RigInfo(armature.name, bmap, frame, arm, side, start,
                   {"shoulder": shoulder, "elbow": elbow, "wrist": wrist}, start_hand, hands,
                   palm, palm_source, fingers, hand_rotation / np.linalg.norm(hand_rotation, axis=0))


#: Arm lengths between the points of the hand's skin triangles that its shape is fitted to
#: (:func:`skinned_hand`), besides their corners.
SKIN_SAMPLE_SPACING = 0.02


def skinned_hand(armature, hands, joints, bend, direction, canon) -> tuple:
    """The hand as skinned (:mod:`reach_addon.core.hand_shape`): capsules in the hand's
    frame holding the skin that the hand's bones ``hands`` and every bone below them move
    (:func:`.skin.skin_points`: at least half of a vertex's weight on them, or the parts
    parented to them) as Blender shows it now: its vertices and points on its triangles at most
    :data:`SKIN_SAMPLE_SPACING` arm lengths apart. ``joints``, ``bend``: the start pose (canonical,
    :func:`~reach_addon.core.arm.forward_kinematics`); ``direction``: the hand's direction
    (canonical, unit); ``canon``: world point → canonical. Empty where the hand moves no
    skin (the axis capsule then stands for it)."""
    names = set(hands)
    for n in hands:
        names |= {b.name for b in armature.pose.bones[n].children_recursive}
    points = skin_points(armature, names, share=True)
    if not len(points):
        return ()
    # the skin's surface, not its vertices only: a low-poly hand's triangles span the
    # capsules of a plate and bulge out between them (CesiumMan's, 0.18 arm lengths long)
    spacing = SKIN_SAMPLE_SPACING * float(np.linalg.norm(joints[3] - joints[1]))
    points = np.vstack([points, surface_samples(skin_triangles(armature, names, share=True),
                                                spacing)])
    u = joints[2] - joints[1]
    frame = hand_frames(direction, np.cross(u / np.linalg.norm(u), bend))
    local = (np.array([canon(p) for p in points]) - joints[3]) @ frame
    return fit_hand_shape(local)


def _rotation(m) -> np.ndarray:
    m = np.array(m)[:3, :3]
    return m / np.linalg.norm(m, axis=0)


def rest_hand_axis(armature, arm_bones, hand_axis) -> np.ndarray:
    """Where the hand would point (world, unit) with the forearm as it is now and the wrist
    as the rest pose holds it: ``hand_axis`` (world) carried by the hand bone's rotation
    relative to the forearm bone from now back to rest,
    ``R_f · (R_f⁰ᵀ R_h⁰) · (R_fᵀ R_h)ᵀ · R_fᵀ``, bones in armature space (⁰: rest)."""
    bones, pb = armature.data.bones, armature.pose.bones
    fa, hand = arm_bones.forearm, arm_bones.hand
    rel_rest = _rotation(bones[fa].matrix_local).T @ _rotation(bones[hand].matrix_local)
    rel_now = _rotation(pb[fa].matrix).T @ _rotation(pb[hand].matrix)
    turn = _rotation(pb[fa].matrix) @ rel_rest @ rel_now.T @ _rotation(pb[fa].matrix).T
    mw = np.array(armature.matrix_world)[:3, :3]
    local = np.linalg.solve(mw, hand_axis)
    axis = mw @ (turn @ local)
    return axis / max(float(np.linalg.norm(axis)), 1e-12)


def _choose_side(armature, bmap: BoneMap, side: str, target) -> str:
    """``side`` itself unless it is 'auto': then the side whose shoulder is nearer
    ``target`` (world point; right on a tie), or right without a target."""
    if side != "auto":
        return side
    if target is None:
        return "right"
    heads = pose_heads(armature, [bmap.arms[s].upper_arm for s in SIDES])
    d = {s: np.linalg.norm(heads[bmap.arms[s].upper_arm] - np.asarray(target)) for s in SIDES}
    return min(SIDES, key=lambda s: (d[s], s != "right"))


def _arm_radii(armature, arm_bones, hands, joints, hand_axis, lengths, spread) -> tuple:
    """The radii (world units) of the upper arm's, forearm's and hand's capsules: the 75th
    percentile of their skin's distance from each segment (:func:`.skin.skin_radius`;
    0.15, 0.14 and 0.18 of the segment's length without skin), the hand's at least half
    the fingers' ``spread``, each clipped to 0.08–0.3 (hand: 0.1–0.35) of its length; a
    hand without fingers (no ``spread``), whose length is its skin's, no thinner than its
    skin up to 0.35 of a 0.74-forearm hand (a short stub or a mitten is not a thin one).
    ``joints``: the shoulder, elbow and wrist (world); ``lengths``: upper arm, forearm and
    hand lengths; ``hand_axis``: the hand's direction (world, unit)."""
    shoulder, elbow, wrist = joints
    l1, l2, lh = lengths
    radii = (
        skin_radius(armature, {arm_bones.upper_arm}, shoulder, elbow, 0.15 * l1),
        skin_radius(armature, {arm_bones.forearm}, elbow, wrist, 0.14 * l2),
        skin_radius(armature, set(hands), wrist, wrist + hand_axis * lh, 0.18 * lh),
    )
    return (float(np.clip(radii[0], 0.08 * l1, 0.3 * l1)), float(np.clip(radii[1], 0.08 * l2, 0.3 * l2)),
            float(np.clip(max(radii[2], 0.5 * spread), 0.1 * lh,
                          0.35 * (lh if spread > 0.0 else max(lh, 0.74 * l2)))))


def _body_capsules(h: float) -> tuple:
    """The chest, pelvis and head capsules (canonical frame) of a body whose shoulder
    half-width is ``h``, in proportion to it."""
    return (
        Capsule("chest", (0, 0, -1.6 * h), (0, 0, 0), 0.68 * h, True),
        Capsule("pelvis", (0, 0, -3.4 * h), (0, 0, -1.6 * h), 0.74 * h, False),
        Capsule("head", (0, 0.1 * h, 0.8 * h), (0, 0.1 * h, 1.6 * h), 0.53 * h, True),
    )


def _metres_per_unit(armature) -> float:
    """Metres per Blender unit in the armature's scene (its unit scale), for messages that
    give lengths in centimetres; 1 when unset."""
    scenes = list(getattr(armature, "users_scene", ())) or [bpy.context.scene]
    scale = float(scenes[0].unit_settings.scale_length) if scenes[0] is not None else 1.0
    return scale if math.isfinite(scale) and scale > 0 else 1.0


def check_armature(armature) -> None:
    """Raise ReachError, naming what to do, unless ``armature`` is an armature Reach can
    read: not in Edit Mode, with a finite transform of non-zero scale."""
    if armature is None:
        raise ReachError("no armature chosen; pick the character's armature in the Reach panel")
    if armature.type != "ARMATURE":
        raise ReachError(f"'{armature.name}' is a {armature.type.lower()}, not an armature; "
                         "pick the character's armature")
    if armature.mode == "EDIT":
        raise ReachError(f"armature '{armature.name}' is in Edit Mode; switch to Object or Pose "
                         "Mode first")
    m = np.array(armature.matrix_world)
    if not np.isfinite(m).all():
        raise ReachError(f"armature '{armature.name}' has a NaN or infinite transform; fix its "
                         "location, rotation and scale")
    if abs(np.linalg.det(m[:3, :3])) < 1e-12:
        raise ReachError(f"armature '{armature.name}' has zero scale on some axis; give it a "
                         "non-zero scale")
    _check_uniform_scale(armature, m[:3, :3])


#: How far the armature's world scale may differ between axes (largest over smallest
#: singular value of its world matrix, minus 1) before Reach refuses it.
SCALE_TOLERANCE = 1e-3


def _check_uniform_scale(armature, m3):
    """Refuse (ReachError) an armature whose world transform ``m3`` (3 × 3) scales its
    axes differently — its own scale, or a parent's: the singular values differ by more
    than :data:`SCALE_TOLERANCE` — naming the object to fix and how; mirroring (a negative
    scale) is uniform and fine."""
    sv = np.linalg.svd(m3, compute_uv=False)
    if sv[0] <= sv[-1] * (1.0 + SCALE_TOLERANCE):
        return
    scale = ", ".join(f"{v:g}" for v in np.round(np.array(armature.scale), 4))
    own = np.abs(np.array(armature.scale))
    if own.max() > own.min() * (1.0 + SCALE_TOLERANCE):
        raise ReachError(
            f"armature '{armature.name}' has a non-uniform scale ({scale}): its bones would "
            "stretch and shear as they turn, so Reach cannot bake them; apply the scale "
            "(select it in Object Mode, Ctrl+A > Scale) or give it the same size on every "
            "axis (a minus sign that mirrors it may stay)")
    culprit = armature.parent
    while culprit is not None:
        s = np.abs(np.array(culprit.scale))
        if s.max() > s.min() * (1.0 + SCALE_TOLERANCE):
            break
        culprit = culprit.parent
    where = f"its parent '{culprit.name}'" if culprit is not None else "its parent"
    raise ReachError(
        f"armature '{armature.name}' is scaled non-uniformly by {where} (world scale "
        f"{', '.join(f'{v:.3g}' for v in sv)}): its bones would stretch and shear as they "
        "turn, so Reach cannot bake them; give the parent the same scale on every axis, or "
        "unparent the armature keeping its transform (Alt+P > Clear and Keep Transformation) "
        "and apply its scale (Ctrl+A > Scale)")
