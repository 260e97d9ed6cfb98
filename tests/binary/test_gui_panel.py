"""Reach in Blender 3.4.1's interface (under Xvfb): what a user sees in the sidebar and the
viewport while planning and baking. One interface session (the ``gui`` fixture) records the
live UI and takes screenshots; these tests check both."""

import numpy as np
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
    result, in order, and nothing else; a line the region could not fit is drawn clipped
    ("…"), never another text."""
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
        lines = [given for given, _shown in text["drawn"]]
        assert lines == text["computed"], \
            f"{step}: the panel drew {lines}, the operator made {text['computed']}"
        for given, shown in text["drawn"]:
            assert shown == given or ("…" in shown and all(
                part in given for part in shown.split("…"))), (given, shown)
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
    """While Plan and Bake run, their progress rises and the panel is redrawn to show it."""
    for op in ("plan", "bake"):
        done = gui["steps_by_name"][f"{op} done"]
        progress = done["progress"]
        assert len(set(progress)) >= 2 and progress == sorted(progress), (op, progress)
        assert 0.0 <= progress[0] and progress[-1] <= 1.0
        assert done["main_draws_while_running"] >= 2, op
        assert done["status"] == "" and done["has_result"]


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
