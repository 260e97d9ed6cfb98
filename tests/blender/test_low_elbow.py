"""The elbow kept low along a path (``core.elbow``) on a real rig.

GoMakeHuman's chase (``test_every_rig``'s everyday chase, built round the rig and scaled by
its arm) goes down past the chase's box. The search's strongest-first swivels lift the elbow
over the hand there: chicken-wing frames, measured on Blender's evaluated bones by
:mod:`verification.naturalness`, which shares no code with the planner. With the swivel and
the hand chosen along the whole chase, no frame is a chicken wing, the report says so, and
the hand still turns at most its bound a frame.

The demo's collision-free reach and the first reach of its rotation task, down past the
crate, showed this until the hand was kept clear as skinned (``core.hand_shape``): since
then the search's own swivels no longer lift the elbow there, so those scenes show nothing.
"""

from __future__ import annotations

from test_every_rig import rig_file  # noqa: F401  (the fixture)
from test_natural_arm import bake as bake_natural

from verification import naturalness


def bake(addon, rig_file, kind, scene, settings):  # noqa: F811
    """Bake ``scene`` round rig ``kind`` with ``settings``: (its result, the naturalness
    figures measured on the evaluated bones)."""
    arm, info, outcome = bake_natural(addon, rig_file, kind, scene, settings)
    (result,) = outcome.results
    assert result.success, result.message
    b = info.bones.arms["right"]
    figures = naturalness.measure(arm, b.upper_arm, b.forearm, b.hand,
                                  range(result.frame_start, result.frame_end + 1))
    return result, figures


def test_no_chicken_wing_down_past_the_box(addon, rig_file):  # noqa: F811
    # the chase follows its target frame by frame in both: where that lifts the elbow, a
    # chase would otherwise plan ahead instead (Chase plans ahead), which is not this pass
    settings = addon.core.Settings
    greedy, greedy_figures = bake(addon, rig_file, "gomakehuman", "chase",
                                  settings(elbow_comfort=0.0, chase_plan_ahead=False))
    # the search's own swivels lift the elbow here (else this test shows nothing)
    assert greedy_figures.wing_frames, "the scene no longer lifts the elbow"
    relaxed, figures = bake(addon, rig_file, "gomakehuman", "chase",
                            settings(chase_plan_ahead=False))
    assert not figures.wing_frames, f"chicken wing at frames {figures.wing_frames}"
    assert relaxed.stats["chicken_wing_frames"] == 0            # and the report says so
    assert relaxed.stats["max_hand_turn_deg_per_frame"] <= 15.0 + 1e-6
