"""A lean, then the reach, on every rig with legs (issue "Reach past the arm", stage 1).

Each rig of ``test_every_rig`` gets a target straight ahead of its reaching shoulder, 0.3
arm lengths below it, :data:`BEYOND` arm lengths beyond the farthest such point the arm
reaches without a lean (found by bisection with *Lean* off, the chest turning as it
may), over a table whose top is 0.75 arm lengths below the shoulder; it is baked as a
user's Bake is, with *Lean* on.
Measured on what Blender evaluates, with code that shares nothing with the planner:

- the wrist (the hand bone's head) ends on the target, within the goal tolerance;
- the feet stay put: every bone whose head starts in the lowest 15 % of the figure's height
  moves less than 0.0005 arm lengths, at every frame and three instants between;
- the reaching arm keeps the clearance the planner promises at every frame and three
  instants between (``clearance.Arm``: its capsules, from the evaluated bones);
- the rest of the character's skin (every mesh the armature deforms or carries, less the
  reaching arm's, whose capsules the line above checks) stays out of the table at those
  instants (signed distance to the box; the metarig has no skin);
- the lean bone turns by the reported lean (±1°) by the reach's first frame, and the
  report gives the lean and the centre of mass's margin, never below 0 nor below the
  rig's own as it stands (two synthetic rigs and the metarig stand past their feet), as
  the planner weighed it and over every frame of the bake.

Without *Lean* the same target is refused as ``needs_lean``, with a hint to turn it on.
"""

from __future__ import annotations

import importlib

import bpy
import everyday
from verification.fuzz import campaign
import numpy as np
import pytest
import clearance
from test_every_rig import KINDS, obstacle_triangles, rig_file  # noqa: F401  (the fixture)

#: The instants measured in a frame (the frame itself and three between).
INSTANTS = 4
#: How far beyond the arm's reach the target stands (arm lengths).
BEYOND = 0.03
#: The target's height under the shoulder (arm lengths).
BELOW = 0.3


def scene(armature, info, ahead):
    """The target ``ahead`` arm lengths in front of the shoulder and :data:`BELOW` under it,
    and a table: its top 0.75 under the shoulder, its near face 0.1 beyond the hand's skin
    and the arm's capsules (:func:`everyday.near`) and beyond the body's skin at the
    table's height (room for what the lean carries forward), at least 0.45 ahead."""
    target = everyday.at(info, ahead, 0.0, -BELOW)
    ob = bpy.data.objects.new("Far Cup", None)
    ob.location = tuple(target)
    bpy.context.scene.collection.objects.link(ob)
    within = ((-0.6, 0.6), (-1.1, -0.75))
    shoulder, forward, outward, up, length = everyday.body_axes(info)
    rel = (skin_vertices(armature, set()) - shoulder) / length
    at_table = (np.abs(rel @ outward) <= 0.64) & (rel @ up >= -1.14) & (rel @ up <= -0.71)
    body = float((rel[at_table] @ forward).max()) if at_table.any() else -np.inf
    f0 = max(everyday.near(armature, info, 0.45, within), body + 0.04) + 0.1
    table = everyday.box(info, "Table", (f0, -0.6, -1.1), (f0 + 1.2, 0.6, -0.75))
    return ob, table


def open_rig(rig_file, kind):  # noqa: F811
    path, name = rig_file(kind)
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    return bpy.data.objects[name]


def run(addon, armature, info, ahead, lean, bake, new_action=False, **settings_):
    target, table = scene(armature, info, ahead)
    pipeline = addon.blender.pipeline
    settings = addon.core.Settings().replace(lean=lean, **settings_)
    request = pipeline.Request(armature.name, [target.name], task="reach", side="right",
                               frame_start=1, draw=False, settings=settings,
                               new_action=new_action)
    return target, table, pipeline.run(bpy.context, request, bake=bake)


