"""The hand as the rig shows it: the bones that make it (:func:`hand_group`), its fingers
(:func:`digits`), its axis, length and spread (:func:`hand_shape`), the direction the
fingers point (:func:`finger_axis`) and the direction the palm faces (:func:`palm_normal`).

Everything is read from the pose on screen, by hierarchy and position (names only to find
a thumb and to leave helper bones out). Why each rule: ``docs/design/blender.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rig_detect import HELPER, tokens
from .skin import skin_points


#: How far (in the hand bone's own lengths) a sibling's head may lie from the hand bone's
#: head for the sibling to be a palm of the same hand (:func:`hand_group`).
PALM_HEAD_TOLERANCE = 0.1


def hand_group(armature, hand_name) -> tuple:
    """The bones that make the hand whose (first) bone is ``hand_name``: that bone first,
    then its palm siblings in the order of the parent's children. A sibling (another child
    of the forearm) is a palm of the same hand when it carries bones of its own (fingers),
    is no helper bone (twist, ik, mch, … see :data:`.rig_detect.HELPER`; nor a weapon or prop bone),
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
                set(tokens(c.name)) & (HELPER | {"weapon", "prop"}):
            continue
        if np.linalg.norm(np.array(c.head_local) - head) > tol:
            continue
        if (np.array(c.tail_local) - np.array(c.head_local)) @ onward <= 0.0:
            continue
        out.append(c.name)
    return tuple(out)


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
        kids = [c for c in bone.children if not set(tokens(c.name)) & HELPER]
        if not kids:
            paths.append(path)
        for c in kids:
            walk(c, path + [c])

    for name in group:
        for c in bones[name].children:
            if c.name not in group and not set(tokens(c.name)) & HELPER:
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
#: reads, in forearm lengths.
HAND_REACH_MAX = 2.0


#: A fingerless hand's skin sets its axis only when the skin's middle lies at least this
#: share of the forearm from the wrist (:func:`hand_shape`); nearer, the direction is noise.
SKIN_AXIS_MIN = 0.05


def hand_shape(armature, hand_name, forearm_len, group=None):
    """The hand as the planner models it, read from the pose on screen: (axis, length,
    spread), world space.

    ``axis``: the unit direction from the wrist (the hand bone's head) to the mean of the
    finger joints (heads and tails of the bones below the hand bones ``group``, helper
    bones left out); ``length``: the farthest joint along it, clipped to 0.4 ..
    :data:`HAND_REACH_MAX` × ``forearm_len``; ``spread``: the farthest joint from the
    axis. A hand with no fingers has no spread; where it moves skin it points from the
    wrist to the middle of that skin (a bone's tail can point anywhere: glTF's importer
    turns CesiumMan's hand bone 140° from its forearm) and is as long as the skin goes
    along that axis (a mitten, a short stub), clipped to 0.2 .. 0.74 × ``forearm_len``;
    where it moves none, it points along its bones (the tails' mean) and is 0.74 forearm
    long (Drillis & Contini). The skin's middle sets the axis only when it lies
    :data:`SKIN_AXIS_MIN` forearms or more from the wrist. ``group``: the hand's bones
    (:func:`hand_group`; default the hand bone alone). The axis is the hand capsule's,
    the middle of its mass; the fingers' direction is :func:`finger_axis`."""
    mw = np.array(armature.matrix_world)
    pb = armature.pose.bones[hand_name]
    group = group or (hand_name,)
    kids = [b for n in group for b in armature.pose.bones[n].children_recursive
            if not set(tokens(b.name)) & HELPER]
    wrist = mw[:3, :3] @ np.array(pb.head) + mw[:3, 3]
    if not kids:
        tails = np.mean([np.array(armature.pose.bones[n].tail) for n in group], axis=0)
        axis = mw[:3, :3] @ (tails - np.array(pb.head))
        axis = axis / max(float(np.linalg.norm(axis)), 1e-12)
        skin = skin_points(armature, set(group))
        if not len(skin):
            return axis, 0.74 * forearm_len, 0.0
        middle = skin.mean(0) - wrist                        # the skin's middle of mass
        if float(np.linalg.norm(middle)) > SKIN_AXIS_MIN * forearm_len:
            axis = middle / float(np.linalg.norm(middle))
        reach = float(((skin - wrist) @ axis).max())       # as far as the hand's skin goes
        return axis, float(np.clip(reach, 0.2 * forearm_len, 0.74 * forearm_len)), 0.0
    rel = np.array([p for b in kids for p in (b.head, b.tail)]) @ mw[:3, :3].T + mw[:3, 3] - wrist
    axis = rel.mean(0)
    if np.linalg.norm(axis) < 1e-9:
        axis = mw[:3, :3] @ (np.array(pb.tail) - np.array(pb.head))
    axis = axis / max(float(np.linalg.norm(axis)), 1e-12)
    along = rel @ axis
    length = float(np.clip(along.max(), 0.4 * forearm_len, HAND_REACH_MAX * forearm_len))
    spread = float(np.linalg.norm(rel - along[:, None] * axis, axis=1).max())
    return axis, length, spread


#: Knuckles closer together than this share of the fingers' reach do not make a knuckle
#: line (:func:`knuckles`).
KNUCKLE_SPREAD = 0.1


