"""Bake plans as keyframes: one key per frame on the bones that move (:func:`bake`).

The plan's poses become bone matrices and rotation channels (:mod:`.bone_matrices`),
settled against the evaluated rig where constraints move the arm (:mod:`.settle`), written
in bulk into the armature's action (:mod:`.fcurves`); then the instants between keys are
checked as Blender interpolates them (:mod:`.straighten`). Existing keys of the baked
channels inside the baked frame range are replaced; every other key stays.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import Plan, ReachError
from .bone_matrices import ROLE_ORDER, bone_roles, channel_values, local_matrices, moves_chest, \
    target_matrices
from .fcurves import Channels, ensure_action, write_channel
from .hand_reading import hand_group
from .settle import settle
from .straighten import straighten


@dataclass
class KeyedPlan:
    """One plan as the pipeline hands it to the bake: ``plan`` (core Plan) keyed from
    ``first_frame`` on; ``checkers``, the collision checkers of the obstacles it was
    planned among (one per pose, or one for all; empty: its instants between keys are not
    checked, :mod:`.straighten`); ``keyable``, whether a Bake keys it (it succeeded, or
    the user bakes the closest approach); ``moving``, the same plan on the trunk as the rig
    moves at its frames, where the bake is posed otherwise (a ready reach before a lean is
    keyed on the leaned trunk and moves on the upright one): the instants between its keys
    are checked on it."""

    plan: Plan
    first_frame: int
    checkers: tuple = ()
    keyable: bool = True
    moving: Plan | None = None

    @property
    def checked(self) -> Plan:
        """The plan whose world joints the instants between keys are checked against."""
        return self.plan if self.moving is None else self.moving

    @property
    def pair(self) -> tuple:
        """(plan, first frame), as :class:`.pipeline.Outcome` and :func:`.body.check` take
        plans."""
        return self.plan, self.first_frame

    @classmethod
    def of(cls, item) -> KeyedPlan:
        """``item`` itself if it is a KeyedPlan, else one of a (Plan, first frame) pair."""
        return item if isinstance(item, cls) else cls(*item)


@dataclass
class BakeResult:
    """What a bake wrote: the action's name, the keyed bones and the frames."""

    action: str
    bones: list            # keyed bone names, hierarchy order
    frames: tuple          # (first, last) frame written
    #: the largest distance left between a planned bone and where the keys put it, as a
    #: share of the arm's length (:func:`.settle.settle`; 0 for rigs that need no settling)
    residual: float = 0.0
    #: per plan, the spans between two keys made linear because Blender's curve between
    #: them came closer to an obstacle than the planner allows (:func:`.straighten.straighten`)
    linear_spans: list = field(default_factory=list)
    #: per plan, the spans still closer than that after it (0 when every instant is clear)
    close_spans: list = field(default_factory=list)
    #: the report's figures of the chest's turn shared down the spine
    #: (:meth:`.spine_share.SpineShare.key`)
    spine: dict = field(default_factory=dict)


