"""Rig adapter: find a humanoid's arms, chest and body frame in an armature, and turn them
into the core's :class:`~reach_addon.core.ArmModel`.

Finding the bones
-----------------
Bone names are split into lowercase tokens (``mixamorig:RightForeArm`` → mixamorig, right,
fore, arm; ``J_Bip_R_UpperArm`` → j, bip, r, upper, arm; ``upperarm01.R`` → upperarm, 01,
r). The side comes from a token r/l/right/left; the role from a small vocabulary (upper
arm, forearm/lower arm/elbow, hand/wrist/palm, clavicle/shoulder/collar). Helper bones (ik,
fk, pole, target, twist, tweak, mch, org, end, …) score lower.

For each side the best upper-arm candidate starts a chain that follows the skeleton
downward: the forearm and hand are the nearest descendants with matching names, or, for
rigs with numbered names (``Skeleton_arm_joint_R__2_``), the joints that fall at the usual
proportions of the arm (the elbow about 56% along the shoulder-to-wrist path; the forearm
about 0.78 of the upper arm). A clavicle is the upper arm's parent when it is not shared
with the other arm. The chest is the lowest bone both arms hang from.

Decoys: among candidates lying on the same joints, the chain that moves the skin (has
weighted vertices in a mesh the armature deforms) wins; a skin bone that copies its
transform from another bone of the same rig hands the keys to that bone (the control that
drives it). Rigify's generated rigs are recognised by their ``rig_id`` and the ``IK_FK``
switch: Reach reads joint positions from the ``ORG-`` chain (where the arm is) and keys the
FK controls with the switch set to FK. Every bone can be overridden by name.

A hand of several bones: some rigs (robots with rigid parts) have no single hand bone but
sibling palm bones directly under the forearm, each carrying fingers (``Palm1.R`` …
``Palm3.R``). The hand is then that group (:func:`hand_group`): the hand bone found as
above and its siblings that carry bones of their own and start where it starts. The arm
model treats the group as one hand (:func:`hand_shape`), and the bake keys every bone of
it with the same turn, so the hand stays rigid.

The body frame
--------------
Nothing about orientation or size is assumed. From the bones, in world space at the
current frame: **right** = right shoulder − left shoulder, **up** = from the base of the
spine (the chest's lowest ancestor within 2.5 shoulder widths) to the neck, made
perpendicular to right, **forward** = up × right (right × up for a mirrored armature,
whose object transform has a negative determinant: its right-side bones are on the body's
left, and the arm's canonical-to-world map is a reflection). The canonical arm frame of the
core has its origin on the spine axis (the line through the chest bone's head along up) at
shoulder height, x toward the reaching arm's side. Body capsules (chest, pelvis, head) are
sized in proportion to the shoulder half-width, and narrowed where the arm's own start pose
passes through them (:func:`clear_of_start`); arm capsule radii come from the skin when
there is one (75th percentile of vertex distances to each segment), else from proportions.

Scale: any uniform scale, and mirroring, of the armature object or its parents is measured
in world units as it is. A non-uniform one (the world matrix's singular values differ by
more than :data:`SCALE_TOLERANCE`) is refused up front with a message that names the
armature (or the parent that causes it) and the fix; :func:`_check_uniform_scale` says why
and what was measured.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..core import ArmConfig, ArmModel, Capsule, ReachError, config_from_joints
from ..core.arm import forward_kinematics, hand_angles
from ..core.collision import segment_distance_float

ROLES = ("clavicle", "upper_arm", "forearm", "hand")
SIDES = ("right", "left")

_SIDE_TOKENS = {"r": "right", "right": "right", "rt": "right", "l": "left", "left": "left",
                "lt": "left"}
_VOCAB = {
    "upper_arm": ({"upperarm"}, {"uparm"}, {"upper", "arm"}, {"up", "arm"}, {"humerus"}),
    "forearm": ({"forearm"}, {"fore", "arm"}, {"lowerarm"}, {"lower", "arm"}, {"loarm"},
                {"elbow"}, {"ulna"}),
    "hand": ({"hand"}, {"wrist"}, {"palm"}),
    "clavicle": ({"clavicle"}, {"collar"}, {"collarbone"}, {"shoulder"}),
}
# Tokens that mark helper, mechanism or non-arm bones: a candidate carrying one scores lower.
_HELPER = {"ik", "fk", "pole", "target", "twist", "roll", "tweak", "mch", "org", "ctrl", "ctl",
           "helper", "end", "nub", "parent", "socket", "vis", "wgt", "widget", "offset", "null",
           "snap", "track", "lock", "rot", "pivot", "jnt_ik"}
_NOT_ARM = {"finger", "fingers", "thumb", "index", "middle", "ring", "pinky", "little", "leg",
            "thigh", "calf", "shin", "foot", "toe", "knee", "breast", "eye", "metacarpal",
            "carpal", "weapon", "prop"}


def tokens(name: str) -> list:
    """Lowercase word tokens of a bone name (camelCase, separators and digits split)."""
    s = re.sub(r"([a-z])([A-Z])", r"\1 \2", name)
    s = re.sub(r"([A-Za-z])(\d)", r"\1 \2", s)
    s = re.sub(r"(\d)([A-Za-z])", r"\1 \2", s)
    return [t for t in re.split(r"[^A-Za-z0-9]+", s.lower()) if t]


def side_of(name: str):
    """'right', 'left' or None from the name's tokens."""
    found = {_SIDE_TOKENS[t] for t in tokens(name) if t in _SIDE_TOKENS}
    return found.pop() if len(found) == 1 else None


def role_score(name: str, role: str) -> int:
    """How well a name fits a role: 0 if not at all, more for a clean match."""
    toks = set(tokens(name)) - set(_SIDE_TOKENS)
    if toks & _NOT_ARM:
        return 0
    if role == "upper_arm" and "arm" in toks and not toks & {"fore", "lower", "lo", "forearm"}:
        base = 6 if toks & {"upper", "up"} else 4
    elif any(words <= toks for words in _VOCAB[role]):
        base = 6
    else:
        return 0
    if role == "hand" and "palm" in toks and not toks & {"hand", "wrist"}:
        base -= 1  # "palm" names a hand in some rigs but a metacarpal in others
    return max(1, base - 3 * len(toks & _HELPER))


@dataclass
class ArmBones:
    """The bones of one arm. ``key_*`` are the bones that get keys; the plain names are the
    bones whose joints say where the arm is (the same bones except on Rigify rigs)."""

    upper_arm: str
    forearm: str
    hand: str
    clavicle: str | None = None
    key: dict = field(default_factory=dict)

    def keyed(self, role: str):
        return self.key.get(role, getattr(self, role))


