"""Esc cancels a running Plan or Bake in Blender 3.4.1's interface and leaves the scene as
it was. The ``gui`` session starts a long Bake (a fine step) as the panel's button does,
checks it is running, presses Esc on the X display with xdotool, and records everything a
bake could touch before and after."""


def test_escape_cancels_a_running_bake_with_nothing_baked(gui):
    esc = gui["steps_by_name"]["escape"]
    invoked = gui["steps_by_name"]["long bake invoked"]
    assert invoked["result"] == ["RUNNING_MODAL"] and invoked["running"]
    running = esc["before_escape"]
    assert running["running"] and running["progress"] < 0.9, running
    assert not esc["running_after"], "still running after Esc"
    assert esc["status"] == "cancelled"
    assert esc["changed"] == [], f"changed by the cancelled bake: {esc['changed']}"
    assert esc["before_action"] is None and esc["after_action"] is None
    assert esc["before_keys"] == esc["after_keys"] == 0
