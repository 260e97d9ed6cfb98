"""The refusal cross-check (``verification.refusal``) on small scenes baked by the command
line: it confirms true refusals of each kind it handles and catches false ones.

Each scene is built round a synthetic humanoid in its own body frame (``everyday.at``:
forward, outward, up from the reaching shoulder, in arm lengths), saved, and baked by
``python -m reach_addon bake ... --report`` in a subprocess, as a user bakes it; the
cross-check then reads the report and the input file. Nothing here mocks Blender.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import bpy
import everyday
import numpy as np
import rigs
import synthetic

from reach_addon.blender import rig as rig_mod
from reach_addon.core.sampling import joints_of_one
from verification import geometry, refusal

ROOT = Path(__file__).resolve().parents[2]


def bake(tmp_path, targets, *flags, name="scene"):
    """Save the open file as ``name``.blend, bake it for ``targets`` with the right arm
    and ``flags`` by the command line, open the input again; returns (exit status, report)."""
    path = tmp_path / f"{name}.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    argv = ["bake", path, "--armature", "Rig", "--arm", "right", "--output",
            tmp_path / f"{name}-out.blend", "--report", tmp_path / f"{name}.json", *flags]
    for t in targets:
        argv += ["--target", t]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-m", "reach_addon", *map(str, argv)],
                          capture_output=True, text=True, env=env, cwd=ROOT, timeout=600)
    assert done.returncode in (0, 1), done.stderr
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    return done.returncode, json.loads((tmp_path / f"{name}.json").read_text())


def humanoid(**kw):
    bpy.ops.wm.read_homefile(use_empty=True)
    arm = synthetic.humanoid(synthetic.MIXAMO, name="Rig", **kw)
    return arm, rig_mod.build(arm, "right")


def reasons(report):
    return {t["target"]: t["reason"] for t in report["tasks"]}


def test_targets_out_of_reach_are_confirmed_without_a_search(tmp_path):
    """Beyond the arm (two arm lengths ahead) and far overhead: no legal pose at the
    target at any chest rotation, so the refusal is confirmed by the IK alone."""
    _arm, info = humanoid()
    rigs.add_target("Ahead", everyday.at(info, 2.0, 0.1, 0.0))
    rigs.add_target("Overhead", everyday.at(info, 0.2, 0.1, 1.6))
    rc, report = bake(tmp_path, ["Ahead", "Overhead"])
    assert rc == 1
    got = reasons(report)
    assert got["Ahead"] in ("needs_lean", "needs_step") and got["Overhead"] == "out_of_reach", got
    verdicts = refusal.check_report(bpy.context, report)
    assert [(v.target, v.status, v.method, v.goal_states) for v in verdicts] == [
        ("Ahead", "confirmed", "ik", 0), ("Overhead", "confirmed", "ik", 0)]
    assert all(v.states_checked == 0 for v in verdicts)     # no pose was even legal


def test_a_target_behind_a_closed_wall_is_confirmed(tmp_path):
    """A closed slab six arm lengths wide and tall stands between the body and the target:
    every pose at the target passes through it, and the cross-check agrees with whatever
    Reach says (no fit, or no path)."""
    _arm, info = humanoid()
    everyday.box(info, "Wall", (0.42, -3.0, -3.0), (0.5, 3.0, 3.0))
    rigs.add_target("Behind", everyday.at(info, 0.7, 0.1, 0.0))
    rc, report = bake(tmp_path, ["Behind"])
    assert rc == 1 and reasons(report)["Behind"] in ("arm_does_not_fit", "no_path"), report
    (v,) = refusal.check_report(bpy.context, report)
    assert (v.status, v.goal_states) == ("confirmed", 0), v.detail


def ring(info, name, centre_share=0.5, hole=0.08, bar=0.03):
    """Four closed bars round the upper arm at ``centre_share`` of its length, in the plane
    across it: a square hole of half-size ``hole`` (metres) the arm passes through."""
    sh, el = info.joints_world["shoulder"], info.joints_world["elbow"]
    u = (el - sh) / np.linalg.norm(el - sh)
    e1 = np.cross(u, info.frame.up)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    centre = sh + centre_share * (el - sh)
    span = 2 * (hole + bar)
    bars = []
    for k, (a, b) in enumerate(((e1, e2), (e2, e1))):
        for sign in (1, -1):
            rot = np.column_stack([a, b, u])
            bars.append(rigs.add_box(f"{name}{2 * k + (sign > 0)}",
                                     centre + sign * (hole + bar / 2) * a, (bar, span, bar), rot))
    return bars


def test_an_arm_threaded_through_a_ring_has_no_path_and_the_search_confirms_it(tmp_path):
    """A closed ring round the upper arm, the chest kept still: the elbow is always farther
    from the shoulder than any point of the ring's hole, so the arm can never leave it;
    the target ahead has clear poses (a goal region) but no path reaches them. Reach says
    no_path; OMPL finds none either (confirmed by the search, not by the IK)."""
    _arm, info = humanoid()
    ring(info, "Ring")
    rigs.add_target("Ahead", everyday.at(info, 0.6, 0.05, -0.1))
    rc, report = bake(tmp_path, ["Ahead"], "--no-chest-rotation", "--sampling-budget", "5000")
    assert rc == 1 and reasons(report)["Ahead"] == "no_path", report["tasks"][0]["message"]
    (v,) = refusal.check_report(bpy.context, report, budget_s=3.0)
    assert (v.status, v.method) == ("confirmed", "ompl"), v.detail
    assert v.goal_states > 0 and v.states_checked > 1000


def test_a_start_with_the_hand_inside_a_box_is_confirmed_by_the_skin(tmp_path):
    """The hand (and the wrist) inside a closed box: Reach refuses the start, and the
    evaluated skin of the hand meets the box."""
    arm, info = humanoid()
    wrist = info.joints_world["wrist"]
    tip = np.array(arm.matrix_world @ arm.pose.bones["mixamorig:RightHand"].tail)
    rigs.add_box("Crate", 0.5 * (wrist + tip), (0.16, 0.16, 0.16))
    rigs.add_target("Ahead", everyday.at(info, 0.6, 0.1, 0.0))
    rc, report = bake(tmp_path, ["Ahead"])
    assert rc == 1 and reasons(report)["Ahead"] == "start_in_collision", report
    (v,) = refusal.check_report(bpy.context, report)
    assert (v.status, v.method, v.clearance) == ("confirmed", "skin", 0.0), v.detail
    assert "Crate" in v.detail


def test_every_target_of_a_sequence_refused_at_its_start_is_checked(tmp_path):
    """A sequence whose start has the hand in a box: Reach refuses every target with the
    start's claim, the arm never moving. The later targets start where the first did, so
    each is checked as the first is (the skin), not left unchecked as a later target whose
    start only the planner knows."""
    arm, info = humanoid()
    wrist = info.joints_world["wrist"]
    tip = np.array(arm.matrix_world @ arm.pose.bones["mixamorig:RightHand"].tail)
    rigs.add_box("Crate", 0.5 * (wrist + tip), (0.16, 0.16, 0.16))
    rigs.add_target("Ahead", everyday.at(info, 0.6, 0.1, 0.0))
    rigs.add_target("Up", everyday.at(info, 0.5, 0.1, 0.3))
    rc, report = bake(tmp_path, ["Ahead", "Up"], "--task", "sequence")
    assert rc == 1 and reasons(report) == {"Ahead": "start_in_collision",
                                           "Up": "start_in_collision"}, report
    verdicts = refusal.check_report(bpy.context, report, "sequence")
    assert [(v.target, v.status, v.method) for v in verdicts] == [
        ("Ahead", "confirmed", "skin"), ("Up", "confirmed", "skin")], [v.detail for v in verdicts]


def test_a_starved_planner_s_no_path_is_a_false_refusal(tmp_path):
    """The plate scene is solvable (Reach reaches it with its default settings); with ten
    search positions and no fallback Reach says no_path, and the cross-check finds a
    clear path: a false refusal, with the path's length and a goal state on the target."""
    arm, info = humanoid()
    rigs.plate_scene(info, arm)
    rc, report = bake(tmp_path, ["Cup"], name="solved")
    assert rc == 0, report["tasks"][0]["message"]
    rc, report = bake(tmp_path, ["Cup"], "--node-budget", "10", "--no-sampling-fallback",
                      "--no-guided-fallback", name="starved")
    assert rc == 1 and reasons(report)["Cup"] == "no_path", report
    (v,) = refusal.check_report(bpy.context, report, budget_s=10.0)
    assert (v.status, v.method) == ("false_refusal", "ompl"), v.detail
    assert v.path_length > 0.1 and len(v.goal_state) == 7
    target = info.arm.to_canonical_points(np.array(bpy.data.objects["Cup"].matrix_world.translation))
    wrist = joints_of_one(info.arm, v.goal_state)[3]
    assert np.linalg.norm(np.array(wrist) - target) <= 0.006 * info.arm.arm_length


