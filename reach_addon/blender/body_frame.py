"""The body frame: the figure's right, forward and up axes and its shoulder half-width,
measured in world space from the bones at the current frame (:func:`body_frame`).

Nothing about orientation or size is assumed; a mirrored armature (negative determinant)
gets a left-handed frame. Why: ``docs/design/blender.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import ReachError
from .rig_detect import BoneMap, ancestors


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
    #: the ground's up, against the scene's gravity (:func:`ground_up`): what the body's
    #: balance, its hips' drop and its steps are measured along. ``up`` is the spine's,
    #: which leans as the figure stands (3.9° forward on the metarig, 6.9° on Quaternius'
    #: figure: 6 cm at its centre of mass's height, a quarter of a foot's length).
    ground: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

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
    for b in ancestors(bones[chest_name]):
        d = world_length(armature, np.array(b.head_local) - chest)
        if best_d < d <= 2.5 * shoulder_width:
            best, best_d = b.name, d
    return best


def ground_up(armature) -> np.ndarray:
    """The world's up for the body's balance (unit): against the gravity of the scene the
    ``armature`` is in (*Scene ▸ Gravity*, (0, 0, −9.81) by default), +Z where that is
    zero or the armature is in no scene."""
    scenes = list(getattr(armature, "users_scene", ()))
    g = -np.asarray(scenes[0].gravity, dtype=float) if scenes else np.zeros(3)
    n = float(np.linalg.norm(g))
    return g / n if np.isfinite(n) and n > 0.0 else np.array([0.0, 0.0, 1.0])


def body_frame(armature, bmap: BoneMap) -> BodyFrame:
    """The body frame of ``armature`` at the current frame (world space): **right** =
    right shoulder − left shoulder; **up** = from the base of the spine (the chest's lowest
    ancestor within 2.5 shoulder widths) to the neck (else the shoulders' middle), made
    perpendicular to right; **forward** = up × right (right × up for a mirrored armature);
    the origin on the spine axis (the line through the chest's head along up) at shoulder
    height; the shoulder half-width in world units. Raises ReachError where the shoulders
    coincide or up cannot be told."""
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
    return BodyFrame(origin, right, forward, up, half, ground_up(armature))