@dataclass
class BoneMap:
    chest: str
    arms: dict                 # side -> ArmBones
    neck: str | None = None    # the spine above the chest: gives the body's up
    key_chest: str | None = None
    ik_fk: dict = field(default_factory=dict)   # side -> (pose bone, property) to set to FK

    @property
    def keyed_chest(self) -> str:
        return self.key_chest or self.chest

    def to_dict(self) -> dict:
        out = {"chest": self.keyed_chest}
        for side, a in self.arms.items():
            for role in ROLES:
                out[f"{role}_{side}"] = a.keyed(role)
        return out


# --- detection ---------------------------------------------------------------------------

def deformed_by(ob, armature) -> bool:
    """Is ``ob`` a mesh whose Armature modifier uses ``armature`` (its skin)?"""
    return ob.type == "MESH" and any(m.type == "ARMATURE" and m.object == armature
                                     for m in ob.modifiers)


def rigid_part(ob, armature) -> str | None:
    """The bone a mesh is parented to, if it is a rigid part of ``armature`` (a robot's or
    a prop-built character's body: no skin, each part carried by one bone), else None."""
    if ob.type == "MESH" and ob.parent == armature and ob.parent_type == "BONE" and \
            ob.parent_bone in armature.data.bones and not deformed_by(ob, armature):
        return ob.parent_bone
    return None


def skin_bones(armature) -> set:
    """Names of bones that move skin: vertex groups with weighted vertices in meshes whose
    Armature modifier uses this armature, and bones that carry rigid parts (meshes
    parented to them)."""
    out = set()
    for ob in _scene_objects(armature):
        bone = rigid_part(ob, armature)
        if bone is not None and len(ob.data.vertices):
            out.add(bone)
        if not deformed_by(ob, armature):
            continue
        names = {vg.index: vg.name for vg in ob.vertex_groups}
        weighted = set()
        for v in ob.data.vertices:
            for g in v.groups:
                if g.weight > 0.0:
                    weighted.add(g.group)
        out |= {names[i] for i in weighted if i in names}
    return out


def skin_points(armature, bone_names, weight: float = 0.5) -> np.ndarray:
    """World positions (n, 3) of the skin that ``bone_names`` move, as Blender evaluates it
    now: the vertices weighted at least ``weight`` to their vertex groups in the meshes the
    armature deforms, and every vertex of the rigid parts parented to them. Empty (0, 3)
    where these bones move no skin."""
    out = []
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for ob in _scene_objects(armature):
        rigid = rigid_part(ob, armature)
        if rigid is None and not deformed_by(ob, armature):
            continue
        if rigid is not None:
            if rigid not in bone_names:
                continue
            chosen = None
        else:
            idx = {vg.index for vg in ob.vertex_groups if vg.name in bone_names}
            if not idx:
                continue
            chosen = [v.index for v in ob.data.vertices
                      if any(g.group in idx and g.weight >= weight for g in v.groups)]
            if not chosen:
                continue
        ev = ob.evaluated_get(depsgraph)
        mesh = ev.data
        if len(mesh.vertices) != len(ob.data.vertices) or not len(mesh.vertices):
            continue
        co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3).astype(float)
        if chosen is not None:
            co = co[chosen]
        mw = np.array(ev.matrix_world)
        out.append(co @ mw[:3, :3].T + mw[:3, 3])
    return np.concatenate(out) if out else np.zeros((0, 3))


def _scene_objects(armature):
    scenes = armature.users_scene
    return scenes[0].objects if scenes else [armature]


def _ancestors(bone):
    out = []
    while bone.parent is not None:
        bone = bone.parent
        out.append(bone)
    return out


def _lca(a, b):
    chain = [a] + _ancestors(a)
    names = {x.name for x in [b] + _ancestors(b)}
    return next((x for x in chain if x.name in names), None)


def _reach(bone) -> float:
    """Total bone length of a subtree (its size, in the rig's units)."""
    return bone.length + sum(b.length for b in bone.children_recursive)


def _dominant_child(bone):
    """The child that carries the limb on, or None at a fork into comparable branches
    (fingers, or the arms and neck at a chest): the biggest subtree if it is at least twice
    the size of the next. Helper bones (twist, roll, ik, …) step aside first."""
    kids = [c for c in bone.children if not set(tokens(c.name)) & _HELPER] or list(bone.children)
    kids = sorted(kids, key=_reach, reverse=True)
    if not kids:
        return None
    if len(kids) == 1 or _reach(kids[0]) >= 2.0 * _reach(kids[1]):
        return kids[0]
    return None


def _main_chain(start, max_len=12):
    """The bones below ``start`` along the arm: at each step the child that looks like an
    arm bone, else the child that dominates the rest (a twist leaf beside the limb does
    not); stops at a fork into comparable branches (the fingers)."""
    chain = [start]
    bone = start
    while bone.children and len(chain) < max_len:
        named = [c for c in bone.children if any(role_score(c.name, r) for r in ("forearm", "hand"))
                 and not set(tokens(c.name)) & _NOT_ARM]
        if named:
            bone = max(named, key=lambda c: (max(role_score(c.name, r) for r in ("forearm", "hand")),
                                             -len(c.children_recursive)))
        else:
            bone = _dominant_child(bone)
            if bone is None:
                break
        chain.append(bone)
    return chain


def _arm_from(upper, side, skin):
    """Complete an arm chain from its upper arm: forearm and hand by name, else by the
    usual proportions along the chain."""
    chain = _main_chain(upper)
    heads = [np.array(b.head_local) for b in chain]
    fore = next((b for b in chain[1:] if role_score(b.name, "forearm")), None)
    if fore is None:
        if len(chain) < 3:
            return None
        path = np.concatenate([[0.0], np.cumsum([np.linalg.norm(h2 - h1)
                                                 for h1, h2 in zip(heads, heads[1:])])])
        target = 0.56 * path[-1]
        fore = chain[1 + int(np.argmin(np.abs(path[1:-1] - target)))]
    i_fore = chain.index(fore)
    after = chain[i_fore + 1:]
    hand = next((b for b in after if role_score(b.name, "hand")), None)
    if hand is None:
        if not after:
            return None
        upper_len = np.linalg.norm(np.array(fore.head_local) - heads[0])
        dist = [np.linalg.norm(np.array(b.head_local) - np.array(fore.head_local)) for b in after]
        hand = after[int(np.argmin(np.abs(np.array(dist) - 0.78 * upper_len)))]
    return upper, fore, hand


