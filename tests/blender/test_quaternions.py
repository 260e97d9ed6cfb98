"""The rotation channels a bake writes (:func:`reach_addon.blender.bone_matrices.channel_values`, on
mathutils' ``to_quaternion``, ``make_compatible`` and ``to_euler``), checked against numpy
arithmetic of their own on a few hundred seeded rotations: random ones, rotations within a
thousandth of a radian of 180°, and a steady turn through 720° whose raw quaternion changes
sign twice; every matrix with non-uniform scale and a translation, as a bone's local
matrix has."""

from types import SimpleNamespace

import numpy as np
import pytest
from mathutils import Euler, Quaternion

from reach_addon.blender.bone_matrices import channel_values

SEED = 20240611
#: Current rotations of the bone: at rest, a half turn, a turn of 216° (w < 0).
CURRENT = [(1.0, 0.0, 0.0, 0.0), (0.0, 0.6, 0.0, 0.8), (-0.309017, 0.0, 0.570634, 0.760845)]


def quaternion_matrices(q):
    """Rotation matrices (F, 3, 3) of unit quaternions (F, 4) (w, x, y, z)."""
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)


def axis_angle(axes, angles):
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    return np.column_stack([np.cos(angles / 2), np.sin(angles / 2)[:, None] * axes])


def rotations():
    """Unit quaternions (F, 4) of the rotations: 200 random, 100 near 180° (some exactly),
    then 200 steps of one steady turn through 720°, starting at rest."""
    rng = np.random.default_rng(SEED)
    random = rng.normal(size=(200, 4))
    random /= np.linalg.norm(random, axis=1, keepdims=True)
    near_half_turn = axis_angle(rng.normal(size=(100, 3)),
                                np.pi - np.where(rng.random(100) < 0.2, 0.0,
                                                 rng.uniform(0, 1e-3, 100)))
    turn = axis_angle(np.tile(rng.normal(size=3), (200, 1)), np.linspace(0, 4 * np.pi, 200))
    return random, near_half_turn, turn


def local_matrices(q, rng):
    """Bone-local 4×4 matrices of rotations ``q``, their columns scaled (0.3–3) and moved."""
    m = np.tile(np.eye(4), (len(q), 1, 1))
    m[:, :3, :3] = quaternion_matrices(q) * rng.uniform(0.3, 3.0, size=(len(q), 1, 3))
    m[:, :3, 3] = rng.normal(size=(len(q), 3))
    return m


def bone(mode, current=(1.0, 0.0, 0.0, 0.0)):
    """What channel_values reads of a pose bone: its rotation mode and current rotation."""
    q = Quaternion(current)
    axis, angle = q.to_axis_angle()
    return SimpleNamespace(rotation_mode=mode, rotation_quaternion=q,
                           rotation_axis_angle=(angle, *axis), rotation_euler=q.to_euler("XYZ"))


def check_quaternions(values, expected, current):
    """Each quaternion is its frame's rotation (the same up to sign), of unit length, and in
    the hemisphere of the one before it, the first in that of the bone's current value."""
    assert values.shape == expected.shape
    np.testing.assert_allclose(np.linalg.norm(values, axis=1), 1.0, atol=1e-5)
    same = np.abs(np.einsum("ij,ij->i", values, expected))
    assert same.min() > 1 - 1e-5, f"frame {same.argmin()} is another rotation"
    before = np.vstack([current, values[:-1]])
    dots = np.einsum("ij,ij->i", values, before)
    assert dots.min() > -1e-6, f"frame {dots.argmin()} flips to the other hemisphere"


@pytest.mark.parametrize("current", CURRENT + [(0.0, 0.48, 0.0, 0.64)])
def test_quaternion_channels_are_the_rotations_without_flips(current):
    """Unit quaternions also where the bone's own is not (as between two keys): mathutils'
    make_compatible would give every key the length of the quaternion it follows."""
    rng = np.random.default_rng(SEED)
    for q in rotations():
        path, values = channel_values(bone("QUATERNION", current), local_matrices(q, rng))
        assert path == "rotation_quaternion"
        check_quaternions(values, q, np.array(current, float))


def test_a_steady_turn_keeps_one_smooth_quaternion_through_720_degrees():
    """The raw quaternion of a steady turn changes sign each 360°; the channels follow the
    turn smoothly instead (from rest: exactly the quaternion the turn is made of)."""
    turn = rotations()[2]
    _path, values = channel_values(bone("QUATERNION"),
                                   local_matrices(turn, np.random.default_rng(SEED)))
    np.testing.assert_allclose(values, turn, atol=1e-5)
    assert values[:, 0].min() < -0.99 and values[:, 0].max() > 0.99


@pytest.mark.parametrize("current", CURRENT)
def test_axis_angle_channels_are_the_rotations_without_flips(current):
    """Also from a current angle of 180° or more: the first key is in its hemisphere (an
    axis-angle of 216° is not taken for one of -144°, whose axis is the other way)."""
    rng = np.random.default_rng(SEED)
    for q in rotations():
        path, values = channel_values(bone("AXIS_ANGLE", current), local_matrices(q, rng))
        assert path == "rotation_axis_angle"
        # (angle, axis) back to a quaternion here, not by mathutils' Quaternion(axis, angle),
        # which wraps the angle into ±180° and so may flip the sign
        check_quaternions(axis_angle(values[:, 1:], values[:, 0]), q, np.array(current))


@pytest.mark.parametrize("mode", ["XYZ", "ZXY", "YZX"])
def test_euler_channels_are_the_rotations(mode):
    rng = np.random.default_rng(SEED)
    for q in rotations():
        path, values = channel_values(bone(mode), local_matrices(q, rng))
        assert path == "rotation_euler"
        back = np.array([np.array(Euler(v, mode).to_matrix()) for v in values])
        np.testing.assert_allclose(back, quaternion_matrices(q), atol=2e-5)
