"""The fixed-seed subset of the fuzz campaign (``make fuzz``, ``verification/fuzz/``): 200
generated scenes, each built in Blender, baked twice by the command line and checked
independently, on worker processes (one per core). Every outcome must be a success that
the independent check finds clear at every frame and sub-frame instant with the wrist on
the target, or a failure with a reason that the refusal cross-check
(``verification.refusal``) does not contradict (a ``false_refusal`` fails); no escaped
exception, the input unchanged, the keys the same on both bakes.

The scenes are the campaign's own with ``quick`` on: smaller search budgets and Rigify's
metarig for the generated Rigify rig, so the subset takes a few minutes; every scene
feature of the campaign occurs in it (checked below)."""

import collections
import os

import numpy as np

from verification.fuzz import building, campaign, checks, scenes, summary

SEEDS = range(200)
#: Seconds a campaign worker may spend on one scene before it counts as stalled: the
#: campaign's own default. A hang guard, not a speed check; seed 7624 took 395 s on a
#: machine running another campaign beside the tests, and CI machines may be slower.
SCENE_TIMEOUT_S = 600


def test_the_subset_has_every_feature_of_the_campaign():
    """Every feature turns up among the subset's seeds; those only a Lean campaign draws
    (``scenes.LEAN_FEATURES``) among the same seeds generated with Lean, and never
    without it."""
    seen = collections.Counter(f for seed in SEEDS for f in scenes.generate(seed, quick=True)["features"])
    lean = collections.Counter(f for seed in SEEDS
                               for f in scenes.generate(seed, quick=True, lean=True)["features"])
    assert not [f for f in scenes.FEATURES if not seen[f] and not (
        f in scenes.LEAN_FEATURES and lean[f])]
    assert not [f for f in scenes.LEAN_FEATURES if seen[f]]
    assert scenes.generate(7, quick=True) == scenes.generate(7, quick=True)


#: False refusals the cross-check finds among the subset's scenes: findings about the
#: planner to be fixed there, not in this harness. Listed (seed: the refused reason) so
#: that every other failure, and any new false refusal, still fails the test, and a listed
#: seed that stops being one fails it too (the list stays true). None now: the six the
#: cross-check found first (91, 134, 144, 189: a turned trunk reaches the target; 118,
#: 198: a tapering arm's capsule stood out of its skin at the start) are fixed
#: (``ConfigurationGenerator.target_chest``; the start's skin, ``results.start_as_it_shows``).
KNOWN_FALSE_REFUSALS: dict = {}


def _false_reason(result):
    return next((c["reason"] for c in result.get("cross_check", ())
                 if c["status"] == "false_refusal"), None)


def test_every_generated_scene_is_a_verified_success_or_a_failure_with_a_reason():
    results = campaign.run_campaign(SEEDS, jobs=max(2, os.cpu_count() or 2), subframes=1,
                                timeout_s=SCENE_TIMEOUT_S, quick=True)
    assert [r["seed"] for r in results] == list(SEEDS)
    false = {r["seed"]: _false_reason(r) for r in results if r["category"] == "false_refusal"}
    bad = [r for r in results if r["category"] not in checks.GOOD + ("false_refusal",)]
    assert not bad, "\n".join(
        f"seed {r['seed']}: {r['category']}: {r['detail']} (rerun: python bench/fuzz.py "
        f"--quick --seed0 {r['seed']} --count 1 --keep DIR)" for r in bad)
    assert false == KNOWN_FALSE_REFUSALS, "\n".join(
        f"seed {r['seed']}: {r['detail']}" for r in results if r["category"] == "false_refusal")
    kinds = collections.Counter(r["category"] for r in results)
    assert kinds["success_verified"] >= 40 and kinds["failure_with_reason"] >= 40, kinds


