"""What a baked reach looks like in Blender, read back from the evaluated bones.

Nothing here uses the planner: the bones are evaluated by Blender (``scene.frame_set``),
the body's axes are taken from the bones themselves, and the angles are measured with
mathutils. So a planner or bake bug cannot hide from these numbers. ``make demo`` prints
them beside Table 1, the bench plots them (``bench/table1.png``) and the tests assert on
them.

The body's axes of a standing figure: up is the world's +Z; right is the horizontal part
of the line from the left shoulder joint (the head of the left upper arm) to the right;
forward is up × right; the spine axis is the vertical line through the chest bone's head,
and the origin sits on it at the shoulders' mean height.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mathutils import Matrix, Vector


@dataclass(frozen=True)
class BodyAxes:
    """World-space axes of a standing figure (see the module docstring)."""

    origin: Vector
    right: Vector
    forward: Vector
    up: Vector

    def side(self, side: str) -> Vector:
        """The horizontal direction toward the figure's ``side`` ('right' or 'left')."""
        return self.right if side == "right" else -self.right

    def direction_deg(self, point, side: str) -> float:
        """Horizontal direction of a world point from straight ahead, positive toward
        ``side`` (90° straight out to that side, 180° behind)."""
        d = Vector(point) - self.origin
        return math.degrees(math.atan2(d.dot(self.side(side)), d.dot(self.forward)))

    def distance(self, point) -> float:
        """Horizontal distance of a world point from the spine axis."""
        d = Vector(point) - self.origin
        return (d - d.dot(self.up) * self.up).length

    def point(self, direction_deg: float, distance: float, height: float, side: str) -> Vector:
        """The world point at a horizontal direction and distance from the spine axis and a
        height above the origin."""
        t = math.radians(direction_deg)
        return (self.origin + distance * (math.sin(t) * self.side(side) + math.cos(t) * self.forward)
                + height * self.up)


def bone_matrix(armature, bone: str) -> Matrix:
    """World matrix of a pose bone as evaluated at the current frame."""
    return armature.matrix_world @ armature.pose.bones[bone].matrix


def bone_head(armature, bone: str) -> Vector:
    """World position of a pose bone's head at the current frame."""
    return armature.matrix_world @ armature.pose.bones[bone].head


def body_axes(armature, chest: str, upper_arm_right: str, upper_arm_left: str) -> BodyAxes:
    """The body's axes at the current frame (see the module docstring)."""
    up = Vector((0.0, 0.0, 1.0))
    r, l_ = bone_head(armature, upper_arm_right), bone_head(armature, upper_arm_left)
    across = r - l_
    right = (across - across.dot(up) * up).normalized()
    forward = up.cross(right)
    c = bone_head(armature, chest)
    origin = c + ((r + l_) / 2 - c).dot(up) * up
    return BodyAxes(origin, right, forward, up)


def yaw_deg(matrix: Matrix, reference: Matrix, axes: BodyAxes, side: str) -> float:
    """How far a bone has turned about the vertical from ``reference`` to ``matrix`` (world
    matrices), positive toward ``side``: the body's forward carried by the bone's rotation
    between the two, measured in the horizontal plane."""
    turn = matrix.to_3x3().normalized() @ reference.to_3x3().normalized().inverted()
    f = turn @ axes.forward
    return math.degrees(math.atan2(f.dot(axes.side(side)), f.dot(axes.forward)))


def body_axes_of(armature, bones) -> BodyAxes:
    """:func:`body_axes` of a figure whose bones are named by a rig's bone map (its chest
    and both upper arms)."""
    return body_axes(armature, bones.chest, bones.arms["right"].upper_arm,
                     bones.arms["left"].upper_arm)


def arrival(armature, bones, side: str, axes: BodyAxes, chest_reference: Matrix) -> dict:
    """Where the ``side`` arm's wrist is at the current frame (the hand bone's head: world
    position, horizontal direction and distance from the spine axis) and how far the keyed
    chest has turned about the vertical since ``chest_reference`` (its world matrix then)."""
    wrist = bone_head(armature, bones.arms[side].hand)
    return {"wrist": wrist, "wrist_direction_deg": axes.direction_deg(wrist, side),
            "wrist_distance": axes.distance(wrist),
            "chest_yaw_deg": yaw_deg(bone_matrix(armature, bones.keyed_chest), chest_reference,
                                     axes, side)}
