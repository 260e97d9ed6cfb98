"""Synthetic humanoid armatures for the rig-adapter tests.

:func:`humanoid` builds, in the current scene, the skeleton of a standard 1.75 m adult in an
A-pose, under any bone names. The construction, in metres, before ``scale``/``facing``/``lying``:

- the character faces −Y, its right is −X, up is +Z (Blender's usual front view);
- hips at z 0.95, chest 1.25–1.45, neck 1.45, head 1.58–1.75, spine straight up the z axis;
- clavicle from the sternum (±0.02, −0.03, 1.40) to the shoulder (±0.18, 0, 1.42) or, when
  the map has a ``shoulder`` bone (MakeHuman), a short clavicle to the side of the neck
  (±0.05, −0.02, 1.42) and the ``shoulder`` bone from there to the shoulder joint;
- upper arm 0.29 long hanging 40° below horizontal in the frontal plane, forearm 0.25 long
  bent 30° forward (toward −Y) at the elbow, hand 0.09 long straight on from the forearm;
- legs from (±0.09, 0, 0.93) to the knee at z 0.50 and the ankle at z 0.08; the foot and toe
  point forward (−Y) along the floor.

``names`` maps roles to bone names. Roles: ``root`` (optional bone at the floor above the
hips), ``hips``, ``spine`` (a name or a tuple of names, bottom up), ``chest``, ``neck``,
``head`` and, per side (suffix ``_R``/``_L``), ``clavicle``, ``shoulder`` (optional extra
bone between clavicle and upper arm, MakeHuman's ``shoulder01``), ``upper_arm``,
``upper_arm_2`` (optional: the upper arm split in two segments in a row), ``forearm``,
``forearm_2`` (same for the forearm), ``hand``, ``upper_arm_twist``/``forearm_twist``
(twist bones, children of the upper arm/forearm beside the next arm bone; built only with
``twist=True``), ``thigh``, ``shin``, ``foot``, ``toe``. :data:`MAPS` holds ready maps.

Options:

- ``scale``: the armature object's scale; bones are built 1/scale longer, so the world size
  does not change.
- ``facing="+Y"``: the armature object is turned 180° about Z (the character faces +Y and
  its right is +X).
- ``lying=True``: the rest pose itself lies on its back: every bone is built rotated −90°
  about X, (x, y, z) → (x, z, −y), with the object unrotated. In world space (facing −Y) the
  body's up is +Y, its front (forward) +Z and its right −X.
- ``skin``: a mesh of one box around each skeleton bone (half-width ``skin_radius``, 4 cm
  by default; larger for a bulky character), parented to the armature with an Armature
  modifier and one vertex group per bone (weight 1).
- ``decoy``: a second arm chain lying exactly on each deform arm (upper arm to hand, both
  sides), parented where the upper arm is, no deform, no vertex groups:

  ``"ik"``       named like an IK chain: ``upper_arm_ik.R``, ``forearm_ik.R``, ``hand_ik.R``;
  ``"twin"``     named as well as the real chain: the real names prefixed with ``A_`` (so the
                 decoy also sorts first by name; only the skin tells the chains apart);
  ``"driver"``   a control chain ``c_upper_arm.R``, ``c_forearm.R``, ``c_hand.R`` that drives
                 the deform bones through Copy Transforms constraints (influence 1).
- ``clavicle=False``: no clavicle (nor ``shoulder``) bones; the upper arms hang off the chest.
- ``twist=True``: add the twist bones (names from the map, else ``<upper arm>_twist`` and
  ``<forearm>_twist``); they deform like the arm bones.
- ``palms=N`` (N ≥ 2): no hand bone; the hand is N sibling palm bones directly under the
  forearm (``Palm1.R`` … ``PalmN.R``, or the map's ``palm_R`` with ``{i}``), all with their
  heads at the wrist and fanned across the hand's plane (:func:`palm_joints`), each
  carrying a finger of ``fingers`` bones (``Finger1.R``, ``Finger1_2.R``, …; the map's
  ``finger_R`` with ``{i}`` and ``{k}``). From the wrist to the middle fingertip the hand
  is as long as the single hand bone would be (``hand_tip``), the palms ``PALM_SHARE`` of it.
- ``proportions="robot"``: a robot with rigid parts (:data:`ROBOT`): on the same 1.75 m
  body, an arm (shoulder to wrist) 0.41 of the height, the forearm 2.4 times the upper arm,
  the hand half the forearm, thick box skins (upper arm, forearm, hand: radii 0.16, 0.25
  and 0.35 of their lengths as the rig adapter reads them), a thin torso (boxes 5 cm from
  the spine) and the arms hanging at its sides (80° below the horizontal, the forearm bent
  forward as usual). :data:`ROBOT_NAMES` names its bones as such a character does
  (``UpperArmR``, ``LowerArmR``, ``Palm1R`` …).
"""