def _candidates(bones, role, side, skin):
    out = []
    for b in bones:
        score = role_score(b.name, role)
        if not score or side_of(b.name) != side:
            continue
        if b.name in skin:
            score += 3
        out.append((score, -len(_ancestors(b)), b.name, b))
    return [b for *_k, b in sorted(out, key=lambda t: (-t[0], -t[1], t[2]))]


def _driver(armature, name):
    """The bone that drives ``name`` through a Copy Transforms/Rotation constraint at full
    influence, if it sits on the same joint; else ``name`` itself."""
    pb = armature.pose.bones.get(name)
    bone = armature.data.bones[name]
    for c in getattr(pb, "constraints", ()):
        if c.type in {"COPY_TRANSFORMS", "COPY_ROTATION"} and not c.mute and c.influence > 0.99 \
                and getattr(c, "target", None) == armature and c.subtarget in armature.data.bones:
            other = armature.data.bones[c.subtarget]
            gap = np.linalg.norm(np.array(other.head_local) - np.array(bone.head_local))
            if gap <= 1e-3 * max(bone.length, 1e-6):
                return c.subtarget
    return name


def _rigify_map(armature):
    """Bone map of a Rigify generated rig, or None if it is not one."""
    data = armature.data
    if "rig_id" not in data.keys():
        return None
    arms, ik_fk = {}, {}
    for side, suffix in (("right", ".R"), ("left", ".L")):
        needed = [f"ORG-{n}{suffix}" for n in ("upper_arm", "forearm", "hand")] + \
                 [f"{n}_fk{suffix}" for n in ("upper_arm", "forearm", "hand")]
        if not all(n in data.bones for n in needed):
            return None
        clav = f"ORG-shoulder{suffix}" if f"ORG-shoulder{suffix}" in data.bones else None
        key = {"upper_arm": f"upper_arm_fk{suffix}", "forearm": f"forearm_fk{suffix}",
               "hand": f"hand_fk{suffix}"}
        if clav and f"shoulder{suffix}" in data.bones:
            key["clavicle"] = f"shoulder{suffix}"
        arms[side] = ArmBones(f"ORG-upper_arm{suffix}", f"ORG-forearm{suffix}",
                              f"ORG-hand{suffix}", clav, key)
        parent = armature.pose.bones.get(f"upper_arm_parent{suffix}")
        if parent is not None and "IK_FK" in parent.keys():
            ik_fk[side] = (parent.name, "IK_FK")
    chest_pos = _lca(data.bones[arms["right"].upper_arm], data.bones[arms["left"].upper_arm])
    key_chest = "chest" if "chest" in data.bones else None
    neck = "ORG-spine.004" if "ORG-spine.004" in data.bones else None
    return BoneMap(chest_pos.name if chest_pos else arms["right"].upper_arm, arms, neck,
                   key_chest, ik_fk)


def detect_bones(armature, overrides=None) -> BoneMap:
    """Find the chest and both arms of ``armature`` (see the module docstring). ``overrides``
    maps ``chest`` / ``<role>_<side>`` to bone names; they win over detection. Raises
    :class:`ReachError` naming the armature when no arm can be found."""
    overrides = {k: v for k, v in (overrides or {}).items() if v}
    data = armature.data
    for role_side, name in overrides.items():
        if name not in data.bones:
            raise ReachError(f"bone '{name}' (set for {role_side.replace('_', ' ')}) is not in "
                             f"armature '{armature.name}'; pick one of its bones or clear the field")
    bmap = _rigify_map(armature)
    if bmap is None:
        bmap = _detect_generic(armature, overrides)
    for side in SIDES:
        arm = bmap.arms.get(side)
        for role in ROLES:
            name = overrides.get(f"{role}_{side}")
            if name and arm is not None:
                setattr(arm, role, name)
                arm.key.pop(role, None)
    if overrides.get("chest"):
        bmap.chest, bmap.key_chest = overrides["chest"], None
    _check_chain(armature, bmap)
    return bmap


def _detect_generic(armature, overrides=None) -> BoneMap:
    """Bone map of a rig by its names (else its topology); an arm that neither finds is
    taken from ``overrides`` when they name its upper arm, forearm and hand."""
    overrides = overrides or {}
    data = armature.data
    bones = list(data.bones)
    skin = skin_bones(armature)
    arms = {}
    for side in SIDES:
        for upper in _candidates(bones, "upper_arm", side, skin):
            found = _arm_from(upper, side, skin)
            if found is None:
                continue
            u, f, h = found
            arms[side] = ArmBones(u.name, f.name, h.name)
            break
    if not arms:
        arms = _arms_by_topology(armature, skin)
    chain = ("upper_arm", "forearm", "hand")
    for side in SIDES:
        names = [overrides.get(f"{role}_{side}") for role in chain]
        if side not in arms and all(names):
            arms[side] = ArmBones(*names)
    missing = [s for s in SIDES if s not in arms]
    if missing:
        unset = [f"{role}_{s}" for s in missing for role in chain if not overrides.get(f"{role}_{s}")]
        raise ReachError(
            f"armature '{armature.name}' has no recognisable {' or '.join(missing)} arm "
            "(looked for upper arm / forearm / hand bones with a left/right marker); set "
            f"{', '.join(unset)} by hand in the Reach panel (Bones; --bone ROLE=BONE on the "
            "command line; both arms are needed, their shoulders give the body's frame) or "
            "load a rig map preset")
    upper_r, upper_l = data.bones[arms["right"].upper_arm], data.bones[arms["left"].upper_arm]
    chest = _lca(upper_r, upper_l)
    if chest is None and overrides.get("chest"):
        chest = data.bones[overrides["chest"]]
    if chest is None:
        raise ReachError(f"the arms of armature '{armature.name}' are not joined by a chest "
                         "bone; set the chest bone by hand in the Reach panel")
    for side, upper in (("right", upper_r), ("left", upper_l)):
        parent = upper.parent
        if parent is not None and parent != chest and _lca(parent, chest) == chest:
            arms[side].clavicle = parent.name
        # decoys: let the control that drives a skin bone take the keys
        a = arms[side]
        for role in ROLES:
            name = getattr(a, role)
            if name:
                drv = _driver(armature, name)
                if drv != name:
                    a.key[role] = drv
    clavicles = {arms[s].clavicle for s in SIDES if arms[s].clavicle}
    neck = _find_neck(chest, {upper_r.name, upper_l.name} | clavicles)
    return BoneMap(chest.name, arms, neck.name if neck else None)