def test_the_campaigns_grazes_between_keys_are_clear_now():
    """The four scenes of the full campaign (``bench/fuzz.json`` at 64fb85b) whose hand or
    arm touched an obstacle between two keys. 799 and 901 with no clearance (0.0010 and
    0.0047 arm lengths in) and 3777 after leaving a start in contact (0.0002): Blender's
    Bézier curves bowed away from the linear span; the bake now checks those instants as
    Blender evaluates them and makes such spans linear (``straighten.straighten``). 849 with no
    clearance (0.0035 in): the planner checked the straight line between its angles,
    which parts from Blender's linear span where the hand turns fast; it now checks
    Blender's (``core.keys``), and its hand pass, which found no clear hand at some frame
    of the way out of the start's contact, checks every transition of the motion's own
    hand instead of none. The independent check finds every instant clear, at the
    campaign's own three instants between frames. The scenes are that campaign's own:
    its synthetic rigs as they were before rig shapes varied (``shapes=False``). 799's
    target rides a moving carrier, 0.138 arm lengths off where it stood by the time the
    wrist arrives: since 528ae92 that is ``target_moved``, not a success the check reads
    (901 and 3777 keep the Bézier case)."""
    seeds = [799, 849, 901, 3777]
    results = campaign.run_campaign(seeds, jobs=2, subframes=3, timeout_s=SCENE_TIMEOUT_S, shapes=False)
    assert [(r["seed"], r["category"]) for r in results] == [
        (799, "failure_with_reason")] + [(s, "success_verified") for s in seeds[1:]], \
        [r["detail"] for r in results]
    assert results[0]["detail"].startswith("target_moved:"), results[0]["detail"]


def test_the_campaigns_chases_keep_the_hand_clear_between_keys():
    """Three chases of the full campaign at ce461f4 (seeds 3820, 4217, 4716) touched an
    obstacle with the hand between two keys, 0.06-0.09 arm lengths deep, and said so
    (``touching_transitions`` 1) while calling the chase a success: the hand lead turns the
    hand in the chase's short searches, and where the hand pass found no clear hand it
    could not slow down (a chase's frames are the target's) and kept the touching one. It
    now keeps the motion's own hands there, which the chase step checked between those
    keys, lifting the turn's bound about them where the hand cannot otherwise get to and
    from them (and where even the first pose along a frame's path touches, the arm holds
    for the frame). Seeds 4456 and 8867 were the harness's: a mesh of bare edges is no
    obstacle, so its NaN vertex is nothing to refuse. The scenes are that campaign's own
    (``shapes=False``: its synthetic rigs)."""
    seeds = [3820, 4217, 4716, 4456, 8867]
    results = campaign.run_campaign(seeds, jobs=2, subframes=3, timeout_s=SCENE_TIMEOUT_S, shapes=False)
    assert [(r["seed"], r["category"]) for r in results] == [
        (3820, "success_verified"), (4217, "success_verified"), (4716, "success_verified"),
        (4456, "failure_with_reason"), (8867, "failure_with_reason")], \
        [r["detail"] for r in results]


def test_a_start_in_contact_never_touches_again_once_clear():
    """Seed 1846 of the campaign at 2bf9405: a synthetic T-pose rig with a rolled hand and
    a long forearm, its forearm starting 0.069 arm lengths into a non-manifold tube. The
    way out left contact on frame 52.75 and touched again 0.0018 arm lengths deep at
    53.00-53.25: the escape and the keys' contact were read from a row of points along
    each capsule's axis, which over-reads by up to half their spacing and missed the
    tube's edge between two of them. Both now read a lower bound of the true clearance
    (``CollisionChecker.least_clearance``), and every instant of the way out is read
    until the arm is clear with the whole margin (``motion_check.escape_contact``)."""
    results = campaign.run_campaign([1846], jobs=1, subframes=3, timeout_s=SCENE_TIMEOUT_S)
    assert [(r["seed"], r["category"]) for r in results] == [(1846, "success_verified")], \
        [r["detail"] for r in results]


#: False refusals of full campaigns that the planner still makes (seed: the reason), of the
#: seeds of :func:`test_the_campaigns_refusals_are_checked_as_they_are_claimed`: of the 34
#: of the campaign at 41157e1 (``bench/fuzz.json``), none now.
CAMPAIGN_FALSE_REFUSALS: dict = {}


def test_a_figure_tilted_off_gravity_is_not_stepped():
    """Seed 40044 of a Lean campaign at ad05076: GoMakeHuman on a parent tilted 48.5° off
    the scene's gravity, its target 1.95 arm lengths off. Every step tried needed the
    hips farther from an ankle than its leg reaches, and posing it raised ``ValueError``
    out of the bake (at 912c012 too). A figure whose legs lean more than 30° off gravity
    is now not stepped or leaned, saying so; the reach ends ``needs_step``, which the
    cross-check confirms (``test_body_step`` covers the step's own refusal)."""
    results = campaign.run_campaign([40044], jobs=1, subframes=1, timeout_s=SCENE_TIMEOUT_S,
                                    lean=True)
    assert [(r["seed"], r["category"]) for r in results] == [(40044, "failure_with_reason")], \
        [r["detail"] for r in results]
    assert "off the scene's gravity" in results[0]["detail"], results[0]["detail"]