def test_a_chase_s_no_path_is_checked_against_its_frames(tmp_path):
    """A target gliding from low ahead of the body to up beside it over 48 frames, nothing
    in the way. Starved (one search node a frame) and without planning ahead the chase
    misses it, and the cross-check finds a way to where it ends that a chase at the same
    limits follows in fewer frames than it had: a false refusal. Planning ahead (the
    default), the starved chase catches it. The same glide in 12 frames, chased at 0.5 arm
    lengths a second (one search step a frame), is missed whatever the chase plans, and
    the way found does not fit the frames: inconclusive, not false."""
    arm, info = humanoid()
    target = rigs.add_target("Glider", everyday.at(info, 0.5, 0.1, -0.5))
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 48
    target.keyframe_insert("location", frame=1)
    target.location = tuple(everyday.at(info, 0.3, 0.6, 0.2))
    target.keyframe_insert("location", frame=48)
    rc, report = bake(tmp_path, ["Glider"], "--task", "chase", "--chase-nodes-per-frame", "1",
                      name="ahead")
    assert report["tasks"][0]["success"], report["tasks"][0]["message"]
    assert "planning ahead" in report["tasks"][0]["message"]
    rc, report = bake(tmp_path, ["Glider"], "--task", "chase", "--chase-nodes-per-frame", "1",
                      "--no-chase-plan-ahead", name="starved")
    assert reasons(report) == {"Glider": "no_path"}, report["tasks"][0]["message"]
    (v,) = refusal.check_report(bpy.context, report, "chase")
    assert (v.status, v.method) == ("false_refusal", "ompl"), v.detail
    need, had = map(int, re.search(r"follows it in (\d+) frames, (\d+) were had",
                                   v.detail).groups())
    assert had == 47 and need <= had, v.detail
    # the same glide in 12 frames, chased at one search step a frame
    target = bpy.data.objects["Glider"]
    target.animation_data_clear()
    target.location = tuple(everyday.at(info, 0.5, 0.1, -0.5))
    target.keyframe_insert("location", frame=1)
    target.location = tuple(everyday.at(info, 0.3, 0.6, 0.2))
    target.keyframe_insert("location", frame=12)
    rc, report = bake(tmp_path, ["Glider"], "--task", "chase", "--chase-max-speed", "0.5",
                      name="slow")
    assert reasons(report) == {"Glider": "no_path"}, report["tasks"][0]["message"]
    (v,) = refusal.check_report(bpy.context, report, "chase")
    assert v.status in ("inconclusive", "confirmed"), v.detail
    if v.status == "inconclusive":
        need, had = map(int, re.search(r"follows it in (\d+) frames, (\d+) were had",
                                       v.detail).groups())
        assert need > had == 11, v.detail


