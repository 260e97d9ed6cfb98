"""The body's balance on every rig with legs: its legs found by their shape, its centre of
mass over its feet as it stands, and moved as its arm moves by what the arm weighs.

Checked against Blender's evaluated bones and skin, not against the code that reads them:

- the feet the reader found are the lowest part of the skin (each toe within 0.15 arm
  lengths of the skin's lowest point, along the scene's up), one on each side;
- standing at rest, the centre of mass is inside the support polygon, along gravity (but
  for Quaternius' Alien, 0.012 arm lengths past it by Winter's human shares);
- raising the right arm forward (the upper arm turned to point forward by hand, in
  Blender) moves the centre of mass forward by what Winter's table gives the
  arm's three segments for that move (their shares of the mass times their centres'
  moves, worked out here from the bones' heads and tails), to within 2 %.
"""

from __future__ import annotations

import math

import bpy
import numpy as np
import pytest
import rigs
from everyday import gravity_up
from mathutils import Vector

from reach_addon.blender import balance, rig as rig_mod
from reach_addon.core import balance as core_balance

#: The real rigs with legs, and Rigify's metarig.
KINDS = rigs.FILE_RIGS + ("metarig",)


def _world(arm, name, end):
    mw = np.array(arm.matrix_world)
    b = arm.pose.bones[name]
    return mw[:3, :3] @ np.array(b.head if end == "head" else b.tail) + mw[:3, 3]


def _skin_low(arm, up) -> float:
    """The lowest point of the character's evaluated skin along ``up``."""
    dg = bpy.context.evaluated_depsgraph_get()
    low = math.inf
    for ob in bpy.context.scene.objects:
        if ob.type != "MESH" or not (ob.parent == arm or any(
                m.type == "ARMATURE" and m.object == arm for m in ob.modifiers)):
            continue
        ev = ob.evaluated_get(dg)
        mesh = ev.to_mesh()
        try:
            co = np.empty(3 * len(mesh.vertices))
            mesh.vertices.foreach_get("co", co)
        finally:
            ev.to_mesh_clear()
        mw = np.array(ob.matrix_world)
        world = co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]
        if len(world):
            low = min(low, float((world @ up).min()))
    return low


@pytest.mark.parametrize("kind", KINDS)
def test_a_standing_rig_is_balanced_and_its_arm_moves_its_centre_of_mass(addon, kind):
    arm = rigs.load(kind)
    rigs.rest_still(arm)
    bpy.context.view_layer.update()
    info = rig_mod.build(arm, "right")
    bmap, frame = info.bones, info.frame
    legs = balance.find_legs(arm, bmap, frame)
    assert len(legs) == 2, kind
    up = gravity_up()
    scale = float(np.linalg.norm(_world(arm, bmap.arms["right"].upper_arm, "head")
                                 - _world(arm, bmap.arms["right"].hand, "head")))
    low = _skin_low(arm, up)
    sides = []
    for leg in legs:
        toe = _world(arm, *leg.toe)
        if math.isfinite(low):
            assert float(toe @ up) - low <= 0.15 * scale, (kind, leg)
        sides.append(float((toe - frame.origin) @ frame.right))
    assert sides[0] > 0.0 > sides[1], (kind, sides)
    margin = balance.margin_now(arm, bmap, legs, up)
    print(f"BALANCE {kind}: margin {margin / scale:.3f} arm lengths")
    if kind == "alien":
        # Winter's human shares on a cartoon's proportions put its centre of mass 0.012
        # arm lengths past the edge of its feet (along the spine's axis, which leans 1.9°
        # back, it was inside, as the metarig was 0.037 past its heels along its own,
        # 3.9° forward, and is 0.091 inside along gravity)
        assert -0.03 < margin / scale < 0.0, margin / scale
    else:
        assert margin > 0.0, (kind, margin / scale)

    # the right arm raised forward by hand: the centre of mass moves by the arm's own share
    a = bmap.arms["right"]
    segments = balance.body_segments(arm, bmap, legs)
    before = core_balance.centre_of_mass(segments)
    joints = [_world(arm, n, "head") for n in (a.upper_arm, a.forearm, a.hand)]
    hand = next(d - p for k, p, d in segments if k == "hand" and np.allclose(p, joints[2]))
    pb = arm.pose.bones[a.upper_arm]
    inv = np.linalg.inv(np.array(arm.matrix_world)[:3, :3])
    now = inv @ (_world(arm, a.forearm, "head") - _world(arm, a.upper_arm, "head"))
    ahead = inv @ np.asarray(frame.forward, dtype=float)
    turn = Vector(now.tolist()).rotation_difference(Vector(ahead.tolist())).to_matrix().to_4x4()
    head = pb.head.copy()
    m = pb.matrix.copy()
    m.translation = (0.0, 0.0, 0.0)
    m = turn @ m
    m.translation = head
    pb.matrix = m
    bpy.context.view_layer.update()
    after = core_balance.centre_of_mass(balance.body_segments(arm, bmap, legs))
    moved = [_world(arm, n, "head") for n in (a.upper_arm, a.forearm, a.hand)]
    # the hand turns with the arm, rigidly: its axis turned as the forearm turned
    turned = np.array(Vector((joints[2] - joints[1]).tolist()).rotation_difference(
        Vector((moved[2] - moved[1]).tolist())).to_matrix())
    total = sum(core_balance.WINTER[k][0] for k, _p, _d in segments)
    expect = np.zeros(3)
    for k, (p0, d0), (p1, d1) in (
            ("upper_arm", joints[:2], moved[:2]), ("forearm", joints[1:], moved[1:]),
            ("hand", (joints[2], joints[2] + hand), (moved[2], moved[2] + turned @ hand))):
        share, r = core_balance.WINTER[k]
        expect += share / total * ((p1 + r * (d1 - p1)) - (p0 + r * (d0 - p0)))
    shift = after - before
    assert float(shift @ frame.forward) > 0.0, kind
    assert np.linalg.norm(shift - expect) <= 0.02 * np.linalg.norm(expect), (kind, shift, expect)


def test_a_baked_reach_reports_the_balance_it_keeps(addon):
    """A reach past a wall on a MakeHuman rig, baked as a user bakes it: the report gives the
    centre of mass's margin on the first frame and its least, from the soles' skin, and
    the least is the least of the frames' margins as this test reads them."""
    import everyday
    arm = rigs.load("gomakehuman")
    rigs.rest_still(arm)
    info = rig_mod.build(arm, "right")
    targets = everyday.build("wall", info, arm)
    pipeline = addon.blender.pipeline
    request = pipeline.Request(arm.name, [t.name for t in targets], task="reach", side="right",
                               frame_start=1, draw=False)
    outcome = pipeline.run(bpy.context, request, bake=True)
    (result,) = outcome.results
    stats = result.stats
    assert result.success and stats["support_from"] == "skin"
    assert 0.0 < stats["com_margin_min"] <= stats["com_margin_start"]
    assert result.frame_start <= stats["com_margin_min_frame"] <= result.frame_end
    legs = balance.find_legs(arm, info.bones, info.frame)
    up = gravity_up()
    bpy.context.scene.frame_set(result.frame_start)
    polygon, _source = balance.support_now(arm, legs, up)
    margins = []
    for f in range(result.frame_start, result.frame_end + 1):
        bpy.context.scene.frame_set(f)
        com = core_balance.centre_of_mass(balance.body_segments(arm, info.bones, legs))
        margins.append(core_balance.balance_margin(com, polygon, up) / info.arm.arm_length)
    assert stats["com_margin_min"] == pytest.approx(min(margins), abs=1e-9)