def _chain_end(bone):
    """The last bone of the limb that starts at ``bone``, or None if the subtree forks into
    comparable branches before its end-fork (then it is not a limb: a spine carries arms
    and a neck)."""
    chain = _main_chain(bone, max_len=64)
    end = chain[-1]
    total = _reach(bone)
    # Past the limb's own end only small branches (fingers, toes) may remain.
    if end.children and max(_reach(c) for c in end.children) > 0.2 * total:
        return None
    return end


def _arms_by_topology(armature, skin):
    """Arms of a rig whose bone names say nothing (no left/right marker): the two child
    chains of one bone whose ends lie farthest apart are the arms; the feet (the leg chains'
    last bones point forward) tell right from left. {} if that cannot be decided."""
    bones = list(armature.data.bones)
    best = None
    for b in bones:
        kids = [c for c in b.children if len(c.children_recursive) >= 2]
        for i, c1 in enumerate(kids):
            for c2 in kids[i + 1:]:
                e1, e2 = _chain_end(c1), _chain_end(c2)
                if e1 is None or e2 is None:
                    continue
                gap = np.linalg.norm(np.array(e1.head_local) - np.array(e2.head_local))
                if best is None or gap > best[0]:
                    best = (gap, b, c1, c2)
    if best is None:
        return {}
    _gap, chest, c1, c2 = best
    legs = [c for a in _ancestors(chest) for c in a.children
            if c not in _ancestors(chest) + [chest] and len(c.children_recursive) >= 2]
    if len(legs) < 2:
        return {}
    neck = _find_neck(chest, {c1.name, c2.name})
    chest_head = np.array(chest.head_local)
    up = (np.array(neck.head_local) if neck else np.array(chest.tail_local)) - chest_head
    up /= np.linalg.norm(up)
    forward = np.zeros(3)
    for leg in legs:
        foot = _chain_end(leg)
        if foot is None:
            continue
        d = np.array(foot.tail_local) - np.array(foot.head_local)
        forward += d - (d @ up) * up
    if np.linalg.norm(forward) < 1e-9:
        return {}
    right = np.cross(forward / np.linalg.norm(forward), up)
    arms = {}
    for root in (c1, c2):
        chain = _main_chain(root)
        # A short first bone followed by a long one is a clavicle.
        upper = chain[1] if len(chain) >= 4 and root.length < 0.6 * chain[1].length else root
        found = _arm_from(upper, None, skin)
        if found is None:
            return {}
        side = "right" if (np.array(upper.head_local) - chest_head) @ right > 0 else "left"
        arms[side] = ArmBones(*(b.name for b in found))
    return arms if len(arms) == 2 else {}


def _find_neck(chest, arm_roots):
    """Where the spine continues above the chest: the chest's child, outside both arms,
    with the most bones below it (neck, head and face hang there)."""
    others = [c for c in chest.children
              if c.name not in arm_roots and not any(a in {x.name for x in c.children_recursive}
                                                     for a in arm_roots)]
    return max(others, key=lambda c: (len(c.children_recursive), c.length), default=None)


#: How far (in the hand bone's own lengths) a sibling's head may lie from the hand bone's
#: head for the sibling to be a palm of the same hand (:func:`hand_group`).
PALM_HEAD_TOLERANCE = 0.1


def hand_group(armature, hand_name) -> tuple:
    """The bones that make the hand whose (first) bone is ``hand_name``: that bone first,
    then its palm siblings in the order of the parent's children. A sibling (another child
    of the forearm) is a palm of the same hand when it carries bones of its own (fingers),
    is no helper bone (twist, ik, mch, … see :data:`_HELPER`; nor a weapon or prop bone),
    points away from the elbow and has its head within :data:`PALM_HEAD_TOLERANCE`
    hand-bone lengths of the hand bone's head, the wrist they then share. A hand bone
    without such siblings is a group of one (every rig with a hand bone). The group turns as
    one rigid hand about that wrist."""
    bones = armature.data.bones
    hand = bones[hand_name]
    parent = hand.parent
    if parent is None:
        return (hand_name,)
    head = np.array(hand.head_local)
    onward = head - np.array(parent.head_local)
    tol = PALM_HEAD_TOLERANCE * max(hand.length, 1e-9)
    out = [hand_name]
    for c in parent.children:
        if c.name == hand_name or not c.children or \
                set(tokens(c.name)) & (_HELPER | {"weapon", "prop"}):
            continue
        if np.linalg.norm(np.array(c.head_local) - head) > tol:
            continue
        if (np.array(c.tail_local) - np.array(c.head_local)) @ onward <= 0.0:
            continue
        out.append(c.name)
    return tuple(out)


def _check_chain(armature, bmap):
    data = armature.data
    for side, arm in bmap.arms.items():
        u, f, h = (data.bones[n] for n in (arm.upper_arm, arm.forearm, arm.hand))
        if f not in u.children_recursive or h not in f.children_recursive:
            raise ReachError(
                f"in armature '{armature.name}' the {side} arm bones do not form a chain "
                f"({arm.upper_arm} → {arm.forearm} → {arm.hand}); check the bone fields")


# --- pose and body frame -------------------------------------------------------------------

def pose_heads(armature, names) -> dict:
    """World-space heads of pose bones (the evaluated pose at the current frame)."""
    mw = np.array(armature.matrix_world)
    out = {}
    for n in names:
        if n is None:
            continue
        h = np.array(armature.pose.bones[n].head)
        out[n] = mw[:3, :3] @ h + mw[:3, 3]
    return out


@dataclass
class BodyFrame:
    """World-space body axes and lengths measured from the bones."""

    origin: np.ndarray       # on the spine axis at shoulder height
    right: np.ndarray
    forward: np.ndarray
    up: np.ndarray
    shoulder_half_width: float

    def to_world(self, side: str) -> np.ndarray:
        """Canonical (x toward ``side``) → world, 4×4."""
        m = np.eye(4)
        x = self.right if side == "right" else -self.right
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, self.forward, self.up, self.origin
        return m


def world_length(armature, vector) -> float:
    """World length of a vector given in the armature's space (rest bones), under its
    object's whole transform: non-uniform and negative (mirroring) scale included."""
    return float(np.linalg.norm(np.array(armature.matrix_world)[:3, :3] @ np.asarray(vector)))


