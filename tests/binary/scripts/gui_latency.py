"""How long Plan takes as a user waits for it, in Blender's interface and headless, on the
same scene and settings:

    xvfb-run -s "-screen 0 1600x1000x24" blender SCENE.blend --python gui_latency.py -- \
        OUT_DIR ARMATURE TARGET PLANS [SETTINGS_JSON]
    blender --background SCENE.blend --python gui_latency.py -- OUT_DIR ARMATURE TARGET PLANS ...

``SETTINGS_JSON``: planner settings set in the panel before planning (``{"step": 0.04}``).
One Plan first (not counted: it imports and warms what a session's first Plan does), then
``PLANS`` Plans, each timed from the moment it is invoked:

- in the interface (the sidebar open on the Reach tab, as when its Plan button is
  pressed): ``reach.plan('INVOKE_DEFAULT')`` from a timer in the live event loop, then
  waited for by a timer that looks every 2 ms whether it is still running (``done_s``),
  and until the Result panel has been drawn with the new result (``shown_s``: what the
  user waits for). The viewport's and the Reach panel's draws are counted (draw
  handlers; the panel's while Plan ran, its progress, apart), and the progress values
  the panel could show;
- headless (``--background``): ``reach.plan()``, which runs the pipeline in one go.

With each, the plan's own figures from the Result (the search's time, the pipeline's time
and the wall time the operator recorded). It all goes to ``OUT_DIR/session.json``;
then Blender quits.
"""

import json
import sys
import time
from pathlib import Path

import bpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
import timer_session  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
OUT, ARMATURE, TARGET, PLANS = Path(ARGS[0]), ARGS[1], ARGS[2], int(ARGS[3])
SETTINGS = json.loads(ARGS[4]) if len(ARGS) > 4 else {}
seen = {"blender": bpy.app.version_string, "background": bpy.app.background,
        "settings": SETTINGS, "plans": [], "steps": []}
counts = {"view": 0, "panel": 0, "result": 0, "panel_running": 0}


def set_up():
    props = bpy.context.scene.reach
    props.armature = bpy.data.objects[ARMATURE]
    props.target = bpy.data.objects[TARGET]
    props.arm = "RIGHT"
    for key, value in SETTINGS.items():
        setattr(props.settings, key, value)
    return props


def figures(props) -> dict:
    """The plan's own figures, from the Result."""
    res = json.loads(props.last_result)
    task = res["tasks"][0]
    st = task["stats"]
    return {"success": task["success"], "nodes_searched": st["nodes_searched"],
            "nodes_in_solution": st["nodes_in_solution"], "search_time_s": st["search_time_s"],
            "planning_time_s": st.get("planning_time_s"),
            "time": res.get("time")}


def headless():
    props = set_up()
    for k in range(PLANS + 1):
        props.last_result = ""
        t0 = time.perf_counter()
        result = bpy.ops.reach.plan()
        wall = time.perf_counter() - t0
        assert result == {"FINISHED"}, result
        if k:
            seen["plans"].append({"done_s": wall, "shown_s": wall, **figures(props)})
    seen["ok"] = True


def interface():
    import gui_window

    def count(key):
        def hook(*_args):
            counts[key] += 1
            if key == "panel" and bpy.context.scene.reach.running:
                counts["panel_running"] += 1      # drawn while Plan ran: its progress
        return hook

    bpy.types.SpaceView3D.draw_handler_add(count("view"), (), "WINDOW", "POST_PIXEL")
    bpy.types.REACH_PT_main.append(count("panel"))
    bpy.types.REACH_PT_result.append(count("result"))
    props = set_up()
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    _win, area, regions = gui_window.ui()
    area.spaces.active.show_region_ui = True
    yield 1.0
    turns = yield from gui_window.reach_tab(lambda: counts["panel"])
    seen["steps"].append({"step": "reach tab", "turns": turns, "panel_draws": counts["panel"]})
    gui_window.xdotool("mousemove", *gui_window.to_screen(regions["WINDOW"], 0.3, 0.3))
    yield 1.0
    for k in range(PLANS + 1):
        props.last_result = ""
        yield 0.5
        before = dict(counts)
        progress = []
        t0 = time.perf_counter()
        with gui_window.override():
            result = bpy.ops.reach.plan("INVOKE_DEFAULT")
        while props.running:
            progress.append(round(props.progress, 4))
            yield 0.002
            if time.perf_counter() - t0 > 300:
                raise RuntimeError("Plan still running after 300 s")
        done = time.perf_counter() - t0
        shown_at = counts["result"]
        while counts["result"] == shown_at and time.perf_counter() - t0 < done + 5:
            yield 0.002
        shown = time.perf_counter() - t0
        if k:
            seen["plans"].append({
                "result": sorted(result), "done_s": done, "shown_s": shown,
                "view_draws": counts["view"] - before["view"],
                "panel_draws": counts["panel"] - before["panel"],
                "panel_draws_running": counts["panel_running"] - before["panel_running"],
                "progress": progress, **figures(props)})


if bpy.app.background:
    OUT.mkdir(parents=True, exist_ok=True)
    try:
        headless()
    except Exception:
        import traceback

        seen["error"] = traceback.format_exc()
    (OUT / "session.json").write_text(json.dumps(seen, indent=1))
else:
    timer_session.drive(interface(), seen, OUT, 900.0)
