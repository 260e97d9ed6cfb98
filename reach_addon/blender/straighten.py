"""Straightening: check the instants between keys as Blender interpolates them, and make
linear the spans that come closer to an obstacle than the planner allows
(:func:`straighten`).
"""

from __future__ import annotations

import numpy as np
from mathutils import Quaternion

from ..core.collision import MIN_CLEARANCE
from .settle import driven


def _carriers(info, reference, arm) -> tuple:
    """The bone that carries each of the arm's five joints (sternum, shoulder, elbow,
    wrist, hand end) and the ends of its hand shape's capsules (``Plan.world_joints``'
    rows after them): the chest, upper arm, forearm, hand, hand, and the hand for each
    end (reference bones). ``arm``: the plans' arm model (without its hand shape where
    ``Settings.hand_as_skinned`` is off)."""
    return (info.bones.keyed_chest, reference["upper_arm"], reference["forearm"],
            reference["hand"], reference["hand"]) + (reference["hand"],) * (
                2 * len(arm.hand_shape))


def straighten(context, armature, info, plans, curves, reference) -> tuple:
    """Check the instants between keys as Blender interpolates them, and make linear the
    spans that come too close.

    Inputs: ``plans`` as keyed (:class:`.bake.KeyedPlan`), each with the collision
    checkers of its obstacles (their margin is not used); ``curves`` the keyed F-curves;
    ``reference`` role → the bone whose place the plan describes
    (:func:`.bone_matrices.bone_roles`).

    Each span between two keys is evaluated by Blender at ``Settings.instants_per_frame``
    instants (``scene.frame_set(f, subframe=s)``); the arm's joints are carried by their
    bones (:func:`_carriers`) from where the plan puts them at the two keys, blended by
    ``s``, and measured against the obstacles of both keys to within
    :data:`STRAIGHTEN_TOLERANCE` arm lengths. A span must keep half the planner's
    clearance where both of its keys keep it, and must not touch where they are within
    it; a span with a key in contact is the planner's own and is not changed. A span that
    comes too close gets linear interpolation on every keyed channel (the key at its start
    decides); if that comes too close as well, the user's interpolation is put back and
    the span counted. Spans whose keys turn the arm too little to come that close
    (:func:`_turn_reader`) are not evaluated. The scene's frame is put back.

    Returns per plan (spans made linear, spans still too close after it)."""
    scene = context.scene
    bones = armature.pose.bones
    mw = np.array(armature.matrix_world)
    carriers = _carriers(info, reference, plans[0].plan.arm if plans else info.arm)
    # every curve's keys by frame, to find the key that starts a span
    keys = []
    for fc in curves:
        pts = fc.keyframe_points
        co = np.empty(2 * len(pts), np.float32)
        pts.foreach_get("co", co)
        keys.append((pts, {int(round(x)): i for i, x in enumerate(co[0::2].tolist())}))

    def carried(frame, sub=0.0):
        scene.frame_set(frame, subframe=sub)
        return [mw @ np.array(bones[c].matrix) for c in carriers]

    def local(mats, joints):
        return [np.linalg.solve(m, np.append(p, 1.0))[:3] for m, p in zip(mats, joints)]

    turned = _turn_reader(armature, curves, carriers)
    chest_head = (mw @ np.array(bones[carriers[0]].matrix))[:3, 3]
    now = (scene.frame_current, scene.frame_subframe)
    try:
        return _straighten_plans(plans, keys, carried, local, turned, chest_head)
    finally:
        scene.frame_set(now[0], subframe=now[1])


def _turn_reader(armature, curves, carriers):
    """A bound on how far the keys turn the arm between two keys, read from the keyed
    curves alone (``FCurve.evaluate``, no scene evaluation): ``turned(f, s)`` gives, for
    the instant ``f`` + ``s``, the sum over the keyed bones of the angle (radians) each
    bone's own rotation has turned from key ``f`` and from key ``f`` + 1. No joint moves
    farther than that sum times the distance from the chest to the hand's end (each
    bone turns the joints it carries about its own head, and none is farther from it).
    None on a rig whose keyed bones also move through constraints or drivers, where the
    curves do not tell the whole motion."""
    groups = {}
    for fc in sorted(curves, key=lambda c: c.array_index):
        name = fc.data_path.split('"')[1]
        mode = fc.data_path.rsplit(".", 1)[-1]
        groups.setdefault((name, mode), []).append(fc)
    if driven(armature, {name for name, _m in groups} | set(carriers)):
        return None

    def rotation(mode, values):
        if mode == "rotation_quaternion":
            return Quaternion(values).normalized()
        return Quaternion(values[1:], values[0]).normalized()       # axis-angle

    def values(x):
        return [[c.evaluate(x) for c in fcs] for fcs in groups.values()]

    at_key = {}             # the curves at each key, read once for all its instants

    def turned(f, s):
        out = [0.0, 0.0]
        now = values(f + s)
        for i, key in enumerate((f, f + 1)):
            if key not in at_key:
                at_key[key] = values(key)
            for (_name, mode), a, b in zip(groups, now, at_key[key]):
                if mode == "rotation_euler":
                    # each channel an angle: their sum bounds the whole turn
                    out[i] += sum(abs(x - y) for x, y in zip(a, b))
                else:
                    out[i] += rotation(mode, a).rotation_difference(rotation(mode, b)).angle
        return out
    return turned


