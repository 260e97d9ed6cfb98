"""A natural arm on every rig: the wrist near its rest alignment, no chicken wing, and a
report that says so.

Each (rig, everyday scene) of ``test_every_rig`` is baked as a user's Bake is and measured
on Blender's evaluated bones by :mod:`verification.naturalness`, which shares no code with
the planner: the hand bone's axis in the forearm bone's frame against the rest pose (wrist
bend), and the elbow more than 0.1 arm lengths above the shoulder while the wrist is more
than that below it (chicken wing), over every frame of the motion. Each reach must keep the
mean bend within 12° and the largest within 45°, with no chicken wing; and the report's
own figures (``blender.results.measure_naturalness``, another construction: the hand's
axis from its fingers against where the rest pose would hold it; the body's up axis) must
agree with the measured ones.

A bend beyond those figures passes only where the report names the obstacle that forced
it (``bend_forced_by``) and the hand turned back to its rest alignment, there or on the
way (a hand bent past a shelf's edge cannot turn back through the shelf), would indeed
come within the clearance a keyed pose keeps of an obstacle (:func:`relaxed_hand_touches`,
exact distances to the evaluated triangles) on
every frame bent beyond 45°, or the frame lies so near a forced one that the hand could not
be bent less than 45° there, turning at most its bounds a frame: relative to the forearm
(``Settings.hand_turn_speed`` / fps, 15° at 24 fps) and in space
(``hand_space_turn_speed`` / fps; the rest alignment moves with the forearm); the other
frames keep the mean within 12°.

Where that bound (the hand's axis alone) leaves a frame bent beyond 45°, the hand's whole
frame as Reach models it decides (:func:`least_model_bend`): its direction and the
elbow's hinge, on the forearm as baked, within the turn bound in space (roll included) and
the bound against the forearm. The pairs the planner does not do yet are
``xfail(strict=True)`` in :data:`XFAIL`, with what was measured (issue "A natural arm").
"""

from __future__ import annotations

import json
import math

import bpy
import clearance
import everyday
import numpy as np
import pytest
from test_every_rig import (TURN_ROUNDING, cases, frame_rate, hand_turns,  # noqa: F401
                            obstacle_triangles, rig_file)

from verification import naturalness
from verification.geometry import segment_triangle_distances

#: How far the report's mean and largest bend may lie from the measured ones (degrees): the
#: two read the hand's axis differently (its fingers' middle, its bone's y axis), and a
#: wrist bend turns the two by a little more or less.
MEAN_AGREES, MAX_AGREES = 2.0, 6.0
#: How many chicken-wing frames the report and the measure may count apart.
WING_FRAMES_AGREE = 1

#: (rig, scene) → what keeps it from the goal, as measured at its commit (none now;
#: "forced": the report names the obstacle and the relaxed hand, or the hand turned
#: straight back to it, would touch it on those frames).
XFAIL: dict = {}


def bake(addon, rig_file, kind, scene, settings=None):  # noqa: F811
    """Bake ``scene`` round rig ``kind`` as a user's Bake is (``settings``: the defaults
    unless given): (armature, rig info, outcome)."""
    path, name = rig_file(kind)
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    arm = bpy.data.objects[name]
    info = addon.blender.rig.build(arm, "right")
    targets = everyday.build(scene, info, arm)
    pipeline = addon.blender.pipeline
    request = pipeline.Request(arm.name, [t.name for t in targets], task=everyday.TASKS[scene],
                               side="right", frame_start=1, draw=False,
                               **({} if settings is None else {"settings": settings}))
    return arm, info, pipeline.run(bpy.context, request, bake=True)


def _rotation(m):
    m = np.array(m)[:3, :3]
    return m / np.linalg.norm(m, axis=0)


