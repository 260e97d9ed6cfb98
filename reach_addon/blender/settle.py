"""Settling: correct computed channel matrices against the evaluated rig, where its
constraints or drivers move the planned bones otherwise than by parenting (Rigify's spine
controls), so the keyed bones put the arm where the plan does (:func:`settle`).
"""

from __future__ import annotations

import math

import numpy as np
from mathutils import Matrix, Vector

from .bone_matrices import ROLE_ORDER, affine_inverse, palm_targets


def driven(armature, names) -> bool:
    """Whether any of ``names`` or their ancestors has a constraint or a driver: then what a
    bone's keys do depends on more than its parents' keys, and the pose must be evaluated."""
    bones = armature.pose.bones
    seen = set()
    for name in names:
        pb = bones[name]
        while pb is not None and pb.name not in seen:
            seen.add(pb.name)
            if any(c.enabled and c.influence > 0 for c in pb.constraints):
                return True
            pb = pb.parent
    ad = armature.animation_data
    drivers = ad.drivers if ad is not None else ()
    return any(d.data_path.startswith("pose.bones[") and
               d.data_path.split('"')[1] in seen for d in drivers if '"' in d.data_path)


#: Settling: corrections per bone and frame at most, and the turn (radians: the arm's
#: length times it, at the far end) it leaves.
SETTLE_ROUNDS = 4
SETTLE_TOLERANCE = 1e-4


def _turn_error(actual, target) -> float:
    """How far a bone's armature-space matrix is turned from its target (the spectral norm
    of the difference of their unit axes: about the angle, in radians). Only turns: keys
    on rotation channels cannot move a head."""
    ra = actual[:3, :3] / np.linalg.norm(actual[:3, :3], axis=0)
    rt = target[:3, :3] / np.linalg.norm(target[:3, :3], axis=0)
    return float(np.linalg.norm(ra - rt, 2))


def settle(context, armature, keyed, reference, targets_arm, locals_, start_pose) -> float:
    """Correct ``locals_`` in place (bone → channel matrices (F, 4, 4), from
    :func:`.bone_matrices.local_matrices`) by evaluating the rig, where its constraints or
    drivers make the keyed bones move the planned bones otherwise than by parenting.

    Inputs: ``keyed`` and ``reference`` (role → bone: the bone keyed, the bone whose place
    the plan describes; :func:`.bone_matrices.bone_roles`), ``targets_arm`` (role →
    armature-space targets (F, 4, 4)), ``start_pose`` (bone → armature-space pose matrix
    at the start).

    Per frame, the keyed bones are posed from ``locals_``, the pose evaluated, and role by
    role in hierarchy order (chest, clavicle, upper arm, forearm, hand, palms) each
    reference bone is turned onto its target by turning its keyed bone, to within
    :data:`SETTLE_TOLERANCE` radians in at most :data:`SETTLE_ROUNDS` corrections. Only
    turns are keyed: every bone keeps its own location. Where the rig has moved the
    shoulder, upper arm and forearm are turned so the wrist still lands on the plan's
    (:func:`wrist_kept`). The pose the user had is restored, however this ends. Rigs
    without constraints or drivers on the keyed chain (:func:`driven`) are left as
    computed.

    Returns the largest distance left between a planned joint (each reference bone's head,
    the hand's tail) and where the rig puts it, as a share of the arm's length (0 when
    unchecked)."""
    names = set(keyed.values()) | set(reference.values())
    if all(keyed[r] == reference[r] for r in keyed) and not driven(armature, names):
        return 0.0
    bones = armature.pose.bones
    data = armature.data.bones
    length = data[reference["upper_arm"]].length + data[reference["forearm"]].length
    order = [r for r in ROLE_ORDER if r in keyed]
    touched = list(locals_)
    saved = {n: bones[n].matrix_basis.copy() for n in touched}
    frames = len(next(iter(locals_.values())))
    palms = {}
    if "hand" in keyed:
        palms = palm_targets(armature, keyed["hand"], targets_arm["hand"], start_pose)
        palms.pop(keyed["hand"])
    hand_tail = np.array([0.0, data[reference["hand"]].length, 0.0, 1.0]) \
        if "hand" in reference else None
    # only turns are keyed: each bone keeps the location it has, here as in the baked file
    kept = {n: basis.to_translation() for n, basis in saved.items()}
    worst = 0.0
    try:
        for k in range(frames):
            for name in touched:
                bones[name].matrix_basis = Matrix(locals_[name][k].tolist())
                bones[name].location = kept[name]
            context.view_layer.update()
            goals = [(keyed[r], reference[r], targets_arm[r][k]) for r in order]
            goals += [(p, p, t[k]) for p, t in palms.items()]
            for key, basis in _settle_frame(context, bones, goals, order, kept):
                locals_[key][k] = basis
            worst = max(worst, _residual(bones, reference, targets_arm, k, hand_tail))
    finally:
        for name, basis in saved.items():
            bones[name].matrix_basis = basis
        context.view_layer.update()
    return worst / length