def test_a_skin_clear_of_a_sleeve_its_capsule_touches_is_not_refused(tmp_path):
    """A square sleeve of four closed bars round the hand, 15 % wider than the hand's skin
    box: the skin is clear (its faces 6 mm from the walls), but the hand's round capsule
    (the box's corners) stands into all four walls, and no step out of the sleeve takes it
    farther from them. Reach used to refuse that start (start_in_collision), which the skin
    check calls a false refusal: it says the skin is clear. Now the claim is what holds:
    the arm cannot move from its start (``start_held``), the capsule being Reach's model
    of the arm (``results.start_as_it_shows``, the skin measured on the start frame)."""
    arm, info = sleeve()
    rigs.add_target("Ahead", everyday.at(info, 0.6, 0.1, 0.0))
    # the claim Reach used to make, checked by the skin: false
    v = refusal.check_start(bpy.context, arm, info, {"Ahead"}, target="Ahead")
    assert (v.status, v.method) == ("false_refusal", "skin"), v.detail
    assert 0.0 < v.clearance < 0.03
    rc, report = bake(tmp_path, ["Ahead"])
    assert reasons(report)["Ahead"] == "start_held", report["tasks"][0]["message"]
    assert "Sleeve" in report["tasks"][0]["message"]
    # the claim Reach makes now, that the arm cannot move: OMPL searches from the start
    # with the arm's model thinned by its depth there (never deeper in) and finds no way
    (v,) = refusal.check_report(bpy.context, report)
    assert (v.status, v.method) == ("confirmed", "ompl"), v.detail
    assert "never deeper in" in v.detail