#: how exactly :func:`straighten` measures clearances, as a share of the arm's length
STRAIGHTEN_TOLERANCE = 1e-4


#: ... and the clearance of keys well clear of the margin (only a bound for the instants)
KEY_TOLERANCE = 2e-3


def _span_touches(carried, f, n, a, b, checkers, need, settings, keys) -> bool:
    """Does the arm come closer than ``need`` to the obstacles (of any of ``checkers``)
    at one of the ``n`` - 1 instants Blender evaluates between keys ``f`` and ``f`` + 1?
    Each joint is carried by its bone from its place at either key (``a``, ``b``:
    bone-local points), blended by the instant. ``keys``: ((joints, clearance) of both
    keys): no joint moves farther than δ from a key's place, so no capsule comes nearer
    than that key's clearance - δ; only instants this bound leaves open are measured."""
    for i in range(1, n):
        s = i / n
        mats = carried(f, s)
        world = np.array([(m @ np.append((1.0 - s) * p + s * q, 1.0))[:3]
                          for m, p, q in zip(mats, a, b)])
        bound = max(c - float(np.linalg.norm(world - j, axis=1).max()) for j, c in keys)
        if bound >= need:
            continue
        if _pose_clearance(checkers, world, settings, need) < need:
            return True
    return False


def _pose_clearance(checkers, joints, settings, horizon, share=STRAIGHTEN_TOLERANCE) -> float:
    """A pose's least clearance (figure units, no margin) against each of ``checkers``'
    obstacles, to ``share`` of the arm's length above it at most, looking no farther than
    ``horizon`` (beyond it: at least ``horizon``)."""
    tolerance = share * checkers[0].arm.arm_length
    return min(c.pose_clearance(joints, horizon + tolerance, tolerance,
                                bool(settings.check_hand)) for c in checkers)


def _straighten_plans(plans, keys, carried, local, turned, chest_head) -> tuple:
    """:func:`straighten`'s loop over every span of every plan."""
    linear, close = [], []
    for keyed in plans:
        plan, frame0, own = keyed.checked, keyed.first_frame, list(keyed.checkers)
        linear.append(0)
        close.append(0)
        settings = plan.settings
        n = max(2, int(settings.instants_per_frame))
        joints = plan.world_joints()
        length = plan.arm.arm_length
        # the planner's, between keys (half the clearance, at least MIN_CLEARANCE)
        margin = max(0.5 * settings.clearance, MIN_CLEARANCE) * length
        ends = [None] * len(joints)                     # each key's clearance, once
        before = None
        # keys farther than this need no exact clearance: the bound of _span_touches
        horizon = margin + 0.25 * length
        # the farthest any joint is from the head of a bone that carries it: the chest's,
        # or the clavicle's, upper arm's, ... (at most the chain's length from it)
        reach = max(float(np.linalg.norm(joints - chest_head, axis=2).max()),
                    float(np.linalg.norm(joints[0, 1] - joints[0, 0])) + length
                    + plan.arm.hand_length)
        coarse = KEY_TOLERANCE * length
        for k in range(len(plan.poses) - 1):
            pair = list({id(c): c for c in (own[min(k, len(own) - 1)],
                                            own[min(k + 1, len(own) - 1)])}.values())
            for i in (k, k + 1):
                if ends[i] is None or len(pair) > 1:
                    # coarsely first: a key clear of the margin by more than that
                    # tolerance needs no more (its clearance only bounds the instants
                    # near it, from below); one nearer is measured exactly
                    ends[i] = _pose_clearance(pair, joints[i], settings, horizon,
                                              KEY_TOLERANCE) - coarse
                    if ends[i] < margin:
                        ends[i] = _pose_clearance(pair, joints[i], settings, horizon)
            if min(ends[k], ends[k + 1]) < 0.0:
                # a key in contact: a start in contact being left, the planner's own
                before = None
                continue
            # the planner's margin between keys where both keys keep it; elsewhere (a
            # motion leaving a start in contact) no contact
            need = (margin if min(ends[k], ends[k + 1]) >= margin else 0.0) \
                - STRAIGHTEN_TOLERANCE * length
            f = frame0 + k
            if turned is not None and all(
                    max(ends[k] - ta * reach, ends[k + 1] - tb * reach) >= need
                    for ta, tb in (turned(f, i / n) for i in range(1, n))):
                before = None      # the keys turn the arm too little to come that close
                continue
            a = before if before is not None else local(carried(f), joints[k])
            b = local(carried(f + 1), joints[k + 1])
            before = b

            def touches(span=(f, n, a, b, pair, need, settings,
                              ((joints[k], ends[k]), (joints[k + 1], ends[k + 1])))):
                return _span_touches(carried, *span)

            if not touches():
                continue
            starts = [(pts[i], pts[i].interpolation) for pts, at in keys
                      if (i := at.get(int(f))) is not None]
            for point, _was in starts:
                point.interpolation = "LINEAR"
            if touches():
                # the straight line comes too close as well (the planner's angles and the
                # bones' rotations part between keys): the user's interpolation stays
                for point, was in starts:
                    point.interpolation = was
                close[-1] += 1
            else:
                linear[-1] += 1
    return linear, close
