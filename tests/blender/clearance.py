"""The independent clearance check of the Blender tests: how far the arm that Blender shows
stays from the obstacles, against what the planner promises.

**What the planner promises** (``core.collision.CollisionChecker``, ``core.hand``,
``Settings.clearance``): the arm is three capsules, each a segment between two joints swept
by a radius of the rig model (``ArmModel``, read from the skin by the rig adapter) — the
upper arm (shoulder → elbow, ``upper_arm_radius``), the forearm (elbow → wrist,
``forearm_radius``) and the hand (wrist → the hand's far end, ``hand_radius``; the far end is
``hand_length`` from the wrist toward the middle of the fingers' joints, or of the skin of a
hand without fingers). A keyed pose keeps
every capsule a margin of ``Settings.clearance`` arm lengths (0.02 by default) clear of every
obstacle surface; the instants between two keys, as the keys interpolate (the planner checks
``Settings.instants_per_frame`` = 4 of them a frame), and the frames the hand pass samples
between two poses of the path may use up to half of that margin. So at every instant each
segment is at least its radius plus half the clearance (0.01 arm lengths) from every
obstacle triangle. (A start pose already inside the margin is another promise: it moves out,
every step farther, first; ``test_motion`` checks that case.)

**What is measured here** shares nothing with the planner: the joints are the heads of the
arm's pose bones as Blender evaluates them (after ``frame_set``, sub-frames included), the
hand's far end is read from its finger bones the same way, and the distances are exact
segment-to-triangle distances (``geometry.segment_triangle_distances``, numpy) to the
obstacles' evaluated triangles. Only the radii, the hand's length and the clearance are the
planner's numbers: they are what is promised.

**The tolerance** (:data:`TOLERANCE`, 0.002 arm lengths, about 1 mm on an adult): how much
of its promised room a capsule may lack here. It covers what Blender shows differently from
what the planner checked: the keyed rotations interpolated by Blender's Bézier curves
rather than the linear spans the planner checks (``core.keys``; over a quarter frame of a
reach, joints a few degrees apart: a fraction of a millimetre at the hand), the bake's error
in reproducing the planned joints on a rig driven through constraints (Rigify's, reported as
``rig_residual_arm_lengths``; its reaches here keep 0.021 arm lengths) and the hand's axis
read from the evaluated
finger joints (within a fraction of a degree of the plan's; over the hand's length under
0.002 arm lengths at its far end). Measured over these tests the least room left is 0.0103
arm lengths (the robot's hand in its shelf, between two keys) against the 0.008 asked. A
threshold of 0.3 forearm radii, as these tests once had, passed a forearm 70 % sunk into an
obstacle.
"""

from __future__ import annotations

import bpy
import numpy as np
from geometry import segment_triangle_distances

#: How much of its promised room (arm lengths) a capsule may lack: see the module docstring.
TOLERANCE = 0.002
#: Distances beyond this many arm lengths are not measured (reported as this).
HORIZON = 0.5
#: Capsule-triangle pairs measured in one call when many instants are measured at once
#: (bounds the arrays: about 100 bytes a pair at a time).
PAIRS = 200_000

# bone names of helpers, not of the hand's shape: the hand's far end is read from the rest
HELPER = ("_end", "ik", "fk", "pole", "tweak", "mch", "org", "ctrl")


def hand_bones(armature, hand):
    """The hand bone and every bone below it that is not a helper."""
    out = [hand]
    for b in armature.pose.bones[hand].children_recursive:
        if not any(t in b.name.lower() for t in HELPER):
            out.append(b.name)
    return out


def segments(armature, names):
    """World (head, tail) of pose bones as Blender evaluates them now."""
    mw = np.array(armature.matrix_world)
    pts = []
    for n in names:
        pb = armature.pose.bones[n]
        pts.append((mw[:3, :3] @ np.array(pb.head) + mw[:3, 3],
                    mw[:3, :3] @ np.array(pb.tail) + mw[:3, 3]))
    return pts


def _world(armature, bone):
    """The pose bone's world matrix as Blender evaluates it now (4×4 numpy)."""
    return np.array(armature.matrix_world) @ np.array(armature.pose.bones[bone].matrix)