def reach_edge(addon, rig_file, kind, steps=7):  # noqa: F811
    """The farthest point ahead (arm lengths from the shoulder) the arm reaches without a
    lean, within 1/128 of the bracket 0.9 .. 1.8."""
    lo, hi = 0.9, 1.8
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        armature = open_rig(rig_file, kind)
        info = addon.blender.rig.build(armature, "right")
        ok = run(addon, armature, info, mid, False, False)[2].results[0].success
        lo, hi = (mid, hi) if ok else (lo, mid)
    return hi


def skin_vertices(armature, skip, leave_out=frozenset()):
    """World positions of every vertex of the meshes the armature deforms or carries, as
    Blender evaluates them now; ``leave_out``: bones whose skin is left out (a vertex whose
    heaviest group is one of them, a part parented to one)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    out = []
    for ob in bpy.context.scene.objects:
        if ob.type != "MESH" or ob.name in skip:
            continue
        deformed = any(m.type == "ARMATURE" and m.object == armature for m in ob.modifiers)
        if not deformed and ob.parent != armature:
            continue
        if not deformed and ob.parent_type == "BONE" and ob.parent_bone in leave_out:
            continue
        ev = ob.evaluated_get(depsgraph)
        co = np.empty(len(ev.data.vertices) * 3)
        ev.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        if deformed and leave_out and len(ev.data.vertices) == len(ob.data.vertices):
            names = {vg.index: vg.name for vg in ob.vertex_groups}
            keep = [not v.groups or names.get(max(v.groups, key=lambda g: g.weight).group)
                    not in leave_out for v in ob.data.vertices]
            co = co[np.array(keep, bool)]
        mw = np.array(ev.matrix_world)
        out.append(co @ mw[:3, :3].T + mw[:3, 3])
    return np.concatenate(out) if out else np.zeros((0, 3))


def box_signed_distance(points, box):
    """Signed distance of world ``points`` to the box object (a unit cube scaled): positive
    outside, exact outside and in the faces' directions inside."""
    m = np.array(box.matrix_world)
    axes = m[:3, :3]
    half = 0.5 * np.linalg.norm(axes, axis=0)
    local = (points - m[:3, 3]) @ (axes / np.linalg.norm(axes, axis=0))
    q = np.abs(local) - half
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    return outside + np.minimum(q.max(axis=1), 0.0)


def bone_heads(armature):
    mw = np.array(armature.matrix_world)
    return {pb.name: mw[:3, :3] @ np.array(pb.head) + mw[:3, 3] for pb in armature.pose.bones}


def feet_of(info, heads, share=0.15):
    """The bones whose heads (``heads``: name → world point) lie in the lowest ``share``
    of the figure's height."""
    heights = {n: float(p @ info.frame.up) for n, p in heads.items()}
    low, high = min(heights.values()), max(heights.values())
    feet = [n for n, h in heights.items() if h <= low + share * (high - low)]
    assert feet
    return feet


def walk(addon, armature, info, result, box, start, kind):
    """Every frame of ``result``'s bake and :data:`INSTANTS` instants between, as Blender
    evaluates them: the reaching arm held to the planner's clearance (``clearance.Arm``,
    which fails the test where it is not), the farthest the feet (:func:`feet_of` the
    bone heads ``start``) moved from there, and the least signed distance of the rest of
    the skin to ``box``. Returns (feet's farthest move, skin's least distance, the bone
    heads at the last instant, the feet's bones)."""
    feet = feet_of(info, start)
    a = info.bones.arms["right"]
    arm_bones = {a.upper_arm, a.forearm, a.hand} | {
        c.name for c in armature.pose.bones[a.forearm].children_recursive}
    arm = clearance.Arm(armature, info)
    tris = obstacle_triangles(addon, armature)
    worst_feet, worst_skin, now = 0.0, np.inf, start
    for f in range(result.frame_start, result.frame_end + 1):
        for k in range(INSTANTS if f < result.frame_end else 1):
            bpy.context.scene.frame_set(f, subframe=k / INSTANTS)
            now = bone_heads(armature)
            worst_feet = max(worst_feet, max(float(np.linalg.norm(now[n] - start[n]))
                                             for n in feet))
            arm.check(tris, f"{kind} frame {f} + {k}/{INSTANTS}")
            skin = skin_vertices(armature, {box.name}, arm_bones)
            if len(skin):                  # the metarig, a template, has none
                worst_skin = min(worst_skin, float(box_signed_distance(skin, box).min()))
    return worst_feet, worst_skin, now, feet


