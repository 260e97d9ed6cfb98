"""Reach in Blender 3.4.1's interface (under Xvfb): what a user sees in the sidebar and the
viewport while planning and baking. One interface session (the ``gui`` fixture), on a
character 0.2 m tall (armature scale 0.0012, as a Mixamo import), records the live UI and
takes screenshots; these tests check both."""

import numpy as np
import pytest
from binhost import crop, polyline_distance, strongly_red, text_rows


def regions(gui, shot):
    return gui["steps_by_name"][f"shot:{shot}"]["geometry"]["regions"]


def test_reach_tab_shows_the_reach_panel(gui):
    """Turning the sidebar's tabs with the mouse wheel reaches the "Reach" tab, where
    Blender draws Reach's panel in the 3D viewport's sidebar; the sidebar then looks
    different from its first tab."""
    tab = gui["steps_by_name"]["reach tab"]
    assert tab["main_draws"] >= 1 and tab["where"] == ["VIEW_3D", "UI"]
    assert 1 <= tab["wheel_turns"] < 8
    assert gui["draws"]["REACH_PT_main"]["count"] > tab["main_draws"], "redrawn as the session went on"
    ui = regions(gui, "before")["UI"]
    assert ui[2] > 100 and ui[3] > 300, f"sidebar open: {ui}"
    first = crop(gui["shots"]["sidebar_first_tab"], ui).astype(int)
    reach = crop(gui["shots"]["before"], ui).astype(int)
    changed = (np.abs(first - reach).max(-1) > 30).mean()
    assert changed > 0.03, f"only {changed:.1%} of the sidebar changed with the tab"


def test_statistics_are_shown_after_plan_and_bake(gui):
    """After Plan and after Bake the Result sub-panel is drawn with the plan's statistics,
    and the sidebar shows several more lines than before planning. The panel's text is
    read from the sidebar region as Blender drew it (its labels' buttons,
    ``scripts/drawn_text.py``): every line the operator's ``result_lines`` makes of the
    result, in order, and nothing else, wrapped to the sidebar's width so that none is
    clipped ("…")."""
    shot = gui["steps_by_name"]["shot:before"]["result_text"]
    assert shot["drawn"] is None and shot["computed"] is None, "no result before planning"
    for step in ("planned", "baked"):
        info = gui["steps_by_name"][step]
        task = info["result"]["tasks"][0]
        assert task["success"], task["message"]
        panel = gui["steps_by_name"][f"shot:{step}"]["panels"].get("REACH_PT_result")
        assert panel and panel["where"] == ["VIEW_3D", "UI"], f"no Result panel drawn when {step}"
        text = gui["steps_by_name"][f"shot:{step}"]["result_text"]
        assert text["drawn"], f"{step}: the sidebar drew no Result panel"
        drawn = " ".join(given for given, _shown in text["drawn"]).split()
        assert drawn == " ".join(text["computed"]).split(), \
            f"{step}: the panel drew {text['drawn']}, the operator made {text['computed']}"
        for given, shown in text["drawn"]:
            assert shown == given, f"{step}: {given!r} drawn clipped as {shown!r}"
        lines = text["computed"]
        st = task["stats"]
        assert lines[0] == f"{task['target']}: reached"
        assert f"frames {task['frame_start']}–{task['frame_end']}" in lines[1]
        assert f"nodes {st['nodes_searched']} searched, {st['nodes_in_solution']} in path" in lines[2]
    ui = regions(gui, "before")["UI"]
    before = text_rows(crop(gui["shots"]["before"], ui))
    for shot in ("planned", "baked"):
        after = text_rows(crop(gui["shots"][shot], ui))
        assert after >= before + 4 * 6, f"{shot}: {after} text rows in the sidebar, {before} before"


def test_bake_keys_the_arm(gui):
    baked = gui["steps_by_name"]["baked"]
    task = baked["result"]["tasks"][0]
    assert baked["result"]["baked"] and baked["action"] == baked["result"]["action"]
    assert baked["keys"] >= 3 * len(task["bones_keyed"]) and len(task["bones_keyed"]) >= 3
    assert gui["steps_by_name"]["planned"]["keys"] == 0, "Plan previews without keys"