def _settle_frame(context, bones, goals, order, kept) -> list:
    """Turn each keyed bone of ``goals`` [(keyed bone, reference bone, armature-space
    target)], in order, until its reference bone is turned onto its target
    (:func:`settle`); ``order``: the roles of the first goals; ``kept``: each keyed
    bone's location, put back after every turn. Returns [(keyed bone, its channel matrix
    (4, 4) once settled)]."""
    out = []
    for i, (key, ref, target) in enumerate(goals):
        if order[i:i + 3] == ["upper_arm", "forearm", "hand"]:
            # the rig has put the shoulder where it does (chest and clavicle are settled
            # by now): turn upper arm and forearm so the wrist still lands where it was
            # planned
            shoulder = np.array(bones[ref].matrix)[:3, 3]
            upper, fore = wrist_kept(shoulder, target, goals[i + 1][2], goals[i + 2][2][:3, 3])
            goals[i + 1] = (*goals[i + 1][:2], fore)
            target = upper
        for _round in range(SETTLE_ROUNDS + 1):
            actual = np.array(bones[ref].matrix)
            if _turn_error(actual, target) <= SETTLE_TOLERANCE or _round == SETTLE_ROUNDS:
                break
            now = np.array(bones[key].matrix)
            bones[key].matrix = Matrix((target @ affine_inverse(actual) @ now).tolist())
            bones[key].location = kept[key]
            context.view_layer.update()
        out.append((key, np.array(bones[key].matrix_basis)))
    return out


def _residual(bones, reference, targets_arm, k, hand_tail) -> float:
    """The largest distance (armature units) on frame ``k`` between a reference bone's head
    (and the hand's tail, ``hand_tail`` in its bone's space) and its target's."""
    worst = 0.0
    for role, ref in reference.items():
        target = targets_arm[role][k]
        actual = np.array(bones[ref].matrix)
        worst = max(worst, float(np.linalg.norm(actual[:3, 3] - target[:3, 3])))
        if role == "hand":
            worst = max(worst, float(np.linalg.norm((actual @ hand_tail - target @ hand_tail)[:3])))
    return worst


def wrist_kept(shoulder, upper, fore, wrist):
    """Turn targets for the upper arm and the forearm (armature-space matrices, their
    heads at the planned shoulder and elbow) that keep the planned ``wrist`` where the
    rig has put the shoulder instead: the elbow goes to the point of the circle of elbows
    between ``shoulder`` and ``wrist`` (the bones' own lengths) nearest the planned one,
    and each bone turns by the least rotation onto its new direction. Where the wrist is
    beyond the arm's reach from there the arm points straight at it. Returns the two
    matrices, their heads at the new shoulder and elbow."""
    elbow = fore[:3, 3]
    a = float(np.linalg.norm(elbow - upper[:3, 3]))
    b = float(np.linalg.norm(wrist - elbow))
    axis = wrist - shoulder
    d = float(np.linalg.norm(axis))
    if a < 1e-12 or b < 1e-12 or d < 1e-12:
        return upper, fore
    axis = axis / d
    d = min(max(d, abs(a - b)), a + b)
    along = (a * a - b * b + d * d) / (2.0 * d)       # the elbow circle's centre ...
    radius = math.sqrt(max(a * a - along * along, 0.0))    # ... and radius
    side = (elbow - shoulder) - np.dot(elbow - shoulder, axis) * axis
    n = float(np.linalg.norm(side))
    new_elbow = shoulder + along * axis + (radius * side / n if n > 1e-12 else 0.0)

    def turned(m, head, old_dir, new_dir):
        out = m.copy()
        least = Vector(old_dir).rotation_difference(Vector(new_dir)).to_matrix()
        out[:3, :3] = np.array(least) @ m[:3, :3]
        out[:3, 3] = head
        return out

    return (turned(upper, shoulder, elbow - upper[:3, 3], new_elbow - shoulder),
            turned(fore, new_elbow, wrist - elbow, wrist - new_elbow))
