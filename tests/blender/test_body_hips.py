"""The hips moved back with the feet planted (``blender.hips``, stage 3 of the whole-body
reach), on every rig of ``test_every_rig`` that has legs.

Each rig's hips are posed 0.12 arm lengths back from the body's front (and down as far as
its legs need). Measured on Blender's evaluated bones, by code that shares nothing with the
posing: every bone whose head starts in the lowest 15 % of the figure's height moves less
than 2 % of an arm length (the issue's planted feet); the hips bone's head moves by the
shift asked (and the drop reported); the chest, carried by the hips, comes back with them;
each knee lies ahead of the line from its hip to its ankle (a knee bends only forward).
"""

from __future__ import annotations

import importlib

import bpy
import numpy as np
import pytest
from test_body_lean import bone_heads, open_rig
from test_every_rig import KINDS, rig_file  # noqa: F401  (the fixture)

#: How far back the hips are posed (arm lengths).
SHIFT = 0.12
#: The issue's planted feet: every bone below the knees within this share of an arm length.
FEET_HOLD = 0.02


@pytest.mark.parametrize("kind", KINDS)
def test_the_hips_move_back_and_the_feet_stay(addon, rig_file, kind):  # noqa: F811
    armature = open_rig(rig_file, kind)
    info = addon.blender.rig.build(armature, "right")
    blender = addon.blender
    hips_mod = importlib.import_module(addon.__name__ + ".blender.hips")
    legs = blender.balance.find_legs(armature, info.bones, info.frame)
    if not legs:
        pytest.skip(f"{kind}: no legs")
    lean = blender.lean.lean_bone(armature, info.bones, legs)
    hips = hips_mod.hips_bone(armature, legs, lean)
    assert hips is not None, f"{kind}: no bone carries both legs and the trunk"
    length = info.arm.arm_length
    up, forward = np.asarray(info.frame.up, float), np.asarray(info.frame.forward, float)
    start = bone_heads(armature)
    heights = {n: float(p @ up) for n, p in start.items()}
    low, high = min(heights.values()), max(heights.values())
    feet = [n for n, h in heights.items() if h <= low + 0.15 * (high - low)]
    assert feet
    shift = -SHIFT * length * forward
    drop = hips_mod.pose_shift(bpy.context, armature, legs, hips, shift, up, forward)
    now = bone_heads(armature)
    moved = max(float(np.linalg.norm(now[n] - start[n])) for n in feet) / length
    assert moved < FEET_HOLD, f"{kind}: a foot bone moved {moved:.4f} arm lengths"
    expected = shift - drop * up
    assert np.linalg.norm(now[hips] - start[hips] - expected) < 1e-4 * length
    # and the knees bend forward, ahead of the line from hip to ankle
    for leg in legs:
        h, k, a = (blender.balance.point_of(armature, p) for p in (leg.hip, leg.knee, leg.ankle))
        line = (a - h) / np.linalg.norm(a - h)
        off = (k - h) - ((k - h) @ line) * line
        assert float(off @ forward) > 0.0, f"{kind}: a knee bends backward"
    chest = info.bones.keyed_chest
    assert np.linalg.norm(now[chest] - start[chest] - expected) < 1e-4 * length
    print(f"HIPS {kind}: hips '{hips}', drop {drop / length:.3f}, feet {moved:.5f}")