def bake(addon, rig_file, kind, ahead, lean):  # noqa: F811
    armature = open_rig(rig_file, kind)
    info = addon.blender.rig.build(armature, "right")
    return (armature, info) + run(addon, armature, info, ahead, lean, True)


@pytest.mark.parametrize("kind", KINDS)
def test_a_target_past_the_arm_is_reached_by_leaning_the_trunk(addon, rig_file, kind):  # noqa: F811
    ahead = reach_edge(addon, rig_file, kind) + BEYOND
    armature, info, target, table, outcome = bake(addon, rig_file, kind, ahead, lean=True)
    result = outcome.results[0]
    assert result.success, result.message
    assert result.stats['lean_deg'] > 0.0 and result.stats['lean_frames'] > 0, result.to_dict()
    assert "leaning the trunk" in result.message
    length = info.arm.arm_length
    scene_ = bpy.context.scene
    scene_.frame_set(result.frame_start)
    start = bone_heads(armature)
    worst_feet, worst_skin, now, feet = walk(addon, armature, info, result, table, start, kind)
    movers = sorted(((float(np.linalg.norm(now[n] - start[n])), n) for n in feet), reverse=True)
    assert worst_feet <= 5e-4 * length, (kind, worst_feet / length, movers[:5])
    assert worst_skin > 0.0, (kind, worst_skin / length)
    # on the target
    scene_.frame_set(result.frame_end)
    wrist = bone_heads(armature)[info.bones.arms["right"].hand]
    tolerance = outcome.request.settings.goal_tolerance * length
    assert np.linalg.norm(wrist - np.array(target.location)) <= tolerance + 1e-4 * length
    # the lean bone turned by the lean by the reach's first frame
    bone = armature.pose.bones[result.stats['lean_bone']]
    scene_.frame_set(result.frame_start)
    r0 = np.array(bone.matrix)[:3, :3]
    scene_.frame_set(result.frame_start + result.stats['lean_frames'])
    r1 = np.array(bone.matrix)[:3, :3]
    turn = np.degrees(np.arccos(np.clip((np.trace(r1 @ np.linalg.inv(r0)) - 1.0) / 2.0, -1, 1)))
    assert turn == pytest.approx(result.stats['lean_deg'], abs=1.0)
    stats = result.stats
    print(f"MARGIN {kind}: at the full lean {stats['lean_com_margin']:.4f}, least over the "
          f"bake {stats['com_margin_min']:.4f} (frame {stats['com_margin_min_frame']}), "
          f"standing {stats['com_margin_start']:.4f}")
    assert stats["lean_com_margin"] >= min(0.0, stats["com_margin_start"]) - 1e-4, stats
    # and over every frame of the bake, the arm's own reach included
    assert stats["com_margin_min"] >= min(0.0, stats["com_margin_start"]) - 1e-4, stats


def test_without_lean_the_same_target_is_refused_with_a_hint(addon, rig_file):  # noqa: F811
    ahead = reach_edge(addon, rig_file, "quaternius") + BEYOND
    _armature, _info, _target, _table, outcome = bake(addon, rig_file, "quaternius", ahead,
                                                      lean=False)
    result = outcome.results[0]
    assert not result.success and result.reason == "needs_lean", result.message
    assert "turn on Lean" in result.message


#: The issue's lean: a target this far ahead of the shoulder (arm lengths), :data:`BELOW`
#: under it.
FAR = 1.3
#: The rig whose :data:`FAR` lean moves its hips back the most plainly (0.15 arm lengths, a
#: lean of 36°), where the tests of hips keyed by the user and of a wall behind them are
#: run. Quaternius' moved them 0.14 back before a twist's trunk effort was weighed against
#: the lean's (``core.effort``); it now leans 18° with them where they stand.
HIPS_BACK_RIG = "knight"