def test_the_campaigns_refusals_are_checked_as_they_are_claimed():
    """False refusals of full campaigns: five in the first 1,193 scenes of the one at
    4289954, 6024, 6356 and 6397 in a later partial run, 783 in one at 76fb172, 209
    in one at 341957e, 7408 in one at 2bf9405, 5196 in one at fbe5464, 5045 and 5235 in
    one at 9c6e3d3, 213, 384, 5239 and 5413 in the first 1,005 scenes of one at f03f3e4:

    - 5257 ``out_of_reach`` and 5310 ``needs_lean``: a pose fits only at a swivel angle
      between the search's 5° samples with the elbow folded to its limit (5257), or
      0.001 arm lengths nearer the shoulder, within the goal tolerance (5310); the search
      and the diagnosis now ask the search's last tries (the tolerance ball's rim, a 1°
      swivel) before they refuse;
    - 5170 ``arm_does_not_fit``, 6024 and 6397 ``no_path``: the only clear poses lie
      0.0047 arm lengths off the target (5170, 6024) or at a chest turn of 53.9° (6397),
      neither at this reach's chest nor the start's, so the sampling planner had no goal;
      it now takes them where the diagnosis finds them (sampling._goals_elsewhere);
    - 6356 ``start_in_collision``: a box animated through the shoulder after the reach's
      start frame (frames 35-55; the start, frame 32, is clear). The refusal was right, its
      claim ("the start pose touches") was not: it now says the box moves into the start
      pose, on which frame (core.sweep), and the cross-check tests that on that frame;
    - 5278 ``start_in_collision``, the chest inside a closed mesh that the arm's skin does
      not touch: the cross-check now tests that claim on the chest's point (and the message
      names the mesh that encloses the chest, not the nearest: quick seed 92);
    - 5221 ``start_in_collision`` of a reach's second target, which starts where the first
      ended, at its own frame, with an animated box moved on: unchecked now, as its path
      claim already was;
    - 783 ``start_in_collision`` at the hand, from a campaign at 76fb172: a fingerless
      one-bone hand 0.06 long, read as 0.74 forearms (0.12), so its capsule reached into a
      box the skin stands 0.08 clear of; a fingerless hand is now as long as its skin;
    - 209 ``start_in_collision`` from a campaign at 341957e: a plane animated to within
      0.03 arm lengths of a rigid robot's skin at the clavicle on frame 8, inside the
      model's fuller capsule there; the refusal now says so (``start_held``, the skin's
      clearance on that frame), as a start the model alone holds does;
    - 7408 ``needs_lean`` from the campaign at 2bf9405: a left arm in a T-pose reaching
      across the body, out of reach by 0.004 arm lengths at Table 1's chest and within
      it only with the trunk turned 60° toward the target, where the shoulder moves
      toward it; the tolerance ball's rim was tried toward the resting shoulder only. It
      is now tried first toward the shoulder as the chest turn nearest the target carries
      it (``search.nearest_shoulder``), and at 0.97 of the tolerance as well as 0.9;
    - 5196 ``start_in_collision`` from the campaign at fbe5464: CesiumMan's clavicle
      capsule 0.10 arm lengths into a box, deeper than a start may touch, its skin 0.088
      arm lengths clear; such a start is now ``start_held`` too, saying the model is in
      and the skin is not (``results.start_as_it_shows``);
    - 7074 ``start_held``, found by the cross-check's search from a start in contact
      (``refusal._held_validity``): a chase's upper arm against a box, which no step of
      the wrist moved off while OMPL left with the chest turned; the escape now turns
      the chest where the wrist's steps are stuck (``contact.escape``). The chase then
      missed the target, and OMPL's way, never deeper than the start, fit its frames;
      but 21 % along it the arm came back from 0.0085 to 0.0090 arm lengths deep, which
      Reach's escape never does, so the claim is now inconclusive
      (``refusal._leaves_as_reach_does``);
    - 5045 and 5235 ``start_held``, from a campaign at 9c6e3d3: an upper arm along a thin
      wall whose greedy escape ran out of steps (the last one clear was never tested) and
      a clavicle in a mesh, which the thinner arm's own conservative test still refused
      and which only the chest moves; the escape now thins the arm until its test passes
      the start and, where the greedy way is stuck, searches best-first with chest turns
      (``contact._search``);
    - 5103 ``start_held``, found when the cross-check's search from a start in contact
      held the arm's exact least clearance to the start's (it had been inconclusive): a
      forearm's bone through a plane, its capsule only its radius "deep", which a way
      never deeper than that passed straight through; the planner now refuses a bone
      through an obstacle's surface as deeper than a start may touch
      (``contact.bone_touches``), which ``refusal.check_deep_start`` confirms;
    - 5413 ``start_held`` from the campaign at f03f3e4: a hand touching an open mesh,
      refused as inside it, since ray parity over all obstacles read the air four axes
      cross oddly as solid; only closed meshes have an inside now, read one piece at a
      time (``Obstacles.enclosing_parts``);
    - 213, 384 and 5239 ``no_path`` of chases from that campaign, ways to where the target
      ends that the plan ahead missed: retimed at the pursuit's whole steps a frame, 2 of
      the 2.78 the speed limit allows, 0.16 of a frame too slow (213; now at the limit,
      ``chase.chase_rate``); a box that moved into the way planned among the first frame's
      obstacles (384; now planned again among every place they take,
      ``obstacle_union.union``); a start in contact whose escape's own transitions were held
      against the way ahead (5239);
    - 863, 2588, 6288 and 7608 ``start_held`` from the campaign at 41157e1: an upper arm
      or clavicle in contact whose wrist's steps found no way out (the IK takes the
      strongest swivel at each wrist) where a straight line in joint space leaves it,
      never deeper; the escape now tries such lines toward the clear swivels at the
      target, the chest as Table 1, the start and either limit turn it
      (``contact._straight``);
    - 1286 ``no_path`` from that campaign: the sampling planner's goal region held only
      this reach's chest and the start's, and its chest range only what lies between them;
      OMPL went straight to a goal with the chest at -30°. A straight line in joint space
      to the goal poses over the whole chest range is now tried first
      (``straight.straight_to_goal``); 2482, a chase ``no_path``: its plan ahead's
      search found a way too long for its 22 frames, where OMPL's straight line fitted
      them exactly; the plan ahead now tries that line too (``sampling.straight_poses``).
      Of the campaign's 34, these three changes let 18 pass (863, 869, 1286, 2482, 2588,
      2829, 3123, 3373, 3821, 4723, 4787, 4997, 6288, 7608, 8420, 8844, 9060, 9346);
    - of the other 16: 4940 and 7738 ``target_in_obstacle``, whose only clear poses lie in
      the thin shell between 0.9 and the whole tolerance, in a swivel window narrower
      than 5° (the last tries now take the rim's 26 directions at 0.97 of it with a 1°
      swivel, ``search.last_tries``); 8331 ``start_held``, a clavicle in a box that the
      chest's turn alone takes out (the escape's lines now include the start's arm with
      the chest at either end of its range); 7624 ``no_path`` and 2959, a chase, starts
      in contact whose greedy way out turned the chest away from the only way in (a
      reach that fails from its escape now tries straight lines out toward the target
      over the chest's range, ``contact.line_escape``); 3441 and 2533 ``no_path``, starts
      within the clearance whose thinner arm's own test still refused the start, so the
      frames the timing held there were called touching (the escape's arm now thins until
      its test passes the start pose itself, ``contact._passing``); 4148 and 3779 pass
      with these; 9192 and 3665, starts in contact with an obstacle that moves, whose
      OMPL way among every place it takes says nothing of when the arm passes each
      (now inconclusive, ``refusal.check_path_claim``'s ``moving``); 7593's OMPL way now
      breaks the escape's rule (inconclusive); 2402 now ends ``bad_input`` (the body's
      own animation carries the arm away while it reaches). 4880, ``success_but_collides``
      by 0.0001 arm lengths at frame 17.5 of a chase with the clearance 0, keeps a
      least margin of 0.001 (``collision.MIN_CLEARANCE``), and a chase frame taken
      nearer for the hand's turn is now clear between its keys too
      (``chase._commit``). 3327 and 5804 are chases whose OMPL way, shortened by a
      simplifier that ran for a second, fitted their frames at the limits exactly (24 of
      24, 25 of 25) where Reach's ways need 27 and 28. The simplifier now stops on a count
      of state tests and, for a chase, runs 16 times, seeded, the way needing the fewest
      frames kept, so that a verdict does not depend on the machine's load (5804 needed 30
      frames in a run under load). Both now catch the target: where neither the search's
      way nor a straight line fits the frames left, the way is shortened in the chase's
      own cost, frames at its limits (``chase_timing.shortcut_for``; 5804's search way
      from 30.4 frames to 19.5, 3327's sampled way from 26.1 to 21.4, 24 had);
    - :data:`CAMPAIGN_FALSE_REFUSALS`, still false refusals (the list stays true: a seed
      that stops being one fails this test too)."""
    seeds = [209, 213, 384, 783, 863, 869, 1286, 2402, 2482, 2533, 2588, 2829, 2959, 3123,
             3327, 3373, 3441, 3665, 3779, 3821, 4148, 4723, 4787, 4880, 4940, 4997, 5045, 5103,
             5170, 5196, 5221, 5235, 5239, 5257, 5278, 5310, 5413, 5804, 6024, 6288, 6356,
             6397, 7074, 7408, 7593, 7608, 7624, 7738, 8331, 8420, 8844, 9060, 9192, 9346]
    results = campaign.run_campaign(seeds, jobs=2, subframes=3, timeout_s=SCENE_TIMEOUT_S)
    false = {r["seed"]: _false_reason(r) for r in results if r["category"] == "false_refusal"}
    assert false == CAMPAIGN_FALSE_REFUSALS
    assert [(r["seed"], r["category"]) for r in results
            if r["category"] not in checks.GOOD + ("false_refusal",)] == []