def _spine_base(armature, chest_name, shoulder_width):
    """The lowest spine bone below the chest: its farthest ancestor within 2.5 shoulder
    widths (so a root bone at the floor does not count), or the chest itself."""
    bones = armature.data.bones
    chest = np.array(bones[chest_name].head_local)
    best, best_d = chest_name, 0.0
    for b in _ancestors(bones[chest_name]):
        d = world_length(armature, np.array(b.head_local) - chest)
        if best_d < d <= 2.5 * shoulder_width:
            best, best_d = b.name, d
    return best


def body_frame(armature, bmap: BoneMap) -> BodyFrame:
    names = [bmap.chest, bmap.neck, bmap.arms["right"].upper_arm, bmap.arms["left"].upper_arm]
    heads = pose_heads(armature, names)
    shoulder_r = heads[bmap.arms["right"].upper_arm]
    shoulder_l = heads[bmap.arms["left"].upper_arm]
    right = shoulder_r - shoulder_l
    width = float(np.linalg.norm(right))
    if not np.isfinite(width) or width < 1e-9:
        raise ReachError(f"the shoulders of armature '{armature.name}' coincide (zero scale?); "
                         "check the armature's scale and the arm bones")
    right /= width
    chest = heads[bmap.chest]
    base = pose_heads(armature, [_spine_base(armature, bmap.chest, width)])
    base = next(iter(base.values()))
    top = heads[bmap.neck] if bmap.neck else 0.5 * (shoulder_r + shoulder_l)
    up = top - base
    up = up - (up @ right) * right
    if np.linalg.norm(up) < 1e-6 * width:
        raise ReachError(f"cannot tell which way is up on armature '{armature.name}': the "
                         "neck is level with the chest; set the chest bone by hand")
    up /= np.linalg.norm(up)
    # A mirrored armature (a negative determinant: scale −1 on one axis) has its right-side
    # bones on the body's left: the right, up and forward of its bones make a left-handed
    # frame, so forward is the other way round. The arm's to_world is then a reflection,
    # which the core allows.
    forward = np.cross(up, right) * np.sign(np.linalg.det(np.array(armature.matrix_world)[:3, :3]))
    mid = 0.5 * (shoulder_r + shoulder_l)
    origin = chest + up * ((mid - chest) @ up)
    half = float(np.linalg.norm((shoulder_r - origin) - ((shoulder_r - origin) @ up) * up))
    return BodyFrame(origin, right, forward, up, half)


def _skin_radius(armature, group_names, a, b, fallback):
    """75th percentile distance from segment a-b (world) of the skin the bones
    ``group_names`` move (:func:`skin_points`: weighted ≥ 0.5, or rigid parts parented to
    them); ``fallback`` if there is no such skin."""
    pts = skin_points(armature, set(group_names))
    if not len(pts):
        return fallback
    ab = b - a
    t = np.clip((pts - a) @ ab / max(ab @ ab, 1e-12), 0, 1)
    return float(np.percentile(np.linalg.norm(pts - (a + t[:, None] * ab), axis=1), 75))


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


@dataclass
class Digits:
    """The fingers below a hand, read by hierarchy and position, world space: ``chains``
    the joints (k, 3) of each finger's own bones (a root-to-leaf path below the hand, less
    the bones it shares with another path: a metacarpal carrying two fingers), ``thumb``
    the index of the chain that is the thumb (or None), ``wrist`` the hand bone's head."""

    wrist: np.ndarray
    chains: list
    thumb: int | None

    @property
    def fingers(self) -> list:
        """The chains but the thumb."""
        return [c for i, c in enumerate(self.chains) if i != self.thumb]


#: A chain is the thumb when its direction is at least this far (degrees) from the hand's
#: mean finger direction and this much farther than any other chain's (:func:`digits`) ...
THUMB_DIVERGENCE = 25.0
THUMB_MARGIN = 10.0
#: ... or when its tip reaches along the hand at most this share of the other chains'
#: median reach.
THUMB_REACH = 0.75


def digits(armature, group) -> Digits:
    """The fingers below the hand bones ``group`` (:func:`hand_group`) in the pose on
    screen (:class:`Digits`), helper bones (FBX "_end" leaves, tweaks) left out.

    The thumb is the chain whose own bones are named so (``thumb``, on either side: a
    Quaternius thumb named for the wrong side counts); failing a name (MakeHuman's
    ``finger1``), the digit that stands apart from the others by position (with three
    chains or more): its direction (first own joint to tip) at least
    :data:`THUMB_DIVERGENCE` from the mean of all of them and :data:`THUMB_MARGIN` farther
    than any other's, or else its tip the nearest the wrist along the hand and within
    :data:`THUMB_REACH` of the others' median (a thumb lying along the hand, as Rigify's
    metarig has it). A mitten (one chain) or fingers all alike have none."""
    mw = np.array(armature.matrix_world)
    bones = armature.pose.bones
    wrist = mw[:3, :3] @ np.array(bones[group[0]].head) + mw[:3, 3]
    paths = []

    def walk(bone, path):
        kids = [c for c in bone.children if not set(tokens(c.name)) & _HELPER]
        if not kids:
            paths.append(path)
        for c in kids:
            walk(c, path + [c])

    for name in group:
        for c in bones[name].children:
            if c.name not in group and not set(tokens(c.name)) & _HELPER:
                walk(c, [c])
    uses: dict = {}
    for path in paths:
        for b in path:
            uses[b.name] = uses.get(b.name, 0) + 1
    owns = [[b for b in path if uses[b.name] == 1] or path[-1:] for path in paths]
    chains = [np.array([own[0].head] + [b.tail for b in own]) @ mw[:3, :3].T + mw[:3, 3]
              for own in owns]
    thumb = next((i for i, own in enumerate(owns)
                  if any("thumb" in tokens(b.name) for b in own)), None)
    if thumb is None and len(chains) >= 3:
        ways = [c[-1] - c[0] for c in chains]
        ways = [w / max(float(np.linalg.norm(w)), 1e-12) for w in ways]
        mean = np.mean(ways, axis=0)
        mean /= max(float(np.linalg.norm(mean)), 1e-12)
        off = np.degrees(np.arccos(np.clip([w @ mean for w in ways], -1.0, 1.0)))
        order = np.argsort(off)[::-1]
        if off[order[0]] >= THUMB_DIVERGENCE and off[order[0]] >= off[order[1]] + THUMB_MARGIN:
            thumb = int(order[0])
        else:
            reach = np.array([(c[-1] - wrist) @ mean for c in chains])
            k = int(np.argmin(reach))
            if reach[k] <= THUMB_REACH * float(np.median(np.delete(reach, k))):
                thumb = k
    return Digits(wrist, chains, thumb)