from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Matrix, Vector

from verification.geometry import unit

SIDES = {"R": -1.0, "L": 1.0}   # the character's right is −X
ARM_LENGTHS = (0.29, 0.25)      # upper arm, forearm
HAND_LENGTH = 0.09
ARM_DROP_DEG = 40.0
ELBOW_BEND_DEG = 30.0
SHOULDER_Z = 1.42
SHOULDER_HALF_WIDTH = 0.18

_TORSO = {"hips": (0.95, 1.05), "chest": (1.25, 1.45), "neck": (1.45, 1.58), "head": (1.58, 1.75)}

#: Proportions of a robot character with rigid box parts, as the rig adapter read them from
#: it (its own units: upper arm 0.58, forearm 1.38 — 2.4 times the upper arm —, hand 0.68;
#: skin radii 0.09, 0.35, 0.24), put on the standard body with its arm (shoulder to wrist)
#: 0.41 of the height, hanging at its sides. ``skin``: half-widths of the skin boxes per
#: role (a box's corners stand √2 half-widths from its bone, which is what the rig adapter
#: reads as the radius); ``torso_skin``: the same for the hips, spine, chest, neck and head.
ROBOT = {
    "arm_lengths": (0.21, 0.50),
    "arm_drop_deg": 80.0,
    "shoulder_half_width": SHOULDER_HALF_WIDTH,
    "hand_length": 0.245,
    "skin": {"upper_arm": 0.023, "forearm": 0.09, "hand": 0.065, "palm": 0.065, "finger": 0.03},
    "torso_skin": 0.05,
}
PROPORTIONS = {None: {"arm_lengths": ARM_LENGTHS, "hand_length": HAND_LENGTH,
                      "arm_drop_deg": ARM_DROP_DEG, "shoulder_half_width": SHOULDER_HALF_WIDTH},
               "robot": ROBOT}
#: Rest poses of the arm (``shape(pose=...)``): degrees below the horizontal.
POSES = {"T": 0.0, "A": ARM_DROP_DEG, "down": 80.0}


def shape(proportions=None, *, pose=None, elbow_bend_deg=None, elbow_bend_dir=None,
          forearm_ratio=None) -> dict:
    """A proportions dict (what ``proportions`` takes besides a key of :data:`PROPORTIONS`):
    those of ``proportions`` with the arm's rest ``pose`` (a key of :data:`POSES`), its
    elbow bend (degrees) and the direction it bends toward (construction axes, default the
    front, (0, -1, 0)), and the forearm's length over the upper arm's (the arm's length,
    shoulder to wrist, kept) changed where given. Plain data (JSON)."""
    out = dict(_proportions(proportions))
    if pose is not None:
        out["arm_drop_deg"] = POSES[pose]
    if elbow_bend_deg is not None:
        out["elbow_bend_deg"] = float(elbow_bend_deg)
    if elbow_bend_dir is not None:
        out["elbow_bend_dir"] = [float(v) for v in elbow_bend_dir]
    if forearm_ratio is not None:
        total = sum(out["arm_lengths"])
        out["arm_lengths"] = (total / (1.0 + forearm_ratio), total * forearm_ratio / (1.0 + forearm_ratio))
    return out


def _proportions(proportions) -> dict:
    """The proportions dict of a key of :data:`PROPORTIONS` or of a dict (:func:`shape`)."""
    if isinstance(proportions, dict):
        return {**PROPORTIONS[None], **proportions}
    return PROPORTIONS[proportions]
#: Share of the hand (wrist to fingertips) taken by the palms when ``palms`` is set; the
#: fingers take the rest.
PALM_SHARE = 0.6
#: Angle (degrees) between neighbouring palms in the hand's plane when ``palms`` is set.
PALM_FAN_DEG = 12.0


# --- name maps --------------------------------------------------------------------------------

def _sided(per_side) -> dict:
    """{role_R: name, role_L: name} from ``per_side(tag)`` for tag in R, L."""
    out = {}
    for tag in SIDES:
        out.update({f"{role}_{tag}": name for role, name in per_side(tag).items()})
    return out


def _mixamo(t):
    s = {"R": "Right", "L": "Left"}[t]
    return {"clavicle": f"mixamorig:{s}Shoulder", "upper_arm": f"mixamorig:{s}Arm",
            "forearm": f"mixamorig:{s}ForeArm", "hand": f"mixamorig:{s}Hand",
            "thigh": f"mixamorig:{s}UpLeg", "shin": f"mixamorig:{s}Leg", "foot": f"mixamorig:{s}Foot",
            "toe": f"mixamorig:{s}ToeBase", "digits": f"mixamorig:{s}Hand" + "{Finger}{k}"}