def test_refusals_are_counted_by_their_words_whatever_the_names_hold():
    """fuzz.json counts refusals by their words with names and numbers taken out; a name
    holding a quote (the generator's "Cup'") must not split a refusal into two keys."""
    def key(detail):
        return summary.reason_key({"detail": detail})
    plain = key("bad_input: target 'Cup' has a NaN or infinite transform; fix its location")
    quoted = key("bad_input: target 'Cup'' has a NaN or infinite transform; fix its location")
    assert plain == quoted == "bad_input: target '…' has a NaN or infinite transform"
    assert key("bad_input: armature 'A' is linked from '//lib.blend' and cannot be keyed; x") == (
        "bad_input: armature '…' is linked from '…' and cannot be keyed")
    assert key("no_path: the wrist did not catch 'a: b'") == "no_path"


def _first_seeds(kinds, quick=True, limit=600) -> dict:
    """The first seed (quick scenes) whose synthetic rig has each shape of ``kinds``
    ("fingers", "palms", "mitten" hands; "rigid" parts), among scenes the bake reads (no
    linked, non-uniformly scaled or NaN armature)."""
    found = {}
    for seed in range(limit):
        spec = scenes.generate(seed, quick=quick)
        shape = spec["rig"].get("shape")
        if not shape or spec["linked_armature"] or spec["non_uniform"] or spec["armature_nan"]:
            continue
        kind = "rigid" if shape["rigid"] else shape["hand"]
        if kind in kinds and kind not in found:
            found[kind] = seed
    return found