def test_progress_is_shown_while_running(gui):
    """While Plan and Bake run, their progress rises, and the panel is redrawn to show it:
    the long bake of the Esc test (the session's first run, the redraws' cost not yet
    measured) has its progress drawn within its first 1.5 s."""
    for op in ("plan", "bake"):
        done = gui["steps_by_name"][f"{op} done"]
        progress = done["progress"]
        assert progress and progress == sorted(progress), (op, progress)
        assert 0.0 < progress[0] and progress[-1] <= 1.0
        assert done["drawn_progress"] == sorted(done["drawn_progress"]), op
        assert done["status"] == "" and done["has_result"]
    long_bake = gui["steps_by_name"]["escape"]["before_escape"]
    assert [p for p in long_bake["drawn_progress"] if 0.0 < p < 1.0], long_bake


def test_progress_redraws_are_throttled(gui):
    """While Plan or Bake runs, only the sidebar is redrawn, and its progress at most about
    10 times a second (each redraw asked for writes the progress the panel shows, so the
    distinct values it drew count the redraws asked for; the one shown when it started is
    the +1). The 3D viewport is not redrawn until the plan is done."""
    runs = {op: gui["steps_by_name"][f"{op} done"] for op in ("plan", "bake")}
    runs["long bake"] = {"running": gui["steps_by_name"]["escape"]["before_escape"]}
    runs["long bake"]["drawn_progress"] = runs["long bake"]["running"]["drawn_progress"]
    for op, done in runs.items():
        running = done["running"]
        shown = len(set(done["drawn_progress"]))
        assert shown <= 10 * running["seconds"] + 1, (op, shown, running)
        assert running["viewport_draws"] == 0, (op, running)


def test_result_shows_planner_and_wall_time(gui):
    """The Result's time line: the pipeline's own time and the wall time from Plan's (or
    Bake's) invoke to its end, as recorded in the result; the wall time holds the
    planner's."""
    for step in ("planned", "baked"):
        result = gui["steps_by_name"][step]["result"]
        times = result["time"]
        assert 0.0 < times["planner_s"] <= times["wall_s"], times
        line = (f"Time: planner {times['planner_s'] * 1000:.0f} ms, "
                f"wall {times['wall_s'] * 1000:.0f} ms")
        text = gui["steps_by_name"][f"shot:{step}"]["result_text"]
        assert line in text["computed"], text["computed"]
        drawn = " ".join(" ".join(given for given, _shown in text["drawn"]).split())
        assert " ".join(line.split()) in drawn, text["drawn"]


def test_trajectory_is_drawn_red_in_the_viewport(gui):
    """Plan draws the wrist's path as a red curve: strongly red pixels appear in the
    viewport, and they lie along the plan's points projected into the view."""
    reg = regions(gui, "planned")
    view, ui = reg["WINDOW"], reg["UI"]
    visible = np.ones((view[3], view[2]), bool)
    visible[:, ui[0] - view[0]:] = False                  # the sidebar overlaps the view
    before = strongly_red(crop(gui["shots"]["before"], view)) & visible
    after = strongly_red(crop(gui["shots"]["planned"], view)) & visible
    new = after & ~before
    assert new.sum() >= 300, f"{new.sum()} new red pixels (before {before.sum()})"
    rows, cols = np.nonzero(new)
    pixels = np.column_stack([cols, view[3] - 1 - rows]).astype(float)   # region coordinates
    path = np.array(gui["steps_by_name"]["planned"]["trajectory_px"])
    assert len(path) >= 10
    near = polyline_distance(pixels, path) <= 6.0
    assert near.mean() >= 0.9, f"only {near.mean():.0%} of the new red pixels lie on the path"
    # ... and they follow the whole path, not one end of it.
    inside = path[(path[:, 0] >= 0) & (path[:, 0] < ui[0] - view[0])
                  & (path[:, 1] >= 0) & (path[:, 1] < view[3])]
    covered = polyline_distance(inside, pixels[near]) <= 6.0
    assert covered.mean() >= 0.5, f"red drawn along {covered.mean():.0%} of the path"