def _vrm(t):
    return {"clavicle": f"J_Bip_{t}_Shoulder", "upper_arm": f"J_Bip_{t}_UpperArm",
            "forearm": f"J_Bip_{t}_LowerArm", "hand": f"J_Bip_{t}_Hand", "thigh": f"J_Bip_{t}_UpperLeg",
            "shin": f"J_Bip_{t}_LowerLeg", "foot": f"J_Bip_{t}_Foot", "toe": f"J_Bip_{t}_ToeBase",
            "digits": f"J_Bip_{t}_" + "{Finger}{k}", "little": "Little"}


def _unity(t):
    s = {"R": "Right", "L": "Left"}[t]
    return {"clavicle": f"{s}Shoulder", "upper_arm": f"{s}UpperArm", "forearm": f"{s}LowerArm",
            "hand": f"{s}Hand", "thigh": f"{s}UpperLeg", "shin": f"{s}LowerLeg", "foot": f"{s}Foot",
            "toe": f"{s}Toes", "digits": f"{s} " + "{Finger} {Part}", "little": "Little"}


def _spaced(t):
    s = {"R": "Right", "L": "Left"}[t]
    return {"clavicle": f"{s} shoulder", "upper_arm": f"{s} arm", "forearm": f"{s} elbow",
            "hand": f"{s} wrist", "thigh": f"{s} leg", "shin": f"{s} knee", "foot": f"{s} ankle",
            "toe": f"{s} toe"}


def _makehuman(t):
    return {"clavicle": f"clavicle.{t}", "shoulder": f"shoulder01.{t}", "upper_arm": f"upperarm01.{t}",
            "upper_arm_2": f"upperarm02.{t}", "forearm": f"lowerarm01.{t}",
            "forearm_2": f"lowerarm02.{t}", "hand": f"wrist.{t}", "thigh": f"upperleg01.{t}",
            "shin": f"lowerleg01.{t}", "foot": f"foot.{t}", "toe": f"toe1-1.{t}",
            "digits": "finger{i}-{k}." + t, "metacarpal": "metacarpal{m}." + t}


def _unreal(t):
    t = t.lower()
    return {"clavicle": f"clavicle_{t}", "upper_arm": f"upperarm_{t}", "forearm": f"lowerarm_{t}",
            "hand": f"hand_{t}", "upper_arm_twist": f"upperarm_twist_01_{t}",
            "forearm_twist": f"lowerarm_twist_01_{t}", "thigh": f"thigh_{t}", "shin": f"calf_{t}",
            "foot": f"foot_{t}", "toe": f"ball_{t}", "digits": "{finger}_0{k}_" + t}


MIXAMO = {"hips": "mixamorig:Hips", "spine": ("mixamorig:Spine", "mixamorig:Spine1"),
          "chest": "mixamorig:Spine2", "neck": "mixamorig:Neck", "head": "mixamorig:Head",
          **_sided(_mixamo)}
VRM = {"hips": "J_Bip_C_Hips", "spine": ("J_Bip_C_Spine", "J_Bip_C_Chest"), "chest": "J_Bip_C_UpperChest",
       "neck": "J_Bip_C_Neck", "head": "J_Bip_C_Head", **_sided(_vrm)}
UNITY = {"hips": "Hips", "spine": ("Spine", "Chest"), "chest": "UpperChest", "neck": "Neck",
         "head": "Head", **_sided(_unity)}
SPACED = {"hips": "Hips", "spine": "Spine", "chest": "Chest", "neck": "Neck", "head": "Head",
          **_sided(_spaced)}
MAKEHUMAN = {"root": "root", "hips": "spine05", "spine": ("spine04", "spine03", "spine02"),
             "chest": "spine01", "neck": "neck01", "head": "head", **_sided(_makehuman)}
UNREAL = {"root": "root", "hips": "pelvis", "spine": ("spine_01", "spine_02"), "chest": "spine_03",
          "neck": "neck_01", "head": "head", **_sided(_unreal)}
# Mixed conventions: "_R" suffixes on the right, ".l" and "Left_" on the left.
PLAIN = {"hips": "Pelvis", "spine": "Spine", "chest": "Chest", "neck": "Neck", "head": "Head",
         "clavicle_R": "Clavicle_R", "upper_arm_R": "UpperArm_R", "forearm_R": "ForeArm_R",
         "hand_R": "Hand_R", "thigh_R": "Thigh_R", "shin_R": "Shin_R", "foot_R": "Foot_R",
         "toe_R": "Toe_R",
         "clavicle_L": "clavicle.l", "upper_arm_L": "upperarm.l", "forearm_L": "Left_Forearm",
         "hand_L": "Left_Hand", "thigh_L": "thigh.l", "shin_L": "Left_Shin", "foot_L": "foot.l",
         "toe_L": "Left_Toe"}