#: The longest hand (wrist to its farthest finger joint along its axis) the rig adapter
#: reads, in forearm lengths: an alien's fingers reach nearly two forearms past its wrist
#: (Quaternius' Alien, 1.9), and a hand capped shorter leaves its fingertips unchecked.
HAND_REACH_MAX = 2.0


def hand_shape(armature, hand_name, forearm_len, group=None):
    """The hand as the planner models it, read from the pose on screen: (axis, length,
    spread) in world space — the unit direction from the wrist to the mean of the finger
    joints (bone heads and tails below the hand, without helper bones such as FBX "_end"
    leaves or Rigify tweaks), the farthest joint along it (between 0.4 and :data:`HAND_REACH_MAX` forearm),
    and the farthest joint from the axis. A hand with no fingers points along its bone and
    is 0.74 forearm long (Drillis & Contini), its spread 0. It is the axis of the hand's
    capsule, the middle of its mass; the direction the fingers point, which a target's
    orientation names, is :func:`finger_axis` (a thumb standing out to the side turns the
    mean of every joint 5–13° from it).

    ``group``: the hand's bones (:func:`hand_group`; default the hand bone alone). A hand
    of several palm bones is measured the same way from the wrist they share over the
    fingers of all of them: its axis points to the mean of all their finger joints (between
    the palms, the middle of the hand), its length reaches the farthest fingertip along
    that axis, and its spread is the outermost joint of any finger (the capsule covers the
    fanned palms). Taking the palms' tails instead would end the hand at the knuckles and
    leave the fingers outside its capsule.

    The direction the planner plans for is the one the bake turns, so the keyed hand is
    where the plan put it."""
    mw = np.array(armature.matrix_world)
    pb = armature.pose.bones[hand_name]
    group = group or (hand_name,)
    kids = [b for n in group for b in armature.pose.bones[n].children_recursive
            if not set(tokens(b.name)) & _HELPER]
    wrist = mw[:3, :3] @ np.array(pb.head) + mw[:3, 3]
    if not kids:
        tails = np.mean([np.array(armature.pose.bones[n].tail) for n in group], axis=0)
        axis = mw[:3, :3] @ (tails - np.array(pb.head))
        return axis / max(float(np.linalg.norm(axis)), 1e-12), 0.74 * forearm_len, 0.0
    rel = np.array([p for b in kids for p in (b.head, b.tail)]) @ mw[:3, :3].T + mw[:3, 3] - wrist
    axis = rel.mean(0)
    if np.linalg.norm(axis) < 1e-9:
        axis = mw[:3, :3] @ (np.array(pb.tail) - np.array(pb.head))
    axis = axis / max(float(np.linalg.norm(axis)), 1e-12)
    along = rel @ axis
    length = float(np.clip(along.max(), 0.4 * forearm_len, HAND_REACH_MAX * forearm_len))
    spread = float(np.linalg.norm(rel - along[:, None] * axis, axis=1).max())
    return axis, length, spread


def _knuckle(chain, wrist, axis) -> np.ndarray:
    """Where a finger chain (joints, world) leaves the palm: its first joint, or its second
    where its first bone is a metacarpal (the chain has four bones or more and starts within
    a quarter of its reach from the wrist along the hand's ``axis``)."""
    reach = float((chain[-1] - wrist) @ axis)
    if len(chain) >= 5 and float((chain[0] - wrist) @ axis) <= 0.25 * reach:
        return chain[1]
    return chain[0]