def test_a_skin_clear_of_a_sleeve_its_capsule_is_deep_in_is_held_not_in_collision(tmp_path):
    """The sleeve of the test above with a start contact tolerance below the capsule's
    depth in its walls (fuzz seed 5196: CesiumMan's clavicle capsule 0.10 arm lengths into
    a box its skin stands 0.088 clear of): Reach refuses to plan from so deep a start, and
    says it is its model that is in, not the skin (``start_held``), not that the start
    touches (``start_in_collision``, which the skin check calls false)."""
    arm, info = sleeve()
    rigs.add_target("Ahead", everyday.at(info, 0.6, 0.1, 0.0))
    rc, report = bake(tmp_path, ["Ahead"], "--start-contact-depth", "0.005")
    task = report["tasks"][0]
    assert (rc, task["reason"]) == (1, "start_held"), task["message"]
    assert "Sleeve" in task["message"] and "raise the start contact tolerance" in task["message"]
    (v,) = refusal.check_report(bpy.context, report)
    assert (v.status, v.method) == ("confirmed", "model"), v.detail
    assert "deep" in v.detail


def test_a_bone_through_a_plane_is_refused_as_deep_and_the_geometry_confirms_it(tmp_path):
    """A rig without a skin (a bare armature, as a Rigify metarig is) with a small open
    plane across the middle of its forearm bone: the forearm's capsule reads only its
    radius deep however the bone runs through, so no depth says which way is out (fuzz
    seeds 5103, 5117: a search never deeper than that passed straight through). Reach
    refuses the start as bone-deep (``start_held``, its model in, the skin clear), and
    the cross-check confirms the claim by its own segment-to-triangle distance; moved a
    forearm's radius and a half off the bone (its nearest edge), the same plane is no
    refusal at all."""
    def plane(offset):
        humanoid(skin=False)
        arm = bpy.data.objects["Rig"]
        a, b, side, third = bone_axes(arm, "mixamorig:RightForeArm")
        h = 0.06
        centre = 0.5 * (a + b) + (offset + (h if offset else 0.0)) * side   # its edge offset
        corners = [centre + h * (i * side + j * third) for i, j in ((-1, -1), (1, -1), (1, 1),
                                                                   (-1, 1))]
        mesh = bpy.data.meshes.new("Pane")
        mesh.from_pydata([c.tolist() for c in corners], [], [(0, 1, 2, 3)])
        bpy.context.scene.collection.objects.link(bpy.data.objects.new("Pane", mesh))
        return rig_mod.build(arm, "right")

    info = plane(0.0)
    rigs.add_target("Ahead", everyday.at(info, 0.6, 0.1, 0.0))
    rc, report = bake(tmp_path, ["Ahead"])
    task = report["tasks"][0]
    assert (rc, task["reason"]) == (1, "start_held"), task["message"]
    assert "bone-deep in 'Pane' (at the forearm)" in task["message"], task["message"]
    (v,) = refusal.check_report(bpy.context, report)
    assert (v.status, v.method) == ("confirmed", "model"), v.detail
    assert "forearm bone meets 'Pane'" in v.detail
    info = plane(1.5 * info.arm.forearm_radius * info.arm.metres_per_unit)
    rigs.add_target("Ahead", everyday.at(info, 0.6, 0.1, 0.0))
    rc, report = bake(tmp_path, ["Ahead"], name="clear")
    assert report["tasks"][0]["success"], report["tasks"][0]["message"]


def bone_axes(armature, name):
    """A pose bone's world head and tail, and two unit directions across it (each
    perpendicular to it and to the other)."""
    from mathutils import Vector

    bone, mw = armature.pose.bones[name], armature.matrix_world
    head, tail = np.array(mw @ bone.head), np.array(mw @ bone.tail)
    axis = (tail - head) / np.linalg.norm(tail - head)
    side = np.array(Vector(axis.tolist()).orthogonal().normalized())
    return head, tail, side, np.cross(axis, side)