# A robot character's names: no separator before the side letter; the hand is numbered palms.
ROBOT_NAMES = {"hips": "Hips", "spine": "Abdomen", "chest": "Torso", "neck": "Neck", "head": "Head",
               **_sided(lambda t: {"clavicle": f"Shoulder{t}", "upper_arm": f"UpperArm{t}",
                                   "forearm": f"LowerArm{t}", "hand": f"Hand{t}",
                                   "palm": "Palm{i}" + t, "finger": "Finger{i}_{k}" + t,
                                   "thigh": f"UpperLeg{t}", "shin": f"LowerLeg{t}",
                                   "foot": f"Foot{t}", "toe": f"Toe{t}"})}

# Blender's default names, numbered in the order bones are usually extruded (spine up, then
# the left limbs before the right ones): nothing says which bone is what or which side.
_NUMBERED_ORDER = ("hips", "spine", "chest", "neck", "head",
                   "clavicle_L", "upper_arm_L", "forearm_L", "hand_L",
                   "clavicle_R", "upper_arm_R", "forearm_R", "hand_R",
                   "thigh_L", "shin_L", "foot_L", "toe_L", "thigh_R", "shin_R", "foot_R", "toe_R")
NUMBERED = {role: "Bone" if i == 0 else f"Bone.{i:03d}" for i, role in enumerate(_NUMBERED_ORDER)}

MAPS = {"mixamo": MIXAMO, "vrm": VRM, "unity": UNITY, "spaced": SPACED, "makehuman": MAKEHUMAN,
        "unreal": UNREAL, "plain": PLAIN, "numbered": NUMBERED}

DECOY_NAMES = {
    "ik": {"upper_arm": "upper_arm_ik.{t}", "forearm": "forearm_ik.{t}", "hand": "hand_ik.{t}"},
    "driver": {"upper_arm": "c_upper_arm.{t}", "forearm": "c_forearm.{t}", "hand": "c_hand.{t}"},
}


def decoy_name(names: dict, decoy: str, role: str, tag: str) -> str:
    """Name of the decoy bone lying on arm bone ``role`` of side ``tag`` (R/L)."""
    if decoy == "twin":
        return "A_" + names[f"{role}_{tag}"]
    return DECOY_NAMES[decoy][role].format(t=tag)


# --- geometry ---------------------------------------------------------------------------------

def arm_joints(tag: str, proportions=None) -> dict:
    """Sternum, shoulder, elbow, wrist and hand tip of side ``tag`` (R/L), standing, metres
    (``proportions``: None for the standard adult, or a key of :data:`PROPORTIONS`)."""
    p = _proportions(proportions)
    lengths = p["arm_lengths"]
    hand_length = p["hand_length"]
    s = SIDES[tag]
    shoulder = np.array([s * p["shoulder_half_width"], 0.0, SHOULDER_Z])
    drop = math.radians(p["arm_drop_deg"])
    d1 = np.array([s * math.cos(drop), 0.0, -math.sin(drop)])
    bend = math.radians(p.get("elbow_bend_deg", ELBOW_BEND_DEG))
    toward = np.asarray(p.get("elbow_bend_dir", (0.0, -1.0, 0.0)), dtype=float)
    toward = unit(toward - (toward @ d1) * d1)
    d2 = unit(math.cos(bend) * d1 + math.sin(bend) * toward)
    elbow = shoulder + lengths[0] * d1
    wrist = elbow + lengths[1] * d2
    return {"sternum": np.array([s * 0.02, -0.03, 1.40]), "clavicle_end": np.array([s * 0.05, -0.02, 1.42]),
            "shoulder": shoulder, "elbow": elbow, "wrist": wrist,
            "hand_tip": wrist + hand_length * d2}


def palm_name(names: dict, tag: str, i: int) -> str:
    """Name of palm ``i`` (1-based) of side ``tag`` for ``palms=N``."""
    return names.get(f"palm_{tag}", "Palm{i}." + tag).format(i=i)


def finger_name(names: dict, tag: str, i: int, k: int) -> str:
    """Name of bone ``k`` (1-based) of the finger on palm ``i`` for ``palms=N``."""
    default = "Finger{i}." + tag if k == 1 else "Finger{i}_{k}." + tag
    return names.get(f"finger_{tag}", default).format(i=i, k=k)