def test_the_independent_check_reads_the_new_rigs_right(tmp_path):
    """On generated rigs with fingers, a mitten, sibling palms and rigid parts: the
    independent check's hand (``checks.ArmReader``) ends at least as far along the hand as its
    farthest finger joint, which lies within a forearm of the wrist; rigid parts parented
    to bones are the character's (Reach leaves them out of the obstacles, so does the
    cross-check) and never among the harness's obstacles."""
    import bpy

    from reach_addon.blender import rig as rig_mod
    from reach_addon.blender.scene import character_objects
    from verification import refusal

    seeds = _first_seeds({"fingers", "mitten", "palms", "rigid"})
    assert set(seeds) == {"fingers", "mitten", "palms", "rigid"}, seeds
    library = tmp_path / "library.blend"
    building.make_library(library)
    cache = building.RigCache(tmp_path)
    for kind, seed in sorted(seeds.items()):
        spec = scenes.generate(seed, quick=True)
        manifest = building.build(spec, cache, tmp_path, library)
        arm = bpy.data.objects[manifest["armature"]]
        info = rig_mod.build(arm, spec["side"])
        joints = checks.ArmReader(arm, info).joints(arm)
        wrist, tip = joints[3], joints[4]
        axis = (tip - wrist) / np.linalg.norm(tip - wrist)
        mw = np.array(arm.matrix_world)
        below = [b for n in info.hand_bones for b in arm.pose.bones[n].children_recursive]
        length = info.arm.arm_length
        if kind == "rigid":
            parts = [ob.name for ob in bpy.data.objects
                     if ob.parent == arm and ob.parent_type == "BONE"]
            assert len(parts) > 10, parts
            assert not set(parts) & set(manifest["solids"])
            assert set(parts) <= character_objects(arm, bpy.context.scene)
            assert set(parts) <= refusal.character_objects_of(arm, bpy.context.scene)
            labels = {label.split("/")[0] for label, _t, _c in refusal.scene_obstacles(
                bpy.context, refusal.character_objects_of(arm, bpy.context.scene))}
            assert not set(parts) & labels
            continue
        assert below, (kind, seed, info.hand_bones)
        pts = np.array([mw[:3, :3] @ np.array(p) + mw[:3, 3] for b in below
                        for p in (b.head, b.tail)])
        along = (pts - wrist) @ axis
        assert float(np.linalg.norm(tip - wrist)) >= along.max() - 1e-6 * length, (kind, seed)
        assert along.max() <= info.arm.forearm_length * (1 + 1e-6), (kind, seed)