def test_trajectory_tube_is_thin_beside_the_small_arm(gui):
    """On the 0.2 m character (armature scale 0.0012) the red tube is drawn a fiftieth of
    an arm length across, not as thick as the forearm: its new red pixels, over the length
    of the path they lie along, are a band no wider than a few pixels more than the tube's
    diameter drawn there, and that diameter is a fiftieth of the arm drawn there."""
    planned = gui["steps_by_name"]["planned"]
    scale = planned["scale"]
    assert scale["bevel"] == pytest.approx(0.01 * scale["arm_length"], rel=1e-3), scale
    assert scale["tube_px"] <= 0.03 * scale["arm_px"], scale
    reg = regions(gui, "planned")
    view, ui = reg["WINDOW"], reg["UI"]
    visible = np.ones((view[3], view[2]), bool)
    visible[:, ui[0] - view[0]:] = False
    new = strongly_red(crop(gui["shots"]["planned"], view)) & visible & \
        ~strongly_red(crop(gui["shots"]["before"], view))
    path = np.array(planned["trajectory_px"])
    inside = (path[:, 0] >= 0) & (path[:, 0] < ui[0] - view[0]) & (path[:, 1] >= 0) & \
        (path[:, 1] < view[3])
    shown = path[inside]
    length_px = np.linalg.norm(np.diff(shown, axis=0), axis=1).sum()
    width_px = new.sum() / max(length_px, 1.0)
    assert width_px <= scale["tube_px"] + 3.0, (width_px, scale, length_px)
    assert width_px <= 0.05 * scale["arm_px"], (width_px, scale)


#: ``uiBut.type`` of buttons showing the user's own data, not a label: a text field
#: (``UI_BTYPE_TEXT``) and a search field (``UI_BTYPE_SEARCH_MENU``: an object's, a
#: collection's or a bone's name). Their text is clipped as any name too long for a field is.
USER_DATA = {3 << 9: "text field", 41 << 9: "search field"}
#: The sidebar's width at UI scale 1 (``UI_SIDEBAR_PANEL_WIDTH`` in Blender 3.4).
SIDEBAR_WIDTH = 220


def test_every_label_fits_the_default_sidebar(gui):
    """No label drawn in any Reach panel is clipped at the sidebar's default width. The
    session (``every_label``) opened each Reach panel in turn — main panel, sub-panels and
    their sub-panels, with the inputs set so that optional rows show — scrolled it into
    view, and read its buttons as Blender drew them: where a text does not fit, Blender
    draws it shortened with "…". Every button counts (labels, checkboxes, buttons, menus,
    number fields) except fields holding the user's own names."""
    from reach_addon.core.settings import fields

    labels = gui["steps_by_name"]["labels"]
    assert abs(labels["width"] - SIDEBAR_WIDTH * labels["ui_scale"]) <= 1, \
        f"sidebar {labels['width']} px wide, not the default at UI scale {labels['ui_scale']}"
    panels = labels["panels"]
    assert {"REACH_PT_main", "REACH_PT_result", "REACH_PT_settings"} <= panels.keys()
    clipped = []
    for name, seen in panels.items():
        assert seen["in_view"] and seen["buttons"], f"{name} was not drawn in view: {seen}"
        clipped += [f"{name}: {b['given']!r} drawn as {b['drawn']!r}" for b in seen["buttons"]
                    if b["type"] not in USER_DATA and "…" in b["drawn"] and "…" not in b["given"]]
    assert not clipped, "clipped in the sidebar:\n" + "\n".join(clipped)
    # The reading covered the panels' rows: every planner setting's label was among them.
    for f in fields():
        panel = panels.get(f"REACH_PT_settings_{f.metadata['group']}")
        if panel is not None:
            assert f.metadata["label"] in [b["given"] for b in panel["buttons"]], f.name
    given = [b["given"] for b in panels["REACH_PT_main"]["buttons"]]
    for label in ("Armature", "Arm", "Task", "Targets", "Target", "Obstacles", "Collection",
                  "Plan", "Bake"):
        assert label in given, (label, given)
