"""What a new user met in Blender 3.4.1's interface (under Xvfb) with Reach on a small
character (0.2 m tall, armature scale 0.0012, as a Mixamo import): one interface session
(``scripts/gui_user.py``) clicks the panel's buttons, moves the target with G and presses
Ctrl+Z on the X display; these tests check what it recorded, read from the sidebar and the
screen's popups as Blender drew them, and its screenshots (``out/gui-user/``)."""

import json
import shutil

import pytest
from binhost import ROOT, SCRIPTS, output, read_png

OUT = ROOT / "out" / "gui-user"


@pytest.fixture(scope="module")
def user(gui_tools, profile, small_scene) -> dict:
    run_dir = profile.root / "gui-user"
    run_dir.mkdir(exist_ok=True)
    proc = profile.blender_run_gui(small_scene["path"], "--python", SCRIPTS / "gui_user.py", "--",
                                   run_dir, small_scene["armature"], small_scene["target"],
                                   timeout=540)
    (run_dir / "blender.log").write_text(f"exit {proc.returncode}\n--- stdout\n{proc.stdout}"
                                         f"\n--- stderr\n{proc.stderr}")
    shutil.rmtree(OUT, ignore_errors=True)
    shutil.copytree(run_dir, OUT, dirs_exist_ok=True)
    assert (run_dir / "session.json").is_file(), output(proc)
    session = json.loads((run_dir / "session.json").read_text())
    assert "error" not in session, session["error"] + "\n" + output(proc)
    assert session.get("ok"), output(proc)
    session["steps_by_name"] = {f"shot:{s['name']}" if s["step"] == "screenshot" else s["step"]: s
                                for s in session["steps"]}
    session["stdout"] = proc.stdout
    session["shots"] = {p.stem: read_png(p) for p in run_dir.glob("*.png")}
    return session


def words(lines):
    return " ".join(lines).split()


def holds(outer, inner) -> bool:
    """Is the word list ``inner`` a contiguous part of ``outer``?"""
    n = len(inner)
    return any(outer[i:i + n] == inner for i in range(len(outer) - n + 1))


def clipped(drawn):
    return [(given, shown) for given, shown in drawn if "…" in shown and "…" not in given]


def test_live_status_wraps_like_the_result_panel(user):
    """Live's status, for a target just beyond reach (a long "leaning would reach it"
    message) and one 5 m away, as the Live panel drew it: every word of the status lines,
    in order, and no label clipped ("…" in the middle of a line)."""
    for name in ("Near", "Far"):
        live = user["steps_by_name"][f"live status {name}"]
        assert live["active"] and live["drawn"], live
        assert live["reason"] in ("needs_lean", "needs_step"), live
        assert len(" ".join(live["computed"])) > 150, live["computed"]
        drawn = [given for given, _shown in live["drawn"]]
        assert holds(words(drawn), words(live["computed"])), (drawn, live["computed"])
        assert not clipped(live["drawn"]), clipped(live["drawn"])


def test_one_ctrl_z_after_live_restores_the_pose_from_before_live(user):
    """Live on, the target moved twice with G (two undo steps, each saved with the arm
    wherever the search had got to), Live off, one Ctrl+Z: the arm exactly as before Live,
    the target where the moves left it."""
    u = user["steps_by_name"]["live undo"]
    before, shown, off, undone = u["before"], u["shown"], u["off"], u["undone"]
    assert u["on"]["active"] and shown["active"] and not off["active"]
    assert u["moves"][0] != before["target"] and u["moves"][1] != u["moves"][0], u["moves"]
    assert shown["target"] == u["moves"][1]
    assert shown["pose"] != before["pose"], "Live posed the arm"
    assert off["pose"] == shown["pose"], "turning Live off leaves the pose on screen"
    changed = sorted(b for b in before["pose"] if undone["pose"][b] != before["pose"][b])
    assert not changed, f"after one Ctrl+Z these bones differ from before Live: {changed}"
    assert undone["target"] == shown["target"], "the target's moves stay"