def relaxed_hand_touches(arm, info, check, tris, margin: float) -> bool:
    """Would the hand, turned back at the wrist to its rest alignment on the forearm as it
    is now, come within its radius and ``margin`` (figure units: the clearance a keyed
    pose keeps) of ``tris``, there or on the way? The hand's capsules as the clearance
    check reads them (its shape's, carried by the hand bone, where the rig model has one;
    else wrist to the fingers' far end), rotated by ``Rf (Rf⁰ᵀ Rh⁰) (Rfᵀ Rh)ᵀ
    Rfᵀ`` (armature space, ⁰: rest), and turned there about the one axis that takes it
    (the rotation's own axis, :data:`SWEEP_STEPS` steps: a hand bent past a shelf's edge
    cannot turn back through the shelf), against the triangles by exact segment
    distances. On the way, a touch counts only nearer than the hand is now by a quarter
    of the margin (this capsule is the skin's, not the planner's, and may already sit
    within the margin)."""
    b = info.bones.arms["right"]
    bones, pb = arm.data.bones, arm.pose.bones
    rf = _rotation(pb[b.forearm].matrix)
    back = rf @ (_rotation(bones[b.forearm].matrix_local).T @ _rotation(bones[b.hand].matrix_local)) \
        @ (rf.T @ _rotation(pb[b.hand].matrix)).T @ rf.T
    mw = np.array(arm.matrix_world)[:3, :3]
    wrist = check.wrist()
    caps = [c for c in check.capsules() if c[0] == "hand"] if check.shape is not None \
        else [check.axis_capsule()]
    for _part, p, q, radius in caps:
        local = [np.linalg.solve(mw, x - wrist) for x in (p, q)]
        now = float(segment_triangle_distances(p, q, tris)[0])
        for t in np.linspace(1.0, 0.0, SWEEP_STEPS + 1)[:-1]:
            turn = _fraction(back, t)
            a, b = (wrist + mw @ (turn @ x) for x in local)
            d = float(segment_triangle_distances(a, b, tris)[0])
            # (on the way, nearer than the hand is now: the planner's margin is between keys)
            if d < radius + margin and (t == 1.0 or d < now - 0.25 * margin):
                return True
    return False


#: Steps of :func:`relaxed_hand_touches`' turn back to the rest alignment.
SWEEP_STEPS = 16


def _fraction(rotation, t: float):
    """The rotation by ``t`` of the angle of ``rotation`` (3 × 3) about its own axis
    (Rodrigues' formula)."""
    angle = float(np.arccos(np.clip((np.trace(rotation) - 1.0) / 2.0, -1.0, 1.0)))
    if angle < 1e-9:
        return np.eye(3)
    axis = np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0],
                     rotation[1, 0] - rotation[0, 1]])
    if np.linalg.norm(axis) < 1e-9:               # a half turn: its axis from R + I
        sym = rotation + np.eye(3)
        axis = sym[:, int(np.argmax(np.linalg.norm(sym, axis=0)))]
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    a = t * angle
    return np.eye(3) + np.sin(a) * k + (1.0 - np.cos(a)) * (k @ k)


def _arm_hinge(arm, b):
    """(the elbow's hinge axis, the forearm's basis rows f, p, h) in world space now, from
    the joints (the bones' heads): h = u × f normalised (u the upper arm's direction, f
    the forearm's), p = h × f, as Reach's hand model has them (README, *the hand*)."""
    mw = np.array(arm.matrix_world)
    s, e, w = (mw[:3, :3] @ np.array(arm.pose.bones[n].head) + mw[:3, 3]
               for n in (b.upper_arm, b.forearm, b.hand))
    u, f = (e - s) / np.linalg.norm(e - s), (w - e) / np.linalg.norm(w - e)
    h = np.cross(u, f)
    h /= max(float(np.linalg.norm(h)), 1e-12)
    return h, np.stack([f, np.cross(h, f), h])


def _model_frames(d, h):
    """Reach's hand frames (..., 3, 3), columns (d, g, d × g), g the hinge ``h`` made
    perpendicular to the hand's directions ``d`` (..., 3)."""
    g = h - (d @ h)[..., None] * d
    g = g / np.maximum(np.linalg.norm(g, axis=-1, keepdims=True), 1e-12)
    return np.stack([d, g, np.cross(d, g)], -1)