def palm_joints(tag: str, n: int, fingers: int = 1, proportions=None) -> list:
    """[(palm head, palm tail, [finger joints …])] of the ``n`` palms of side ``tag``
    (standing, metres): every head at the wrist, each palm ``PALM_SHARE`` of the hand
    long, fanned ``PALM_FAN_DEG`` apart about the hand's axis in the plane of the elbow's
    bend (so the middle palm of an odd number lies along the forearm), each finger
    carrying on straight from its palm, the rest of the hand long, in ``fingers`` bones."""
    j = arm_joints(tag, proportions)
    wrist = j["wrist"]
    length = float(np.linalg.norm(j["hand_tip"] - wrist))
    axis = unit(j["hand_tip"] - wrist)
    plane = np.cross(unit(j["elbow"] - j["shoulder"]), axis)   # the elbow's hinge
    across = unit(np.cross(plane, axis))
    out = []
    for i in range(n):
        a = math.radians(PALM_FAN_DEG * (i - 0.5 * (n - 1)))
        d = math.cos(a) * axis + math.sin(a) * across
        tail = wrist + PALM_SHARE * length * d
        step = (1.0 - PALM_SHARE) * length / fingers
        out.append((wrist, tail, [tail + step * k * d for k in range(fingers + 1)]))
    return out


#: Hand kinds of :func:`humanoid` besides sibling palms: one bone; a mitten (the hand bone,
#: then ``MiddleHand`` and ``Fingers`` in a row, no thumb); five fingers of three bones, the
#: thumb's on the hand bone, the others' on metacarpals where the map names them.
HANDS = ("bone", "mitten", "fingers")
#: The fingers, thumb first, and each one's length as a share of the hand bone's.
FINGERS = (("thumb", 0.85), ("index", 0.95), ("middle", 1.0), ("ring", 0.95), ("little", 0.8))
_PARTS = ("Proximal", "Intermediate", "Distal")


def hand_frame(tag: str, proportions=None) -> tuple:
    """(d, a, n) of side ``tag``'s hand at rest (standing, metres): d along the hand bone
    (wrist to its tail), a across the palm toward the thumb (forward, made perpendicular
    to d) and n the way the palm faces. The thumb points forward, so a T-posed hand faces
    down and an A-posed one down and in. For a right hand n = a × d (a left hand is its
    mirror image: n = -(a × d) in world axes)."""
    j = arm_joints(tag, proportions)
    d = unit(j["hand_tip"] - j["wrist"])
    a = np.array([0.0, -1.0, 0.0])
    a = a - (a @ d) * d
    a = unit(a if np.linalg.norm(a) > 1e-6 else np.array([0.0, 0.0, 1.0]) - d[2] * d)
    n = -SIDES[tag] * np.cross(a, d)
    return d, a, n


def digit_name(names: dict, tag: str, i: int, k: int) -> str:
    """Bone ``k`` (1–3) of finger ``i`` (1 thumb … 5 little) of side ``tag``, by the map's
    ``digits_<tag>`` pattern (fields {Finger}, {finger}, {i}, {k}, {Part}), by default
    ``Index1.R`` and so on."""
    word = FINGERS[i - 1][0]
    if word == "little":
        word = names.get(f"little_{tag}", "Pinky").lower()
    pattern = names.get(f"digits_{tag}", "{Finger}{k}." + tag)
    return pattern.format(Finger=word.capitalize(), finger=word, i=i, k=k, Part=_PARTS[k - 1])


def hand_segments(tag: str, hand: str, names: dict, proportions=None) -> list:
    """(key, head, tail, parent key) of the bones below the hand bone ``hand_<tag>`` for
    hand kind ``hand`` (:data:`HANDS`): nothing for "bone"; a mitten's two bones on from the
    hand bone; or five fingers fanned across the knuckle line at the hand bone's tail
    (their roots 0.22 hand-bone lengths apart, index on the thumb's side), each of three
    bones, the thumb from beside the wrist toward the palm, the four fingers on
    metacarpals (wrist to knuckle) where the map names them (``metacarpal_<tag>``)."""
    if hand == "bone":
        return []
    j = arm_joints(tag, proportions)
    wrist, tip = j["wrist"], j["hand_tip"]
    length = float(np.linalg.norm(tip - wrist))
    d, a, n = hand_frame(tag, proportions)
    top = f"hand_{tag}"
    if hand == "mitten":
        mid = tip + 0.45 * length * d
        return [(f"mitten#1_{tag}", tip, mid, top), (f"mitten#2_{tag}", mid, tip + 0.9 * length * d,
                                                     f"mitten#1_{tag}")]
    if hand != "fingers":
        raise ValueError(f"unknown hand {hand!r}")
    segs = []
    for i, (_word, share) in enumerate(FINGERS, 1):
        if i == 1:
            root = wrist + 0.2 * length * d + 0.3 * length * a + 0.12 * length * n
            way = unit(0.7 * d + 0.6 * a + 0.4 * n)
            parent = top
        else:
            root = tip + (0.33 - 0.22 * (i - 2)) * length * a
            way = unit(d + (0.06 * (3.5 - i)) * a)
            parent = top
            if f"metacarpal_{tag}" in names:
                base = wrist + 0.1 * length * d + 0.5 * (root - tip)   # nearer together
                segs.append((f"metacarpal#{i}_{tag}", base, root, top))
                parent = f"metacarpal#{i}_{tag}"
        bone = share * length / 3.0
        for k in range(1, 4):
            segs.append((f"digit#{i}#{k}_{tag}", root + (k - 1) * bone * way, root + k * bone * way,
                         parent))
            parent = f"digit#{i}#{k}_{tag}"
    return segs