@pytest.mark.parametrize("kind", KINDS + ("rigify",))
def test_a_target_far_ahead_is_reached_leaning_with_the_hips_back(addon, rig_file, kind,  # noqa: F811
                                                                  tmp_path):
    """Issue "Reach past the arm", *Lean*: a target :data:`FAR` arm lengths ahead is reached
    by leaning on every rig (the Alien and the Male Base Mesh, which can reach it upright
    with the chest turned 35° and 60° past Table 1's, lean instead: ``core.effort``), the
    hips moving back where the lean alone would tip the body; the wrist
    (the hand bone's head as Blender evaluates it) ends on the target; the feet stay
    (every bone whose head starts in the lowest 15 % of the figure moves less than 2 % of
    an arm length at every frame) and the centre of mass stays over them (the report's
    least margin, read on the evaluated bones, is not below 0 nor below the rig's own).
    Rigify's generated rig too: its ``chest`` control turns the spine about two joints
    and its arm in IK keeps the hand where it was as the trunk leans; a lean there ended
    0.18 arm lengths off (fuzz seed 40071: 1.44, reported reached).
    The bake is kept as ``far-<rig>.blend`` in the test's temporary folder (the README's
    picture is rendered from Quaternius')."""
    armature = open_rig(rig_file, kind)
    info = addon.blender.rig.build(armature, "right")
    bpy.context.scene.frame_set(1)
    start = bone_heads(armature)
    _target, _table, outcome = run(addon, armature, info, FAR, True, True)
    result = outcome.results[0]
    assert result.success, result.message
    length = info.arm.arm_length
    feet = feet_of(info, start)
    worst = 0.0
    for f in range(result.frame_start, result.frame_end + 1):
        bpy.context.scene.frame_set(f)
        now = bone_heads(armature)
        worst = max(worst, max(float(np.linalg.norm(now[n] - start[n])) for n in feet))
    wrist = now[info.bones.arms["right"].hand]        # on the last frame
    gap = float(np.linalg.norm(wrist - np.array(_target.location))) / length
    assert gap <= outcome.request.settings.goal_tolerance + 1e-4, f"{kind}: the wrist {gap:.4f} off"
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / f"far-{kind}.blend"), copy=True)
    print(f"FAR {kind}: lean {result.stats.get('lean_deg')}°, hips back "
          f"{result.stats.get('lean_hips_back')}, margin {result.stats['com_margin_min']:.4f}, "
          f"feet {worst / length:.6f}")
    assert worst / length < 0.02, f"{kind}: a foot moved {worst / length:.4f} arm lengths"
    assert result.stats["com_margin_min"] >= min(0.0, result.stats["com_margin_start"]) - 1e-4
    assert (result.stats.get("lean_deg") or 0.0) > 0.0, (kind, result.message)
    if kind == HIPS_BACK_RIG:           # what the two tests below hold back
        assert result.stats["lean_hips_back"] > 0.1, result.stats