def least_model_bend(f, forced, hand_axis, rest_axis, hinge, basis, bound, space) -> float:
    """The least bend (degrees) a hand could have on frame ``f`` as Reach models the hand:
    a direction d on the forearm as it moved, its frame fixed by d and the elbow's hinge
    (:func:`_model_frames`; the model has no wrist twist), its frame in space within
    ``space`` degrees a frame of the frame it had on each forced frame g, and its
    direction against the forearm's basis within ``bound`` a frame of g's. Directions on
    a grid about the rest axis (0.5° by 2°); inf where none is within."""
    rest = rest_axis[f] / np.linalg.norm(rest_axis[f])
    e1 = np.cross(rest, hinge[f])
    if np.linalg.norm(e1) < 1e-9:
        e1 = np.cross(rest, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(rest, e1)
    rho = np.radians(np.arange(0.0, 120.25, 0.5))[:, None, None]
    psi = np.radians(np.arange(0.0, 360.0, 2.0))[None, :, None]
    d = np.cos(rho) * rest + np.sin(rho) * (np.cos(psi) * e1 + np.sin(psi) * e2)
    frames = _model_frames(d, hinge[f])
    coefficients = d @ basis[f].T
    ok = np.ones(d.shape[:2], bool)
    for g in forced:
        dg = hand_axis[g] / np.linalg.norm(hand_axis[g])
        fg = _model_frames(dg, hinge[g])
        ok &= _angle(np.einsum("ij,abij->ab", fg, frames)) <= space * abs(f - g) + 1e-6
        cg = basis[g] @ dg
        ok &= _angle(coefficients @ cg, trace=False) <= bound * abs(f - g) + 1e-6
    bends = np.broadcast_to(np.degrees(rho[:, :, 0]), ok.shape)
    return float(bends[ok].min()) if ok.any() else math.inf


def _angle(x, trace: bool = True):
    """Degrees of a rotation from its trace (``trace``) or of two unit vectors from their
    dot product."""
    c = (x - 1.0) / 2.0 if trace else x
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


@pytest.mark.parametrize("kind, scene", list(cases(XFAIL)))
def test_the_arm_looks_natural(addon, rig_file, kind, scene):  # noqa: F811
    """Natural, or bent only where the report says an obstacle forced it and the relaxed
    hand there would indeed touch one (:func:`relaxed_hand_touches`): every frame bent
    beyond 45° is such a frame, and the others keep the mean within 12°."""
    arm, info, outcome = bake(addon, rig_file, kind, scene)
    assert_natural(addon, arm, info, outcome, {"rig": kind, "scene": scene})


#: The demo's tasks the planner does not make natural yet, with what was measured (none
#: now: the chase alone, from the rest pose, kept a pursuit that turned the hand 15.9° in a
#: frame with 11 winged frames until a chase that turns too fast plans ahead instead).
DEMO_XFAIL: dict = {}


@pytest.mark.parametrize("name", [
    pytest.param(n, marks=[pytest.mark.xfail(strict=True, reason=DEMO_XFAIL[n])]
                 if n in DEMO_XFAIL else [])
    for n in ("collision_free", "rotation", "guided", "chase")])
def test_the_demo_arm_looks_natural(addon, name):
    """The demo's four tasks (``make demo``), each baked alone from frame 1 on its
    character and workplace, as :func:`test_the_arm_looks_natural` asks: the guided reach
    into the shelf bends the hand beyond 45° (50.1° at 37ac9da) where the report names the
    obstacle, and that claim is checked here by the relaxed hand on Blender's bones."""
    from reach_addon import demo

    arm = demo.scene_.build_scene(demo.WORKPLACE)
    task = dict(demo.demo_tasks())[name]
    request = addon.blender.pipeline.Request(
        arm.name, demo._demo_target_names(task, 1), task=task.kind, side="right",
        frame_start=1, draw=False)
    outcome = addon.blender.pipeline.run(bpy.context, request, bake=True)
    info = addon.blender.rig.build(arm, "right")
    assert_natural(addon, arm, info, outcome, {"demo": name})
    # and the hand keeps its turn bound in space (the chase alone once turned it 15.9°),
    # the upper arm and forearm theirs (the rotation once turned the upper arm 15.7°):
    # each bone's whole world rotation, and each limb's direction, from frame to frame
    frames = range(outcome.results[0].frame_start, outcome.results[-1].frame_end + 1)
    turns = hand_turns(arm, info, request.settings, frames)
    assert not turns.over, f"the hand turns {turns.worst[0]:.2f}° into frame {turns.worst[1]}"
    limb = request.settings.limb_turn_speed / frame_rate() + TURN_ROUNDING
    b = info.bones.arms["right"]
    mw = arm.matrix_world
    prev = None
    for f in frames:
        bpy.context.scene.frame_set(f)
        now = [(mw @ arm.pose.bones[n].tail - mw @ arm.pose.bones[n].head).normalized()
               for n in (b.upper_arm, b.forearm)]
        if prev is not None:
            turn = max(np.degrees(x.angle(y, 0.0)) for x, y in zip(prev, now))
            assert turn <= limb, f"a limb turns {turn:.2f}° into frame {f}"
        prev = now


def assert_natural(addon, arm, info, outcome, label: dict) -> None:
    """The checks of :func:`test_the_arm_looks_natural` on a baked ``outcome`` of the
    armature ``arm`` (``info``: its rig as read at the start)."""
    tasks = outcome.results
    assert outcome.baked and all(t.success for t in tasks)
    b = info.bones.arms["right"]
    # a fingerless hand's axis is its skin's middle, fixed in the hand bone's frame (a
    # bone's y axis can point anywhere: CesiumMan's is 140° from its forearm)
    anchor = clearance.skin_anchor(arm, (b.hand,))
    axis = (0.0, 1.0, 0.0) if anchor is None else anchor[1] / np.linalg.norm(anchor[1])
    figures = naturalness.measure(arm, b.upper_arm, b.forearm, b.hand,
                                  range(tasks[0].frame_start, tasks[-1].frame_end + 1),
                                  axis=axis)
    frames = [t.frame_end - t.frame_start + 1 for t in tasks]
    reported_mean = sum(t.stats["mean_wrist_bend_deg"] * n for t, n in zip(tasks, frames)) / \
        sum(frames)
    reported_max = max(t.stats["max_wrist_bend_deg"] for t in tasks)
    reported_wings = sum(t.stats["chicken_wing_frames"] for t in tasks)
    print(f"NATURAL {json.dumps(label | figures.summary())} "
          f"reported mean {reported_mean:.2f} max {reported_max:.2f} wings {reported_wings}")
    # the report says what the bones show
    assert abs(reported_mean - figures.mean_bend) <= MEAN_AGREES
    assert abs(reported_max - figures.max_bend) <= MAX_AGREES
    # (a frame at the margin may count on one side only: the report's up is the body's,
    # the measure's the world's)
    assert abs(reported_wings - len(figures.wing_frames)) <= WING_FRAMES_AGREE
    # and what they show is natural
    assert not figures.wing_frames, f"chicken wing at frames {figures.wing_frames}"
    if figures.mean_bend <= naturalness.MEAN_BEND_MAX and \
            figures.max_bend <= naturalness.MAX_BEND_MAX:
        return
    # or bent where an obstacle forces it, as the report says and the relaxed hand shows
    named = {t.stats.get("bend_forced_by") for t in tasks} - {None}
    assert named, f"bent without a reason: {figures.summary()}"
    check, tris = clearance.Arm(arm, info), obstacle_triangles(addon, arm)
    settings = addon.core.Settings()
    margin = settings.clearance * info.arm.arm_length
    forced, hand_axis, rest_axis, hinge, basis = set(), {}, {}, {}, {}
    bones, pb = arm.data.bones, arm.pose.bones
    mw = _rotation(arm.matrix_world)
    offset = _rotation(bones[b.forearm].matrix_local).T @ \
        _rotation(bones[b.hand].matrix_local) @ np.asarray(axis)
    for f, bend in zip(figures.frames, figures.bends):
        bpy.context.scene.frame_set(f)
        hand_axis[f] = mw @ _rotation(pb[b.hand].matrix) @ np.asarray(axis)
        rest_axis[f] = mw @ _rotation(pb[b.forearm].matrix) @ offset
        hinge[f], basis[f] = _arm_hinge(arm, b)
        if bend > naturalness.FORCED_FROM and \
                relaxed_hand_touches(arm, info, check, tris, margin):
            forced.add(f)
    # a hand bent at a forced frame g cannot be straight the next: its bend changes by at
    # most the turn bound relative to the forearm a frame, and its axis in space by at most
    # the bound in space, so at frame f it is still at least the forced bend less the one
    # bound, and at least its axis's angle at g from the rest axis at f less the other,
    # for each frame away
    bound = settings.hand_turn_speed / frame_rate()
    space = settings.hand_space_turn_speed / frame_rate()
    bends = dict(zip(figures.frames, figures.bends))

    def degrees(u, v):
        return float(np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v),
                                                  -1.0, 1.0))))

    least = {f: max((max(bends[g] - bound * abs(f - g),
                         degrees(hand_axis[g], rest_axis[f]) - space * abs(f - g))
                     for g in forced), default=0.0)
             for f in figures.frames}
    # where that bound leaves a frame over 45°, the hand's whole frame as Reach models it
    # (its direction and the elbow's hinge, :func:`least_model_bend`)
    for f in figures.frames:
        if bends[f] > naturalness.MAX_BEND_MAX and f not in forced and \
                least[f] <= naturalness.MAX_BEND_MAX:
            least[f] = max(least[f], least_model_bend(f, forced, hand_axis, rest_axis, hinge,
                                                      basis, bound, space))
    over = [f for f, bend in bends.items() if bend > naturalness.MAX_BEND_MAX and
            f not in forced and least[f] <= naturalness.MAX_BEND_MAX]
    free = [bend for f, bend in bends.items()
            if f not in forced and least[f] <= naturalness.FORCED_FROM]
    print(f"FORCED by {sorted(named)} on {sorted(forced)}; over {over}; unforced mean "
          f"{np.mean(free) if free else 0.0:.1f}")
    assert not over, f"bent beyond 45° where a relaxed hand is clear: frames {over}"
    assert not free or np.mean(free) <= naturalness.MEAN_BEND_MAX