def test_a_far_target_is_a_step_away_though_the_body_axis_leans(user):
    """5 m ahead and 1 cm below the shoulder. The body's up axis read from the rig's bones
    leans a few degrees, which puts the target more than 1.5 arm lengths above or below
    the shoulder along it (the old reason: "above what the arm reaches"); the reason is
    the step, by the distance."""
    far = user["steps_by_name"]["far"]
    assert abs(far["along_body_up"]) > 1.5 and far["below_in_world"] > 0, far
    assert 1.0 < far["body_tilt_deg"] < 15.0, far
    assert far["reason"] == "needs_step", far["message"]
    assert "above" not in far["message"] and "below" not in far["message"]
    assert "a step of at least" in far["message"], far["message"]
    assert not clipped(far["result_text"]), clipped(far["result_text"])


def test_auto_names_its_arm_and_a_failure_shows_no_empty_statistics(user):
    """Arm = Auto, the target in the box round the resting left hand: the Result panel as
    drawn names the left arm in the reason, and shows no statistics of the search that
    never ran."""
    auto = user["steps_by_name"]["auto"]
    task = auto["result"]["tasks"][0]
    assert task["arm"] == "left" and not task["success"], task
    drawn = [given for given, _shown in auto["drawn"]]
    text = " ".join(drawn)
    assert "Left arm (Auto): the start pose is inside 'Table'" in " ".join(text.split()), drawn
    for empty in ("nodes 0", "path 0.00", "f_R", "frames", "search 0 ms"):
        assert empty not in text, (empty, drawn)
    assert words(drawn) == words(auto["computed"]), (drawn, auto["computed"])
    assert not clipped(auto["drawn"]), clipped(auto["drawn"])


def test_a_refused_bake_pops_up_short_and_says_all_in_the_result_and_log(user):
    """The armature slides while the arm would reach; Bake clicked. The popup Blender shows
    fits in the window and is short; the whole reason is in the Result panel (drawn, none
    of it clipped), in the Info log and on the console; nothing was keyed."""
    r = user["steps_by_name"]["refusal"]
    window = user["steps_by_name"]["start"]["window"]
    assert r["result_changed"], "the Result panel still shows the run before"
    reason = r["result"]["refused"]
    assert "its own animation moves the body" in reason and len(reason) > 200, reason
    assert r["popups"], "no popup"
    for popup in r["popups"]:
        xmin, xmax = popup["rect"][:2]
        assert 0 <= xmin and xmax <= window[0], (popup["rect"], window)
        text = " ".join(b["given"] for b in popup["buttons"])
        assert len(text) <= 160 and "Bake refused" in text, text
    drawn = [given for given, _shown in r["drawn"]]
    assert holds(words(drawn), words([reason])), drawn
    assert not clipped(r["drawn"]), clipped(r["drawn"])
    assert reason in r["info_log"], r["info_log"][-2000:]
    assert reason in user["stdout"]
    assert r["keys"] == 3, "only the user's own location keys"


def test_the_target_field_leaves_out_what_is_not_a_target(user):
    """Each object's name typed into the Target field (opened with a click) and Enter
    pressed: the field takes a target ("Inside"), but not the camera, the light, the
    armature or Reach's own objects (Blender: "Failed to find")."""
    typed = user["steps_by_name"]["target list"]["typed"]
    objects = user["steps_by_name"]["target list"]["objects"]
    opened = user["steps_by_name"]["target list"]["opened"]
    assert all(opened.values()), f"the click did not open the field's list: {opened}"
    assert typed["Inside"] == "Inside", typed
    for name, took in typed.items():
        if name == "Inside":
            continue
        assert took != name, f"the Target field took {name} ({objects.get(name)})"
        assert not took.startswith("Reach "), typed