def test_hips_with_keys_of_their_own_stay_where_the_user_keyed_them(addon, rig_file):  # noqa: F811
    """Nothing lost: where the hips bone's location is keyed by the user, the lean does not
    move the hips back (it would overwrite those keys). The :data:`HIPS_BACK_RIG`'s
    1.3-arm-length lean, which moves its hips back when they are free, is planned without
    them (a smaller lean with the chest turned farther) and the user's keys are as they
    were."""
    armature = open_rig(rig_file, HIPS_BACK_RIG)
    info = addon.blender.rig.build(armature, "right")
    legs = addon.blender.balance.find_legs(armature, info.bones, info.frame)
    lean_mod = importlib.import_module(addon.__name__ + ".blender.lean")
    hips_mod = importlib.import_module(addon.__name__ + ".blender.hips")
    hips = hips_mod.hips_bone(armature, legs, lean_mod.lean_bone(armature, info.bones, legs))
    pb = armature.pose.bones[hips]
    pb.keyframe_insert("location", frame=1)
    pb.keyframe_insert("location", frame=40)         # held: the body does not move

    def keys():
        """The hips' location keys, read on Blender's own F-curves."""
        ad = armature.animation_data
        if hasattr(ad.action, "layers") and ad.action.layers:     # a layered action (4.4+)
            bag = ad.action.layers[0].strips[0].channelbag(ad.action_slot)
            curves = bag.fcurves
        else:
            curves = ad.action.fcurves
        return sorted((fc.data_path, fc.array_index, [tuple(k.co) for k in fc.keyframe_points])
                      for fc in curves if fc.data_path == f'pose.bones["{hips}"].location')

    before = keys()
    assert len(before) == 3
    _target, _table, outcome = run(addon, armature, info, FAR, True, True)
    result = outcome.results[0]
    assert keys() == before
    if result.success:
        assert not result.stats.get("lean_hips_back"), result.stats
        assert result.stats["com_margin_min"] >= 0.0, result.stats
    else:
        assert f"bone '{hips}' has keys of its own" in result.message, result.message


def test_hips_that_would_move_back_into_a_wall_keep_the_body_clear(addon, rig_file):  # noqa: F811
    """The whole body is checked: a wall stands just behind the :data:`HIPS_BACK_RIG`'s hips
    (its face 0.02 arm lengths behind the skin, from 0.3 arm lengths under the hip joints
    to 0.3 over them), and the 1.3-arm-length lean, which moves its hips back where
    they are free, must keep every vertex of the skin (less the reaching arm's) out of the
    wall at every frame and three instants between, as Blender evaluates them: reached
    another way, or refused with the lower body named."""
    armature = open_rig(rig_file, HIPS_BACK_RIG)
    info = addon.blender.rig.build(armature, "right")
    legs = addon.blender.balance.find_legs(armature, info.bones, info.frame)
    shoulder, forward, outward, up, length = everyday.body_axes(info)
    hips = np.array([addon.blender.balance.point_of(armature, leg.hip) for leg in legs])
    hip_up = float(((hips - shoulder) @ up).mean()) / length
    rel = (skin_vertices(armature, set()) - shoulder) / length
    band = (rel @ up >= hip_up - 0.3) & (rel @ up <= hip_up + 0.3)
    back = float((rel[band] @ forward).min())
    wall = everyday.box(info, "Wall", (back - 0.5, -0.8, hip_up - 0.3),
                        (back - 0.02, 0.8, hip_up + 0.3))
    _target, _table, outcome = run(addon, armature, info, FAR, True, True)
    result = outcome.results[0]
    print(f"WALL: {result.success} {result.stats.get('lean_deg')} "
          f"{result.stats.get('lean_hips_back')} {result.message}")
    if not result.success:
        assert "lower body would touch 'Wall'" in result.message, result.message
        return
    a = info.bones.arms["right"]
    arm_bones = {a.upper_arm, a.forearm, a.hand} | {
        c.name for c in armature.pose.bones[a.forearm].children_recursive}
    worst = np.inf
    for f in range(result.frame_start, result.frame_end + 1):
        for k in range(INSTANTS if f < result.frame_end else 1):
            bpy.context.scene.frame_set(f, subframe=k / INSTANTS)
            skin = skin_vertices(armature, {wall.name}, arm_bones)
            worst = min(worst, float(box_signed_distance(skin, wall).min()))
    print(f"WALL worst {worst / length:.4f}")
    assert worst > 0.0, worst / length


#: The issue's table: its top this far under the shoulder, its near edge this far ahead
#: (or 0.05 beyond the body's skin at the table's height, the arms' left out, where a
#: belly stands past it),
#: the target this far ahead, :data:`OVER` above the top (arm lengths). "Just above" is
#: 0.15, or the forearm's radius and 0.03 where that is more: the wrist's capsule end is
#: the forearm's radius round it (0.09 to 0.11 arm lengths on most of these rigs, the
#: Alien's 0.147) and keeps the clearance (0.02) besides, so no wrist comes nearer a table
#: top than that whatever the forearm's slope.
TABLE_TOP, TABLE_EDGE, TABLE_TARGET, OVER = -0.85, 0.35, 1.25, 0.15

