"""How natural a baked arm looks, measured on the bones as Blender evaluates them.

Two figures of a posture, each read from pose bone matrices alone (no code of the planner):

*wrist bend* (:func:`wrist_bend_deg`)
    how far the hand's axis (its bone's y axis, or a direction fixed in the hand bone's
    frame that the caller gives: a fingerless hand's skin) has turned in the forearm's
    frame from where
    it lies in the rig's rest pose, in degrees. The rest pose is the rig's neutral wrist, so
    a rig modelled with a slightly bent hand is not charged for it. The hand's twist about
    its own axis is not a bend (the forearm carries it), so it does not count.
*chicken wing* (:func:`chicken_wing`)
    the elbow more than :data:`WING_MARGIN` arm lengths above the shoulder while the wrist is
    more than that below it: the elbow lifted out to the side for a low target, which people
    reaching below the shoulder do not do. "Above" is along ``up`` (world z for an upright
    character).

RULA scores a wrist beyond 15° from neutral as a risk; :data:`MEAN_BEND_MAX` and
:data:`MAX_BEND_MAX` are the figures a reach is held to where nothing forces a bend.

:func:`measure` evaluates an armature frame by frame and returns a :class:`Figures`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

#: Arm lengths the elbow must be above the shoulder, and the wrist below it, to count.
WING_MARGIN = 0.1
#: The mean wrist bend (degrees) over a reach that reads as relaxed.
MEAN_BEND_MAX = 12.0
#: The largest wrist bend (degrees) a reach may have where no obstacle forces it.
MAX_BEND_MAX = 45.0
#: Degrees of bend from which a frame counts as bent (RULA's risk threshold).
FORCED_FROM = 15.0


def _unit_columns(m: np.ndarray) -> np.ndarray:
    return m / np.linalg.norm(m, axis=0)


def hand_axis_in_forearm(forearm: np.ndarray, hand: np.ndarray, axis=(0.0, 1.0, 0.0)) -> np.ndarray:
    """The hand's ``axis`` (a unit direction in the hand bone's frame, default its y axis)
    in the forearm bone's frame: ``Rfᵀ Rh a`` for the two bones' 3×3 matrices (armature or
    world space, scale divided out)."""
    rf, rh = _unit_columns(forearm[:3, :3]), _unit_columns(hand[:3, :3])
    return rf.T @ (rh @ np.asarray(axis, float))


def wrist_bend_deg(forearm, hand, forearm_rest, hand_rest, axis=(0.0, 1.0, 0.0)) -> float:
    """The angle (degrees) between the hand's axis in the forearm's frame now and at rest:
    ``acos(a_now · a_rest)``, ``a = Rfᵀ Rh â`` (:func:`hand_axis_in_forearm`; ``axis`` â)."""
    a = hand_axis_in_forearm(np.asarray(forearm), np.asarray(hand), axis)
    b = hand_axis_in_forearm(np.asarray(forearm_rest), np.asarray(hand_rest), axis)
    c = float(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def chicken_wing(shoulder, elbow, wrist, up, arm_length, margin: float = WING_MARGIN) -> bool:
    """Is the elbow more than ``margin`` arm lengths above the shoulder while the wrist is
    more than that below it? ``(elbow - shoulder)·up > margin·L`` and
    ``(wrist - shoulder)·up < -margin·L``."""
    up = np.asarray(up, float) / np.linalg.norm(up)
    e = float(np.dot(np.asarray(elbow) - np.asarray(shoulder), up))
    w = float(np.dot(np.asarray(wrist) - np.asarray(shoulder), up))
    return e > margin * arm_length and w < -margin * arm_length


@dataclass
class Figures:
    """The naturalness of a stretch of frames: wrist bend per frame (degrees), its mean and
    maximum, and the frames with a chicken wing."""
    frames: list = field(default_factory=list)
    bends: list = field(default_factory=list)
    wing_frames: list = field(default_factory=list)

    @property
    def mean_bend(self) -> float:
        return float(np.mean(self.bends)) if self.bends else 0.0

    @property
    def max_bend(self) -> float:
        return float(np.max(self.bends)) if self.bends else 0.0

    @property
    def worst_frame(self):
        return self.frames[int(np.argmax(self.bends))] if self.bends else None

    def summary(self) -> dict:
        return {"mean_wrist_bend_deg": round(self.mean_bend, 2),
                "max_wrist_bend_deg": round(self.max_bend, 2), "worst_frame": self.worst_frame,
                "chicken_wing_frames": list(self.wing_frames)}

    def as_dict(self) -> dict:
        return asdict(self) | self.summary()


def measure(armature, upper: str, forearm: str, hand: str, frames, up=(0.0, 0.0, 1.0),
            scene=None, axis=(0.0, 1.0, 0.0)) -> Figures:
    """:class:`Figures` of ``frames`` of ``armature`` (a Blender armature object), its arm
    the pose bones ``upper``, ``forearm`` and ``hand``, as Blender evaluates them after
    ``scene.frame_set`` (the rest pose read from the armature's bones); ``axis``: the hand's
    axis in the hand bone's frame (:func:`hand_axis_in_forearm`)."""
    import bpy

    scene = scene or bpy.context.scene
    world = np.array(armature.matrix_world)
    bones = armature.data.bones
    fa_rest, h_rest = np.array(bones[forearm].matrix_local), np.array(bones[hand].matrix_local)
    pb = armature.pose.bones
    out = Figures()
    for f in frames:
        scene.frame_set(int(f), subframe=float(f) - int(f))
        m_f, m_h = np.array(pb[forearm].matrix), np.array(pb[hand].matrix)
        out.frames.append(f)
        out.bends.append(wrist_bend_deg(m_f, m_h, fa_rest, h_rest, axis))
        joints = [world @ np.append(np.array(v), 1.0) for v in
                  (pb[upper].head, pb[forearm].head, pb[hand].head)]
        shoulder, elbow, wrist = (j[:3] for j in joints)
        length = np.linalg.norm(elbow - shoulder) + np.linalg.norm(wrist - elbow)
        if chicken_wing(shoulder, elbow, wrist, up, length):
            out.wing_frames.append(f)
    return out