def bake(context, armature, info, plans, new_action=False, then=None,
         start_pose=None, spine=None) -> BakeResult:
    """Write keys for ``plans`` on ``armature``, whose arm ``info`` (:class:`.rig.RigInfo`)
    describes: one key per frame on each keyed bone's rotation channels, the hand's palm
    siblings and the chest (when a plan turns it) included, and the IK/FK switch set to
    FK. ``plans``: :class:`KeyedPlan` records (or (Plan, first frame) pairs: no checkers),
    in frame order; where every one has checkers, the instants between keys are checked
    as Blender interpolates them (:func:`.straighten.straighten`). ``new_action``: key a
    copy of the armature's action. ``then(result)``: called with the :class:`BakeResult`
    once the plans are keyed, before that check (a lean keys the trunk there, so the check
    sees the trunk move). ``start_pose``: every bone's armature-space matrix in the pose
    the first plan starts from, where that is not the pose now (a lean's: :func:`.lean.
    carried_start`). ``spine``: the :class:`.spine_share.SpineShare` that spreads the
    chest's turn down the spine, keyed after ``then`` (None: the chest alone). Raises
    ReachError if a keyed bone is missing. Returns a :class:`BakeResult`."""
    plans = [KeyedPlan.of(p) for p in plans]
    bmap = info.bones
    pose = armature.pose.bones
    mw = np.array(armature.matrix_world)
    mw_inv = np.linalg.inv(mw)
    if start_pose is None:
        start_pose = {pb.name: np.array(pb.matrix) for pb in pose}

    keyed, reference = bone_roles(info, moves_chest([k.pair for k in plans]))
    for name in keyed.values():
        if name not in pose:
            raise ReachError(f"bone '{name}' is missing from armature '{armature.name}'")

    start_world = {role: mw @ start_pose[ref] for role, ref in reference.items()}
    chest_head = (mw @ start_pose[bmap.keyed_chest])[:3, 3]

    first = plans[0].first_frame
    # the FK/IK switch first: the arm's controls only move it in FK, and settling evaluates
    switches = [(bone_name, prop) for side, (bone_name, prop) in bmap.ik_fk.items()
                if side == info.side]
    for bone_name, prop in switches:
        pose[bone_name][prop] = 1.0
        armature.update_tag()
    # every plan's channel matrices, settled against the evaluated rig before the action is
    # touched (a newly assigned action or new keys would be evaluated over the pose being
    # measured)
    baked, residual = [], 0.0
    for plan, frame0 in (k.pair for k in plans):
        targets = target_matrices(info, plan, start_world, chest_head, plans[0].plan)
        targets_arm = {role: mw_inv[None] @ m for role, m in targets.items()}
        locals_ = local_matrices(armature, keyed, targets_arm, start_pose)
        residual = max(residual, settle(context, armature, keyed, reference, targets_arm,
                                        locals_, start_pose))
        baked.append((locals_, frame0 + np.arange(len(plan.poses), dtype=float)))
    action = ensure_action(armature, new_action)
    channels = Channels(armature, action)
    last = first
    curves = []
    for locals_, frames in baked:
        for name, mats in locals_.items():
            path, values = channel_values(pose[name], mats)
            full = f'pose.bones["{name}"].{path}'
            write_channel(channels, full, values, frames, name)
            curves += [(full, i) for i in range(values.shape[1])]
        last = max(last, int(frames[-1]))
    for bone_name, prop in switches:
        write_channel(channels, f'pose.bones["{bone_name}"]["{prop}"]',
                      np.ones((2, 1)), np.array([first, last], float), bone_name)
    context.view_layer.update()
    order = [n for r in ROLE_ORDER if r in keyed
             for n in (hand_group(armature, keyed[r]) if r == "hand" else (keyed[r],))]
    result = BakeResult(action.name, order, (first, last), residual)
    if then is not None:
        then(result)
    if spine is not None and "chest" in keyed:
        curves += _spread(context, armature, spine, keyed["chest"], plans, result, first, last)
    if all(k.checkers for k in plans):
        curves = [channels.bag.fcurves.find(path, index=i) for path, i in dict.fromkeys(curves)]
        result.linear_spans, result.close_spans = straighten(
            context, armature, info, plans, curves, reference)
    return result


def _spread(context, armature, spine, chest: str, plans, result: BakeResult, first: int,
            last: int) -> list:
    """Key ``spine`` (:class:`.spine_share.SpineShare`) on frames ``first``..``last``, its skin
    held clear of the obstacles of ``plans`` where one checker holds them all (they do not
    move); its figures into ``result.spine`` and its bones before the others. Returns the
    rotation channels it keyed, as (data path, index) pairs."""
    checkers = {id(c): c for k in plans for c in k.checkers}
    result.spine, more = spine.key(context, armature, chest, first, last,
                                   next(iter(checkers.values())) if len(checkers) == 1
                                   else None)
    # hierarchy order, the hand last (readers take the last keyed bone for the hand)
    result.bones = [b for b in dict.fromkeys(p.split('"')[1] for p, _i in more)
                    if b not in result.bones] + result.bones
    return more
