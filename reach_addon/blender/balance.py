"""The body's balance on a rig: its legs found by their shape, its segments read from the
evaluated bones, and the centre of mass's margin over the feet (:mod:`..core.balance`).

**Legs** (:func:`find_legs`). No names are read. A leg is a chain of bones that move
skin, walked up from a bone while the parents stay on its side of the body and below the
chest; on each side the chain that drops farthest (half the chest's height or more). On
its joints (the bones' heads, and a tail where the next bone does not start there):

- the **hip** is its first joint;
- the **ankle** is the joint whose height above the lowest joint is nearest
  :data:`ANKLE_HEIGHT` of the hip's (the joints' heights, not the bones' directions: a
  glTF bone's tail points anywhere);
- the **knee** is the joint between the two that lies farthest from the line joining
  them (the joint nearest their middle, for a straight leg);
- the **toe** is the point, past the ankle or on a bone that starts near it, that lies
  farthest forward.

A rig where no such pair of legs is found has no legs for Reach (a bust, a robot on a
stand), and no balance figure is given.

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

#: The ankle's height over the hip's (the greater trochanter's), both above the ground:
#: 0.039 and 0.530 of stature (Drillis & Contini, 1966).
ANKLE_HEIGHT = 0.039 / 0.530


@dataclass
class Leg:
    """One leg's joints as bone points, each a (bone name, "head" | "tail" | "middle"), and
    the bones of its foot (past the knee: what the foot's skin hangs from)."""

    hip: tuple
    knee: tuple
    ankle: tuple
    toe: tuple
    foot_bones: tuple = ()


def point_of(armature, where) -> np.ndarray:
    """World position of a bone point (:class:`Leg`) in the evaluated pose."""
    name, end = where
    b = armature.pose.bones[name]
    h, t = np.array(b.head), np.array(b.tail)
    p = h if end == "head" else t if end == "tail" else 0.5 * (h + t)
    mw = np.array(armature.matrix_world)
    return mw[:3, :3] @ p + mw[:3, 3]


def _weighted(armature) -> set:
    """The bones that move some skin (:func:`.skin.skin_bones`); where nothing is skinned,
    the deforming bones (a generated Rigify rig's DEF- bones, not its controls), or all
    bones where none deform. (An FBX file's leaf "_end" bones move nothing and may point
    anywhere: Quaternius' shins end in one more than a leg's length below the feet.)"""
    return skin.skin_bones(armature) or {b.name for b in armature.data.bones if b.use_deform} \
        or {b.name for b in armature.data.bones}


def find_legs(armature, bmap, frame) -> list:
    """The rig's two legs (:class:`Leg`, right first), or [] where it has none. ``bmap``: the
    rig's :class:`~.rig_detect.BoneMap`; ``frame``: its :class:`~.body_frame.BodyFrame`
    (world axes, turned into the armature's rest space here).

    See the module docstring. No parentage to the spine is asked for: a generated Rigify
    rig hangs its legs from a bone its chest does not descend from, and a Quaternius foot
    hangs from the root."""
    bones = armature.data.bones
    inv = np.linalg.inv(np.array(armature.matrix_world)[:3, :3])
    up = inv @ np.asarray(frame.up, dtype=float)
    up /= np.linalg.norm(up)
    right = inv @ np.asarray(frame.right, dtype=float)
    forward = inv @ np.asarray(frame.forward, dtype=float)
    used = _weighted(armature)
    centre = np.array(bones[bmap.chest].head_local)
    arms = {n for a in bmap.arms.values() for n in (a.upper_arm, a.forearm, a.hand) if n}

    def head(b):
        return np.array(b.head_local)

    def tail(b):
        return np.array(b.tail_local)

    def side_of(p):
        return float((p - centre) @ right)

    lowest = min(float(head(b) @ up) for b in bones if b.name in used)
    height = float(centre @ up) - lowest
    found: dict = {}
    for end in bones:
        if end.name not in used or end.name in arms:
            continue
        sign = np.sign(side_of(head(end)))
        if abs(side_of(head(end))) < 0.02 * height:
            continue
        path = [end]
        while path[-1].parent is not None:
            parent = path[-1].parent
            if parent.name not in used or parent.name in arms or \
                    sign * side_of(head(parent)) < 0.02 * height or \
                    float(head(parent) @ up) >= float(centre @ up):
                break
            path.append(parent)
        path.reverse()
        if any(n.name in arms for p in path for n in [p] + list(p.children)):
            continue
        points, coords = _chain_points(path)
        drop = float(coords[0] @ up) - min(float(p @ up) for p in coords)
        side = "right" if sign > 0.0 else "left"
        if drop >= 0.5 * height and (side not in found or drop > found[side][0]):
            found[side] = (drop, points, coords)
    if set(found) != {"right", "left"}:
        return []
    legs = [_leg(armature, used, found[side][1], found[side][2], up, forward,
                 lowest, (1.0 if side == "right" else -1.0) * right, centre)
            for side in ("right", "left")]
    return legs if all(legs) else []


def _leg(armature, used, points, coords, up, forward, lowest, outward, centre):
    """A :class:`Leg` from its chain's ``points`` and rest ``coords`` (:func:`find_legs`;
    ``outward``: the body's axis toward its side), or None where it has no foot ahead of
    the ankle."""
    bones = armature.data.bones
    hip_height = float(coords[0] @ up) - lowest

    def off_ankle(k):
        return abs(float(coords[k] @ up) - lowest - ANKLE_HEIGHT * hip_height)

    # a bone's head is a joint in every format; its tail only where nothing else is
    heads = [k for k in range(1, len(coords)) if points[k][1] == "head"]
    k_ankle = min(heads, key=off_ankle, default=None)
    if k_ankle is None or off_ankle(k_ankle) > 0.05 * hip_height:
        k_ankle = min(range(1, len(coords)), key=off_ankle)
    hip, ankle = coords[0], coords[k_ankle]
    line = ankle - hip
    leg_length = float(np.linalg.norm(line))
    if leg_length <= 0.0:
        return None
    k_knee = _knee(coords[:k_ankle + 1], hip, line, [p[1] == "head" for p in points])
    toes = list(zip(points[k_ankle + 1:], coords[k_ankle + 1:]))
    for b in bones:
        h = np.array(b.head_local)
        if b.name in used and float(np.linalg.norm(h - ankle)) <= 0.2 * leg_length \
                and float((h - centre) @ outward) > 0.0:
            toes += [((b.name, "head"), h), ((b.name, "tail"), np.array(b.tail_local))]
    if not toes:
        return None
    toe, at = max(toes, key=lambda pc: float(pc[1] @ forward))
    if float((at - ankle) @ forward) <= 0.0:
        return None
    foot = {p[0] for p in points[k_knee:]} | {p[0] for p, _c in toes}
    foot |= {c.name for n in list(foot) for c in bones[n].children_recursive}
    return Leg(points[0], points[k_knee], points[k_ankle], toe, tuple(sorted(foot)))


def _chain_points(path) -> tuple:
    """(bone points, rest coordinates) along a bone ``path``: each bone's head, and its tail
    too where the next bone does not start there (a heel bone hung from the shin starts at
    the heel, not the ankle) and for the last."""
    points, coords = [], []
    for k, b in enumerate(path):
        points.append((b.name, "head"))
        coords.append(np.array(b.head_local))
        nxt = path[k + 1] if k + 1 < len(path) else None
        if nxt is None or np.linalg.norm(np.array(nxt.head_local) - np.array(b.tail_local)) > \
                1e-3 * max(b.length, 1e-9):
            points.append((b.name, "tail"))
            coords.append(np.array(b.tail_local))
    return points, coords


def _knee(coords, hip, line, is_head) -> int:
    """The knee's index among a leg's points ``coords`` from ``hip`` to the ankle (the
    last) along ``line``: the point farthest off the line, or for a straight leg the one
    nearest its middle; a bone's head where there is one between (``is_head``: a bone's
    tail may point anywhere)."""
    inner = list(range(1, len(coords) - 1))
    if not inner:
        return 0
    inner = [k for k in inner if is_head[k]] or inner
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
        e, w = (point_of(armature, (n, "head")) for n in (a.forearm, a.hand))
        axis, length, _spread = hand_shape(armature, a.hand, float(np.linalg.norm(w - e)))
        rotation = mw[:3, :3] @ np.array(armature.pose.bones[a.hand].matrix)[:3, :3]
        out[a.hand] = (np.linalg.solve(rotation, axis), float(length))
    return out


def body_segments(armature, bmap, legs, hands=None) -> list:
    """The body's segments now (the evaluated pose, world space):
    [(kind, proximal, distal)] for :func:`~..core.balance.centre_of_mass` (see the module
    docstring). ``hands``: :func:`hands_now` read before (default: now)."""
    def at(where):
        return point_of(armature, where)

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
    soles (each foot's, :func:`_sole`), "skin"; else the feet's rectangles from the heels to the
    toes (:func:`~..core.balance.support_polygon`) with the joints of the feet's bones no
    higher than the ankles (a heel bone marks the heel), "bones"."""
    names = {n for leg in legs for n in leg.foot_bones}
    soles = [_sole(armature, leg, up) for leg in legs]
    if all(len(sole) for sole in soles):
        polygon = core_balance.polygon_of(np.concatenate(soles), up)
        if len(polygon) >= 3:
            return polygon, "skin"
    feet = [(point_of(armature, leg.ankle), point_of(armature, leg.toe)) for leg in legs]
    rectangles = core_balance.support_polygon(feet, up)
    # and the joints of the feet's bones (a heel bone marks where the heel is)
    ankle_height = min(float(point_of(armature, leg.ankle) @ up) for leg in legs)
    joints = [point_of(armature, (n, end)) for n in names for end in ("head", "tail")]
    joints = [p for p in joints if float(p @ up) <= ankle_height]
    if not joints:
        return rectangles, "bones"
    basis = core_balance.ground_basis(up)        # the rectangles' corners back in 3-D
    return core_balance.polygon_of([basis.T @ c for c in rectangles] + joints, up), "bones"


def ankles_now(armature, legs) -> tuple:
    """(each leg's ankle now (world, (n, 3)), the legs' mean length from hip to ankle)."""
    ankles = np.array([point_of(armature, leg.ankle) for leg in legs])
    length = float(np.mean([np.linalg.norm(point_of(armature, leg.hip) - a)
                            for leg, a in zip(legs, ankles)]))
    return ankles, length


#: The farthest (degrees) the legs, hips to ankles, may lean off the scene's gravity for
#: the body to lean, squat or step (:func:`standing_why_not`): a figure standing, however
#: its trunk leans, has its hips over its ankles; one lying, sitting or on a tilted parent
#: does not, and its balance over its feet means nothing. Ours: the paper is silent.
STANDING_TILT = 30.0


def legs_tilt(armature, legs, ground) -> float:
    """The angle (degrees) between ``ground`` (the unit up against gravity) and the line
    from the legs' mean ankle to their mean hip, as they stand now."""
    hips = np.mean([point_of(armature, leg.hip) for leg in legs], axis=0)
    ankles = np.mean([point_of(armature, leg.ankle) for leg in legs], axis=0)
    d = hips - ankles
    c = float(d @ np.asarray(ground, dtype=float)) / max(float(np.linalg.norm(d)), 1e-300)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def standing_why_not(armature, legs, ground, verb: str) -> str | None:
    """Why the body does not ``verb`` (lean, step): its legs lean more than
    :data:`STANDING_TILT` off the scene's gravity (:func:`legs_tilt`); else None."""
    tilt = legs_tilt(armature, legs, ground)
    if tilt <= STANDING_TILT:
        return None
    return (f"the legs of '{armature.name}' lean {tilt:.0f}° off the scene's gravity (Scene "
            f"> Gravity), and Reach {verb}s only a body standing on its feet (legs within "
            f"{STANDING_TILT:.0f}° of it): stand the character upright, or set the gravity "
            "its ground has")


def ground_now(armature, legs, up) -> float:
    """The height (along the unit ``up``) of the ground the feet stand on now: the lowest
    point of their soles' skin (:func:`_sole`), else of their bones' joints."""
    u = np.asarray(up, dtype=float) / np.linalg.norm(up)
    points = [p for leg in legs for p in _sole(armature, leg, u)]
    if not points:
        points = [point_of(armature, (n, end)) for leg in legs for n in leg.foot_bones
                  for end in ("head", "tail")] + [point_of(armature, leg.toe) for leg in legs]
    return float(min(float(np.asarray(p) @ u) for p in points))


def _sole(armature, leg, up) -> np.ndarray:
    """The skin of ``leg``'s foot within :data:`SOLE_BAND` of the leg's length above the
    foot's own lowest point (world, (n, 3)); empty where the foot has no skin. Each foot's
    own: a foot set down in a wide stance, its shank tipped, dips the heel's skin that
    the shank blends below the other foot's sole (the Goblin, 2.5 cm)."""
    points = skin.skin_points(armature, set(leg.foot_bones))
    if len(points) < 3:
        return np.zeros((0, 3))
    heights = points @ (np.asarray(up, dtype=float) / np.linalg.norm(up))
    hip, ankle = point_of(armature, leg.hip), point_of(armature, leg.ankle)
    band = SOLE_BAND * float(np.linalg.norm(hip - ankle))
    return points[heights <= heights.min() + band]


class Soles:
    """The feet's soles read once (:func:`_sole`, as the rig stands) and carried after by
    each foot's bone (the one its toe point lies on), so that a sole is the same patch of
    skin however the shank above it tips: reading the skin again on every frame lets a
    heel the shank blends dip below the sole and take its place (the Alien's stance foot,
    0.03 arm lengths). Where the feet have no skin, :func:`support_now`'s bones."""

    def __init__(self, armature, legs, up):
        self.armature, self.legs, self.up = armature, list(legs), np.asarray(up, dtype=float)
        mw = np.array(armature.matrix_world)
        self.local = []
        for leg in self.legs:
            sole = _sole(armature, leg, up)
            if not len(sole):
                self.local = None
                break
            m = mw @ np.array(armature.pose.bones[leg.toe[0]].matrix)
            self.local.append(np.c_[sole, np.ones(len(sole))] @ np.linalg.inv(m).T)

    def polygon(self, planted=None) -> np.ndarray:
        """The support polygon now of the legs ``planted`` (default all; :class:`Leg`s)."""
        legs = self.legs if planted is None else list(planted)
        if self.local is None:
            return support_now(self.armature, legs, self.up)[0]
        mw = np.array(self.armature.matrix_world)
        points = [(local @ (mw @ np.array(self.armature.pose.bones[leg.toe[0]].matrix)).T)[:, :3]
                  for leg, local in zip(self.legs, self.local) if leg in legs]
        return core_balance.polygon_of(np.concatenate(points), self.up)


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
    scene = context.scene
    baked = [r for r in results if r.bones_keyed and r.frame_end >= r.frame_start]
    if baked:                 # the legs as the rig stands before it moves (a step's last
        scene.frame_set(baked[0].frame_start)    # stance, leaned, reads another chain)
    legs = find_legs(armature, info.bones, info.frame)
    if not legs:
        return
    length = info.arm.arm_length                 # figure units are world units
    hands = None
    for r in results:
        if not r.bones_keyed or r.frame_end < r.frame_start:
            continue
        scene.frame_set(r.frame_start)
        hands = hands if hands is not None else hands_now(armature, info.bones)
        margins, source = margins_over(scene, armature, info, legs, r.frame_start,
                                       r.frame_end, hands)
        margins = [m / length for m in margins]
        worst = int(np.argmin(margins))
        r.stats["com_margin_start"] = float(margins[0])
        r.stats["com_margin_min"] = float(margins[worst])
        r.stats["com_margin_min_frame"] = r.frame_start + worst
        r.stats["support_from"] = source



def margins_over(scene, armature, info, legs, first: int, last: int, hands=None) -> tuple:
    """(the centre of mass's margin over the feet on each frame ``first``..``last`` as
    Blender evaluates it, world units; what the support polygon was read from): the
    polygon read on ``first``, and once a foot has moved (a step) on every frame from the
    soles carried by the feet (:class:`Soles`) on the ground (a foot :data:`LIFTED` off
    it left out), the centre of mass on
    every frame (``hands``: :func:`hands_now`'s, else read now). Changes the scene's
    frame."""
    up = np.asarray(info.frame.ground, dtype=float)
    scene.frame_set(first)
    polygon, source = support_now(armature, legs, up)
    hands = hands if hands is not None else hands_now(armature, info.bones)
    read = [point_of(armature, leg.ankle) for leg in legs]
    leg = float(np.linalg.norm(point_of(armature, legs[0].hip) - read[0]))
    lift = LIFTED * leg
    margins, stepping, soles = [], False, Soles(armature, legs, up)
    for f in range(first, last + 1):
        scene.frame_set(f)
        ankles = [point_of(armature, leg.ankle) for leg in legs]
        stepping = stepping or max(float(np.linalg.norm(a - r))
                                   for a, r in zip(ankles, read)) > STEPPED * leg
        if stepping:
            # a foot has moved (a step): the soles of the feet on the ground now
            ground = min(float(a @ up) for a in ankles)
            planted = [leg for leg, a in zip(legs, ankles) if float(a @ up) <= ground + lift]
            polygon = soles.polygon(planted)
        com = core_balance.centre_of_mass(body_segments(armature, info.bones, legs, hands))
        margins.append(core_balance.balance_margin(com, polygon, up))
    return margins, source


#: A foot counts as lifted off the ground (:func:`margins_over`) where its ankle stands
#: higher than the lower ankle by more than this share of the leg (hip to ankle).
LIFTED = 0.005
#: A foot has moved (:func:`margins_over` reads the polygon on every frame from then on)
#: where its ankle is this share of the leg from where it stood on the first frame (a
#: planted foot in a squat moves by 1e-6 of it).
STEPPED = 0.001
