"""The body's balance on a rig: its legs found by their shape, its segments read from the
evaluated bones, and the centre of mass's margin over the feet (:mod:`..core.balance`).

**Legs** (:func:`find_legs`). No names are read. A leg is the bone path, from a bone
beside the spine, down to the lowest bone tail on one side of the body. On that path:

- the **hip** is the head of its first bone that is long (a tenth of the path or more)
  and points down;
- the **ankle** is the tail of its last bone that points down;
- the **knee** is the joint between the two that lies farthest from the line joining
  them (the joint nearest their middle, for a straight leg);
- the **toe** is the tail, below the ankle, that lies farthest forward.

"Down" is within 60° of the body's down axis, in the rest pose. A rig where no such pair
of legs is found has no legs for Reach (a bust, a robot on a stand), and no balance
figure is given.

**Segments** (:func:`body_segments`). These follow :data:`~..core.balance.WINTER`:

- the trunk runs from the hips' middle to the shoulders' middle;
- head and neck run from the shoulders' middle to the middle of the neck bone's farthest
  tail below it (the head);
- each arm is upper arm (shoulder to elbow: the bones' heads), forearm (elbow to wrist)
  and hand (the wrist along the hand's axis, as long as it is:
  :func:`.hand_reading.hand_shape`), as the rig adapter found them;
- each leg is thigh, shank and foot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core import balance as core_balance
from . import skin
from .hand_reading import hand_shape
from .rig_detect import ancestors

#: A leg bone "points down" within this angle of the body's down axis (degrees).
DOWN_WITHIN = 60.0


@dataclass
class Leg:
    """One leg's joints as bone points, each a (bone name, "head" | "tail" | "middle"), and
    the bones of its foot (past the knee: what the foot's skin hangs from)."""

    hip: tuple
    knee: tuple
    ankle: tuple
    toe: tuple
    foot_bones: tuple = ()


def _point(armature, where, pose: bool) -> np.ndarray:
    """World (``pose``: the evaluated pose) or armature-space rest position of a bone point."""
    name, end = where
    if pose:
        b = armature.pose.bones[name]
        h, t = np.array(b.head), np.array(b.tail)
        mw = np.array(armature.matrix_world)
        p = h if end == "head" else t if end == "tail" else 0.5 * (h + t)
        return mw[:3, :3] @ p + mw[:3, 3]
    b = armature.data.bones[name]
    h, t = np.array(b.head_local), np.array(b.tail_local)
    return h if end == "head" else t if end == "tail" else 0.5 * (h + t)


def _weighted(armature) -> set:
    """The bones that move some skin (:func:`.skin.skin_bones`), or all bones where nothing
    is skinned. (An FBX file's leaf "_end" bones move nothing and may point anywhere:
    Quaternius' shins end in one more than a leg's length below the feet.)"""
    return skin.skin_bones(armature) or {b.name for b in armature.data.bones}


def find_legs(armature, bmap, frame) -> list:
    """The rig's two legs (:class:`Leg`, right first), or [] where it has none. ``bmap``: the
    rig's :class:`~.rig_detect.BoneMap`; ``frame``: its :class:`~.body_frame.BodyFrame`
    (world axes, turned into the armature's rest space here).

    A leg is read from joints, the heads of its bones (a glTF joint has no tail, and the
    importer's tails point anywhere: CesiumMan's leg bones lie level). Its first bone is
    a child of the spine (the chest and its ancestors) whose chain of largest children
    reaches down at least half the chest's height; the chain's points are the bones'
    heads and the last one's tail. The hip is the first point, the ankle the first point
    after which the chain runs more forward than down (else its last), the knee between
    (the point farthest off the hip-ankle line, or the one nearest its middle for a
    straight leg). The toe is the point farthest forward among the chain's points past
    the ankle and the heads and tails of the bones whose head lies within a fifth of the
    leg's length of the ankle on the same side (a foot may hang from the root, as an IK
    foot does). Bones that move no skin are left out (:func:`_weighted`)."""
    bones = armature.data.bones
    inv = np.linalg.inv(np.array(armature.matrix_world)[:3, :3])
    up = inv @ np.asarray(frame.up, dtype=float)
    up /= np.linalg.norm(up)
    right = inv @ np.asarray(frame.right, dtype=float)
    forward = inv @ np.asarray(frame.forward, dtype=float)
    chest = bones[bmap.chest]
    spine = [chest] + ancestors(chest)
    names = {b.name for b in spine}
    used = _weighted(armature)
    centre = np.array(chest.head_local)

    def head(b):
        return np.array(b.head_local)

    def tail(b):
        return np.array(b.tail_local)

    def size(b):
        return b.length + sum(c.length for c in b.children_recursive if c.name in used)

    def chain(first):
        path = [first]
        while True:
            kids = [c for c in path[-1].children if c.name in used]
            if not kids:
                return path
            path.append(max(kids, key=size))

    lowest = min(float(head(b) @ up) for b in bones if b.name in used)
    height = float(centre @ up) - lowest
    found: dict = {}
    for s in spine:
        for c in s.children:
            if c.name in names or c.name not in used:
                continue
            path = chain(c)
            points = [(b.name, "head") for b in path] + [(path[-1].name, "tail")]
            coords = [head(b) for b in path] + [tail(path[-1])]
            drop = float(coords[0] @ up) - min(float(p @ up) for p in coords)
            side = "right" if (coords[0] - centre) @ right > 0.0 else "left"
            if drop >= 0.5 * height and (side not in found or drop > found[side][0]):
                found[side] = (drop, points, coords)
    if set(found) != {"right", "left"}:
        return []
    legs = []
    for side in ("right", "left"):
        _drop, points, coords = found[side]
        k_ankle = len(coords) - 1
        for k in range(1, len(coords) - 1):
            step = coords[k + 1] - coords[k]
            if float(step @ forward) > float(-step @ up) and \
                    float(coords[0] @ up - coords[k] @ up) >= 0.5 * height:
                k_ankle = k
                break
        hip, ankle = coords[0], coords[k_ankle]
        line = ankle - hip
        leg_length = float(np.linalg.norm(line))
        if leg_length <= 0.0 or k_ankle < 1:
            return []
        k_knee = _knee(coords[:k_ankle + 1], hip, line)
        sign = 1.0 if side == "right" else -1.0
        toes = list(zip(points[k_ankle + 1:], coords[k_ankle + 1:]))
        for b in bones:
            if b.name in used and float(np.linalg.norm(head(b) - ankle)) <= 0.2 * leg_length \
                    and sign * float((head(b) - centre) @ right) > 0.0:
                toes += [((b.name, "head"), head(b)), ((b.name, "tail"), tail(b))]
        if not toes:
            return []
        toe, at = max(toes, key=lambda pc: float(pc[1] @ forward))
        if float((at - ankle) @ forward) <= 0.0:
            return []
        foot = {p[0] for p in points[k_knee:]} | {p[0] for p, _c in toes}
        foot |= {c.name for n in list(foot) for c in bones[n].children_recursive}
        legs.append(Leg(points[0], points[k_knee], points[k_ankle], toe, tuple(sorted(foot))))
    return legs


def _knee(coords, hip, line) -> int:
    """The knee's index among a leg's points ``coords`` from ``hip`` to the ankle (the
    last) along ``line``: the point farthest off the line, or for a straight leg the one
    nearest its middle."""
    inner = list(range(1, len(coords) - 1))
    if not inner:
        return 0
    span = max(float(line @ line), 1e-300)

    def off_line(k):
        p = coords[k]
        t = float(np.clip((p - hip) @ line / span, 0.0, 1.0))
        return float(np.linalg.norm(p - (hip + t * line)))

    k = max(inner, key=off_line)
    if off_line(k) < 0.02 * math.sqrt(span):                          # a straight leg
        k = min(inner, key=lambda i: abs(float((coords[i] - hip) @ line) / span - 0.5))
    return k


def _head_end(armature, bmap):
    """The farthest tail above the neck (the head's end), as a bone point, or None."""
    if not bmap.neck:
        return None
    neck = armature.data.bones[bmap.neck]
    below = [neck] + list(neck.children_recursive)
    base = np.array(neck.head_local)
    far = max(below, key=lambda b: float(np.linalg.norm(np.array(b.tail_local) - base)))
    return far.name, "tail"


def hands_now(armature, bmap) -> dict:
    """{hand bone: (its axis in the bone's own frame, its length)} as the hand is now
    (:func:`.hand_reading.hand_shape`): read once, then carried by the bone (reading a
    fingerless hand's skin on every frame cost a third of a bake)."""
    out = {}
    mw = np.array(armature.matrix_world)
    for a in bmap.arms.values():
        e, w = (_point(armature, (n, "head"), True) for n in (a.forearm, a.hand))
        axis, length, _spread = hand_shape(armature, a.hand, float(np.linalg.norm(w - e)))
        rotation = mw[:3, :3] @ np.array(armature.pose.bones[a.hand].matrix)[:3, :3]
        out[a.hand] = (np.linalg.solve(rotation, axis), float(length))
    return out


def body_segments(armature, bmap, legs, hands=None) -> list:
    """The body's segments now (the evaluated pose, world space):
    [(kind, proximal, distal)] for :func:`~..core.balance.centre_of_mass` (see the module
    docstring). ``hands``: :func:`hands_now` read before (default: now)."""
    def at(where):
        return _point(armature, where, True)

    hands = hands if hands is not None else hands_now(armature, bmap)
    mw = np.array(armature.matrix_world)
    out = []
    shoulders = []
    for a in bmap.arms.values():
        s, e, w = (at((n, "head")) for n in (a.upper_arm, a.forearm, a.hand))
        shoulders.append(s)
        local, length = hands[a.hand]
        axis = mw[:3, :3] @ np.array(armature.pose.bones[a.hand].matrix)[:3, :3] @ local
        axis = axis / max(float(np.linalg.norm(axis)), 1e-12)
        out += [("upper_arm", s, e), ("forearm", e, w), ("hand", w, w + length * axis)]
    for leg in legs:
        hip, knee, ankle, toe = (at(p) for p in (leg.hip, leg.knee, leg.ankle, leg.toe))
        out += [("thigh", hip, knee), ("shank", knee, ankle), ("foot", ankle, toe)]
    top = np.mean(shoulders, axis=0)
    if legs:
        out.append(("trunk", np.mean([at(leg.hip) for leg in legs], axis=0), top))
    head = _head_end(armature, bmap)
    if head is not None:
        out.append(("head_neck", top, 0.5 * (at((bmap.neck, "head")) + at(head))))
    return out


#: The sole: the skin of the feet within this share of the leg's length above its lowest
#: point.
SOLE_BAND = 0.03


def support_now(armature, legs, up) -> tuple:
    """(the support polygon now, in :func:`~..core.balance.ground_basis` coordinates of
    ``up``; what it was read from). Where the feet have skin, the convex hull of their
    soles (:data:`SOLE_BAND`), "skin"; else the feet's rectangles from the ankles to the
    toes (:func:`~..core.balance.support_polygon`), "bones"."""
    names = {n for leg in legs for n in leg.foot_bones}
    points = skin.skin_points(armature, names) if names else np.zeros((0, 3))
    if len(points) >= 3:
        heights = points @ (np.asarray(up, dtype=float) / np.linalg.norm(up))
        hip, ankle = _point(armature, legs[0].hip, True), _point(armature, legs[0].ankle, True)
        band = SOLE_BAND * float(np.linalg.norm(hip - ankle))
        sole = points[heights <= heights.min() + band]
        polygon = core_balance.polygon_of(sole, up)
        if len(polygon) >= 3:
            return polygon, "skin"
    feet = [(_point(armature, leg.ankle, True), _point(armature, leg.toe, True)) for leg in legs]
    return core_balance.support_polygon(feet, up), "bones"


def margin_now(armature, bmap, legs, up) -> float:
    """The centre of mass's margin over the feet now (world units; positive inside the
    support polygon, :func:`support_now`): :func:`~..core.balance.balance_margin`."""
    com = core_balance.centre_of_mass(body_segments(armature, bmap, legs))
    return core_balance.balance_margin(com, support_now(armature, legs, up)[0], up)


def measure(context, armature, info, results) -> None:
    """Put, in place, into each baked result of ``results`` (:class:`.results.TaskResult`)
    the body's balance over its frames, as Blender evaluates them: ``com_margin_start`` and
    ``com_margin_min`` (arm lengths: the centre of mass's margin inside the support polygon
    on the task's first frame, and its least over the task's frames), ``com_margin_min_frame``
    and ``support_from`` ("skin": the soles; "bones": the feet's rectangles). The support
    polygon is read on each task's first frame (Reach keys no leg bone; a foot the rig's own
    animation moves during the reach is not followed), the hands' axes and lengths on the
    first task's (:func:`hands_now`). Nothing is added for a rig without legs
    (:func:`find_legs`). Changes the scene's frame."""
    legs = find_legs(armature, info.bones, info.frame)
    if not legs:
        return
    scene = context.scene
    up = np.asarray(info.frame.up, dtype=float)
    length = info.arm.arm_length                 # figure units are world units
    hands = None
    for r in results:
        if not r.bones_keyed or r.frame_end < r.frame_start:
            continue
        scene.frame_set(r.frame_start)
        polygon, source = support_now(armature, legs, up)
        hands = hands if hands is not None else hands_now(armature, info.bones)
        margins = []
        for f in range(r.frame_start, r.frame_end + 1):
            scene.frame_set(f)
            com = core_balance.centre_of_mass(body_segments(armature, info.bones, legs, hands))
            margins.append(core_balance.balance_margin(com, polygon, up) / length)
        worst = int(np.argmin(margins))
        r.stats["com_margin_start"] = float(margins[0])
        r.stats["com_margin_min"] = float(margins[worst])
        r.stats["com_margin_min_frame"] = r.frame_start + worst
        r.stats["support_from"] = source

