"""Bone detection: which bones of an armature are the chest, the neck and each arm's
clavicle, upper arm, forearm and hand (:func:`detect_bones` → :class:`BoneMap`).

Detection reads bone names (tokens, a side marker, a role vocabulary), else the
skeleton's shape; Rigify's generated rigs by their ``rig_id``. Overrides by name win.
How each rule came about: ``docs/design/blender.md``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ..core import ReachError
from .skin import skin_bones


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
#: Tokens that mark helper, mechanism or non-arm bones: a candidate carrying one scores lower.
HELPER = {"ik", "fk", "pole", "target", "twist", "roll", "tweak", "mch", "org", "ctrl", "ctl",
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
    return max(1, base - 3 * len(toks & HELPER))


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
    """The bones Reach reads and keys in one armature (names): the chest, each side's
    :class:`ArmBones`, the neck, the chest's keyed control (Rigify) and each side's
    IK/FK switch."""

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


def constrained(pose_bone) -> bool:
    """Whether ``pose_bone`` has a constraint of its own that acts (unmuted, influence
    above 0): its keys are then not all of what Blender evaluates."""
    return any(not c.mute and c.influence > 0.0 for c in pose_bone.constraints)


def followers(armature, names) -> set:
    """``names`` and every bone of ``armature`` that moves with them: their children, and
    bones a constraint that acts (unmuted, influence above 0) aims at one of them (a
    generated Rigify rig's ``ORG-`` and ``DEF-`` bones follow its controls that way), and
    so on."""
    moved = set(names)
    grown = True
    while grown:
        grown = False
        for pb in armature.pose.bones:
            if pb.name in moved:
                continue
            if (pb.parent is not None and pb.parent.name in moved) or any(
                    not c.mute and c.influence > 0.0 and getattr(c, "target", None) == armature
                    and getattr(c, "subtarget", "") in moved for c in pb.constraints):
                moved.add(pb.name)
                grown = True
    return moved


def ancestors(bone) -> list:
    """The bone's parent, its parent's parent, ... up to the root."""
    out = []
    while bone.parent is not None:
        bone = bone.parent
        out.append(bone)
    return out


def _lca(a, b):
    chain = [a] + ancestors(a)
    names = {x.name for x in [b] + ancestors(b)}
    return next((x for x in chain if x.name in names), None)


def _reach(bone) -> float:
    """Total bone length of a subtree (its size, in the rig's units)."""
    return bone.length + sum(b.length for b in bone.children_recursive)


def _dominant_child(bone):
    """The child that carries the limb on, or None at a fork into comparable branches
    (fingers, or the arms and neck at a chest): the biggest subtree if it is at least twice
    the size of the next. Helper bones (twist, roll, ik, …) step aside first."""
    kids = [c for c in bone.children if not set(tokens(c.name)) & HELPER] or list(bone.children)
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
        out.append((score, -len(ancestors(b)), b.name, b))
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
    """Find the chest, the neck and both arms of ``armature`` (an armature object) by their
    names, else by the skeleton's shape; a Rigify generated rig by its ``rig_id``.
    ``overrides`` maps ``chest`` / ``<role>_<side>`` to bone names; they win over
    detection. Returns a :class:`BoneMap`. Raises :class:`ReachError` naming the armature
    when an override names no bone of it, when no arm can be found, or when an arm's bones
    do not form a chain."""
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
    legs = [c for a in ancestors(chest) for c in a.children
            if c not in ancestors(chest) + [chest] and len(c.children_recursive) >= 2]
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


def _check_chain(armature, bmap):
    data = armature.data
    for side, arm in bmap.arms.items():
        u, f, h = (data.bones[n] for n in (arm.upper_arm, arm.forearm, arm.hand))
        if f not in u.children_recursive or h not in f.children_recursive:
            raise ReachError(
                f"in armature '{armature.name}' the {side} arm bones do not form a chain "
                f"({arm.upper_arm} → {arm.forearm} → {arm.hand}); check the bone fields")