#: Rigs the issue's table does not yet let reach, with the cause measured.
TABLE_XFAIL: dict = {}
#: Rigs the issue's table does not apply to: the robot's forearm, 2.4 times its upper arm,
#: hangs through the table's top as it stands (its start is inside the table).
TABLE_NOT_APPLICABLE = ("robot",)


def attach_loose_parts(armature):
    """Parent every other armature of the file that has no parent (the Goblin's face rig,
    FBX's ``FaceArmature``, which deforms ``GoblinFace``) to ``armature``'s head bone,
    keeping where it is: what a user does so that the face leans with the head (Reach,
    as documented, takes a mesh it does not find carried by the character for an
    obstacle)."""
    bones = armature.data.bones
    head = next((b.name for b in bones if "head" in b.name.lower()), None)
    for ob in bpy.context.scene.objects:
        if ob.type == "ARMATURE" and ob != armature and ob.parent is None and head:
            world = ob.matrix_world.copy()
            ob.parent, ob.parent_type, ob.parent_bone = armature, "BONE", head
            bpy.context.view_layer.update()
            ob.matrix_world = world
    bpy.context.view_layer.update()


@pytest.mark.parametrize("kind", [
    pytest.param(k, marks=[pytest.mark.xfail(strict=True, reason=TABLE_XFAIL[k])]
                 if k in TABLE_XFAIL else [])
    for k in KINDS if k not in TABLE_NOT_APPLICABLE])
def test_a_target_over_a_table_is_reached_and_no_skin_enters_the_table(addon, rig_file, kind):  # noqa: F811
    """Issue "Reach past the arm", *Over a table*: a target :data:`OVER` arm lengths (or
    the forearm's radius and 0.03) above a table, :data:`TABLE_TARGET` ahead of the shoulder (the table's top
    :data:`TABLE_TOP` under the shoulder, its near edge :data:`TABLE_EDGE` ahead, 1.2 wide,
    0.4 deep under the top) is reached, and no vertex of the character's skin (less the
    reaching arm's, whose capsules ``clearance.Arm`` checks with the planner's clearance)
    is inside the table at any frame or three instants between, as Blender evaluates
    them."""
    armature = open_rig(rig_file, kind)
    attach_loose_parts(armature)
    info = addon.blender.rig.build(armature, "right")
    shoulder, forward, _outward, up, length = everyday.body_axes(info)
    over = max(OVER, info.arm.forearm_radius / length + 0.03)
    target = everyday.at(info, TABLE_TARGET, 0.0, TABLE_TOP + over)
    ob = bpy.data.objects.new("Over Table", None)
    ob.location = tuple(target)
    bpy.context.scene.collection.objects.link(ob)
    arms = {b.name for a in info.bones.arms.values()
            for b in [armature.data.bones[a.upper_arm]] + list(
                armature.data.bones[a.upper_arm].children_recursive)}
    rel = (skin_vertices(armature, set(), arms) - shoulder) / length
    band = (rel @ up >= TABLE_TOP - 0.45) & (rel @ up <= TABLE_TOP + 0.05)
    edge = max(TABLE_EDGE, float((rel[band] @ forward).max()) + 0.05 if band.any() else 0.0)
    table = everyday.box(info, "Table", (edge, -0.6, TABLE_TOP - 0.4),
                         (edge + 1.4, 0.6, TABLE_TOP))
    settings = addon.core.Settings().replace(lean=True)
    request = addon.blender.pipeline.Request(armature.name, [ob.name], task="reach",
                                             side="right", frame_start=1, draw=False,
                                             settings=settings)
    outcome = addon.blender.pipeline.run(bpy.context, request, bake=True)
    result = outcome.results[0]
    print(f"TABLE {kind}: edge {edge:.3f}, {result.success} lean {result.stats.get('lean_deg')} hips "
          f"{result.stats.get('lean_hips_back')} {result.message}")
    assert result.success, result.message
    a = info.bones.arms["right"]
    arm_bones = {a.upper_arm, a.forearm, a.hand} | {
        c.name for c in armature.pose.bones[a.forearm].children_recursive}
    arm = clearance.Arm(armature, info)
    tris = obstacle_triangles(addon, armature)
    worst = np.inf
    for f in range(result.frame_start, result.frame_end + 1):
        for k in range(INSTANTS if f < result.frame_end else 1):
            bpy.context.scene.frame_set(f, subframe=k / INSTANTS)
            arm.check(tris, f"{kind} frame {f} + {k}/{INSTANTS}")
            skin = skin_vertices(armature, {table.name}, arm_bones)
            if len(skin):
                worst = min(worst, float(box_signed_distance(skin, table).min()))
    print(f"TABLE {kind}: skin at least {worst / length:.4f} arm lengths from the table")
    assert worst > 0.0, (kind, worst / length)
    stats = result.stats
    if "lean_deg" in stats or stats["com_margin_start"] >= 0.0:
        assert stats["com_margin_min"] >= min(0.0, stats["com_margin_start"]) - 1e-4, stats
    else:
        # the arm alone (the Alien reaches this one unleaned) moves the centre of mass by
        # its own weight: the Alien, which Winter's shares put 0.0116 arm lengths past its
        # toes along gravity as it stands, comes 0.0015 farther past them; the balance is
        # the body's moves', which an arm's reach does not make
        assert stats["com_margin_min"] >= stats["com_margin_start"] - 0.005, stats