def _segments(names: dict, *, clavicle: bool, twist: bool, palms: int = 0, fingers: int = 1,
              proportions=None, hand: str = "bone") -> list:
    """(role key, head, tail, parent role key) for every skeleton bone, parents first. The
    palms and fingers of ``palms=N`` have keys ``palm#<i>_<tag>`` and ``finger#<i>#<k>_<tag>``."""
    segs = []
    if "root" in names:
        segs.append(("root", (0, 0, 0), (0, 0.2, 0), None))
    h0, h1 = _TORSO["hips"]
    segs.append(("hips", (0, 0, h0), (0, 0, h1), "root" if "root" in names else None))
    spine = names.get("spine", ())
    spine = (spine,) if isinstance(spine, str) else tuple(spine)
    c0 = _TORSO["chest"][0]
    parent, z = "hips", h1
    for i in range(len(spine)):
        z1 = h1 + (c0 - h1) * (i + 1) / len(spine)
        key = "spine" if len(spine) == 1 else f"spine#{i}"
        segs.append((key, (0, 0, z), (0, 0, z1), parent))
        parent, z = key, z1
    segs.append(("chest", (0, 0, _TORSO["chest"][0]), (0, 0, _TORSO["chest"][1]), parent))
    segs.append(("neck", (0, 0, _TORSO["neck"][0]), (0, 0, _TORSO["neck"][1]), "chest"))
    segs.append(("head", (0, 0, _TORSO["head"][0]), (0, 0, _TORSO["head"][1]), "neck"))
    for tag, s in SIDES.items():
        j = arm_joints(tag, proportions)
        parent = "chest"
        if clavicle and f"clavicle_{tag}" in names:
            if f"shoulder_{tag}" in names:
                segs.append((f"clavicle_{tag}", j["sternum"], j["clavicle_end"], parent))
                segs.append((f"shoulder_{tag}", j["clavicle_end"], j["shoulder"], f"clavicle_{tag}"))
                parent = f"shoulder_{tag}"
            else:
                segs.append((f"clavicle_{tag}", j["sternum"], j["shoulder"], parent))
                parent = f"clavicle_{tag}"
        for role, a, b in (("upper_arm", "shoulder", "elbow"), ("forearm", "elbow", "wrist")):
            head, tail = j[a], j[b]
            mid = 0.5 * (head + tail)
            if f"{role}_2_{tag}" in names:
                segs.append((f"{role}_{tag}", head, mid, parent))
                segs.append((f"{role}_2_{tag}", mid, tail, f"{role}_{tag}"))
                parent = f"{role}_2_{tag}"
            else:
                segs.append((f"{role}_{tag}", head, tail, parent))
                parent = f"{role}_{tag}"
            if twist:
                segs.append((f"{role}_twist_{tag}", mid, head + 0.75 * (tail - head), f"{role}_{tag}"))
        if palms:
            for i, (head, tail, finger) in enumerate(palm_joints(tag, palms, fingers, proportions), 1):
                segs.append((f"palm#{i}_{tag}", head, tail, parent))
                above = f"palm#{i}_{tag}"
                for k in range(1, fingers + 1):
                    segs.append((f"finger#{i}#{k}_{tag}", finger[k - 1], finger[k], above))
                    above = f"finger#{i}#{k}_{tag}"
        else:
            segs.append((f"hand_{tag}", j["wrist"], j["hand_tip"], parent))
            segs += hand_segments(tag, hand, names, proportions)
        x = s * 0.09
        segs.append((f"thigh_{tag}", (x, 0, 0.93), (x, -0.01, 0.50), "hips"))
        segs.append((f"shin_{tag}", (x, -0.01, 0.50), (x, 0.02, 0.08), f"thigh_{tag}"))
        segs.append((f"foot_{tag}", (x, 0.02, 0.08), (x, -0.12, 0.02), f"shin_{tag}"))
        segs.append((f"toe_{tag}", (x, -0.12, 0.02), (x, -0.18, 0.02), f"foot_{tag}"))
    return segs