def skin_anchor(armature, hands, weight=0.5):
    """The middle of a fingerless hand's skin, fixed to its first bone: (bone, point in that
    bone's space), or None where the hand has fingers or moves no skin. The skin is read
    from Blender now: the evaluated vertices of the meshes whose Armature modifier uses
    ``armature``, weighted at least ``weight`` to a bone of ``hands``, and every vertex of
    the meshes parented to one of those bones. Read once (at the start pose), then carried
    by the bone, so a wrist bend that stretches the skin near the wrist does not move it."""
    if any(hand_bones(armature, h)[1:] for h in hands):
        return None
    names, pts = set(hands), []
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for ob in bpy.context.scene.objects:
        if ob.type != "MESH":
            continue
        rigid = ob.parent == armature and ob.parent_type == "BONE" and ob.parent_bone in names
        skinned = any(m.type == "ARMATURE" and m.object == armature for m in ob.modifiers)
        if not (rigid or skinned):
            continue
        groups = {vg.index for vg in ob.vertex_groups if vg.name in names}
        if not rigid and not groups:
            continue
        ev = ob.evaluated_get(depsgraph).data
        mw = np.array(ob.matrix_world)
        for v, e in zip(ob.data.vertices, ev.vertices):
            if rigid or any(g.group in groups and g.weight >= weight for g in v.groups):
                pts.append(mw[:3, :3] @ np.array(e.co) + mw[:3, 3])
    if not pts:
        return None
    bone = hands[0]
    local = np.linalg.inv(_world(armature, bone)) @ np.append(np.mean(pts, axis=0), 1.0)
    return bone, local[:3]


def hand_axis_point(armature, hands, anchor=None):
    """A point the hand's axis runs to from the wrist, now: the mean of the hand's finger
    joints (heads and tails of the bones below the hand bones ``hands``, helpers left out);
    for a hand without fingers its skin's middle (``anchor``, :func:`skin_anchor`), or where
    it has no skin the mean of its bones' tails."""
    joints = [x for h in hands for seg in segments(armature, hand_bones(armature, h)[1:])
              for x in seg]
    if joints:
        return np.mean(joints, axis=0)
    if anchor is not None:
        bone, local = anchor
        return (_world(armature, bone) @ np.append(local, 1.0))[:3]
    return np.mean([t for _h, t in segments(armature, hands)], axis=0)


def hand_end(armature, hands, wrist, length, anchor=None):
    """The hand's far end: ``length`` from the wrist toward :func:`hand_axis_point`."""
    axis = hand_axis_point(armature, hands, anchor) - wrist
    return wrist + length * axis / np.linalg.norm(axis)