def test_a_bake_again_over_a_lean_leans_the_same_way(addon, rig_file):  # noqa: F811
    """The lean's keys (the lean bone, the hips, the legs) are Reach's own
    (``own_keys``): a second bake over the first, the target where it was, leans again and
    keys the same values; a third, the target now within the arm's reach, into a new
    action, clears the earlier lean's keys from the copy but the one on its first frame
    (nothing holds the trunk leaned) and leaves the user's action as it was; keys a user
    set stay refused (``test_hips_with_keys_of_their_own_stay_where_the_user_keyed_them``)."""
    ahead = reach_edge(addon, rig_file, "quaternius") + BEYOND
    armature = open_rig(rig_file, "quaternius")
    info = addon.blender.rig.build(armature, "right")
    baked, lean_bone = [], None

    def curves():
        bag = addon.blender.fcurves.Channels(armature, armature.animation_data.action).bag
        return {(fc.data_path, fc.array_index): [tuple(k.co) for k in fc.keyframe_points]
                for fc in bag.fcurves}

    for _bake in range(2):
        target, table, outcome = run(addon, armature, info, ahead, True, True)
        result = outcome.results[0]
        assert result.success and result.stats["lean_deg"] > 0.0, result.message
        lean_bone = result.stats["lean_bone"]
        baked.append(curves())
        bpy.data.objects.remove(target)
        bpy.data.objects.remove(table)
    # the command line's report carries the body's figures, as the fuzz campaign reads them
    cli = importlib.import_module(addon.__name__ + ".cli")
    report = cli.report_dict(outcome, addon.core.Settings().replace(lean=True), "x", None)
    task = report["tasks"][0]
    assert task["lean_deg"] == result.stats["lean_deg"] and "com_margin_min" in task, task
    assert campaign.body_outcomes(report) == ["lean"]
    assert baked[0].keys() == baked[1].keys()
    for key, points in baked[0].items():
        np.testing.assert_allclose(points, baked[1][key], atol=1e-5, err_msg=str(key))
    # with New action the earlier lean's keys go from the copy; the user's action keeps them
    # (the chest turning alone: the spine's share of its turn would key the lean bone anew)
    original = armature.animation_data.action
    target, table, outcome = run(addon, armature, info, 0.6, True, True, new_action=True,
                                 spine_share=0.0)
    result = outcome.results[0]
    assert result.success and not result.stats.get("lean_deg"), result.message
    assert armature.animation_data.action != original
    # but its key on the first frame (the lean starts there: no ready reach), the trunk
    # upright as the bake found it, which it holds
    left = {k: v for k, v in curves().items() if k[0].startswith(f'pose.bones["{lean_bone}"]')}
    assert left, curves().keys()
    for key, points in left.items():
        assert points == [baked[1][key][0]] and points[0][0] == result.frame_start, (key, points)
    armature.animation_data.action = original
    assert curves() == baked[1]