def _bone_name(names: dict, key: str) -> str:
    if key.startswith("spine#"):
        return names["spine"][int(key[6:])]
    if key.startswith("palm#"):
        i, tag = key[5:].split("_")
        return palm_name(names, tag, int(i))
    if key.startswith("finger#"):
        rest, tag = key[7:].split("_")
        i, k = rest.split("#")
        return finger_name(names, tag, int(i), int(k))
    if key.startswith("digit#"):
        rest, tag = key[6:].split("_")
        i, k = rest.split("#")
        return digit_name(names, tag, int(i), int(k))
    if key.startswith("metacarpal#"):
        i, tag = key[11:].split("_")
        return names[f"metacarpal_{tag}"].format(m=int(i) - 1)
    if key.startswith("mitten#"):
        i, tag = key[7:].split("_")
        return ("MiddleHand", "Fingers")[int(i) - 1] + "." + tag
    if key in names:
        return names[key]
    role, _, tag = key.rpartition("_")          # twist bones missing from the map
    base = role[: -len("_twist")]
    return f"{names[f'{base}_{tag}']}_twist"


def lie(p) -> np.ndarray:
    """The ``lying`` rest-pose rotation, −90° about X: (x, y, z) → (x, z, −y)."""
    x, y, z = np.asarray(p, dtype=float)
    return np.array([x, z, -y])


def object_rotation(facing: str) -> np.ndarray:
    if facing == "-Y":
        return np.eye(3)
    if facing == "+Y":
        return np.diag([-1.0, -1.0, 1.0])
    raise ValueError(f"facing must be '-Y' or '+Y', not {facing!r}")


def to_world(p, *, facing="-Y", lying=False) -> np.ndarray:
    """Where construction point ``p`` (standing, facing −Y, metres) ends up in world space."""
    q = lie(p) if lying else np.asarray(p, dtype=float)
    return object_rotation(facing) @ q


# --- building ---------------------------------------------------------------------------------

def humanoid(names: dict, *, facing="-Y", scale=1.0, lying=False, skin=True, decoy=None,
             clavicle=True, twist=False, name="Humanoid", skin_radius=0.04, palms=0, fingers=1,
             proportions=None, hand="bone", roll=None, hand_roll_deg=0.0, rigid=False):
    """Build the humanoid (see the module docstring) in the current scene; returns the
    armature object, active and in Object Mode.

    ``hand``: a kind of :data:`HANDS` (sibling palms are ``palms``). ``roll``: a direction
    (construction axes) every bone's Z axis is turned toward (Blender's *Recalculate Roll*
    to an axis; None leaves Blender's default roll); ``hand_roll_deg``: the hand bones'
    roll added to that, about their own axis (mirrored on the left), so the hand's local
    axes are turned against the forearm's as on some VRM and game rigs. ``rigid``: instead
    of one skinned mesh, one box object per bone parented to the bone (a robot of rigid
    parts, no Armature modifier, no vertex groups)."""
    if decoy not in (None, "ik", "twin", "driver"):
        raise ValueError(f"unknown decoy {decoy!r}")
    if not isinstance(proportions, dict) and proportions not in PROPORTIONS:
        raise ValueError(f"unknown proportions {proportions!r}")
    if palms and (palms < 2 or decoy is not None):
        raise ValueError("palms needs 2 or more palms and no decoy")
    rot = object_rotation(facing)
    segs = _segments(names, clavicle=clavicle, twist=twist, palms=palms, fingers=fingers,
                     proportions=proportions, hand=hand)
    bone_of = {key: _bone_name(names, key) for key, *_ in segs}

    def local(p):   # construction metres → armature space
        return Vector(((lie(p) if lying else np.asarray(p, dtype=float)) / scale).tolist())

    data = bpy.data.armatures.new(name)
    arm = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(arm)
    m = np.eye(4)
    m[:3, :3] = rot * scale
    arm.matrix_world = Matrix(m.tolist())
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm

    bpy.ops.object.mode_set(mode="EDIT")
    ebones = data.edit_bones
    for key, head, tail, parent in segs:
        eb = ebones.new(bone_of[key])
        eb.head, eb.tail = local(head), local(tail)
        eb.use_deform = True
        if parent is not None:
            eb.parent = ebones[bone_of[parent]]
        if roll is not None:
            eb.align_roll(local(np.asarray(roll, dtype=float) * scale))
        if hand_roll_deg and key.startswith(("hand_", "palm#")):
            eb.roll += math.radians(hand_roll_deg) * (1.0 if key.endswith("_R") else -1.0)
    decoys = {}
    if decoy is not None:
        for tag in SIDES:
            parent = ebones[bone_of[f"upper_arm_{tag}"]].parent
            for role in ("upper_arm", "forearm", "hand"):
                src = ebones[bone_of[f"{role}_{tag}"]]
                tail = src.tail
                if f"{role}_2_{tag}" in bone_of:
                    tail = ebones[bone_of[f"{role}_2_{tag}"]].tail
                eb = ebones.new(decoy_name(names, decoy, role, tag))
                eb.head, eb.tail, eb.roll = src.head, tail, src.roll
                eb.use_deform = False
                eb.parent = parent
                parent = eb
                decoys[src.name] = eb.name
    bpy.ops.object.mode_set(mode="OBJECT")

    if decoy == "driver":
        for deform, control in decoys.items():
            c = arm.pose.bones[deform].constraints.new("COPY_TRANSFORMS")
            c.target, c.subtarget, c.influence = arm, control, 1.0
    if skin or rigid:
        radii = {key: _skin_half_width(key, proportions, skin_radius) / scale for key, *_r in segs}
        bones = [(bone_of[key], local(h), local(t), radii[key]) for key, h, t, _p in segs]
        if rigid:
            _add_rigid(arm, bones)
        else:
            _add_skin(arm, bones)
    bpy.context.view_layer.objects.active = arm
    bpy.context.view_layer.update()
    return arm