def finger_axis(armature, group, hand_axis) -> np.ndarray:
    """The direction the fingers point in the pose on screen (world, unit): the wrist to the
    middle finger's knuckle (:func:`_knuckle`), read by position (:func:`digits`): the
    fingers but the thumb, in their order across the hand from the thumb's side, the second
    (index, *middle*, ring, little; a three-fingered hand's middle one); of two fingers
    beside a thumb the one nearer it; of two without one, or an even count without a thumb,
    the middle of the central two; a mitten's one chain. A hand without fingers points
    along ``hand_axis`` (:func:`hand_shape`)."""
    axis = np.asarray(hand_axis, dtype=float)
    found = digits(armature, group)
    fingers = found.fingers
    if not fingers:
        return axis
    knuckles = [_knuckle(c, found.wrist, axis) for c in fingers]
    rel = [k - found.wrist for k in knuckles]
    lateral = [r - (r @ axis) * axis for r in rel]
    if found.thumb is not None:
        t = found.chains[found.thumb].mean(0) - found.wrist
        t = t - (t @ axis) * axis
        order = sorted(range(len(fingers)), key=lambda i: -float(lateral[i] @ t))
        pick = [order[1]] if len(order) >= 3 else [order[0]]
    else:
        spread = max(((float(np.linalg.norm(a - b)), a - b) for a in lateral for b in lateral),
                     key=lambda x: x[0])[1]
        order = sorted(range(len(fingers)), key=lambda i: float(lateral[i] @ spread))
        m = len(order)
        pick = [order[m // 2]] if m % 2 else [order[m // 2 - 1], order[m // 2]]
    v = np.mean([rel[i] for i in pick], axis=0)
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else axis


def palm_normal(armature, group, hand_axis, up, to_canonical):
    """The direction the palm faces in the pose on screen, canonical arm frame (unit,
    perpendicular to the hand's axis), for :mod:`reach_addon.core.orient`; and where it was
    read from. Returns (normal, source).

    In the canonical frame every arm is a right arm (x toward its side, y forward, z up;
    a left arm's frame is mirrored), so one rule serves both sides: n = a × d, with d the
    fingers' direction (:func:`finger_axis`; ``hand_axis``, world, :func:`hand_shape`,
    where there are no fingers) and a the direction across the palm toward the thumb, made
    perpendicular to d. (A right hand hanging palm forward:
    d down, a outward, a × d forward.) Read by hierarchy and position (:func:`digits`),
    never by name:

    * ``"fingers"``: the knuckle line, across the two fingers whose knuckles
      (:func:`_knuckle`) lie farthest apart across the hand, signed toward the thumb;
    * ``"thumb"``: with one finger chain besides the thumb (a mitten with a thumb), from
      that chain's joints on average to the thumb's (the thumb stands a little toward the
      palm, which tilts n by that much: about 9° on Quaternius' hands);
    * ``"fingers, rest pose"``: fingers but no thumb (a three-fingered or thumbless hand):
      the knuckle line, its sign from the rest-pose rule below;
    * ``"skin"``: no knuckle line (a mitten, a hand bone alone) but a skin: the hand skin's
      thinnest direction (the least principal axis of its vertices, made perpendicular to
      d), its sign from the rest-pose rule;
    * ``"rest pose"``: nothing else to go by: the palm faces down in the rest pose, as in a
      T or A pose (``up``: the body's up, world), carried by the hand bone from rest to the
      pose on screen.

    ``to_canonical``: the 3 × 3 map of world vectors into the canonical frame."""
    mw = np.array(armature.matrix_world)
    m3 = mw[:3, :3]
    d = to_canonical @ finger_axis(armature, group, hand_axis)

    def unit(v):
        v = np.asarray(v, dtype=float)
        v = v - (v @ d) * d
        n = float(np.linalg.norm(v))
        return v / n if n > 1e-9 else None

    # the rest-pose rule: palm down at rest, carried to the pose on screen
    bone, pose_bone = armature.data.bones[group[0]], armature.pose.bones[group[0]]
    rest = np.array(bone.matrix_local)[:3, :3]
    down = -np.linalg.solve(m3, np.asarray(up, dtype=float))          # armature space
    axis = rest[:, 1] / max(float(np.linalg.norm(rest[:, 1])), 1e-12)
    down = down - (down @ axis) * axis
    if np.linalg.norm(down) < 1e-9:
        down = rest[:, 2]
    now = np.array(pose_bone.matrix)[:3, :3] @ np.linalg.solve(rest, down)
    assumed = unit(to_canonical @ (m3 @ now))
    if assumed is None:
        assumed = unit(np.cross(d, [0.0, 0.0, 1.0])) if abs(d[2]) < 0.99 else np.array([1.0, 0, 0])

    found = digits(armature, group)
    # each chain's knuckle (the thumb: its joints on average; its root may sit with the
    # others' at the wrist) as an offset across the fingers' direction (canonical)
    axis = np.asarray(hand_axis, dtype=float)
    lateral = [to_canonical @ ((c.mean(0) if i == found.thumb else _knuckle(c, found.wrist, axis))
                               - found.wrist) for i, c in enumerate(found.chains)]
    lateral = [v - (v @ d) * d for v in lateral]
    fingers = [v for i, v in enumerate(lateral) if i != found.thumb]
    thumb = lateral[found.thumb] if found.thumb is not None else None
    across, source = None, None
    if len(fingers) >= 2:
        pairs = [(float(np.linalg.norm(p - q)), k, j) for k, p in enumerate(fingers)
                 for j, q in enumerate(fingers) if k < j]
        _gap, k, j = max(pairs)
        across = fingers[k] - fingers[j]
        if thumb is not None:
            if across @ (thumb - np.mean(fingers, axis=0)) < 0:
                across = -across
            source = "fingers"
        else:
            source = "fingers, rest pose"
    elif len(fingers) == 1 and thumb is not None:
        # the finger's joints on average (a mitten's knuckle lies on the hand's axis)
        finger = to_canonical @ (found.fingers[0].mean(0) - found.wrist)
        across, source = thumb - (finger - (finger @ d) * d), "thumb"
    elif len(found.chains) <= 1:
        thin = _skin_thin_axis(armature, group, d, to_canonical)
        if thin is not None:
            across, source = np.cross(d, thin), "skin"        # a × d = thin, up to sign
    a = None if across is None else unit(across)
    if a is None:
        return assumed, "rest pose"
    n = np.cross(a, d)
    n /= np.linalg.norm(n)
    if source != "fingers" and source != "thumb" and n @ assumed < 0:
        n = -n
    return n, source


def _skin_thin_axis(armature, group, d, to_canonical):
    """The thinnest direction (canonical, unit, perpendicular to d) of the skin that the
    hand's bones and the bones below them move, or None without such skin."""
    names = set(group) | {b.name for n in group for b in armature.pose.bones[n].children_recursive}
    pts = skin_points(armature, names)
    if len(pts) < 4:
        return None
    c = (pts - pts.mean(0)) @ np.asarray(to_canonical, dtype=float).T
    c = c - np.outer(c @ d, d)                         # across the hand's axis only
    _w, vecs = np.linalg.eigh(c.T @ c)
    for k in range(3):                                 # the least, other than along d
        v = vecs[:, k]
        if abs(v @ d) < 0.5:
            v = v - (v @ d) * d
            return v / np.linalg.norm(v)
    return None


#: Room (arm lengths) left between the arm in its start pose and a body capsule that had to
#: be narrowed for it (:func:`clear_of_start`): one search step (``Settings.step``).
START_BODY_GAP = 0.02
#: The least a body capsule is narrowed to, as a share of its proportional radius.
MIN_BODY_RADIUS = 0.25


def skin_clearance(info: RigInfo, armature, obstacles, horizon: float) -> float:
    """The least distance (figure units) between the reaching arm's skin as Blender shows it
    now (:func:`skin_points` of the upper arm, forearm and hand bones, the bones below the
    hand included, weighted 0.5 or more) and the obstacles, looking no farther than
    ``horizon`` (returned where nothing is that near, or the arm has no skin); 0 where a
    point of the skin is inside a closed obstacle: what a user sees of a start the
    planner's capsules hold in contact (a tapering limb's capsule is fuller than its skin
    near its thin end)."""
    tree = getattr(obstacles, "tree", None)
    bones = info.bones.arms[info.side]
    names = {bones.upper_arm, bones.forearm} | set(info.hand_bones or (bones.hand,))
    names |= {b.name for h in tuple(names - {bones.upper_arm, bones.forearm})
              for b in armature.pose.bones[h].children_recursive}
    if tree is None:
        return horizon
    points = skin_points(armature, names)
    if any(obstacles.point_inside(p) for p in points):
        return 0.0                                   # the skin is inside a closed obstacle
    near = [tree.find_nearest(p.tolist(), horizon) for p in points]
    return min((hit[3] for hit in near if hit[0] is not None), default=horizon)


def clear_of_start(capsules, segments, arm_length):
    """The body capsules, each one that the arm's own start pose passes through narrowed
    until the arm clears it by :data:`START_BODY_GAP` arm lengths (never below
    :data:`MIN_BODY_RADIUS` of its radius). A capsule the start pose clears, or touches by
    less than 10⁻⁴ arm lengths (a pose the planner left right at it, read back from the
    bones), is unchanged: on a rig whose arm starts clear of its body nothing changes.

    ``segments``: (a, b, radius) of the arm's parts the planner keeps out of the body — the
    elbow half of the upper arm, the forearm and the hand — in the start pose (canonical
    frame, the chest unturned, as the capsules are).

    Why. The capsules are sized from the shoulder width alone (a human's torso between the
    shoulders); the planner refuses every pose whose forearm, hand or upper arm (elbow half)
    passes through one, and does not test the start pose itself. A figure whose arm rests
    closer to its spine than a human's, or whose forearm is much thicker (a robot with rigid
    parts: a forearm 2.4 times the upper arm, its radius 0.18 arm lengths, hanging at its
    side), starts inside them: every position the search tries near the start is refused
    and it gives up after about a hundred positions (``no_path``) wherever the target is, and a
    chase never leaves the start. The pose on screen is one the character's body allows, so
    the body cannot be wider there than the arm lets it be."""
    out = []
    for c in capsules:
        gap = min(segment_distance_float(a, b, c.a, c.b) - r for a, b, r in segments) - c.radius
        if gap < -1e-4 * arm_length:
            radius = max(c.radius + gap - START_BODY_GAP * arm_length, MIN_BODY_RADIUS * c.radius)
            c = Capsule(c.name, c.a, c.b, radius, c.turns_with_chest)
        out.append(c)
    return tuple(out)


def build(armature, side="auto", overrides=None, target=None) -> RigInfo:
    """Read ``armature`` at the current frame into the core's model of one arm.

    ``side``: 'right', 'left' or 'auto' (the shoulder nearer ``target``, a world point).
    The model is built from the pose at the current frame, so planning starts exactly
    where the arm is; the chest rotation of the model is counted from the current pose.
    """
    check_armature(armature)
    bmap = detect_bones(armature, overrides)
    frame = body_frame(armature, bmap)
    if side == "auto":
        if target is None:
            side = "right"
        else:
            heads = pose_heads(armature, [bmap.arms[s].upper_arm for s in SIDES])
            d = {s: np.linalg.norm(heads[bmap.arms[s].upper_arm] - np.asarray(target))
                 for s in SIDES}
            side = min(SIDES, key=lambda s: (d[s], s != "right"))
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
    radii = (
        _skin_radius(armature, {arm_bones.upper_arm}, shoulder, elbow, 0.15 * l1),
        _skin_radius(armature, {arm_bones.forearm}, elbow, wrist, 0.14 * l2),
        _skin_radius(armature, set(hands), wrist, wrist + hand_axis * lh, 0.18 * lh),
    )
    # the hand's capsule: its palm skin, or half the fingers' spread about its axis if more
    # (one capsule round a spread thumb would make the hand a ball that fits nowhere: the
    # thumb's tip may stand out of it; see the README's Limitations)
    radii = (float(np.clip(radii[0], 0.08 * l1, 0.3 * l1)), float(np.clip(radii[1], 0.08 * l2, 0.3 * l2)),
             float(np.clip(max(radii[2], 0.5 * spread), 0.1 * lh, 0.35 * lh)))
    h = half
    capsules = (
        Capsule("chest", (0, 0, -1.6 * h), (0, 0, 0), 0.68 * h, True),
        Capsule("pelvis", (0, 0, -3.4 * h), (0, 0, -1.6 * h), 0.74 * h, False),
        Capsule("head", (0, 0.1 * h, 0.8 * h), (0, 0.1 * h, 1.6 * h), 0.53 * h, True),
    )
    hand_end = canon(wrist) + inv[:3, :3] @ hand_axis * lh
    capsules = clear_of_start(capsules, (
        (0.5 * (canon(shoulder) + canon(elbow)), canon(elbow), radii[0]),
        (canon(elbow), canon(wrist), radii[1]),
        (canon(wrist), hand_end, radii[2]),
    ), l1 + l2)
    arm = ArmModel(
        sternum=sternum, shoulder=canon(shoulder), waist=np.array([0.0, 0.0, -2.4 * h]),
        upper_arm_length=l1, forearm_length=l2, hand_length=lh,
        upper_arm_radius=radii[0], forearm_radius=radii[1], hand_radius=radii[2],
        to_world=to_world, body_capsules=capsules, side=side,
        name=f"{armature.name} {side} arm", metres_per_unit=_metres_per_unit(armature))
    start = config_from_joints(arm, canon(elbow), canon(wrist), 0.0)
    joints, bend = forward_kinematics(arm, start.as_array())
    start_hand = hand_angles(joints[2] - joints[1], bend, joints[3] - joints[2],
                             inv[:3, :3] @ hand_axis)
    palm, palm_source = palm_normal(armature, hands, hand_axis, frame.up, inv[:3, :3])
    fingers = inv[:3, :3] @ finger_axis(armature, hands, hand_axis)
    return RigInfo(armature.name, bmap, frame, arm, side, start,
                   {"shoulder": shoulder, "elbow": elbow, "wrist": wrist}, start_hand, hands,
                   palm, palm_source, fingers)


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
#: singular value of its world matrix, minus 1) before Reach refuses it. Measured: a scale
#: of (1, 1.001, 1) put the baked wrist 0.06–0.08 % of an arm length off the plan.
SCALE_TOLERANCE = 1e-3


def _check_uniform_scale(armature, m3):
    """Refuse an armature whose world transform scales its axes differently (its own scale,
    or a parent's: the singular values of its world matrix differ); mirroring (a negative
    scale) is uniform and fine.

    Why refuse rather than handle it. Under such a transform a bone's world length depends
    on its direction, and a bone's rotation under a non-uniformly scaled parent shears it:
    no rotation of rigid bones can follow the planner's arm, whose segments keep their
    world lengths. Measured (Rigify's metarig and the Quaternius rig, the plate reach of the
    tests, the baked bones evaluated with ``frame_set``): with object scale (1, 1.3, 0.8)
    the baked wrist ended 0.21–0.30 arm lengths from the planned wrist, (1.3, 1, 1)
    0.17, (1, 1.05, 1) 0.03–0.04, (1, 1.01, 1) 0.006–0.008, a non-uniformly scaled
    parent 0.24–0.26; and even bones pointed exactly along each planned segment's direction
    in armature space would change the segments' world lengths by up to 0.14–0.22 arm
    lengths at (1, 1.3, 0.8) (0.005 at (1, 1.01, 1)). So the bake could only be made right
    by stretching bones (keying scale), which changes the character; Reach asks for the
    scale to be applied instead, before anything is changed."""
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