def test_a_contradicted_refusal_is_counted_as_a_false_refusal():
    """``false_refusal`` is a category that does not pass; fuzz.json counts the cross-check's
    verdicts per reason and lists every false refusal with its seed, and the README's
    block says how many (``summary.cross_check_counts``, which bench/readme.py writes)."""
    assert "false_refusal" in checks.CATEGORIES and "false_refusal" not in checks.GOOD
    base = {"features": [], "task": "reach", "rig": "synthetic/mixamo", "time_s": 1.0}
    results = [
        {**base, "seed": 1, "category": "failure_with_reason", "detail": "out_of_reach: x",
         "cross_check": [{"target": "A", "reason": "out_of_reach", "status": "confirmed",
                          "method": "ik", "seconds": 0.01, "detail": "no valid goal state"}]},
        {**base, "seed": 2, "category": "false_refusal", "detail": "'B' no_path: found",
         "cross_check": [{"target": "B", "reason": "no_path", "status": "false_refusal",
                          "method": "ompl", "seconds": 0.5, "detail": "found a path"},
                         {"target": "C", "reason": "no_path", "status": "unchecked",
                          "method": "ik", "seconds": 0.0, "detail": "later leg"}]}]
    counts = summary.summarize(results, {"seed0": 1, "count": 2})
    assert counts["passed"] == 1 and counts["categories"]["false_refusal"]["count"] == 1
    assert (counts["refusals_cross_checked"], counts["false_refusals"],
            counts["refusals_not_decided"]) == (2, 1, 1)
    assert counts["cross_check"]["no_path"]["false_refusal"] == 1
    assert counts["false_refusal_list"] == [
        {"seed": 2, "target": "B", "reason": "no_path", "detail": "found a path"}]
    line = summary.cross_check_counts(counts)
    assert "**2 decided**" in line and "**1 false refusals**; seed 2 `no_path` ('B')" in line