def sleeve():
    """The humanoid with a square sleeve of four closed bars round its right hand, 15 %
    wider than the hand's skin box: the skin 6 mm from the walls, the hand's round capsule
    (the box's corners) into all four."""
    arm, info = humanoid(skin_radius=0.04)
    wrist, tip, side, third = bone_axes(arm, "mixamorig:RightHand")
    axis = (tip - wrist) / np.linalg.norm(tip - wrist)
    half, bar, long = 1.15 * 0.04, 0.02, np.linalg.norm(tip - wrist) + 0.06
    centre = wrist + axis * (0.01 + long / 2)
    for k, (a, b) in enumerate(((side, third), (third, side))):
        for sign in (1, -1):
            rigs.add_box(f"Sleeve{2 * k + (sign > 0)}", centre + sign * (half + bar / 2) * a,
                         (bar, 2 * (half + bar), long), np.column_stack([a, b, axis]))
    return arm, info


def test_the_geometry_finds_touching_crossing_and_inside():
    """The numpy geometry on hand-made cases: crossing and touching triangles, parallel
    ones apart, a point inside a closed box and outside it, a box's closedness."""
    t = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=float)
    up = np.array([[0.2, 0.2, -0.5], [0.2, 0.2, 0.5], [0.2, 0.6, 0.5]])
    apart = t + [0, 0, 0.01]
    touching = np.array([[0.3, 0.3, 0.0], [0.3, 0.3, 1.0], [0.3, 0.5, 1.0]])
    assert geometry.triangles_intersect(np.array([t, t, t]), np.array([up, apart, touching])).tolist() \
        == [True, False, True]
    corners = np.array([(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = np.array([(q[0], q[i], q[i + 1]) for q in quads for i in (1, 2)])
    assert geometry.closed(tris) and not geometry.closed(tris[:-1])
    inside = geometry.points_inside([[0.5, 0.5, 0.5], [0.5, 0.5, 1.5], [0.0, 0.5, 0.5]],
                                    corners[tris])
    assert inside[:2].tolist() == [True, False]
    d = geometry.point_triangle_distance(np.array([[0.2, 0.2, 2.0], [2.0, 0.0, 0.0]]),
                                         *np.repeat(t[None], 2, 0).transpose(1, 0, 2))
    assert np.allclose(d, [2.0, 1.0])


def test_a_target_inside_the_body_is_confirmed_by_no_pose_at_it(tmp_path):
    """A target in the chest, inside no obstacle mesh: Reach refuses it as inside the
    character's own body, which ray parity cannot confirm (the body is not an obstacle
    mesh); the cross-check confirms the claim's substance instead, that no valid state
    puts the wrist within the goal tolerance of it (``refusal.check_no_pose_at``)."""
    _arm, info = humanoid()
    rigs.add_target("Chest", everyday.at(info, 0.05, -0.33, -0.25))
    rc, report = bake(tmp_path, ["Chest"])
    assert rc == 1 and reasons(report)["Chest"] == "target_in_obstacle", report
    (v,) = refusal.check_report(bpy.context, report)
    assert (v.status, v.method, v.goal_states) == ("confirmed", "ik", 0), v.detail
    assert "inside no closed obstacle" in v.detail


def test_a_target_that_moved_is_confirmed_and_one_forged_still_is_a_false_refusal(tmp_path):
    """``target_moved`` is a claim about the target object: its keys carry it 0.3 arm
    lengths up by the frame the wrist arrives, and the check, reading the object as
    Blender evaluates it on the start and arrival frames, confirms it. The same report
    with the target's keys removed (it stands still) is a false refusal."""
    arm, info = humanoid()
    cup = rigs.add_target("Cup", everyday.at(info, 0.6, 0.1, -0.1))
    start = np.array(cup.location)
    up = np.asarray(info.frame.up, dtype=float)
    for frame, lift in ((1, 0.0), (2, 0.3)):
        cup.location = tuple(start + lift * info.arm.arm_length * up)
        cup.keyframe_insert("location", frame=frame)
    bpy.context.scene.frame_set(1)
    rc, report = bake(tmp_path, ["Cup"])
    assert rc == 1 and reasons(report) == {"Cup": "target_moved"}, report["tasks"][0]["message"]
    [v] = refusal.check_report(bpy.context, report)
    assert (v.target, v.reason, v.status, v.method) == ("Cup", "target_moved", "confirmed",
                                                        "object"), v.detail
    bpy.data.objects["Cup"].animation_data_clear()
    bpy.data.objects["Cup"].location = tuple(start)
    [v] = refusal.check_report(bpy.context, report)
    assert v.status == "false_refusal", v.detail
