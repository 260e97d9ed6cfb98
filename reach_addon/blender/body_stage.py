"""The body under the arm, after the arm's plans (stage 4 of :class:`.pipeline.
PipelineRun`; issue 41, stages 2–5 of ``docs/design/core.md``'s whole-body reach).

With Lean on, a single reach (or a sequence or guided reach, :mod:`..core.whole_body`)
whose target the arm and chest could not reach is planned again with the trunk leaning
or the figure squatting (:func:`.lean.plan`), and where that does not reach either, with a
step toward it first (:func:`.step.plan`). A reach that turned the chest past Table 1's
for a target beyond the arm is planned with a lean as well, which is taken where it
costs the trunk less (:mod:`..core.effort`). What the body does not do is said in the
refused plans' messages: a target the character carries, obstacles that move, several
reaches.
"""

from __future__ import annotations

import numpy as np

from . import lean as lean_mod
from . import rig as rig_mod
from . import step as step_mod
from ..core.effort import reach_effort, twist_for_reach
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
    """Where the reach (a single reach, or a sequence or guided reach) turned the chest
    past Table 1's to bring one of its targets within reach and a lean would cost the
    trunk less there (:func:`~..core.effort.twist_for_reach`), the lean toward that
    target (no squat: the upright reach reached), held through the targets after it and
    taken where it is planned and its :func:`~..core.effort.reach_effort` from that target
    on (its lean, and its own chest's turns past Table 1's, at each arrival) is still
    below the upright reach's: sets ``run.lean`` (its ``spared_twist``) and
    ``plans[0]``; else the upright reach stays, as planned. The targets before it are
    reached upright as they were (:func:`~..core.whole_body.upright_part`)."""
    upright = run.plans[0]
    costed = twist_for_reach(upright.plan)
    if costed is None:
        return
    aim, twist = costed[0], costed[1]
    # the leans tried are weighed one arrival at a time: the upright effort per arrival it
    # would be held through (the whole sum decides, below)
    held = len(upright.plan.task.targets) - aim
    ceiling = reach_effort(upright.plan, 0.0, aim) / held
    lean, keyed = lean_mod.plan(run.context, run.armature, run.info, run.planner, upright,
                                aim=aim, ceiling=ceiling)
    if lean is None:
        return
    # the leaned plan's targets: from ``aim`` where the ones before it were reached upright
    # first, else all of them (the lean before the first: compared over as many)
    first = len(upright.plan.task.targets) - len(keyed.plan.task.targets)
    if reach_effort(keyed.plan, lean.phase.lean.angle) >= reach_effort(upright.plan, 0.0, first):
        return
    lean.spared_twist, lean.spared_at = twist, aim - lean.phase.ready_reaches
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
