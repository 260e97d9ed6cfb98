"""Esc cancels a running Plan or Bake in Blender 3.4.1's interface and leaves the scene as
it was. The ``gui`` session gives the user keys of their own (one undo step) on the bone the
bake would key, starts a long Bake (a fine step) as the panel's button does, checks it is
running, presses Esc on the X display with xdotool, and records everything a bake could
touch before and after; then it presses undo and redo.

Esc can only land between the operator's timer slices, i.e. at one of the pipeline's
yields; ``tests/blender/test_bake.py::test_stopping_at_any_step_changes_nothing`` closes the
pipeline at each of them in turn (the last one, just before the keys, included)."""


def test_escape_cancels_a_running_bake_with_nothing_baked(gui):
    esc = gui["steps_by_name"]["escape"]
    invoked = gui["steps_by_name"]["long bake invoked"]
    assert invoked["result"] == ["RUNNING_MODAL"] and invoked["running"]
    running = esc["before_escape"]
    assert running["running"] and running["progress"] < 0.9, running
    assert not esc["running_after"], "still running after Esc"
    assert esc["status"] == "cancelled"
    assert esc["changed"] == [], f"changed by the cancelled bake: {esc['changed']}"
    # the user's keys are there, untouched (``changed`` compares every key of every curve)
    assert esc["before_action"] is not None and esc["after_action"] == esc["before_action"]
    assert esc["before_keys"] == esc["after_keys"] > 0


def test_undo_after_escape_is_the_users_own_step(gui):
    """The cancelled bake left no undo step and broke none: one undo after Esc removes the
    user's own keys (the file is as before them), redo brings them back exactly."""
    undo = gui["steps_by_name"]["undo after escape"]
    assert undo["clean_keys"] == 0 and undo["undone_keys"] == 0
    assert undo["undone_vs_clean"] == [], undo
    assert undo["redone_keys"] > 0 and undo["redone_vs_before"] == [], undo