def test_a_bake_part_way_through_a_lean_keeps_the_frames_before_it(addon, rig_file):  # noqa: F811
    """A lean baked from frame 1, then a reach to a target within the arm baked from a
    frame half way through the lean (the chest turning alone: the lean bone is not keyed
    again): the earlier lean's frames before it stay as they were (the earlier reach's arm
    keys, which stay too, were planned on them), and from there on the trunk holds as it
    stood on that frame, which the new reach was planned from: its wrist ends on target."""
    ahead = reach_edge(addon, rig_file, "quaternius") + BEYOND
    armature = open_rig(rig_file, "quaternius")
    info = addon.blender.rig.build(armature, "right")
    _target, table, outcome = run(addon, armature, info, ahead, True, True)
    first = outcome.results[0]
    assert first.success and first.stats["lean_deg"] > 0.0, first.message
    bone = armature.pose.bones[first.stats["lean_bone"]]
    middle = 1 + first.stats["lean_ready_frames"] + first.stats["lean_frames"] // 2
    scene_ = bpy.context.scene

    def basis(f):
        scene_.frame_set(f)
        return np.array(bone.matrix_basis)

    before = [basis(f) for f in range(1, middle + 1)]
    assert not np.allclose(before[0], before[-1], atol=1e-3)    # leaning by then
    bpy.data.objects.remove(table)
    near = everyday.at(info, 0.6, 0.0, -0.3)
    ob = bpy.data.objects.new("Near Target", None)
    ob.location = tuple(near)
    scene_.collection.objects.link(ob)
    pipeline = addon.blender.pipeline
    request = pipeline.Request(armature.name, [ob.name], task="reach", side="right",
                               frame_start=middle, draw=False, settings=addon.core.Settings(
                                   ).replace(lean=True, spine_share=0.0))
    second = pipeline.run(bpy.context, request, bake=True).results[0]
    assert second.success and "lean_deg" not in second.stats, second.message
    for f, was in zip(range(1, middle + 1), before):
        np.testing.assert_allclose(basis(f), was, atol=1e-5, err_msg=f"frame {f}")
    np.testing.assert_allclose(basis(second.frame_end), before[-1], atol=1e-5)
    hand = armature.pose.bones[info.bones.arms["right"].hand]
    wrist = np.array(armature.matrix_world @ hand.head)
    tolerance = request.settings.goal_tolerance * info.arm.arm_length
    assert np.linalg.norm(wrist - near) <= tolerance + 1e-4 * info.arm.arm_length


def test_among_moving_obstacles_the_refusal_says_the_body_leans_only_among_still_ones(
        addon, rig_file):  # noqa: F811
    """Lean on, a single reach past the arm, and a box the scene animates: the body does not
    lean (its checks hold the scene still), and the refusal says so, naming the box, rather
    than asking to turn Lean on."""
    armature = open_rig(rig_file, "quaternius")
    info = addon.blender.rig.build(armature, "right")
    ahead = reach_edge(addon, rig_file, "quaternius") + BEYOND
    armature = open_rig(rig_file, "quaternius")
    box = everyday.box(info, "Swinging Box", (-0.3, -1.6, -0.3), (0.0, -1.3, 0.0))
    box.keyframe_insert("location", frame=1)
    box.location.z += 0.2 * info.arm.arm_length
    box.keyframe_insert("location", frame=30)
    _target, _table, outcome = run(addon, armature, info, ahead, True, True)
    result = outcome.results[0]
    assert not result.success and result.reason == "needs_lean", result.message
    assert "leans only among obstacles that hold still, and 'Swinging Box'" in result.message