def test_the_hand_turn_check_finds_a_turn_over_the_bound():
    """``checks.HandTurns`` reads the hand bones' whole turn from frame to frame as Blender
    evaluates it: a bone keyed to turn 10°, 10°, then 30° a frame is over a 15° bound into
    the third frame only, roll about its own axis included (a turn the bone's direction
    alone would not show)."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    arm = bpy.data.objects.new("Turner", bpy.data.armatures.new("Turner"))
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    bone = arm.data.edit_bones.new("hand")
    bone.head, bone.tail = (0.0, 0.0, 0.0), (0.0, 0.2, 0.0)
    bpy.ops.object.mode_set(mode="OBJECT")
    pb = arm.pose.bones["hand"]
    pb.rotation_mode = "XYZ"
    for frame, roll in ((1, 0.0), (2, 10.0), (3, 20.0), (4, 50.0)):
        pb.rotation_euler = (0.0, np.radians(roll), 0.0)         # about the bone's own y
        pb.keyframe_insert("rotation_euler", frame=frame)
    turns = checks.HandTurns(arm, ["hand"], 15.0 + checks.TURN_ROUNDING)
    for frame in range(1, 5):
        bpy.context.scene.frame_set(frame)
        turns.at(frame)
    assert [f for f, _t in turns.over] == [4]
    assert abs(turns.over[0][1] - 30.0) < 1e-3


def test_a_stopped_campaign_carries_on_where_it_stopped(tmp_path):
    """``make fuzz --resume``: the results kept in the campaign's folder are not run again;
    a scene started and not finished (the line a stopped worker leaves) is."""
    seeds = [3, 7, 8]
    runs = tmp_path / "runs"
    first = campaign.run_campaign(seeds[:2], jobs=1, subframes=1, timeout_s=SCENE_TIMEOUT_S, quick=True,
                                  runs=runs)
    (kept,) = runs.glob("worker-*.jsonl")
    # as a worker stopped part way leaves it: seed 8 started, no result
    with open(kept, "a", encoding="utf-8") as out:
        out.write('{"seed": 8, "event": "start"}\n')
    assert sorted(campaign.kept_results(runs)) == [3, 7]
    again = campaign.run_campaign(seeds, jobs=2, subframes=1, timeout_s=SCENE_TIMEOUT_S, quick=True,
                                  runs=runs)
    assert [r["seed"] for r in again] == seeds
    assert again[:2] == first                       # kept, not run again
    new = [p for p in runs.glob("worker-*.jsonl") if p != kept]
    assert [sorted(campaign._read_results(p)[0]) for p in new] == [[8]]   # only the rest ran
    assert again[2]["category"] in checks.GOOD


def test_the_code_digest_follows_the_code_not_the_scheduler(tmp_path):
    import shutil

    root = tmp_path / "repo"
    for d in ("reach_addon", "verification"):
        shutil.copytree(campaign.ROOT / d, root / d, ignore=shutil.ignore_patterns("__pycache__"))
    before = campaign.code_digest(root)
    assert before == campaign.code_digest(campaign.ROOT)
    (root / "verification" / "fuzz" / "campaign.py").write_text("# the scheduler only\n")
    assert campaign.code_digest(root) == before
    core = root / "reach_addon" / "core" / "search.py"
    core.write_text(core.read_text() + "\n# a change\n")
    assert campaign.code_digest(root) != before


def test_a_scene_a_signal_stopped_is_not_recorded_and_runs_again(tmp_path, monkeypatch):
    """Pausing a campaign (SIGTERM) stops a scene's bake with exit status 143; that scene
    gets no result, so a resumed campaign runs it again (seeds 621 and 5514 were recorded
    as "nondeterministic" when the second of their two bakes was stopped so)."""
    ran = []

    def fake_scene(seed, *args, **kwargs):
        ran.append(seed)
        if seed == 2:
            raise campaign.StoppedError(seed)
        return {"seed": seed, "category": "success_verified"}

    monkeypatch.setattr(campaign, "run_scene", fake_scene)
    results = tmp_path / "worker-0-3-1.jsonl"
    campaign.worker([1, 2, 3], results, subframes=1, keep=tmp_path / "scene")
    assert ran == [1, 2]
    assert sorted(campaign.kept_results(tmp_path)) == [1]


def test_the_summary_counts_what_the_whole_body_did():
    """A scene's report (the CLI's: each task's statistics flattened into it) says what the
    body did for each task (``lean_deg``, ``lean_hips_down``, ``lean_ready_frames``,
    ``step_count``); the
    campaign reads it
    (``campaign.body_outcomes``) and fuzz.json counts each outcome."""
    report = {"tasks": [{"reason": None, "lean_deg": 30.0, "lean_hips_down": 0.01},
                        {"reason": None, "lean_deg": 80.0, "lean_hips_down": 0.4,
                         "lean_ready_frames": 20},
                        {"reason": None, "frames": 30},
                        {"reason": "needs_lean"},
                        {"reason": None, "step_count": 2},
                        {"reason": None, "step_count": 3, "lean_deg": 9.0}]}
    assert campaign.body_outcomes(report) == ["lean", "squat+ready", "step", "step+lean"]
    base = {"features": [], "task": "reach", "rig": "synthetic/mixamo", "time_s": 1.0,
            "category": "success", "detail": ""}
    results = [{**base, "seed": 1, "body": ["lean"]}, {**base, "seed": 2},
               {**base, "seed": 3, "body": ["lean", "squat+ready"]}]
    assert summary.summarize(results, {})["body"] == {"lean": 2, "squat+ready": 1}