def knuckles(chains, wrist, axis) -> list:
    """Where each finger chain (joints, world) leaves the palm: its first joint, or its
    second where its first bone is a metacarpal (the chain has four bones or more and starts
    within a quarter of its reach from the wrist along the hand's ``axis``); and where the
    chains' knuckles so found all but coincide (fingers that spring from one point, as a
    Quaternius alien's do: less than :data:`KNUCKLE_SPREAD` of the fingers' reach apart),
    each one's next joint, where the fingers have parted."""
    def first(chain):
        reach = float((chain[-1] - wrist) @ axis)
        return 1 if len(chain) >= 5 and float((chain[0] - wrist) @ axis) <= 0.25 * reach else 0

    at = [first(c) for c in chains]
    points = [c[i] for c, i in zip(chains, at)]
    if len(chains) >= 2:
        reach = max(float(np.linalg.norm(c[-1] - wrist)) for c in chains)
        if max(float(np.linalg.norm(p - q)) for p in points for q in points) \
                < KNUCKLE_SPREAD * reach:
            points = [c[min(i + 1, len(c) - 1)] for c, i in zip(chains, at)]
    return points


def finger_axis(armature, group, hand_axis) -> np.ndarray:
    """The direction the fingers point in the pose on screen (world, unit): the wrist to the
    middle finger's knuckle (:func:`knuckles`), read by position (:func:`digits`): the
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
    rel = [k - found.wrist for k in knuckles(fingers, found.wrist, axis)]
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
    """The direction the palm faces in the pose on screen, and where it was read from:
    (normal, source). ``normal``: canonical arm frame, unit, perpendicular to the fingers'
    direction, for :mod:`reach_addon.core.orient`.

    Inputs: ``group`` the hand's bones (:func:`hand_group`); ``hand_axis`` its axis
    (world, :func:`hand_shape`); ``up`` the body's up (world); ``to_canonical`` the 3 × 3
    map of world vectors into the canonical frame.

    n = a × d, with d the fingers' direction (:func:`finger_axis`, canonical) and a the
    direction across the palm toward the thumb, made perpendicular to d (in the canonical
    frame every arm is a right arm: a right hand hanging palm forward has d down, a
    outward, n forward). ``source`` says what gave a (:func:`digits`, never names):

    * ``"fingers"``: the knuckle line across the two fingers whose knuckles lie farthest
      apart, signed toward the thumb;
    * ``"thumb"``: one finger chain besides the thumb: from that chain's joints on average
      to the thumb's;
    * ``"fingers, rest pose"``: fingers but no thumb: the knuckle line, signed by the
      rest-pose rule;
    * ``"skin"``: no knuckle line but a skin: the hand skin's thinnest direction, signed by
      the rest-pose rule;
    * ``"rest pose"``: nothing else: the palm faces down in the rest pose (against ``up``),
      carried by the hand bone to the pose on screen (:func:`_rest_palm`)."""
    d = to_canonical @ finger_axis(armature, group, hand_axis)
    assumed = _rest_palm(armature, group[0], up, to_canonical, d)
    across, source = _across_palm(armature, group, hand_axis, d, to_canonical)
    a = None if across is None else _perpendicular(across, d)
    if a is None:
        return assumed, "rest pose"
    n = np.cross(a, d)
    n /= np.linalg.norm(n)
    if source != "fingers" and source != "thumb" and n @ assumed < 0:
        n = -n
    return n, source


def _perpendicular(v, d):
    """``v`` made perpendicular to the unit vector ``d`` and of unit length; None where it
    lies along ``d``."""
    v = np.asarray(v, dtype=float)
    v = v - (v @ d) * d
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else None


def _rest_palm(armature, hand, up, to_canonical, d):
    """The palm's normal by the rest-pose rule (canonical, unit, perpendicular to ``d``):
    the palm of bone ``hand`` faces down (against the world ``up``) in its rest pose, and
    is carried by the bone from rest to the pose on screen."""
    m3 = np.array(armature.matrix_world)[:3, :3]
    bone, pose_bone = armature.data.bones[hand], armature.pose.bones[hand]
    rest = np.array(bone.matrix_local)[:3, :3]
    down = -np.linalg.solve(m3, np.asarray(up, dtype=float))          # armature space
    axis = rest[:, 1] / max(float(np.linalg.norm(rest[:, 1])), 1e-12)
    down = down - (down @ axis) * axis
    if np.linalg.norm(down) < 1e-9:
        down = rest[:, 2]
    now = np.array(pose_bone.matrix)[:3, :3] @ np.linalg.solve(rest, down)
    assumed = _perpendicular(to_canonical @ (m3 @ now), d)
    if assumed is None:
        assumed = _perpendicular(np.cross(d, [0.0, 0.0, 1.0]), d) if abs(d[2]) < 0.99 \
            else np.array([1.0, 0, 0])
    return assumed


def _across_palm(armature, group, hand_axis, d, to_canonical):
    """(a, source) of :func:`palm_normal`: the direction across the palm (canonical, not yet
    unit or perpendicular to ``d``) and what gave it; (None, None) where nothing does."""
    found = digits(armature, group)
    # each chain's knuckle (the thumb: its joints on average; its root may sit with the
    # others' at the wrist) as an offset across the fingers' direction (canonical)
    axis = np.asarray(hand_axis, dtype=float)

    def across_d(point):
        v = to_canonical @ (point - found.wrist)
        return v - (v @ d) * d

    fingers = [across_d(k) for k in knuckles(found.fingers, found.wrist, axis)]
    thumb = across_d(found.chains[found.thumb].mean(0)) if found.thumb is not None else None
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
    return across, source


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