def _skin_half_width(key: str, proportions, default: float) -> float:
    """Half-width of the skin box of the bone with role key ``key``: ``default`` unless the
    ``proportions`` give one for its role (the torso's bones: ``torso_skin``)."""
    p = _proportions(proportions)
    role = key.split("#")[0]
    if role in ("digit", "metacarpal"):
        return 0.25 * default            # a finger is about a quarter of the hand's thickness
    if "skin" not in p:
        return default
    if role in ("root", "hips", "spine", "chest", "neck", "head"):
        return p["torso_skin"]
    role = role.rsplit("_", 1)[0] if role.endswith(tuple(f"_{t}" for t in SIDES)) else role
    role = role[:-2] if role.endswith("_2") else role
    return p["skin"].get(role, default)


def _add_skin(arm, bones):
    """One box per bone (armature space; (name, head, tail, half-width)), an Armature
    modifier and a vertex group per bone."""
    verts, faces, groups = [], [], []
    quads = ((0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3))
    for name, head, tail, radius in bones:
        axis = (tail - head).normalized()
        side = axis.orthogonal().normalized()
        third = axis.cross(side)
        start = len(verts)
        for end in (head, tail):
            for a in (-radius, radius):
                for b in (-radius, radius):
                    verts.append(tuple(end + side * a + third * b))
        faces += [tuple(start + i for i in q) for q in quads]
        groups.append((name, list(range(start, start + 8))))
    mesh = bpy.data.meshes.new(f"{arm.name}_skin")
    mesh.from_pydata(verts, [], faces)
    ob = bpy.data.objects.new(f"{arm.name}_skin", mesh)
    bpy.context.scene.collection.objects.link(ob)
    ob.parent = arm
    ob.matrix_parent_inverse = Matrix.Identity(4)
    for name, idx in groups:
        ob.vertex_groups.new(name=name).add(idx, 1.0, "REPLACE")
    mod = ob.modifiers.new("Armature", "ARMATURE")
    mod.object = arm
    return ob


def _add_rigid(arm, bones):
    """One box object per bone (armature space; (name, head, tail, half-width)), each
    parented to its bone where it stands, with no Armature modifier."""
    quads = ((0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3))
    bpy.context.view_layer.update()
    mw = arm.matrix_world
    out = []
    for name, head, tail, radius in bones:
        axis = (tail - head).normalized()
        side = axis.orthogonal().normalized()
        third = axis.cross(side)
        verts = [tuple(mw @ (end + side * a + third * b)) for end in (head, tail)
                 for a in (-radius, radius) for b in (-radius, radius)]
        mesh = bpy.data.meshes.new(f"{arm.name}_{name}")
        mesh.from_pydata(verts, [], list(quads))
        ob = bpy.data.objects.new(f"{arm.name}_{name}", mesh)
        bpy.context.scene.collection.objects.link(ob)
        pb = arm.pose.bones[name]
        ob.parent, ob.parent_type, ob.parent_bone = arm, "BONE", name
        at_tail = mw @ pb.matrix @ Matrix.Translation((0.0, pb.bone.length, 0.0))
        ob.matrix_parent_inverse = at_tail.inverted()
        out.append(ob)
    return out


def bone_chain(names, *, name="Chain"):
    """An armature of one vertical chain of bones (0.3 long each, parent to child) named
    ``names``, in the current scene; returns it, active and in Object Mode."""
    data = bpy.data.armatures.new(name)
    arm = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    parent = None
    for i, bone in enumerate(names):
        eb = data.edit_bones.new(bone)
        eb.head, eb.tail = (0, 0, 1.0 + 0.3 * i), (0, 0, 1.3 + 0.3 * i)
        eb.parent = parent
        parent = eb
    bpy.ops.object.mode_set(mode="OBJECT")
    return arm
