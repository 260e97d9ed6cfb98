"""The body under the arm, after the arm's plans (stage 4 of :class:`.pipeline.
PipelineRun`; issue 41, stages 2–5 of ``docs/design/core.md``'s whole-body reach).

With Lean on, a single reach (or a sequence or guided reach, :mod:`..core.whole_body`)
whose target the arm and chest could not reach is planned again with the trunk leaning
or the figure squatting (:func:`.lean.plan`), and where that does not reach either, with a
step toward it first (:func:`.step.plan`). A reach to one target the chest turned past
Table 1's for is planned with a lean as well, which is taken where it costs the trunk
less (:mod:`..core.effort`). What the body does not do is said in the
refused plans' messages: a target the character carries, obstacles that move, several
reaches.
"""

from __future__ import annotations

import numpy as np

from . import lean as lean_mod
from . import rig as rig_mod
from . import step as step_mod
from ..core.effort import trunk_effort, twist_for_reach, twist_past_table1
from .carried import carrying_bone


def plan(run) -> None:
    """The body for ``run`` (a :class:`.pipeline.PipelineRun` whose arm is planned): sets
    its ``lean`` and ``step``, and ``plans[0]`` to the reach from where they end."""
    settings = run.settings
    if not settings.lean:
        return
    carried = [(t.name, b) for t in run.targets
               if (b := carrying_bone(t, run.armature)) is not None]
    if len(run.plans) == 1 and carried:
        lean_mod.note_carried(run.plans[0].plan, *carried[0])
    elif len(run.plans) == 1 and not run.moving and run.frame_obstacles is None:
        if run.plans[0].plan.success:
            _instead_of_twist(run)
            return
        run.lean, run.plans[0] = lean_mod.plan(run.context, run.armature, run.info,
                                               run.planner, run.plans[0])
        if run.lean is None and not run.plans[0].plan.success:
            _step(run)
    elif len(run.plans) == 1 and run.moving:
        lean_mod.note_moving(run.plans[0].plan, sorted(run.moving))
    elif len(run.plans) > 1:
        lean_mod.note_several([k.plan for k in run.plans])


def _instead_of_twist(run) -> None:
    """Where the reach (to one target: a single reach, or a sequence or guided reach with
    one) turned the chest past Table 1's to bring its target within reach and a lean would
    cost the trunk less (:func:`~..core.effort.twist_for_reach`), the lean (no squat: the
    upright reach reached), taken where it is planned and its
    :func:`~..core.effort.trunk_effort` (its lean, and its own chest's turn past Table
    1's) is still below the upright reach's: sets ``run.lean`` (its ``spared_twist``) and
    ``plans[0]``; else the upright reach stays, as planned."""
    upright = run.plans[0]
    costed = twist_for_reach(upright.plan)
    if costed is None:
        return
    twist, s = costed[0], run.settings
    ceiling = trunk_effort(twist, 0.0, s)
    lean, keyed = lean_mod.plan(run.context, run.armature, run.info, run.planner, upright,
                                aim=0, ceiling=ceiling)
    if lean is None or trunk_effort(twist_past_table1(keyed.plan), lean.phase.lean.angle, s) \
            >= ceiling:
        return
    lean.spared_twist = twist
    run.lean, run.plans[0] = lean, keyed


def _step(run) -> None:
    """Where no lean reaches, a step toward the target, then the reach (and a lean) from
    where it ends (:func:`.step.plan`): ``run.step``; ``run.info`` becomes the rig read
    there."""
    first = np.array(run.targets[0].matrix_world.translation)
    side, overrides = run.info.side, run.request.overrides

    def reread():
        return rig_mod.build(run.armature, side, overrides, target=first)

    found, run.plans[0] = step_mod.plan(run.context, run.armature, run.info, run.planner,
                                        run.plans[0], reread, run.request.bake_closest)
    if found is not None:
        run.step, run.lean, run.info = found, found.lean, found.info