class Arm:
    """The reaching arm's capsules as Blender shows them, for one rig.

    ``arm``: the rig model (``RigInfo.arm``) whose radii and hand length the planner used;
    ``chain``: the bones whose heads are the shoulder, the elbow and the wrist (default the
    rig's detected arm); ``hands``: the hand's bones (default the rig's hand group);
    ``clearance``: the planner's ``Settings.clearance`` (default its default).

    ``required``: the least margin (distance − radius, arm lengths) a capsule must keep at
    every instant: half the clearance less :data:`TOLERANCE`."""

    PARTS = ("upper arm", "forearm", "hand")

    def __init__(self, armature, info, chain=None, hands=None, clearance=None):
        if clearance is None:
            from reach_addon.core import Settings

            clearance = Settings().clearance
        self.required = 0.5 * clearance - TOLERANCE
        bones = info.bones.arms[info.side]
        self.armature = armature
        self.model = info.arm
        self.length = info.arm.arm_length
        self.chain = tuple(chain or (bones.upper_arm, bones.forearm, bones.hand))
        self.hands = tuple(hands or getattr(info, "hand_bones", ()) or (bones.hand,))
        a = info.arm
        self.radii = (a.upper_arm_radius, a.forearm_radius, a.hand_radius)
        self.anchor = skin_anchor(armature, self.hands)
        self.worst = {}          # part -> (margin in arm lengths, where)
        self.shape = self._shape_at_start(info) if a.hand_shape else None

    def _shape_at_start(self, info):
        """(the hand bone's world rotation, the wrist, the ends of the hand shape's capsules
        (2K, 3), world) at the start pose, as the rig adapter read it
        (``RigInfo.start_hand_rotation``, ``joints_world``): the model's shape
        (``RigInfo.arm.hand_shape``, what the planner promises to keep clear) placed on the
        model's start pose. From there the shape is carried by the hand bone's turn as
        Blender shows it."""
        from reach_addon.core.arm import pose_from_config
        from reach_addon.core.hand_shape import world_pose

        model = info.arm
        ends = world_pose(model, pose_from_config(model, info.start, hand=info.start_hand))[5:]
        return (np.asarray(info.start_hand_rotation, dtype=float),
                np.asarray(info.joints_world["wrist"], dtype=float), ends)

    def _hand_rotation(self):
        m = _world(self.armature, self.hands[0])[:3, :3]
        return m / np.linalg.norm(m, axis=0)

    def _joints(self):
        mw = np.array(self.armature.matrix_world)
        return [mw[:3, :3] @ np.array(self.armature.pose.bones[n].head) + mw[:3, 3]
                for n in self.chain]

    def capsules(self):
        """[(part, p, q, radius)] at the current evaluation. A model with a hand shape
        (``ArmModel.hand_shape``) has one "hand" capsule per capsule of its shape, carried
        from the start by the hand bone's turn as Blender shows it."""
        shoulder, elbow, wrist = self._joints()
        if self.shape is not None:
            rot0, wrist0, ends0 = self.shape
            turn = self._hand_rotation() @ rot0.T
            ends = wrist + (ends0 - wrist0) @ turn.T
            arm = [("upper arm", shoulder, elbow, self.radii[0]),
                   ("forearm", elbow, wrist, self.radii[1])]
            return arm + [("hand", ends[2 * i], ends[2 * i + 1], r)
                          for i, (_a, _b, r) in enumerate(self.model.hand_shape)]
        tip = hand_end(self.armature, self.hands, wrist, self.model.hand_length, self.anchor)
        ends = ((shoulder, elbow), (elbow, wrist), (wrist, tip))
        return [(part, p, q, r) for part, (p, q), r in zip(self.PARTS, ends, self.radii)]

    def wrist(self):
        """The wrist (the hand bone's head) as Blender shows it now."""
        return self._joints()[2]

    def axis_capsule(self):
        """("hand", wrist, far end, hand radius): the hand's axis capsule now, whether or
        not the model has a hand shape."""
        wrist = self.wrist()
        tip = hand_end(self.armature, self.hands, wrist, self.model.hand_length, self.anchor)
        return "hand", wrist, tip, self.radii[2]

    def margins(self, tris, parts=PARTS):
        """{part: (distance to the triangles − radius) / arm length} now (at most
        :data:`HORIZON`)."""
        return self._margins_of([self._parts(parts)], tris)[0]

    def _parts(self, parts):
        return [c for c in self.capsules() if c[0] in parts]

    def _margins_of(self, instants, tris):
        """:meth:`margins` of capsules read earlier: ``instants`` is a list of capsule lists
        (:meth:`capsules`), all measured against the same triangles in one
        ``segment_triangle_distances`` call per :data:`PAIRS` capsule-triangle pairs (the
        same numbers as one call per instant, pair by pair, in a fraction of the time)."""
        caps = [c for cs in instants for c in cs]
        if not caps:
            return [{} for _cs in instants]
        horizon = HORIZON * self.length + max(r for *_pq, r in caps)
        per = max(1, PAIRS // max(1, len(tris)))
        d = np.concatenate([segment_triangle_distances([c[1] for c in caps[i:i + per]],
                                                       [c[2] for c in caps[i:i + per]],
                                                       tris, horizon)
                            for i in range(0, len(caps), per)])
        out, k = [], 0
        for cs in instants:
            now = {}
            for (part, _p, _q, r), dist in zip(cs, d[k:k + len(cs)]):
                now[part] = min(now.get(part, HORIZON), (dist - r) / self.length)
            out.append(now)
            k += len(cs)
        return out

    def check(self, tris, where, parts=PARTS):
        """Assert every capsule of ``parts`` keeps its radius plus :attr:`required` arm
        lengths from the triangles now; keep the worst margin of each part (``worst``).
        Returns the margins."""
        return self._judge(self.margins(tris, parts), where)

    def _judge(self, now, where):
        """Keep the worst of the margins ``now`` (at ``where``) and assert they keep
        :attr:`required`; returns them."""
        for part, m in now.items():
            if part not in self.worst or m < self.worst[part][0]:
                self.worst[part] = (m, where)
        bad = {part: round(m, 4) for part, m in now.items() if m < self.required}
        assert not bad, (f"{where}: capsule(s) nearer an obstacle than their radius + "
                         f"{self.required:.4f} arm lengths (distance - radius, arm lengths: "
                         f"{bad})")
        return now

    def check_instants(self, tris_at, frames, where="", subframes=(0.0, 0.25, 0.5, 0.75),
                       parts=PARTS):
        """:meth:`check` at every instant of ``frames`` (a range of frames): each frame and
        its ``subframes`` (Blender's ``frame_set(f, subframe=s)``), but only the frame itself
        at the last. ``tris_at()`` gives the obstacles' triangles at the current
        evaluation (a callable, for obstacles that move) or is the triangles. Obstacles
        that stay are measured for all the instants at once (the arm read at each first);
        the first instant, in order, that lacks room fails, as instant by instant."""
        scene = bpy.context.scene
        frames = list(frames)
        instants = [(f, sub) for f in frames for sub in (subframes if f < frames[-1] else (0.0,))]
        if callable(tris_at):
            for f, sub in instants:
                scene.frame_set(f, subframe=sub)
                self.check(tris_at(), f"{where}frame {f + sub:g}", parts)
            return self.worst
        caps = []
        for f, sub in instants:
            scene.frame_set(f, subframe=sub)
            caps.append(self._parts(parts))
        for (f, sub), now in zip(instants, self._margins_of(caps, tris_at)):
            self._judge(now, f"{where}frame {f + sub:g}")
        return self.worst

    def report(self):
        """The worst margins seen, one line (for -s runs and failure messages)."""
        return ", ".join(f"{part} {m:+.4f} at {where}" for part, (m, where) in self.worst.items())


class HandSkin:
    """The hand's skin as Blender shows it, against the obstacles' triangles: the
    triangles of the evaluated meshes that the hand's bones (the hand group and every bone
    below it that is no helper, :func:`hand_bones`) move, read by
    ``verification.refusal.arm_skin`` (a triangle is the hand's where each of its vertices
    is weighted at least half to those bones; a part parented to one of them, whole). A
    triangle across the wrist, half the forearm's, is the forearm's: its capsule has the
    75th percentile of its skin's distance for a radius, and a flared cuff stands outside
    it (the Knight's gauntlet, 0.1–0.2 arm lengths at the wrist).

    This measures what the capsules of :class:`Arm` stand for: the planner models the hand
    as one capsule (wrist → far end, ``hand_radius``), and a hand's skin (a flat mitten, a
    thumb or splayed fingers) can reach beyond it. :meth:`check_instants` keeps, for every
    instant, whether a skin triangle crosses an obstacle's and the least distance from the
    skin's vertices to the obstacles."""

    def __init__(self, armature, info):
        bones = info.bones.arms[info.side]
        self.armature = armature
        self.length = info.arm.arm_length
        self.bones = {b for h in (getattr(info, "hand_bones", ()) or (bones.hand,))
                      for b in hand_bones(armature, h)}
        self.crossings = []      # (instant, number of skin triangles crossing an obstacle's)
        self.least = (HORIZON, -1.0)    # (least distance in arm lengths, instant)
        self.measured = 0

    def skin(self):
        """The hand's skin triangles (T, 3, 3), world, as Blender evaluates them now."""
        from verification.refusal import arm_skin

        return arm_skin(bpy.context, self.armature, self.bones, every_vertex=True)[0]

    def check_instants(self, tris, frames, subframes=(0.0, 0.5)):
        """Measure the skin against the (still) obstacle triangles ``tris`` at every frame
        of ``frames`` and its ``subframes`` (only the frame itself at the last). Returns the
        instants where the skin crosses an obstacle."""
        from verification import geometry

        frames = list(frames)
        horizon = HORIZON * self.length
        for f in frames:
            for sub in (subframes if f < frames[-1] else (0.0,)):
                bpy.context.scene.frame_set(f, subframe=sub)
                skin = self.skin()
                if not len(skin):
                    continue
                self.measured += 1
                ia, _ib = geometry.intersecting_pairs(skin, tris)
                if len(ia):
                    self.crossings.append((f + sub, len(np.unique(ia))))
                    self.least = min(self.least, (0.0, f + sub))
                    continue
                d = geometry.least_distance(np.unique(skin.reshape(-1, 3), axis=0), tris,
                                            horizon) / self.length
                self.least = min(self.least, (d, f + sub))
        return self.crossings

    #: What the skin is of, in reports.
    part = "hand"

    def report(self):
        if not self.measured:
            return f"no {self.part} skin"
        if self.crossings:
            at = ", ".join(f"{t:g}" for t, _n in self.crossings[:6])
            return (f"the {self.part}'s skin crosses an obstacle at {len(self.crossings)} of "
                    f"{self.measured} instants (frames {at}{'…' if len(self.crossings) > 6 else ''})")
        return (f"the {self.part}'s skin keeps {self.least[0]:.4f} arm lengths at least "
                f"(at {self.least[1]:g})")


class ArmSkin(HandSkin):
    """:class:`HandSkin` for the skin of the upper arm and the forearm: the triangles the
    bones from the upper arm down to the hand move (twist bones included, the hand's
    own not). The planner keeps capsules clear whose radii are the 75th percentile of
    this skin's distance from each segment (``blender.rig``), so a quarter of it stands
    outside them, within the clearance it keeps (an elbow's flare, a gauntlet's cuff)."""

    part = "arm"

    def __init__(self, armature, info):
        super().__init__(armature, info)
        upper = armature.pose.bones[info.bones.arms[info.side].upper_arm]
        self.bones = {upper.name} | {b.name for b in upper.children_recursive} - self.bones
